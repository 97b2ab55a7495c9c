//! Fig. 8's comparison as a paired Monte Carlo (`fig:claims.paired`, `fig:claims.paired-ci`):
//! Example 2 under random initial states and fault instants, each draw run under every scheme
//! with the same values (common random numbers: a campaign's draw depends only on its seed and
//! its index, `docs/CAMPAIGNS.md`), then the paired differences with percentile-bootstrap 95 %
//! intervals (pairs resampled with replacement, a seeded stream).
//!
//! The schemes: the proposed scheme (`scenarios/example2.toml`), the prescribed-time baseline
//! at the gains the same-settling search of `fig:claims.further` picks, and the baseline at its
//! shipped gains (`scenarios/example2-baseline.toml`). Every run is judged at that search's band
//! with its dwell. The runs are `host-sim sweep`s of campaign files written here under
//! `target/docs/paired/`.
//!
//! The full study (`FULL`, minutes) is written with its date and command and skipped by
//! `--check`; CI re-runs and checks the first draws (`CI`, seconds), which are the same draws.

use std::{fmt::Write as _, fs, process::Command};

use rand_xoshiro::{
    rand_core::{Rng as _, SeedableRng as _},
    SplitMix64,
};

use super::super::{cell, diverged, fixed, grouped, rows, run as run_cmd, today, Row, Sources};
use super::{same_settling, DWELL, SAME_SETTLING_BAND};
use crate::task::{workspace_root, Result};

/// A study: how many draws, and the block it writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Study {
    /// Draws (pairs) of the study.
    pub draws: usize,
    /// The `fig:` block.
    pub block: &'static str,
    /// Directory tag under `target/docs/paired/`.
    tag: &'static str,
}

/// The full study: 1,000 draws, three schemes (about 3,000 runs of 10 s at `h = 0.2 ms`).
pub const FULL: Study = Study {
    draws: 1000,
    block: "claims.paired",
    tag: "full",
};

/// The subset CI re-runs: the first 20 draws of [`FULL`].
pub const CI: Study = Study {
    draws: 20,
    block: "claims.paired-ci",
    tag: "ci",
};

/// Seed of the campaign draws.
const DRAW_SEED: u64 = 2026;
/// Seed of the bootstrap's resampling stream.
const BOOT_SEED: u64 = 1;
/// Bootstrap resamples.
const RESAMPLES: usize = 2000;

/// The `[[sample]]`s of every study: each agent's `x(0)` around the paper's `[1, 2]`
/// (`x₁` uniform on `[0.5, 1.5]` rad, `x₂` on `[1, 3]` rad/s) and the first window of both
/// fault rules starting uniform on `[0, 4)` s (windows stay 2 s long every 4 s).
fn samples() -> String {
    let mut t = String::new();
    let mut one = |key: String, low: f64, high: f64| {
        let _ = write!(
            t,
            "\n[[sample]]\nkey = \"{key}\"\ndist = \"uniform\"\nlow = {low:?}\nhigh = {high:?}\n"
        );
    };
    for agent in 1..=4 {
        one(format!("plant.x0[{agent}][1]"), 0.5, 1.5);
        one(format!("plant.x0[{agent}][2]"), 1.0, 3.0);
    }
    for rule in 1..=2 {
        one(format!("faults.rule[{rule}].start"), 0.0, 4.0);
    }
    t
}

/// The words that describe the draws in the table.
const DRAWS_TEXT: &str = "each agent's x(0) uniform on [0.5, 1.5] rad × [1, 3] rad/s (the paper's [1, 2] in the middle), the first window of both fault rules starting uniform on [0, 4) s";

/// One scheme of the comparison.
struct Scheme {
    /// Words of the table.
    name: String,
    /// Directory tag.
    tag: &'static str,
    /// Shipped scenario.
    scenario: &'static str,
    /// `set` of its campaign besides the band.
    sets: Vec<String>,
}

