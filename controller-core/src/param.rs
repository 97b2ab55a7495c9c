//! Every parameter of a [`crate::ControllerConfig`] once: its scenario key, unit, default and
//! range ([`Param::spec`]). The constructors validate against these ranges, the defaults of
//! [`crate::ControllerConfig`], [`crate::QuantizerConfig`] and [`crate::SafetyConfig`] are read
//! from here, and a [`crate::ConfigError`] names the [`Param`] at fault.
//!
//! Defaults are `f64` as written in a scenario file; the controller takes them `as f32`.

use core::fmt;

/// Largest supported MTN order `m` (the upper bound of [`Param::MtnOrder`]).
pub const MAX_MTN_ORDER: usize = 8;

/// `√f32::MAX`: the largest usable `c_1`, `c_2` (the recursion squares them).
pub const MAX_GAIN: f32 = 1.844_674_3e19;

/// One configuration parameter, named after its scenario key (docs/SCENARIO.md).
///
/// Deliberately exhaustive (not `#[non_exhaustive]`): agent-node's object dictionary and the
/// EDS written from it match every variant, so a new parameter cannot compile until it has its
/// CANopen entry. [`Param::ALL`] lists them.
///
/// ```
/// use controller_core::param::{Param, Range};
/// // ζ of (17)–(19): key, unit, default and range in one place.
/// let p = Param::Zeta;
/// assert_eq!((p.key(), p.name(), p.to_string()), ("controller.zeta", "zeta", "zeta".into()));
/// assert_eq!(p.default_f32(), 0.1);
/// assert_eq!(p.spec().range, Range::OpenUnit);
/// assert!(Param::ALL.contains(&p));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Param {
    /// `simulation.h`: sample period `h`.
    H,
    /// `controller.scheme`: proposed law or the LAW §10 baseline.
    Scheme,
    /// `controller.ts`: predefined-time parameter `T_s` (Theorem 1).
    Ts,
    /// `controller.zeta`: `ζ` of (17)–(19).
    Zeta,
    /// `controller.a_check`: MTN design constants `ǎ_j` of (17)–(19).
    ACheck,
    /// `controller.p`: adaptation gain of `μ̂` (20).
    P,
    /// `controller.eta`: adaptation gain of `ξ̂` (21).
    Eta,
    /// `controller.tau`: adaptation gain of `λ̂` (22).
    Tau,
    /// `controller.gamma`: `γ` of `tanh(e_n/γ)` (28).
    Gamma,
    /// `controller.mtn_order`: MTN order `m`.
    MtnOrder,
    /// `controller.phi_low`: lower control-gain bounds `φ_low_j` (Assumption 3).
    PhiLow,
    /// `controller.phi_up`: upper control-gain bounds `φ_up_j` (Assumption 3).
    PhiUp,
    /// `controller.eps_bar`: bounds `ε̄_j` of the differentiator error (Lemma 5).
    EpsBar,
    /// `controller.diff_l1`: differentiator gain `ℓ_1`.
    DiffL1,
    /// `controller.diff_l2`: differentiator gain `ℓ_2`.
    DiffL2,
    /// `controller.varpi0`: `ϖ(0)` of the smoothing width.
    Varpi0,
    /// `controller.varpi_decay`: `κ` of `ϖ(t) = ϖ_0 e^(−κt)`.
    VarpiDecay,
    /// `controller.varpi_min`: floor `ϖ_min`.
    VarpiMin,
    /// `controller.mu0`: `μ̂(0)`.
    Mu0,
    /// `controller.xi0`: `ξ̂(0)`.
    Xi0,
    /// `controller.lambda0`: `λ̂(0)`.
    Lambda0,
    /// `controller.estimate_max`: projection bound of `μ̂`, `ξ̂`, `λ̂`.
    EstimateMax,
    /// `controller.c1`: explicit `c_1`.
    C1,
    /// `controller.c2`: explicit `c_2`.
    C2,
    /// `controller.gain_reading`: which reading of the gain factor of Theorem 1 (D1).
    GainReading,
    /// `controller.kappa`: exponent `κ` of the baseline's `μ_T(t)`.
    Kappa,
    /// `controller.mu_max`: cap `μ_max` of `μ_T(t)`.
    MuMax,
    /// `controller.t_prescribed`: `T` of `μ_T(t)`.
    TPrescribed,
    /// `quantizer.enabled`: the hysteresis quantizer (2) on or off.
    QuantizerEnabled,
    /// `quantizer.rho`: level ratio `ρ` of (2).
    Rho,
    /// `quantizer.u_min`: smallest level `u_min` of (2).
    UMin,
    /// `quantizer.direction`: reading of the direction of (2).
    Direction,
    /// `safety.enabled`: limits, anti-windup and recovery on or off.
    SafetyEnabled,
    /// `safety.u_max`: command magnitude limit.
    UMax,
    /// `safety.du_max`: command rate limit.
    DuMax,
    /// `safety.recovery_rate`: speed `v_r` of a returning link's re-entry.
    RecoveryRate,
    /// `safety.recovery_jump`: jumps that re-enter at once.
    RecoveryJump,
    /// `graph.neighbours`: the neighbours an agent hears (`S_i`).
    Neighbours,
    /// `graph.pinned`: the agent hears the leader (`r_i = 1`).
    Pinned,
    /// `plant.model`: the plant fixes the state order `n`.
    StateOrder,
    /// `controller.feedforward`: the velocity feed-forward of LAW §5a (off: the paper's law).
    Feedforward,
}

