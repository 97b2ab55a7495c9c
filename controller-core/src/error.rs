//! Configuration errors: every way a [`crate::ControllerConfig`] can be rejected, naming the
//! [`Param`] at fault (and the step of a per-step parameter).

use core::fmt;

pub use crate::param::Reason;
use crate::param::{Param, Range, MAX_GAIN, SCHEMES};

/// Most problems [`crate::ControllerConfig::errors`] reports for one configuration.
pub const MAX_CONFIG_ERRORS: usize = 16;

/// Problems of one configuration (see [`crate::ControllerConfig::errors`]).
pub type ConfigErrors = heapless::Vec<ConfigError, MAX_CONFIG_ERRORS>;

/// Why a controller configuration was rejected by [`crate::Controller::new`]: the parameter,
/// the 1-based step `j` of a per-step parameter (as in the paper, `j = 1..n`) and the reason.
///
/// `Display` writes a sentence naming the scenario key, `Debug` a compact form for logs:
///
/// ```
/// use controller_core::{param::Param, ConfigError, Controller, ControllerConfig, Reason};
/// // φ_low_1 must be > 0: it divides α_1 (15).
/// let cfg = ControllerConfig::<2> { phi_low: [0.0, 1.0], ..Default::default() };
/// let e: ConfigError = Controller::<2, 2, 0>::new(&cfg).unwrap_err();
/// assert_eq!(e, ConfigError::new(Param::PhiLow, Reason::NonPositive).at_step(1));
/// assert_eq!(e.to_string(), "`phi_low[1]` must be > 0");
/// assert_eq!(format!("{e:?}"), "NonPositive(controller.phi_low[1])");
/// let _: &dyn core::error::Error = &e;
/// ```
#[derive(Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    param: Param,
    step: Option<u8>,
    reason: Reason,
}

impl ConfigError {
    /// `param` rejected for `reason`.
    ///
    /// ```
    /// use controller_core::{param::Param, ConfigError, Reason};
    /// let e = ConfigError::new(Param::Gamma, Reason::NonPositive);
    /// assert_eq!((e.param(), e.step(), e.reason()), (Param::Gamma, None, Reason::NonPositive));
    /// assert_eq!(e.to_string(), "`gamma` must be > 0");
    /// ```
    #[must_use]
    pub const fn new(param: Param, reason: Reason) -> Self {
        Self {
            param,
            step: None,
            reason,
        }
    }

    /// The same error for entry `step` (1-based) of a per-step parameter.
    ///
    /// ```
    /// use controller_core::{param::Param, ConfigError, Reason};
    /// let e = ConfigError::new(Param::ACheck, Reason::Zero).at_step(2);
    /// assert_eq!(e.step(), Some(2));
    /// assert_eq!(e.to_string(), "`a_check[2]` must not be 0");
    /// ```
    #[must_use]
    pub const fn at_step(self, step: u8) -> Self {
        Self {
            step: Some(step),
            ..self
        }
    }

    /// The parameter at fault; its scenario key is [`Param::key`].
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig};
    /// let cfg = ControllerConfig::<2> { ts: 0.0, ..Default::default() }; // T_s > 0 (Theorem 1)
    /// let e = Controller::<2, 2, 0>::new(&cfg).unwrap_err();
    /// assert_eq!(e.param().key(), "controller.ts");
    /// ```
    #[must_use]
    pub const fn param(&self) -> Param {
        self.param
    }

    /// The 1-based step of a per-step parameter.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig};
    /// // ε̄_2 is unused but must still be ≥ 0; ε̄_1 < 0 is the fault here.
    /// let cfg = ControllerConfig::<2> { eps_bar: [-0.1, 0.0], ..Default::default() };
    /// assert_eq!(Controller::<2, 2, 0>::new(&cfg).unwrap_err().step(), Some(1));
    /// let cfg = ControllerConfig::<2> { gamma: -1.0, ..Default::default() };
    /// assert_eq!(Controller::<2, 2, 0>::new(&cfg).unwrap_err().step(), None);
    /// ```
    #[must_use]
    pub const fn step(&self) -> Option<u8> {
        self.step
    }

    /// Why it was rejected.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Reason};
    /// let cfg = ControllerConfig::<2> { h: f32::NAN, ..Default::default() };
    /// assert_eq!(Controller::<2, 2, 0>::new(&cfg).unwrap_err().reason(), Reason::NonFinite);
    /// ```
    #[must_use]
    pub const fn reason(&self) -> Reason {
        self.reason
    }
}