/// What one run gives: settling time at the band, control energy, `γ̌`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    pub settling: Option<f64>,
    pub energy: f64,
    pub gamma: f64,
}

/// Each draw's outcome by run index; `None` for a diverged or failed run.
type Outcomes = Vec<Option<Outcome>>;

impl Sources {
    /// The study's runs of `scheme`: `results.csv` of `host-sim sweep` of a campaign written to
    /// `target/docs/paired/<study>-<scheme>.toml`.
    fn paired_runs(&mut self, study: Study, scheme: &Scheme, band: f64) -> Result<Outcomes> {
        let name = format!("{}-{}", study.tag, scheme.tag);
        let path = format!("target/docs/paired/{name}/results.csv");
        let scenario = workspace_root().join("scenarios").join(scheme.scenario);
        let mut sets = vec![
            format!("simulation.settle_band={band:?}"),
            format!("metrics.settle_dwell={DWELL:?}"),
        ];
        sets.extend(scheme.sets.iter().cloned());
        let text = format!(
            "scenario = {:?}\nset = {sets:?}\ndraws = {}\nseed = {DRAW_SEED}\n{}",
            scenario.display().to_string(),
            study.draws,
            samples()
        );
        let file = self.file(&path, |s, file| {
            let bin = s.host_sim()?;
            let dir = file.parent().unwrap_or(file);
            // A directory left by an older run would be resumed.
            let _ = fs::remove_dir_all(dir);
            let campaign = workspace_root().join(format!("target/docs/paired/{name}.toml"));
            fs::write(&campaign, &text).map_err(|e| format!("{}: {e}", campaign.display()))?;
            run_cmd(
                Command::new(bin)
                    .current_dir(workspace_root())
                    .arg("sweep")
                    .arg(&campaign)
                    .args(["--quiet", "--out"])
                    .arg(dir),
            )
            .map(|_| ())
        })?;
        let csv = fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))?;
        let rows = rows(&csv).map_err(|e| format!("{path}: {e}"))?;
        let mut out = vec![None; study.draws];
        for r in &rows {
            let k = cell(r, "run")?.map_or(usize::MAX, |k| k as usize);
            if let Some(slot) = out.get_mut(k) {
                *slot = outcome(r)?;
            }
        }
        Ok(out)
    }
}

/// A run's outcome, `None` when it diverged or failed.
fn outcome(r: &Row) -> Result<Option<Outcome>> {
    if diverged(r) || r.get("status").map(String::as_str) != Some("ok") {
        return Ok(None);
    }
    let (Some(energy), Some(gamma)) = (
        cell(r, "total_u_energy")?,
        cell(r, "max_error_after_predefined_time")?,
    ) else {
        return Ok(None);
    };
    Ok(Some(Outcome {
        settling: cell(r, "settling_time")?,
        energy,
        gamma,
    }))
}

// ---------------------------------------------------------------------------------------------
// Statistics

/// Uniform on `0..n` from the bootstrap's resampling stream (`n ≥ 1`; Lemire's multiply-shift,
/// bias below `n / 2⁶⁴`).
fn below(rng: &mut SplitMix64, n: usize) -> usize {
    ((u128::from(rng.next_u64()) * n as u128) >> 64) as usize
}

/// A mean and its percentile-bootstrap 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    pub mean: f64,
    pub low: f64,
    pub high: f64,
}

