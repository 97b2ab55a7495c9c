//! The `[controller]`, `[quantizer]` and `[safety]` sections of a scenario file
//! (docs/SCENARIO.md) as one set of types for every reader: `host-sim` reads them in `f64` into
//! `Vec`s, firmware in `f32` into `heapless::Vec`s; [`ControllerConfig::from_sections`] turns
//! either into a configuration (each value `as f32`). Defaults come from [`Param::spec`].
//!
//! With the `serde` feature the sections are (de)serializable, and `ConfigFile` reads a whole
//! scenario file (its other tables ignored) into a [`ControllerConfig`].

use core::fmt;

use crate::{
    backstepping::Feedforward,
    config::ControllerConfig,
    error::ConfigError,
    gains::{GainSelection, Gains},
    param::{Param, Reason},
    quantizer::{QuantizerConfig, QuantizerDirection},
    safety::SafetyConfig,
    scheme::{BaselineConfig, SchemeConfig},
};

pub use crate::error::ConfigErrors;

/// A number type a file is read in: `f32` on the target, `f64` on the host.
///
/// ```
/// use controller_core::sections::{ControllerSection, Number};
/// // The host reads f64, the controller takes each value `as f32`.
/// let host: ControllerSection<f64, heapless::Vec<f64, 2>> = ControllerSection::default();
/// assert_eq!(host.ts.to_f32(), 2.0);
/// assert_eq!(f64::from_f64(0.1), 0.1);
/// ```
pub trait Number: Copy + PartialEq {
    /// A default of the parameter table.
    ///
    /// ```
    /// use controller_core::sections::Number;
    /// assert_eq!(<f32 as Number>::from_f64(1e-6), 1e-6f32); // ϖ_min as the target reads it
    /// ```
    fn from_f64(v: f64) -> Self;
    /// The controller's `f32`.
    ///
    /// ```
    /// use controller_core::sections::Number;
    /// assert_eq!(0.1f64.to_f32(), 0.1f32);
    /// ```
    fn to_f32(self) -> f32;
}

impl Number for f32 {
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    fn to_f32(self) -> f32 {
        self
    }
}

impl Number for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
    fn to_f32(self) -> f32 {
        self as f32
    }
}

/// The per-step values of a section (one per step `j = 1..n`).
///
/// ```
/// use controller_core::sections::ControllerSection;
/// // Firmware: a fixed-capacity vector; ǎ_j = 90 for both steps of Example 1.
/// let c: ControllerSection<f32, heapless::Vec<f32, 2>> = ControllerSection::default();
/// assert_eq!(c.a_check.as_slice(), &[90.0, 90.0]);
/// ```
pub trait PerStep<F>: AsRef<[F]> {
    /// The default: `v` for every step of the default plant.
    ///
    /// ```
    /// use controller_core::sections::PerStep;
    /// let v: heapless::Vec<f32, 3> = PerStep::filled(1.0);
    /// assert_eq!(v.as_slice(), &[1.0; 3]);
    /// ```
    fn filled(v: F) -> Self;
}

impl<F: Copy, const N: usize> PerStep<F> for heapless::Vec<F, N> {
    fn filled(v: F) -> Self {
        Self::from_array([v; N])
    }
}

/// Steps of the default plant (Example 1, `n = 2`).
#[cfg(feature = "alloc")]
const DEFAULT_STEPS: usize = 2;

#[cfg(feature = "alloc")]
impl<F: Copy> PerStep<F> for alloc::vec::Vec<F> {
    fn filled(v: F) -> Self {
        alloc::vec![v; DEFAULT_STEPS]
    }
}

/// `controller.scheme`: which control law.
///
/// ```
/// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
/// use controller_core::{ControllerConfig, SchemeConfig, SchemeName};
/// assert_eq!(SchemeName::PrescribedTime.to_string(), "prescribed-time"); // the scenario value
/// let c = ControllerSection::<f32, heapless::Vec<f32, 2>> {
///     scheme: SchemeName::PrescribedTime,
///     ..Default::default()
/// };
/// let cfg = ControllerConfig::<2>::from_sections(Agent::default(), &c,
///     &QuantizerSection::default(), &SafetySection::default())?;
/// assert!(matches!(cfg.scheme, SchemeConfig::PrescribedTime(b) if b.kappa == 2.0));
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum SchemeName {
    /// The paper's predefined-time law.
    #[default]
    PredefinedTime,
    /// The LAW §10 prescribed-time baseline.
    PrescribedTime,
}