/// A parameter's default as a scenario file states it.
///
/// ```
/// use controller_core::param::{DefaultValue, Param};
/// assert_eq!(Param::Ts.spec().default, DefaultValue::Num(2.0)); // Example 1's T_s
/// assert_eq!(Param::ACheck.spec().default, DefaultValue::PerStep(90.0)); // ǎ_j
/// assert_eq!(Param::C1.spec().default, DefaultValue::Computed); // c_1 of Theorem 1
/// assert_eq!(Param::SafetyEnabled.spec().default, DefaultValue::Bool(false));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DefaultValue {
    /// A number.
    Num(f64),
    /// The same number for every step `j = 1..n`.
    PerStep(f64),
    /// Computed from other parameters (the gains of LAW §3).
    Computed,
    /// The value of another parameter.
    Same(Param),
    /// Absent: the feature it sets is off.
    None,
    /// A switch.
    Bool(bool),
    /// One of the names of [`Range::OneOf`].
    Name(&'static str),
    /// Given by another section of the scenario (graph, plant).
    Elsewhere,
}

/// The values a parameter accepts; every number must also be finite unless stated.
///
/// ```
/// use controller_core::param::{Param, Range};
/// use controller_core::Reason;
/// // ρ of the quantizer (2) lies in (0, 1); so does ζ.
/// let r = Param::Rho.spec().range;
/// assert_eq!(r, Range::OpenUnit);
/// assert_eq!(r.to_string(), "in (0, 1)");
/// assert_eq!(r.check(0.9), Ok(0.9));
/// assert_eq!(r.check(1.0), Err(Reason::OutOfRange));
/// // ϖ_min lies in (0, ϖ_0], compared by the constructor.
/// assert_eq!(Param::VarpiMin.spec().range, Range::UpTo(Param::Varpi0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    /// `> 0`.
    Positive,
    /// `> 0`, `+∞` included.
    PositiveOrInfinite,
    /// `≥ 0`.
    NonNegative,
    /// `(0, 1)`.
    OpenUnit,
    /// `≠ 0`.
    NonZero,
    /// `≥ 1`.
    AtLeastOne,
    /// `(0, p]` for the value of parameter `p` (compared by the constructor).
    UpTo(Param),
    /// `≥` the value of parameter `p` (compared by the constructor).
    AtLeast(Param),
    /// An integer in `min..=max`.
    Count {
        /// Smallest value.
        min: usize,
        /// Largest value.
        max: usize,
    },
    /// One of these names.
    OneOf(&'static [&'static str]),
    /// `true` or `false`.
    Bool,
    /// Checked where the scenario resolves it (graph, plant).
    Elsewhere,
}

