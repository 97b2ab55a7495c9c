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
}

/// The signals of one sample's recursion, per step `j` (index `j−1`).
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
}

impl<const N: usize> Backstepping<N> {
    /// Runs steps `1..n` from `e_1` (with `phi1 = ‖Φ_1‖²`) and the local state `x`.
    #[inline]
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
        let (mut tanh_n, mut u) = (0.0, 0.0);
        let mut states: MtnAccumulator = self.mtn.accumulator();
        let (mut e_prev, mut alpha_prev) = (0.0, 0.0);
        for (j, &xj) in x.iter().enumerate() {
            states.push(xj);
            let (e, phi_sq) = if j == 0 {
                (e1, phi1)
            } else {
                (xj - alpha_prev, states.norm_sq())
            };
            // (17)–(19): stabilising term, MTN compensation, damping / cross terms.
            let mut beta = feedback.term(e) + est.mu * e * phi_sq * self.inv_two_a2[j];
            if j == 0 {
                beta += self.damping_1 * e;
            } else {
                beta += e + math::sign(e) * (self.eps_bar[j] + self.cross[j] * math::abs(e_prev))
                    - est.alpha_dot[j - 1];
            }
            if j + 1 == N {
                tanh_n = math::tanh(e * self.inv_gamma);
                beta += est.xi * tanh_n;
                // (28): u = −(1/(1−δ)) λ̂ β_n s_ϖ(e_n λ̂ β_n).
                let lb = est.lambda * beta;
                u = -self.command_gain * lb * smooth(e * lb, est.varpi);
            } else {
                // (15): α_j = −β_j s_ϖ(e_j β_j) / (L_j φ_low_j).
                alpha_prev = -self.inv_l_phi_low[j] * beta * smooth(e * beta, est.varpi);
                alphas[j] = alpha_prev;
            }
            es[j] = e;
            betas[j] = beta;
            phis[j] = phi_sq;
            e_prev = e;
        }
        Signals {
            e: es,
            beta: betas,
            alpha: alphas,
            phi_sq: phis,
            tanh_n,
            u,
        }
    }
}
