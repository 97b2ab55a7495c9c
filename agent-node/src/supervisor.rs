//! The node's supervisor: its state (`Boot → Operational ↔ Safe`, `Fault`), when it enters and
//! leaves its safe state, and what it commands there.
//!
//! ## States
//!
//! | state | entered | the actuators get | the controller |
//! |---|---|---|---|
//! | `Boot` | at start | the controller's command | steps |
//! | `Operational` | from `Boot` once every supervised source is healthy; from `Safe` after the recovery dwell | the controller's command | steps |
//! | `Safe` | from `Boot` or `Operational` when a supervised source is lost | closed-loop [`SafePolicy`]: the controller's command towards the safe reference; open-loop policy, or the sensor lost: the open-loop command | closed loop: steps; open loop: frozen (see below) |
//! | `Fault` | [`crate::Node::enter_fault`] (the board found a fault it cannot recover from) | zero | frozen; left only by a restart (a new `Node`) |
//!
//! ## Safe policies: closed loop first
//!
//! A plant may be unstable without feedback (Example 1's `ẋ₂ = u − 2x₁² + x₂³ + …` escapes in
//! finite time under any constant input), so the default safe state keeps the loop closed and
//! changes only the *reference* the controller tracks. The two closed-loop policies follow the
//! drive profile CiA 402's *halt* and *quick stop*:
//!
//! | policy | kind | reference while `Safe` | on entry | on exit |
//! |---|---|---|---|---|
//! | [`SafePolicy::HoldPosition`] (default) | closed loop, CiA 402 *halt* | the leader's value frozen at its last valid value (pinned agents), silent neighbours frozen at theirs (the freshness policy's hold), live neighbours as they are | nothing jumps: the frozen values are the ones in use; estimates, differentiators and time go on | live values re-enter; with `[safety]` at its recovery rate |
//! | [`SafePolicy::Stop`] | closed loop, CiA 402 *quick stop* | the agent's own output and velocity at entry, decelerated to rest at `decel` and held there; every consensus and leader term follows it | `e₁ = 0`, velocity matched; estimates, differentiators and time go on | every link re-enters from the agent's output; with `[safety]` at its recovery rate |
//! | [`SafePolicy::Hold`] | open loop | – | the controller freezes; the last command stays | controller resumed ([`controller_core::Controller::resume`]) |
//! | [`SafePolicy::Ramp`] | open loop | – | the last command ramps to zero | resumed |
//! | [`SafePolicy::Off`] | open loop (CiA 402 *disable*) | – | zero | resumed |
//!
//! Open-loop policies suit plants that are stable without feedback (the manipulators of
//! Example 2 under `off`). A lost **sensor** leaves nothing to close the loop with: whatever
//! the policy, the node then applies [`SupervisorConfig::sensor_policy`], which must be open
//! loop (default [`SafePolicy::Hold`], the command the controller itself holds on a non-finite
//! state).
//!
//! ## Sources, loss and health
//!
//! A source is *lost* when it has been silent (or invalid) for longer than its loss timeout,
//! and *healthy* when it is fresh in the sense of the freshness policy (`docs/NETWORK.md` §3).
//! Before a source was ever heard, its silence is counted from the node's first tick.
//!
//! | source | lost when | healthy when |
//! |---|---|---|
//! | leader (`leader_timeout`) | no valid leader value for longer than the timeout; every node that has the timeout watches the leader's frames, pinned or not (the bus is shared), only pinned agents use the value | a leader value within the stale timeout |
//! | neighbours (`neighbour_timeout`), [`NeighbourLoss::All`] (default) | *every* neighbour silent for longer than the timeout: the node has lost its network | at least one neighbour fresh |
//! | neighbours, [`NeighbourLoss::Any`] | *any* neighbour silent for longer than the timeout | every neighbour fresh |
//! | sensor (`sensor_timeout`) | read errors or non-finite states for longer than the timeout | a finite read |
//!
//! A node that is a CANopen device and consumes heartbeats (`0x1016`) counts a source whose
//! consumed heartbeat is lost as silent, whatever its values (the node passes it with an
//! infinite age): a neighbour's node-ID for that neighbour, any other for the leader
//! (`docs/NETWORK.md` §12, *Consumed heartbeats feed the supervisor*).
//!
//! A source without a timeout is not supervised. `All` is the default because one silent
//! neighbour is already handled by the freshness policy (its value is held); a node that hears
//! none of its neighbours has nothing left to agree with.
//!
//! ## Leaving the safe state
//!
//! Only when every supervised source has been healthy without interruption for
//! `recover_dwell`; a loss during the dwell restarts it. After a closed-loop safe state the
//! controller simply goes on (it never stopped). After an open-loop one it resumes
//! ([`controller_core::Controller::resume`]): its estimates `μ̂`, `ξ̂`, `λ̂` are kept (they bound
//! the plant's uncertainty, which did not change), while its time, `ϖ` and differentiators
//! restart, so the predefined-time transient starts again from the state the plant is in
//! rather than continuing one that the safe state interrupted; nothing is integrated against
//! commands that were not applied.

/// The node's state; [`NodeState::code`] is what the heartbeat and the PIL report carry.
///
/// ```
/// use agent_node::{supervisor::Supervisor, NodeState, SupervisorConfig};
/// // A node starts in Boot; with nothing supervised its first tick makes it Operational.
/// let sup = Supervisor::new(&SupervisorConfig::OFF)?;
/// assert_eq!(sup.state(), NodeState::Boot);
/// assert_eq!(NodeState::from_code(NodeState::Safe.code()), Some(NodeState::Safe));
/// # Ok::<(), agent_node::supervisor::SupervisorError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NodeState {
    /// Controlling, every supervised source healthy or not yet timed out.
    Operational,
    /// Started, not every supervised source heard yet; controlling.
    Boot,
    /// A supervised source was lost: the [`SafePolicy`] drives the actuators.
    Safe,
    /// A fault the node cannot recover from: outputs zero until restarted.
    Fault,
}

