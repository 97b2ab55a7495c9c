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
#[derive(Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    param: Param,
    step: Option<u8>,
    reason: Reason,
}

impl ConfigError {
    /// `param` rejected for `reason`.
    pub const fn new(param: Param, reason: Reason) -> Self {
        Self {
            param,
            step: None,
            reason,
        }
    }

    /// The same error for entry `step` (1-based) of a per-step parameter.
    pub const fn at_step(self, step: u8) -> Self {
        Self {
            step: Some(step),
            ..self
        }
    }

    /// The parameter at fault.
    pub const fn param(&self) -> Param {
        self.param
    }

    /// The 1-based step of a per-step parameter.
    pub const fn step(&self) -> Option<u8> {
        self.step
    }

    /// Why it was rejected.
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
    pub fn check(self, v: f32) -> Result<f32, ConfigError> {
        self.spec()
            .range
            .check(v)
            .map_err(|r| ConfigError::new(self, r))
    }

    /// [`Self::check`] of the entry for step `step` (1-based) of a per-step parameter.
    pub fn check_step(self, step: u8, v: f32) -> Result<f32, ConfigError> {
        self.check(v).map_err(|e| e.at_step(step))
    }

    /// `v` if the parameter's [`Range::Count`] holds it.
    pub const fn check_count(self, v: usize) -> Result<usize, ConfigError> {
        match self.spec().range {
            Range::Count { min, max } if v < min || v > max => {
                Err(ConfigError::new(self, Reason::OutOfRange))
            }
            _ => Ok(v),
        }
    }
}
