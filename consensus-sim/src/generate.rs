//! Generated groups (docs/SCENARIO.md §2, `graph.generator`, `plant.x0_min`): communication
//! graphs of LAW §2 built from a few numbers, and initial states drawn in a box, so a scenario
//! of 1,000 agents is a short file. Random choices come from a ChaCha8 stream of the scenario's
//! seed: the same seed gives the same group on every machine.

use rand_chacha::{
    rand_core::{Rng, SeedableRng},
    ChaCha8Rng,
};

use consensus_plot::error::{Error, Result};

/// The graph families of `graph.generator`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Agent `i` hears agent `i − 1`.
    Line,
    /// Agent `i` hears `i − 1` and `i + 1`, around a circle.
    Ring,
    /// Every agent hears agent 1, the hub.
    Star,
    /// Agents evenly spaced on a circle; each hears its `k` nearest (`⌈k/2⌉` behind, `⌊k/2⌋`
    /// ahead).
    Knn,
    /// A random spanning tree rooted at the pinned agents plus `extra_edges` random links.
    Random,
}

impl Family {
    /// The key word of `graph.generator`.
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "line" => Self::Line,
            "ring" => Self::Ring,
            "star" => Self::Star,
            "knn" => Self::Knn,
            "random" => Self::Random,
            other => {
                return Err(Error::invalid(
                    "graph.generator",
                    format!(
                        "unknown generator \"{other}\" (expected \"line\", \"ring\", \"star\", \
                         \"knn\" or \"random\")"
                    ),
                ))
            }
        })
    }
}

/// Everything a generator needs (0-based pinned agents).
#[derive(Debug, Clone, PartialEq)]
pub struct GraphRecipe {
    /// Which family.
    pub family: Family,
    /// Number of agents.
    pub agents: usize,
    /// `knn`: neighbours per agent.
    pub k: usize,
    /// `random`: links beyond the spanning tree, in total.
    pub extra_edges: usize,
    /// `random`: seed of the draw.
    pub seed: u64,
    /// Agents that hear the leader (0-based, at least one).
    pub pinned: Vec<usize>,
    /// Largest in-degree: the controllers' neighbour capacity `K` (`graph::MAX_NEIGHBOURS`).
    pub capacity: usize,
}

/// The neighbour lists (0-based, agent `i` hears `lists[i]`) of `recipe`; every in-degree is
/// at most `recipe.capacity`, and the random family reaches every agent from a pinned one.
pub fn neighbours(recipe: &GraphRecipe) -> Result<Vec<Vec<usize>>> {
    let n = recipe.agents;
    if n == 0 {
        return Err(Error::invalid("graph.agents", "must be >= 1"));
    }
    Ok(match recipe.family {
        Family::Line => (0..n)
            .map(|i| (i > 0).then(|| i - 1).into_iter().collect())
            .collect(),
        Family::Ring => (0..n)
            .map(|i| {
                let mut row = vec![(i + n - 1) % n, (i + 1) % n];
                row.dedup();
                row.retain(|&k| k != i);
                row
            })
            .collect(),
        Family::Star => (0..n)
            .map(|i| if i == 0 { vec![] } else { vec![0] })
            .collect(),
        Family::Knn => knn(n, recipe.k, recipe.capacity)?,
        Family::Random => random(recipe)?,
    })
}

fn knn(n: usize, k: usize, capacity: usize) -> Result<Vec<Vec<usize>>> {
    if k == 0 || k > capacity || k >= n {
        return Err(Error::invalid(
            "graph.k",
            format!(
                "must lie in 1..={} (at most the controllers' neighbour capacity \
                 {capacity}, and fewer than the {n} agents) (got {k})",
                capacity.min(n.saturating_sub(1))
            ),
        ));
    }
    let (behind, ahead) = (k.div_ceil(2), k / 2);
    Ok((0..n)
        .map(|i| {
            let mut row: Vec<usize> = (1..=behind).map(|d| (i + n - d) % n).collect();
            row.extend((1..=ahead).map(|d| (i + d) % n));
            row
        })
        .collect())
}

/// A uniform draw in `0..n` (`n ≥ 1`; multiply-shift, the bias is below 2⁻³²).
fn below(rng: &mut ChaCha8Rng, n: usize) -> usize {
    ((u128::from(rng.next_u64()) * n as u128) >> 64) as usize
}