impl NodeState {
    /// Code on the wire: 0 operational, 1 boot, 2 safe, 3 fault (0 so a healthy node's PIL
    /// report reads as before).
    ///
    /// ```
    /// use agent_node::NodeState;
    /// // 0 so that a healthy node's PIL report reads as before the supervisor existed.
    /// assert_eq!(NodeState::Operational.code(), 0);
    /// assert_eq!(NodeState::Fault.code(), 3);
    /// ```
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Operational => 0,
            Self::Boot => 1,
            Self::Safe => 2,
            Self::Fault => 3,
        }
    }

    /// The state of a code; `None` above 3.
    ///
    /// ```
    /// use agent_node::NodeState;
    /// assert_eq!(NodeState::from_code(2), Some(NodeState::Safe));
    /// assert_eq!(NodeState::from_code(4), None); // a corrupt heartbeat byte
    /// ```
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Self::Operational),
            1 => Some(Self::Boot),
            2 => Some(Self::Safe),
            3 => Some(Self::Fault),
            _ => None,
        }
    }

    /// The lower-case name.
    ///
    /// ```
    /// use agent_node::NodeState;
    /// assert_eq!(NodeState::Safe.as_str(), "safe");
    /// assert_eq!(NodeState::Operational.as_str(), "operational");
    /// ```
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Operational => "operational",
            Self::Boot => "boot",
            Self::Safe => "safe",
            Self::Fault => "fault",
        }
    }
}

/// What the node does while `Safe` (module docs, *Safe policies*).
///
/// ```
/// use agent_node::{supervisor::safe_command, SafePolicy};
/// // Open-loop ramp at 2 units/s: after 0.25 s a command of 1.0 has come down to 0.5.
/// let q = safe_command(SafePolicy::Ramp { rate: 2.0 }, &[1.0], 250_000);
/// assert!((q[0] - 0.5).abs() < 1e-6);
/// assert!(SafePolicy::HoldPosition.is_closed_loop() && !SafePolicy::Off.is_closed_loop());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SafePolicy {
    /// Closed loop (CiA 402 *halt*): the controller keeps stepping with the leader's value
    /// frozen at its last valid value and silent neighbours frozen at theirs.
    HoldPosition,
    /// Closed loop (CiA 402 *quick stop*): the controller keeps stepping towards the agent's
    /// own reference, which starts at its output and velocity on entry and decelerates to rest.
    Stop {
        /// Deceleration of the reference (units of `y` per s², > 0, finite).
        decel: f32,
    },
    /// Open loop: keep the last command applied before entering.
    Hold,
    /// Open loop: from the last command, each actuator moves towards zero at `rate` (command
    /// units per second, > 0, finite) and stays there.
    Ramp {
        /// Command units per second.
        rate: f32,
    },
    /// Open loop: zero.
    Off,
}

impl SafePolicy {
    /// The controller keeps stepping (the loop stays closed around a safe reference).
    ///
    /// ```
    /// use agent_node::SafePolicy;
    /// // CiA 402 halt and quick stop keep the controller stepping; hold, ramp and off do not.
    /// assert!(SafePolicy::Stop { decel: 1.0 }.is_closed_loop());
    /// assert!(!SafePolicy::Ramp { rate: 1.0 }.is_closed_loop());
    /// ```
    #[must_use]
    pub const fn is_closed_loop(&self) -> bool {
        matches!(self, Self::HoldPosition | Self::Stop { .. })
    }

    /// The lower-case name used in scenario and node files.
    ///
    /// ```
    /// use agent_node::SafePolicy;
    /// assert_eq!(SafePolicy::HoldPosition.as_str(), "hold-position");
    /// assert_eq!(SafePolicy::Stop { decel: 3.0 }.as_str(), "stop");
    /// ```
    #[must_use]
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::HoldPosition => "hold-position",
            Self::Stop { .. } => "stop",
            Self::Hold => "hold",
            Self::Ramp { .. } => "ramp",
            Self::Off => "off",
        }
    }
}

/// Which neighbour silence is a loss.
///
/// ```
/// use agent_node::supervisor::{Observation, Supervisor};
/// use agent_node::{NeighbourLoss, NodeState, SupervisorConfig};
/// // One neighbour silent for 20 ms, the other fresh: a loss only under `Any`.
/// let obs = Observation { now_us: 20_000, stale_timeout_us: 2_500, leader_age_us: 0,
///     newest_neighbour_age_us: Some(0), oldest_neighbour_age_us: Some(20_000), sensor_ok: true };
/// for (loss, state) in [(NeighbourLoss::All, NodeState::Operational), (NeighbourLoss::Any, NodeState::Safe)] {
///     let cfg = SupervisorConfig { neighbour_timeout_us: Some(10_000), neighbour_loss: loss,
///         ..SupervisorConfig::OFF };
///     let mut sup = Supervisor::new(&cfg)?;
///     sup.update(&obs);
///     assert_eq!(sup.state(), state);
/// }
/// # Ok::<(), agent_node::supervisor::SupervisorError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NeighbourLoss {
    /// Every neighbour silent (the node has lost its network).
    #[default]
    All,
    /// Any one neighbour silent.
    Any,
}

/// When the node enters and leaves its safe state, and what it commands there.
///
/// ```
/// use agent_node::{supervisor::SupervisorError, SafePolicy, SupervisorConfig};
/// // Leader silent for 50 ms: quick stop at 2 units/s².
/// let cfg = SupervisorConfig { leader_timeout_us: Some(50_000),
///     policy: SafePolicy::Stop { decel: 2.0 }, ..SupervisorConfig::OFF };
/// assert_eq!(cfg.validate(), Ok(()));
/// // A sensor lost leaves no loop to close: a closed-loop sensor policy is refused.
/// let bad = SupervisorConfig { sensor_policy: SafePolicy::HoldPosition, ..cfg };
/// assert_eq!(bad.validate(), Err(SupervisorError::SensorPolicyClosedLoop));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SupervisorConfig {
    /// What the node does while `Safe` with its sensor working.
    pub policy: SafePolicy,
    /// What the node commands while its sensor is lost (open loop only: nothing to close the
    /// loop with).
    pub sensor_policy: SafePolicy,
    /// Leader silent longer than this (µs, > 0) is a loss; `None`: not supervised.
    pub leader_timeout_us: Option<u64>,
    /// Neighbour silence longer than this (µs, > 0) is a loss (see `neighbour_loss`); `None`:
    /// not supervised.
    pub neighbour_timeout_us: Option<u64>,
    /// Every neighbour or any neighbour.
    pub neighbour_loss: NeighbourLoss,
    /// Sensor invalid longer than this (µs, > 0) is a loss; `None`: not supervised.
    pub sensor_timeout_us: Option<u64>,
    /// Every supervised source healthy this long (µs) before leaving `Safe`.
    pub recover_dwell_us: u64,
    /// Speed (units of `y` per s, > 0; `∞`: at once) at which values that return after a loss
    /// re-enter the consensus error, when the controller has no `[safety]` of its own: with a
    /// closed-loop policy the node turns on the controller's rate-limited re-entry alone
    /// ([`controller_core::safety`], no limits) at this rate, so that leaving `Safe` is
    /// bumpless. A controller with `[safety]` uses its own `recovery_rate`.
    pub reentry_rate: f32,
}