impl fmt::Display for SchemeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::PredefinedTime => crate::param::SCHEMES[0],
            Self::PrescribedTime => crate::param::SCHEMES[1],
        })
    }
}

/// `controller.gain_reading`: which reading of the gain factor of Theorem 1 (D1).
///
/// `#[non_exhaustive]`: LAW §9's stricter `ϑ` is a candidate for a further reading.
///
/// ```
/// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
/// use controller_core::{ControllerConfig, GainReading, GainSelection};
/// let c = ControllerSection::<f32, heapless::Vec<f32, 2>> {
///     gain_reading: GainReading::Printed,
///     ..Default::default()
/// };
/// let cfg = ControllerConfig::<2>::from_sections(Agent::default(), &c,
///     &QuantizerSection::default(), &SafetySection::default())?;
/// // The printed r of Theorem 1 gives Example 1 c_1 ≈ 2,862 (the reconstruction: 16.26).
/// assert!(matches!(cfg.gains, GainSelection::Explicit { c1, .. } if (c1 - 2862.0).abs() < 1.0));
/// assert_eq!(GainReading::Printed.to_string(), "printed");
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
#[non_exhaustive]
pub enum GainReading {
    /// `ϑ` of LAW §3, reconstructed from the proof's (46)–(55).
    #[default]
    Reconstructed,
    /// The factor `r` as printed below (21) ([`crate::gains::printed_factor`]).
    Printed,
}

impl GainReading {
    /// The default reading (left out when a section is written).
    ///
    /// ```
    /// use controller_core::GainReading;
    /// assert!(GainReading::default().is_reconstructed());
    /// assert!(!GainReading::Printed.is_reconstructed());
    /// ```
    #[must_use]
    pub fn is_reconstructed(&self) -> bool {
        *self == Self::Reconstructed
    }
}

impl fmt::Display for GainReading {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Reconstructed => crate::param::GAIN_READINGS[0],
            Self::Printed => crate::param::GAIN_READINGS[1],
        })
    }
}

/// `[controller]`: the design values of LAW §3–§5, shared by all agents.
///
/// ```
/// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
/// use controller_core::{param::Param, ControllerConfig, Reason};
/// type Section = ControllerSection<f32, heapless::Vec<f32, 3>>;
/// // Three ǎ_j for a plant of order n = 2: the layout error names the key.
/// let c = Section { a_check: heapless::Vec::from_array([90.0; 3]), ..Default::default() };
/// let e = ControllerConfig::<2>::from_sections(Agent::default(), &c,
///     &QuantizerSection::default(), &SafetySection::default()).unwrap_err();
/// assert_eq!((e.param(), e.reason()), (Param::ACheck, Reason::StepCount { expected: 2, got: 3 }));
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(
        deny_unknown_fields,
        default,
        bound(
            serialize = "F: serde::Serialize, S: serde::Serialize",
            deserialize = "F: Number + serde::Deserialize<'de>, S: PerStep<F> + serde::Deserialize<'de>"
        )
    )
)]
pub struct ControllerSection<F, S> {
    /// Proposed law or baseline.
    pub scheme: SchemeName,
    /// `T_s` \[s\].
    pub ts: F,
    /// `ζ`.
    pub zeta: F,
    /// `ǎ_j`, one per step.
    pub a_check: S,
    /// `p`.
    pub p: F,
    /// `η`.
    pub eta: F,
    /// `τ`.
    pub tau: F,
    /// `γ`.
    pub gamma: F,
    /// MTN order.
    pub mtn_order: u32,
    /// `φ_low_j`.
    pub phi_low: S,
    /// `φ_up_j`.
    pub phi_up: S,
    /// `ε̄_j`.
    pub eps_bar: S,
    /// `ℓ_1`.
    pub diff_l1: F,
    /// `ℓ_2`.
    pub diff_l2: F,
    /// `ϖ_0`.
    pub varpi0: F,
    /// `κ` of `ϖ(t)`.
    pub varpi_decay: F,
    /// `ϖ_min`.
    pub varpi_min: F,
    /// `μ̂(0)`.
    pub mu0: F,
    /// `ξ̂(0)`.
    pub xi0: F,
    /// `λ̂(0)`.
    pub lambda0: F,
    /// Projection bound of the three estimates.
    pub estimate_max: F,
    /// Explicit `c_1` (with `c2`).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub c1: Option<F>,
    /// Explicit `c_2` (with `c1`).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub c2: Option<F>,
    /// Reading of the gain factor when `c1`, `c2` are not given.
    #[cfg_attr(
        feature = "serde",
        serde(skip_serializing_if = "GainReading::is_reconstructed")
    )]
    pub gain_reading: GainReading,
    /// Velocity feed-forward (LAW §5a; off: the paper's law).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Feedforward::is_off"))]
    pub feedforward: Feedforward,
    /// Baseline `κ`.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub kappa: Option<F>,
    /// Baseline `μ_max`.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub mu_max: Option<F>,
    /// Baseline `T` (default `T_s`).
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub t_prescribed: Option<F>,
}

