//! `[clock]`: a free-running clock per follower, and the figures of a clocked run
//! (docs/CLOCKS.md).
//!
//! Follower `i` (0-based) samples at the true instants `s_{i,k} = o_i + k h (1 + δ_i) + j_{i,k}`
//! (`sync = "none"`), or `j_{i,k}` after the leader frame of sample `k` reached it
//! (`sync = "leader"`); its clock reads `(t − o_i) / (1 + δ_i)`. `δ_i` is `drift_ppm · 1e-6`
//! (positive: a slow clock, samples further apart), `o_i` is `offset_us`, and the jitter
//! `j_{i,k}` is uniform on `[0, jitter_us]` (interrupt latency: never early), drawn from the
//! ChaCha8 stream `i + 1` of `seed` as 53-bit uniforms. With `draw = "uniform"`, each
//! follower's `δ_i` and `o_i` are drawn once, uniform on `[−|v_i|, |v_i|]`, from stream 0.

use rand_chacha::{
    rand_core::{Rng, SeedableRng},
    ChaCha8Rng,
};
use serde::{Deserialize, Serialize};

use consensus_plot::error::{Error, Problems, Result};

/// A value for every follower, or one per follower.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "a number, or a list of numbers with one per follower"
)]
pub enum PerFollower {
    /// The same for all.
    All(f64),
    /// One per follower, in agent order.
    Each(Vec<f64>),
}

impl Default for PerFollower {
    fn default() -> Self {
        Self::All(0.0)
    }
}

impl PerFollower {
    fn is_zero(&self) -> bool {
        match self {
            Self::All(v) => *v == 0.0,
            Self::Each(v) => v.iter().all(|v| *v == 0.0),
        }
    }

    /// The value of each of `followers`, each finite and accepted by `ok` (its reason else).
    fn resolve(
        &self,
        key: &str,
        followers: usize,
        ok: impl Fn(f64) -> std::result::Result<(), String>,
    ) -> Result<Vec<f64>> {
        let values = match self {
            Self::All(v) => vec![*v; followers],
            Self::Each(v) if v.len() == followers => v.clone(),
            Self::Each(v) => {
                return Err(Error::invalid(
                    format!("clock.{key}"),
                    format!(
                        "a list needs one value per follower ({followers}), got {}",
                        v.len()
                    ),
                ))
            }
        };
        let mut problems = Problems::default();
        for (i, &v) in values.iter().enumerate() {
            let name = match self {
                Self::All(_) => format!("clock.{key}"),
                Self::Each(_) => format!("clock.{key}[{}]", i + 1),
            };
            let check = if v.is_finite() {
                ok(v)
            } else {
                Err(format!("must be a finite number (got {v})"))
            };
            if let Err(reason) = check {
                problems.push(Error::invalid(name, reason));
                if matches!(self, Self::All(_)) {
                    break;
                }
            }
        }
        problems.finish(values)
    }
}

/// `clock.sync`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SyncMode {
    /// Every follower samples on its own clock.
    #[default]
    None,
    /// The leader's frame of each sample releases every follower's sampling (CANopen SYNC).
    Leader,
}

impl SyncMode {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Leader => "leader",
        }
    }
}

/// `clock.draw`: how `drift_ppm` and `offset_us` are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Draw {
    /// As written.
    #[default]
    Fixed,
    /// Drawn once per follower, uniform on `[−|v|, |v|]`, from `seed`.
    Uniform,
}

/// `[clock]` (docs/CLOCKS.md).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClockSpec {
    /// Relative error of each follower's sample period \[ppm\] (positive: slow).
    pub drift_ppm: PerFollower,
    /// Upper bound of the uniform delay of each sample after its clock tick or release \[µs\].
    pub jitter_us: PerFollower,
    /// True time of each follower's sample 0 \[µs\].
    pub offset_us: PerFollower,
    /// Seed of the jitter (and of the drawn drifts and offsets).
    pub seed: u64,
    /// `"none"` or `"leader"`.
    pub sync: SyncMode,
    /// `"fixed"` or `"uniform"`.
    pub draw: Draw,
}