impl SupervisorConfig {
    /// Nothing supervised: the node never enters `Safe` (the default).
    pub const OFF: Self = Self {
        policy: SafePolicy::HoldPosition,
        sensor_policy: SafePolicy::Hold,
        leader_timeout_us: None,
        neighbour_timeout_us: None,
        neighbour_loss: NeighbourLoss::All,
        sensor_timeout_us: None,
        recover_dwell_us: 0,
        reentry_rate: 1.0,
    };

    /// Some source has a loss timeout (otherwise the node never enters `Safe`).
    ///
    /// ```
    /// use agent_node::SupervisorConfig;
    /// assert!(!SupervisorConfig::OFF.supervises_any());
    /// let cfg = SupervisorConfig { sensor_timeout_us: Some(5_000), ..SupervisorConfig::OFF };
    /// assert!(cfg.supervises_any());
    /// ```
    #[must_use]
    pub const fn supervises_any(&self) -> bool {
        self.leader_timeout_us.is_some()
            || self.neighbour_timeout_us.is_some()
            || self.sensor_timeout_us.is_some()
    }

    /// Check every field once.
    ///
    /// ```
    /// use agent_node::{supervisor::SupervisorError, SupervisorConfig};
    /// assert_eq!(SupervisorConfig::OFF.validate(), Ok(()));
    /// let cfg = SupervisorConfig { leader_timeout_us: Some(0), ..SupervisorConfig::OFF };
    /// assert_eq!(cfg.validate(), Err(SupervisorError::LeaderTimeout));
    /// ```
    pub fn validate(&self) -> Result<(), SupervisorError> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        for p in [self.policy, self.sensor_policy] {
            match p {
                SafePolicy::Ramp { rate } if !positive(rate) => {
                    return Err(SupervisorError::RampRate)
                }
                SafePolicy::Stop { decel } if !positive(decel) => {
                    return Err(SupervisorError::StopDecel)
                }
                _ => {}
            }
        }
        if self.reentry_rate.is_nan() || self.reentry_rate <= 0.0 {
            return Err(SupervisorError::ReentryRate);
        }
        if self.sensor_policy.is_closed_loop() {
            return Err(SupervisorError::SensorPolicyClosedLoop);
        }
        for (t, e) in [
            (self.leader_timeout_us, SupervisorError::LeaderTimeout),
            (self.neighbour_timeout_us, SupervisorError::NeighbourTimeout),
            (self.sensor_timeout_us, SupervisorError::SensorTimeout),
        ] {
            if t == Some(0) {
                return Err(e);
            }
        }
        Ok(())
    }
}

impl Default for SupervisorConfig {
    fn default() -> Self {
        Self::OFF
    }
}

/// Which [`SupervisorConfig`] field is invalid.
///
/// `#[non_exhaustive]`: each new supervision setting brings its own check.
///
/// ```
/// use agent_node::{supervisor::{Supervisor, SupervisorError}, SafePolicy, SupervisorConfig};
/// let cfg = SupervisorConfig { policy: SafePolicy::Ramp { rate: f32::NAN }, ..SupervisorConfig::OFF };
/// let e = Supervisor::new(&cfg).unwrap_err();
/// assert_eq!(e, SupervisorError::RampRate);
/// assert_eq!(e.to_string(), "safe-state ramp rate must be finite and > 0");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SupervisorError {
    /// `policy = Ramp { rate }` with a rate that is not finite and > 0.
    RampRate,
    /// `policy = Stop { decel }` with a deceleration that is not finite and > 0.
    StopDecel,
    /// A closed-loop `sensor_policy`: without a sensor there is no loop to close.
    SensorPolicyClosedLoop,
    /// `reentry_rate` not > 0 (NaN included).
    ReentryRate,
    /// `leader_timeout_us = Some(0)`.
    LeaderTimeout,
    /// `neighbour_timeout_us = Some(0)`.
    NeighbourTimeout,
    /// `sensor_timeout_us = Some(0)`.
    SensorTimeout,
}

impl core::fmt::Display for SupervisorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::RampRate => "safe-state ramp rate must be finite and > 0",
            Self::StopDecel => "safe-state stop deceleration must be finite and > 0",
            Self::ReentryRate => "re-entry rate must be > 0 (infinite: at once)",
            Self::SensorPolicyClosedLoop => {
                "the sensor-loss policy must be open loop (hold, ramp or off): without a sensor \
                 there is no loop to close"
            }
            Self::LeaderTimeout => "leader timeout must be > 0",
            Self::NeighbourTimeout => "neighbour timeout must be > 0",
            Self::SensorTimeout => "sensor timeout must be > 0",
        })
    }
}

impl core::error::Error for SupervisorError {}

/// The reference of [`SafePolicy::Stop`]: from the output `y0` and velocity `w` at entry
/// (`t0`), `y(τ) = y0 + w τ − sgn(w) d τ²/2` until rest at `τ = |w|/d`, then held.
///
/// ```
/// use agent_node::supervisor::StopProfile;
/// // From y = 1 moving at 2 units/s, decelerating at 4 units/s²: at rest after 0.5 s at y = 1.5.
/// let p = StopProfile::new(1.0, 2.0, 4.0, 0);
/// assert!((p.at(250_000) - 1.375).abs() < 1e-6);
/// assert!((p.at(500_000) - 1.5).abs() < 1e-6);
/// assert_eq!(p.at(2_000_000), p.at(500_000)); // held at rest
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StopProfile {
    y0: f32,
    w: f32,
    decel: f32,
    t0_us: u64,
}