impl<F: Number, S: PerStep<F>> Default for ControllerSection<F, S> {
    fn default() -> Self {
        let num = |p: Param| F::from_f64(p.default_f64());
        let steps = |p: Param| S::filled(num(p));
        Self {
            scheme: SchemeName::default(),
            ts: num(Param::Ts),
            zeta: num(Param::Zeta),
            a_check: steps(Param::ACheck),
            p: num(Param::P),
            eta: num(Param::Eta),
            tau: num(Param::Tau),
            gamma: num(Param::Gamma),
            mtn_order: Param::MtnOrder.default_f64() as u32,
            phi_low: steps(Param::PhiLow),
            phi_up: steps(Param::PhiUp),
            eps_bar: steps(Param::EpsBar),
            diff_l1: num(Param::DiffL1),
            diff_l2: num(Param::DiffL2),
            varpi0: num(Param::Varpi0),
            varpi_decay: num(Param::VarpiDecay),
            varpi_min: num(Param::VarpiMin),
            mu0: num(Param::Mu0),
            xi0: num(Param::Xi0),
            lambda0: num(Param::Lambda0),
            estimate_max: num(Param::EstimateMax),
            c1: None,
            c2: None,
            gain_reading: GainReading::default(),
            feedforward: Feedforward::default(),
            kappa: None,
            mu_max: None,
            t_prescribed: None,
        }
    }
}

/// `[quantizer]`: the hysteresis quantizer of eq. (2).
///
/// ```
/// use controller_core::sections::QuantizerSection;
/// let q = QuantizerSection::<f64>::default();
/// assert!(q.enabled && q.rho == 0.9 && q.u_min == 0.01); // LAW §8
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(
        deny_unknown_fields,
        default,
        bound(deserialize = "F: Number + serde::Deserialize<'de>")
    )
)]
pub struct QuantizerSection<F> {
    /// Off: actuators get `u` itself.
    pub enabled: bool,
    /// `ρ`.
    pub rho: F,
    /// `u_min`.
    pub u_min: F,
    /// Direction reading.
    pub direction: QuantizerDirection,
}

impl<F: Number> Default for QuantizerSection<F> {
    fn default() -> Self {
        Self {
            enabled: Param::QuantizerEnabled.default_bool(),
            rho: F::from_f64(Param::Rho.default_f64()),
            u_min: F::from_f64(Param::UMin.default_f64()),
            direction: QuantizerDirection::default(),
        }
    }
}

impl<F: Number> QuantizerSection<F> {
    /// The quantizer's settings, `None` when off.
    ///
    /// ```
    /// use controller_core::sections::QuantizerSection;
    /// use controller_core::QuantizerConfig;
    /// assert_eq!(QuantizerSection::<f64>::default().config(), Some(QuantizerConfig::default()));
    /// let off = QuantizerSection::<f64> { enabled: false, ..Default::default() };
    /// assert_eq!(off.config(), None); // actuators get u itself (δ = 0)
    /// ```
    pub fn config(&self) -> Option<QuantizerConfig> {
        self.enabled.then(|| QuantizerConfig {
            rho: self.rho.to_f32(),
            u_min: self.u_min.to_f32(),
            direction: self.direction,
        })
    }
}