/// Key, unit, default and range of one parameter.
///
/// ```
/// use controller_core::param::{DefaultValue, Param, Range};
/// let s = Param::UMin.spec(); // u_min of eq. (2)
/// assert_eq!((s.key, s.unit, s.default), ("quantizer.u_min", "`[u]`", DefaultValue::Num(0.01)));
/// assert_eq!(s.range, Range::Positive);
/// assert!(!s.per_step && Param::PhiLow.spec().per_step);
/// assert_eq!(Param::UMax.spec().condition, ", above `quantizer.u_min`");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spec {
    /// Scenario key, `section.name`.
    pub key: &'static str,
    /// Unit as docs/SCENARIO.md writes it (`–`: none).
    pub unit: &'static str,
    /// Default.
    pub default: DefaultValue,
    /// Accepted values.
    pub range: Range,
    /// One value per step `j = 1..n`.
    pub per_step: bool,
    /// A condition that involves other keys, as docs/SCENARIO.md writes it after the range.
    pub condition: &'static str,
}

const fn spec(key: &'static str, unit: &'static str, default: DefaultValue, range: Range) -> Spec {
    Spec {
        key,
        unit,
        default,
        range,
        per_step: false,
        condition: "",
    }
}

const fn per_step(key: &'static str, default: f64, range: Range) -> Spec {
    Spec {
        per_step: true,
        ..spec(key, "–", DefaultValue::PerStep(default), range)
    }
}

const fn with(s: Spec, condition: &'static str) -> Spec {
    Spec { condition, ..s }
}

/// Names of `controller.scheme`.
pub const SCHEMES: &[&str] = &["predefined-time", "prescribed-time"];
/// Names of `quantizer.direction`.
pub const DIRECTIONS: &[&str] = &["signed", "magnitude"];
/// Names of `controller.gain_reading`.
pub const GAIN_READINGS: &[&str] = &["reconstructed", "printed"];
/// Names of `controller.feedforward`.
pub const FEEDFORWARDS: &[&str] = &["off", "estimated"];

const BASELINE_ONLY: &str = "; `prescribed-time` only";