fn random(recipe: &GraphRecipe) -> Result<Vec<Vec<usize>>> {
    let n = recipe.agents;
    if recipe.pinned.is_empty() {
        return Err(Error::invalid(
            "graph.pinned",
            "the random generator roots its spanning tree at the pinned agents: pin at least one",
        ));
    }
    let most = recipe.capacity.min(n - 1);
    let mut roots = recipe.pinned.clone();
    roots.sort_unstable();
    roots.dedup();
    let capacity = n * most;
    let tree = n - roots.len();
    if tree + recipe.extra_edges > capacity {
        return Err(Error::invalid(
            "graph.extra_edges",
            format!(
                "{} links beyond the spanning tree do not fit: {n} agents hear at most {most} \
                 agents each (neighbour capacity {}), {capacity} links in all, {tree} of them in \
                 the tree",
                recipe.extra_edges, recipe.capacity
            ),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(recipe.seed);
    // Pinned agents first, the others in a random order; each of those hears one agent placed
    // before it, so every agent is reached from a pinned one (Assumption 2).
    let mut rest: Vec<usize> = (0..n).filter(|i| roots.binary_search(i).is_err()).collect();
    for j in (1..rest.len()).rev() {
        rest.swap(j, below(&mut rng, j + 1));
    }
    let first = roots.len();
    let mut order = roots;
    order.extend(rest);
    let mut lists = vec![Vec::new(); n];
    for (pos, &i) in order.iter().enumerate().skip(first) {
        lists[i].push(order[below(&mut rng, pos)]);
    }
    let mut open: Vec<usize> = (0..n).filter(|&i| lists[i].len() < most).collect();
    let mut added = 0;
    while added < recipe.extra_edges {
        let slot = below(&mut rng, open.len());
        let i = open[slot];
        let k = below(&mut rng, n);
        if k == i || lists[i].contains(&k) {
            continue;
        }
        lists[i].push(k);
        added += 1;
        if lists[i].len() == most {
            open.swap_remove(slot);
        }
    }
    Ok(lists)
}

/// `agents` initial states, state `j` uniform in `[lower[j], upper[j]]`, from `seed`.
pub fn initial_states(
    agents: usize,
    lower: &[f64],
    upper: &[f64],
    seed: u64,
) -> Result<Vec<Vec<f64>>> {
    if lower.len() != upper.len() {
        return Err(Error::invalid(
            "plant.x0_max",
            format!(
                "{} entries but plant.x0_min has {} (one bound per state)",
                upper.len(),
                lower.len()
            ),
        ));
    }
    for (j, (&lo, &hi)) in lower.iter().zip(upper).enumerate() {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(Error::invalid(
                format!("plant.x0_max[{}]", j + 1),
                format!("need finite x0_min <= x0_max (got {lo} .. {hi})"),
            ));
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Ok((0..agents)
        .map(|_| {
            lower
                .iter()
                .zip(upper)
                .map(|(&lo, &hi)| {
                    let u = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
                    lo + u * (hi - lo)
                })
                .collect()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recipe(family: Family, agents: usize) -> GraphRecipe {
        GraphRecipe {
            family,
            agents,
            k: 4,
            extra_edges: if agents < 5 { 0 } else { agents },
            seed: 7,
            pinned: vec![0],
            capacity: 16,
        }
    }

    fn refusal(r: &GraphRecipe) -> String {
        match neighbours(r) {
            Ok(_) => panic!("{r:?} must be refused"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn every_family_has_the_expected_links() -> Result<()> {
        for family in [
            Family::Line,
            Family::Ring,
            Family::Star,
            Family::Knn,
            Family::Random,
        ] {
            for n in [1, 2, 5, 50, 1000] {
                if family == Family::Knn && n <= 4 {
                    assert!(refusal(&recipe(family, n)).contains("graph.k"));
                    continue;
                }
                let lists = neighbours(&recipe(family, n))?;
                let links: usize = lists.iter().map(Vec::len).sum();
                let want = match family {
                    Family::Line | Family::Star => n - 1,
                    Family::Ring => n * 2.min(n - 1),
                    Family::Knn => 4 * n,
                    Family::Random => (n - 1) + if n < 5 { 0 } else { n },
                };
                assert_eq!(links, want, "{family:?}, n = {n}");
                for (i, row) in lists.iter().enumerate() {
                    assert!(row.len() <= 16 && !row.contains(&i), "{family:?}: {row:?}");
                    let mut r = row.clone();
                    r.sort_unstable();
                    r.dedup();
                    assert_eq!(r.len(), row.len(), "{family:?}: duplicate in {row:?}");
                }
            }
        }
        Ok(())
    }

    #[test]
    fn random_graphs_are_reproducible() -> Result<()> {
        let mut r = recipe(Family::Random, 300);
        r.extra_edges = 3000;
        let a = neighbours(&r)?;
        assert_eq!(a, neighbours(&r)?, "same seed, same graph");
        r.seed = 8;
        assert_ne!(a, neighbours(&r)?, "another seed, another graph");
        assert!(a.iter().all(|row| row.len() <= 16));
        Ok(())
    }

    #[test]
    fn impossible_requests_name_their_key() {
        let mut r = recipe(Family::Random, 20);
        r.extra_edges = 20 * 16;
        assert!(refusal(&r).contains("graph.extra_edges"));
        let mut r = recipe(Family::Knn, 100);
        r.k = 17;
        let e = refusal(&r);
        assert!(e.contains("graph.k") && e.contains("16"), "{e}");
        assert!(refusal(&recipe(Family::Line, 0)).contains("graph.agents"));
        let mut r = recipe(Family::Random, 10);
        r.pinned.clear();
        assert!(refusal(&r).contains("graph.pinned"));
    }

    #[test]
    fn initial_states_stay_in_their_box_and_repeat_with_the_seed() -> Result<()> {
        let x = initial_states(1000, &[-0.5, 0.0], &[0.5, 2.0], 3)?;
        assert_eq!(x, initial_states(1000, &[-0.5, 0.0], &[0.5, 2.0], 3)?);
        assert!(x
            .iter()
            .all(|r| (-0.5..=0.5).contains(&r[0]) && (0.0..=2.0).contains(&r[1])));
        let spread = x.iter().map(|r| r[0]).fold(f64::NEG_INFINITY, f64::max)
            - x.iter().map(|r| r[0]).fold(f64::INFINITY, f64::min);
        assert!(spread > 0.9, "uniform over the box: spread {spread}");
        assert!(initial_states(2, &[1.0], &[0.0], 3).is_err());
        assert!(initial_states(2, &[0.0, 0.0], &[1.0], 3).is_err());
        Ok(())
    }
}