impl StopProfile {
    /// The profile from `y0` moving at `w` (units per s) at `t0_us`, decelerating at `decel`
    /// (> 0, validated with the policy); a non-finite `w` counts as rest.
    ///
    /// ```
    /// use agent_node::supervisor::StopProfile;
    /// // A non-finite velocity counts as rest: the reference stays at y0.
    /// let p = StopProfile::new(0.3, f32::NAN, 1.0, 10);
    /// assert_eq!(p.at(1_000_000), 0.3);
    /// ```
    #[must_use]
    pub fn new(y0: f32, w: f32, decel: f32, t0_us: u64) -> Self {
        let w = if w.is_finite() { w } else { 0.0 };
        Self {
            y0,
            w,
            decel,
            t0_us,
        }
    }

    /// The reference at `now_us`.
    ///
    /// ```
    /// use agent_node::supervisor::StopProfile;
    /// // Moving backwards at 1 unit/s from 0, decelerating at 1 unit/s²: rest at -0.5 after 1 s.
    /// let p = StopProfile::new(0.0, -1.0, 1.0, 1_000);
    /// assert_eq!(p.at(0), 0.0); // before entry: y0
    /// assert!((p.at(1_001_000) + 0.5).abs() < 1e-6);
    /// ```
    #[must_use]
    pub fn at(&self, now_us: u64) -> f32 {
        let tau = now_us.saturating_sub(self.t0_us) as f32 * 1e-6;
        let speed = self.w.abs();
        let tau = if speed < self.decel * tau {
            speed / self.decel
        } else {
            tau
        };
        self.y0 + self.w * tau - (0.5 * self.decel * tau * tau).copysign(self.w)
    }
}

/// Supervised sources that are lost, as bits (heartbeat byte 1).
///
/// ```
/// use agent_node::supervisor::Lost;
/// let lost = Lost::from_bits(Lost::LEADER | Lost::SENSOR);
/// assert!(lost.leader() && lost.sensor() && !lost.neighbours());
/// assert_eq!(lost.bits(), 0b101);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Lost(u8);

impl Lost {
    /// Bit of the leader.
    pub const LEADER: u8 = 1;
    /// Bit of the neighbours.
    pub const NEIGHBOURS: u8 = 2;
    /// Bit of the sensor.
    pub const SENSOR: u8 = 4;

    /// From bits (unknown bits dropped).
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// // Unknown bits of a heartbeat byte are dropped.
    /// assert_eq!(Lost::from_bits(0xF8).bits(), 0);
    /// assert!(Lost::from_bits(0xFA).neighbours());
    /// ```
    #[must_use]
    pub const fn from_bits(bits: u8) -> Self {
        Self(bits & (Self::LEADER | Self::NEIGHBOURS | Self::SENSOR))
    }

    /// The bits.
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// assert_eq!(Lost::from_bits(Lost::NEIGHBOURS).bits(), 2);
    /// ```
    #[must_use]
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// No source lost.
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// assert!(Lost::default().is_empty());
    /// assert!(!Lost::from_bits(Lost::SENSOR).is_empty());
    /// ```
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The leader is lost.
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// assert!(Lost::from_bits(Lost::LEADER).leader());
    /// assert!(!Lost::from_bits(Lost::SENSOR).leader());
    /// ```
    #[must_use]
    pub const fn leader(self) -> bool {
        self.0 & Self::LEADER != 0
    }

    /// The neighbours are lost.
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// assert!(Lost::from_bits(Lost::NEIGHBOURS).neighbours());
    /// assert!(!Lost::from_bits(Lost::LEADER).neighbours());
    /// ```
    #[must_use]
    pub const fn neighbours(self) -> bool {
        self.0 & Self::NEIGHBOURS != 0
    }

    /// The sensor is lost.
    ///
    /// ```
    /// use agent_node::supervisor::Lost;
    /// assert!(Lost::from_bits(Lost::SENSOR).sensor());
    /// assert!(!Lost::default().sensor());
    /// ```
    #[must_use]
    pub const fn sensor(self) -> bool {
        self.0 & Self::SENSOR != 0
    }
}

/// What the node observed at one tick, for [`Supervisor::update`]. Ages are µs since the last
/// valid value (since the first tick for a source never heard).
///
/// ```
/// use agent_node::supervisor::{Observation, Supervisor};
/// use agent_node::{NodeState, SupervisorConfig};
/// let cfg = SupervisorConfig { leader_timeout_us: Some(10_000), ..SupervisorConfig::OFF };
/// let mut sup = Supervisor::new(&cfg)?;
/// // The leader's value 1 ms old, within the 2.5 ms stale timeout: healthy.
/// let obs = Observation { now_us: 1_000, stale_timeout_us: 2_500, leader_age_us: 1_000,
///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: true };
/// sup.update(&obs);
/// assert_eq!(sup.state(), NodeState::Operational);
/// # Ok::<(), agent_node::supervisor::SupervisorError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Observation {
    /// Clock at the tick (µs).
    pub now_us: u64,
    /// The freshness timeout (µs): a source within it is healthy.
    pub stale_timeout_us: u64,
    /// Age of the leader's value.
    pub leader_age_us: u64,
    /// Age of the freshest neighbour value; `None` without neighbours.
    pub newest_neighbour_age_us: Option<u64>,
    /// Age of the stalest neighbour value; `None` without neighbours.
    pub oldest_neighbour_age_us: Option<u64>,
    /// The sensor read gave a finite state.
    pub sensor_ok: bool,
}

