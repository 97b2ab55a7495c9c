//! The controller's configuration as a user writes it, and its one-time validation into the
//! read-only [`Params`] the hot path uses.

use crate::{
    adaptive::{AdaptiveLaws, Estimates},
    backstepping::{Backstepping, Feedforward},
    consensus::Consensus,
    differentiator::LevantDifferentiator,
    error::{ConfigError, ConfigErrors},
    gains::{GainSelection, Gains},
    mtn::MtnRegressor,
    param::{Param, Reason},
    quantizer::{HysteresisQuantizer, QuantizerConfig},
    safety::{Safety, SafetyConfig},
    scheme::{Scheme, SchemeConfig},
    smoothing::VarpiSchedule,
};

pub use crate::error::MAX_CONFIG_ERRORS;

/// Everything one agent's controller needs, with the defaults of LAW §8 (Example 1, agent 1:
/// pinned, no neighbours). Step-indexed arrays hold step `j` at index `j−1`.
///
/// ```
/// use controller_core::{ControllerConfig, GainSelection, QuantizerConfig};
/// // Example 2 of the paper (LAW §8), agent 3: hears agent 1, T_s = 0.5, ζ = 0.6.
/// let cfg = ControllerConfig::<2> {
///     neighbour_count: 1,
///     pinned: false,
///     ts: 0.5,
///     zeta: 0.6,
///     a_check: [100.0, 120.0],
///     p: 30.0,
///     eta: 30.0,
///     tau: 30.0,
///     ..ControllerConfig::default()
/// };
/// assert!(cfg.errors(4).is_empty());
/// // What Example 1 and 2 share is the default: ρ = 0.9, u_min = 0.01, ϖ(0) = 0.1, κ = 0.7.
/// assert_eq!(cfg.quantizer, Some(QuantizerConfig { rho: 0.9, u_min: 0.01, ..Default::default() }));
/// assert_eq!((cfg.varpi0, cfg.varpi_decay), (0.1, 0.7));
/// assert_eq!(cfg.gains, GainSelection::Auto); // c_1, c_2 from Theorem 1
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControllerConfig<const N: usize> {
    /// Sample period `h` (s).
    pub h: f32,
    /// `S_i`: neighbours this agent hears (their values come in this order to `step`).
    pub neighbour_count: usize,
    /// `r_i = 1`: the agent hears the leader.
    pub pinned: bool,
    /// Predefined-time parameter `T_s` (s); the settling time is `2 T_s`.
    pub ts: f32,
    /// `ζ ∈ (0, 1)`.
    pub zeta: f32,
    /// `c_1`, `c_2` from §3 or explicit.
    pub gains: GainSelection,
    /// MTN design constants `ǎ_j`.
    pub a_check: [f32; N],
    /// Adaptation gain `p` of `μ̂`.
    pub p: f32,
    /// Adaptation gain `η` of `ξ̂`.
    pub eta: f32,
    /// Adaptation gain `τ` of `λ̂`.
    pub tau: f32,
    /// `γ > 0` of `tanh(e_n/γ)`.
    pub gamma: f32,
    /// MTN order `m`.
    pub mtn_order: usize,
    /// Known lower bounds `φ_low_j > 0` of the control gains.
    pub phi_low: [f32; N],
    /// Known upper bounds `φ_up_j ≥ φ_low_j`.
    pub phi_up: [f32; N],
    /// `ε̄_j ≥ 0`: bound of the differentiator error of `α_j` (the last entry is unused).
    pub eps_bar: [f32; N],
    /// Differentiator gain `ℓ_1`.
    pub diff_l1: f32,
    /// Differentiator gain `ℓ_2`.
    pub diff_l2: f32,
    /// `ϖ(0)`.
    pub varpi0: f32,
    /// Decay rate `κ` of `ϖ(t) = ϖ_0 e^(−κt)`.
    pub varpi_decay: f32,
    /// Floor `ϖ_min > 0`.
    pub varpi_min: f32,
    /// `μ̂(0) ≥ 0`.
    pub mu0: f32,
    /// `ξ̂(0) ≥ 0`.
    pub xi0: f32,
    /// `λ̂(0) ≥ 0`.
    pub lambda0: f32,
    /// Projection bound `θ_max` of the three estimates (default 1e6; see [`crate::adaptive`]).
    pub estimate_max: f32,
    /// The hysteresis quantizer of every actuator; `None` sends `u` unquantized (`δ = 0`).
    pub quantizer: Option<QuantizerConfig>,
    /// Proposed scheme or baseline.
    pub scheme: SchemeConfig,
    /// Command limits, anti-windup and recovery ([`crate::safety`]); `None` (default) is the
    /// paper's law.
    pub safety: Option<SafetyConfig>,
    /// Velocity feed-forward (LAW §5a); [`Feedforward::Off`] (default) is the paper's law.
    pub feedforward: Feedforward,
}