/// `[safety]`: command limits, anti-windup and recovery of [`crate::safety`]. Off by default:
/// the paper's law.
///
/// ```
/// use controller_core::sections::SafetySection;
/// let s = SafetySection::<f64>::default();
/// assert!(!s.enabled && s.u_max.is_none() && s.du_max.is_none());
/// assert_eq!((s.recovery_rate, s.recovery_jump), (1.0, 0.05));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(
        deny_unknown_fields,
        default,
        bound(deserialize = "F: Number + serde::Deserialize<'de>")
    )
)]
pub struct SafetySection<F> {
    /// On: limits, conditional integration, bumpless re-entry, differentiator re-seeding.
    pub enabled: bool,
    /// Limit of `|u|` per actuator before the quantizer [command units]; absent: none.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub u_max: Option<F>,
    /// Limit of `|du/dt|` [command units / s]; absent: none.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub du_max: Option<F>,
    /// `v_r` [units of `y` / s]: a returning neighbour / leader value's jump is removed at
    /// this speed (`inf`: used at once).
    pub recovery_rate: F,
    /// Jumps up to this size [units of `y`] re-enter at once.
    pub recovery_jump: F,
}

impl<F: Number> Default for SafetySection<F> {
    fn default() -> Self {
        Self {
            enabled: Param::SafetyEnabled.default_bool(),
            u_max: None,
            du_max: None,
            recovery_rate: F::from_f64(Param::RecoveryRate.default_f64()),
            recovery_jump: F::from_f64(Param::RecoveryJump.default_f64()),
        }
    }
}

impl<F: Number> SafetySection<F> {
    /// The default (off, nothing set).
    ///
    /// ```
    /// use controller_core::sections::SafetySection;
    /// assert!(SafetySection::<f32>::default().is_default());
    /// assert!(!SafetySection::<f32> { u_max: Some(40.0), ..Default::default() }.is_default());
    /// ```
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The controller's settings, `None` when off.
    ///
    /// ```
    /// use controller_core::sections::SafetySection;
    /// let s = SafetySection::<f64> { enabled: true, u_max: Some(40.0), ..Default::default() };
    /// assert_eq!(s.config().and_then(|c| c.u_max), Some(40.0));
    /// assert_eq!(SafetySection::<f64>::default().config(), None);
    /// ```
    pub fn config(&self) -> Option<SafetyConfig> {
        self.enabled.then(|| self.settings())
    }

    /// The controller's settings whether on or off (to check them while off).
    ///
    /// ```
    /// use controller_core::safety::Safety;
    /// use controller_core::{param::Param, sections::SafetySection};
    /// // Off, but a wrong value is still worth reporting.
    /// let s = SafetySection::<f64> { du_max: Some(-1.0), ..Default::default() };
    /// assert_eq!(s.config(), None);
    /// assert_eq!(Safety::new(&s.settings(), 1e-3).unwrap_err().param(), Param::DuMax);
    /// ```
    pub fn settings(&self) -> SafetyConfig {
        SafetyConfig {
            u_max: self.u_max.map(F::to_f32),
            du_max: self.du_max.map(F::to_f32),
            recovery_rate: self.recovery_rate.to_f32(),
            recovery_jump: self.recovery_jump.to_f32(),
        }
    }
}

/// The agent-specific part of a configuration: sample period and topology.
///
/// ```
/// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
/// use controller_core::ControllerConfig;
/// // Agent 3 of the examples hears agent 1 only.
/// let agent = Agent { neighbour_count: 1, pinned: false, ..Agent::default() };
/// let c = ControllerSection::<f64, heapless::Vec<f64, 2>>::default();
/// let cfg = ControllerConfig::<2>::from_sections(agent, &c,
///     &QuantizerSection::default(), &SafetySection::default())?;
/// assert_eq!((cfg.h, cfg.neighbour_count, cfg.pinned), (1e-3, 1, false));
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agent {
    /// Sample period `h` \[s\].
    pub h: f32,
    /// `S_i`: neighbours this agent hears.
    pub neighbour_count: usize,
    /// `r_i = 1`: the agent hears the leader.
    pub pinned: bool,
}

impl Default for Agent {
    /// Agent 1 of the paper's examples: pinned, no neighbours.
    fn default() -> Self {
        Self {
            h: Param::H.default_f32(),
            neighbour_count: 0,
            pinned: true,
        }
    }
}

