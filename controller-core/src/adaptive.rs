//! The adaptive laws of `μ̂`, `ξ̂`, `λ̂` (LAW §5; the paper's (20)–(22)), forward-Euler and
//! projected onto `[0, θ_max]`: the clamp at 0 is LAW §6 step 3; the upper bound (default 1e6,
//! far above what the examples reach) keeps one absurd but finite sample from committing an
//! estimate so large that every later step overflows `f32` (a documented deviation).

use crate::powers::Powers;

/// The three estimates of one agent.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Estimates, Link};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// // μ̂(0) = ξ̂(0) = 0, λ̂(0) = 1 (LAW §5).
/// assert_eq!(c.state().estimates, Estimates { mu: 0.0, xi: 0.0, lambda: 1.0 });
/// // An error drives μ̂ up by (20); estimates stay ≥ 0 (LAW §6 step 3).
/// let out = c.step(&[0.5, 0.0], &[], Link::Fresh(0.0));
/// assert!(out.estimates.mu > 0.0 && out.estimates.xi >= 0.0 && out.estimates.lambda >= 0.0);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimates {
    /// `μ̂`: MTN approximation-error bound.
    pub mu: f32,
    /// `ξ̂`: disturbance / stuck-actuator bound.
    pub xi: f32,
    /// `λ̂`: inverse bound of the quantizer-and-fault effectiveness.
    pub lambda: f32,
}

impl Estimates {
    /// All finite.
    ///
    /// ```
    /// use controller_core::Estimates;
    /// assert!(Estimates { mu: 0.0, xi: 2.0, lambda: 1.0 }.is_finite());
    /// assert!(!Estimates { mu: f32::NAN, xi: 2.0, lambda: 1.0 }.is_finite());
    /// ```
    #[inline]
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.mu.is_finite() && self.xi.is_finite() && self.lambda.is_finite()
    }
}

/// The driving terms of one sample: `Σ_j p/(2ǎ_j²) e_j² ‖Φ_j‖²`, `η |e_n tanh(e_n/γ)|`,
/// `τ |e_n β_n|`.
///
/// ```
/// use controller_core::adaptive::{AdaptiveLaws, Drives};
/// use controller_core::Estimates;
/// // Drives alone move the estimates by h · drive from 0 (no leakage at 0).
/// let laws = AdaptiveLaws::new(16.26, 15.71, 0.1, 1e-3, 1e6);
/// let zero = Estimates { mu: 0.0, xi: 0.0, lambda: 0.0 };
/// let next = laws.next(&zero, &Drives { mu: 1.0, xi: 2.0, lambda: 3.0 });
/// assert!((next.mu - 1e-3).abs() < 1e-9 && (next.xi - 2e-3).abs() < 1e-9);
/// assert!((next.lambda - 3e-3).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drives {
    /// Drive of `μ̂`.
    pub mu: f32,
    /// Drive of `ξ̂`.
    pub xi: f32,
    /// Drive of `λ̂`.
    pub lambda: f32,
}

/// The leakage gains `c_1`, `c_2`, `ζ` and the sample period shared by the three laws.
///
/// ```
/// use controller_core::adaptive::{AdaptiveLaws, Drives};
/// use controller_core::Estimates;
/// // Without drive, the leakage −c_1 θ^(1+ζ) − c_2 θ pulls every estimate to 0 (Example 1's
/// // c_1, c_2: from 1 to below 1e-12 within 2 s).
/// let laws = AdaptiveLaws::new(16.26, 15.71, 0.1, 1e-3, 1e6);
/// let none = Drives { mu: 0.0, xi: 0.0, lambda: 0.0 };
/// let mut est = Estimates { mu: 1.0, xi: 1.0, lambda: 1.0 };
/// for _ in 0..2_000 {
///     est = laws.next(&est, &none);
/// }
/// assert!([est.mu, est.xi, est.lambda].iter().all(|&v| (0.0..1e-12).contains(&v)));
/// // An Euler step that would overshoot below 0 is projected onto 0 (LAW §6 step 3).
/// let coarse = AdaptiveLaws::new(16.26, 15.71, 0.1, 0.1, 1e6);
/// assert_eq!(coarse.next(&Estimates { mu: 1.0, xi: 1.0, lambda: 1.0 }, &none).mu, 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdaptiveLaws {
    c1: f32,
    c2: f32,
    h: f32,
    max: f32,
    powers: Powers,
}