impl<const N: usize> Default for ControllerConfig<N> {
    fn default() -> Self {
        Self {
            h: const { Param::H.default_f32() },
            neighbour_count: 0,
            pinned: true,
            ts: const { Param::Ts.default_f32() },
            zeta: const { Param::Zeta.default_f32() },
            gains: GainSelection::Auto,
            a_check: [const { Param::ACheck.default_f32() }; N],
            p: const { Param::P.default_f32() },
            eta: const { Param::Eta.default_f32() },
            tau: const { Param::Tau.default_f32() },
            gamma: const { Param::Gamma.default_f32() },
            mtn_order: const { Param::MtnOrder.default_f64() as usize },
            phi_low: [const { Param::PhiLow.default_f32() }; N],
            phi_up: [const { Param::PhiUp.default_f32() }; N],
            eps_bar: [const { Param::EpsBar.default_f32() }; N],
            diff_l1: const { Param::DiffL1.default_f32() },
            diff_l2: const { Param::DiffL2.default_f32() },
            varpi0: const { Param::Varpi0.default_f32() },
            varpi_decay: const { Param::VarpiDecay.default_f32() },
            varpi_min: const { Param::VarpiMin.default_f32() },
            mu0: const { Param::Mu0.default_f32() },
            xi0: const { Param::Xi0.default_f32() },
            lambda0: const { Param::Lambda0.default_f32() },
            estimate_max: const { Param::EstimateMax.default_f32() },
            quantizer: Some(QuantizerConfig::default()),
            scheme: SchemeConfig::PredefinedTime,
            safety: None,
            feedforward: Feedforward::Off,
        }
    }
}

impl<const N: usize> ControllerConfig<N> {
    /// Every problem of the configuration for neighbour capacity `capacity`, in the order
    /// [`Params::new`] meets them (its error is the first); empty when it is valid.
    ///
    /// Each rejected value is replaced by one that passes and the check repeated, so a problem
    /// is reported once whatever it makes of the later checks.
    ///
    /// ```
    /// use controller_core::{param::Param, ControllerConfig, Reason};
    /// let cfg = ControllerConfig::<2> {
    ///     ts: -1.0,                // T_s > 0 (Theorem 1)
    ///     phi_low: [1.0, 3.0],     // φ_low_2 above φ_up_2 = 1 (Assumption 3)
    ///     gamma: 0.0,              // γ divides tanh(e_n/γ) (28)
    ///     ..Default::default()
    /// };
    /// let found: Vec<_> = cfg.errors(4).iter().map(|e| (e.param(), e.step())).collect();
    /// assert_eq!(found, [(Param::Ts, None), (Param::PhiLow, Some(2)), (Param::Gamma, None)]);
    /// assert_eq!(cfg.errors(4)[1].reason(), Reason::Exceeds(Param::PhiUp));
    /// assert!(ControllerConfig::<2>::default().errors(4).is_empty());
    /// ```
    #[must_use]
    pub fn errors(&self, capacity: usize) -> ConfigErrors {
        let mut found = ConfigErrors::new();
        let mut cfg = *self;
        while let Err(e) = Params::new(&cfg, capacity) {
            if found.contains(&e) || found.push(e).is_err() || !cfg.replace_rejected(&e) {
                break;
            }
        }
        found
    }