fn steps<const N: usize, F: Number>(param: Param, v: &[F]) -> Result<[f32; N], ConfigError> {
    if v.len() != N {
        let reason = Reason::StepCount {
            expected: u8::try_from(N).unwrap_or(u8::MAX),
            got: u32::try_from(v.len()).unwrap_or(u32::MAX),
        };
        return Err(ConfigError::new(param, reason));
    }
    let mut a = [0.0; N];
    for (d, s) in a.iter_mut().zip(v) {
        *d = s.to_f32();
    }
    Ok(a)
}

fn baseline_only<F>(param: Param, v: Option<F>) -> Result<(), ConfigError> {
    match v {
        Some(_) => Err(ConfigError::new(param, Reason::BaselineOnly)),
        None => Ok(()),
    }
}

/// The value of `r`, or `None` with its error added to `errors`.
fn keep<T>(errors: &mut ConfigErrors, r: Result<T, ConfigError>) -> Option<T> {
    r.map_err(|e| {
        // Full: the first MAX_CONFIG_ERRORS problems are reported.
        let _ = errors.push(e);
    })
    .ok()
}

impl<const N: usize> ControllerConfig<N> {
    /// The configuration of one agent from the scenario sections, each value `as f32`; only
    /// the layout is checked here (entries per step, `c1` with `c2`, baseline keys), the values
    /// by [`crate::Controller::new`]. The error is the first of [`Self::from_sections_all`].
    ///
    /// ```
    /// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
    /// use controller_core::{param::Param, Controller, ControllerConfig, Reason};
    /// type Section = ControllerSection<f32, heapless::Vec<f32, 2>>;
    /// let (q, s) = (QuantizerSection::default(), SafetySection::default());
    /// // The defaults are Example 1's: the same configuration as ControllerConfig::default().
    /// let cfg = ControllerConfig::<2>::from_sections(Agent::default(), &Section::default(), &q, &s)?;
    /// assert_eq!(cfg, ControllerConfig::default());
    /// // c1 without c2 is a layout error; a bad value passes here and is caught by the controller.
    /// let c = Section { c1: Some(10.0), ..Default::default() };
    /// let e = ControllerConfig::<2>::from_sections(Agent::default(), &c, &q, &s).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::C2, Reason::Unpaired));
    /// let c = Section { zeta: 2.0, ..Default::default() };
    /// let cfg = ControllerConfig::<2>::from_sections(Agent::default(), &c, &q, &s)?;
    /// assert_eq!(Controller::<2, 2, 0>::new(&cfg).unwrap_err().param(), Param::Zeta);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn from_sections<F: Number, S: PerStep<F>>(
        agent: Agent,
        c: &ControllerSection<F, S>,
        q: &QuantizerSection<F>,
        s: &SafetySection<F>,
    ) -> Result<Self, ConfigError> {
        let (cfg, errors) = Self::from_sections_all(agent, c, q, s);
        match errors.first() {
            Some(e) => Err(*e),
            None => Ok(cfg),
        }
    }

    /// [`Self::from_sections`] with every layout problem, not only the first, and the
    /// configuration with the default in place of each rejected value (to check the values
    /// of the others with [`Self::errors`]).
    ///
    /// ```
    /// use controller_core::sections::{Agent, ControllerSection, QuantizerSection, SafetySection};
    /// use controller_core::{param::Param, ControllerConfig};
    /// let c = ControllerSection::<f32, heapless::Vec<f32, 2>> {
    ///     kappa: Some(2.0), // a baseline key for the predefined-time scheme
    ///     c2: Some(9.0),    // without c1
    ///     ..Default::default()
    /// };
    /// let (cfg, errors) = ControllerConfig::<2>::from_sections_all(Agent::default(), &c,
    ///     &QuantizerSection::default(), &SafetySection::default());
    /// let params: Vec<Param> = errors.iter().map(|e| e.param()).collect();
    /// assert_eq!(params, [Param::C1, Param::Kappa]);
    /// assert!(cfg.errors(0).is_empty()); // the rest is valid
    /// ```
    pub fn from_sections_all<F: Number, S: PerStep<F>>(
        agent: Agent,
        c: &ControllerSection<F, S>,
        q: &QuantizerSection<F>,
        s: &SafetySection<F>,
    ) -> (Self, ConfigErrors) {
        let mut errors = ConfigErrors::new();
        let gains = keep(
            &mut errors,
            match (c.c1, c.c2, c.gain_reading) {
                (None, None, GainReading::Reconstructed) => Ok(GainSelection::Auto),
                // The printed reading is a pair of explicit gains computed here, so every
                // reader of a `GainSelection` (firmware, node link) handles it unchanged.
                (None, None, GainReading::Printed) => Gains::printed(
                    c.ts.to_f32(),
                    c.zeta.to_f32(),
                    N,
                    c.p.to_f32(),
                    c.eta.to_f32(),
                    c.tau.to_f32(),
                )
                .map(|g| GainSelection::Explicit { c1: g.c1, c2: g.c2 }),
                (Some(_), Some(_), GainReading::Printed) => Err(ConfigError::new(
                    Param::GainReading,
                    Reason::Conflicts(Param::C1),
                )),
                (Some(c1), Some(c2), _) => Ok(GainSelection::Explicit {
                    c1: c1.to_f32(),
                    c2: c2.to_f32(),
                }),
                (Some(_), None, _) => Err(ConfigError::new(Param::C2, Reason::Unpaired)),
                (None, Some(_), _) => Err(ConfigError::new(Param::C1, Reason::Unpaired)),
            },
        );
        let scheme = match c.scheme {
            SchemeName::PredefinedTime => {
                keep(&mut errors, baseline_only(Param::Kappa, c.kappa));
                keep(&mut errors, baseline_only(Param::MuMax, c.mu_max));
                keep(
                    &mut errors,
                    baseline_only(Param::TPrescribed, c.t_prescribed),
                );
                SchemeConfig::PredefinedTime
            }
            SchemeName::PrescribedTime => {
                let d = BaselineConfig::default();
                SchemeConfig::PrescribedTime(BaselineConfig {
                    kappa: c.kappa.map_or(d.kappa, F::to_f32),
                    mu_max: c.mu_max.map_or(d.mu_max, F::to_f32),
                    t_prescribed: c.t_prescribed.map(F::to_f32),
                })
            }
        };
        let mut per_step = |p: Param, v: &S| {
            keep(&mut errors, steps(p, v.as_ref())).unwrap_or([p.default_f32(); N])
        };
        let a_check = per_step(Param::ACheck, &c.a_check);
        let phi_low = per_step(Param::PhiLow, &c.phi_low);
        let phi_up = per_step(Param::PhiUp, &c.phi_up);
        let eps_bar = per_step(Param::EpsBar, &c.eps_bar);
        let cfg = Self {
            h: agent.h,
            neighbour_count: agent.neighbour_count,
            pinned: agent.pinned,
            ts: c.ts.to_f32(),
            zeta: c.zeta.to_f32(),
            gains: gains.unwrap_or(GainSelection::Auto),
            a_check,
            p: c.p.to_f32(),
            eta: c.eta.to_f32(),
            tau: c.tau.to_f32(),
            gamma: c.gamma.to_f32(),
            mtn_order: c.mtn_order as usize,
            phi_low,
            phi_up,
            eps_bar,
            diff_l1: c.diff_l1.to_f32(),
            diff_l2: c.diff_l2.to_f32(),
            varpi0: c.varpi0.to_f32(),
            varpi_decay: c.varpi_decay.to_f32(),
            varpi_min: c.varpi_min.to_f32(),
            mu0: c.mu0.to_f32(),
            xi0: c.xi0.to_f32(),
            lambda0: c.lambda0.to_f32(),
            estimate_max: c.estimate_max.to_f32(),
            quantizer: q.config(),
            scheme,
            safety: s.config(),
            feedforward: c.feedforward,
        };
        (cfg, errors)
    }
}

