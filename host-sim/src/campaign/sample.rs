//! Monte Carlo draws: one `[[sample]]` per key, drawn from a ChaCha8 stream seeded by the
//! campaign seed and the run index, so a run's values depend on neither the thread count nor
//! the shard that runs it.

use rand_chacha::{
    rand_core::{Rng, SeedableRng},
    ChaCha8Rng,
};
use serde::{Deserialize, Serialize};

use consensus_plot::error::{Error, Result};

/// Distribution of a `[[sample]]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Dist {
    /// Uniform on `[low, high)`.
    Uniform,
    /// Normal with `mean`, `std`, optionally truncated to `[low, high]` (redrawn).
    Normal,
    /// `exp` of uniform on `[ln low, ln high)` (`0 < low < high`).
    LogUniform,
    /// One of `values`, each equally likely (any TOML values).
    Choice,
    /// An integer uniform on `[0, 2^31)`: a fresh seed per run (e.g. `network.seed`).
    Seed,
}

/// One `[[sample]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sample {
    /// Scenario key (dotted, 1-based `[i]` for array entries).
    pub key: String,
    /// Distribution.
    pub dist: Dist,
    /// Lower bound (uniform, log-uniform; truncation of normal).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub low: Option<f64>,
    /// Upper bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub high: Option<f64>,
    /// Normal mean.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean: Option<f64>,
    /// Normal standard deviation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
    /// Choice values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<Vec<toml::Value>>,
}

/// Redraws of a truncated normal before giving up (then the nearer bound is used).
const MAX_REDRAWS: usize = 1000;

/// The random stream of run `run` of a campaign seeded with `seed`.
pub fn run_rng(seed: u64, run: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(run);
    rng
}

