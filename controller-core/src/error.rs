//! Configuration errors: every way a [`crate::ControllerConfig`] can be rejected, each naming the
//! parameter at fault.

use core::fmt;

/// Why a controller configuration was rejected by [`crate::Controller::new`].
///
/// Step indices (`step`) are 1-based, as in the paper (`j = 1..n`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// A parameter is NaN or infinite.
    NonFinite(&'static str),
    /// `ζ` must lie in the open interval (0, 1).
    ZetaOutOfRange,
    /// The predefined-time parameter `T_s` must be > 0.
    NonPositiveTs,
    /// The sample period `h` must be > 0.
    NonPositiveSamplePeriod,
    /// The quantizer's `ρ` must lie in (0, 1).
    RhoOutOfRange,
    /// The quantizer's `u_min` must be > 0.
    NonPositiveUMin,
    /// `φ_low` of a step must be > 0.
    NonPositivePhiLow {
        /// 1-based step `j`.
        step: u8,
    },
    /// `φ_low` of a step exceeds its `φ_up`.
    PhiLowAbovePhiUp {
        /// 1-based step `j`.
        step: u8,
    },
    /// The MTN design constant `ǎ_j` of a step is 0 (it divides the law).
    ZeroACheck {
        /// 1-based step `j`.
        step: u8,
    },
    /// The MTN order is 0 (Φ would be empty).
    ZeroMtnOrder,
    /// The MTN order exceeds [`crate::mtn::MAX_MTN_ORDER`].
    MtnOrderTooLarge,
    /// More neighbours than the controller's capacity `K`.
    TooManyNeighbours,
    /// The agent hears neither a neighbour nor the leader (`A_i = 0`): it cannot take part.
    Isolated,
    /// A design gain that must be > 0 is not (`p`, `η`, `τ`, `γ`, `ℓ_1`, `ℓ_2`, `c_1`, `c_2`, ...).
    NonPositive(&'static str),
    /// A gain (`c1` or `c2`, given or computed from `T_s`, `ζ`, …) is at or above `√f32::MAX`:
    /// the second backstepping step squares it, so every step would overflow `f32`.
    GainTooLarge(&'static str),
    /// A parameter that must be ≥ 0 is negative (`ε̄`, decay rates, initial estimates).
    Negative(&'static str),
    /// A setting the controller derives from this parameter (its reciprocal, or its product
    /// with `A_i`) is not a finite `f32`, e.g. a subnormal `γ` or `φ_low`: every step would
    /// overflow.
    DerivedOverflow(&'static str),
    /// `ϖ_min` must lie in (0, `ϖ_0`].
    VarpiMinOutOfRange,
    /// An initial estimate exceeds the projection bound `estimate_max`.
    InitialEstimateAboveMax,
    /// Baseline: `μ_max` must be ≥ 1 (`μ_T(0) = 1`).
    MuMaxBelowOne,
    /// The state order `n` (const generic `N`) must be ≥ 1.
    ZeroStateOrder,
    /// Safety: `u_max` is at or below the quantizer's `u_min`, so every command would be
    /// quantized to 0.
    UMaxNotAboveUMin,
    /// Safety is configured, but the crate was built without its `safety` feature.
    SafetyNotBuilt,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite(p) => write!(f, "`{p}` is not a finite number"),
            Self::ZetaOutOfRange => f.write_str("`zeta` must lie in (0, 1)"),
            Self::NonPositiveTs => f.write_str("`ts` must be > 0"),
            Self::NonPositiveSamplePeriod => f.write_str("sample period `h` must be > 0"),
            Self::RhoOutOfRange => f.write_str("quantizer `rho` must lie in (0, 1)"),
            Self::NonPositiveUMin => f.write_str("quantizer `u_min` must be > 0"),
            Self::NonPositivePhiLow { step } => write!(f, "`phi_low[{step}]` must be > 0"),
            Self::PhiLowAbovePhiUp { step } => {
                write!(f, "`phi_low[{step}]` must not exceed `phi_up[{step}]`")
            }
            Self::ZeroACheck { step } => write!(f, "`a_check[{step}]` must not be 0"),
            Self::ZeroMtnOrder => f.write_str("`mtn_order` must be >= 1"),
            Self::MtnOrderTooLarge => {
                write!(f, "`mtn_order` must be <= {}", crate::mtn::MAX_MTN_ORDER)
            }
            Self::TooManyNeighbours => {
                f.write_str("more neighbours than the controller's capacity K")
            }
            Self::Isolated => {
                f.write_str("agent hears no neighbour and is not pinned to the leader (A_i = 0)")
            }
            Self::NonPositive(p) => write!(f, "`{p}` must be > 0"),
            Self::GainTooLarge(p) => write!(
                f,
                "`{p}` must be below 1.8e19 (sqrt of f32::MAX): every step would overflow"
            ),
            Self::Negative(p) => write!(f, "`{p}` must be >= 0"),
            Self::DerivedOverflow(p) => write!(
                f,
                "`{p}` is so small or large that a setting derived from it overflows f32"
            ),
            Self::VarpiMinOutOfRange => f.write_str("`varpi_min` must lie in (0, varpi0]"),
            Self::InitialEstimateAboveMax => {
                f.write_str("`mu0`, `xi0` and `lambda0` must not exceed `estimate_max`")
            }
            Self::MuMaxBelowOne => f.write_str("baseline `mu_max` must be >= 1"),
            Self::ZeroStateOrder => f.write_str("state order n must be >= 1"),
            Self::UMaxNotAboveUMin => {
                f.write_str("safety `u_max` must be above the quantizer's `u_min`")
            }
            Self::SafetyNotBuilt => f.write_str(
                "`safety` is set, but controller-core was built without its `safety` feature",
            ),
        }
    }
}

impl core::error::Error for ConfigError {}
