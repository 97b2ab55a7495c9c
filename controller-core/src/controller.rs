//! One agent's controller: the step order of LAW §6 over the blocks of LAW §4–§5.

use crate::{
    adaptive::{Drives, Estimates},
    backstepping::{Backstepping, Estimated, Lane, Signals},
    config::{ControllerConfig, Params},
    consensus::{Link, LinkMemory, LinkReport},
    differentiator::DifferentiatorState,
    error::ConfigError,
    math,
    quantizer::{HysteresisQuantizer, QuantizerState},
    safety::{reenter_link, Recovery, Safety},
};

/// Why a step held the previous command instead of computing a new one.
///
/// A NaN in the agent's own state holds the command of the last good sample (LAW §6):
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link, StepFault};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// let good = c.step(&[0.02, 0.8], &[], Link::Fresh(0.0));
/// let held = c.step(&[f32::NAN, 0.8], &[], Link::Fresh(0.0));
/// assert_eq!(held.status.fault, Some(StepFault::InvalidState));
/// assert_eq!(held.u, good.u);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
///
/// Exhaustive: the PIL record carries each fault as a number (`node-fw` matches every variant),
/// so a new fault must get its number before it compiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepFault {
    /// The agent's own state had a NaN or infinite entry.
    InvalidState,
    /// The law produced a non-finite command, estimate or differentiator state (inputs so large
    /// that `f32` overflowed). Nothing was committed.
    NonFiniteResult,
}

impl core::fmt::Display for StepFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::InvalidState => "the own state has a NaN or infinite entry; command held",
            Self::NonFiniteResult => "the law overflowed f32; command held, no state committed",
        })
    }
}

impl core::error::Error for StepFault {}

/// Health of one step: the links as resolved, and a fault if the command was held.
///
/// `#[non_exhaustive]`: the step gains status flags (as `limited` came with safety); outside
/// this crate it is built by `StepStatus::default()` and read field by field.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// // Agent 4 of the paper's examples: hears agents 1 and 3, not the leader.
/// let cfg = ControllerConfig::<2> { neighbour_count: 2, pinned: false, ..Default::default() };
/// let mut c = Controller::<2, 2, 2>::new(&cfg)?;
/// let st = c.step(&[0.0, 0.7], &[Link::Fresh(0.02), Link::Stale(0.01)], Link::Missing).status;
/// assert!(st.fault.is_none() && !st.limited);
/// assert_eq!(st.links.stale_neighbours, 1);
/// assert!(!st.links.is_clean());
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct StepStatus {
    /// `Some` when `u` and `q` are the previous sample's, held.
    pub fault: Option<StepFault>,
    /// Stale, missing and invalid neighbour / leader values of this sample.
    pub links: LinkReport,
    /// A safety limit (magnitude or rate) changed this sample's command; the adaptive laws
    /// were not integrated (always `false` with safety off).
    pub limited: bool,
}

/// What one step returns: the commands and the internal signals worth logging.
///
/// On a fault (`status.fault.is_some()`), `u` and `q` hold the last committed command, `e`,
/// `alpha` and `beta` are 0 and the estimates are the held ones: every field is finite.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// // Example 1, agent 1: y = 0.02 above the leader's y_d = 0, so e_1 = r_1 (y − y_d) = 0.02 (10).
/// let out = c.step(&[0.02, 0.8], &[], Link::Fresh(0.0));
/// assert!((out.e[0] - 0.02).abs() < 1e-7);
/// // n = 2: one virtual control α_1 (15), the last entry is 0; e_2 = x_2 − α_1.
/// assert_eq!(out.alpha[1], 0.0);
/// assert!((out.e[1] - (0.8 - out.alpha[0])).abs() < 1e-5);
/// // Both actuators get the same u (28); q is a level of the quantizer (2) or 0.
/// assert_eq!(out.u[0], out.u[1]);
/// assert!(out.u[0] < 0.0 && out.q[0] <= 0.0);
/// assert_eq!(out.varpi, 0.1); // ϖ(0) of LAW §8
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepOutput<const N: usize, const M: usize> {
    /// Commands `u_l` before quantization (28).
    pub u: [f32; M],
    /// Quantized commands `q_l = Q(u_l)` (2): the values sent to the actuators.
    pub q: [f32; M],
    /// Errors `e_j` (`e_1` is the consensus error).
    pub e: [f32; N],
    /// Virtual controls `α_j`, `j < n` (last entry 0).
    pub alpha: [f32; N],
    /// `β_j` (the paper's `ᾰ_j`).
    pub beta: [f32; N],
    /// `μ̂`, `ξ̂`, `λ̂` after this step's update.
    pub estimates: Estimates,
    /// `ϖ` used in this step.
    pub varpi: f32,
    /// Faults and link health.
    pub status: StepStatus,
}

