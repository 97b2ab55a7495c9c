//! Deployment safety, an addition to the paper's law (off by default; `docs/DEVIATIONS.md` §3):
//!
//! * **Limits** of the command before the quantizer: the rate `|u_k − u_{k−1}| ≤ du_max h`,
//!   then the magnitude `|u_k| ≤ u_max`, i.e. `u_k = sat_{u_max}(u_{k−1} + sat_{du_max h}(u*_k −
//!   u_{k−1}))` with `u*_k` the law's (28).
//! * **Anti-windup** by conditional integration (Åström & Hägglund, *Advanced PID Control*,
//!   2006, ch. 3): in a sample where a limit changed the command, the adaptive laws (20)–(22)
//!   are not integrated: `θ̂_{k+1} = θ̂_k` for `μ̂, ξ̂, λ̂`.
//! * **Rate-limited re-entry** of neighbour and leader values: a link that returns fresh after
//!   a stale, missing, invalid or silent period enters `e_{i,1}` (10) as
//!   `ŷ_k(t) = y_k(t) + o_k(t)`, where the offset `o_k = ŷ_k(t_r⁻) − y_k(t_r)` (the last value
//!   used minus the returning one) shrinks to 0 at `v_r` per second (`recovery_rate`), i.e.
//!   within `|o_k(t_r)| / v_r`; while a link is degraded the last value used is held. Jumps up
//!   to `recovery_jump` re-enter at once (`o_k = 0`).
//! * **Re-seeded differentiators** after a held step (NaN state or overflow): the first valid
//!   step restarts every differentiator at `χ_1 = α`, `χ_2 = 0`, as on the first sample.
//!
//! [`Safety`] holds the validated settings. The step applies the re-entry to the links before
//! the law and the limits inside it; with safety off (`None`) none of this code runs, and
//! without the crate's `safety` feature none of it is linked.

use crate::{consensus::Link, error::ConfigError, param::Param};

/// Safety settings as a user writes them (units of the command `u` and seconds).
///
/// A magnitude limit on (28)'s command, and the adaptive laws paused while it acts
/// (needs the crate's `safety` feature, on by default; without it the configuration is
/// rejected):
///
/// ```
/// use controller_core::{param::Param, Controller, ControllerConfig, Link, Reason, SafetyConfig};
/// let cfg = ControllerConfig::<2> {
///     safety: Some(SafetyConfig { u_max: Some(0.5), ..SafetyConfig::default() }),
///     ..Default::default()
/// };
/// match Controller::<2, 2, 0>::new(&cfg) {
///     Ok(mut c) => {
///         let out = c.step(&[1.0, 2.0], &[], Link::Fresh(0.0)); // far from y_d = 0
///         assert_eq!(out.u, [-0.5, -0.5]);
///         assert!(out.status.limited);
///         assert_eq!(out.estimates.mu, 0.0); // μ̂ not integrated in a limited sample
///     }
///     Err(e) => {
///         assert!(!cfg!(feature = "safety"));
///         assert_eq!((e.param(), e.reason()), (Param::SafetyEnabled, Reason::NotBuilt));
///     }
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SafetyConfig {
    /// Limit of `|u|` per actuator before the quantizer (`None`: no magnitude limit).
    pub u_max: Option<f32>,
    /// Limit of `|du/dt|` [units/s] (`None`: no rate limit).
    pub du_max: Option<f32>,
    /// `v_r` [units of `y` per s]: speed at which a returning link's jump is removed from the
    /// value used (`∞`: no blending, the returning value is used at once).
    pub recovery_rate: f32,
    /// Jumps up to this size [units of `y`] re-enter at once: the small steps that brief
    /// staleness (lost frames) produces, which the law handles and which blending would turn
    /// into a lag that builds up under frequent loss.
    pub recovery_jump: f32,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            u_max: None,
            du_max: None,
            recovery_rate: const { Param::RecoveryRate.default_f32() },
            recovery_jump: const { Param::RecoveryJump.default_f32() },
        }
    }
}

/// Validated safety settings for sample period `h`.
///
/// ```
/// use controller_core::safety::Safety;
/// use controller_core::SafetyConfig;
/// let s = Safety::new(&SafetyConfig { u_max: Some(2.0), ..SafetyConfig::default() }, 1e-3)?;
/// assert_eq!(s.u_max(), 2.0);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Safety {
    u_max: f32,
    du_step: f32,
    blend_step: f32,
    jump: f32,
}