/// The mean of `x` and its percentile-bootstrap 95 % interval: `resamples` means of `x.len()`
/// values drawn from `x` with replacement (stream seeded with `seed`), the 2.5th and 97.5th
/// percentiles (nearest rank) of those means. `None` for an empty `x`.
pub fn bootstrap_mean(x: &[f64], resamples: usize, seed: u64) -> Option<Interval> {
    if x.is_empty() || resamples == 0 {
        return None;
    }
    let n = x.len();
    let mut rng = SplitMix64::seed_from_u64(seed);
    let mut means: Vec<f64> = (0..resamples)
        .map(|_| {
            (0..n)
                .filter_map(|_| x.get(below(&mut rng, n)))
                .sum::<f64>()
                / n as f64
        })
        .collect();
    means.sort_by(f64::total_cmp);
    let rank = |p: f64| {
        let k = ((p * resamples as f64).ceil() as usize).clamp(1, resamples);
        means.get(k - 1).copied().unwrap_or(f64::NAN)
    };
    Some(Interval {
        mean: x.iter().sum::<f64>() / n as f64,
        low: rank(0.025),
        high: rank(0.975),
    })
}

/// What an interval rule decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntervalVerdict {
    /// The interval lies on the side the check states.
    Holds,
    /// It lies on the other side.
    DoesNotHold,
    /// It contains the reference value.
    Undecided,
    /// No pair to compare.
    NoPairs,
}

impl IntervalVerdict {
    fn text(self) -> &'static str {
        match self {
            Self::Holds => "holds",
            Self::DoesNotHold => "does not hold",
            Self::Undecided => "undecided: the interval contains the reference",
            Self::NoPairs => "undecided: no pair to compare",
        }
    }
}

/// Holds if the interval lies strictly below `reference` (with `below`) or above it.
pub fn interval_side(i: Option<Interval>, reference: f64, below: bool) -> IntervalVerdict {
    let Some(i) = i else {
        return IntervalVerdict::NoPairs;
    };
    let (under, over) = (i.high < reference, i.low > reference);
    match (under, over) {
        (true, _) if below => IntervalVerdict::Holds,
        (_, true) if !below => IntervalVerdict::Holds,
        (false, false) => IntervalVerdict::Undecided,
        _ => IntervalVerdict::DoesNotHold,
    }
}

/// The three paired figures of one baseline against the proposed scheme.
struct Paired {
    /// Pairs in which both runs stayed bounded.
    bounded: usize,
    /// Runs that diverged: proposed, baseline.
    diverged: (usize, usize),
    /// Bounded pairs in which a scheme never settles: proposed, baseline.
    never: (usize, usize),
    /// Settling time, proposed − baseline, over the pairs in which both settle (s).
    settling: Option<Interval>,
    /// `ln(E_baseline / E_proposed)`.
    log_energy: Option<Interval>,
    /// `γ̌`, proposed − baseline.
    gamma: Option<Interval>,
}

fn paired(p: &Outcomes, b: &Outcomes) -> Paired {
    let both: Vec<(Outcome, Outcome)> = p.iter().zip(b).filter_map(|(p, b)| p.zip(*b)).collect();
    let count = |o: &Outcomes| o.iter().filter(|o| o.is_none()).count();
    let settling: Vec<f64> = both
        .iter()
        .filter_map(|(p, b)| p.settling.zip(b.settling).map(|(p, b)| p - b))
        .collect();
    let log_energy: Vec<f64> = both
        .iter()
        .map(|(p, b)| (b.energy / p.energy).ln())
        .collect();
    let gamma: Vec<f64> = both.iter().map(|(p, b)| p.gamma - b.gamma).collect();
    Paired {
        bounded: both.len(),
        diverged: (count(p), count(b)),
        never: (
            both.iter().filter(|(p, _)| p.settling.is_none()).count(),
            both.iter().filter(|(_, b)| b.settling.is_none()).count(),
        ),
        settling: bootstrap_mean(&settling, RESAMPLES, BOOT_SEED),
        log_energy: bootstrap_mean(&log_energy, RESAMPLES, BOOT_SEED),
        gamma: bootstrap_mean(&gamma, RESAMPLES, BOOT_SEED),
    }
}