impl Param {
    /// Every parameter, in the order of docs/SCENARIO.md, except the ones added later, which are
    /// appended so that the object dictionary's index of every earlier one stays.
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::ALL[0], Param::H);
    /// // Every scenario key once.
    /// for p in Param::ALL {
    ///     assert_eq!(Param::ALL.iter().filter(|q| q.key() == p.key()).count(), 1);
    /// }
    /// ```
    pub const ALL: [Self; 41] = [
        Self::H,
        Self::Scheme,
        Self::Ts,
        Self::Zeta,
        Self::ACheck,
        Self::P,
        Self::Eta,
        Self::Tau,
        Self::Gamma,
        Self::MtnOrder,
        Self::PhiLow,
        Self::PhiUp,
        Self::EpsBar,
        Self::DiffL1,
        Self::DiffL2,
        Self::Varpi0,
        Self::VarpiDecay,
        Self::VarpiMin,
        Self::Mu0,
        Self::Xi0,
        Self::Lambda0,
        Self::EstimateMax,
        Self::C1,
        Self::C2,
        Self::GainReading,
        Self::Kappa,
        Self::MuMax,
        Self::TPrescribed,
        Self::QuantizerEnabled,
        Self::Rho,
        Self::UMin,
        Self::Direction,
        Self::SafetyEnabled,
        Self::UMax,
        Self::DuMax,
        Self::RecoveryRate,
        Self::RecoveryJump,
        Self::Neighbours,
        Self::Pinned,
        Self::StateOrder,
        Self::Feedforward,
    ];

    /// The parameter table: scenario key, unit, default and range (docs/SCENARIO.md, LAW §8).
    ///
    /// ```
    /// use controller_core::param::{DefaultValue, Param, Range, MAX_MTN_ORDER};
    /// let s = Param::MtnOrder.spec(); // m of Lemma 4
    /// assert_eq!(s.default, DefaultValue::Num(2.0));
    /// assert_eq!(s.range, Range::Count { min: 1, max: MAX_MTN_ORDER });
    /// // Every numeric default passes its own range.
    /// for p in Param::ALL {
    ///     if let DefaultValue::Num(v) | DefaultValue::PerStep(v) = p.spec().default {
    ///         assert!(p.spec().range.check(v as f32).is_ok(), "{p:?}");
    ///     }
    /// }
    /// ```
    #[must_use]
    pub const fn spec(self) -> Spec {
        use DefaultValue as D;
        use Range as R;
        let num = D::Num;
        match self {
            Self::H => spec("simulation.h", "s", num(1e-3), R::Positive),
            Self::Scheme => spec(
                "controller.scheme",
                "–",
                D::Name("predefined-time"),
                R::OneOf(SCHEMES),
            ),
            Self::Ts => spec("controller.ts", "s", num(2.0), R::Positive),
            Self::Zeta => spec("controller.zeta", "–", num(0.1), R::OpenUnit),
            Self::ACheck => per_step("controller.a_check", 90.0, R::NonZero),
            Self::P => spec("controller.p", "–", num(80.0), R::Positive),
            Self::Eta => spec("controller.eta", "–", num(50.0), R::Positive),
            Self::Tau => spec("controller.tau", "–", num(50.0), R::Positive),
            Self::Gamma => spec("controller.gamma", "`[x_n]`", num(0.1), R::Positive),
            Self::MtnOrder => spec(
                "controller.mtn_order",
                "–",
                num(2.0),
                R::Count {
                    min: 1,
                    max: MAX_MTN_ORDER,
                },
            ),
            Self::PhiLow => per_step("controller.phi_low", 1.0, R::Positive),
            Self::PhiUp => per_step("controller.phi_up", 1.0, R::AtLeast(Self::PhiLow)),
            Self::EpsBar => per_step("controller.eps_bar", 0.0, R::NonNegative),
            Self::DiffL1 => spec("controller.diff_l1", "–", num(1.0), R::Positive),
            Self::DiffL2 => spec("controller.diff_l2", "–", num(1.0), R::Positive),
            Self::Varpi0 => spec("controller.varpi0", "–", num(0.1), R::Positive),
            Self::VarpiDecay => spec("controller.varpi_decay", "1/s", num(0.7), R::NonNegative),
            Self::VarpiMin => spec(
                "controller.varpi_min",
                "–",
                num(1e-6),
                R::UpTo(Self::Varpi0),
            ),
            Self::Mu0 => spec("controller.mu0", "–", num(0.0), R::NonNegative),
            Self::Xi0 => spec("controller.xi0", "–", num(0.0), R::NonNegative),
            Self::Lambda0 => spec("controller.lambda0", "–", num(1.0), R::NonNegative),
            Self::EstimateMax => with(
                spec("controller.estimate_max", "–", num(1e6), R::Positive),
                ", `≥` the initial estimates",
            ),
            Self::C1 => with(
                spec("controller.c1", "1/s", D::Computed, R::Positive),
                ", with `c2`",
            ),
            Self::C2 => with(
                spec("controller.c2", "1/s", D::Computed, R::Positive),
                ", with `c1`",
            ),
            Self::GainReading => with(
                spec(
                    "controller.gain_reading",
                    "–",
                    D::Name("reconstructed"),
                    R::OneOf(GAIN_READINGS),
                ),
                ", without `c1`, `c2`",
            ),
            Self::Kappa => with(
                spec("controller.kappa", "–", num(2.0), R::Positive),
                BASELINE_ONLY,
            ),
            Self::MuMax => with(
                spec("controller.mu_max", "–", num(10.0), R::AtLeastOne),
                BASELINE_ONLY,
            ),
            Self::TPrescribed => with(
                spec(
                    "controller.t_prescribed",
                    "s",
                    D::Same(Self::Ts),
                    R::Positive,
                ),
                BASELINE_ONLY,
            ),
            Self::QuantizerEnabled => spec("quantizer.enabled", "–", D::Bool(true), R::Bool),
            Self::Rho => spec("quantizer.rho", "–", num(0.9), R::OpenUnit),
            Self::UMin => spec("quantizer.u_min", "`[u]`", num(0.01), R::Positive),
            Self::Direction => spec(
                "quantizer.direction",
                "–",
                D::Name("signed"),
                R::OneOf(DIRECTIONS),
            ),
            Self::SafetyEnabled => spec("safety.enabled", "–", D::Bool(false), R::Bool),
            Self::UMax => with(
                spec("safety.u_max", "`[u]`", D::None, R::Positive),
                ", above `quantizer.u_min`",
            ),
            Self::DuMax => spec("safety.du_max", "`[u]`/s", D::None, R::Positive),
            Self::RecoveryRate => spec(
                "safety.recovery_rate",
                "`[y]`/s",
                num(1.0),
                R::PositiveOrInfinite,
            ),
            Self::RecoveryJump => spec("safety.recovery_jump", "`[y]`", num(0.05), R::NonNegative),
            Self::Neighbours => spec("graph.neighbours", "–", D::Elsewhere, R::Elsewhere),
            Self::Pinned => spec("graph.pinned", "–", D::Elsewhere, R::Elsewhere),
            Self::StateOrder => spec("plant.model", "–", D::Elsewhere, R::Elsewhere),
            Self::Feedforward => with(
                spec(
                    "controller.feedforward",
                    "–",
                    D::Name("off"),
                    R::OneOf(FEEDFORWARDS),
                ),
                ", not with `n = 1`",
            ),
        }
    }

    /// The parameter as figure text names it: the paper's symbol with a few words, e.g.
    /// `predefined time Tₛ` (the unit is [`Spec::unit`]).
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::Ts.label(), "predefined time Tₛ"); // T_s of Theorem 1
    /// assert_eq!(Param::Ts.spec().unit, "s");
    /// assert!(Param::ALL.iter().all(|p| !p.label().is_empty()));
    /// ```
    #[must_use]
    pub const fn label(self) -> &'static str {
        match self {
            Self::H => "sample period h",
            Self::Scheme => "control scheme",
            Self::Ts => "predefined time Tₛ",
            Self::Zeta => "gain constant ζ",
            Self::ACheck => "MTN design constant ǎ",
            Self::P => "adaptation gain p of μ̂",
            Self::Eta => "adaptation gain η of ξ̂",
            Self::Tau => "adaptation gain τ of λ̂",
            Self::Gamma => "smoothing width γ",
            Self::MtnOrder => "MTN order m",
            Self::PhiLow => "lower control-gain bound φ",
            Self::PhiUp => "upper control-gain bound φ̄",
            Self::EpsBar => "differentiator error bound ε̄",
            Self::DiffL1 => "differentiator gain ℓ₁",
            Self::DiffL2 => "differentiator gain ℓ₂",
            Self::Varpi0 => "smoothing width ϖ(0)",
            Self::VarpiDecay => "smoothing decay κ",
            Self::VarpiMin => "smoothing floor ϖ min",
            Self::Mu0 => "initial estimate μ̂(0)",
            Self::Xi0 => "initial estimate ξ̂(0)",
            Self::Lambda0 => "initial estimate λ̂(0)",
            Self::EstimateMax => "estimate bound",
            Self::C1 => "gain c₁",
            Self::C2 => "gain c₂",
            Self::GainReading => "gain reading",
            Self::Kappa => "baseline exponent κ",
            Self::MuMax => "baseline cap μ max",
            Self::TPrescribed => "prescribed time T",
            Self::QuantizerEnabled => "quantizer",
            Self::Rho => "quantizer level ratio ρ",
            Self::UMin => "quantizer smallest level u min",
            Self::Direction => "quantizer direction",
            Self::SafetyEnabled => "safety layer",
            Self::UMax => "command limit u max",
            Self::DuMax => "command rate limit",
            Self::RecoveryRate => "recovery rate",
            Self::RecoveryJump => "recovery jump",
            Self::Neighbours => "neighbours",
            Self::Pinned => "pinned to the leader",
            Self::StateOrder => "plant model",
            Self::Feedforward => "velocity feed-forward",
        }
    }

    /// The scenario key, e.g. `controller.ts`.
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::Ts.key(), "controller.ts");
    /// assert_eq!(Param::H.key(), "simulation.h");
    /// assert_eq!(Param::Rho.key(), "quantizer.rho");
    /// ```
    #[must_use]
    pub const fn key(self) -> &'static str {
        self.spec().key
    }

    /// The key without its section, e.g. `ts`.
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::ACheck.name(), "a_check"); // ǎ_j
    /// assert_eq!(Param::RecoveryRate.name(), "recovery_rate");
    /// ```
    #[must_use]
    pub fn name(self) -> &'static str {
        let key = self.key();
        key.rsplit_once('.').map_or(key, |(_, name)| name)
    }

    /// The numeric default (`NaN` for a parameter without one, which every range rejects).
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert_eq!(Param::VarpiMin.default_f64(), 1e-6); // ϖ_min of LAW §4
    /// assert!(Param::C1.default_f64().is_nan()); // computed, not a number of the table
    /// assert!(Param::C1.check(Param::C1.default_f32()).is_err());
    /// ```
    #[must_use]
    pub const fn default_f64(self) -> f64 {
        match self.spec().default {
            DefaultValue::Num(v) | DefaultValue::PerStep(v) => v,
            _ => f64::NAN,
        }
    }

    /// The default of a switch (`false` for a parameter that is not one).
    ///
    /// ```
    /// use controller_core::param::Param;
    /// assert!(Param::QuantizerEnabled.default_bool()); // eq. (2) is on
    /// assert!(!Param::SafetyEnabled.default_bool()); // the paper's law as printed
    /// assert!(!Param::Ts.default_bool());
    /// ```
    #[must_use]
    pub const fn default_bool(self) -> bool {
        matches!(self.spec().default, DefaultValue::Bool(true))
    }

    /// [`Self::default_f64`] in the controller's `f32`.
    ///
    /// ```
    /// use controller_core::{param::Param, ControllerConfig};
    /// assert_eq!(Param::Tau.default_f32(), 50.0); // τ of (22), Example 1
    /// assert_eq!(ControllerConfig::<2>::default().tau, Param::Tau.default_f32());
    /// ```
    #[must_use]
    pub const fn default_f32(self) -> f32 {
        self.default_f64() as f32
    }
}

