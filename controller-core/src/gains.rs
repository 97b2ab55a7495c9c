//! Predefined-time gains `c_1`, `c_2`, `k_1`, `k_2` (LAW §3; the paper's Theorem 1).

use crate::{
    error::ConfigError,
    math,
    param::{Param, Reason},
};
use core::f32::consts::PI;

pub use crate::param::MAX_GAIN;

/// How `c_1`, `c_2` are chosen.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, GainSelection};
/// // Example 2's baseline comparison sets c_1 = 10, c_2 = 9 directly (LAW §10).
/// let cfg = ControllerConfig::<2> {
///     gains: GainSelection::Explicit { c1: 10.0, c2: 9.0 },
///     ..Default::default()
/// };
/// let c = Controller::<2, 2, 0>::new(&cfg)?;
/// assert_eq!((c.params().gains().c1, c.params().gains().c2), (10.0, 9.0));
/// // Auto: from T_s by Theorem 1, c_2 = π/(ζ T_s).
/// let auto = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// assert!((auto.params().gains().c2 - core::f32::consts::PI / 0.2).abs() < 1e-4);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum GainSelection {
    /// From `T_s`, `ζ` and the adaptation gains by LAW §3 (the paper's choice).
    Auto,
    /// Explicit `c_1`, `c_2` (baseline comparisons, the stricter `ϑ` of LAW §9).
    Explicit {
        /// `c_1 > 0`.
        c1: f32,
        /// `c_2 > 0`.
        c2: f32,
    },
}

/// The gains of one agent: `c_1`, `c_2` and the derived `k_1`, `k_2`.
///
/// ```
/// use controller_core::Gains;
/// // Example 1: n = 2, ζ = 0.1, p = 80, η = τ = 50, T_s = 2.
/// let g = Gains::predefined_time(2.0, 0.1, 2, 80.0, 50.0, 50.0).unwrap();
/// assert!((g.c1 - 16.26).abs() < 0.01 && (g.c2 - 15.71).abs() < 0.01);
/// // k_1 = (1/2)^(1+ζ/2) c_1, k_2 = (1/2)^(1−ζ/2) c_2.
/// assert!((g.k1 - 0.5f32.powf(1.05) * g.c1).abs() < 1e-4);
/// assert!((g.k2 - 0.5f32.powf(0.95) * g.c2).abs() < 1e-4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gains {
    /// `c_1 = π / (ϑ ζ T_s)`.
    pub c1: f32,
    /// `c_2 = π / (ζ T_s)`.
    pub c2: f32,
    /// `k_1 = (1/2)^(1+ζ/2) c_1`.
    pub k1: f32,
    /// `k_2 = (1/2)^(1−ζ/2) c_2`.
    pub k2: f32,
}

