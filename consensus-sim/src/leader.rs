//! The leader of LAW §2: the reference `y_d(t)` every pinned agent hears: the default sinusoid,
//! or `y_d = "<expression in t>"` with its derivatives computed exactly (symbolically).

use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::plant::custom::{TimeFunction, MAX_ORDER};
use consensus_plot::error::{Error, Result};

/// `[leader]`: `y_d = amplitude sin(omega t + phase) + offset`, or the expression `y_d`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Leader {
    /// Amplitude.
    pub amplitude: f64,
    /// Angular frequency [rad/s].
    pub omega: f64,
    /// Phase \[rad\].
    pub phase: f64,
    /// Offset.
    pub offset: f64,
    /// `y_d(t)` as an expression in `t` (the functions of custom plants); replaces the sinusoid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub y_d: Option<String>,
    /// `y_d` compiled with its derivatives, on first use.
    #[serde(skip)]
    compiled: OnceLock<Option<TimeFunction>>,
}

impl PartialEq for Leader {
    fn eq(&self, o: &Self) -> bool {
        (
            self.amplitude,
            self.omega,
            self.phase,
            self.offset,
            &self.y_d,
        ) == (o.amplitude, o.omega, o.phase, o.offset, &o.y_d)
    }
}

impl Default for Leader {
    fn default() -> Self {
        Self {
            amplitude: 0.6,
            omega: 2.0,
            phase: 0.0,
            offset: 0.0,
            y_d: None,
            compiled: OnceLock::new(),
        }
    }
}

/// Derivatives of `y_d` computed: as many as the highest plant order (Assumption 1 bounds
/// `y_d` and its derivatives up to `n`).
pub const DERIVATIVES: usize = MAX_ORDER;

/// Points of `[0, t_end]` at which `y_d` and its derivatives are checked.
const CHECK_POINTS: u32 = 2000;

impl Leader {
    /// The sinusoid of the four keys (no `y_d`).
    pub fn sinusoid(amplitude: f64, omega: f64, phase: f64, offset: f64) -> Self {
        Self {
            amplitude,
            omega,
            phase,
            offset,
            ..Self::default()
        }
    }

    /// The reference `y_d(t) = text`.
    pub fn expression(text: &str) -> Self {
        Self {
            y_d: Some(text.into()),
            ..Self::default()
        }
    }

    /// `y_d` compiled, `None` without an expression or when it does not compile.
    fn function(&self) -> Option<&TimeFunction> {
        let text = self.y_d.as_ref()?;
        self.compiled
            .get_or_init(|| TimeFunction::new(text, DERIVATIVES).ok())
            .as_ref()
    }

    /// `y_d(t)`.
    #[inline]
    pub fn yd(&self, t: f64) -> f64 {
        match &self.y_d {
            None => self.amplitude * (self.omega * t + self.phase).sin() + self.offset,
            Some(_) => self.function().map_or(f64::NAN, |f| f.value(t)),
        }
    }

    /// The `k`-th time derivative of `y_d` at `t` (`k ≤` [`DERIVATIVES`], exact: the
    /// sinusoid's closed form, or the expression's symbolic derivative).
    pub fn derivative(&self, k: usize, t: f64) -> f64 {
        match &self.y_d {
            None if k == 0 => self.yd(t),
            None => {
                let phase = self.omega * t + self.phase + k as f64 * std::f64::consts::FRAC_PI_2;
                self.amplitude * self.omega.powi(k as i32) * phase.sin()
            }
            Some(_) => self.function().map_or(f64::NAN, |f| f.derivative(k, t)),
        }
    }

    /// The `k`-th derivative of the expression written out (`None` for the sinusoid).
    pub fn derivative_text(&self, k: usize) -> Option<String> {
        self.function().and_then(|f| f.derivative_text(k))
    }