impl fmt::Display for Param {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Range {
    /// The numeric part of the range: the reason `v` is outside it.
    ///
    /// ```
    /// use controller_core::{param::Range, Reason};
    /// assert_eq!(Range::Positive.check(0.0), Err(Reason::NonPositive));
    /// assert_eq!(Range::NonNegative.check(-1e-9), Err(Reason::Negative));
    /// assert_eq!(Range::Positive.check(f32::INFINITY), Err(Reason::NonFinite));
    /// // recovery_rate = ∞ means "no blending" (safety).
    /// assert_eq!(Range::PositiveOrInfinite.check(f32::INFINITY), Ok(f32::INFINITY));
    /// ```
    pub fn check(self, v: f32) -> Result<f32, Reason> {
        let finite = match self {
            Self::PositiveOrInfinite => !v.is_nan(),
            _ => v.is_finite(),
        };
        if !finite {
            return Err(Reason::NonFinite);
        }
        match self {
            Self::Positive | Self::PositiveOrInfinite if v <= 0.0 => Err(Reason::NonPositive),
            Self::NonNegative if v < 0.0 => Err(Reason::Negative),
            Self::NonZero if v == 0.0 => Err(Reason::Zero),
            Self::OpenUnit if v <= 0.0 || v >= 1.0 => Err(Reason::OutOfRange),
            Self::AtLeastOne if v < 1.0 => Err(Reason::OutOfRange),
            Self::UpTo(_) if v <= 0.0 => Err(Reason::OutOfRange),
            _ => Ok(v),
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Positive => f.write_str("> 0"),
            Self::PositiveOrInfinite => f.write_str("> 0 (inf allowed)"),
            Self::NonNegative => f.write_str(">= 0"),
            Self::OpenUnit => f.write_str("in (0, 1)"),
            Self::NonZero => f.write_str("!= 0"),
            Self::AtLeastOne => f.write_str(">= 1"),
            Self::UpTo(p) => write!(f, "in (0, {p}]"),
            Self::AtLeast(p) => write!(f, ">= {p}"),
            Self::Count { min, max } if *max == usize::MAX => write!(f, ">= {min}"),
            Self::Count { min, max } => write!(f, "in {min}..={max}"),
            Self::OneOf(names) => {
                f.write_str("one of")?;
                for n in *names {
                    write!(f, " \"{n}\"")?;
                }
                Ok(())
            }
            Self::Bool => f.write_str("true or false"),
            Self::Elsewhere => f.write_str("valid"),
        }
    }
}

/// Why a parameter was rejected.
///
/// `#[non_exhaustive]`: new checks bring new reasons.
///
/// ```
/// use controller_core::{param::Param, ControllerConfig, Params, Reason};
/// // φ_low_1 = 2 above φ_up_1 = 1 breaks φ_low ≤ φ ≤ φ_up (Assumption 3).
/// let cfg = ControllerConfig::<2> { phi_low: [2.0, 1.0], ..Default::default() };
/// let e = Params::new(&cfg, 0).unwrap_err();
/// assert_eq!(e.reason(), Reason::Exceeds(Param::PhiUp));
/// assert_eq!(e.to_string(), "`phi_low[1]` must not exceed `phi_up[1]`");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Reason {
    /// NaN or infinite.
    NonFinite,
    /// Must be > 0.
    NonPositive,
    /// Must be ≥ 0.
    Negative,
    /// Must not be 0 (it divides the law).
    Zero,
    /// Outside its [`Range`].
    OutOfRange,
    /// A gain at or above `√f32::MAX`: the second backstepping step squares it, so every step
    /// would overflow `f32`.
    TooLarge,
    /// A setting derived from the parameter (its reciprocal, or its product with `A_i`) is not a
    /// finite `f32`, e.g. a subnormal `γ` or `φ_low`: every step would overflow.
    DerivedOverflow,
    /// Above the value of this parameter.
    Exceeds(Param),
    /// At or below the value of this parameter.
    NotAbove(Param),
    /// Below one of the initial estimates `μ̂(0)`, `ξ̂(0)`, `λ̂(0)`.
    BelowInitialEstimates,
    /// More neighbours than the controller's capacity `K`.
    OverCapacity,
    /// The agent hears neither a neighbour nor the leader (`A_i = 0`): it cannot take part.
    Isolated,
    /// A per-step parameter without one entry per step `j = 1..n`.
    StepCount {
        /// `n`.
        expected: u8,
        /// Entries given (saturated at `u32::MAX`).
        got: u32,
    },
    /// `c1` or `c2` given without the other.
    Unpaired,
    /// A baseline parameter given for the predefined-time scheme.
    BaselineOnly,
    /// Set, but controller-core was built without the feature that implements it (`safety`).
    NotBuilt,
    /// Set together with this parameter, which overrides it.
    Conflicts(Param),
}