    /// Replaces the value `e` rejects by one that passes its check and creates no new
    /// problem; `false` when there is none.
    fn replace_rejected(&mut self, e: &ConfigError) -> bool {
        let d = |p: Param| p.default_f32();
        let valid = |p: Param, v: f32| p.check(v).is_ok();
        let j = e.step().map(|s| usize::from(s).saturating_sub(1));
        match (e.param(), e.reason(), j) {
            (Param::H, ..) => self.h = d(Param::H),
            (Param::ACheck, _, Some(j)) if j < N => self.a_check[j] = d(Param::ACheck),
            (Param::PhiLow, Reason::Exceeds(_), Some(j)) if j < N => {
                self.phi_up[j] = self.phi_low[j];
            }
            (Param::PhiLow, _, Some(j)) if j < N => {
                let up = self.phi_up[j];
                if valid(Param::PhiLow, up) && up.is_normal() {
                    self.phi_low[j] = up;
                } else {
                    // A φ_up that passes its own check but no φ_low fits under is raised with
                    // it, so the replacement does not add an `exceeds` problem.
                    self.phi_low[j] = d(Param::PhiLow);
                    if valid(Param::PhiUp, up) {
                        self.phi_up[j] = up.max(d(Param::PhiLow));
                    }
                }
            }
            (Param::PhiUp, _, Some(j)) if j < N => self.phi_up[j] = self.phi_low[j],
            (Param::EpsBar, _, Some(j)) if j < N => self.eps_bar[j] = d(Param::EpsBar),
            (Param::C1 | Param::C2, _, _) if self.gains != GainSelection::Auto => {
                self.gains = GainSelection::Auto;
            }
            (Param::Ts, ..) => self.ts = d(Param::Ts),
            (Param::Zeta, ..) => self.zeta = d(Param::Zeta),
            (Param::P, ..) => self.p = d(Param::P),
            (Param::Eta, ..) => self.eta = d(Param::Eta),
            (Param::Tau, ..) => self.tau = d(Param::Tau),
            (Param::Gamma, ..) => self.gamma = d(Param::Gamma),
            (Param::MtnOrder, ..) => self.mtn_order = Param::MtnOrder.default_f64() as usize,
            (Param::Neighbours, ..) => {
                self.neighbour_count = 0;
                self.pinned = true;
            }
            (Param::DiffL1, ..) => self.diff_l1 = d(Param::DiffL1),
            (Param::DiffL2, ..) => self.diff_l2 = d(Param::DiffL2),
            (Param::Varpi0, ..) => {
                self.varpi0 = if valid(Param::Varpi0, self.varpi_min) {
                    self.varpi_min.max(d(Param::Varpi0))
                } else {
                    d(Param::Varpi0)
                };
            }
            (Param::VarpiDecay, ..) => self.varpi_decay = d(Param::VarpiDecay),
            (Param::VarpiMin, ..) => self.varpi_min = self.varpi0,
            (Param::Mu0, ..) => self.mu0 = 0.0,
            (Param::Xi0, ..) => self.xi0 = 0.0,
            (Param::Lambda0, ..) => self.lambda0 = 0.0,
            (Param::EstimateMax, ..) => self.estimate_max = f32::MAX,
            (Param::Kappa | Param::MuMax | Param::TPrescribed, ..) => match &mut self.scheme {
                SchemeConfig::PrescribedTime(b) => {
                    let def = crate::scheme::BaselineConfig::default();
                    match e.param() {
                        Param::Kappa => b.kappa = def.kappa,
                        Param::MuMax => b.mu_max = def.mu_max,
                        _ => b.t_prescribed = None,
                    }
                }
                SchemeConfig::PredefinedTime => return false,
            },
            (Param::Rho | Param::UMin, ..) => match &mut self.quantizer {
                Some(q) => {
                    let def = QuantizerConfig::default();
                    if e.param() == Param::Rho {
                        q.rho = def.rho;
                    } else {
                        q.u_min = def.u_min;
                    }
                }
                None => return false,
            },
            (Param::Feedforward, ..) => self.feedforward = Feedforward::Off,
            (Param::UMax | Param::DuMax | Param::RecoveryRate | Param::RecoveryJump, ..) => {
                match &mut self.safety {
                    Some(s) => match e.param() {
                        Param::UMax => s.u_max = None,
                        Param::DuMax => s.du_max = None,
                        Param::RecoveryRate => s.recovery_rate = d(Param::RecoveryRate),
                        _ => s.recovery_jump = d(Param::RecoveryJump),
                    },
                    None => return false,
                }
            }
            _ => return false,
        }
        true
    }
}

