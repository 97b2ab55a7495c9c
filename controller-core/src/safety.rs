//! Deployment safety, an addition to the paper's law (off by default; `docs/DEVIATIONS.md` §3):
//!
//! * **Limits** of the command before the quantizer: the rate `|u_k − u_{k−1}| ≤ du_max h`,
//!   then the magnitude `|u_k| ≤ u_max`, i.e. `u_k = sat_{u_max}(u_{k−1} + sat_{du_max h}(u*_k −
//!   u_{k−1}))` with `u*_k` the law's (28).
//! * **Anti-windup** by conditional integration (Åström & Hägglund, *Advanced PID Control*,
//!   2006, ch. 3): in a sample where a limit changed the command, the adaptive laws (20)–(22)
//!   are not integrated: `θ̂_{k+1} = θ̂_k` for `μ̂, ξ̂, λ̂`.
//! * **Bumpless re-entry** of neighbour and leader values: a link that returns fresh after a
//!   stale, missing, invalid or silent period enters `e_{i,1}` (10) as
//!   `ŷ_k(t) = y_k(t) + o_k(t)`, where the offset `o_k = ŷ_k(t_r⁻) − y_k(t_r)` (the last value
//!   used minus the returning one) shrinks linearly to 0 over `T_r` (`recovery_time`); while a
//!   link is degraded the last value used is held.
//! * **Re-seeded differentiators** after a held step (NaN state or overflow): the first valid
//!   step restarts every differentiator at `χ_1 = α`, `χ_2 = 0`, as on the first sample.
//!
//! [`Paper`] is the law as printed (every hook the identity); [`Safety`] the validated settings.

use crate::{gains::positive, ConfigError};

/// Safety settings as a user writes them (units of the command `u` and seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafetyConfig {
    /// Limit of `|u|` per actuator before the quantizer (`None`: no magnitude limit).
    pub u_max: Option<f32>,
    /// Limit of `|du/dt|` [units/s] (`None`: no rate limit).
    pub du_max: Option<f32>,
    /// `T_r` [s]: time over which a returning link's jump is blended in (0: no blending).
    pub recovery_time: f32,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            u_max: None,
            du_max: None,
            recovery_time: 0.2,
        }
    }
}

/// Validated safety settings for sample period `h`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Safety {
    u_max: f32,
    du_step: f32,
    blend_rate: f32,
}

impl Safety {
    /// Validates `cfg` for sample period `h` (> 0, checked by the caller).
    pub fn new(cfg: &SafetyConfig, h: f32) -> Result<Self, ConfigError> {
        let u_max = match cfg.u_max {
            Some(v) => positive(v, "u_max")?,
            None => f32::INFINITY,
        };
        let du_step = match cfg.du_max {
            Some(v) => positive(v, "du_max")? * h,
            None => f32::INFINITY,
        };
        if !cfg.recovery_time.is_finite() {
            return Err(ConfigError::NonFinite("recovery_time"));
        }
        if cfg.recovery_time < 0.0 {
            return Err(ConfigError::Negative("recovery_time"));
        }
        let blend_rate = if cfg.recovery_time > 0.0 {
            h / cfg.recovery_time
        } else {
            f32::INFINITY
        };
        Ok(Self {
            u_max,
            du_step,
            blend_rate,
        })
    }

    /// The magnitude limit (`∞` without one).
    pub const fn u_max(&self) -> f32 {
        self.u_max
    }
}

/// Re-entry memory of one link.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reentry {
    used: f32,
    offset: f32,
    step: f32,
    degraded: bool,
    seen: bool,
}

/// Safety memory of one agent: re-entry of `K` neighbour links and the leader, and whether
/// the previous step was held.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Recovery<const K: usize> {
    pub(crate) neighbours: [Reentry; K],
    pub(crate) leader: Reentry,
    pub(crate) after_hold: bool,
}

impl<const K: usize> Default for Recovery<K> {
    fn default() -> Self {
        Self {
            neighbours: [Reentry::default(); K],
            leader: Reentry::default(),
            after_hold: false,
        }
    }
}

/// The hooks the step calls; [`Paper`] makes each the identity.
pub(crate) trait Guard {
    /// `true` for [`Safety`]: lets the step skip the safety bookkeeping at compile time.
    const ENABLED: bool;
    /// The value of one link entering `e_{i,1}`: `y` as resolved by the consensus policy,
    /// `fresh` when it is a fresh, valid value.
    fn reenter(&self, mem: &mut Reentry, y: Option<f32>, fresh: bool) -> Option<f32>;
    /// The limited command and whether a limit changed it.
    fn limit(&self, u: f32, prev: f32) -> (f32, bool);
}

/// The paper's law: no limits, no re-entry blending.
pub(crate) struct Paper;

impl Guard for Paper {
    const ENABLED: bool = false;

