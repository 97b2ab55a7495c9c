//! The leader of LAW §2: the reference `y_d(t)` every pinned agent hears.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// `[leader]`: `y_d = amplitude sin(omega t + phase) + offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Leader {
    /// Amplitude.
    pub amplitude: f64,
    /// Angular frequency [rad/s].
    pub omega: f64,
    /// Phase [rad].
    pub phase: f64,
    /// Offset.
    pub offset: f64,
}

impl Default for Leader {
    fn default() -> Self {
        Self {
            amplitude: 0.6,
            omega: 2.0,
            phase: 0.0,
            offset: 0.0,
        }
    }
}

impl Leader {
    /// `y_d(t)`.
    pub fn yd(&self, t: f64) -> f64 {
        self.amplitude * (self.omega * t + self.phase).sin() + self.offset
    }

    /// Checks the keys (finite) and that `y_d` stays finite in the controller's `f32` over
    /// `[0, t_end]`.
    pub fn check(&self, t_end: f64) -> Result<()> {
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
