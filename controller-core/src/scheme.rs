//! The stabilising term that tells the proposed scheme from the baseline: the predefined-time
//! `k_1 M(e) + k_2 N(e)` of (17)–(19), or the prescribed-time `(c_1 + c_2 μ_T(t)) e` of the
//! LAW §10 baseline. Everything else of the backstepping design is shared.

use crate::{error::ConfigError, gains::Gains, math, param::Param, powers::Powers};

/// Which scheme a controller runs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum SchemeConfig {
    /// The paper's predefined-time law (default).
    #[default]
    PredefinedTime,
    /// The LAW §10 prescribed-time baseline.
    PrescribedTime(BaselineConfig),
}

/// Parameters of the prescribed-time scaling `μ_T(t) = (T/(T−t))^κ`, clamped at `μ_max`.
///
/// A representative member of the time-varying-scaling family the paper compares against in its
/// Fig. 8, not a copy of its (unavailable) ref. \[39\].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BaselineConfig {
    /// `κ > 0` (default 2).
    pub kappa: f32,
    /// `μ_max ≥ 1` (default 10): the clamp before `T` and the value after it.
    pub mu_max: f32,
    /// `T`; `None` takes `T_s`.
    pub t_prescribed: Option<f32>,
}

impl Default for BaselineConfig {
    fn default() -> Self {
        Self {
            kappa: const { Param::Kappa.default_f32() },
            mu_max: const { Param::MuMax.default_f32() },
            t_prescribed: None,
        }
    }
}

/// A validated scheme.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Scheme {
    /// `k_1 M(e) + k_2 N(e)`.
    PredefinedTime {
        /// `k_1`.
        k1: f32,
        /// `k_2`.
        k2: f32,
        /// `M`, `N` of `ζ`.
        powers: Powers,
    },
    /// `(c_1 + c_2 μ_T(t)) e`.
    PrescribedTime {
        /// `c_1`.
        c1: f32,
        /// `c_2`.
        c2: f32,
        /// `κ`.
        kappa: f32,
        /// `μ_max`.
        mu_max: f32,
        /// `T`.
        t_prescribed: f32,
    },
}

/// The stabilising term of one sample (the time-varying gain of the baseline already evaluated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feedback {
    /// `k_1 M(e) + k_2 N(e)`.
    PredefinedTime {
        /// `k_1`.
        k1: f32,
        /// `k_2`.
        k2: f32,
        /// `M`, `N`.
        powers: Powers,
    },
    /// `g e` with `g = c_1 + c_2 μ_T(t)`.
    Linear(f32),
}

impl Scheme {
    /// Validates the scheme's own parameters; `ts` is the fallback `T` of the baseline.
    pub fn new(cfg: &SchemeConfig, gains: &Gains, zeta: f32, ts: f32) -> Result<Self, ConfigError> {
        Ok(match cfg {
            SchemeConfig::PredefinedTime => Self::PredefinedTime {
                k1: gains.k1,
                k2: gains.k2,
                powers: Powers::new(zeta),
            },
            SchemeConfig::PrescribedTime(b) => {
                let kappa = Param::Kappa.check(b.kappa)?;
                let mu_max = Param::MuMax.check(b.mu_max)?;
                let t_prescribed = match b.t_prescribed {
                    Some(t) => Param::TPrescribed.check(t)?,
                    None => ts,
                };
                Self::PrescribedTime {
                    c1: gains.c1,
                    c2: gains.c2,
                    kappa,
                    mu_max,
                    t_prescribed,
                }
            }
        })
    }

    /// The stabilising term at time `t` (one `powf` per sample for the baseline before `T`).
    #[inline]
    pub fn feedback_at(&self, t: f32) -> Feedback {
        match *self {
            Self::PredefinedTime { k1, k2, powers } => Feedback::PredefinedTime { k1, k2, powers },
            Self::PrescribedTime {
                c1,
                c2,
                kappa,
                mu_max,
                t_prescribed,
            } => Feedback::Linear(c1 + c2 * scaling(t, t_prescribed, kappa, mu_max)),
        }
    }
}

/// `μ_T(t) = (T/(T−t))^κ` for `t < T`, clamped at `μ_max`; `μ_max` from `T` on.
///
/// ```
/// use controller_core::scheme::scaling;
/// // Within the per-step power's error (a few ulp; 1e-6 with `fast-math`).
/// assert!((scaling(0.0, 1.0, 2.0, 10.0) - 1.0).abs() < 1e-5);
/// assert!((scaling(0.5, 1.0, 2.0, 10.0) - 4.0).abs() < 1e-4);
/// assert_eq!(scaling(0.99, 1.0, 2.0, 10.0), 10.0);
/// assert_eq!(scaling(3.0, 1.0, 2.0, 10.0), 10.0);
/// ```
#[inline]
pub fn scaling(t: f32, t_prescribed: f32, kappa: f32, mu_max: f32) -> f32 {
    if t >= t_prescribed {
        mu_max
    } else {
        // `min(mu_max)` written out (NaN or ∞ give `mu_max`, as `f32::min` does).
        let s = math::pow_pos(t_prescribed / (t_prescribed - t), kappa);
        if s < mu_max {
            s
        } else {
            mu_max
        }
    }
}

impl Feedback {
    /// The stabilising term of one error `e`.
    #[inline]
    pub fn term(&self, e: f32) -> f32 {
        match *self {
            Self::PredefinedTime { k1, k2, powers } => {
                let (m, n) = powers.m_n(e);
                k1 * m + k2 * n
            }
            Self::Linear(g) => g * e,
        }
    }
}