/// Largest `|drift_ppm|`.
pub const MAX_DRIFT_PPM: f64 = 100_000.0;
/// `jitter_us` stays below this many sample periods (a period is at least `0.9 h`).
pub const MAX_JITTER_PERIODS: f64 = 0.9;
/// Largest `|offset_us|`.
pub const MAX_OFFSET_US: f64 = 1e6;

impl ClockSpec {
    /// The section is left out (`check` does not print it).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Some follower's sampling differs from the plant's instants `k h`.
    pub fn is_active(&self) -> bool {
        self.sync == SyncMode::Leader
            || !(self.drift_ppm.is_zero() && self.jitter_us.is_zero() && self.offset_us.is_zero())
    }

    /// The clocks of `followers` at sample period `h` \[s\]; every bad value named by its key.
    pub fn plan(&self, followers: usize, h: f64) -> Result<ClockPlan> {
        let mut problems = Problems::default();
        let drift = problems.take(self.drift_ppm.resolve("drift_ppm", followers, |v| {
            if v.abs() <= MAX_DRIFT_PPM {
                Ok(())
            } else {
                Err(format!(
                    "must lie in [-{MAX_DRIFT_PPM}, {MAX_DRIFT_PPM}] ppm (got {v})"
                ))
            }
        }));
        let bound = h * MAX_JITTER_PERIODS * 1e6;
        let jitter = problems.take(self.jitter_us.resolve("jitter_us", followers, |v| {
            if v < 0.0 {
                Err(format!("must be >= 0 µs (got {v})"))
            } else if v >= bound {
                Err(format!(
                    "must be below 0.9 h = {bound:.1} µs, so that at any allowed drift a \
                     follower's samples stay in order (got {v})"
                ))
            } else {
                Ok(())
            }
        }));
        let offset = problems.take(self.offset_us.resolve("offset_us", followers, |v| {
            if v.abs() <= MAX_OFFSET_US {
                Ok(())
            } else {
                Err(format!(
                    "must lie in [-{MAX_OFFSET_US}, {MAX_OFFSET_US}] µs (got {v})"
                ))
            }
        }));
        let (Some(mut drift), Some(jitter), Some(mut offset)) = (drift, jitter, offset) else {
            return Err(problems
                .into_error()
                .unwrap_or_else(|| Error::Invalid("clock".into())));
        };
        if self.draw == Draw::Uniform {
            let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
            for v in drift.iter_mut().chain(offset.iter_mut()) {
                *v *= 2.0 * unit(&mut rng) - 1.0;
            }
        }
        let clocks = (0..followers)
            .map(|i| Clock {
                period: h * (1.0 + drift[i] * 1e-6),
                drift: drift[i] * 1e-6,
                offset: offset[i] * 1e-6,
                jitter: jitter[i] * 1e-6,
            })
            .collect();
        Ok(ClockPlan {
            clocks,
            seed: self.seed,
            sync: self.sync,
            h,
        })
    }
}

/// A uniform on `[0, 1)` from the top 53 bits of one draw.
fn unit(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// One follower's clock, resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    /// True time between two clock ticks \[s\].
    pub period: f64,
    /// `δ` (relative).
    pub drift: f64,
    /// True time of tick 0 \[s\].
    pub offset: f64,
    /// Bound of the uniform sampling delay \[s\].
    pub jitter: f64,
}

impl Clock {
    /// The clock's reading at true time `t`, whole µs (0 before tick 0).
    pub fn local_us(&self, t: f64) -> u64 {
        ((t - self.offset) / (1.0 + self.drift) * 1e6).max(0.0) as u64
    }
}

/// The validated `[clock]` of a scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct ClockPlan {
    /// Per follower.
    pub clocks: Vec<Clock>,
    /// Jitter seed.
    pub seed: u64,
    /// Sampling release.
    pub sync: SyncMode,
    /// Nominal sample period \[s\].
    pub h: f64,
}

/// Points of each follower's series in the clock figure (at most).
const SERIES_POINTS: u64 = 2_000;

/// The clocks running: jitter streams, each follower's next tick, and what the run measured.
#[derive(Debug, Clone)]
pub struct Clocks {
    plan: ClockPlan,
    rngs: Vec<ChaCha8Rng>,
    /// Per follower, the index of its next own tick (`sync = "none"`).
    tick: Vec<u64>,
    ages: Histogram,
    errors: Histogram,
    /// Per follower `(t, s − k h)` [s] of every `every`-th sample.
    series: Vec<Vec<(f64, f64)>>,
    every: u64,
    taken: Vec<u64>,
}