/// The mutable state of one agent's controller: small and plain.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// assert_eq!(c.state().k, 0);
/// assert_eq!(c.state().estimates.lambda, 1.0); // λ̂(0) = 1 (LAW §5)
/// let out = c.step(&[0.02, 0.8], &[], Link::Fresh(0.0));
/// let s = c.state();
/// assert_eq!(s.k, 1);
/// assert_eq!((s.u, s.q), (out.u, out.q)); // the committed command
/// assert_eq!(s.estimates, out.estimates);
/// assert!(s.varpi < out.varpi); // ϖ ← ϖ e^(−κh) (LAW §6 step 5)
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct State<const N: usize, const M: usize, const K: usize> {
    /// Samples taken so far (`t = k h`, never an accumulated float time).
    pub k: u32,
    /// `ϖ(t_k)`.
    pub varpi: f32,
    /// `μ̂`, `ξ̂`, `λ̂`.
    pub estimates: Estimates,
    /// Differentiator of `α_j` at index `j−1` (the last is unused).
    pub differentiators: [DifferentiatorState; N],
    /// Differentiator of the weighted neighbour mean `w_i` (LAW §5a; at rest with the
    /// feed-forward off).
    pub feedforward: DifferentiatorState,
    /// One hysteresis quantizer per actuator.
    pub quantizers: [QuantizerState; M],
    /// Last committed `u` (held on a fault).
    pub u: [f32; M],
    /// Last committed `q` (held on a fault).
    pub q: [f32; M],
    /// Remembered neighbour and leader values.
    pub links: LinkMemory<K>,
    /// Re-entry of returning links and the held-step flag (used only with safety on).
    pub recovery: Recovery<K>,
}

/// The predefined-time adaptive consensus controller of one follower agent: `n = N` states,
/// `m = M` actuators, up to `K` neighbours. A fixed-size value with no allocation.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let cfg = ControllerConfig::<2>::default(); // Example 1, agent 1 (pinned)
/// let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
/// let out = c.step(&[0.02, 0.8], &[], Link::Fresh(0.0));
/// assert!(out.status.fault.is_none() && out.u.iter().all(|u| u.is_finite()));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Controller<const N: usize, const M: usize, const K: usize> {
    params: Params<N>,
    state: State<N, M, K>,
}

impl<const N: usize, const M: usize, const K: usize> Controller<N, M, K> {
    /// Validates `cfg` once; the controller starts at `t = 0`. A rejected configuration names
    /// the parameter at fault (and the step `j` of a per-step one).
    ///
    /// ```
    /// use controller_core::{param::Param, Controller, ControllerConfig, Reason};
    /// // ζ must lie in (0, 1) (Theorem 1).
    /// let cfg = ControllerConfig::<2> { zeta: 1.5, ..Default::default() };
    /// let e = Controller::<2, 2, 4>::new(&cfg).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::Zeta, Reason::OutOfRange));
    /// assert_eq!(e.to_string(), "`zeta` must be in (0, 1)");
    ///
    /// // ǎ_2 = 0 would divide (18) by zero: the error names step j = 2.
    /// let cfg = ControllerConfig::<2> { a_check: [90.0, 0.0], ..Default::default() };
    /// let e = Controller::<2, 2, 4>::new(&cfg).unwrap_err();
    /// assert_eq!((e.param(), e.step()), (Param::ACheck, Some(2)));
    ///
    /// // Three neighbours do not fit a controller built for K = 2.
    /// let cfg = ControllerConfig::<2> { neighbour_count: 3, ..Default::default() };
    /// let e = Controller::<2, 2, 2>::new(&cfg).unwrap_err();
    /// assert_eq!(e.reason(), Reason::OverCapacity);
    /// ```
    pub fn new(cfg: &ControllerConfig<N>) -> Result<Self, ConfigError> {
        const { assert!(N > 0, "state order n must be at least 1") };
        const { assert!(M > 0, "an agent needs at least one actuator") };
        let params = Params::new(cfg, K)?;
        let state = Self::initial_state(&params);
        Ok(Self { params, state })
    }