/// A configuration file: a scenario file's `[simulation]` `h`, `[controller]`, `[quantizer]` and
/// `[safety]` (its other tables and `[simulation]` keys are ignored), and an optional `[agent]`
/// table (`neighbour_count`, `pinned`; default agent 1 of the examples: pinned, no neighbours).
///
/// ```
/// use controller_core::{param::Param, Controller, ControllerConfig};
/// let text = r#"
///     [simulation]
///     h = 2e-4
///     [controller]
///     ts = 0.5
///     zeta = 0.6
///     a_check = [100.0, 120.0]
///     [agent]
///     neighbour_count = 1
///     pinned = false
/// "#;
/// let cfg: ControllerConfig<2> = toml::from_str(text).unwrap();
/// assert_eq!((cfg.h, cfg.ts, cfg.a_check), (2e-4, 0.5, [100.0, 120.0]));
/// assert!(Controller::<2, 2, 4>::new(&cfg).is_ok());
/// // Two values for a plant of order 3: rejected with the key's name.
/// let e = toml::from_str::<ControllerConfig<3>>(text).unwrap_err();
/// assert!(e.to_string().contains("a_check"), "{e}");
/// ```
#[cfg(feature = "serde")]
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(
    default,
    bound(
        serialize = "S: serde::Serialize",
        deserialize = "S: PerStep<f32> + serde::Deserialize<'de>"
    )
)]
pub struct ConfigFile<S> {
    /// `h` of `[simulation]`.
    pub simulation: FileSimulation,
    /// The agent's topology.
    pub agent: FileAgent,
    /// `[controller]`.
    pub controller: ControllerSection<f32, S>,
    /// `[quantizer]`.
    pub quantizer: QuantizerSection<f32>,
    /// `[safety]`.
    pub safety: SafetySection<f32>,
}