/// A change of state.
///
/// ```
/// use agent_node::supervisor::{Observation, Supervisor, Transition};
/// use agent_node::{NodeState, SupervisorConfig};
/// let cfg = SupervisorConfig { sensor_timeout_us: Some(1_000), ..SupervisorConfig::OFF };
/// let mut sup = Supervisor::new(&cfg)?;
/// let mut obs = Observation { now_us: 0, stale_timeout_us: 2_500, leader_age_us: 0,
///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: false };
/// assert_eq!(sup.update(&obs), None); // invalid, not yet for longer than 1 ms
/// obs.now_us = 2_000;
/// let t: Transition = sup.update(&obs).unwrap();
/// assert_eq!((t.from, t.to), (NodeState::Boot, NodeState::Safe));
/// assert!(t.lost.sensor());
/// # Ok::<(), agent_node::supervisor::SupervisorError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transition {
    /// Before.
    pub from: NodeState,
    /// After.
    pub to: NodeState,
    /// Sources lost at the time.
    pub lost: Lost,
}

/// The state machine of the module docs; pure, no I/O.
///
/// ```
/// use agent_node::supervisor::{Observation, Supervisor};
/// use agent_node::{NodeState, SupervisorConfig};
/// // The leader supervised with a 10 ms timeout and a 5 ms recovery dwell.
/// let cfg = SupervisorConfig { leader_timeout_us: Some(10_000), recover_dwell_us: 5_000,
///     ..SupervisorConfig::OFF };
/// let mut sup = Supervisor::new(&cfg)?;
/// let at = |now_us, leader_age_us| Observation { now_us, stale_timeout_us: 2_500, leader_age_us,
///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: true };
/// sup.update(&at(0, 0));
/// assert_eq!(sup.state(), NodeState::Operational);
/// sup.update(&at(20_000, 20_000)); // silent for 20 ms: safe state
/// assert_eq!(sup.state(), NodeState::Safe);
/// sup.update(&at(21_000, 0)); // back: the dwell starts
/// assert_eq!(sup.state(), NodeState::Safe);
/// sup.update(&at(26_000, 0)); // healthy for 5 ms: operational again
/// assert_eq!((sup.state(), sup.safe_entries()), (NodeState::Operational, 1));
/// # Ok::<(), agent_node::supervisor::SupervisorError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Supervisor {
    cfg: SupervisorConfig,
    state: NodeState,
    lost: Lost,
    sensor_bad_since: Option<u64>,
    healthy_since: Option<u64>,
    entries: u32,
}

impl Supervisor {
    /// A supervisor in `Boot`; the configuration is checked once.
    ///
    /// ```
    /// use agent_node::{supervisor::{Supervisor, SupervisorError}, SupervisorConfig};
    /// assert!(Supervisor::new(&SupervisorConfig::OFF).is_ok());
    /// let cfg = SupervisorConfig { reentry_rate: 0.0, ..SupervisorConfig::OFF };
    /// assert_eq!(Supervisor::new(&cfg), Err(SupervisorError::ReentryRate));
    /// ```
    pub fn new(cfg: &SupervisorConfig) -> Result<Self, SupervisorError> {
        cfg.validate()?;
        Ok(Self {
            cfg: *cfg,
            state: NodeState::Boot,
            lost: Lost::default(),
            sensor_bad_since: None,
            healthy_since: None,
            entries: 0,
        })
    }

    /// The configuration.
    ///
    /// ```
    /// use agent_node::{supervisor::Supervisor, SupervisorConfig};
    /// let cfg = SupervisorConfig { recover_dwell_us: 7, ..SupervisorConfig::OFF };
    /// assert_eq!(Supervisor::new(&cfg)?.config(), &cfg);
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn config(&self) -> &SupervisorConfig {
        &self.cfg
    }

    /// The current state.
    ///
    /// ```
    /// use agent_node::{supervisor::Supervisor, NodeState, SupervisorConfig};
    /// let mut sup = Supervisor::new(&SupervisorConfig::OFF)?;
    /// assert_eq!(sup.state(), NodeState::Boot);
    /// sup.fault();
    /// assert_eq!(sup.state(), NodeState::Fault);
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn state(&self) -> NodeState {
        self.state
    }

    /// Sources lost at the last update.
    ///
    /// ```
    /// use agent_node::supervisor::{Observation, Supervisor};
    /// use agent_node::SupervisorConfig;
    /// let cfg = SupervisorConfig { leader_timeout_us: Some(1_000), ..SupervisorConfig::OFF };
    /// let mut sup = Supervisor::new(&cfg)?;
    /// assert!(sup.lost().is_empty());
    /// sup.update(&Observation { now_us: 5_000, stale_timeout_us: 2_500, leader_age_us: 5_000,
    ///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: true });
    /// assert!(sup.lost().leader());
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn lost(&self) -> Lost {
        self.lost
    }

    /// The policy that applies while `Safe`: [`SupervisorConfig::sensor_policy`] while the
    /// sensor is lost, [`SupervisorConfig::policy`] otherwise.
    ///
    /// ```
    /// use agent_node::supervisor::{Observation, Supervisor};
    /// use agent_node::{SafePolicy, SupervisorConfig};
    /// let cfg = SupervisorConfig { sensor_timeout_us: Some(1_000), sensor_policy: SafePolicy::Off,
    ///     ..SupervisorConfig::OFF };
    /// let mut sup = Supervisor::new(&cfg)?;
    /// assert_eq!(sup.policy_in_force(), SafePolicy::HoldPosition);
    /// let bad = |now_us| Observation { now_us, stale_timeout_us: 2_500, leader_age_us: 0,
    ///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: false };
    /// sup.update(&bad(0));
    /// sup.update(&bad(2_000)); // sensor lost: its open-loop policy applies
    /// assert_eq!(sup.policy_in_force(), SafePolicy::Off);
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn policy_in_force(&self) -> SafePolicy {
        if self.lost.sensor() {
            self.cfg.sensor_policy
        } else {
            self.cfg.policy
        }
    }

    /// Times the node entered `Safe`.
    ///
    /// ```
    /// use agent_node::supervisor::{Observation, Supervisor};
    /// use agent_node::SupervisorConfig;
    /// let cfg = SupervisorConfig { leader_timeout_us: Some(1_000), ..SupervisorConfig::OFF };
    /// let mut sup = Supervisor::new(&cfg)?;
    /// assert_eq!(sup.safe_entries(), 0);
    /// sup.update(&Observation { now_us: 3_000, stale_timeout_us: 2_500, leader_age_us: 3_000,
    ///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: true });
    /// assert_eq!(sup.safe_entries(), 1);
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn safe_entries(&self) -> u32 {
        self.entries
    }