    fn initial_state(params: &Params<N>) -> State<N, M, K> {
        let q0 = params
            .quantizer
            .map_or_else(QuantizerState::default, |q| q.state());
        State {
            k: 0,
            varpi: params.varpi.initial,
            estimates: params.initial,
            differentiators: [DifferentiatorState::default(); N],
            feedforward: DifferentiatorState::default(),
            quantizers: [q0; M],
            u: [0.0; M],
            q: [0.0; M],
            links: LinkMemory::default(),
            recovery: Recovery::default(),
        }
    }

    /// Back to `t = 0` with the initial estimates, keeping the configuration.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// let first = c.step(&[0.5, 0.8], &[], Link::Fresh(0.0));
    /// c.step(&[0.4, 0.1], &[], Link::Fresh(0.0));
    /// assert_eq!(c.state().k, 2);
    /// c.reset();
    /// assert_eq!(c.time(), 0.0);
    /// // The same sample gives the same output again: nothing of the run is left.
    /// assert_eq!(c.step(&[0.5, 0.8], &[], Link::Fresh(0.0)), first);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn reset(&mut self) {
        self.state = Self::initial_state(&self.params);
    }

    /// Resume after a pause in which no step ran (a node's safe state), with the agent's
    /// output `y` and the command `applied` meanwhile: `t` and `ϖ` start again, the
    /// differentiators from rest, and the last command is `applied` (the rate limit starts
    /// there). With safety on, every link re-enters from `y` at the recovery rate, so the
    /// consensus error starts near zero instead of jumping (a bumpless transfer). The
    /// estimates `μ̂`, `ξ̂`, `λ̂` and the quantizers are kept.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// for _ in 0..100 {
    ///     c.step(&[0.3, 0.0], &[], Link::Fresh(0.0));
    /// }
    /// let learned = c.state().estimates;
    /// c.resume(0.3, &[0.25, 0.25]); // the safe state applied 0.25 meanwhile
    /// assert_eq!(c.time(), 0.0);
    /// assert_eq!(c.state().varpi, 0.1); // ϖ back at ϖ(0)
    /// assert_eq!(c.state().u, [0.25, 0.25]);
    /// assert_eq!(c.state().estimates, learned); // μ̂, ξ̂, λ̂ kept
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn resume(&mut self, y: f32, applied: &[f32; M]) {
        let s = &mut self.state;
        s.k = 0;
        s.varpi = self.params.varpi.initial;
        s.differentiators = [DifferentiatorState::default(); N];
        s.feedforward = DifferentiatorState::default();
        s.u = *applied;
        s.q = *applied;
        self.reenter_links_from(y);
    }

    /// Every neighbour and leader link re-enters from `y` (the agent's own output, usually):
    /// with `[safety]`, the next fresh values are blended in from `y` at the recovery rate, so
    /// `e_{i,1}` (10) starts near 0 instead of jumping; without safety (or for a non-finite
    /// `y`) nothing changes.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link, SafetyConfig};
    /// let cfg = ControllerConfig::<2> {
    ///     neighbour_count: 1,
    ///     pinned: false,
    ///     safety: Some(SafetyConfig { recovery_rate: 1.0, ..SafetyConfig::default() }),
    ///     ..ControllerConfig::default()
    /// };
    /// # #[cfg(feature = "safety")] {
    /// let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
    /// c.reenter_links_from(0.2);
    /// // The neighbour says 0.7: at 1 per second and h = 1 ms, e₁ = y − ŷ moves by 1e-3.
    /// let o = c.step(&[0.2, 0.0], &[Link::Fresh(0.7)], Link::Missing);
    /// assert!((o.e[0] - -0.001).abs() < 1e-5);
    /// # }
    /// ```
    pub fn reenter_links_from(&mut self, y: f32) {
        if y.is_finite() && safety(&self.params).is_some() {
            self.state.recovery.restart_from(y);
        }
    }

    /// The validated settings.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig};
    /// let c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// // The gains of Theorem 1 for Example 1 (T_s = 2): c_1 ≈ 16.26, c_2 = π/(ζ T_s) ≈ 15.71.
    /// assert!((c.params().gains().c1 - 16.26).abs() < 0.01);
    /// assert_eq!(c.params().h(), 1e-3);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn params(&self) -> &Params<N> {
        &self.params
    }

    /// The current state (see [`State`]).
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig};
    /// let c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// let s = c.state();
    /// assert_eq!((s.k, s.u, s.q), (0, [0.0; 2], [0.0; 2])); // u_{−1} = 0 (LAW §4)
    /// assert_eq!((s.estimates.mu, s.estimates.xi), (0.0, 0.0)); // μ̂(0) = ξ̂(0) = 0
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn state(&self) -> &State<N, M, K> {
        &self.state
    }

    /// `t = k h` of the next step: a sample counter times `h`, never an accumulated float.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// for _ in 0..2000 {
    ///     c.step(&[0.0, 0.0], &[], Link::Fresh(0.0));
    /// }
    /// assert_eq!(c.time(), 2000.0 * 1e-3); // exactly 2000 h, no drift
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub fn time(&self) -> f32 {
        self.state.k as f32 * self.params.h
    }

    /// One sample (LAW §6): `x` is this agent's state, `neighbours` the latest values of its
    /// `S_i` neighbours in configured order, `leader` the leader's `y_d` (ignored unless pinned).
    ///
    /// Never panics. A non-finite `x`, or a result that overflows `f32`, holds the previous
    /// command and commits nothing (see [`StepFault`]); neighbour and leader values follow the
    /// policy of [`crate::consensus`].
    ///
    /// With safety on ([`crate::SafetyConfig`]) the command is limited before the quantizer,
    /// the adaptive laws pause while a limit is active, returning links are blended in and the
    /// differentiators restart after a held step ([`crate::safety`]); with it off this is the
    /// paper's law: none of that code runs.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// // Agent 2 of the paper's examples: hears agent 1 only, not the leader.
    /// let cfg = ControllerConfig::<2> { neighbour_count: 1, pinned: false, ..Default::default() };
    /// let mut c = Controller::<2, 2, 4>::new(&cfg)?;
    /// // y_2 = 0.01 below y_1 = 0.03: e_1 = a_{2,1}(y_2 − y_1) = −0.02 (10), and the command
    /// // pushes x_2 up (u > 0).
    /// let out = c.step(&[0.01, 0.0], &[Link::Fresh(0.03)], Link::Missing);
    /// assert!((out.e[0] + 0.02).abs() < 1e-7);
    /// assert!(out.u[0] > 0.0);
    /// // The neighbour's value goes missing: the last one received is used.
    /// let out = c.step(&[0.01, 0.0], &[Link::Missing], Link::Missing);
    /// assert!((out.e[0] + 0.02).abs() < 1e-7);
    /// assert_eq!(out.status.links.missing_neighbours, 1);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use = "the step's quantized command `q` is what the actuators must get"]
    pub fn step(&mut self, x: &[f32; N], neighbours: &[Link], leader: Link) -> StepOutput<N, M> {
        let r = self.begin(x, neighbours, leader);
        if !r.valid {
            return held(&mut self.state, r.varpi, StepFault::InvalidState, r.links);
        }
        let p = &self.params;
        let sig = p
            .backstepping
            .run(&p.scheme.feedback_at(r.t), r.e1, r.phi1, x, &r.estimated());
        self.finish(x, &r, &sig)
    }

    /// [`Controller::step`] of `L` agents at once (`x[i]` and `links[i]`, the neighbour values
    /// and the leader value, are those of `ctrls[i]`), the same outputs to the bit: each
    /// agent's backstepping recursion (LAW §5), one long dependent chain of powers, divisions
    /// and roots, runs beside the others' (step `j` of every agent before step `j+1` of any),
    /// so the processor overlaps the chains. For a host stepping many agents; a firmware steps
    /// one.
    ///
    /// The outputs go to `out` in agent order.
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// let cfg = ControllerConfig::<2> { neighbour_count: 1, pinned: false, ..Default::default() };
    /// let c = Controller::<2, 2, 1>::new(&cfg)?;
    /// let (mut pair, mut a, mut b) = ([c, c], c, c);
    /// let (x, y) = ([[0.01, 0.0], [0.2, -0.1]], [Link::Fresh(0.03)]);
    /// let mut out = Vec::new();
    /// Controller::step_side_by_side(&mut pair, &x, [(&y, Link::Missing); 2], &mut out);
    /// assert_eq!(out, [a.step(&x[0], &y, Link::Missing), b.step(&x[1], &y, Link::Missing)]);
    /// assert_eq!(pair, [a, b]);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    pub fn step_side_by_side<const L: usize>(
        ctrls: &mut [Self; L],
        x: &[[f32; N]; L],
        links: [(&[Link], Link); L],
        out: &mut impl Extend<StepOutput<N, M>>,
    ) {
        let mut ready = [Ready::EMPTY; L];
        for (((r, c), x), (neighbours, leader)) in
            ready.iter_mut().zip(ctrls.iter_mut()).zip(x).zip(links)
        {
            *r = c.begin(x, neighbours, leader);
        }
        // A held agent's lane computes on its state as it is; its signals are not read.
        // `i < L` in the closure: the indexing cannot fail.
        let signals: [Signals<N>; L] = Backstepping::run_side_by_side(core::array::from_fn(|i| {
            let (c, r) = (&ctrls[i], &ready[i]);
            Lane {
                backstepping: &c.params.backstepping,
                feedback: c.params.scheme.feedback_at(r.t),
                e1: r.e1,
                phi1: r.phi1,
                x: &x[i],
                est: r.estimated(),
            }
        }));
        for (((c, r), x), sig) in ctrls.iter_mut().zip(&ready).zip(x).zip(&signals) {
            out.extend(core::iter::once(if r.valid {
                c.finish(x, r, sig)
            } else {
                held(&mut c.state, r.varpi, StepFault::InvalidState, r.links)
            }));
        }
    }

    /// The step up to its backstepping recursion (LAW §6 step 1 to `e_1`): with safety on, the
    /// re-entry of returning links and the differentiators' restart after a held step; the
    /// time, `ϖ`, the consensus error `e_1`. A non-finite `x` makes the step a held one
    /// (`valid` false).
    #[inline(always)]
    fn begin(&mut self, x: &[f32; N], neighbours: &[Link], leader: Link) -> Ready<N> {
        // With safety on: differentiators restart after a held step and returning links
        // re-enter at the recovery rate, each value as the law reads it (no copy of the
        // links). More values than slots (a wiring error, counted by the law) go through as
        // given.
        let (leader, reenter) = match safety(&self.params) {
            Some(safety) if neighbours.len() <= K => {
                let s = &mut self.state;
                if s.recovery.after_hold {
                    s.differentiators = [DifferentiatorState::default(); N];
                    s.feedforward = DifferentiatorState::default();
                    s.recovery.after_hold = false;
                }
                (reenter_link(safety, &mut s.recovery.leader, leader), true)
            }
            _ => (leader, false),
        };
        let p = &self.params;
        let s = &mut self.state;
        let t = s.k as f32 * p.h;
        let varpi = s.varpi;
        p.varpi.advance(&mut s.varpi);
        s.k = s.k.saturating_add(1);

        // 1. e_1 from the latest neighbour / leader values, then β_j, α_j, e_{j+1}.
        let mut links = LinkReport::default();
        let mut phi1 = p.backstepping.mtn.accumulator();
        let reentry = if reenter { safety(p) } else { None };
        let slots = &mut s.recovery.neighbours;
        let through = |k: usize, link| match (reentry, slots.get_mut(k)) {
            (Some(safety), Some(slot)) => reenter_link(safety, slot, link),
            _ => link,
        };
        let e1 = p.consensus.consensus_error(
            &mut s.links,
            x[0],
            neighbours,
            leader,
            &mut phi1,
            &mut links,
            through,
        );
        let mut alpha_dot = [0.0; N];
        for (d, st) in alpha_dot.iter_mut().zip(s.differentiators.iter()) {
            *d = st.chi2;
        }
        Ready {
            valid: x.iter().all(|v| v.is_finite()),
            t,
            varpi,
            e1,
            phi1: phi1.norm_sq(),
            links,
            alpha_dot,
            estimates: s.estimates,
            w_dot: s.feedforward.chi2,
        }
    }

    /// The step after its backstepping recursion `sig` (LAW §6 steps 2–5): the command, the
    /// adaptive laws, the differentiators, the finiteness check, the quantizer.
    #[inline(always)]
    fn finish(&mut self, x: &[f32; N], r: &Ready<N>, sig: &Signals<N>) -> StepOutput<N, M> {
        let p = &self.params;
        let s = &mut self.state;
        let (varpi, e1, links, est) = (r.varpi, r.e1, r.links, r.estimates);

        // 2. u_l (limited with safety on); its quantization follows the check below.
        let (u_l, limited) = match safety(p) {
            None => (sig.u, false),
            Some(safety) => safety.limit(sig.u, s.u[0]),
        };

        // 3. Adaptive laws (forward Euler, clamped at 0).
        let e_n = sig.e[N - 1];
        let mut mu_drive = 0.0;
        for ((&pj, &e), &phi) in p.p_over_two_a2.iter().zip(&sig.e).zip(&sig.phi_sq) {
            mu_drive += pj * e * e * phi;
        }
        let drives = Drives {
            mu: mu_drive,
            xi: p.eta * math::abs(e_n * sig.tanh_n),
            lambda: p.tau * math::abs(e_n * sig.beta[N - 1]),
        };
        // Conditional integration: the laws pause while a limit is active.
        let estimates = if limited {
            est
        } else {
            p.laws.next(&est, &drives)
        };

        // 4. Differentiators of α_j, j < n.
        let mut differentiators = s.differentiators;
        for (d, &a) in differentiators.iter_mut().zip(&sig.alpha).take(N - 1) {
            *d = p.differentiator.next(d, a);
        }

        // All finite: `0·v` is ±0 for a finite `v` and NaN for ±∞ or NaN, so one comparison
        // of the sum replaces a test per value. The law's `u` before any limit: a limit must
        // not hide an overflow. The quantizers need no check (a finite `u` gives a finite `q`),
        // so they run after it, on the committed state.
        let mut probe =
            0.0 * sig.u + 0.0 * estimates.mu + 0.0 * estimates.xi + 0.0 * estimates.lambda;
        for d in &differentiators {
            probe += 0.0 * d.chi1 + 0.0 * d.chi2;
        }
        let finite = probe == 0.0;
        if !finite {
            return held(s, varpi, StepFault::NonFiniteResult, links);
        }
        s.estimates = estimates;
        s.differentiators = differentiators;
        // ... and of w_i = y_i − e_{i,1}/A_i with the feed-forward on (LAW §5a).
        if p.backstepping.feedforward.is_some() {
            advance_feedforward(p, s, x, e1);
        }

        // 2, continued: q_l = Q_l(u_l).
        let u = [u_l; M];
        let mut q = u;
        if let (Some(qz), Some((first, rest)), Some((q_first, q_rest))) = (
            &p.quantizer,
            s.quantizers.split_first_mut(),
            q.split_first_mut(),
        ) {
            // Every actuator gets the same `u`, so actuators whose quantizer state equals the
            // first one's get its result (always the case: they start equal and are committed
            // together); the comparison keeps this exact for any state.
            let before = *first;
            *q_first = qz.quantize(first, u_l);
            for (ql, st) in q_rest.iter_mut().zip(rest.iter_mut()) {
                *ql = if *st == before {
                    *st = *first;
                    *q_first
                } else {
                    quantize_apart(qz, st, u_l)
                };
            }
        }
        s.u = u;
        s.q = q;
        StepOutput {
            u,
            q,
            e: sig.e,
            alpha: sig.alpha,
            beta: sig.beta,
            estimates,
            varpi,
            status: StepStatus {
                fault: None,
                links,
                limited,
            },
        }
    }
}