#[cfg(feature = "serde")]
impl<S: PerStep<f32>> Default for ConfigFile<S> {
    fn default() -> Self {
        Self {
            simulation: FileSimulation::default(),
            agent: FileAgent::default(),
            controller: ControllerSection::default(),
            quantizer: QuantizerSection::default(),
            safety: SafetySection::default(),
        }
    }
}

/// The `[simulation]` key a controller reads.
///
/// ```
/// use controller_core::sections::FileSimulation;
/// let s: FileSimulation = toml::from_str("h = 5e-4").unwrap();
/// assert_eq!(s.h, 5e-4);
/// assert_eq!(FileSimulation::default().h, 1e-3);
/// ```
#[cfg(feature = "serde")]
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct FileSimulation {
    /// Sample period `h` \[s\].
    pub h: f32,
}

#[cfg(feature = "serde")]
impl Default for FileSimulation {
    fn default() -> Self {
        Self {
            h: Agent::default().h,
        }
    }
}

/// `[agent]`: the topology of the agent the file configures.
///
/// ```
/// use controller_core::sections::FileAgent;
/// assert!(toml::from_str::<FileAgent>("neighbours = 2").is_err()); // the key is neighbour_count
/// let a: FileAgent = toml::from_str("neighbour_count = 2").unwrap();
/// assert_eq!((a.neighbour_count, a.pinned), (2, true));
/// ```
#[cfg(feature = "serde")]
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FileAgent {
    /// `S_i`: neighbours this agent hears.
    pub neighbour_count: usize,
    /// `r_i = 1`: the agent hears the leader.
    pub pinned: bool,
}

#[cfg(feature = "serde")]
impl Default for FileAgent {
    fn default() -> Self {
        let a = Agent::default();
        Self {
            neighbour_count: a.neighbour_count,
            pinned: a.pinned,
        }
    }
}

#[cfg(feature = "serde")]
impl<const N: usize, S: PerStep<f32>> TryFrom<ConfigFile<S>> for ControllerConfig<N> {
    type Error = ConfigError;

    fn try_from(f: ConfigFile<S>) -> Result<Self, ConfigError> {
        let agent = Agent {
            h: f.simulation.h,
            neighbour_count: f.agent.neighbour_count,
            pinned: f.agent.pinned,
        };
        Self::from_sections(agent, &f.controller, &f.quantizer, &f.safety)
    }
}

/// The sections a scenario file would give for a configuration: the inverse of
/// [`ControllerConfig::from_sections`] (an object dictionary's parameter store and
/// `ConfigFile` both start from it).
///
/// ```
/// use controller_core::{sections::Sections, ControllerConfig};
/// // Example 1's defaults, T_s = 0.5 s: to sections and back is the same configuration.
/// let cfg = ControllerConfig::<2> { ts: 0.5, ..Default::default() };
/// let s = Sections::from(cfg);
/// assert_eq!(s.controller.ts, 0.5);
/// assert_eq!(s.controller.a_check.len(), 2); // one ǎ_j per step j = 1..n
/// assert_eq!(s.config(), Ok(cfg));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Sections<const N: usize> {
    /// Sample period and topology.
    pub agent: Agent,
    /// `[controller]`.
    pub controller: ControllerSection<f32, heapless::Vec<f32, N>>,
    /// `[quantizer]`.
    pub quantizer: QuantizerSection<f32>,
    /// `[safety]`.
    pub safety: SafetySection<f32>,
}