/// Compact for logs: `NonPositive(controller.ts)`, `Zero(controller.a_check[2])`.
impl fmt::Debug for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}({}", self.reason, self.param.key())?;
        match self.step {
            Some(j) => write!(f, "[{j}])"),
            None => f.write_str(")"),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.param;
        if p == Param::StateOrder {
            return f.write_str("state order n (const generic N) must be >= 1");
        }
        match self.step {
            Some(j) => write!(f, "`{p}[{j}]` ")?,
            None => write!(f, "`{p}` ")?,
        }
        match self.reason {
            Reason::NonFinite if p.spec().range == Range::PositiveOrInfinite => {
                f.write_str("is not a number")
            }
            Reason::NonFinite => f.write_str("is not a finite number"),
            Reason::NonPositive => f.write_str("must be > 0"),
            Reason::Negative => f.write_str("must be >= 0"),
            Reason::Zero => f.write_str("must not be 0"),
            Reason::OutOfRange => write!(f, "must be {}", p.spec().range),
            Reason::TooLarge => write!(
                f,
                "must be below {MAX_GAIN:e} (sqrt of f32::MAX): every step would overflow"
            ),
            Reason::DerivedOverflow => {
                f.write_str("is so small or large that a setting derived from it overflows f32")
            }
            Reason::Exceeds(q) => match self.step {
                Some(j) => write!(f, "must not exceed `{q}[{j}]`"),
                None => write!(f, "must not exceed `{q}`"),
            },
            Reason::NotAbove(q) => write!(f, "must be above `{}`", q.key()),
            Reason::BelowInitialEstimates => {
                f.write_str("must not be below `mu0`, `xi0` and `lambda0`")
            }
            Reason::OverCapacity => f.write_str("exceeds the controller's capacity K"),
            Reason::StepCount { expected, got } => write!(
                f,
                "must have {expected} entries, one per step j = 1..n (got {got})"
            ),
            Reason::Unpaired => {
                let other = if p == Param::C1 { Param::C2 } else { Param::C1 };
                write!(f, "is required when `{other}` is given")
            }
            Reason::BaselineOnly => {
                let baseline = SCHEMES.get(1).copied().unwrap_or_default();
                write!(f, "is only for scheme = \"{baseline}\"")
            }
            Reason::Isolated => {
                f.write_str("is empty and the agent is not pinned to the leader (A_i = 0)")
            }
            Reason::NotBuilt => {
                f.write_str("is set, but controller-core was built without its `safety` feature")
            }
            Reason::Conflicts(q) => write!(f, "cannot be used with `{}`", q.key()),
        }
    }
}

impl core::error::Error for ConfigError {}

/// The range checks of the parameter table, as errors that name the parameter.
impl Param {
    /// `v` if it lies in the parameter's [`Range`], else the error naming the parameter.
    ///
    /// ```
    /// use controller_core::{param::Param, Reason};
    /// assert_eq!(Param::Rho.check(0.9), Ok(0.9)); // 0 < ρ < 1 of eq. (2)
    /// let e = Param::Rho.check(1.0).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::Rho, Reason::OutOfRange));
    /// ```
    pub fn check(self, v: f32) -> Result<f32, ConfigError> {
        self.spec()
            .range
            .check(v)
            .map_err(|r| ConfigError::new(self, r))
    }

    /// [`Self::check`] of the entry for step `step` (1-based) of a per-step parameter.
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::PhiLow.check_step(2, 0.5), Ok(0.5));
    /// let e = Param::PhiLow.check_step(2, 0.0).unwrap_err(); // φ_low_2 > 0 (Assumption 3)
    /// assert_eq!((e.param(), e.step()), (Param::PhiLow, Some(2)));
    /// assert_eq!(e.to_string(), "`phi_low[2]` must be > 0");
    /// ```
    pub fn check_step(self, step: u8, v: f32) -> Result<f32, ConfigError> {
        self.check(v).map_err(|e| e.at_step(step))
    }

    /// `v` if the parameter's [`Range::Count`] holds it.
    ///
    /// ```
    /// use controller_core::param::{Param, MAX_MTN_ORDER};
    /// assert_eq!(Param::MtnOrder.check_count(2), Ok(2)); // the examples' MTN order
    /// assert!(Param::MtnOrder.check_count(0).is_err());
    /// assert!(Param::MtnOrder.check_count(MAX_MTN_ORDER + 1).is_err());
    /// ```
    pub const fn check_count(self, v: usize) -> Result<usize, ConfigError> {
        match self.spec().range {
            Range::Count { min, max } if v < min || v > max => {
                Err(ConfigError::new(self, Reason::OutOfRange))
            }
            _ => Ok(v),
        }
    }
}
