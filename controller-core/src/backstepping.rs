//! The recursive backstepping steps `β_j`, `α_j`, `e_{j+1}` and the actual control `u`
//! (LAW §5; the paper's (15)–(19), (28)), shared by the proposed scheme and the baseline: the
//! scheme enters only through its [`Feedback`] term.

use crate::{
    math,
    mtn::{MtnAccumulator, MtnRegressor},
    scheme::Feedback,
    smoothing::smooth,
};

/// Step constants precomputed from the validated configuration.
///
/// Built by [`crate::Params::new`] only; seen through the controller's output. With Example
/// 1's agent 1 (`A_1 = 1`, `S_1 = 0`) and `μ̂(0) = 0` the first sample's step 1 is
/// `β_1 = k_1 M(e_1) + k_2 N(e_1) + (1 + A_1 + S_1)/2 · e_1` (17) and
/// `α_1 = −β_1 s_ϖ(e_1 β_1) / (A_1 φ_low_1)` (15):
///
/// ```
/// use controller_core::powers::Powers;
/// use controller_core::smoothing::smooth;
/// use controller_core::{Controller, ControllerConfig, Link};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// let g = *c.params().gains();
/// let out = c.step(&[0.3, 0.8], &[], Link::Fresh(0.0));
/// let e1 = out.e[0];
/// let (m, n) = Powers::new(0.1).m_n(e1);
/// let beta1 = g.k1 * m + g.k2 * n + e1;
/// assert!((out.beta[0] - beta1).abs() < 1e-5 * beta1.abs());
/// let alpha1 = -beta1 * smooth(e1 * beta1, 0.1);
/// assert!((out.alpha[0] - alpha1).abs() < 1e-4 * alpha1.abs());
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Backstepping<const N: usize> {
    pub(crate) mtn: MtnRegressor,
    /// `1 / (2 ǎ_j²)`.
    pub(crate) inv_two_a2: [f32; N],
    /// `(1 + A_i + S_i) / 2`, the damping of step 1 (17).
    pub(crate) damping_1: f32,
    /// `J_j φ_up_{j−1}` at index `j−1` for `j ≥ 2` (index 0 unused).
    pub(crate) cross: [f32; N],
    /// `ε̄_{j−1}` at index `j−1` for `j ≥ 2` (index 0 unused).
    pub(crate) eps_bar: [f32; N],
    /// `1 / (L_j φ_low_j)`.
    pub(crate) inv_l_phi_low: [f32; N],
    /// `1 / γ`.
    pub(crate) inv_gamma: f32,
    /// `1 / (1 − δ)` of the quantizer (1 without one).
    pub(crate) command_gain: f32,
    /// The velocity feed-forward of LAW §5a; `None` is the paper's law.
    pub(crate) feedforward: Option<VelocityFeedforward>,
}

/// Constants of the velocity feed-forward (LAW §5a), a documented option that is not the
/// paper's law: `α_1 ← α_1 + ẇ_i / φ_up_1`, where `w_i = (Σ_k a_{i,k} y_k + r_i y_d) / A_i =
/// y_i − e_{i,1}/A_i` (10) is the weighted neighbour mean and `A_i ẇ_i` the velocity term
/// `Σ_k a_{i,k} ẏ_k + r_i ẏ_d` dropped between (26) and (27).
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Feedforward, Link};
/// let on = ControllerConfig::<2> { feedforward: Feedforward::Estimated, ..Default::default() };
/// let (mut a, mut b) = (Controller::<2, 2, 0>::new(&on)?, Controller::<2, 2, 0>::new(&Default::default())?);
/// // The first sample primes the differentiator (ẇ = 0): both laws agree.
/// assert_eq!(a.step(&[0.1, 0.0], &[], Link::Fresh(0.0)), b.step(&[0.1, 0.0], &[], Link::Fresh(0.0)));
/// // The leader moves up: the feed-forward raises α_1 by the estimated ẇ > 0.
/// let (fa, fb) = (a.step(&[0.1, 0.0], &[], Link::Fresh(0.01)), b.step(&[0.1, 0.0], &[], Link::Fresh(0.01)));
/// let (fa, fb) = (a.step(&[0.1, 0.0], &[], Link::Fresh(0.02)), b.step(&[0.1, 0.0], &[], Link::Fresh(0.02)));
/// assert!(fa.alpha[0] > fb.alpha[0]);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VelocityFeedforward {
    /// `1 / A_i`, to form `w_i = y_i − e_{i,1}/A_i`.
    pub(crate) inv_a: f32,
    /// `1 / φ_up_1`: with the unknown `φ_{i,1}` in `[φ_low_1, φ_up_1]` the term cancels the
    /// fraction `φ_{i,1}/φ_up_1 ∈ (0, 1]` of `A_i ẇ_i`, never more.
    pub(crate) inv_phi_up: f32,
}