    /// The leader is supervised.
    ///
    /// ```
    /// use agent_node::{supervisor::Supervisor, SupervisorConfig};
    /// assert!(!Supervisor::new(&SupervisorConfig::OFF)?.watches_leader());
    /// let cfg = SupervisorConfig { leader_timeout_us: Some(1), ..SupervisorConfig::OFF };
    /// assert!(Supervisor::new(&cfg)?.watches_leader());
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    #[must_use]
    pub fn watches_leader(&self) -> bool {
        self.cfg.leader_timeout_us.is_some()
    }

    /// Latch `Fault`.
    ///
    /// ```
    /// use agent_node::{supervisor::Supervisor, NodeState, SupervisorConfig};
    /// let mut sup = Supervisor::new(&SupervisorConfig::OFF)?;
    /// let t = sup.fault().unwrap();
    /// assert_eq!((t.from, t.to), (NodeState::Boot, NodeState::Fault));
    /// assert_eq!(sup.fault(), None); // latched: no second transition
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    pub fn fault(&mut self) -> Option<Transition> {
        self.go(NodeState::Fault)
    }

    fn go(&mut self, to: NodeState) -> Option<Transition> {
        let from = self.state;
        if from == to {
            return None;
        }
        if to == NodeState::Safe {
            self.entries = self.entries.saturating_add(1);
        }
        self.state = to;
        self.healthy_since = None;
        Some(Transition {
            from,
            to,
            lost: self.lost,
        })
    }

    /// One tick's observation: evaluate loss and health, and change state if due.
    ///
    /// ```
    /// use agent_node::supervisor::{Observation, Supervisor};
    /// use agent_node::{NodeState, SupervisorConfig};
    /// let mut sup = Supervisor::new(&SupervisorConfig::OFF)?;
    /// let obs = Observation { now_us: 0, stale_timeout_us: 2_500, leader_age_us: 0,
    ///     newest_neighbour_age_us: None, oldest_neighbour_age_us: None, sensor_ok: true };
    /// let t = sup.update(&obs).unwrap();
    /// assert_eq!(t.to, NodeState::Operational);
    /// assert_eq!(sup.update(&obs), None); // no change, no transition
    /// # Ok::<(), agent_node::supervisor::SupervisorError>(())
    /// ```
    pub fn update(&mut self, o: &Observation) -> Option<Transition> {
        let c = &self.cfg;
        let lost_after = |timeout: Option<u64>, age: Option<u64>| match (timeout, age) {
            (Some(t), Some(a)) => a > t,
            _ => false,
        };
        let fresh = |age: Option<u64>| age.is_none_or(|a| a <= o.stale_timeout_us);
        let neighbour_age = match c.neighbour_loss {
            NeighbourLoss::All => o.newest_neighbour_age_us,
            NeighbourLoss::Any => o.oldest_neighbour_age_us,
        };
        if o.sensor_ok {
            self.sensor_bad_since = None;
        } else if self.sensor_bad_since.is_none() {
            self.sensor_bad_since = Some(o.now_us);
        }
        let sensor_bad_for = self.sensor_bad_since.map(|t| o.now_us.saturating_sub(t));

        let mut lost = 0;
        if lost_after(c.leader_timeout_us, Some(o.leader_age_us)) {
            lost |= Lost::LEADER;
        }
        if lost_after(c.neighbour_timeout_us, neighbour_age) {
            lost |= Lost::NEIGHBOURS;
        }
        if lost_after(c.sensor_timeout_us, sensor_bad_for) {
            lost |= Lost::SENSOR;
        }
        self.lost = Lost(lost);
        let healthy = (c.leader_timeout_us.is_none() || fresh(Some(o.leader_age_us)))
            && (c.neighbour_timeout_us.is_none() || fresh(neighbour_age))
            && (c.sensor_timeout_us.is_none() || o.sensor_ok);

        match self.state {
            NodeState::Fault => None,
            NodeState::Boot | NodeState::Operational if lost != 0 => self.go(NodeState::Safe),
            NodeState::Boot if healthy => self.go(NodeState::Operational),
            NodeState::Boot | NodeState::Operational => None,
            NodeState::Safe => {
                if lost != 0 || !healthy {
                    self.healthy_since = None;
                    return None;
                }
                let since = *self.healthy_since.get_or_insert(o.now_us);
                if o.now_us.saturating_sub(since) >= c.recover_dwell_us {
                    self.go(NodeState::Operational)
                } else {
                    None
                }
            }
        }
    }
}