/// The reason alone, without the parameter ([`crate::ConfigError`]'s `Display` names it).
impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite => f.write_str("not a finite number"),
            Self::NonPositive => f.write_str("must be > 0"),
            Self::Negative => f.write_str("must be >= 0"),
            Self::Zero => f.write_str("must not be 0"),
            Self::OutOfRange => f.write_str("outside its range"),
            Self::TooLarge => f.write_str("at or above sqrt(f32::MAX): every step would overflow"),
            Self::DerivedOverflow => f.write_str("a setting derived from it overflows f32"),
            Self::Exceeds(q) => write!(f, "must not exceed `{}`", q.key()),
            Self::NotAbove(q) => write!(f, "must be above `{}`", q.key()),
            Self::BelowInitialEstimates => {
                f.write_str("must not be below `mu0`, `xi0` and `lambda0`")
            }
            Self::OverCapacity => f.write_str("exceeds the controller's capacity K"),
            Self::Isolated => f.write_str("the agent hears neither a neighbour nor the leader"),
            Self::StepCount { expected, got } => {
                write!(f, "must have {expected} entries, one per step (got {got})")
            }
            Self::Unpaired => f.write_str("given without its pair (`c1` and `c2`)"),
            Self::BaselineOnly => f.write_str("only for the baseline scheme"),
            Self::NotBuilt => f.write_str("needs controller-core's `safety` feature"),
            Self::Conflicts(q) => write!(f, "cannot be used with `{}`", q.key()),
        }
    }
}