    /// Checks the keys (finite) and that `y_d` stays finite in the controller's `f32` over
    /// `[0, t_end]`; an expression must compile (errors name `leader.y_d` and the column) and
    /// it and its derivatives must be finite at every checked point.
    pub fn check(&self, t_end: f64) -> Result<()> {
        if let Some(text) = &self.y_d {
            let f = TimeFunction::new(text, DERIVATIVES)
                .map_err(|why| Error::invalid("leader.y_d", why))?;
            for p in 0..=CHECK_POINTS {
                let t = t_end * f64::from(p) / f64::from(CHECK_POINTS);
                let v = f.value(t);
                if !v.is_finite() || v.abs() > f64::from(f32::MAX) {
                    return Err(Error::invalid(
                        "leader.y_d",
                        format!(
                            "is {v} at t = {t}: y_d must be finite and fit the controller's f32"
                        ),
                    ));
                }
                for k in 1..=DERIVATIVES {
                    let d = f.derivative(k, t);
                    if !d.is_finite() {
                        return Err(Error::invalid(
                            "leader.y_d",
                            format!(
                                "derivative {k} is {d} at t = {t}: y_d and its derivatives up to \
                                 order {DERIVATIVES} must stay bounded (Assumption 1)"
                            ),
                        ));
                    }
                }
            }
            return Ok(());
        }
        for (k, v) in [
            ("leader.amplitude", self.amplitude),
            ("leader.omega", self.omega),
            ("leader.phase", self.phase),
            ("leader.offset", self.offset),
        ] {
            if !v.is_finite() {
                return Err(Error::invalid(k, format!("must be finite (got {v})")));
            }
        }
        let peak = self.amplitude.abs() + self.offset.abs();
        if peak > f64::from(f32::MAX) {
            return Err(Error::invalid(
                "leader.amplitude",
                format!("|amplitude| + |offset| = {peak:e} does not fit the controller's f32"),
            ));
        }
        if !(self.omega.abs() * t_end + self.phase.abs()).is_finite() {
            return Err(Error::invalid(
                "leader.omega",
                "omega * t_end overflows (y_d would be NaN)",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y_d = "0.6*sin(2*t)"` is the default sinusoid to the bit; `"sin(t)"` the unit one.
    #[test]
    fn an_expression_of_the_sinusoid_gives_its_values_to_the_bit() {
        let (default, written) = (Leader::default(), Leader::expression("0.6*sin(2*t)"));
        let unit = (
            Leader::sinusoid(1.0, 1.0, 0.0, 0.0),
            Leader::expression("sin(t)"),
        );
        for k in 0..=20_000 {
            let t = f64::from(k) * 1e-3;
            assert_eq!(default.yd(t).to_bits(), written.yd(t).to_bits(), "t = {t}");
            assert_eq!(unit.0.yd(t).to_bits(), unit.1.yd(t).to_bits(), "t = {t}");
        }
    }

    /// The symbolic derivatives of `sin(t)` are the closed forms `cos`, `−sin`, `−cos`, `sin`,
    /// and the sinusoid's own derivatives agree with them.
    #[test]
    fn derivatives_of_sin_are_the_closed_forms() {
        let (e, s) = (
            Leader::expression("sin(t)"),
            Leader::sinusoid(1.0, 1.0, 0.0, 0.0),
        );
        for k in 0..=1000 {
            let t = f64::from(k) * 0.01;
            let closed = [t.sin(), t.cos(), -t.sin(), -t.cos(), t.sin()];
            for (order, want) in closed.iter().enumerate() {
                assert!(
                    (e.derivative(order, t) - want).abs() < 1e-12,
                    "d{order} at {t}"
                );
                assert!(
                    (s.derivative(order, t) - want).abs() < 1e-12,
                    "sinusoid d{order}"
                );
            }
        }
        assert_eq!(e.derivative_text(1).as_deref(), Some("cos(t)"));
    }

    /// Each derivative of smooth expressions against a central difference of the one before.
    #[test]
    fn derivatives_match_finite_differences() {
        for text in [
            "0.5*sin(2*t) + 0.1*t^2 - exp(-t)",
            "tanh(3*(t - 1)) * cos(t)",
            "sqrt(1 + t^2) / (2 + sin(t))",
            "ln(2 + t) * 2^t - t % 0.7",
            "tan(0.3*t) + t^-1.5 * (t + 1)",
        ] {
            let l = Leader::expression(text);
            for k in 1..=DERIVATIVES {
                for p in 1..40 {
                    let t = 0.2 + f64::from(p) * 0.1 + 0.013;
                    let h = 1e-5;
                    let fd = (l.derivative(k - 1, t + h) - l.derivative(k - 1, t - h)) / (2.0 * h);
                    let d = l.derivative(k, t);
                    let tol = 1e-5 * (1.0 + d.abs());
                    assert!((d - fd).abs() < tol, "{text}: d{k} at {t}: {d} vs {fd}");
                }
            }
        }
    }

    #[test]
    fn bad_expressions_name_the_key_and_the_column() {
        for (text, what) in [
            ("0.6*sin(2*x)", "`x` at column 11"),
            ("sin(t", "column 4"),
            ("min(t)", "`min` at column 1 takes 2 arguments"),
            ("foo(t)", "unknown function `foo` at column 1"),
            ("", "empty expression"),
            ("t % t", "derivative 1"),
            ("sqrt(t)", "derivative 1 is inf at t = 0"),
            ("1/(t - 1)", "at t = 1"),
        ] {
            let e = Leader::expression(text)
                .check(2.0)
                .expect_err(text)
                .to_string();
            assert!(e.contains("leader.y_d") && e.contains(what), "{text}: {e}");
        }
        assert!(Leader::expression("sat(t - 1) + sign(t) * abs(sin(t))")
            .check(2.0)
            .is_ok());
    }
}