/// The safety settings in force: none without the `safety` feature, so that the step's code
/// holds none of [`crate::safety`]'s.
#[inline(always)]
fn safety<const N: usize>(params: &Params<N>) -> Option<&Safety> {
    if cfg!(feature = "safety") {
        params.safety.as_ref()
    } else {
        None
    }
}

/// An actuator whose quantizer state differs from the first one's (never, as the states are
/// committed together): out of line, so that the common path inlines a single quantization.
#[cold]
#[inline(never)]
fn quantize_apart(qz: &HysteresisQuantizer, st: &mut QuantizerState, u: f32) -> f32 {
    qz.quantize(st, u)
}

/// One step of the differentiator of `w_i = y_i − e_{i,1}/A_i` (LAW §5a), after the step is
/// committed. Out of line, so that the paper's step (feed-forward off) carries none of it. `e_1`
/// and `y_i` are finite here (a step with either non-finite was held), so only an `f32` overflow
/// of `χ` itself can make the state non-finite; it then restarts from rest.
#[inline(never)]
fn advance_feedforward<const N: usize, const M: usize, const K: usize>(
    p: &Params<N>,
    s: &mut State<N, M, K>,
    x: &[f32; N],
    e1: f32,
) {
    if let (Some(ff), Some(&y)) = (&p.backstepping.feedforward, x.first()) {
        let next = p.differentiator.next(&s.feedforward, ff.mean(y, e1));
        s.feedforward = if next.is_finite() {
            next
        } else {
            DifferentiatorState::default()
        };
    }
}