impl core::error::Error for Reason {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_param_is_listed_once_in_all() {
        for (i, p) in Param::ALL.iter().enumerate() {
            assert_eq!(Param::ALL.iter().position(|q| q == p), Some(i), "{p:?}");
        }
        for p in Param::ALL {
            // The exhaustive match: a new variant fails to compile until it is listed here.
            match p {
                Param::H
                | Param::Scheme
                | Param::Ts
                | Param::Zeta
                | Param::ACheck
                | Param::P
                | Param::Eta
                | Param::Tau
                | Param::Gamma
                | Param::MtnOrder
                | Param::PhiLow
                | Param::PhiUp
                | Param::EpsBar
                | Param::DiffL1
                | Param::DiffL2
                | Param::Varpi0
                | Param::VarpiDecay
                | Param::VarpiMin
                | Param::Mu0
                | Param::Xi0
                | Param::Lambda0
                | Param::EstimateMax
                | Param::C1
                | Param::C2
                | Param::GainReading
                | Param::Kappa
                | Param::MuMax
                | Param::TPrescribed
                | Param::QuantizerEnabled
                | Param::Rho
                | Param::UMin
                | Param::Direction
                | Param::SafetyEnabled
                | Param::UMax
                | Param::DuMax
                | Param::RecoveryRate
                | Param::RecoveryJump
                | Param::Neighbours
                | Param::Pinned
                | Param::StateOrder
                | Param::Feedforward => {}
            }
        }
    }