impl<const N: usize> Sections<N> {
    /// The configuration these sections describe ([`ControllerConfig::from_sections`]).
    ///
    /// ```
    /// use controller_core::{param::Param, sections::Sections, ControllerConfig, Reason};
    /// let mut s = Sections::from(ControllerConfig::<2>::default());
    /// s.controller.a_check.pop(); // one ǎ_j for a plant of order n = 2
    /// let e = s.config().unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::ACheck, Reason::StepCount { expected: 2, got: 1 }));
    /// ```
    pub fn config(&self) -> Result<ControllerConfig<N>, ConfigError> {
        ControllerConfig::from_sections(self.agent, &self.controller, &self.quantizer, &self.safety)
    }
}

impl<const N: usize> From<ControllerConfig<N>> for Sections<N> {
    fn from(c: ControllerConfig<N>) -> Self {
        let steps = heapless::Vec::from_array;
        let (c1, c2) = match c.gains {
            GainSelection::Auto => (None, None),
            GainSelection::Explicit { c1, c2 } => (Some(c1), Some(c2)),
        };
        let (scheme, baseline) = match c.scheme {
            SchemeConfig::PredefinedTime => (SchemeName::PredefinedTime, None),
            SchemeConfig::PrescribedTime(b) => (SchemeName::PrescribedTime, Some(b)),
        };
        Self {
            agent: Agent {
                h: c.h,
                neighbour_count: c.neighbour_count,
                pinned: c.pinned,
            },
            controller: ControllerSection {
                scheme,
                ts: c.ts,
                zeta: c.zeta,
                a_check: steps(c.a_check),
                p: c.p,
                eta: c.eta,
                tau: c.tau,
                gamma: c.gamma,
                mtn_order: u32::try_from(c.mtn_order).unwrap_or(u32::MAX),
                phi_low: steps(c.phi_low),
                phi_up: steps(c.phi_up),
                eps_bar: steps(c.eps_bar),
                diff_l1: c.diff_l1,
                diff_l2: c.diff_l2,
                varpi0: c.varpi0,
                varpi_decay: c.varpi_decay,
                varpi_min: c.varpi_min,
                mu0: c.mu0,
                xi0: c.xi0,
                lambda0: c.lambda0,
                estimate_max: c.estimate_max,
                c1,
                c2,
                gain_reading: GainReading::Reconstructed,
                feedforward: c.feedforward,
                kappa: baseline.map(|b| b.kappa),
                mu_max: baseline.map(|b| b.mu_max),
                t_prescribed: baseline.and_then(|b| b.t_prescribed),
            },
            quantizer: match c.quantizer {
                Some(q) => QuantizerSection {
                    enabled: true,
                    rho: q.rho,
                    u_min: q.u_min,
                    direction: q.direction,
                },
                None => QuantizerSection {
                    enabled: false,
                    ..QuantizerSection::default()
                },
            },
            safety: match c.safety {
                Some(s) => SafetySection {
                    enabled: true,
                    u_max: s.u_max,
                    du_max: s.du_max,
                    recovery_rate: s.recovery_rate,
                    recovery_jump: s.recovery_jump,
                },
                None => SafetySection {
                    enabled: false,
                    ..SafetySection::default()
                },
            },
        }
    }
}

#[cfg(feature = "serde")]
impl<const N: usize> From<ControllerConfig<N>> for ConfigFile<heapless::Vec<f32, N>> {
    fn from(c: ControllerConfig<N>) -> Self {
        let s = Sections::from(c);
        Self {
            simulation: FileSimulation { h: s.agent.h },
            agent: FileAgent {
                neighbour_count: s.agent.neighbour_count,
                pinned: s.agent.pinned,
            },
            controller: s.controller,
            quantizer: s.quantizer,
            safety: s.safety,
        }
    }
}

/// Read as a [`ConfigFile`], checked for its layout by [`ControllerConfig::from_sections`].
#[cfg(feature = "serde")]
impl<'de, const N: usize> serde::Deserialize<'de> for ControllerConfig<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let file = ConfigFile::<heapless::Vec<f32, N>>::deserialize(d)?;
        Self::try_from(file).map_err(serde::de::Error::custom)
    }
}

/// Written as a [`ConfigFile`].
#[cfg(feature = "serde")]
impl<const N: usize> serde::Serialize for ControllerConfig<N> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        serde::Serialize::serialize(&ConfigFile::from(*self), s)
    }
}