/// The fault result: previous command held, nothing committed.
fn held<const N: usize, const M: usize, const K: usize>(
    s: &mut State<N, M, K>,
    varpi: f32,
    fault: StepFault,
    links: LinkReport,
) -> StepOutput<N, M> {
    // Read only with safety on (the next valid step re-seeds the differentiators).
    s.recovery.after_hold = true;
    StepOutput {
        u: s.u,
        q: s.q,
        e: [0.0; N],
        alpha: [0.0; N],
        beta: [0.0; N],
        estimates: s.estimates,
        varpi,
        status: StepStatus {
            fault: Some(fault),
            links,
            limited: false,
        },
    }
}

/// What a step has found before its backstepping recursion ([`Controller::step`]'s first
/// part).
#[derive(Debug, Clone, Copy)]
struct Ready<const N: usize> {
    /// A finite state: the step goes on (else it is held).
    valid: bool,
    /// `t_k`.
    t: f32,
    /// `ϖ(t_k)`.
    varpi: f32,
    /// `e_1` (10).
    e1: f32,
    /// `‖Φ_1‖²`.
    phi1: f32,
    /// The links' report of the step.
    links: LinkReport,
    /// `χ_{j,2} ≈ α̇_j` at index `j−1`.
    alpha_dot: [f32; N],
    /// `μ̂`, `ξ̂`, `λ̂` before the step.
    estimates: Estimates,
    /// `ẇ_i`'s estimate (LAW §5a).
    w_dot: f32,
}

