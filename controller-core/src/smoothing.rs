//! The smoothing function `s_ϖ(x) = x / √(x² + ϖ²)` and the schedule `ϖ(t) = ϖ_0 e^(−κt)`
//! floored at `ϖ_min` (LAW §4, §6; the paper's (15), (28)).

use crate::math;

/// `s_ϖ(x) = x / √(x² + ϖ²)` in hypot form: `x²` is never formed, so it stays in `[−1, 1]` and
/// finite for every finite `x` (also ±f32::MAX, and ±∞ gives ±1); `s(0) = 0`.
///
/// ```
/// use controller_core::smoothing::smooth;
/// // The back-end's n/√d: 1.6 ulp, 5e-6 with `fast-math`, 5.8e-2 with `micromath`.
/// let tol = if cfg!(feature = "micromath") { 5.8e-2 } else { 1e-5 };
/// assert!((smooth(3.0, 4.0) - 0.6).abs() < tol);
/// let s = smooth(f32::MAX, 0.1); // 1 (within the tolerance, never above, with the others)
/// assert!(s <= 1.0 && s > 1.0 - tol);
/// assert_eq!(smooth(0.0, 0.0), 0.0);
/// ```
#[inline]
#[must_use]
pub fn smooth(x: f32, varpi: f32) -> f32 {
    let a = math::abs(x);
    let b = math::abs(varpi);
    if a >= b {
        if a == 0.0 {
            return 0.0;
        }
        let r = b / a;
        math::div_sqrt(math::sign(x), 1.0 + r * r)
    } else {
        let r = x / b;
        math::div_sqrt(r, 1.0 + r * r)
    }
}

/// The `ϖ(t)` schedule: a per-sample decay factor `e^(−κh)` and the floor `ϖ_min`.
///
/// ```
/// use controller_core::smoothing::VarpiSchedule;
/// // LAW §8: ϖ = 0.1 e^(−0.7 t), floored at 1e-6, sampled at h = 1 ms.
/// let s = VarpiSchedule::new(0.1, 0.7, 1e-6, 1e-3);
/// let mut varpi = s.initial;
/// for _ in 0..1000 {
///     s.advance(&mut varpi);
/// }
/// assert!((varpi - 0.1 * (-0.7f32).exp()).abs() < 1e-6); // ϖ(1 s)
/// for _ in 0..30_000 {
///     s.advance(&mut varpi);
/// }
/// assert_eq!(varpi, s.floor); // 0.1 e^(−21) < 1e-6: the floor holds
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VarpiSchedule {
    /// `ϖ(0)`.
    pub initial: f32,
    /// `e^(−κh)`, computed once.
    pub decay_per_sample: f32,
    /// `ϖ_min > 0`.
    pub floor: f32,
}

impl VarpiSchedule {
    /// Schedule for `ϖ_0`, decay rate `κ`, floor and sample period `h` (validated by the caller).
    ///
    /// ```
    /// use controller_core::smoothing::VarpiSchedule;
    /// let s = VarpiSchedule::new(0.1, 0.7, 1e-6, 1e-3);
    /// assert!((s.decay_per_sample - (-0.7e-3f32).exp()).abs() < 1e-7);
    /// // κ = 0: a constant width.
    /// assert_eq!(VarpiSchedule::new(0.1, 0.0, 1e-6, 1e-3).decay_per_sample, 1.0);
    /// ```
    #[must_use]
    pub fn new(varpi0: f32, kappa: f32, floor: f32, h: f32) -> Self {
        Self {
            initial: varpi0,
            decay_per_sample: math::exp(-kappa * h),
            floor,
        }
    }

    /// `ϖ ← max(ϖ e^(−κh), ϖ_min)` (LAW §6 step 5).
    ///
    /// ```
    /// use controller_core::smoothing::VarpiSchedule;
    /// let s = VarpiSchedule::new(1.0, 1.0, 0.5, 0.5); // e^(−0.5) ≈ 0.607 per sample
    /// let mut varpi = 1.0;
    /// s.advance(&mut varpi);
    /// assert!((varpi - 0.60653).abs() < 1e-4);
    /// s.advance(&mut varpi); // 0.368 would be below the floor
    /// assert_eq!(varpi, 0.5);
    /// ```
    #[inline]
    pub fn advance(&self, varpi: &mut f32) {
        // `max(floor)` written out (a call to `fmaxf` on a Cortex-M4 otherwise).
        let v = *varpi * self.decay_per_sample;
        *varpi = if v > self.floor { v } else { self.floor };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_formula_where_it_does_not_overflow() {
        // The back-end's `n/√d`: 1.6 ulp, 5e-6 (`fast-math`), 5.8e-2 (`micromath`).
        let tol = if cfg!(feature = "micromath") {
            5.8e-2
        } else if cfg!(feature = "fast-math") {
            1e-5
        } else {
            1e-6
        };
        for &(x, w) in &[(0.3f32, 0.1f32), (-2.0, 0.5), (1e-3, 1e-6), (5.0, 5.0)] {
            let direct = x / (x * x + w * w).sqrt();
            assert!((smooth(x, w) - direct).abs() < tol, "{x} {w}");
        }
    }

    #[test]
    fn extreme_inputs_stay_in_range() {
        // ±1 (`fast-math`: within its 5e-6 of ±1, never beyond).
        let one = |s: f32| {
            if cfg!(feature = "fast-math") {
                (1.0 - 5e-6..=1.0).contains(&s)
            } else {
                s == 1.0
            }
        };
        assert!(one(-smooth(-f32::MAX, 1e-6)));
        assert!(one(smooth(f32::INFINITY, 0.1)));
        assert!(smooth(1e-30, 1e-6).abs() < 1e-20);
        assert_eq!(smooth(0.0, 0.1), 0.0);
    }

    #[test]
    fn schedule_decays_and_floors() {
        let s = VarpiSchedule::new(0.1, 0.7, 1e-6, 0.001);
        let mut v = s.initial;
        for _ in 0..1000 {
            s.advance(&mut v);
        }
        assert!((v - 0.1 * (-0.7f32).exp()).abs() < 1e-5);
        for _ in 0..100_000 {
            s.advance(&mut v);
        }
        assert_eq!(v, 1e-6);
    }
}