impl Clocks {
    /// The clocks of `plan` for a run of `samples` samples.
    pub fn new(plan: &ClockPlan, samples: u64) -> Self {
        let n = plan.clocks.len();
        let rngs = (0..n)
            .map(|i| {
                let mut r = ChaCha8Rng::seed_from_u64(plan.seed);
                r.set_stream(i as u64 + 1);
                r
            })
            .collect();
        Self {
            plan: plan.clone(),
            rngs,
            tick: vec![0; n],
            ages: Histogram::default(),
            errors: Histogram::default(),
            series: vec![Vec::new(); n],
            every: samples.div_ceil(SERIES_POINTS).max(1),
            taken: vec![0; n],
        }
    }

    /// The sampling release.
    pub fn sync(&self) -> SyncMode {
        self.plan.sync
    }

    /// Follower `i`'s clock reading at true time `t` \[µs\].
    pub fn local_us(&self, i: usize, t: f64) -> u64 {
        self.plan.clocks[i].local_us(t)
    }

    /// A fresh sampling delay of follower `i` \[s\].
    pub fn jitter(&mut self, i: usize) -> f64 {
        let j = self.plan.clocks[i].jitter;
        if j == 0.0 {
            0.0
        } else {
            j * unit(&mut self.rngs[i])
        }
    }

    /// Follower `i`'s next own sample `(s, k)` at or after true time 0 (`sync = "none"`).
    pub fn next_own(&mut self, i: usize) -> (f64, u64) {
        let c = self.plan.clocks[i];
        loop {
            let k = self.tick[i];
            self.tick[i] += 1;
            let s = c.offset + k as f64 * c.period + self.jitter(i);
            if s >= 0.0 {
                return (s, k);
            }
        }
    }

    /// Records follower `i`'s sample `k` taken at true time `s`.
    pub fn sampled(&mut self, i: usize, k: u64, s: f64) {
        let err = s - k as f64 * self.plan.h;
        self.errors.add(err.abs() / self.plan.h);
        if self.taken[i].is_multiple_of(self.every) {
            self.series[i].push((s, err));
        }
        self.taken[i] += 1;
    }

    /// Records the age \[s\] of a neighbour or leader value a follower used.
    pub fn age(&mut self, age: f64) {
        self.ages.add(age / self.plan.h);
    }

    /// Per follower, `(t, s − k h)` \[s\] at some of its samples (the clock figure).
    pub fn series(&self) -> &[Vec<(f64, f64)>] {
        &self.series
    }

    /// The figures of `summary.json` `clock`.
    pub fn summary(&self) -> ClockSummary {
        ClockSummary {
            sync: self.plan.sync,
            sample_age: self.ages.spread(),
            sampling_error: self.errors.spread(),
            samples_taken: self.taken.iter().sum(),
        }
    }
}

/// Median, 99th percentile and maximum of a distribution.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    /// Median (nearest rank, rounded down to [`RESOLUTION`]).
    pub median: f64,
    /// 99th percentile (nearest rank, rounded down to [`RESOLUTION`]).
    pub p99: f64,
    /// Maximum (exact).
    pub max: f64,
    /// Values counted.
    pub count: u64,
}

/// `summary.json` `clock` (runs with an active `[clock]`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClockSummary {
    /// `"none"` or `"leader"`.
    pub sync: SyncMode,
    /// Age of the neighbour and leader values the controllers used, at their use \[samples\].
    pub sample_age: Spread,
    /// `|s_{i,k} − k h|` over every follower sample \[samples\].
    pub sampling_error: Spread,
    /// Samples the followers took, summed.
    pub samples_taken: u64,
}

/// Bin width of the distributions \[samples\].
pub const RESOLUTION: f64 = 1e-3;
/// Bins kept; larger values only count (their quantile reads as the maximum).
const BINS: usize = 1 << 20;

/// Counts of non-negative values in bins of [`RESOLUTION`].
#[derive(Debug, Clone, Default)]
struct Histogram {
    counts: Vec<u64>,
    over: u64,
    n: u64,
    max: f64,
}

