//! Levant's robust exact differentiator, one per virtual control `α_j` (the paper's Lemma 5 with
//! `sign(χ_1 − α)` in the second line, LAW §4 and §9 item 2), integrated by forward Euler.

use crate::math;

/// Settings `ℓ_1`, `ℓ_2` and the sample period `h`.
///
/// ```
/// use controller_core::{differentiator::DifferentiatorState, LevantDifferentiator};
/// // α(t) = sin t sampled at h = 1 ms; ℓ_2 = 4 > |α̈| and ℓ_1 = 1.5 √ℓ_2 meet Levant's
/// // conditions (Lemma 5), so χ_2 converges to α̇ = cos t in finite time.
/// let (h, d) = (1e-3, LevantDifferentiator::new(3.0, 4.0, 1e-3));
/// let mut s = DifferentiatorState::default();
/// let mut worst = 0.0f32;
/// for k in 0..10_000 {
///     let t = k as f32 * h;
///     s = d.next(&s, t.sin());
///     if t >= 3.0 {
///         worst = worst.max((s.chi2 - t.cos()).abs());
///     }
/// }
/// assert!(worst < 0.05, "max |χ_2 − cos t| = {worst}");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevantDifferentiator {
    l1: f32,
    l2: f32,
    h: f32,
}

/// State `(χ_1, χ_2)`; `χ_2` estimates `α̇`.
///
/// ```
/// use controller_core::{differentiator::DifferentiatorState, LevantDifferentiator};
/// let d = LevantDifferentiator::new(1.0, 1.0, 1e-3);
/// let s = d.next(&DifferentiatorState::default(), 0.5);
/// assert_eq!((s.chi1, s.chi2), (0.5, 0.0)); // primed: χ_1 = α, χ_2 = 0
/// assert!(s.is_finite());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DifferentiatorState {
    /// `χ_1`, tracks `α`.
    pub chi1: f32,
    /// `χ_2`, the derivative estimate.
    pub chi2: f32,
    primed: bool,
}

impl LevantDifferentiator {
    /// Gains `ℓ_1, ℓ_2 > 0` and sample period `h > 0` (validated by the controller's config).
    ///
    /// ```
    /// use controller_core::{differentiator::DifferentiatorState, LevantDifferentiator};
    /// // A ramp α = 2 t has α̈ = 0 < ℓ_2: χ_2 settles at the slope 2.
    /// let d = LevantDifferentiator::new(3.0, 4.0, 1e-3);
    /// let mut s = DifferentiatorState::default();
    /// for k in 0..5_000 {
    ///     s = d.next(&s, 2.0 * k as f32 * 1e-3);
    /// }
    /// assert!((s.chi2 - 2.0).abs() < 0.02, "χ_2 = {}", s.chi2);
    /// ```
    #[must_use]
    pub const fn new(l1: f32, l2: f32, h: f32) -> Self {
        Self { l1, l2, h }
    }

    /// The state after one Euler step of
    /// `χ̇_1 = −ℓ_1 |χ_1 − α|^(1/2) sign(χ_1 − α) + χ_2`, `χ̇_2 = −ℓ_2 sign(χ_1 − α)` (Lemma 5).
    /// The first sample sets `χ_1 = α`, `χ_2 = 0`.
    ///
    /// ```
    /// use controller_core::{differentiator::DifferentiatorState, LevantDifferentiator};
    /// let d = LevantDifferentiator::new(1.0, 2.0, 0.1);
    /// let s = d.next(&DifferentiatorState::default(), 1.0);
    /// // χ_1 − α = 0.25: χ_1 += 0.1 (−1 · √0.25 + 0) = 0.95, χ_2 += 0.1 (−2) = −0.2.
    /// let s = d.next(&s, 0.75);
    /// assert!((s.chi1 - 0.95).abs() < 1e-5 && (s.chi2 + 0.2).abs() < 1e-6);
    /// ```
    #[inline]
    #[must_use]
    pub fn next(&self, s: &DifferentiatorState, alpha: f32) -> DifferentiatorState {
        if !s.primed {
            return DifferentiatorState {
                chi1: alpha,
                chi2: 0.0,
                primed: true,
            };
        }
        let d = s.chi1 - alpha;
        let sg = math::sign(d);
        DifferentiatorState {
            chi1: s.chi1 + self.h * (-self.l1 * math::sqrt(math::abs(d)) * sg + s.chi2),
            chi2: s.chi2 - self.h * self.l2 * sg,
            primed: true,
        }
    }
}

impl DifferentiatorState {
    /// Both components finite.
    ///
    /// ```
    /// use controller_core::{differentiator::DifferentiatorState, LevantDifferentiator};
    /// let d = LevantDifferentiator::new(1.0, 1.0, 1e-3);
    /// let s = d.next(&DifferentiatorState::default(), f32::INFINITY);
    /// assert!(!s.is_finite()); // the controller holds such a step (StepFault)
    /// assert!(DifferentiatorState::default().is_finite());
    /// ```
    #[inline]
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.chi1.is_finite() && self.chi2.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_sample_primes_then_tracks_a_ramp_slope() {
        let h = 1e-3;
        let d = LevantDifferentiator::new(3.0, 4.0, h);
        let mut s = DifferentiatorState::default();
        s = d.next(&s, 0.5);
        assert_eq!((s.chi1, s.chi2), (0.5, 0.0));
        // α(t) = 0.5 + 1.5 t: χ_2 converges to 1.5 in finite time (|α̈| = 0 < ℓ_2).
        for k in 1..20_000 {
            s = d.next(&s, 0.5 + 1.5 * k as f32 * h);
        }
        assert!((s.chi2 - 1.5).abs() < 0.05, "chi2 = {}", s.chi2);
    }

    #[test]
    fn euler_step_by_hand() {
        let d = LevantDifferentiator::new(1.0, 2.0, 0.1);
        let s = DifferentiatorState {
            chi1: 1.0,
            chi2: 0.5,
            primed: true,
        };
        let n = d.next(&s, 0.75);
        // χ_1 − α = 0.25: χ_1 += 0.1·(−1·0.5 + 0.5) = 1.0; χ_2 += 0.1·(−2) = 0.3.
        assert!((n.chi1 - 1.0).abs() < 1e-6);
        assert!((n.chi2 - 0.3).abs() < 1e-6);
    }
}