/// The validated, read-only settings of one controller: everything the hot path needs,
/// precomputed, so `step` repeats no check.
///
/// ```
/// use controller_core::{ControllerConfig, Params};
/// // Agent 4 of the examples: neighbours 1 and 3, not pinned, so A_4 = 2 (LAW §2).
/// let cfg = ControllerConfig::<2> { neighbour_count: 2, pinned: false, ..Default::default() };
/// let p = Params::new(&cfg, 4)?;
/// assert_eq!(p.a(), 2.0);
/// assert!(p.quantizer().is_some() && p.safety().is_none());
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Params<const N: usize> {
    pub(crate) h: f32,
    pub(crate) gains: Gains,
    pub(crate) consensus: Consensus,
    pub(crate) backstepping: Backstepping<N>,
    pub(crate) scheme: Scheme,
    pub(crate) laws: AdaptiveLaws,
    /// `p/(2ǎ_j²)`.
    pub(crate) p_over_two_a2: [f32; N],
    pub(crate) eta: f32,
    pub(crate) tau: f32,
    pub(crate) differentiator: LevantDifferentiator,
    pub(crate) quantizer: Option<HysteresisQuantizer>,
    pub(crate) varpi: VarpiSchedule,
    pub(crate) initial: Estimates,
    pub(crate) safety: Option<Safety>,
}