/// The safe-state command after `dt_us` at `policy`, from the `last` one.
/// Closed-loop policies have no command of their own: they return `last`.
///
/// ```
/// use agent_node::{supervisor::safe_command, SafePolicy};
/// assert_eq!(safe_command(SafePolicy::Off, &[0.7, -0.2], 1_000), [0.0, 0.0]);
/// assert_eq!(safe_command(SafePolicy::Hold, &[0.7, -0.2], 1_000), [0.7, -0.2]);
/// // Ramp at 1 unit/s for 0.5 s: -0.2 reaches 0 and stays there, 0.7 comes down to 0.2.
/// let q = safe_command(SafePolicy::Ramp { rate: 1.0 }, &[0.7, -0.2], 500_000);
/// assert!((q[0] - 0.2).abs() < 1e-6 && q[1] == 0.0);
/// ```
#[must_use]
pub fn safe_command<const M: usize>(policy: SafePolicy, last: &[f32; M], dt_us: u64) -> [f32; M] {
    match policy {
        SafePolicy::Hold | SafePolicy::HoldPosition | SafePolicy::Stop { .. } => *last,
        SafePolicy::Off => [0.0; M],
        SafePolicy::Ramp { rate } => {
            let step = rate * (dt_us as f32 * 1e-6);
            last.map(|q| {
                if !q.is_finite() || q.abs() <= step {
                    0.0
                } else {
                    q - step.copysign(q)
                }
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STALE: u64 = 2_500;

    fn obs(
        now_us: u64,
        leader: u64,
        neighbours: Option<(u64, u64)>,
        sensor_ok: bool,
    ) -> Observation {
        Observation {
            now_us,
            stale_timeout_us: STALE,
            leader_age_us: leader,
            newest_neighbour_age_us: neighbours.map(|n| n.0),
            oldest_neighbour_age_us: neighbours.map(|n| n.1),
            sensor_ok,
        }
    }

    fn watching(cfg: SupervisorConfig) -> Supervisor {
        Supervisor::new(&cfg).expect("valid")
    }

    #[test]
    fn boot_goes_operational_at_once_when_nothing_is_supervised() {
        let mut s = watching(SupervisorConfig::OFF);
        assert_eq!(s.state(), NodeState::Boot);
        let t = s.update(&obs(0, u64::MAX, None, false));
        assert_eq!(t.map(|t| t.to), Some(NodeState::Operational));
        for k in 1..100 {
            assert_eq!(
                s.update(&obs(k * 1000, u64::MAX, Some((u64::MAX, u64::MAX)), false)),
                None
            );
        }
        assert_eq!(s.safe_entries(), 0);
    }

    #[test]
    fn boot_waits_for_the_leader_then_goes_operational() {
        let mut s = watching(SupervisorConfig {
            leader_timeout_us: Some(100_000),
            ..SupervisorConfig::OFF
        });
        assert_eq!(
            s.update(&obs(0, 0, None, true)).map(|t| t.to),
            Some(NodeState::Operational)
        );
        let mut s = watching(SupervisorConfig {
            leader_timeout_us: Some(100_000),
            ..SupervisorConfig::OFF
        });
        assert_eq!(s.update(&obs(0, 50_000, None, true)), None);
        assert_eq!(s.state(), NodeState::Boot);
    }

    #[test]
    fn boot_goes_safe_when_the_leader_is_never_heard() {
        let mut s = watching(SupervisorConfig {
            leader_timeout_us: Some(100_000),
            ..SupervisorConfig::OFF
        });
        assert_eq!(s.update(&obs(100_000, 100_000, None, true)), None);
        let t = s
            .update(&obs(100_001, 100_001, None, true))
            .expect("transition");
        assert_eq!((t.from, t.to), (NodeState::Boot, NodeState::Safe));
        assert!(t.lost.leader() && !t.lost.neighbours() && !t.lost.sensor());
        assert_eq!(s.safe_entries(), 1);
    }

    #[test]
    fn leader_loss_enters_safe_after_the_timeout_and_leaves_after_the_dwell() {
        let mut s = watching(SupervisorConfig {
            leader_timeout_us: Some(10_000),
            recover_dwell_us: 5_000,
            ..SupervisorConfig::OFF
        });
        s.update(&obs(0, 0, None, true));
        assert_eq!(s.state(), NodeState::Operational);
        assert_eq!(s.update(&obs(20_000, 10_000, None, true)), None);
        let t = s.update(&obs(20_001, 10_001, None, true)).expect("enters");
        assert_eq!(t.to, NodeState::Safe);
        // Back, but not yet for the dwell; a relapse restarts the dwell.
        assert_eq!(s.update(&obs(30_000, 0, None, true)), None);
        assert_eq!(s.update(&obs(34_000, STALE + 1, None, true)), None);
        assert_eq!(s.update(&obs(35_000, 0, None, true)), None);
        assert_eq!(s.update(&obs(39_999, 0, None, true)), None);
        let t = s.update(&obs(40_000, 0, None, true)).expect("leaves");
        assert_eq!((t.from, t.to), (NodeState::Safe, NodeState::Operational));
        assert_eq!(s.safe_entries(), 1);
        s.update(&obs(60_001, 10_001, None, true));
        assert_eq!(s.safe_entries(), 2);
    }

    #[test]
    fn neighbour_loss_all_needs_every_neighbour_silent() {
        let cfg = SupervisorConfig {
            neighbour_timeout_us: Some(10_000),
            ..SupervisorConfig::OFF
        };
        let mut s = watching(cfg);
        s.update(&obs(0, 0, Some((0, 0)), true));
        // One neighbour silent for long, another fresh: not lost with `All`.
        assert_eq!(s.update(&obs(50_000, 0, Some((1_000, 50_000)), true)), None);
        let t = s
            .update(&obs(60_000, 0, Some((10_001, 60_000)), true))
            .expect("enters");
        assert!(t.lost.neighbours());
        // Healthy again as soon as one neighbour is fresh.
        let t = s
            .update(&obs(61_000, 0, Some((0, 61_000)), true))
            .expect("leaves");
        assert_eq!(t.to, NodeState::Operational);
    }

    #[test]
    fn neighbour_loss_any_needs_one_neighbour_silent_and_every_one_back() {
        let mut s = watching(SupervisorConfig {
            neighbour_timeout_us: Some(10_000),
            neighbour_loss: NeighbourLoss::Any,
            ..SupervisorConfig::OFF
        });
        s.update(&obs(0, 0, Some((0, 0)), true));
        let t = s
            .update(&obs(50_000, 0, Some((1_000, 10_001)), true))
            .expect("enters");
        assert!(t.lost.neighbours());
        assert_eq!(s.update(&obs(51_000, 0, Some((0, STALE + 1)), true)), None);
        let t = s
            .update(&obs(52_000, 0, Some((0, STALE)), true))
            .expect("leaves");
        assert_eq!(t.to, NodeState::Operational);
    }

    #[test]
    fn sensor_loss_counts_from_the_first_invalid_read() {
        let mut s = watching(SupervisorConfig {
            sensor_timeout_us: Some(3_000),
            ..SupervisorConfig::OFF
        });
        s.update(&obs(0, 0, None, true));
        for t in [1_000, 2_000, 3_000, 4_000] {
            assert_eq!(s.update(&obs(t, 0, None, false)), None, "{t}");
        }
        let t = s.update(&obs(5_000, 0, None, false)).expect("enters");
        assert!(t.lost.sensor());
        assert_eq!(
            s.update(&obs(6_000, 0, None, true)).map(|t| t.to),
            Some(NodeState::Operational)
        );
        // A single valid read restarts the count.
        s.update(&obs(7_000, 0, None, false));
        s.update(&obs(9_000, 0, None, true));
        assert_eq!(s.update(&obs(11_000, 0, None, false)), None);
        assert_eq!(s.state(), NodeState::Operational);
    }

    #[test]
    fn fault_is_latched() {
        let mut s = watching(SupervisorConfig {
            leader_timeout_us: Some(1_000),
            ..SupervisorConfig::OFF
        });
        s.update(&obs(0, 0, None, true));
        assert_eq!(s.fault().map(|t| t.to), Some(NodeState::Fault));
        assert_eq!(s.fault(), None);
        for t in [5_000, 10_000] {
            assert_eq!(s.update(&obs(t, t, None, true)), None);
            assert_eq!(s.update(&obs(t + 1, 0, None, true)), None);
        }
        assert_eq!(s.state(), NodeState::Fault);
        assert_eq!(s.safe_entries(), 0);
    }

    #[test]
    fn invalid_configurations_are_named() {
        let bad = [
            (
                SupervisorConfig {
                    policy: SafePolicy::Ramp { rate: 0.0 },
                    ..SupervisorConfig::OFF
                },
                SupervisorError::RampRate,
            ),
            (
                SupervisorConfig {
                    policy: SafePolicy::Ramp { rate: f32::NAN },
                    ..SupervisorConfig::OFF
                },
                SupervisorError::RampRate,
            ),
            (
                SupervisorConfig {
                    leader_timeout_us: Some(0),
                    ..SupervisorConfig::OFF
                },
                SupervisorError::LeaderTimeout,
            ),
            (
                SupervisorConfig {
                    neighbour_timeout_us: Some(0),
                    ..SupervisorConfig::OFF
                },
                SupervisorError::NeighbourTimeout,
            ),
            (
                SupervisorConfig {
                    sensor_timeout_us: Some(0),
                    ..SupervisorConfig::OFF
                },
                SupervisorError::SensorTimeout,
            ),
        ];
        for (cfg, e) in bad {
            assert_eq!(Supervisor::new(&cfg).err(), Some(e));
        }
    }

    #[test]
    fn policies_command_hold_ramp_and_off() {
        let last = [2.0f32, -0.5];
        assert_eq!(safe_command(SafePolicy::Hold, &last, 1_000), last);
        assert_eq!(safe_command(SafePolicy::Off, &last, 1_000), [0.0, 0.0]);
        let ramp = SafePolicy::Ramp { rate: 100.0 };
        assert_eq!(safe_command(ramp, &last, 10_000), [1.0, 0.0]);
        assert_eq!(safe_command(ramp, &[1.0, f32::NAN], 10_000), [0.0, 0.0]);
        let mut q = last;
        for _ in 0..30 {
            q = safe_command(SafePolicy::Ramp { rate: 10.0 }, &q, 10_000);
        }
        assert_eq!(q, [0.0, 0.0]);
    }

    #[test]
    fn state_codes_round_trip() {
        for s in [
            NodeState::Operational,
            NodeState::Boot,
            NodeState::Safe,
            NodeState::Fault,
        ] {
            assert_eq!(NodeState::from_code(s.code()), Some(s));
        }
        assert_eq!(NodeState::from_code(4), None);
    }
}

/// `s` seconds as whole µs, rounded half up: the same value as
/// `(f64::from(s) * 1e6 + 0.5) as u64` (a 24-bit mantissa times 10⁶ is exact in 64-bit
/// integers), without double-precision arithmetic, which a core with a single-precision FPU
/// (or none) links as about 2 KiB of library code. Negative or NaN: 0; saturates at
/// `u64::MAX`.
///
/// ```
/// use agent_node::supervisor::micros_from_secs;
/// assert_eq!(micros_from_secs(0.001), 1_000);
/// assert_eq!(micros_from_secs(0.0002), 200);
/// assert_eq!(micros_from_secs(2.5e-3), 2_500);
/// assert_eq!(micros_from_secs(-1.0), 0);
/// ```
#[must_use]
pub const fn micros_from_secs(s: f32) -> u64 {
    let bits = s.to_bits();
    let biased = ((bits >> 23) & 0xff) as i32;
    if bits >> 31 != 0 || (biased == 0xff && bits & 0x7f_ffff != 0) {
        return 0;
    }
    if biased == 0xff {
        return u64::MAX;
    }
    let (mantissa, exp) = if biased == 0 {
        ((bits & 0x7f_ffff) as u64, -149)
    } else {
        (((bits & 0x7f_ffff) | 0x80_0000) as u64, biased - 150)
    };
    // `s · 10⁶ = p · 2^exp` with `p < 2^44`.
    let p = mantissa * 1_000_000;
    if exp >= 64 || (exp >= 0 && p > u64::MAX >> exp) {
        u64::MAX
    } else if exp >= 0 {
        p << exp
    } else if exp <= -45 {
        0
    } else {
        let shift = (-exp) as u32;
        (p + (1 << (shift - 1))) >> shift
    }
}

#[cfg(test)]
mod micros_tests {
    use super::micros_from_secs;

    /// Every exponent and many mantissas against the double-precision formula it replaces.
    #[test]
    fn micros_from_secs_equals_the_double_precision_rounding() {
        let mut x: u32 = 0x9E37_79B9;
        for k in 0..400_000u32 {
            // xorshift over the bit patterns, plus every exponent with edge mantissas.
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let bits = if k < 2048 {
                ((k / 8) << 23)
                    | [
                        0, 1, 0x40_0000, 0x7f_ffff, 0x3f_ffff, 0x55_5555, 7, 0x7f_fff0,
                    ][(k % 8) as usize]
            } else {
                x
            };
            let s = f32::from_bits(bits);
            let want = (f64::from(s) * 1e6 + 0.5) as u64;
            assert_eq!(micros_from_secs(s), want, "s = {s:e} (bits {bits:#010x})");
        }
        for s in [
            0.001f32, 0.0002, 0.0025, 0.05, 0.1, 1.0, 1e6, 0.5e-6, 0.49e-6,
        ] {
            assert_eq!(
                micros_from_secs(s),
                (f64::from(s) * 1e6 + 0.5) as u64,
                "{s}"
            );
        }
    }
}
