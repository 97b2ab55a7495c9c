//! The communication graph of LAW §2: neighbour lists and pinning, checked against
//! Assumption 2 (the leader is the root of a spanning tree).

use rand_xoshiro::{
    rand_core::{Rng as _, SeedableRng as _},
    SplitMix64,
};
use serde::{Deserialize, Serialize};

use crate::generate::{self, Family, GraphRecipe};
use consensus_plot::error::{Error, Result};

/// `[graph]`: who hears whom (LAW §2), as neighbour lists or an adjacency matrix.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GraphSpec {
    /// Agent `i` (1-based) hears these agents.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neighbours: Option<Vec<Vec<i64>>>,
    /// Alternative: `a_{i,k}` as a square 0/1 matrix.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adjacency: Option<Vec<Vec<i64>>>,
    /// Agents that hear the leader (`r_i = 1`).
    pub pinned: Vec<i64>,
    /// Instead of lists: a generated graph, `"line"`, `"ring"`, `"star"`, `"knn"`, `"random"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
    /// Generated graphs: number of agents.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub agents: Option<i64>,
    /// `knn`: neighbours per agent (default 2).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k: Option<i64>,
    /// `random`: links beyond the spanning tree, in total (default: one per agent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extra_edges: Option<i64>,
    /// `random`: seed of the draw (default 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

impl Default for GraphSpec {
    fn default() -> Self {
        Self {
            neighbours: None,
            adjacency: None,
            pinned: vec![1],
            generator: None,
            agents: None,
            k: None,
            extra_edges: None,
            seed: None,
        }
    }
}

impl GraphSpec {
    /// LAW §8's graph (agent 2 hears 1, agent 3 hears 1, agent 4 hears 1 and 3) when the
    /// scenario gives neither neighbour lists nor a matrix.
    pub fn or_example(mut self) -> Self {
        if self.neighbours.is_none() && self.adjacency.is_none() && self.generator.is_none() {
            self.neighbours = Some(vec![vec![], vec![1], vec![1], vec![1, 3]]);
        }
        self
    }
}

/// Largest in-degree supported: the nodes' neighbour capacity `K`.
pub use agent_node::wire::MAX_NEIGHBOURS;

/// Most agents of a generated graph.
pub const MAX_GENERATED: i64 = 1_000_000;

/// `graph.pinned` (1-based) as one flag per agent of `n`.
fn pinned_flags(list: &[i64], n: usize) -> Result<Vec<bool>> {
    let mut pinned = vec![false; n];
    for &p in list {
        if p < 1 || p as usize > n {
            return Err(Error::invalid(
                "graph.pinned",
                format!("agent {p} out of range 1..={n} (agents are 1-based)"),
            ));
        }
        pinned[(p - 1) as usize] = true;
    }
    Ok(pinned)
}

/// A validated directed graph: agent `i` hears `neighbours(i)` (0-based), `pinned(i)` hears
/// the leader.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Graph {
    offsets: Vec<usize>,
    flat: Vec<usize>,
    pinned: Vec<bool>,
}

impl Graph {
    /// Checks self links, range, duplicates, in-degree and Assumption 2.
    pub fn new(neighbours: Vec<Vec<usize>>, pinned: Vec<bool>) -> Result<Self> {
        let n = neighbours.len();
        if n == 0 {
            return Err(Error::invalid("graph", "no agents"));
        }
        if pinned.len() != n {
            return Err(Error::invalid(
                "graph.pinned",
                "one flag per agent expected",
            ));
        }
        let mut offsets = Vec::with_capacity(n + 1);
        let mut flat = Vec::new();
        offsets.push(0);
        for (i, row) in neighbours.iter().enumerate() {
            if row.len() > MAX_NEIGHBOURS {
                return Err(Error::invalid(
                    format!("graph.neighbours[{}]", i + 1),
                    format!(
                        "agent {} hears {} agents, more than the supported {MAX_NEIGHBOURS}",
                        i + 1,
                        row.len()
                    ),
                ));
            }
            for (s, &k) in row.iter().enumerate() {
                if k >= n {
                    return Err(Error::invalid(
                        format!("graph.neighbours[{}]", i + 1),
                        format!(
                            "agent {} hears agent {}, which does not exist",
                            i + 1,
                            k + 1
                        ),
                    ));
                }
                if k == i {
                    return Err(Error::invalid(
                        format!("graph.neighbours[{}]", i + 1),
                        format!("agent {} hears itself (self link)", i + 1),
                    ));
                }
                if row[..s].contains(&k) {
                    return Err(Error::invalid(
                        format!("graph.neighbours[{}]", i + 1),
                        format!("agent {} lists agent {} twice", i + 1, k + 1),
                    ));
                }
            }
            flat.extend_from_slice(row);
            offsets.push(flat.len());
        }
        let g = Self {
            offsets,
            flat,
            pinned,
        };
        let unreached = g.unreached();
        if !unreached.is_empty() {
            let list: Vec<String> = unreached.iter().map(|i| (i + 1).to_string()).collect();
            return Err(Error::invalid(
                "graph",
                format!(
                    "agent(s) {} not reached from the leader: the leader must be the root of a \
                     spanning tree (Assumption 2); pin an agent or add links",
                    list.join(", ")
                ),
            ));
        }
        Ok(g)
    }