    #[inline(always)]
    fn reenter(&self, _: &mut Reentry, y: Option<f32>, _: bool) -> Option<f32> {
        y
    }

    #[inline(always)]
    fn limit(&self, u: f32, _: f32) -> (f32, bool) {
        (u, false)
    }
}

impl Guard for Safety {
    const ENABLED: bool = true;

    #[inline]
    fn reenter(&self, mem: &mut Reentry, y: Option<f32>, fresh: bool) -> Option<f32> {
        let v = y?;
        if !fresh && mem.seen {
            mem.degraded = true;
            return Some(mem.used);
        }
        if fresh && mem.degraded && mem.seen {
            mem.offset = mem.used - v;
            mem.step = self.blend_rate * crate::math::abs(mem.offset);
        }
        mem.degraded = !fresh;
        mem.offset -= clamp(mem.offset, mem.step);
        mem.used = v + mem.offset;
        mem.seen = true;
        Some(mem.used)
    }

    #[inline]
    fn limit(&self, u: f32, prev: f32) -> (f32, bool) {
        let v = prev + clamp(u - prev, self.du_step);
        let v = clamp(v, self.u_max);
        (v, v != u)
    }
}

/// `x` limited to `[−b, b]` (`b ≥ 0`, may be `∞`); NaN stays NaN.
#[inline]
fn clamp(x: f32, b: f32) -> f32 {
    if x > b {
        b
    } else if x < -b {
        -b
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn safety(u_max: Option<f32>, du_max: Option<f32>, tr: f32, h: f32) -> Safety {
        Safety::new(
            &SafetyConfig {
                u_max,
                du_max,
                recovery_time: tr,
            },
            h,
        )
        .unwrap()
    }

    #[test]
    fn rate_then_magnitude_limit_by_hand() {
        let s = safety(Some(5.0), Some(100.0), 0.2, 0.01); // at most 1 per sample
        assert_eq!(s.limit(3.5, 3.0), (3.5, false));
        assert_eq!(s.limit(10.0, 3.0), (4.0, true));
        assert_eq!(s.limit(-10.0, 3.0), (2.0, true));
        assert_eq!(s.limit(5.5, 4.9), (5.0, true));
        assert_eq!(s.limit(-5.5, -5.0), (-5.0, true));
        let none = safety(None, None, 0.2, 0.01);
        assert_eq!(none.limit(1e30, -1e30), (1e30, false));
        assert!(none.limit(f32::NAN, 0.0).0.is_nan());
    }

    #[test]
    fn returning_link_is_blended_in_over_the_recovery_time() {
        // h = 0.1, T_r = 0.4: the jump is removed in 4 equal parts.
        let s = safety(None, None, 0.4, 0.1);
        let mut m = Reentry::default();
        assert_eq!(s.reenter(&mut m, Some(1.0), true), Some(1.0));
        assert_eq!(s.reenter(&mut m, Some(1.0), false), Some(1.0)); // stale: held
        assert_eq!(s.reenter(&mut m, Some(1.0), false), Some(1.0));
        let used: [f32; 5] = core::array::from_fn(|_| s.reenter(&mut m, Some(3.0), true).unwrap());
        let want = [1.5, 2.0, 2.5, 3.0, 3.0];
        for (u, w) in used.iter().zip(want) {
            assert!((u - w).abs() < 1e-6, "{used:?}");
        }
        // Without blending the returning value is used at once.
        let direct = safety(None, None, 0.0, 0.1);
        let mut m = Reentry::default();
        direct.reenter(&mut m, Some(1.0), true);
        direct.reenter(&mut m, Some(1.0), false);
        assert_eq!(direct.reenter(&mut m, Some(3.0), true), Some(3.0));
        // A link that never delivered stays out; its first value is used as it is.
        let mut m = Reentry::default();
        assert_eq!(s.reenter(&mut m, None, false), None);
        assert_eq!(s.reenter(&mut m, Some(2.0), true), Some(2.0));
    }

    #[test]
    fn invalid_settings_name_the_parameter() {
        let bad = |u_max, du_max, recovery_time| {
            Safety::new(
                &SafetyConfig {
                    u_max,
                    du_max,
                    recovery_time,
                },
                1e-3,
            )
            .unwrap_err()
        };
        assert_eq!(bad(Some(0.0), None, 0.1), ConfigError::NonPositive("u_max"));
        assert_eq!(
            bad(Some(f32::NAN), None, 0.1),
            ConfigError::NonFinite("u_max")
        );
        assert_eq!(
            bad(None, Some(-1.0), 0.1),
            ConfigError::NonPositive("du_max")
        );
        assert_eq!(
            bad(None, None, f32::INFINITY),
            ConfigError::NonFinite("recovery_time")
        );
        assert_eq!(
            bad(None, None, -0.1),
            ConfigError::Negative("recovery_time")
        );
    }
}