impl Histogram {
    fn add(&mut self, v: f64) {
        self.n += 1;
        if !v.is_finite() {
            self.max = f64::INFINITY;
            self.over += 1;
            return;
        }
        let v = v.max(0.0);
        self.max = self.max.max(v);
        let b = (v / RESOLUTION) as usize;
        if b < BINS {
            if b >= self.counts.len() {
                self.counts.resize(b + 1, 0);
            }
            self.counts[b] += 1;
        } else {
            self.over += 1;
        }
    }

    /// The value of rank `⌈p n⌉` (1-based).
    fn quantile(&self, p: f64) -> f64 {
        let rank = ((p * self.n as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return b as f64 * RESOLUTION;
            }
        }
        self.max
    }

    fn spread(&self) -> Spread {
        Spread {
            median: self.quantile(0.5),
            p99: self.quantile(0.99),
            max: self.max,
            count: self.n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(drift: PerFollower) -> ClockSpec {
        ClockSpec {
            drift_ppm: drift,
            ..ClockSpec::default()
        }
    }

    #[test]
    fn a_100_ppm_drift_moves_the_samples_apart_at_that_rate() -> Result<()> {
        let h = 1e-3;
        let plan = spec(PerFollower::Each(vec![100.0, 0.0])).plan(2, h)?;
        let mut c = Clocks::new(&plan, 100_000);
        for _ in 0..100_000 {
            let (a, ka) = c.next_own(0);
            let (b, kb) = c.next_own(1);
            assert_eq!(ka, kb);
            let expected = ka as f64 * h * 100e-6;
            assert!(
                ((a - b) - expected).abs() < 1e-12,
                "k {ka}: {} vs {expected}",
                a - b
            );
        }
        Ok(())
    }

    #[test]
    fn jitter_stays_in_its_bound_and_repeats_with_the_seed() -> Result<()> {
        let seed = 7;
        println!("seed {seed}");
        let s = ClockSpec {
            jitter_us: PerFollower::All(200.0),
            seed,
            ..ClockSpec::default()
        };
        let plan = s.plan(3, 1e-3)?;
        let draw = |plan: &ClockPlan| {
            let mut c = Clocks::new(plan, 10);
            (0..1000).map(|_| c.next_own(2)).collect::<Vec<_>>()
        };
        let a = draw(&plan);
        assert_eq!(a, draw(&plan));
        for (s, k) in a {
            let j = s - k as f64 * 1e-3;
            assert!((0.0..200e-6).contains(&j), "jitter {j}");
        }
        Ok(())
    }

    #[test]
    fn bad_values_name_their_key() {
        let msg = |s: ClockSpec| {
            s.plan(4, 1e-3)
                .map(|_| ())
                .expect_err("invalid")
                .to_string()
        };
        let m = msg(spec(PerFollower::Each(vec![1.0, 2.0])));
        assert!(
            m.contains("clock.drift_ppm") && m.contains("one value per follower (4)"),
            "{m}"
        );
        let m = msg(spec(PerFollower::Each(vec![0.0, f64::NAN, 0.0, 0.0])));
        assert!(
            m.contains("clock.drift_ppm[2]") && m.contains("finite"),
            "{m}"
        );
        let m = msg(ClockSpec {
            jitter_us: PerFollower::All(-1.0),
            ..ClockSpec::default()
        });
        assert!(m.contains("clock.jitter_us") && m.contains(">= 0"), "{m}");
        let m = msg(ClockSpec {
            jitter_us: PerFollower::All(950.0),
            ..ClockSpec::default()
        });
        assert!(m.contains("clock.jitter_us") && m.contains("0.9 h"), "{m}");
        let m = msg(ClockSpec {
            offset_us: PerFollower::All(f64::INFINITY),
            ..ClockSpec::default()
        });
        assert!(m.contains("clock.offset_us"), "{m}");
    }

    #[test]
    fn quantiles_are_nearest_rank() {
        let mut h = Histogram::default();
        for v in [0.0, 0.5, 1.0, 1.0, 2.0] {
            h.add(v);
        }
        let s = h.spread();
        assert_eq!((s.median, s.max, s.count), (1.0, 2.0, 5));
        assert_eq!(s.p99, 2.0);
    }
}