impl<const N: usize> Ready<N> {
    /// A place for a step's findings, before they are found.
    const EMPTY: Self = Self {
        valid: false,
        t: 0.0,
        varpi: 0.0,
        e1: 0.0,
        phi1: 0.0,
        links: LinkReport {
            stale_neighbours: 0,
            missing_neighbours: 0,
            invalid_neighbours: 0,
            dropped_neighbours: 0,
            count_mismatch: false,
            leader_stale: false,
            leader_missing: false,
            leader_dropped: false,
        },
        alpha_dot: [0.0; N],
        estimates: Estimates {
            mu: 0.0,
            xi: 0.0,
            lambda: 0.0,
        },
        w_dot: 0.0,
    };

    /// The recursion's inputs from the state.
    #[inline(always)]
    fn estimated(&self) -> Estimated<'_, N> {
        Estimated {
            mu: self.estimates.mu,
            xi: self.estimates.xi,
            lambda: self.estimates.lambda,
            varpi: self.varpi,
            alpha_dot: &self.alpha_dot,
            w_dot: self.w_dot,
        }
    }
}

#[cfg(test)]
#[path = "../tests/common/mod.rs"]
mod example1;

#[cfg(test)]
mod tests {
    //! The per-step math of the build's back-end (this crate's kernels with `libm`, its fast
    //! approximations with `fast-math`, the `micromath` crate's) against the exact-math run (`libm`'s `powf`, `sqrtf`, `tanhf`) in the
    //! closed loop of Example 1 (LAW §8): four agents, RK4 plant with 4 substeps, faults and
    //! quantizer on, h = 1 ms.
    use super::example1::Example1;
    use crate::math::with_exact_math;