impl VelocityFeedforward {
    /// The weighted neighbour mean `w_i = y_i − e_{i,1}/A_i` of (10).
    ///
    /// ```
    /// use controller_core::{Controller, ControllerConfig, Feedforward, Link};
    /// // Agent 4 of the examples hears agents 1 and 3 (A_4 = 2): w_4 = (y_1 + y_3)/2.
    /// let cfg = ControllerConfig::<2> {
    ///     neighbour_count: 2, pinned: false, feedforward: Feedforward::Estimated,
    ///     ..Default::default()
    /// };
    /// let mut c = Controller::<2, 2, 2>::new(&cfg)?;
    /// let out = c.step(&[0.5, 0.0], &[Link::Fresh(0.2), Link::Fresh(0.4)], Link::Missing);
    /// let ff = c.params().feedforward().unwrap();
    /// assert!((ff.mean(0.5, out.e[0]) - 0.3).abs() < 1e-6);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[inline]
    #[must_use]
    pub fn mean(&self, y: f32, e1: f32) -> f32 {
        y - e1 * self.inv_a
    }
}

/// The signals of one sample's recursion, per step `j` (index `j−1`); the controller's
/// [`crate::StepOutput`] reports `e`, `α`, `β` and `u` of them.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// // n = 3: two virtual controls α_1, α_2 and e_{j+1} = x_{j+1} − α_j.
/// let mut c = Controller::<3, 1, 0>::new(&ControllerConfig::default())?;
/// let x = [0.1, -0.2, 0.3];
/// let out = c.step(&x, &[], Link::Fresh(0.0));
/// for j in 1..3 {
///     assert!((out.e[j] - (x[j] - out.alpha[j - 1])).abs() < 1e-5);
/// }
/// assert_eq!(out.alpha[2], 0.0); // there is no α_n
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signals<const N: usize> {
    /// `e_j`.
    pub e: [f32; N],
    /// `β_j` (the paper's `ᾰ_j`).
    pub beta: [f32; N],
    /// `α_j` for `j < n`; the last entry is 0 (there is no `α_n`).
    pub alpha: [f32; N],
    /// `‖Φ_j‖²`.
    pub phi_sq: [f32; N],
    /// `tanh(e_n / γ)`.
    pub tanh_n: f32,
    /// The actual control `u` (the same for every actuator).
    pub u: f32,
}

/// Inputs of the recursion that come from the controller's state.
///
/// ```
/// use controller_core::backstepping::Estimated;
/// let alpha_dot = [0.0, 0.0];
/// let est = Estimated { mu: 0.0, xi: 0.0, lambda: 1.0, varpi: 0.1, alpha_dot: &alpha_dot, w_dot: 0.0 };
/// assert_eq!(est.alpha_dot.len(), 2); // one χ_{j,2} per step, the last unused
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Estimated<'a, const N: usize> {
    /// `μ̂`.
    pub mu: f32,
    /// `ξ̂`.
    pub xi: f32,
    /// `λ̂`.
    pub lambda: f32,
    /// `ϖ(t)`.
    pub varpi: f32,
    /// Differentiator estimates `χ_{j,2} ≈ α̇_j` at index `j−1`.
    pub alpha_dot: &'a [f32; N],
    /// Estimate of `ẇ_i`, the weighted neighbour mean's rate (read only with the feed-forward
    /// of LAW §5a on).
    pub w_dot: f32,
}

