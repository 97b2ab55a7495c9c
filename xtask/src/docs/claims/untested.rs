//! Claims of the paper that none of its figures tests, measured: independence from the initial
//! conditions (contribution 2, Remark 9(5)) at a converged sample period, the boundedness of
//! every closed-loop signal (Theorem 1(2)), Lemma 2's predefined-time envelope of the Lyapunov
//! function, Lemma 5's differentiator error, and the paper's printed figures beside the
//! measured ones.
//!
//! As in the parent module, no verdict is text: each is the value of a rule function applied to
//! measured figures, and each rule has a test that it can return each of its verdicts.

use super::{run_with, Run, Verdict, READINGS};
use crate::docs::{fixed, grouped, ms, Sources};
use crate::task::{workspace_root, Result};
use std::{fmt::Write as _, fs};

// ---------------------------------------------------------------------------------------------
// Rules

/// Contribution 2 / Remark 9(5), "does not rely on initial conditions": `counts` are the
/// diverging runs per sample period, halved from the first; the count has converged when two
/// successive periods give the same count. Holds if no run diverges at the converged period.
pub fn initial_independence(counts: &[(f64, usize)]) -> Verdict {
    let converged = counts
        .windows(2)
        .find(|w| matches!(w, [a, b] if a.1 == b.1))
        .and_then(|w| w.first());
    match converged {
        None => Verdict::Undecided,
        Some((_, 0)) => Verdict::Holds,
        Some(_) => Verdict::DoesNotHold,
    }
}

/// Theorem 1(2), "all signals … are bounded", as far as a finite run can show it: no run
/// diverges and no signal makes a new high late in a long run: its peak over the last window is
/// at most `1 + margin` times its largest peak over the earlier windows. `growth` is the largest
/// such ratio over every signal and run.
pub fn bounded(margin: f64, growth: f64, diverged: bool) -> Verdict {
    if diverged || !growth.is_finite() {
        Verdict::Diverged
    } else if growth <= 1.0 + margin {
        Verdict::Holds
    } else {
        Verdict::DoesNotHold
    }
}

/// Lemma 2: the measured `V` stays at or below the envelope `W` (the solution of the lemma's
/// comparison equation (4) with equality, from `V(0)`) at every sample up to `2 T_s`.
pub fn below_envelope(measured: &[f64], envelope: &[f64], diverged: bool) -> Verdict {
    if diverged {
        Verdict::Diverged
    } else if measured.is_empty() {
        Verdict::Undecided
    } else if measured.iter().zip(envelope).all(|(v, w)| v <= w) {
        Verdict::Holds
    } else {
        Verdict::DoesNotHold
    }
}

/// Lemma 5, `α̇ = χ₂ + ε` "with arbitrary accuracy": holds if the largest `|χ₂ − α̇|` after
/// `2 T_s` is at most `fraction` of the largest `|α̇|` there.
pub fn differentiator_tracks(fraction: f64, error: f64, rate: f64, diverged: bool) -> Verdict {
    if diverged || !error.is_finite() || !rate.is_finite() {
        Verdict::Diverged
    } else if error <= fraction * rate {
        Verdict::Holds
    } else {
        Verdict::DoesNotHold
    }
}

/// A figure read off the paper's printed figures against the measured one: holds if the
/// measured figure lies within the reading ± its reading error; undecided without a reading.
pub fn matches_paper(reading: Option<(f64, f64)>, measured: Option<f64>) -> Verdict {
    match (reading, measured) {
        (None, _) => Verdict::Undecided,
        (Some(_), None) => Verdict::Diverged,
        (Some((v, err)), Some(m)) if (m - v).abs() <= err => Verdict::Holds,
        (Some(_), Some(_)) => Verdict::DoesNotHold,
    }
}

/// Margin of [`bounded`]: a signal may peak 10 % higher in the last window than before.
const GROWTH_MARGIN: f64 = 0.1;
/// Fraction of [`differentiator_tracks`].
const TRACKING_FRACTION: f64 = 0.1;

// ---------------------------------------------------------------------------------------------
// Trajectories