    /// (max |y_i − y_d| after 2 T_s, RMS of y_i − y_d over the whole run).
    fn example1(ts: f32, t_end: f64) -> (f64, f64) {
        let mut sim = Example1::new(ts, 1e-3, true, true);
        let steps = (t_end / 1e-3).round() as usize;
        let (mut worst, mut sq) = (0.0f64, 0.0f64);
        for _ in 0..steps {
            let s = sim.step();
            if s.t >= 2.0 * f64::from(ts) {
                worst = worst.max(s.max_error);
            }
            sq += s.sum_sq_error;
        }
        (worst, (sq / (4 * steps) as f64).sqrt())
    }

    /// Relative drift allowed from the exact-math run (max error after 2 `T_s`, RMS), at the
    /// measured level: 0.013 % for the accurate kernels, 0.008 % for the fast approximations,
    /// 0.65 % for the `micromath` crate's.
    const DRIFT: f64 = if cfg!(feature = "micromath") {
        0.007
    } else {
        2e-4
    };

    #[test]
    fn example1_with_per_step_math_within_its_measured_drift_of_exact_math() {
        for ts in [2.0f32, 1.0] {
            let fast = example1(ts, 10.0);
            let exact = with_exact_math(|| example1(ts, 10.0));
            let rel = |a: f64, b: f64| (a - b).abs() / b;
            println!(
                "Example 1, T_s = {ts}: max error after 2 T_s {:.5} (exact math {:.5}, {:+.3} %), RMS {:.5} (exact {:.5}, {:+.3} %)",
                fast.0,
                exact.0,
                100.0 * (fast.0 - exact.0) / exact.0,
                fast.1,
                exact.1,
                100.0 * (fast.1 - exact.1) / exact.1
            );
            assert!(
                rel(fast.0, exact.0) <= DRIFT,
                "T_s = {ts}: {fast:?} vs {exact:?}"
            );
            assert!(
                rel(fast.1, exact.1) <= DRIFT,
                "T_s = {ts}: {fast:?} vs {exact:?}"
            );
        }
    }
}