impl<const N: usize> Params<N> {
    /// Validates `cfg` for a controller with neighbour capacity `capacity`; the first problem
    /// [`ControllerConfig::errors`] would list.
    ///
    /// ```
    /// use controller_core::{param::Param, ControllerConfig, Params, Reason};
    /// // Neither neighbours nor the leader: A_i = 0, the agent cannot take part (Assumption 2).
    /// let cfg = ControllerConfig::<2> { pinned: false, ..Default::default() };
    /// let e = Params::new(&cfg, 4).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::Neighbours, Reason::Isolated));
    /// assert_eq!(Some(e), cfg.errors(4).first().copied());
    /// ```
    pub fn new(cfg: &ControllerConfig<N>, capacity: usize) -> Result<Self, ConfigError> {
        if N == 0 {
            return Err(ConfigError::new(Param::StateOrder, Reason::OutOfRange));
        }
        Param::H.check(cfg.h)?;
        let gains = match cfg.gains {
            GainSelection::Auto => {
                Gains::predefined_time(cfg.ts, cfg.zeta, N, cfg.p, cfg.eta, cfg.tau)?
            }
            GainSelection::Explicit { c1, c2 } => {
                // T_s still matters (baseline T, reports): it must be valid too.
                Gains::predefined_time(cfg.ts, cfg.zeta, N, cfg.p, cfg.eta, cfg.tau)?;
                Gains::explicit(c1, c2, cfg.zeta)?
            }
        };
        let mtn = MtnRegressor::new(cfg.mtn_order)?;
        if cfg.neighbour_count > capacity || cfg.neighbour_count > u8::MAX as usize {
            return Err(ConfigError::new(Param::Neighbours, Reason::OverCapacity));
        }
        let consensus = Consensus::new(cfg.neighbour_count as u8, cfg.pinned);
        if consensus.a() == 0.0 {
            return Err(ConfigError::new(Param::Neighbours, Reason::Isolated));
        }
        let quantizer = match &cfg.quantizer {
            Some(q) => Some(HysteresisQuantizer::new(q)?),
            None => None,
        };
        let delta = quantizer.as_ref().map_or(0.0, HysteresisQuantizer::delta);

        let mut inv_two_a2 = [0.0; N];
        let mut p_over_two_a2 = [0.0; N];
        let mut cross = [0.0; N];
        let mut eps_bar = [0.0; N];
        let mut inv_l_phi_low = [0.0; N];
        for j in 0..N {
            let step = (j + 1).min(u8::MAX as usize) as u8;
            let overflow = |p| ConfigError::new(p, Reason::DerivedOverflow).at_step(step);
            let a = Param::ACheck.check_step(step, cfg.a_check[j])?;
            let lo = Param::PhiLow.check_step(step, cfg.phi_low[j])?;
            let up = Param::PhiUp.check_step(step, cfg.phi_up[j])?;
            if lo > up {
                return Err(
                    ConfigError::new(Param::PhiLow, Reason::Exceeds(Param::PhiUp)).at_step(step),
                );
            }
            Param::EpsBar.check_step(step, cfg.eps_bar[j])?;
            inv_two_a2[j] = 1.0 / (2.0 * a * a);
            p_over_two_a2[j] = cfg.p * inv_two_a2[j];
            if !inv_two_a2[j].is_finite() || !p_over_two_a2[j].is_finite() {
                return Err(overflow(Param::ACheck));
            }
            let l = if j == 0 { consensus.a() } else { 1.0 };
            inv_l_phi_low[j] = 1.0 / (l * lo);
            if !inv_l_phi_low[j].is_finite() {
                return Err(overflow(Param::PhiLow));
            }
            if j > 0 {
                let jj = if j == 1 { consensus.a() } else { 1.0 };
                cross[j] = jj * cfg.phi_up[j - 1];
                if !cross[j].is_finite() {
                    return Err(overflow(Param::PhiUp).at_step(step - 1));
                }
                eps_bar[j] = cfg.eps_bar[j - 1];
            }
        }
        let gamma = Param::Gamma.check(cfg.gamma)?;
        let inv_gamma = 1.0 / gamma;
        if !inv_gamma.is_finite() {
            return Err(ConfigError::new(Param::Gamma, Reason::DerivedOverflow));
        }
        Param::DiffL1.check(cfg.diff_l1)?;
        Param::DiffL2.check(cfg.diff_l2)?;
        // LAW §5a: ẇ_i enters α_1, which a first-order plant (n = 1) does not have.
        let feedforward = match cfg.feedforward {
            Feedforward::Off => None,
            Feedforward::Estimated if N < 2 => {
                return Err(ConfigError::new(
                    Param::Feedforward,
                    Reason::Conflicts(Param::StateOrder),
                ))
            }
            Feedforward::Estimated => Some(crate::backstepping::VelocityFeedforward {
                inv_a: 1.0 / consensus.a(),
                inv_phi_up: cfg.phi_up.first().map_or(1.0, |up| 1.0 / up),
            }),
        };
        Param::Varpi0.check(cfg.varpi0)?;
        Param::VarpiDecay.check(cfg.varpi_decay)?;
        if Param::VarpiMin.check(cfg.varpi_min)? > cfg.varpi0 {
            return Err(ConfigError::new(Param::VarpiMin, Reason::OutOfRange));
        }
        let estimate_max = Param::EstimateMax.check(cfg.estimate_max)?;
        let initial = Estimates {
            mu: Param::Mu0.check(cfg.mu0)?,
            xi: Param::Xi0.check(cfg.xi0)?,
            lambda: Param::Lambda0.check(cfg.lambda0)?,
        };
        if initial.mu > estimate_max || initial.xi > estimate_max || initial.lambda > estimate_max {
            return Err(ConfigError::new(
                Param::EstimateMax,
                Reason::BelowInitialEstimates,
            ));
        }
        let scheme = Scheme::new(&cfg.scheme, &gains, cfg.zeta, cfg.ts)?;
        let safety = match &cfg.safety {
            Some(_) if !cfg!(feature = "safety") => {
                return Err(ConfigError::new(Param::SafetyEnabled, Reason::NotBuilt))
            }
            Some(sc) => {
                let safety = Safety::new(sc, cfg.h)?;
                if let Some(q) = &cfg.quantizer {
                    if safety.u_max() <= q.u_min {
                        return Err(ConfigError::new(Param::UMax, Reason::NotAbove(Param::UMin)));
                    }
                }
                Some(safety)
            }
            None => None,
        };
        Ok(Self {
            h: cfg.h,
            gains,
            consensus,
            backstepping: Backstepping {
                mtn,
                inv_two_a2,
                damping_1: (1.0 + consensus.a() + consensus.s()) / 2.0,
                cross,
                eps_bar,
                inv_l_phi_low,
                inv_gamma,
                command_gain: 1.0 / (1.0 - delta),
                feedforward,
            },
            scheme,
            laws: AdaptiveLaws::new(gains.c1, gains.c2, cfg.zeta, cfg.h, estimate_max),
            p_over_two_a2,
            eta: cfg.eta,
            tau: cfg.tau,
            differentiator: LevantDifferentiator::new(cfg.diff_l1, cfg.diff_l2, cfg.h),
            quantizer,
            varpi: VarpiSchedule::new(cfg.varpi0, cfg.varpi_decay, cfg.varpi_min, cfg.h),
            initial,
            safety,
        })
    }