/// `mean, 95 % interval low to high` of an interval, mapped by `f`, with `decimals` and `unit`.
fn interval_text(
    i: Option<Interval>,
    f: impl Fn(f64) -> f64,
    decimals: usize,
    unit: &str,
) -> String {
    i.map_or("no pair".to_owned(), |i| {
        let v = |x: f64| format!("{}{unit}", fixed(f(x), decimals));
        format!("{}, 95 % interval {} to {}", v(i.mean), v(i.low), v(i.high))
    })
}

/// `fig:claims.paired` (the full study, with its date and command) or `fig:claims.paired-ci`
/// (the first draws, checked by CI).
pub fn table(src: &mut Sources, study: Study) -> Result<String> {
    let search = same_settling(src)?;
    let band = search.band;
    let mut schemes = vec![Scheme {
        name: "predefined-time (proposed)".to_owned(),
        tag: "proposed",
        scenario: "example2.toml",
        sets: vec![],
    }];
    if let Some((c1, c2, _, _)) = search.picked {
        schemes.push(Scheme {
            name: format!(
                "prescribed-time [39] tuned to the same settling time (c₁ = {}, c₂ = {})",
                grouped(c1, 2),
                grouped(c2, 2)
            ),
            tag: "retuned",
            scenario: "example2-baseline.toml",
            sets: vec![
                format!("controller.c1={c1:?}"),
                format!("controller.c2={c2:?}"),
            ],
        });
    }
    schemes.push(Scheme {
        name: "prescribed-time [39] at its shipped gains (c₁ = 10, c₂ = 9)".to_owned(),
        tag: "shipped",
        scenario: "example2-baseline.toml",
        sets: vec![],
    });
    let mut outcomes = Vec::new();
    for s in &schemes {
        outcomes.push(src.paired_runs(study, s, band)?);
    }
    let mut t = if study == FULL {
        format!(
            "Written {} by `cargo xtask docs --only {} --rerun`.\n\n",
            today(),
            study.block
        )
    } else {
        format!(
            "The first {} draws of the study above, re-run and checked by `cargo xtask docs --check`.\n\n",
            study.draws
        )
    };
    let _ = writeln!(
        t,
        "{} draws of Example 2 (campaign seed {DRAW_SEED}: {DRAWS_TEXT}), each run under every scheme with the same values; settling time at band {} ({}× Example 2's final residual), dwell {} s; bootstrap: {} resamples of the pairs, seed {BOOT_SEED}.\n",
        grouped(study.draws as f64, 0),
        fixed(band, 4),
        fixed(SAME_SETTLING_BAND, 1),
        fixed(DWELL, 0),
        grouped(RESAMPLES as f64, 0),
    );
    t.push_str(
        "| check (not a claim of the paper) | rule | measured | verdict |\n|---|---|---|---|\n",
    );
    let (Some(proposed), Some(bases)) = (outcomes.first(), outcomes.get(1..)) else {
        return Err("no scheme ran".to_owned());
    };
    for (scheme, b) in schemes.iter().skip(1).zip(bases) {
        let p = paired(proposed, b);
        let pairs = format!(
            "{} of {} pairs bounded (diverged: proposed {}, baseline {})",
            grouped(p.bounded as f64, 0),
            grouped(study.draws as f64, 0),
            p.diverged.0,
            p.diverged.1
        );
        let _ = writeln!(
            t,
            "| the proposed scheme settles sooner than {} | holds if the 95 % interval of the mean paired difference of settling times (proposed − baseline, pairs in which both settle) lies below 0; does not hold if above 0 | {pairs}; never settle: proposed {}, baseline {}; mean difference {} | **{}** |",
            scheme.name,
            p.never.0,
            p.never.1,
            interval_text(p.settling, |x| x, 3, " s"),
            interval_side(p.settling, 0.0, true).text()
        );
        let _ = writeln!(
            t,
            "| {} spends more control energy | holds if the 95 % interval of the geometric mean of the paired ratios baseline / proposed energy lies above 1; does not hold if below 1 | {pairs}; geometric mean ratio {} | **{}** |",
            scheme.name,
            interval_text(p.log_energy, f64::exp, 2, "×"),
            interval_side(p.log_energy, 0.0, false).text()
        );
        let _ = writeln!(
            t,
            "| the proposed scheme ends closer to the leader than {} (γ̌ after each scheme's 1 s deadline) | holds if the 95 % interval of the mean paired difference of γ̌ (proposed − baseline) lies below 0; does not hold if above 0 | {pairs}; mean difference {} | **{}** |",
            scheme.name,
            interval_text(p.gamma, |x| x, 4, " rad"),
            interval_side(p.gamma, 0.0, true).text()
        );
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bootstrap_of_a_constant_is_the_constant_and_its_interval_covers_the_mean() {
        let c = bootstrap_mean(&[2.5; 30], 500, 7);
        assert_eq!(
            c,
            Some(Interval {
                mean: 2.5,
                low: 2.5,
                high: 2.5
            })
        );
        let x: Vec<f64> = (0..200).map(|k| f64::from(k % 10)).collect();
        let i = bootstrap_mean(&x, 2000, 3).unwrap_or(Interval {
            mean: f64::NAN,
            low: f64::NAN,
            high: f64::NAN,
        });
        assert_eq!(i.mean, 4.5);
        // Standard error of the mean: 2.87 / √200 ≈ 0.203; the interval is about ±0.4.
        assert!(i.low < 4.5 && i.high > 4.5, "{i:?}");
        assert!(i.low > 4.0 && i.high < 5.0, "{i:?}");
        assert_eq!(bootstrap_mean(&[], 10, 1), None);
        assert_eq!(bootstrap_mean(&x, 2000, 3), Some(i), "seeded: the same");
    }

    #[test]
    fn interval_rule_returns_each_verdict() {
        let i = |low, high| {
            Some(Interval {
                mean: 0.5 * (low + high),
                low,
                high,
            })
        };
        assert_eq!(
            interval_side(i(-2.0, -1.0), 0.0, true),
            IntervalVerdict::Holds
        );
        assert_eq!(
            interval_side(i(1.0, 2.0), 0.0, true),
            IntervalVerdict::DoesNotHold
        );
        assert_eq!(
            interval_side(i(-1.0, 2.0), 0.0, true),
            IntervalVerdict::Undecided
        );
        assert_eq!(
            interval_side(i(1.0, 2.0), 0.0, false),
            IntervalVerdict::Holds
        );
        assert_eq!(
            interval_side(i(-2.0, -1.0), 0.0, false),
            IntervalVerdict::DoesNotHold
        );
        assert_eq!(interval_side(None, 0.0, true), IntervalVerdict::NoPairs);
    }

    #[test]
    fn pairs_with_a_diverged_run_are_left_out_and_counted() {
        let o = |t: Option<f64>, e: f64, g: f64| {
            Some(Outcome {
                settling: t,
                energy: e,
                gamma: g,
            })
        };
        let p = vec![o(Some(1.0), 1.0, 0.1), o(None, 2.0, 0.2), None];
        let b = vec![
            o(Some(2.0), 4.0, 0.3),
            o(Some(1.0), 8.0, 0.1),
            o(None, 1.0, 0.1),
        ];
        let r = paired(&p, &b);
        assert_eq!((r.bounded, r.diverged, r.never), (2, (1, 0), (1, 0)));
        assert_eq!(r.settling.map(|i| i.mean), Some(-1.0));
        let e = r.log_energy.map(|i| i.mean.exp()).unwrap_or(f64::NAN);
        assert!((e - 4.0).abs() < 1e-12, "geometric mean of 4 and 4: {e}");
    }

    #[test]
    fn every_draw_is_a_uniform_sample_of_ten_keys() {
        let s = samples();
        assert_eq!(s.matches("[[sample]]").count(), 10);
        assert!(s.contains("key = \"plant.x0[4][2]\"") && s.contains("faults.rule[2].start"));
    }
}