#[cfg(test)]
mod feedforward_off {
    //! With the feed-forward off (the default) the step is the paper's law: nothing of LAW §5a
    //! reaches an output, whatever the feed-forward differentiator holds.
    use super::*;
    use proptest::prelude::*;

    fn bits<const N: usize, const M: usize>(o: &StepOutput<N, M>) -> Vec<u32> {
        let mut v: Vec<u32> = Vec::new();
        for a in [&o.u[..], &o.q[..], &o.e[..], &o.alpha[..], &o.beta[..]] {
            v.extend(a.iter().map(|x| x.to_bits()));
        }
        let e = o.estimates;
        v.extend([e.mu, e.xi, e.lambda, o.varpi].iter().map(|x| x.to_bits()));
        v
    }

    proptest! {
        #[test]
        fn off_ignores_the_feedforward_state_bit_for_bit(
            xs in prop::collection::vec((-3.0f32..3.0, -3.0f32..3.0, -2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0), 1..60),
            garbage in (-1e3f32..1e3, -1e3f32..1e3),
            pinned in any::<bool>(),
        ) {
            let cfg = ControllerConfig::<2> { neighbour_count: 2, pinned, ..Default::default() };
            let mut plain = Controller::<2, 2, 2>::new(&cfg).unwrap();
            let mut dirty = plain;
            // A primed state far from rest: χ_1 = g_0 − …, χ_2 = ∓(|g_1| + 1).
            let d = crate::LevantDifferentiator::new(1.0, garbage.1.abs() + 1.0, 1.0);
            let junk = d.next(&d.next(&DifferentiatorState::default(), garbage.0), garbage.1);
            prop_assert!(junk.chi2 != 0.0);
            for (x1, x2, n1, n2, yd) in xs {
                dirty.state.feedforward = junk;
                let links = [Link::Fresh(n1), Link::Fresh(n2)];
                let a = plain.step(&[x1, x2], &links, Link::Fresh(yd));
                let b = dirty.step(&[x1, x2], &links, Link::Fresh(yd));
                prop_assert_eq!(bits(&a), bits(&b));
                prop_assert_eq!(plain.state.feedforward, DifferentiatorState::default());
                prop_assert_eq!(dirty.state.feedforward, junk);
            }
        }
    }
}