impl Safety {
    /// Validates `cfg` for sample period `h` (> 0, checked by the caller).
    ///
    /// ```
    /// use controller_core::safety::Safety;
    /// use controller_core::{param::Param, Reason, SafetyConfig};
    /// let bad = SafetyConfig { du_max: Some(0.0), ..SafetyConfig::default() };
    /// let e = Safety::new(&bad, 1e-3).unwrap_err();
    /// assert_eq!((e.param(), e.reason()), (Param::DuMax, Reason::NonPositive));
    /// // recovery_rate = ∞: returning values are used at once.
    /// let at_once = SafetyConfig { recovery_rate: f32::INFINITY, ..SafetyConfig::default() };
    /// assert!(Safety::new(&at_once, 1e-3).is_ok());
    /// ```
    pub fn new(cfg: &SafetyConfig, h: f32) -> Result<Self, ConfigError> {
        let u_max = match cfg.u_max {
            Some(v) => Param::UMax.check(v)?,
            None => f32::INFINITY,
        };
        let du_step = match cfg.du_max {
            Some(v) => Param::DuMax.check(v)? * h,
            None => f32::INFINITY,
        };
        Ok(Self {
            u_max,
            du_step,
            blend_step: Param::RecoveryRate.check(cfg.recovery_rate)? * h,
            jump: Param::RecoveryJump.check(cfg.recovery_jump)?,
        })
    }

    /// The magnitude limit (`∞` without one).
    ///
    /// ```
    /// use controller_core::safety::Safety;
    /// use controller_core::SafetyConfig;
    /// assert_eq!(Safety::new(&SafetyConfig::default(), 1e-3)?.u_max(), f32::INFINITY);
    /// # Ok::<(), controller_core::ConfigError>(())
    /// ```
    #[must_use]
    pub const fn u_max(&self) -> f32 {
        self.u_max
    }
}

/// Re-entry memory of one link.
///
/// A neighbour that returns after an outage with a jump enters `e_{i,1}` (10) at the
/// recovery rate (1 per second here, so 1e-3 per sample of 1 ms) instead of at once:
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link, SafetyConfig};
/// let cfg = ControllerConfig::<2> {
///     neighbour_count: 1,
///     pinned: false,
///     safety: Some(SafetyConfig::default()),
///     ..Default::default()
/// };
/// # #[cfg(feature = "safety")] {
/// let mut c = Controller::<2, 2, 1>::new(&cfg)?;
/// let x = [0.0, 0.0];
/// assert_eq!(c.step(&x, &[Link::Fresh(0.0)], Link::Missing).e[0], 0.0);
/// c.step(&x, &[Link::Missing], Link::Missing); // outage
/// let back = c.step(&x, &[Link::Fresh(0.5)], Link::Missing); // returns 0.5 higher
/// assert!((back.e[0] + 0.001).abs() < 1e-6); // not −0.5
/// # }
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reentry {
    used: f32,
    offset: f32,
    degraded: bool,
    seen: bool,
}

/// Safety memory of one agent: re-entry of `K` neighbour links and the leader, and whether
/// the previous step was held.
///
/// ```
/// use controller_core::{Controller, ControllerConfig, Link};
/// let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default())?;
/// // Without safety the recovery memory stays untouched.
/// let before = c.state().recovery;
/// c.step(&[0.1, 0.0], &[], Link::Fresh(0.0));
/// assert_eq!(c.state().recovery, before);
/// # Ok::<(), controller_core::ConfigError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Recovery<const K: usize> {
    pub(crate) neighbours: [Reentry; K],
    pub(crate) leader: Reentry,
    pub(crate) after_hold: bool,
}

impl Reentry {
    /// Re-enter from `y`: the next fresh value is blended in from it.
    fn restart_from(&mut self, y: f32) {
        *self = Self {
            used: y,
            offset: 0.0,
            degraded: true,
            seen: true,
        };
    }
}

impl<const K: usize> Recovery<K> {
    /// Every link re-enters from `y` (see [`crate::Controller::resume`]).
    pub(crate) fn restart_from(&mut self, y: f32) {
        for r in self.neighbours.iter_mut() {
            r.restart_from(y);
        }
        self.leader.restart_from(y);
    }
}

