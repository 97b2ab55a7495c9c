//! The stabilising term that tells the proposed scheme from the baseline: the predefined-time
//! `k_1 M(e) + k_2 N(e)` of (17)–(19), or the prescribed-time `(c_1 + c_2 μ_T(t)) e` of the
//! LAW §10 baseline. Everything else of the backstepping design is shared.

use crate::{error::ConfigError, gains::Gains, math, param::Param, powers::Powers};

/// Which scheme a controller runs.
///
/// ```
/// use controller_core::{param::Param, BaselineConfig, Controller, ControllerConfig, SchemeConfig};
/// // Example 2's comparison (LAW §10): the prescribed-time baseline.
/// let baseline = ControllerConfig::<2> {
///     scheme: SchemeConfig::PrescribedTime(BaselineConfig::default()),
///     ..Default::default()
/// };
/// assert!(Controller::<2, 2, 0>::new(&baseline).is_ok());
/// // κ must be > 0: the error names the baseline's key.
/// let bad = ControllerConfig::<2> {
///     scheme: SchemeConfig::PrescribedTime(BaselineConfig { kappa: 0.0, ..Default::default() }),
///     ..Default::default()
/// };
/// assert_eq!(Controller::<2, 2, 0>::new(&bad).unwrap_err().param(), Param::Kappa);
/// ```
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
///
/// ```
/// use controller_core::BaselineConfig;
/// let b = BaselineConfig::default();
/// assert_eq!((b.kappa, b.mu_max, b.t_prescribed), (2.0, 10.0, None)); // LAW §10; T = T_s
/// ```
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
///
/// ```
/// use controller_core::scheme::{Feedback, Scheme};
/// use controller_core::{Gains, SchemeConfig};
/// let g = Gains::predefined_time(2.0, 0.1, 2, 80.0, 50.0, 50.0)?;
/// let s = Scheme::new(&SchemeConfig::PredefinedTime, &g, 0.1, 2.0)?;
/// assert!(matches!(s, Scheme::PredefinedTime { k1, k2, .. } if k1 == g.k1 && k2 == g.k2));
/// // The predefined-time term does not depend on t.
/// assert_eq!(s.feedback_at(0.0), s.feedback_at(100.0));
/// assert!(matches!(s.feedback_at(0.0), Feedback::PredefinedTime { .. }));
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
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
///
/// ```
/// use controller_core::powers::Powers;
/// use controller_core::scheme::Feedback;
/// let f = Feedback::PredefinedTime { k1: 2.0, k2: 3.0, powers: Powers::new(0.5) };
/// // k_1 M(e) + k_2 N(e) at e = 4: 2 · 4^1.5 + 3 · 4^0.5 = 16 + 6 (`micromath`: within 1.2 %).
/// let tol = if cfg!(feature = "micromath") { 0.27 } else { 1e-4 };
/// assert!((f.term(4.0) - 22.0).abs() < tol);
/// assert_eq!(f.term(-4.0), -f.term(4.0)); // odd in e
/// assert_eq!(Feedback::Linear(5.0).term(-0.5), -2.5);
/// ```
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
    ///
    /// ```
    /// use controller_core::scheme::Scheme;
    /// use controller_core::{BaselineConfig, Gains, SchemeConfig};
    /// let g = Gains::explicit(10.0, 9.0, 0.6)?;
    /// let cfg = SchemeConfig::PrescribedTime(BaselineConfig::default());
    /// // T_s = 1 of Example 2's baseline stands in for T.
    /// let s = Scheme::new(&cfg, &g, 0.6, 1.0)?;
    /// assert!(matches!(s, Scheme::PrescribedTime { t_prescribed, c1, .. } if t_prescribed == 1.0 && c1 == 10.0));
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
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
    ///
    /// ```
    /// use controller_core::scheme::{Feedback, Scheme};
    /// use controller_core::{BaselineConfig, Gains, SchemeConfig};
    /// let g = Gains::explicit(10.0, 9.0, 0.6)?;
    /// let cfg = SchemeConfig::PrescribedTime(BaselineConfig::default());
    /// let s = Scheme::new(&cfg, &g, 0.6, 1.0)?;
    /// // (c_1 + c_2 μ_T(t)) with μ_T(0) = 1 and μ_T = μ_max = 10 from T on.
    /// let gain = |t| match s.feedback_at(t) {
    ///     Feedback::Linear(g) => g,
    ///     _ => f32::NAN,
    /// };
    /// assert!((gain(0.0) - 19.0).abs() < 1e-4);
    /// assert_eq!(gain(1.0), 100.0);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    #[must_use]
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
/// // Within the per-step power's error (a few ulp; 1e-6 with `fast-math`; 1.2 % with
/// // `micromath`).
/// let tol = if cfg!(feature = "micromath") { 1.2e-2 } else { 2.5e-5 }; // relative
/// assert!((scaling(0.0, 1.0, 2.0, 10.0) - 1.0).abs() < tol);
/// assert!((scaling(0.5, 1.0, 2.0, 10.0) - 4.0).abs() < 4.0 * tol);
/// assert_eq!(scaling(0.99, 1.0, 2.0, 10.0), 10.0);
/// assert_eq!(scaling(3.0, 1.0, 2.0, 10.0), 10.0);
/// ```
#[inline]
#[must_use]
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
    /// The stabilising term of one error `e`: the first terms of `β_j` in (17)–(19).
    ///
    /// ```
    /// use controller_core::powers::Powers;
    /// use controller_core::scheme::Feedback;
    /// use controller_core::Gains;
    /// let g = Gains::predefined_time(2.0, 0.1, 2, 80.0, 50.0, 50.0)?;
    /// let f = Feedback::PredefinedTime { k1: g.k1, k2: g.k2, powers: Powers::new(0.1) };
    /// let e = 0.5f32;
    /// let want = g.k1 * e.powf(1.1) + g.k2 * e.powf(0.9);
    /// assert!((f.term(e) - want).abs() < 1e-4 * want);
    /// assert_eq!(f.term(0.0), 0.0);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    #[must_use]
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