    #[test]
    fn keys_are_unique_and_dotted() {
        for p in Param::ALL {
            let key = p.key();
            assert!(key.contains('.'), "{key}");
            assert_eq!(
                Param::ALL.iter().filter(|q| q.key() == key).count(),
                1,
                "{key}"
            );
        }
    }

    #[test]
    fn every_numeric_default_lies_in_its_range() {
        for p in Param::ALL {
            if let DefaultValue::Num(_) | DefaultValue::PerStep(_) = p.spec().default {
                assert_eq!(p.check(p.default_f32()), Ok(p.default_f32()), "{p:?}");
            }
        }
    }

    #[test]
    fn ranges_reject_what_they_exclude() {
        assert_eq!(Range::Positive.check(0.0), Err(Reason::NonPositive));
        assert_eq!(Range::Positive.check(f32::INFINITY), Err(Reason::NonFinite));
        assert_eq!(
            Range::PositiveOrInfinite.check(f32::INFINITY),
            Ok(f32::INFINITY)
        );
        assert_eq!(
            Range::PositiveOrInfinite.check(f32::NAN),
            Err(Reason::NonFinite)
        );
        assert_eq!(Range::NonNegative.check(-1e-9), Err(Reason::Negative));
        assert_eq!(Range::OpenUnit.check(1.0), Err(Reason::OutOfRange));
        assert_eq!(Range::NonZero.check(-0.0), Err(Reason::Zero));
        assert_eq!(Range::AtLeastOne.check(0.99), Err(Reason::OutOfRange));
        assert_eq!(
            Param::MtnOrder.check_count(9).map_err(|e| e.param()),
            Err(Param::MtnOrder)
        );
        assert_eq!(Param::MtnOrder.check_count(8), Ok(8));
    }
}