impl Gains {
    /// Gains from the predefined time `T_s` (LAW §3, `ϑ` reconstructed from (46)–(55)).
    ///
    /// ```
    /// use controller_core::{param::Param, Gains};
    /// // Example 1 (n = 2, ζ = 0.1, p = 80, η = τ = 50): halving T_s doubles both gains,
    /// // the settling time 2 T_s halves.
    /// let ts2 = Gains::predefined_time(2.0, 0.1, 2, 80.0, 50.0, 50.0)?;
    /// let ts1 = Gains::predefined_time(1.0, 0.1, 2, 80.0, 50.0, 50.0)?;
    /// assert!((ts1.c1 - 2.0 * ts2.c1).abs() < 1e-3 && (ts1.c2 - 2.0 * ts2.c2).abs() < 1e-3);
    /// // T_s must be positive; the error names it.
    /// let e = Gains::predefined_time(0.0, 0.1, 2, 80.0, 50.0, 50.0).unwrap_err();
    /// assert_eq!(e.param(), Param::Ts);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn predefined_time(
        ts: f32,
        zeta: f32,
        n: usize,
        p: f32,
        eta: f32,
        tau: f32,
    ) -> Result<Self, ConfigError> {
        Self::from_factor(ts, zeta, || theta(zeta, n, p, eta, tau))
    }

    /// Gains from `T_s` with the factor `r` of Theorem 1 as the paper prints it (D1, the
    /// reading `controller.gain_reading = "printed"`): `c_1 = π/(r ζ T_s)`, `c_2 = π/(ζ T_s)`
    /// with [`printed_factor`] for `r`. For Example 1 `c_1 ≈ 2,862` (the reconstruction of
    /// [`Self::predefined_time`] gives 16.26).
    ///
    /// ```
    /// use controller_core::Gains;
    /// let g = Gains::printed(2.0, 0.1, 2, 80.0, 50.0, 50.0)?;
    /// assert!((g.c1 - 2862.0).abs() < 1.0); // D1: the printed r is tiny
    /// assert!((g.c2 - 15.708).abs() < 1e-3); // c_2 as in the reconstruction
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn printed(
        ts: f32,
        zeta: f32,
        n: usize,
        p: f32,
        eta: f32,
        tau: f32,
    ) -> Result<Self, ConfigError> {
        Self::from_factor(ts, zeta, || printed_factor(zeta, n, p, eta, tau))
    }

    /// `c_2 = π/(ζ T_s)` and `c_1 = c_2 / factor` (`ϑ` or `r`), `ζ` and `T_s` checked first.
    fn from_factor(
        ts: f32,
        zeta: f32,
        factor: impl FnOnce() -> Result<f32, ConfigError>,
    ) -> Result<Self, ConfigError> {
        Param::Zeta.check(zeta)?;
        Param::Ts.check(ts)?;
        let factor = factor()?;
        let c2 = PI / (zeta * ts);
        Self::explicit(c2 / factor, c2, zeta)
    }

    /// Explicit `c_1`, `c_2`; `k_1`, `k_2` follow from `ζ`.
    ///
    /// ```
    /// use controller_core::{gains::MAX_GAIN, param::Param, Gains, Reason};
    /// // ζ = 0.5: k_1 = (1/2)^1.25 c_1, k_2 = (1/2)^0.75 c_2.
    /// let g = Gains::explicit(10.0, 9.0, 0.5)?;
    /// assert!((g.k1 - 10.0 * 0.5f32.powf(1.25)).abs() < 1e-4);
    /// assert!((g.k2 - 9.0 * 0.5f32.powf(0.75)).abs() < 1e-4);
    /// // A gain at √f32::MAX would overflow the second backstepping step.
    /// let e = Gains::explicit(MAX_GAIN, 9.0, 0.5).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::C1, Reason::TooLarge));
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    pub fn explicit(c1: f32, c2: f32, zeta: f32) -> Result<Self, ConfigError> {
        Param::Zeta.check(zeta)?;
        for (c, param) in [(c1, Param::C1), (c2, Param::C2)] {
            if param.check(c)? >= MAX_GAIN {
                return Err(ConfigError::new(param, Reason::TooLarge));
            }
        }
        Ok(Self {
            c1,
            c2,
            k1: math::powf(0.5, 1.0 + zeta / 2.0) * c1,
            k2: math::powf(0.5, 1.0 - zeta / 2.0) * c2,
        })
    }
}

/// The factor `ϑ` of LAW §3 (the paper's `r`).
///
/// ```
/// use controller_core::gains::theta;
/// // Example 1: the first candidate n^(−ζ/2) = 2^(−0.05) is the smallest.
/// let t = theta(0.1, 2, 80.0, 50.0, 50.0)?;
/// assert!((t - 2f32.powf(-0.05)).abs() < 1e-6);
/// // A small adaptation gain p selects its own candidate 2^(1+ζ/2) p^(ζ/2) (1+ζ)/(2+ζ).
/// let small_p = theta(0.1, 2, 0.01, 50.0, 50.0)?;
/// let want = 2f32.powf(1.05) * 0.01f32.powf(0.05) * 1.1 / 2.1;
/// assert!((small_p - want).abs() < 1e-5 && small_p < t);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
pub fn theta(zeta: f32, n: usize, p: f32, eta: f32, tau: f32) -> Result<f32, ConfigError> {
    check_factor_inputs(zeta, n, p, eta, tau)?;
    let two = scaled_power(1.0, 2.0, 1.0 + zeta / 2.0, 1.0, 1.0);
    let half = zeta / 2.0;
    let f1 = (1.0 + zeta) / (2.0 + zeta);
    let candidates = [
        scaled_power(1.0, n as f32, -half, 1.0, 1.0),
        scaled_power(two, p, half, f1, 1.0),
        scaled_power(two, eta, half, f1, 1.0),
        scaled_power(two, tau, half, 1.0 + 2.0 * zeta, 2.0 + 2.0 * zeta),
    ];
    Ok(candidates.iter().fold(f32::INFINITY, |m, &c| m.min(c)))
}