    /// The gains in force: those of Theorem 1, or the explicit `c_1`, `c_2`.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, GainSelection, Params};
    /// let cfg = ControllerConfig::<2> {
    ///     gains: GainSelection::Explicit { c1: 10.0, c2: 9.0 }, // the baseline of LAW §10
    ///     ..Default::default()
    /// };
    /// let g = *Params::new(&cfg, 0)?.gains();
    /// assert_eq!((g.c1, g.c2), (10.0, 9.0));
    /// // k_1 = (1/2)^(1+ζ/2) c_1 with ζ = 0.1.
    /// assert!((g.k1 - 0.5f32.powf(1.05) * 10.0).abs() < 1e-4);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn gains(&self) -> &Gains {
        &self.gains
    }

    /// The sample period `h`.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, Params};
    /// let cfg = ControllerConfig::<2> { h: 2e-4, ..Default::default() }; // Example 2's stable h
    /// assert_eq!(Params::new(&cfg, 0)?.h(), 2e-4);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn h(&self) -> f32 {
        self.h
    }

    /// The quantizer, if any.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, Params};
    /// let p = Params::new(&ControllerConfig::<2>::default(), 0)?;
    /// // δ = (1 − ρ)/(1 + ρ) of eq. (2) for ρ = 0.9.
    /// assert!((p.quantizer().unwrap().delta() - 0.1 / 1.9).abs() < 1e-7);
    /// let off = ControllerConfig::<2> { quantizer: None, ..Default::default() };
    /// assert!(Params::new(&off, 0)?.quantizer().is_none());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn quantizer(&self) -> Option<&HysteresisQuantizer> {
        self.quantizer.as_ref()
    }

    /// `A_i = Σ_k a_{i,k} + r_i` (LAW §2).
    ///
    /// ```
    /// use controller_core::{ControllerConfig, Params};
    /// let cfg = ControllerConfig::<2> { neighbour_count: 3, pinned: true, ..Default::default() };
    /// assert_eq!(Params::new(&cfg, 4)?.a(), 4.0);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn a(&self) -> f32 {
        self.consensus.a()
    }

    /// The velocity feed-forward (LAW §5a), if on.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, Feedforward, Params};
    /// assert!(Params::new(&ControllerConfig::<2>::default(), 0)?.feedforward().is_none());
    /// let on = ControllerConfig::<2> { feedforward: Feedforward::Estimated, ..Default::default() };
    /// assert!(Params::new(&on, 0)?.feedforward().is_some());
    /// // n = 1 has no virtual control α_1 to carry it.
    /// let n1 = ControllerConfig::<1> { feedforward: Feedforward::Estimated, ..Default::default() };
    /// assert_eq!(Params::new(&n1, 0).unwrap_err().to_string(), "`feedforward` cannot be used with `plant.model`");
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn feedforward(&self) -> Option<&crate::backstepping::VelocityFeedforward> {
        self.backstepping.feedforward.as_ref()
    }

    /// The safety settings, if on.
    ///
    /// ```
    /// use controller_core::{ControllerConfig, Params, SafetyConfig};
    /// let cfg = ControllerConfig::<2> {
    ///     safety: Some(SafetyConfig { u_max: Some(5.0), ..Default::default() }),
    ///     ..Default::default()
    /// };
    /// # #[cfg(feature = "safety")] {
    /// assert_eq!(Params::new(&cfg, 0)?.safety().map(|s| s.u_max()), Some(5.0));
    /// # }
    /// assert!(Params::new(&ControllerConfig::<2>::default(), 0)?.safety().is_none());
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn safety(&self) -> Option<&Safety> {
        self.safety.as_ref()
    }
}