impl<const N: usize> Backstepping<N> {
    /// Runs steps `1..n` from `e_1` (with `phi1 = ‖Φ_1‖²`) and the local state `x`.
    ///
    /// The controller calls it once per step; its `u` is (28),
    /// `u = −λ̂ β_n s_ϖ(e_n λ̂ β_n) / (1 − δ)`, the same for every actuator:
    ///
    /// ```
    /// use controller_core::smoothing::smooth;
    /// use controller_core::{Controller, ControllerConfig, Link};
    /// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
    /// let delta = c.params().quantizer().unwrap().delta();
    /// let out = c.step(&[0.3, 0.8], &[], Link::Fresh(0.0));
    /// let (e2, beta2) = (out.e[1], out.beta[1]); // λ̂(0) = 1
    /// let u = -beta2 * smooth(e2 * beta2, 0.1) / (1.0 - delta);
    /// assert!((out.u[0] - u).abs() < 1e-4 * u.abs() && out.u[0] == out.u[1]);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    // Always inlined: returned through memory, the signals were read back as 8-byte words
    // stored as 4-byte halves (a stalled load per step on the host).
    #[inline(always)]
    #[must_use]
    pub fn run(
        &self,
        feedback: &Feedback,
        e1: f32,
        phi1: f32,
        x: &[f32; N],
        est: &Estimated<'_, N>,
    ) -> Signals<N> {
        // Four short arrays rather than one `Signals` cleared as a block and refilled.
        let (mut es, mut betas, mut alphas, mut phis) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
        let mut states = self.mtn.accumulator();
        let mut carried = Carried::default();
        for (j, &xj) in x.iter().enumerate() {
            let (e, beta, phi_sq) =
                self.stabilise(&mut states, &carried, j, xj, feedback, e1, phi1, est);
            let c = self.virtual_control(j, e, beta, est);
            (es[j], betas[j], alphas[j], phis[j]) = (e, c.beta, c.alpha, phi_sq);
            carried = c;
        }
        Signals {
            e: es,
            beta: betas,
            alpha: alphas,
            phi_sq: phis,
            tanh_n: carried.tanh_n,
            u: carried.u,
        }
    }

    /// [`Backstepping::run`] of several agents at once, step `j` of every agent before step
    /// `j+1` of any: each agent's recursion is one dependent chain (powers, divisions, roots),
    /// so the processor overlaps the agents' chains instead of waiting on one. Each agent's
    /// arithmetic is its own and in the same order as in [`Backstepping::run`], so every
    /// result is the same to the bit (the controller's tests compare
    /// [`crate::Controller::step_side_by_side`] with [`crate::Controller::step`]).
    // Always inlined, as `run` is (signals returned through memory are read back stalled).
    #[inline(always)]
    #[must_use]
    pub(crate) fn run_side_by_side<const L: usize>(lanes: [Lane<'_, N>; L]) -> [Signals<N>; L] {
        let mut sig = [Signals::ZERO; L];
        let mut states = lanes.each_ref().map(|l| l.backstepping.mtn.accumulator());
        let mut carried = [Carried::default(); L];
        let mut half = [(0.0, 0.0, 0.0); L];
        for j in 0..N {
            for (((l, states), c), h) in lanes.iter().zip(&mut states).zip(&carried).zip(&mut half)
            {
                if let Some(&xj) = l.x.get(j) {
                    *h = l.backstepping.stabilise(
                        states,
                        c,
                        j,
                        xj,
                        &l.feedback,
                        l.e1,
                        l.phi1,
                        &l.est,
                    );
                }
            }
            for (((l, c), &(e, beta, phi_sq)), s) in
                lanes.iter().zip(&mut carried).zip(&half).zip(&mut sig)
            {
                *c = l.backstepping.virtual_control(j, e, beta, &l.est);
                s.record(j, phi_sq, c);
            }
        }
        sig
    }

    /// Step `j+1` of the recursion (index `j`, state `x_{j+1} = xj`), its first half: `e_j`,
    /// `β_j` before its last term and `‖Φ_j‖²`, (17)–(19).
    #[allow(
        clippy::too_many_arguments,
        reason = "the inputs of one step, passed apart so that both callers keep them in registers"
    )]
    #[inline(always)]
    fn stabilise(
        &self,
        states: &mut MtnAccumulator,
        prev: &Carried,
        j: usize,
        xj: f32,
        feedback: &Feedback,
        e1: f32,
        phi1: f32,
        est: &Estimated<'_, N>,
    ) -> (f32, f32, f32) {
        states.push(xj);
        let (e, phi_sq) = if j == 0 {
            (e1, phi1)
        } else {
            (xj - prev.alpha, states.norm_sq())
        };
        // (17)–(19): stabilising term, MTN compensation, damping / cross terms.
        let mut beta = feedback.term(e) + est.mu * e * phi_sq * self.inv_two_a2[j];
        if j == 0 {
            beta += self.damping_1 * e;
        } else {
            beta += e + math::sign(e) * (self.eps_bar[j] + self.cross[j] * math::abs(prev.e))
                - est.alpha_dot[j - 1];
        }
        (e, beta, phi_sq)
    }

    /// Step `j+1`'s second half, after [`Backstepping::stabilise`]: the smoothed virtual
    /// control `α_j` (15), or at the last step `β_n`'s `tanh` term and the command `u` (28).
    #[inline(always)]
    fn virtual_control(&self, j: usize, e: f32, mut beta: f32, est: &Estimated<'_, N>) -> Carried {
        let (mut alpha, mut tanh_n, mut u) = (0.0, 0.0, 0.0);
        if j + 1 == N {
            tanh_n = math::tanh(e * self.inv_gamma);
            beta += est.xi * tanh_n;
            // (28): u = −(1/(1−δ)) λ̂ β_n s_ϖ(e_n λ̂ β_n).
            let lb = est.lambda * beta;
            u = -self.command_gain * lb * smooth(e * lb, est.varpi);
        } else {
            // (15): α_j = −β_j s_ϖ(e_j β_j) / (L_j φ_low_j).
            alpha = -self.inv_l_phi_low[j] * beta * smooth(e * beta, est.varpi);
            if let (0, Some(ff)) = (j, &self.feedforward) {
                // LAW §5a: α_1 + ẇ_i / φ_up_1.
                alpha += ff.inv_phi_up * est.w_dot;
            }
        }
        Carried {
            e,
            beta,
            alpha,
            tanh_n,
            u,
        }
    }
}