/// The factor `r` of Theorem 1 as printed below (21): `r = min{ n^(ζ/2),
/// (1/2)^(1+ζ/2)/(p (1+ζ)), (1/2)^(1+ζ/2)/(η (1+ζ)), (1/2)^(1+ζ/2)/(τ (1+2ζ)) }` (D1).
///
/// ```
/// use controller_core::gains::printed_factor;
/// // Example 1: the p term (1/2)^1.05 / (80 · 1.1) is the smallest.
/// let r = printed_factor(0.1, 2, 80.0, 50.0, 50.0)?;
/// assert!((r - 0.5f32.powf(1.05) / 88.0).abs() < 1e-7);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
pub fn printed_factor(zeta: f32, n: usize, p: f32, eta: f32, tau: f32) -> Result<f32, ConfigError> {
    check_factor_inputs(zeta, n, p, eta, tau)?;
    let half = scaled_power(1.0, 0.5, 1.0 + zeta / 2.0, 1.0, 1.0);
    let candidates = [
        scaled_power(1.0, n as f32, zeta / 2.0, 1.0, 1.0),
        half / (p * (1.0 + zeta)),
        half / (eta * (1.0 + zeta)),
        half / (tau * (1.0 + 2.0 * zeta)),
    ];
    Ok(candidates.iter().fold(f32::INFINITY, |m, &c| m.min(c)))
}

/// The parameters both readings of the gain factor use, in the order their errors are reported.
fn check_factor_inputs(zeta: f32, n: usize, p: f32, eta: f32, tau: f32) -> Result<(), ConfigError> {
    Param::Zeta.check(zeta)?;
    Param::P.check(p)?;
    Param::Eta.check(eta)?;
    Param::Tau.check(tau)?;
    if n == 0 {
        return Err(ConfigError::new(Param::StateOrder, Reason::OutOfRange));
    }
    Ok(())
}