/// Every column of a run's `trajectory.csv`.
struct Trajectory {
    names: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Trajectory {
    /// `target/docs/run/<dir>/trajectory.csv`, written by [`run_with`].
    fn read(dir: &str) -> Result<Self> {
        let path = format!("target/docs/run/{dir}/trajectory.csv");
        let text =
            fs::read_to_string(workspace_root().join(&path)).map_err(|e| format!("{path}: {e}"))?;
        let mut lines = text.lines();
        let names = lines
            .next()
            .ok_or(format!("{path}: empty"))?
            .split(',')
            .map(str::to_owned)
            .collect();
        let rows = lines
            .map(|l| {
                l.split(',')
                    .map(|x| x.parse::<f64>().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        Ok(Self { names, rows })
    }

    /// The column `name`.
    fn col(&self, name: &str) -> Result<Vec<f64>> {
        let k = self
            .names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| format!("trajectory.csv: no column `{name}`"))?;
        Ok(self
            .rows
            .iter()
            .map(|r| r.get(k).copied().unwrap_or(f64::NAN))
            .collect())
    }

    /// Names of the columns that start with `prefix` followed by an agent number.
    fn family(&self, prefix: &str) -> Vec<String> {
        self.names
            .iter()
            .filter(|n| {
                n.strip_prefix(prefix)
                    .and_then(|rest| rest.chars().next())
                    .is_some_and(|c| c.is_ascii_digit())
            })
            .cloned()
            .collect()
    }

    /// Agents in the file (`y1`, `y2`, …).
    fn agents(&self) -> usize {
        (1..)
            .take_while(|i| self.names.iter().any(|n| *n == format!("y{i}")))
            .count()
    }
}

/// A number `key = value` of `scenarios/<stem>.toml` (first occurrence).
fn scenario_number(stem: &str, key: &str) -> Result<f64> {
    let path = format!("scenarios/{stem}.toml");
    let text =
        fs::read_to_string(workspace_root().join(&path)).map_err(|e| format!("{path}: {e}"))?;
    text.lines()
        .filter_map(|l| l.split_once('='))
        .find(|(k, _)| k.trim() == key)
        .and_then(|(_, v)| v.split('#').next().and_then(|v| v.trim().parse().ok()))
        .ok_or_else(|| format!("{path}: no number `{key}`"))
}

/// A shipped scenario run as it is, with its trajectory (`target/docs/run/<stem><tag>`).
fn shipped(src: &mut Sources, stem: &str, tag: &str, sets: &[String]) -> Result<(Run, Trajectory)> {
    let r = run_with(src, stem, tag, sets, &[])?;
    Ok((r, Trajectory::read(&format!("{stem}{tag}"))?))
}

// ---------------------------------------------------------------------------------------------
// Theorem 1(2): boundedness

/// Signal families of Theorem 1(2): states, commands, the adaptive estimates.
const SIGNALS: [(&str, &str); 5] = [
    ("\\|x\\|", "x"),
    ("\\|u\\|", "u"),
    ("μ̂", "mu"),
    ("ξ̂", "xi"),
    ("λ̂", "lambda"),
];

/// Length of the long runs of the growth test (6× the shipped 10 s) and of its windows.
const LONG_RUN: f64 = 60.0;
const WINDOW: f64 = 10.0;

/// Per family of [`SIGNALS`]: the largest absolute value over the run.
fn peaks(tr: &Trajectory) -> Result<Vec<f64>> {
    let mut out = Vec::new();
    for (_, prefix) in SIGNALS {
        let mut peak = 0.0f64;
        for name in tr.family(prefix) {
            for x in tr.col(&name)? {
                peak = peak.max(if x.is_finite() {
                    x.abs()
                } else {
                    f64::INFINITY
                });
            }
        }
        out.push(peak);
    }
    Ok(out)
}

/// The signal with the largest ratio of its peak over the last [`WINDOW`] to its largest peak
/// over the earlier windows: (column, ratio).
fn growth(tr: &Trajectory) -> Result<(String, f64)> {
    let t = tr.col("t")?;
    let end = t.last().copied().unwrap_or(0.0);
    let mut worst = (String::new(), 0.0f64);
    for (_, prefix) in SIGNALS {
        for name in tr.family(prefix) {
            let (mut before, mut last) = (0.0f64, 0.0f64);
            for (tk, x) in t.iter().zip(tr.col(&name)?) {
                let a = if x.is_finite() {
                    x.abs()
                } else {
                    f64::INFINITY
                };
                if *tk > end - WINDOW {
                    last = last.max(a);
                } else {
                    before = before.max(a);
                }
            }
            // A signal at rest (exactly zero) throughout does not grow.
            let ratio = if last > 0.0 { last / before } else { 0.0 };
            if ratio > worst.1 {
                worst = (name, ratio);
            }
        }
    }
    Ok(worst)
}

// ---------------------------------------------------------------------------------------------
// Lemma 2: the envelope of V

/// Lemma 2 on one run: the measured `V = ½ Σ_i Σ_j e_{i,j}²`, the envelope `W`, sample times,
/// the `Γ` used and the bound `ζ Γ T_s / π`, the deadline `2 T_s`.
struct Envelope {
    zeta: f64,
    ts: f64,
    t: Vec<f64>,
    v: Vec<f64>,
    w: Vec<f64>,
    gamma: f64,
    bound: f64,
    deadline: f64,
    diverged: bool,
}

impl Envelope {
    /// Samples up to the deadline.
    fn until_deadline(&self) -> usize {
        self.t
            .iter()
            .take_while(|t| **t <= self.deadline + 1e-9)
            .count()
    }

    /// The verdict of [`below_envelope`] on `[0, 2 T_s]`.
    fn verdict(&self) -> Verdict {
        let n = self.until_deadline();
        below_envelope(
            self.v.get(..n).unwrap_or(&[]),
            self.w.get(..n).unwrap_or(&[]),
            self.diverged,
        )
    }

    /// The smallest `Γ` for which `V ≤ W` at every sample up to the deadline (bisection in
    /// `log Γ` between the `Γ` in force and a million times it): the `Γ` that (4) needs along
    /// the measured run.
    fn gamma_needed(&self, zeta: f64, ts: f64) -> f64 {
        let n = self.until_deadline();
        let (t, v) = (
            self.t.get(..n).unwrap_or(&[]),
            self.v.get(..n).unwrap_or(&[]),
        );
        let v0 = v.first().copied().unwrap_or(0.0);
        let fits = |g: f64| {
            let w = comparison_solution(t, v0, zeta, ts, g);
            v.iter().zip(&w).all(|(v, w)| v <= w)
        };
        let (mut lo, mut hi) = (self.gamma.max(1e-12), self.gamma.max(1e-12) * 1e6);
        if fits(lo) {
            return lo;
        }
        if !fits(hi) {
            return f64::INFINITY;
        }
        for _ in 0..20 {
            let mid = (lo * hi).sqrt();
            if fits(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// `(time, V / W)` of the first sample above the envelope before the deadline, and the
    /// largest `V / W` there.
    fn excess(&self) -> (Option<f64>, f64) {
        let n = self.until_deadline();
        let mut first = None;
        let mut worst = 0.0f64;
        for k in 0..n {
            let (Some(v), Some(w), Some(t)) = (self.v.get(k), self.w.get(k), self.t.get(k)) else {
                break;
            };
            if v > w && first.is_none() {
                first = Some(*t);
            }
            if *w > 0.0 {
                worst = worst.max(v / w);
            }
        }
        (first, worst)
    }
}

/// The solution of `Ẇ = −(π/(ζ T_s)) (W^{1+ζ/2} + W^{1−ζ/2}) + Γ` (Lemma 2's (4) with
/// equality, the paper's (57)) at the times `t` from `W(t₀) = w0`: classical RK4 with 20 steps
/// per sample interval, clamped at zero.
fn comparison_solution(t: &[f64], w0: f64, zeta: f64, ts: f64, gamma: f64) -> Vec<f64> {
    let k = std::f64::consts::PI / (zeta * ts);
    let f = |w: f64| {
        let w = w.max(0.0);
        -k * (w.powf(1.0 + zeta / 2.0) + w.powf(1.0 - zeta / 2.0)) + gamma
    };
    let mut out = Vec::with_capacity(t.len());
    let mut w = w0;
    let mut prev = t.first().copied().unwrap_or(0.0);
    for tk in t {
        let steps = 20;
        let dt = (tk - prev) / f64::from(steps);
        for _ in 0..steps {
            let k1 = f(w);
            let k2 = f(w + 0.5 * dt * k1);
            let k3 = f(w + 0.5 * dt * k2);
            let k4 = f(w + dt * k3);
            w = (w + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).max(0.0);
        }
        prev = *tk;
        out.push(w);
    }
    out
}

/// Lemma 2 on a shipped run. `Γ` of (57) holds the unknown `μ_i`, `ξ_i`, `λ_i`, `d̄` and `ε̄`:
/// it is taken as the smallest value for which the lemma's final bound `V ≤ ζ Γ T_s / π`
/// holds after `2 T_s`, and `V(0)` as `½ Σ e²(0)` (the adaptive terms of `V_n` need the same
/// unknowns).
fn envelope(stem: &str, run: &Run, tr: &Trajectory) -> Result<Envelope> {
    let t = tr.col("t")?;
    let mut v = vec![0.0; t.len()];
    for name in tr.family("e") {
        for (acc, e) in v.iter_mut().zip(tr.col(&name)?) {
            *acc += 0.5 * e * e;
        }
    }
    let (zeta, ts) = (scenario_number(stem, "zeta")?, scenario_number(stem, "ts")?);
    let deadline = 2.0 * ts;
    let after = t
        .iter()
        .zip(&v)
        .filter(|(tk, _)| **tk >= deadline - 1e-9)
        .map(|(_, x)| *x)
        .fold(0.0, f64::max);
    let gamma = std::f64::consts::PI * after / (zeta * ts);
    let w = comparison_solution(&t, v.first().copied().unwrap_or(0.0), zeta, ts, gamma);
    Ok(Envelope {
        zeta,
        ts,
        bound: zeta * gamma * ts / std::f64::consts::PI,
        t,
        v,
        w,
        gamma,
        deadline,
        diverged: run.diverged,
    })
}

/// Scientific notation with three significant digits: `1.23e-4`.
fn sci(x: f64) -> String {
    format!("{x:.2e}")
}

// ---------------------------------------------------------------------------------------------
// Lemma 5: the differentiator

/// Lemma 5 on a shipped run, per agent's differentiator of `α_{i,1}`: the largest
/// `|χ₂ − α̇|` and `|α̇|` after `2 T_s`, and the largest `|α̈|` there.
struct Tracking {
    error: f64,
    rate: f64,
    accel: f64,
    l2: f64,
    diverged: bool,
}

/// `α_{i,1} = x_{i,2} − e_{i,2}` from the recorded trajectory; `χ` replayed in f64 with the
/// controller's forward-Euler update (SPEC §4 step 4, `χ₁ = α`, `χ₂ = 0` on the first sample);
/// `α̇` and `α̈` by central differences at the controller's own samples; `χ₂` as the law
/// uses it at `t_k` (updated with `α(t_{k−1})`).
fn tracking(stem: &str, run: &Run, tr: &Trajectory) -> Result<Tracking> {
    let t = tr.col("t")?;
    let h = t.get(1).zip(t.first()).map_or(f64::NAN, |(b, a)| b - a);
    let (l1, l2) = (
        scenario_number(stem, "diff_l1")?,
        scenario_number(stem, "diff_l2")?,
    );
    let deadline = 2.0 * scenario_number(stem, "ts")?;
    let (mut error, mut rate, mut accel) = (0.0f64, 0.0f64, 0.0f64);
    for i in 1..=tr.agents() {
        let x2 = tr.col(&format!("x{i}_2"))?;
        let e2 = tr.col(&format!("e{i}_2"))?;
        let alpha: Vec<f64> = x2.iter().zip(&e2).map(|(x, e)| x - e).collect();
        let (mut chi1, mut chi2) = (alpha.first().copied().unwrap_or(0.0), 0.0);
        for k in 1..alpha.len().saturating_sub(1) {
            let (Some(a0), Some(a1), Some(a2), Some(tk)) =
                (alpha.get(k - 1), alpha.get(k), alpha.get(k + 1), t.get(k))
            else {
                break;
            };
            // χ as updated with α(t_{k−1}): the law's estimate at t_k.
            if k > 1 {
                let d = chi1 - a0;
                let sg = if d > 0.0 {
                    1.0
                } else if d < 0.0 {
                    -1.0
                } else {
                    0.0
                };
                chi1 += h * (-l1 * d.abs().sqrt() * sg + chi2);
                chi2 -= h * l2 * sg;
            }
            if *tk >= deadline - 1e-9 {
                let d1 = (a2 - a0) / (2.0 * h);
                let d2 = (a2 - 2.0 * a1 + a0) / (h * h);
                error = error.max((chi2 - d1).abs());
                rate = rate.max(d1.abs());
                accel = accel.max(d2.abs());
            }
        }
    }
    Ok(Tracking {
        error,
        rate,
        accel,
        l2,
        diverged: run.diverged,
    })
}

// ---------------------------------------------------------------------------------------------
// Initial conditions

/// One initial state of the Monte Carlo (`campaigns/example1-monte-carlo.toml`).
#[derive(Debug, Clone)]
struct Draw {
    run: usize,
    x0: [[f64; 2]; 4],
    starts: [f64; 2],
    diverged: bool,
}

impl Draw {
    /// `--set` overrides that re-create the draw (with the campaign's own override).
    fn sets(&self) -> Vec<String> {
        let x0: Vec<String> = self.x0.iter().map(|[a, b]| format!("[{a}, {b}]")).collect();
        vec![
            "simulation.settle_band=0.25".to_owned(),
            format!("plant.x0=[{}]", x0.join(", ")),
            format!("faults.rule[1].start={}", self.starts[0]),
            format!("faults.rule[2].start={}", self.starts[1]),
        ]
    }

    /// The largest `|x_{i,1}(0)|`.
    fn spread(&self) -> f64 {
        self.x0.iter().map(|x| x[0].abs()).fold(0.0, f64::max)
    }
}

/// The Monte Carlo's draws, from its `results.csv` (the sweep is run when missing).
fn draws(src: &mut Sources) -> Result<Vec<Draw>> {
    src.campaign("example1-monte-carlo")?;
    let path = "out/campaigns/example1-monte-carlo/results.csv";
    let text =
        fs::read_to_string(workspace_root().join(path)).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty")?.split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| format!("{path}: no column `{name}`"))
    };
    let mut x0k = Vec::new();
    for i in 1..=4 {
        for j in 1..=2 {
            x0k.push(col(&format!("plant.x0[{i}][{j}]"))?);
        }
    }
    let (runk, divk, s1, s2) = (
        col("run")?,
        col("diverged")?,
        col("faults.rule[1].start")?,
        col("faults.rule[2].start")?,
    );
    let mut out = Vec::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let num = |k: usize| {
            cells
                .get(k)
                .and_then(|c| c.parse::<f64>().ok())
                .ok_or_else(|| format!("{path}: a row without a number in column {k}"))
        };
        let mut x0 = [[0.0; 2]; 4];
        for (slot, k) in x0.iter_mut().flatten().zip(&x0k) {
            *slot = num(*k)?;
        }
        out.push(Draw {
            run: cells
                .get(runk)
                .and_then(|c| c.parse().ok())
                .ok_or_else(|| format!("{path}: a row without `run`"))?,
            x0,
            starts: [num(s1)?, num(s2)?],
            diverged: cells.get(divk) == Some(&"true"),
        });
    }
    Ok(out)
}

/// The Monte Carlo's sample period (its scenario's).
const H0: f64 = 1e-3;
/// Halvings of `h` tried at most.
const MAX_HALVINGS: u32 = 4;
/// Initial states of CI's subset: the first diverging draws of the Monte Carlo.
const CI_SUBSET: usize = 5;

/// The re-runs of a set of draws at `h`, `h/2`, … until the diverging count repeats.
struct Halving {
    /// `(h, diverging runs)` per period tried.
    counts: Vec<(f64, usize)>,
    /// Runs at the last period tried, with their largest `|x|`.
    last: Vec<(Run, f64)>,
}

/// Re-runs `draws` under `reading_sets` at `H0` halved until two periods give the same count
/// (or after [`MAX_HALVINGS`]).
fn halve(src: &mut Sources, draws: &[Draw], tag: &str, reading_sets: &[&str]) -> Result<Halving> {
    let mut counts: Vec<(f64, usize)> = Vec::new();
    let mut last = Vec::new();
    for k in 0..=MAX_HALVINGS {
        let h = H0 / f64::from(1u32 << k);
        let mut runs = Vec::new();
        for d in draws {
            let mut sets: Vec<String> = reading_sets.iter().map(|s| (*s).to_owned()).collect();
            sets.extend(d.sets());
            sets.push(format!("simulation.h={h}"));
            let dir = format!("-ic{tag}/run{}-h{h}", d.run);
            let r = run_with(src, "example1", &dir, &sets, &["--decimate", "1000"])?;
            runs.push((r, peak_state(&format!("example1{dir}"))?));
        }
        let n = runs.iter().filter(|r| r.0.diverged).count();
        let repeat = counts.last().is_some_and(|(_, c)| *c == n);
        counts.push((h, n));
        last = runs;
        if repeat {
            break;
        }
    }
    Ok(Halving { counts, last })
}

/// `n of m at h` for each period.
fn counts_text(counts: &[(f64, usize)], of: usize) -> String {
    counts
        .iter()
        .map(|(h, n)| format!("{n} of {of} at {}", ms(*h)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The period at which the count stopped changing.
fn converged_h(counts: &[(f64, usize)]) -> Option<f64> {
    counts
        .windows(2)
        .find(|w| matches!(w, [a, b] if a.1 == b.1))
        .and_then(|w| w.first())
        .map(|(h, _)| *h)
}

/// Largest `|x|` and `|u|` of `runs` (from their summaries).
fn run_peaks(runs: &[(Run, f64)]) -> (f64, f64) {
    let x = runs.iter().map(|r| r.1).fold(0.0, f64::max);
    let u = runs.iter().map(|r| r.0.peak_u).fold(0.0, f64::max);
    (x, u)
}

/// The largest `peak_abs_state` over the agents of `target/docs/run/<dir>/summary.json`.
fn peak_state(dir: &str) -> Result<f64> {
    let path = format!("target/docs/run/{dir}/summary.json");
    let text =
        fs::read_to_string(workspace_root().join(&path)).map_err(|e| format!("{path}: {e}"))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
    Ok(v["agents"].as_array().map_or(f64::NAN, |a| {
        a.iter()
            .filter_map(|x| x["peak_abs_state"].as_f64())
            .fold(0.0, f64::max)
    }))
}

// ---------------------------------------------------------------------------------------------
// Tables

/// The rule statements of the rows.
const IC_RULE: &str = "the Monte Carlo's diverging initial states (at h = 1 ms) re-run with h halved until the number that diverges repeats; holds if none diverges at that converged h";
const BOUNDED_RULE: &str = "holds if no run diverges and no signal (x, u, μ̂, ξ̂, λ̂) makes a new high late: over runs of Examples 1 and 2 six times as long (60 s), its peak over the last 10 s is at most 1.1× its peak over the 50 s before (a finite run can show no more)";
const ENVELOPE_RULE: &str = "holds if the measured V = ½ Σᵢ Σⱼ e²ᵢⱼ stays at or below the solution W of (4) with equality from V(0) at every sample up to 2Tₛ; Γ (unknown constants of (57)) taken as the smallest for which the final bound V ≤ ζΓTₛ/π holds after 2Tₛ";
const TRACKING_RULE: &str = "holds if max \\|χ₂ − α̇\\| after 2Tₛ is at most 10 % of max \\|α̇\\| there (α = x₂ − e₂ recorded, χ replayed with the controller's Euler update, α̇ by central differences at the controller's samples)";

/// `fig:claims.untested`: the rows CI re-runs (Examples 1 and 2 as shipped, and the first
/// [`CI_SUBSET`] diverging initial states of the Monte Carlo).
pub fn untested_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from("| claim (paper) | rule | measured | verdict |\n|---|---|---|---|\n");
    // Initial conditions, CI's subset.
    let all = draws(src)?;
    let subset: Vec<Draw> = all
        .iter()
        .filter(|d| d.diverged)
        .take(CI_SUBSET)
        .cloned()
        .collect();
    let halving = halve(src, &subset, "", &[])?;
    let _ = writeln!(
        t,
        "| contribution 2, Remark 9(5): the scheme \"does not rely on initial conditions\" (CI's subset: the first {} diverging draws of the Monte Carlo, runs {}) | {IC_RULE} | {}; converged at h = {} | **{}** |",
        subset.len(),
        subset.iter().map(|d| d.run.to_string()).collect::<Vec<_>>().join(", "),
        counts_text(&halving.counts, subset.len()),
        converged_h(&halving.counts).map_or("–".to_owned(), ms),
        initial_independence(&halving.counts).text()
    );
    let mut shipped_runs = Vec::new();
    for stem in ["example1", "example2"] {
        let (run, tr) = shipped(src, stem, "", &[])?;
        shipped_runs.push((stem, run, tr));
    }
    // Boundedness: peaks of the shipped runs, growth over runs 6× as long.
    let mut worst = (String::new(), 0.0f64, "");
    let mut diverged = false;
    let mut parts = Vec::new();
    for (stem, run, tr) in &shipped_runs {
        let p = peaks(tr)?;
        diverged |= run.diverged;
        parts.push(format!(
            "{}: {}",
            example(stem),
            SIGNALS
                .iter()
                .zip(&p)
                .map(|((name, _), peak)| format!("{name} {}", sig(*peak)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        let h = scenario_number(stem, "h")?;
        let decimate = ((0.01 / h).round() as u32).max(1).to_string();
        let long = run_with(
            src,
            stem,
            "-long",
            &[format!("simulation.t_end={LONG_RUN}")],
            &["--decimate", &decimate],
        )?;
        diverged |= long.diverged;
        let (name, g) = growth(&Trajectory::read(&format!("{stem}-long"))?)?;
        if g > worst.1 {
            worst = (name, g, example(stem));
        }
    }
    let (px, pu) = run_peaks(&halving.last);
    diverged |= halving.last.iter().any(|r| r.0.diverged);
    let _ = writeln!(
        t,
        "| Theorem 1(2): \"all signals in the closed-loop system are bounded\" | {BOUNDED_RULE} | peaks over the shipped runs, {}; the {} re-run initial states at the converged h: \\|x\\| ≤ {}, \\|u\\| ≤ {}; largest last-window / earlier peak over {} s runs (sampled every 10 ms): {} ({} of {}) | **{}** |",
        parts.join("; "),
        halving.last.len(),
        sig(px),
        sig(pu),
        LONG_RUN,
        fixed(worst.1, 2),
        worst.0,
        worst.2,
        bounded(GROWTH_MARGIN, worst.1, diverged).text()
    );
    // Lemma 2 (and its figure, which `cargo xtask docs` copies to docs/figures/).
    let mut verdict = Verdict::Holds;
    let mut parts = Vec::new();
    let mut panels = Vec::new();
    for (stem, run, tr) in &shipped_runs {
        let env = envelope(stem, run, tr)?;
        let (first, worst) = env.excess();
        verdict = super::worst(verdict, env.verdict());
        let needed = env.gamma_needed(env.zeta, env.ts);
        let needed_bound = env.zeta * needed * env.ts / std::f64::consts::PI;
        parts.push(format!(
            "{}: V(0) = {}, Γ = {}, bound ζΓTₛ/π = {}, {}, largest V/W before 2Tₛ {}; the Γ (4) needs for V ≤ W up to 2Tₛ: {}, whose bound {} is {}× the measured one",
            example(stem),
            sig(env.v.first().copied().unwrap_or(0.0)),
            sig(env.gamma),
            sig(env.bound),
            first.map_or("never above W".to_owned(), |t| format!(
                "first above W at t = {} s",
                fixed(t, 3)
            )),
            fixed(worst, 2),
            sig(needed),
            sig(needed_bound),
            fixed(needed_bound / env.bound, 1)
        ));
        panels.push(env);
    }
    write_envelope_figure(&panels)?;
    let _ = writeln!(
        t,
        "| Lemma 2 / (57): V \"can remain within the range V ≤ ζΓTₛ/π for a predefined-time of 2Tₛ\", through the decay of (4) | {ENVELOPE_RULE} | {} | **{}** |",
        parts.join("; "),
        verdict.text()
    );
    // Lemma 5.
    let mut verdict = Verdict::Holds;
    let mut parts = Vec::new();
    for (stem, run, tr) in &shipped_runs {
        let tr = tracking(stem, run, tr)?;
        verdict = super::worst(
            verdict,
            differentiator_tracks(TRACKING_FRACTION, tr.error, tr.rate, tr.diverged),
        );
        parts.push(format!(
            "{}: max \\|χ₂ − α̇\\| {}, max \\|α̇\\| {}; max \\|α̈\\| {} against ℓ₂ = {} (Levant's condition ℓ₂ > \\|α̈\\| {})",
            example(stem),
            sig(tr.error),
            sig(tr.rate),
            sig(tr.accel),
            fixed(tr.l2, 0),
            if tr.l2 > tr.accel { "met" } else { "not met" }
        ));
    }
    let _ = writeln!(
        t,
        "| Lemma 5: the differentiator (8) gives α̇ \"with arbitrary accuracy\", α̇ = χ₂ + ε, \\|ε\\| < ε̄ | {TRACKING_RULE} | {} | **{}** |",
        parts.join("; "),
        verdict.text()
    );
    Ok(t)
}

/// "Example 1" / "Example 2".
fn example(stem: &str) -> &'static str {
    if stem.starts_with("example2") {
        "Example 2"
    } else {
        "Example 1"
    }
}

/// Three significant digits, thousands grouped above 1,000.
fn sig(x: f64) -> String {
    let a = x.abs();
    if a >= 1000.0 {
        grouped(x, 0)
    } else if a >= 100.0 {
        fixed(x, 0)
    } else if a >= 10.0 {
        fixed(x, 1)
    } else if a >= 0.01 || a == 0.0 {
        fixed(x, 3)
    } else {
        sci(x)
    }
}

/// `fig:claims.initial-conditions`: every diverging draw of the Monte Carlo re-run with `h`
/// halved, per reading. Costs minutes: `--check` skips it; it states the date and the command
/// that wrote it.
pub fn initial_conditions_table(src: &mut Sources) -> Result<String> {
    let all = draws(src)?;
    let mut t = format!(
        "Written {} by `cargo xtask docs --only claims.initial-conditions --rerun`.\n\n| reading | diverging at h = 1 ms (of {}) | diverging after halving h (same states) | converged at h | verdict | peaks at the converged h |\n|---|---|---|---|---|---|\n",
        super::super::today(),
        grouped(all.len() as f64, 0)
    );
    for reading in READINGS.iter() {
        if !reading.full {
            let _ = writeln!(
                t,
                "| {} | not run: it needs h = 1 µs, a minute per run, about {} h for the {} draws | – | – | – | – |",
                reading.name,
                fixed(all.len() as f64 / 60.0, 0),
                grouped(all.len() as f64, 0)
            );
            continue;
        }
        // Which draws diverge at h = 1 ms under this reading.
        let diverging: Vec<Draw> = if reading.sets.is_empty() {
            all.iter().filter(|d| d.diverged).cloned().collect()
        } else {
            let mut v = Vec::new();
            for d in &all {
                let mut sets: Vec<String> = reading.sets.iter().map(|s| (*s).to_owned()).collect();
                sets.extend(d.sets());
                let r = run_with(
                    src,
                    "example1",
                    &format!("-ic{}/draw{}", reading.tag, d.run),
                    &sets,
                    &["--decimate", "1000"],
                )?;
                if r.diverged {
                    v.push(d.clone());
                }
            }
            v
        };
        let halving = halve(src, &diverging, reading.tag, reading.sets)?;
        let spread = diverging
            .iter()
            .map(Draw::spread)
            .fold(f64::INFINITY, f64::min);
        let (px, pu) = run_peaks(&halving.last);
        let _ = writeln!(
            t,
            "| {} | {} (smallest max\\|x_{{i,1}}(0)\\| among them {}) | {} | {} | **{}** | \\|x\\| ≤ {}, \\|u\\| ≤ {} |",
            reading.name,
            diverging.len(),
            fixed(spread, 3),
            counts_text(&halving.counts, diverging.len()),
            converged_h(&halving.counts).map_or(format!("not within {MAX_HALVINGS} halvings"), ms),
            initial_independence(&halving.counts).text(),
            sig(px),
            sig(pu)
        );
    }
    let _ = write!(t, "\nRule: {IC_RULE}.\n");
    Ok(t)
}

// ---------------------------------------------------------------------------------------------
// The paper's printed figures

/// What is read off a printed figure.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Quantity {
    /// The largest `|u_{i,l}|` of every agent.
    PeakU,
    /// The largest `max_i |y_i − y_d|` over the run's last `2 T_s`.
    Residual,
}

/// A figure of the paper read by eye: the figure, what, which run, the reading and its error
/// (± half a grid division of the printed axis), `None` when not read.
struct PaperReading {
    figure: &'static str,
    quantity: Quantity,
    stem: &'static str,
    reading: Option<(f64, f64)>,
}

/// The readings. The repository's copy of the paper (`predefined-time-consensus-lu-2024`, its
/// text) keeps the figures' captions only, not their plots: nothing could be read, so every
/// reading is `None` and its row undecided until someone reads the printed figures.
const PAPER_READINGS: [PaperReading; 6] = [
    PaperReading {
        figure: "Fig. 2",
        quantity: Quantity::Residual,
        stem: "example1",
        reading: None,
    },
    PaperReading {
        figure: "Figs. 3–6",
        quantity: Quantity::PeakU,
        stem: "example1",
        reading: None,
    },
    PaperReading {
        figure: "Fig. 7",
        quantity: Quantity::Residual,
        stem: "example1-ts1",
        reading: None,
    },
    PaperReading {
        figure: "Fig. 8a",
        quantity: Quantity::Residual,
        stem: "example2-baseline",
        reading: None,
    },
    PaperReading {
        figure: "Fig. 8b",
        quantity: Quantity::Residual,
        stem: "example2",
        reading: None,
    },
    PaperReading {
        figure: "Figs. 9–12",
        quantity: Quantity::PeakU,
        stem: "example2",
        reading: None,
    },
];

/// `fig:claims.paper-figures`: the paper's printed figures beside the measured ones.
pub fn paper_figures_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from(
        "| figure (paper) | quantity | run | read off the figure (± reading error) | measured | verdict |\n|---|---|---|---|---|---|\n",
    );
    for p in &PAPER_READINGS {
        let r = run_with(src, p.stem, "", &[], &[])?;
        let measured = match (p.quantity, r.diverged) {
            (_, true) => None,
            (Quantity::PeakU, false) => Some(r.peak_u),
            (Quantity::Residual, false) => Some(r.residual()),
        };
        let _ = writeln!(
            t,
            "| {} | {} | `{}` | {} | {} | **{}** |",
            p.figure,
            match p.quantity {
                Quantity::PeakU => "peak \\|u\\|",
                Quantity::Residual => "residual: max error over the last 2Tₛ",
            },
            p.stem,
            p.reading.map_or("not read".to_owned(), |(v, e)| format!(
                "{} ± {}",
                sig(v),
                sig(e)
            )),
            measured.map_or("diverged".to_owned(), sig),
            matches_paper(p.reading, measured).text()
        );
    }
    Ok(t)
}

// ---------------------------------------------------------------------------------------------
// Figure: Lemma 2's envelope

/// `target/docs/claims/lemma2-envelope.svg`: `V` and `W` of Examples 1 and 2 on a log scale
/// up to `2.5 T_s`, with the bound `ζΓT_s/π` and the deadline `2 T_s`.
pub fn envelope_figure(src: &mut Sources) -> Result<std::path::PathBuf> {
    let mut panels = Vec::new();
    for stem in ["example1", "example2"] {
        let (run, tr) = shipped(src, stem, "", &[])?;
        panels.push(envelope(stem, &run, &tr)?);
    }
    write_envelope_figure(&panels)
}

/// Writes [`envelope_svg`] of `panels` (Examples 1 and 2) where [`envelope_figure`] puts it.
fn write_envelope_figure(panels: &[Envelope]) -> Result<std::path::PathBuf> {
    let path = workspace_root().join("target/docs/claims/lemma2-envelope.svg");
    if let Some(dir) = path.parent() {
        fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let svg = envelope_svg(panels, &["Example 1 (Tₛ = 2)", "Example 2 (Tₛ = 0.5)"]);
    fs::write(&path, svg).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// The SVG text of [`envelope_figure`].
fn envelope_svg(panels: &[Envelope], titles: &[&str]) -> String {
    let (pw, ph, ml, mt, mb) = (440.0, 300.0, 60.0, 30.0, 45.0);
    let width = pw * panels.len() as f64 + 20.0;
    let height = ph;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" font-family=\"DejaVu Sans, sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    for (k, (env, title)) in panels.iter().zip(titles).enumerate() {
        let x0 = k as f64 * pw + ml;
        let (w, hgt) = (pw - ml - 20.0, ph - mt - mb);
        let t_max = 1.25 * env.deadline;
        let n = env.t.iter().take_while(|t| **t <= t_max).count();
        let top = env
            .v
            .iter()
            .take(n)
            .chain(env.w.iter().take(n))
            .fold(f64::MIN_POSITIVE, |a, b| a.max(*b));
        let hi = top.log10().ceil();
        let lo = (env.bound.max(1e-12).log10() - 3.0).floor().max(hi - 12.0);
        let px = |t: f64| x0 + w * t / t_max;
        let py = |v: f64| {
            let l = if v > 0.0 { v.log10().clamp(lo, hi) } else { lo };
            mt + hgt * (hi - l) / (hi - lo)
        };
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{title}</text>",
            x0 + w / 2.0
        );
        let _ = writeln!(
            s,
            "<rect x=\"{x0}\" y=\"{mt}\" width=\"{w}\" height=\"{hgt}\" fill=\"none\" stroke=\"black\"/>"
        );
        // Decades on the y axis.
        let mut d = lo;
        while d <= hi {
            let y = py(10f64.powf(d));
            let _ = writeln!(
                s,
                "<line x1=\"{x0}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{d}</text>",
                x0 + w,
                x0 - 4.0,
                y + 4.0
            );
            d += if hi - lo > 8.0 { 2.0 } else { 1.0 };
        }
        // Seconds on the x axis.
        let step = if t_max > 2.0 { 1.0 } else { 0.25 };
        let mut tk = 0.0;
        while tk <= t_max + 1e-9 {
            let x = px(tk);
            let _ = writeln!(
                s,
                "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"black\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">{tk}</text>",
                mt + hgt,
                mt + hgt + 5.0,
                mt + hgt + 18.0
            );
            tk += step;
        }
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">t (s)</text>",
            x0 + w / 2.0,
            mt + hgt + 35.0
        );
        // Deadline and bound.
        let xd = px(env.deadline);
        let yb = py(env.bound);
        let _ = writeln!(
            s,
            "<line x1=\"{xd}\" y1=\"{mt}\" x2=\"{xd}\" y2=\"{}\" stroke=\"gray\" stroke-dasharray=\"4 3\"/><text x=\"{}\" y=\"{}\" fill=\"gray\">2Tₛ</text>",
            mt + hgt,
            xd + 4.0,
            mt + hgt - 6.0
        );
        let _ = writeln!(
            s,
            "<line x1=\"{x0}\" y1=\"{yb}\" x2=\"{}\" y2=\"{yb}\" stroke=\"green\" stroke-dasharray=\"6 3\"/>",
            x0 + w
        );
        // Curves, at most 1,500 points each.
        let every = (n / 1500).max(1);
        for (series, colour) in [(&env.w, "crimson"), (&env.v, "steelblue")] {
            let pts: Vec<String> = env
                .t
                .iter()
                .zip(series.iter())
                .take(n)
                .step_by(every)
                .map(|(t, v)| format!("{:.1},{:.1}", px(*t), py(*v)))
                .collect();
            let _ = writeln!(
                s,
                "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" points=\"{}\"/>",
                pts.join(" ")
            );
        }
        // Legend.
        let (lx, ly) = (x0 + w - 190.0, mt + 14.0);
        let _ = writeln!(
            s,
            "<rect x=\"{}\" y=\"{}\" width=\"186\" height=\"50\" fill=\"white\" stroke=\"#ccc\"/>",
            lx - 4.0,
            ly - 10.0
        );
        for (j, (label, colour, dash)) in [
            ("measured V = ½Σe²", "steelblue", ""),
            ("envelope W of (4)", "crimson", ""),
            ("bound ζΓTₛ/π", "green", " stroke-dasharray=\"6 3\""),
        ]
        .iter()
        .enumerate()
        {
            let y = ly + 16.0 * j as f64;
            let _ = writeln!(
                s,
                "<line x1=\"{lx}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"{colour}\" stroke-width=\"1.5\"{dash}/><text x=\"{}\" y=\"{}\">{label}</text>",
                lx + 22.0,
                lx + 27.0,
                y + 4.0
            );
        }
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn initial_independence_returns_each_verdict() {
        let h = |k: u32| 1e-3 / f64::from(1u32 << k);
        assert_eq!(
            initial_independence(&[(h(0), 30), (h(1), 0), (h(2), 0)]),
            Verdict::Holds
        );
        assert_eq!(
            initial_independence(&[(h(0), 30), (h(1), 4), (h(2), 4)]),
            Verdict::DoesNotHold
        );
        assert_eq!(
            initial_independence(&[(h(0), 30), (h(1), 4), (h(2), 2)]),
            Verdict::Undecided,
            "the count never repeats"
        );
        assert_eq!(converged_h(&[(h(0), 30), (h(1), 0), (h(2), 0)]), Some(h(1)));
    }

    #[test]
    fn bounded_returns_each_verdict() {
        assert_eq!(bounded(0.1, 1.05, false), Verdict::Holds);
        assert_eq!(bounded(0.1, 1.5, false), Verdict::DoesNotHold);
        assert_eq!(bounded(0.1, 1.0, true), Verdict::Diverged);
        assert_eq!(bounded(0.1, f64::INFINITY, false), Verdict::Diverged);
    }

    #[test]
    fn below_envelope_returns_each_verdict() {
        assert_eq!(
            below_envelope(&[1.0, 0.5], &[1.0, 0.6], false),
            Verdict::Holds
        );
        assert_eq!(
            below_envelope(&[1.0, 0.7], &[1.0, 0.6], false),
            Verdict::DoesNotHold
        );
        assert_eq!(below_envelope(&[1.0], &[1.0], true), Verdict::Diverged);
        assert_eq!(below_envelope(&[], &[], false), Verdict::Undecided);
    }

    #[test]
    fn differentiator_tracks_returns_each_verdict() {
        assert_eq!(differentiator_tracks(0.1, 0.5, 10.0, false), Verdict::Holds);
        assert_eq!(
            differentiator_tracks(0.1, 5.0, 10.0, false),
            Verdict::DoesNotHold
        );
        assert_eq!(
            differentiator_tracks(0.1, 0.5, 10.0, true),
            Verdict::Diverged
        );
    }

    #[test]
    fn matches_paper_returns_each_verdict() {
        assert_eq!(matches_paper(Some((40.0, 5.0)), Some(44.0)), Verdict::Holds);
        assert_eq!(
            matches_paper(Some((40.0, 5.0)), Some(47.2)),
            Verdict::DoesNotHold
        );
        assert_eq!(matches_paper(Some((40.0, 5.0)), None), Verdict::Diverged);
        assert_eq!(matches_paper(None, Some(47.2)), Verdict::Undecided);
    }

    #[test]
    fn comparison_solution_settles_to_its_equilibrium() {
        // Without Γ, W reaches zero before T_s (the predefined time of Lemma 2 with Γ = 0).
        let t: Vec<f64> = (0..=400).map(|k| f64::from(k) * 0.01).collect();
        let w = comparison_solution(&t, 50.0, 0.5, 2.0, 0.0);
        let zero_at = t.iter().zip(&w).find(|(_, w)| **w < 1e-9).map(|(t, _)| *t);
        assert!(zero_at.is_some_and(|z| z <= 2.0), "{zero_at:?}");
        // With Γ, it rests where the decay balances Γ, inside ζΓT_s/π's order.
        let g = comparison_solution(&t, 50.0, 0.5, 2.0, 1.0);
        let last = g.last().copied().unwrap_or(f64::NAN);
        let k = std::f64::consts::PI / (0.5 * 2.0);
        let rate = k * (last.powf(1.25) + last.powf(0.75));
        assert!((rate - 1.0).abs() < 1e-6, "equilibrium: {last}, {rate}");
    }

    #[test]
    fn svg_has_both_panels_and_curves() {
        let env = Envelope {
            zeta: 0.5,
            ts: 1.0,
            t: vec![0.0, 1.0, 2.0, 4.0],
            v: vec![1.0, 0.1, 0.01, 0.01],
            w: vec![1.0, 0.2, 0.02, 0.02],
            gamma: 0.1,
            bound: 0.01,
            deadline: 2.0,
            diverged: false,
        };
        assert_eq!(env.verdict(), Verdict::Holds);
        assert_eq!(bounded(0.1, 0.9, false), Verdict::Holds);
        assert_eq!(env.excess(), (None, 1.0));
        let s = envelope_svg(&[env], &["Example 1"]);
        assert_eq!(s.matches("<polyline").count(), 2);
        assert!(s.contains("Example 1") && s.ends_with("</svg>\n"));
    }
}