/// One finished step `j` of the recursion, what the next one reads: `e_j`, `β_j`, `α_j` (0 at
/// the last step) and, at the last step, `tanh(e_n/γ)` and `u` (0 before).
#[derive(Debug, Clone, Copy, Default)]
struct Carried {
    e: f32,
    beta: f32,
    alpha: f32,
    tanh_n: f32,
    u: f32,
}

impl<const N: usize> Signals<N> {
    /// Every signal 0, before a recursion.
    const ZERO: Self = Self {
        e: [0.0; N],
        beta: [0.0; N],
        alpha: [0.0; N],
        phi_sq: [0.0; N],
        tanh_n: 0.0,
        u: 0.0,
    };

    /// Records step `j` (index `j < N`): `c` and its `‖Φ_j‖²`.
    #[inline(always)]
    fn record(&mut self, j: usize, phi_sq: f32, c: &Carried) {
        if let (Some(e), Some(beta), Some(alpha), Some(phi)) = (
            self.e.get_mut(j),
            self.beta.get_mut(j),
            self.alpha.get_mut(j),
            self.phi_sq.get_mut(j),
        ) {
            (*e, *beta, *alpha, *phi) = (c.e, c.beta, c.alpha, phi_sq);
        }
        (self.tanh_n, self.u) = (c.tanh_n, c.u);
    }
}

/// One agent's inputs of [`Backstepping::run_side_by_side`]: those of [`Backstepping::run`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lane<'a, const N: usize> {
    /// The agent's step constants.
    pub(crate) backstepping: &'a Backstepping<N>,
    /// The stabilising term in force.
    pub(crate) feedback: Feedback,
    /// `e_1`.
    pub(crate) e1: f32,
    /// `‖Φ_1‖²`.
    pub(crate) phi1: f32,
    /// The local state `x`.
    pub(crate) x: &'a [f32; N],
    /// The estimates and schedules of the agent's state.
    pub(crate) est: Estimated<'a, N>,
}

/// `controller.feedforward`: the velocity feed-forward of LAW §5a, a documented option that is
/// not the paper's law (off by default).
///
/// `#[non_exhaustive]`: velocities carried by the network would be a further source.
///
/// ```
/// use controller_core::Feedforward;
/// assert!(Feedforward::default().is_off()); // the paper's (17): no feed-forward
/// assert_eq!(Feedforward::Estimated.to_string(), "estimated");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Feedforward {
    /// The paper's law: the terms dropped between (26) and (27) stay dropped.
    #[default]
    Off,
    /// `α_1 += ẇ_i / φ_up_1`, with `ẇ_i` the derivative of the weighted neighbour mean
    /// `w_i = y_i − e_{i,1}/A_i` estimated by one more Levant differentiator (LAW §5a).
    Estimated,
}

impl Feedforward {
    /// The default, the paper's law (left out when a section is written).
    ///
    /// ```
    /// use controller_core::Feedforward;
    /// assert!(Feedforward::Off.is_off() && !Feedforward::Estimated.is_off());
    /// ```
    #[must_use]
    pub fn is_off(&self) -> bool {
        *self == Self::Off
    }
}

impl core::fmt::Display for Feedforward {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Off => crate::param::FEEDFORWARDS[0],
            Self::Estimated => crate::param::FEEDFORWARDS[1],
        })
    }
}
