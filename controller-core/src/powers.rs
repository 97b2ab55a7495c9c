//! The predefined-time powers `M(e) = sign(e)|e|^(1+ζ)` and `N(e) = sign(e)|e|^(1−ζ)` (LAW §4).

use crate::math;

/// `M` and `N` of one `ζ`, sharing one `|e|^ζ` per evaluation.
///
/// Near 0 `N` dominates (`|e|^(1−ζ) > |e|^(1+ζ)` for `|e| < 1`), far from it `M`: together
/// they give the predefined-time convergence of Theorem 1.
///
/// ```
/// use controller_core::powers::Powers;
/// let p = Powers::new(0.1); // Example 1's ζ
/// let (m_small, n_small) = p.m_n(0.01);
/// let (m_large, n_large) = p.m_n(10.0);
/// assert!(n_small > m_small && m_large > n_large);
/// // Relative error of the per-step power: a few 1e-6, 1.2 % with `micromath`.
/// let tol = if cfg!(feature = "micromath") { 1.2e-2 } else { 1e-5 };
/// assert!((m_large - 10f32.powf(1.1)).abs() < tol * m_large);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Powers {
    zeta: f32,
}

impl Powers {
    /// Powers for `ζ` (validated by the controller's configuration).
    ///
    /// ```
    /// use controller_core::powers::Powers;
    /// // ζ = 0.6 of Example 2: N(e) = sign(e)|e|^0.4, M(e) = sign(e)|e|^1.6.
    /// let (m, n) = Powers::new(0.6).m_n(-2.0);
    /// let tol = if cfg!(feature = "micromath") { 1.2e-2 } else { 1e-5 }; // relative
    /// assert!((m / -2f32.powf(1.6) - 1.0).abs() < tol && (n / -2f32.powf(0.4) - 1.0).abs() < tol);
    /// ```
    #[must_use]
    pub const fn new(zeta: f32) -> Self {
        Self { zeta }
    }

    /// `x^ζ` for `x ≥ 0`, with `0^ζ = 0`.
    ///
    /// ```
    /// use controller_core::powers::Powers;
    /// let p = Powers::new(0.5);
    /// let tol = if cfg!(feature = "micromath") { 1.2e-2 } else { 1e-5 }; // relative
    /// assert!((p.pow_zeta(0.25) / 0.5 - 1.0).abs() < tol);
    /// assert_eq!(p.pow_zeta(0.0), 0.0);
    /// ```
    #[inline]
    #[must_use]
    pub fn pow_zeta(&self, x: f32) -> f32 {
        if x > 0.0 {
            math::pow_pos(x, self.zeta)
        } else {
            0.0
        }
    }

    /// `(M(e), N(e))`, both 0 at `e = 0`.
    ///
    /// ```
    /// use controller_core::powers::Powers;
    /// let (m, n) = Powers::new(0.5).m_n(-4.0);
    /// let tol = if cfg!(feature = "micromath") { 1.2e-2 } else { 1e-5 }; // relative
    /// assert!((m / -8.0 - 1.0).abs() < tol && (n / -2.0 - 1.0).abs() < tol);
    /// ```
    #[inline]
    #[must_use]
    pub fn m_n(&self, e: f32) -> (f32, f32) {
        let a = math::abs(e);
        if a > 0.0 {
            let z = math::pow_pos(a, self.zeta);
            // `sign(e) a z` and `sign(e) a / z`: the sign moved onto the rounded product (the
            // same bits, no sign function).
            ((a * z).copysign(e), (a / z).copysign(e))
        } else {
            (0.0, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative tolerance of the back-end's per-step power (`math`'s tests measure each).
    const REL: f32 = if cfg!(feature = "micromath") {
        1.2e-2
    } else if cfg!(feature = "fast-math") {
        1e-5
    } else {
        5e-6
    };

    #[test]
    fn closed_forms() {
        let p = Powers::new(0.1);
        let close = |got: f32, want: f32| (got - want).abs() <= REL * want.abs();
        let (m, n) = p.m_n(2.0);
        assert!(close(m, 2f32.powf(1.1)));
        assert!(close(n, 2f32.powf(0.9)));
        assert_eq!(p.m_n(0.0), (0.0, 0.0));
        assert_eq!(p.m_n(-0.0), (0.0, 0.0));
        let (m, n) = p.m_n(-0.25);
        assert!(close(m, -(0.25f32.powf(1.1))));
        assert!(close(n, -(0.25f32.powf(0.9))));
        assert_eq!(p.pow_zeta(0.0), 0.0);
    }
}