/// One link through [`Safety::reenter`], keeping its kind; invalid and missing values go
/// through unchanged (the consensus policy replaces them by the last value used).
#[inline(never)]
pub(crate) fn reenter_link(safety: &Safety, mem: &mut Reentry, link: Link) -> Link {
    let (v, fresh) = match link {
        Link::Fresh(v) if v.is_finite() => (v, true),
        Link::Stale(v) if v.is_finite() => (v, false),
        other => {
            mem.degraded |= mem.seen;
            return other;
        }
    };
    match safety.reenter(mem, Some(v), fresh) {
        Some(y) if fresh => Link::Fresh(y),
        Some(y) => Link::Stale(y),
        None => link,
    }
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

impl Safety {
    /// Rate-limited re-entry of one link: the value to use for it this sample.
    #[inline]
    fn reenter(&self, mem: &mut Reentry, y: Option<f32>, fresh: bool) -> Option<f32> {
        let v = y?;
        if !fresh && mem.seen {
            mem.degraded = true;
            return Some(mem.used);
        }
        if fresh && mem.degraded && mem.seen {
            let jump = mem.used - v;
            if crate::math::abs(jump) > self.jump {
                mem.offset = jump;
            }
        }
        mem.degraded = !fresh;
        mem.offset -= clamp(mem.offset, self.blend_step);
        mem.used = v + mem.offset;
        mem.seen = true;
        Some(mem.used)
    }

    /// The limited command and whether a limit changed it.
    #[inline]
    pub(crate) fn limit(&self, u: f32, prev: f32) -> (f32, bool) {
        // Without a rate limit `prev + (u − prev)` could round away from `u` and flag a limit.
        let v = if self.du_step.is_finite() {
            prev + clamp(u - prev, self.du_step)
        } else {
            u
        };
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

    fn safety(u_max: Option<f32>, du_max: Option<f32>, rate: f32, h: f32) -> Safety {
        Safety::new(
            &SafetyConfig {
                u_max,
                du_max,
                recovery_rate: rate,
                recovery_jump: 0.05,
            },
            h,
        )
        .unwrap()
    }

    #[test]
    fn rate_then_magnitude_limit_by_hand() {
        let s = safety(Some(5.0), Some(100.0), 1.0, 0.01); // at most 1 per sample
        assert_eq!(s.limit(3.5, 3.0), (3.5, false));
        assert_eq!(s.limit(10.0, 3.0), (4.0, true));
        assert_eq!(s.limit(-10.0, 3.0), (2.0, true));
        assert_eq!(s.limit(5.5, 4.9), (5.0, true));
        assert_eq!(s.limit(-5.5, -5.0), (-5.0, true));
        let none = safety(None, None, 1.0, 0.01);
        assert_eq!(none.limit(1e30, -1e30), (1e30, false));
        assert!(none.limit(f32::NAN, 0.0).0.is_nan());
    }

    #[test]
    fn returning_link_is_blended_in_at_the_recovery_rate() {
        // h = 0.1, v_r = 5: 0.5 per sample, a jump of 2 is removed in 4 samples.
        let s = safety(None, None, 5.0, 0.1);
        let mut m = Reentry::default();
        assert_eq!(s.reenter(&mut m, Some(1.0), true), Some(1.0));
        assert_eq!(s.reenter(&mut m, Some(1.0), false), Some(1.0)); // stale: held
        assert_eq!(s.reenter(&mut m, Some(1.0), false), Some(1.0));
        let used: [f32; 5] = core::array::from_fn(|_| s.reenter(&mut m, Some(3.0), true).unwrap());
        let want = [1.5, 2.0, 2.5, 3.0, 3.0];
        for (u, w) in used.iter().zip(want) {
            assert!((u - w).abs() < 1e-6, "{used:?}");
        }
        // A small jump (lost frames) re-enters at once.
        s.reenter(&mut m, Some(3.0), false);
        assert_eq!(s.reenter(&mut m, Some(3.04), true), Some(3.04));
        // Without blending the returning value is used at once.
        let direct = safety(None, None, f32::INFINITY, 0.1);
        let mut m = Reentry::default();
        direct.reenter(&mut m, Some(1.0), true);
        direct.reenter(&mut m, Some(1.0), false);
        assert_eq!(direct.reenter(&mut m, Some(3.0), true), Some(3.0));
        // A link that never delivered stays out; its first value is used as it is.
        let mut m = Reentry::default();
        assert_eq!(s.reenter(&mut m, None, false), None);
        assert_eq!(s.reenter(&mut m, Some(2.0), true), Some(2.0));
    }

    /// Agent 2 of the examples (hears agent 1 only) with safety on.
    fn agent(u_max: f32) -> crate::Controller<2, 2, 4> {
        let cfg = crate::ControllerConfig::<2> {
            neighbour_count: 1,
            pinned: false,
            safety: Some(SafetyConfig {
                u_max: Some(u_max),
                du_max: None,
                recovery_rate: 1.0,
                recovery_jump: 0.05,
            }),
            ..crate::ControllerConfig::default()
        };
        crate::Controller::new(&cfg).expect("valid")
    }

    #[test]
    fn limited_command_pauses_the_adaptive_laws() {
        let mut c = agent(1.0);
        let initial = c.state().estimates;
        for _ in 0..50 {
            let o = c.step(&[1.0, 0.0], &[Link::Fresh(0.0)], Link::Missing);
            assert!(
                o.status.limited && o.u.iter().all(|u| u.abs() == 1.0),
                "{o:?}"
            );
            assert_eq!(o.estimates, initial);
        }
        // Without safety the same error integrates the estimates at once.
        let cfg = crate::ControllerConfig::<2> {
            neighbour_count: 1,
            pinned: false,
            ..crate::ControllerConfig::default()
        };
        let mut free = crate::Controller::<2, 2, 4>::new(&cfg).expect("valid");
        let o = free.step(&[1.0, 0.0], &[Link::Fresh(0.0)], Link::Missing);
        assert!(!o.status.limited && o.estimates != initial, "{o:?}");
    }

    #[test]
    fn returning_neighbour_moves_e1_at_the_recovery_rate_and_nan_reseeds() {
        let mut c = agent(1e3);
        let y = [0.2, 0.0];
        for _ in 0..10 {
            let _ = c.step(&y, &[Link::Fresh(0.0)], Link::Missing);
        }
        for _ in 0..100 {
            let _ = c.step(&y, &[Link::Stale(0.0)], Link::Missing);
        }
        // Back with a jump of 0.5: e_1 = y − ŷ moves by h·v_r = 1e-3 per sample.
        let mut e_prev = 0.2;
        for k in 0..600 {
            let o = c.step(&y, &[Link::Fresh(0.5)], Link::Missing);
            let want = if k < 500 {
                0.2 - 1e-3 * (k + 1) as f32
            } else {
                -0.3
            };
            assert!((o.e[0] - want).abs() < 1e-4, "k = {k}: {}", o.e[0]);
            assert!((o.e[0] - e_prev).abs() <= 1e-3 + 1e-6);
            e_prev = o.e[0];
        }
        // A NaN state holds the command; the next valid step restarts the differentiator.
        assert!(c.state().differentiators[0].chi2 != 0.0);
        let held = c.step(&[f32::NAN, 0.0], &[Link::Fresh(0.5)], Link::Missing);
        assert!(held.status.fault.is_some());
        let o = c.step(&y, &[Link::Fresh(0.5)], Link::Missing);
        assert!(o.status.fault.is_none());
        let d = c.state().differentiators[0];
        assert_eq!((d.chi1, d.chi2), (o.alpha[0], 0.0));
    }

    #[test]
    fn invalid_settings_name_the_parameter() {
        let bad = |u_max, du_max, recovery_rate| {
            Safety::new(
                &SafetyConfig {
                    u_max,
                    du_max,
                    recovery_rate,
                    recovery_jump: 0.0,
                },
                1e-3,
            )
            .unwrap_err()
        };
        use crate::Reason as R;
        let e = ConfigError::new;
        assert_eq!(bad(Some(0.0), None, 0.1), e(Param::UMax, R::NonPositive));
        assert_eq!(bad(Some(f32::NAN), None, 0.1), e(Param::UMax, R::NonFinite));
        assert_eq!(bad(None, Some(-1.0), 0.1), e(Param::DuMax, R::NonPositive));
        assert_eq!(
            bad(None, None, f32::NAN),
            e(Param::RecoveryRate, R::NonFinite)
        );
        assert_eq!(bad(None, None, 0.0), e(Param::RecoveryRate, R::NonPositive));
    }
}