/// `a x^y b / c`, rounded in that order (factors of 1 are exact). Out of line so that a
/// firmware links one copy of `powf` for the five powers of `ϑ`, not five inlined ones.
#[inline(never)]
fn scaled_power(a: f32, x: f32, y: f32, b: f32, c: f32) -> f32 {
    a * math::powf(x, y) * b / c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn example1_gains_match_spec() {
        let g = Gains::predefined_time(2.0, 0.1, 2, 80.0, 50.0, 50.0).unwrap();
        assert!((g.c2 - 15.7080).abs() < 1e-3, "c2 = {}", g.c2);
        assert!((g.c1 - 16.262).abs() < 5e-3, "c1 = {}", g.c1);
        // ϑ is the n^(−ζ/2) branch here: 2^(−0.05).
        let t = theta(0.1, 2, 80.0, 50.0, 50.0).unwrap();
        assert!((t - 2f32.powf(-0.05)).abs() < 1e-6);
        assert!((g.k1 - 0.5f32.powf(1.05) * g.c1).abs() < 1e-4);
        assert!((g.k2 - 0.5f32.powf(0.95) * g.c2).abs() < 1e-4);
        let g1 = Gains::predefined_time(1.0, 0.1, 2, 80.0, 50.0, 50.0).unwrap();
        assert!((g1.c1 - 2.0 * g.c1).abs() < 1e-3);
    }

    #[test]
    fn example2_gains_by_hand() {
        // ζ = 0.6, T_s = 0.5, p = τ = η = 30, n = 2: c2 = π / 0.3.
        let g = Gains::predefined_time(0.5, 0.6, 2, 30.0, 30.0, 30.0).unwrap();
        let c2 = core::f64::consts::PI / 0.3;
        assert!((g.c2 as f64 - c2).abs() < 1e-3);
        // ϑ = min(2^(−0.3), 2^1.3·30^0.3·1.6/2.6, same, 2^1.3·30^0.3·2.2/3.2) = 2^(−0.3).
        let theta = 2f64.powf(-0.3);
        assert!((g.c1 as f64 - c2 / theta).abs() < 1e-2, "c1 = {}", g.c1);
    }

    #[test]
    fn printed_factor_gives_the_gains_of_deviation_d1() {
        // Example 1: r = (1/2)^1.05 / (80 · 1.1), c1 = π / (r · 0.1 · 2) ≈ 2,862.
        let g = Gains::printed(2.0, 0.1, 2, 80.0, 50.0, 50.0).unwrap();
        let r = 0.5f64.powf(1.05) / (80.0 * 1.1);
        let c1 = core::f64::consts::PI / (r * 0.2);
        assert!((g.c1 as f64 - c1).abs() < 1e-3 * c1, "c1 = {}", g.c1);
        assert!((g.c1 - 2862.0).abs() < 1.0, "c1 = {}", g.c1);
        assert!((g.c2 - 15.7080).abs() < 1e-3, "c2 as reconstructed");
        // Example 2: the τ branch, (1/2)^1.3 / (30 · 2.2); c1 ≈ 1,702.
        let g2 = Gains::printed(0.5, 0.6, 2, 30.0, 30.0, 30.0).unwrap();
        let r2 = 0.5f64.powf(1.3) / (30.0 * 2.2);
        let c1 = core::f64::consts::PI / (r2 * 0.3);
        assert!((g2.c1 as f64 - c1).abs() < 1e-3 * c1, "c1 = {}", g2.c1);
        assert_eq!(
            printed_factor(0.1, 2, -1.0, 50.0, 50.0),
            Err(ConfigError::new(Param::P, Reason::NonPositive))
        );
    }

    #[test]
    fn small_adaptation_gain_selects_its_branch() {
        // With p tiny the second candidate is the minimum.
        let t = theta(0.5, 1, 1e-4, 50.0, 50.0).unwrap();
        let expect = 2f32.powf(1.25) * 1e-4f32.powf(0.25) * 1.5 / 2.5;
        assert!((t - expect).abs() < 1e-5);
    }

    #[test]
    fn rejects_bad_inputs() {
        let e = ConfigError::new;
        assert_eq!(
            Gains::predefined_time(2.0, 1.0, 2, 1.0, 1.0, 1.0),
            Err(e(Param::Zeta, Reason::OutOfRange))
        );
        assert_eq!(
            Gains::predefined_time(0.0, 0.5, 2, 1.0, 1.0, 1.0),
            Err(e(Param::Ts, Reason::NonPositive))
        );
        assert_eq!(
            Gains::explicit(-1.0, 1.0, 0.5),
            Err(e(Param::C1, Reason::NonPositive))
        );
        assert_eq!(
            Gains::predefined_time(1.0, 0.5, 0, 1.0, 1.0, 1.0),
            Err(e(Param::StateOrder, Reason::OutOfRange))
        );
        // ζ = 1e-30 passes the range check, but c_2 = π/(ζ T_s) ≈ 1.6e30 cannot be used.
        assert_eq!(
            Gains::predefined_time(2.0, 1e-30, 2, 80.0, 50.0, 50.0),
            Err(e(Param::C1, Reason::TooLarge))
        );
        assert_eq!(
            Gains::explicit(1.0, 2e19, 0.5),
            Err(e(Param::C2, Reason::TooLarge))
        );
    }
}