impl AdaptiveLaws {
    /// Laws with leakage `c_1`, `c_2`, exponent `ζ`, sample period `h` and projection bound
    /// `θ_max` (validated by the caller).
    ///
    /// ```
    /// use controller_core::adaptive::{AdaptiveLaws, Drives};
    /// use controller_core::Estimates;
    /// // θ_max = 10: a huge drive stops at the projection bound.
    /// let laws = AdaptiveLaws::new(1.0, 1.0, 0.1, 1e-3, 10.0);
    /// let e = Estimates { mu: 0.0, xi: 0.0, lambda: 1.0 };
    /// let n = laws.next(&e, &Drives { mu: 1e9, xi: 0.0, lambda: 0.0 });
    /// assert_eq!(n.mu, 10.0);
    /// ```
    #[must_use]
    pub const fn new(c1: f32, c2: f32, zeta: f32, h: f32, max: f32) -> Self {
        Self {
            c1,
            c2,
            h,
            max,
            powers: Powers::new(zeta),
        }
    }

    /// One Euler step: `μ̂' = drive − c_1 μ̂^(1+ζ) − c_2 μ̂`, likewise `ξ̂`; `λ̂` with `λ̂^(1+2ζ)`.
    ///
    /// ```
    /// use controller_core::adaptive::{AdaptiveLaws, Drives};
    /// use controller_core::Estimates;
    /// let laws = AdaptiveLaws::new(2.0, 3.0, 0.5, 0.01, 1e6);
    /// let est = Estimates { mu: 4.0, xi: 0.0, lambda: 1.0 };
    /// let n = laws.next(&est, &Drives { mu: 10.0, xi: 5.0, lambda: 0.0 });
    /// // μ̂: 4 + 0.01 (10 − 2 · 4^1.5 − 3 · 4) = 3.82 (20)
    /// assert!((n.mu - 3.82).abs() < 1e-5);
    /// // ξ̂: 0 + 0.01 · 5 = 0.05 (21)
    /// assert!((n.xi - 0.05).abs() < 1e-7);
    /// // λ̂: 1 + 0.01 (0 − 2 · 1^2 − 3 · 1) = 0.95 (22)
    /// assert!((n.lambda - 0.95).abs() < 1e-6);
    /// ```
    #[inline(always)]
    #[must_use]
    pub fn next(&self, est: &Estimates, drives: &Drives) -> Estimates {
        let mu_z = self.powers.pow_zeta(est.mu);
        let xi_z = self.powers.pow_zeta(est.xi);
        let la_z = self.powers.pow_zeta(est.lambda);
        Estimates {
            mu: self.euler(est.mu, drives.mu, est.mu * mu_z),
            xi: self.euler(est.xi, drives.xi, est.xi * xi_z),
            lambda: self.euler(est.lambda, drives.lambda, est.lambda * la_z * la_z),
        }
    }

    #[inline]
    fn euler(&self, x: f32, drive: f32, power: f32) -> f32 {
        // `clamp(0, max)` written out: the same result (NaN stays NaN for the finiteness
        // check) without the `fmaxf`/`fminf` calls it compiles to on a Cortex-M4.
        let v = x + self.h * (drive - self.c1 * power - self.c2 * x);
        let v = if v < 0.0 { 0.0 } else { v };
        if v > self.max {
            self.max
        } else {
            v
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_step_by_hand() {
        let laws = AdaptiveLaws::new(2.0, 3.0, 0.5, 0.01, 1e6);
        let est = Estimates {
            mu: 4.0,
            xi: 0.0,
            lambda: 1.0,
        };
        let d = Drives {
            mu: 10.0,
            xi: 5.0,
            lambda: 0.0,
        };
        let n = laws.next(&est, &d);
        // μ: 4 + 0.01·(10 − 2·4^1.5 − 3·4) = 4 + 0.01·(10 − 16 − 12) = 3.82
        assert!((n.mu - 3.82).abs() < 1e-5);
        // ξ: 0 + 0.01·5 = 0.05
        assert!((n.xi - 0.05).abs() < 1e-7);
        // λ: 1 + 0.01·(0 − 2·1 − 3·1) = 0.95
        assert!((n.lambda - 0.95).abs() < 1e-6);
    }

    #[test]
    fn clamps_at_zero() {
        let laws = AdaptiveLaws::new(100.0, 100.0, 0.5, 1.0, 1e6);
        let est = Estimates {
            mu: 1.0,
            xi: 1.0,
            lambda: 1.0,
        };
        let d = Drives {
            mu: 0.0,
            xi: 0.0,
            lambda: 0.0,
        };
        let n = laws.next(&est, &d);
        assert_eq!((n.mu, n.xi, n.lambda), (0.0, 0.0, 0.0));
        let capped = AdaptiveLaws::new(1.0, 1.0, 0.5, 1.0, 10.0);
        let big = Drives {
            mu: 1e30,
            xi: 1e30,
            lambda: 1e30,
        };
        let n = capped.next(&est, &big);
        assert_eq!((n.mu, n.xi, n.lambda), (10.0, 10.0, 10.0));
    }
}