/// Uniform on `[0, 1)` with 53 random bits.
fn unit(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Standard normal (Box–Muller, one value per pair of uniforms).
fn std_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1 = 1.0 - unit(rng);
    let u2 = unit(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl Sample {
    /// Checks the parameters of the distribution; `what` is e.g. `sample[2]`.
    pub fn check(&self, what: &str) -> Result<()> {
        let need = |v: Option<f64>, k: &str| -> Result<f64> {
            let v = v.ok_or_else(|| {
                Error::invalid(
                    format!("{what}.{k}"),
                    format!("required for {:?}", self.dist),
                )
            })?;
            if !v.is_finite() {
                return Err(Error::invalid(format!("{what}.{k}"), "must be finite"));
            }
            Ok(v)
        };
        let unused = |present: bool, k: &str| -> Result<()> {
            if present {
                return Err(Error::invalid(
                    format!("{what}.{k}"),
                    format!("not a parameter of {:?}", self.dist),
                ));
            }
            Ok(())
        };
        match self.dist {
            Dist::Uniform | Dist::LogUniform => {
                let (lo, hi) = (need(self.low, "low")?, need(self.high, "high")?);
                if lo >= hi {
                    return Err(Error::invalid(format!("{what}.high"), "must be > low"));
                }
                if self.dist == Dist::LogUniform && lo <= 0.0 {
                    return Err(Error::invalid(format!("{what}.low"), "must be > 0"));
                }
                unused(self.mean.is_some(), "mean")?;
                unused(self.std.is_some(), "std")?;
                unused(self.values.is_some(), "values")
            }
            Dist::Normal => {
                need(self.mean, "mean")?;
                if need(self.std, "std")? <= 0.0 {
                    return Err(Error::invalid(format!("{what}.std"), "must be > 0"));
                }
                if let (Some(lo), Some(hi)) = (self.low, self.high) {
                    if lo.is_nan() || hi.is_nan() || lo >= hi {
                        return Err(Error::invalid(format!("{what}.high"), "must be > low"));
                    }
                }
                unused(self.values.is_some(), "values")
            }
            Dist::Choice => {
                if self.values.as_ref().is_none_or(Vec::is_empty) {
                    return Err(Error::invalid(
                        format!("{what}.values"),
                        "required, not empty",
                    ));
                }
                unused(self.low.is_some() || self.high.is_some(), "low/high")?;
                unused(self.mean.is_some() || self.std.is_some(), "mean/std")
            }
            Dist::Seed => {
                unused(self.low.is_some() || self.high.is_some(), "low/high")?;
                unused(self.mean.is_some() || self.std.is_some(), "mean/std")?;
                unused(self.values.is_some(), "values")
            }
        }
    }

    /// A value of the right kind for checking the key.
    pub fn example(&self) -> toml::Value {
        match (self.dist, &self.values) {
            (Dist::Choice, Some(v)) if !v.is_empty() => v[0].clone(),
            (Dist::Seed, _) => toml::Value::Integer(0),
            _ => toml::Value::Float(self.low.or(self.mean).unwrap_or(0.0)),
        }
    }

    /// One draw (parameters checked by [`Sample::check`]).
    pub fn draw(&self, rng: &mut ChaCha8Rng) -> toml::Value {
        let (lo, hi) = (self.low.unwrap_or(0.0), self.high.unwrap_or(1.0));
        let x = match self.dist {
            Dist::Uniform => lo + (hi - lo) * unit(rng),
            Dist::LogUniform => (lo.ln() + (hi.ln() - lo.ln()) * unit(rng)).exp(),
            Dist::Normal => {
                let (m, s) = (self.mean.unwrap_or(0.0), self.std.unwrap_or(1.0));
                let lo = self.low.unwrap_or(f64::NEG_INFINITY);
                let hi = self.high.unwrap_or(f64::INFINITY);
                let mut x = m + s * std_normal(rng);
                for _ in 0..MAX_REDRAWS {
                    if (lo..=hi).contains(&x) {
                        break;
                    }
                    x = m + s * std_normal(rng);
                }
                x.clamp(lo, hi)
            }
            Dist::Choice => {
                let v = self.values.as_deref().unwrap_or_default();
                let i = (rng.next_u64() % v.len().max(1) as u64) as usize;
                return v.get(i).cloned().unwrap_or(toml::Value::Integer(0));
            }
            Dist::Seed => return toml::Value::Integer((rng.next_u64() >> 33) as i64),
        };
        toml::Value::Float(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(dist: Dist) -> Sample {
        Sample {
            key: "k".into(),
            dist,
            low: None,
            high: None,
            mean: None,
            std: None,
            values: None,
        }
    }

    #[test]
    fn draws_depend_only_on_seed_and_run() {
        let u = Sample {
            low: Some(-1.0),
            high: Some(3.0),
            ..s(Dist::Uniform)
        };
        let a = u.draw(&mut run_rng(7, 12));
        assert_eq!(a, u.draw(&mut run_rng(7, 12)));
        assert_ne!(a, u.draw(&mut run_rng(7, 13)));
        assert_ne!(a, u.draw(&mut run_rng(8, 12)));
    }

    #[test]
    fn draws_respect_their_distributions() {
        let u = Sample {
            low: Some(-1.0),
            high: Some(3.0),
            ..s(Dist::Uniform)
        };
        let l = Sample {
            low: Some(1e-3),
            high: Some(1e-1),
            ..s(Dist::LogUniform)
        };
        let n = Sample {
            mean: Some(2.0),
            std: Some(0.5),
            low: Some(1.5),
            ..s(Dist::Normal)
        };
        let (mut su, mut below) = (0.0, 0);
        let count = 20_000;
        for run in 0..count {
            let mut rng = run_rng(1, run);
            let x = u.draw(&mut rng).as_float().unwrap_or(f64::NAN);
            assert!((-1.0..3.0).contains(&x));
            su += x;
            let y = l.draw(&mut rng).as_float().unwrap_or(f64::NAN);
            assert!((1e-3..1e-1).contains(&y));
            if y < 1e-2 {
                below += 1;
            }
            let z = n.draw(&mut rng).as_float().unwrap_or(f64::NAN);
            assert!(z >= 1.5);
        }
        assert!((su / count as f64 - 1.0).abs() < 0.05, "uniform mean");
        let half = f64::from(below) / count as f64;
        assert!(
            (half - 0.5).abs() < 0.02,
            "log-uniform: half below 1e-2, got {half}"
        );
    }

    #[test]
    fn parameters_are_checked_by_name() {
        let bad = Sample {
            low: Some(2.0),
            high: Some(1.0),
            ..s(Dist::Uniform)
        };
        assert!(bad
            .check("sample[1]")
            .is_err_and(|e| e.to_string().contains("sample[1].high")));
        let neg = Sample {
            low: Some(0.0),
            high: Some(1.0),
            ..s(Dist::LogUniform)
        };
        assert!(neg
            .check("sample[2]")
            .is_err_and(|e| e.to_string().contains("sample[2].low")));
        assert!(s(Dist::Choice).check("sample[3]").is_err());
        assert!(s(Dist::Seed).check("sample[4]").is_ok());
    }
}