    /// From the scenario's `[graph]` (1-based agent numbers, lists or matrix).
    pub fn from_spec(spec: &GraphSpec) -> Result<Self> {
        if spec.generator.is_some() {
            return Self::generated(spec);
        }
        for (key, given) in [
            ("agents", spec.agents.is_some()),
            ("k", spec.k.is_some()),
            ("extra_edges", spec.extra_edges.is_some()),
            ("seed", spec.seed.is_some()),
        ] {
            if given {
                return Err(Error::invalid(
                    format!("graph.{key}"),
                    "only with graph.generator (a generated graph)",
                ));
            }
        }
        let lists: Vec<Vec<usize>> = match (&spec.neighbours, &spec.adjacency) {
            (Some(_), Some(_)) => {
                return Err(Error::invalid(
                    "graph.adjacency",
                    "give either graph.neighbours or graph.adjacency, not both",
                ))
            }
            (None, None) => {
                return Err(Error::invalid(
                    "graph.neighbours",
                    "missing (or give graph.adjacency)",
                ))
            }
            (Some(rows), None) => {
                let n = rows.len() as i64;
                let mut out = Vec::with_capacity(rows.len());
                for (i, row) in rows.iter().enumerate() {
                    let mut r = Vec::with_capacity(row.len());
                    for &k in row {
                        if k < 1 || k > n {
                            return Err(Error::invalid(
                                format!("graph.neighbours[{}]", i + 1),
                                format!(
                                    "agent {} hears agent {k}, out of range 1..={n} \
                                     (agents are 1-based)",
                                    i + 1
                                ),
                            ));
                        }
                        r.push((k - 1) as usize);
                    }
                    out.push(r);
                }
                out
            }
            (None, Some(mat)) => {
                let n = mat.len();
                let mut out = Vec::with_capacity(n);
                for (i, row) in mat.iter().enumerate() {
                    if row.len() != n {
                        return Err(Error::invalid(
                            format!("graph.adjacency[{}]", i + 1),
                            format!(
                                "row has {} entries, the matrix must be square ({n} x {n})",
                                row.len()
                            ),
                        ));
                    }
                    let mut r = Vec::new();
                    for (k, &a) in row.iter().enumerate() {
                        match a {
                            0 => {}
                            1 => r.push(k),
                            _ => {
                                return Err(Error::invalid(
                                    format!("graph.adjacency[{}][{}]", i + 1, k + 1),
                                    format!("entries must be 0 or 1 (got {a})"),
                                ))
                            }
                        }
                    }
                    out.push(r);
                }
                out
            }
        };
        let n = lists.len();
        if n == 0 {
            return Err(Error::invalid("graph.neighbours", "no agents"));
        }
        let pinned = pinned_flags(&spec.pinned, n)?;
        Self::new(lists, pinned)
    }

    /// A `[graph]` with `generator`: the family's lists for `agents` agents, then the checks of
    /// [`Graph::new`].
    fn generated(spec: &GraphSpec) -> Result<Self> {
        let family = Family::parse(spec.generator.as_deref().unwrap_or_default())?;
        if spec.neighbours.is_some() || spec.adjacency.is_some() {
            return Err(Error::invalid(
                "graph.generator",
                "give either graph.generator or written lists (graph.neighbours, \
                 graph.adjacency), not both",
            ));
        }
        let Some(agents) = spec.agents else {
            return Err(Error::invalid(
                "graph.agents",
                "required with graph.generator (the number of agents)",
            ));
        };
        if !(1..=MAX_GENERATED).contains(&agents) {
            return Err(Error::invalid(
                "graph.agents",
                format!("must lie in 1..={MAX_GENERATED} (got {agents})"),
            ));
        }
        let only = |key: &str, given: bool, family_name: &str, wanted: Family| -> Result<()> {
            if given && family != wanted {
                return Err(Error::invalid(
                    format!("graph.{key}"),
                    format!("only for generator = \"{family_name}\""),
                ));
            }
            Ok(())
        };
        only("k", spec.k.is_some(), "knn", Family::Knn)?;
        only(
            "extra_edges",
            spec.extra_edges.is_some(),
            "random",
            Family::Random,
        )?;
        only("seed", spec.seed.is_some(), "random", Family::Random)?;
        let n = agents as usize;
        let count = |key: &str, v: Option<i64>, default: usize| -> Result<usize> {
            match v {
                None => Ok(default),
                Some(v) if v >= 0 => Ok(v as usize),
                Some(v) => Err(Error::invalid(
                    format!("graph.{key}"),
                    format!("must be >= 0 (got {v})"),
                )),
            }
        };
        let pinned = pinned_flags(&spec.pinned, n)?;
        let lists = generate::neighbours(&GraphRecipe {
            family,
            agents: n,
            k: count("k", spec.k, 2)?,
            extra_edges: count("extra_edges", spec.extra_edges, n)?,
            seed: spec.seed.unwrap_or(1),
            pinned: (0..n).filter(|&i| pinned[i]).collect(),
            capacity: MAX_NEIGHBOURS,
        })?;
        Self::new(lists, pinned)
    }

    /// Agents no path from the leader reaches.
    fn unreached(&self) -> Vec<usize> {
        let n = self.len();
        let mut hearers: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            for &k in self.neighbours(i) {
                hearers[k].push(i);
            }
        }
        let mut seen = self.pinned.clone();
        let mut stack: Vec<usize> = (0..n).filter(|&i| seen[i]).collect();
        while let Some(k) = stack.pop() {
            for &i in &hearers[k] {
                if !seen[i] {
                    seen[i] = true;
                    stack.push(i);
                }
            }
        }
        (0..n).filter(|&i| !seen[i]).collect()
    }

    /// Per agent, the fewest links from the leader to it (a pinned agent: 1); `None` for an
    /// agent no path reaches (not in a graph that [`Graph::new`] accepted).
    pub fn hops(&self) -> Vec<Option<usize>> {
        let n = self.len();
        let mut hearers: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            for &k in self.neighbours(i) {
                hearers[k].push(i);
            }
        }
        let mut hops: Vec<Option<usize>> = self.pinned.iter().map(|&p| p.then_some(1)).collect();
        let mut queue: std::collections::VecDeque<usize> =
            (0..n).filter(|&i| self.pinned[i]).collect();
        while let Some(k) = queue.pop_front() {
            let next = hops[k].map(|h| h + 1);
            for &i in &hearers[k] {
                if hops[i].is_none() {
                    hops[i] = next;
                    queue.push_back(i);
                }
            }
        }
        hops
    }

    /// Number of agents.
    pub fn len(&self) -> usize {
        self.pinned.len()
    }

    /// Always false (a graph has at least one agent).
    pub fn is_empty(&self) -> bool {
        self.pinned.is_empty()
    }

    /// Agents that agent `i` hears, in configured order.
    pub fn neighbours(&self, i: usize) -> &[usize] {
        &self.flat[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Offset of agent `i`'s first neighbour in a flat per-link array.
    pub fn offset(&self, i: usize) -> usize {
        self.offsets[i]
    }

    /// Total number of links.
    pub fn links(&self) -> usize {
        self.flat.len()
    }

    /// `r_i = 1`.
    pub fn pinned(&self, i: usize) -> bool {
        self.pinned[i]
    }

    /// A seeded random graph of `n` agents: agent 1 pinned, every other agent hears one random
    /// earlier agent (a spanning tree from the leader) and up to `extra` more random agents.
    pub fn random_connected(n: usize, extra: usize, seed: u64) -> Result<Self> {
        let mut rng = SplitMix64::seed_from_u64(seed);
        let mut lists = vec![Vec::new(); n];
        for (i, row) in lists.iter_mut().enumerate().skip(1) {
            row.push(below(&mut rng, i));
            for _ in 0..extra {
                let k = below(&mut rng, n);
                if k != i && !row.contains(&k) && row.len() < MAX_NEIGHBOURS {
                    row.push(k);
                }
            }
        }
        let mut pinned = vec![false; n];
        if n > 0 {
            pinned[0] = true;
        }
        Self::new(lists, pinned)
    }
}

/// `0..n` from the seeded test graphs' stream (`n ≥ 1`; the remainder, as the graphs were drawn).
fn below(rng: &mut SplitMix64, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn example_graph_is_valid_and_unreached_agents_are_named() {
        let g = Graph::new(
            vec![vec![], vec![0], vec![0], vec![0, 2]],
            vec![true, false, false, false],
        );
        assert!(g.is_ok());
        let err = match Graph::new(
            vec![vec![], vec![0], vec![3], vec![2]],
            vec![true, false, false, false],
        ) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("agents 3 and 4 are not reached from the leader"),
        };
        assert!(err.contains("3, 4"), "{err}");
    }

    #[test]
    fn hops_count_the_links_from_the_leader() {
        // LAW §8's graph: 1 pinned, 2 and 3 hear 1, 4 hears 1 and 3.
        let g = Graph::new(
            vec![vec![], vec![0], vec![0], vec![0, 2]],
            vec![true, false, false, false],
        )
        .expect("graph");
        assert_eq!(g.hops(), [Some(1), Some(2), Some(2), Some(2)]);
        let line =
            Graph::new(vec![vec![], vec![0], vec![1]], vec![true, false, false]).expect("line");
        assert_eq!(line.hops(), [Some(1), Some(2), Some(3)]);
    }

    #[test]
    fn random_graph_is_connected() {
        let g = Graph::random_connected(1000, 2, 7).expect("valid");
        assert_eq!(g.len(), 1000);
    }
}
