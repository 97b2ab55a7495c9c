//! The agent node application: one follower's firmware, `no_std`, no allocation.
//!
//! A timer interrupt at the sample period `h` calls [`Node::tick`], which does, in order:
//!
//! 1. **sample** — read the clock and the agent's state `x_i` from the [`Sensor`];
//! 2. **drain** — take every frame waiting in the CAN controller (at most [`MAX_RX_PER_POLL`]),
//!    decode it ([`crate::wire`]), and keep the latest value of each neighbour and of the
//!    leader, time-stamped with the clock (a CAN receive interrupt may call
//!    [`Node::poll_rx`] earlier, which time-stamps frames closer to their arrival);
//! 3. **freshness** — turn each neighbour slot into a [`Link`] for the controller (below);
//! 4. **step** — [`Controller::step`];
//! 5. **actuate** — write the quantized commands `q` to the [`Actuator`];
//! 6. **broadcast** — send `y_i = x_{i,1}` in one frame with the agent's identifier and the
//!    next sequence counter.
//!
//! ## Freshness policy (what the controller gets, and what it does with it)
//!
//! A value is *fresh* while `now − t_rx ≤ stale_timeout`, where `t_rx` is the node's clock when
//! the frame was taken from the CAN controller. The node hands the controller, per neighbour
//! `k` (in the configured order) and for the leader:
//!
//! | what the node has                        | [`Link`] passed     | what the controller does (`controller_core::consensus`) |
//! |------------------------------------------|---------------------|------------------------------------|
//! | a value received within the timeout      | `Fresh(y_k)`        | uses it                            |
//! | a value older than the timeout           | `Stale(y_k)`        | uses it (zero-order hold of the last value), counts `stale_neighbours` / `leader_stale` |
//! | nothing ever received (or only `NO_VALUE`) | `Missing`         | leaves the term `a_ik (y_i − y_k)` out of `e_{i,1}` (as if the neighbour agreed), counts `missing_neighbours` and `dropped_neighbours` (`leader_dropped` for the leader) |
//!
//! So a neighbour that falls silent is **held at its last value**, for as long as it stays
//! silent: the consensus error `e_{i,1}` still has all its terms, but one of them is frozen.
//! When the neighbour speaks again its first frame is accepted whatever its sequence counter
//! (the link had timed out) and the link is fresh from the next step. A **silent leader** is
//! handled the same way by the pinned agent(s): `y_d` is held at its last received value, so
//! the followers converge to a constant reference until the leader returns, and then track it
//! again; non-pinned agents never look at leader frames. The node logs each transition
//! (fresh → stale with `warn!`, stale → fresh with `info!`) once, not every sample.
//!
//! While a link is fresh, a frame whose sequence counter repeats the last accepted one, or is
//! behind it, is dropped and counted ([`NodeStats::repeated`], [`NodeStats::out_of_order`]);
//! counters skipped between two accepted frames are counted in [`NodeStats::seq_gaps`] (frames
//! this node never saw: lost on the bus, or replaced at the sender before they were sent).
//!
//! ## Supervision, heartbeat, overruns
//!
//! A [`Supervisor`] ([`crate::supervisor`]) watches the leader, the neighbours and the sensor
//! against the timeouts of [`NodeConfig::supervisor`] and moves the node between `Boot`,
//! `Operational`, `Safe` and `Fault`; while `Safe` the actuators get the configured
//! [`crate::supervisor::SafePolicy`]'s command instead of the controller's, and the controller
//! is not advanced (the tick still reports the error the frozen controller would see). With
//! [`NodeConfig::heartbeat_period_us`] > 0 the node sends a heartbeat
//! ([`wire::Heartbeat`]) after its value frame every period, agent `i`'s `i − 1` samples after
//! the first tick (modulo the period) so that the heartbeats of a bus are spread over samples.
//!
//! A deadline overrun ([`NodeStats::overruns`]) is a sample period whose release found the
//! previous step still running. A board with a release timer reports each one as it sees it
//! ([`Node::record_overrun`]), so every late step is counted, however little it was late; a
//! tick that comes more than 1.5 sample periods after the previous one counts the samples
//! skipped in between, less those the board reported since that tick, so a board that reports
//! and the skipped samples of the same late step are counted once.
//!
//! ## Faults and errors
//!
//! Nothing on the runtime path panics or allocates. A sensor error passes a NaN state to the
//! controller, which holds its previous command ([`controller_core::StepFault`]); the node
//! still actuates (the held command) and broadcasts `NO_VALUE`. Actuator and CAN errors are
//! counted in [`NodeStats`] and logged on their first occurrence after a success.

use controller_core::{Controller, ControllerConfig, Link, SafetyConfig, StepFault, StepOutput};
use embedded_can::{nb::Can, Error as _, ErrorKind};

#[cfg(feature = "canopen")]
use crate::canopen::{self, od::ParamStore, CoFrame, Device, Event, Identity};
use crate::canopen::{od::NodeIdentity, Fault};
pub use crate::own::NodeError;
use crate::own::Own;
use crate::supervisor::{
    micros_from_secs, safe_command, NodeState, Observation, SafePolicy, StopProfile, Supervisor,
    SupervisorConfig,
};
use crate::wire::{self, DecodeStats, Decoded, Heartbeat, IdPlan, SeqCheck, Source, WireError};

/// Overrun EMCYs go out at most this often (µs of the node's clock).
pub const OVERRUN_EMCY_INHIBIT_US: u64 = 1_000_000;

/// Frames drained per call of [`Node::poll_rx`] at most, so a flooded bus cannot keep the
/// sample interrupt busy forever.
pub const MAX_RX_PER_POLL: usize = 32;

/// A monotonic clock.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// // The node reads its clock once per tick: the tick reports the reading.
/// let mut n = node();
/// n.clock_mut().0 = 1_000;
/// assert_eq!(n.tick().now_us, 1_000);
/// ```
pub trait Clock {
    /// Microseconds since an arbitrary origin; never decreases.
    ///
    /// ```
    /// use agent_node::Clock;
    /// struct Ticks(u64);
    /// impl Clock for Ticks {
    ///     fn now_us(&mut self) -> u64 {
    ///         self.0 += 1_000; // a 1 kHz timer
    ///         self.0
    ///     }
    /// }
    /// let mut c = Ticks(0);
    /// assert!(c.now_us() < c.now_us()); // monotonic
    /// ```
    fn now_us(&mut self) -> u64;
}

/// The agent's state sensors: `x_i` (`N` entries; `x_{i,1} = y_i`).
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use controller_core::StepFault;
/// // A failed read passes a NaN state: the controller holds its command (LAW §6).
/// let mut n = node();
/// n.sensor_mut().0 = Err(());
/// let t = n.tick();
/// assert_eq!(t.output.status.fault, Some(StepFault::InvalidState));
/// assert_eq!(n.stats().sensor_errors, 1);
/// ```
pub trait Sensor<const N: usize> {
    /// Why a read failed.
    type Error;
    /// One sample of the state.
    ///
    /// ```
    /// use agent_node::Sensor;
    /// // Position from an encoder count, velocity from a tachometer; a dead encoder is an error.
    /// struct Encoder { count: Option<i32>, rpm: f32 }
    /// impl Sensor<2> for Encoder {
    ///     type Error = &'static str;
    ///     fn read(&mut self) -> Result<[f32; 2], Self::Error> {
    ///         let c = self.count.ok_or("encoder silent")?;
    ///         Ok([c as f32 / 4096.0, self.rpm / 60.0])
    ///     }
    /// }
    /// assert_eq!(Encoder { count: Some(2048), rpm: 60.0 }.read(), Ok([0.5, 1.0]));
    /// assert!(Encoder { count: None, rpm: 0.0 }.read().is_err());
    /// ```
    fn read(&mut self) -> Result<[f32; N], Self::Error>;
}

/// The agent's actuators: the `M` quantized commands `q_{i,l}`.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// // Each tick writes the quantized commands q of the step to the actuators.
/// let mut n = node();
/// let t = n.tick();
/// assert_eq!(n.actuator().0, t.output.q);
/// ```
pub trait Actuator<const M: usize> {
    /// Why a write failed.
    type Error;
    /// Apply the commands until the next write.
    ///
    /// ```
    /// use agent_node::Actuator;
    /// // A PWM duty in per mille from the quantized command, refused beyond full scale.
    /// struct Pwm(u16);
    /// impl Actuator<1> for Pwm {
    ///     type Error = ();
    ///     fn write(&mut self, q: &[f32; 1]) -> Result<(), ()> {
    ///         if !(0.0..=1.0).contains(&q[0]) { return Err(()); }
    ///         self.0 = (q[0] * 1000.0) as u16;
    ///         Ok(())
    ///     }
    /// }
    /// let mut p = Pwm(0);
    /// assert_eq!(p.write(&[0.5]), Ok(()));
    /// assert_eq!(p.0, 500);
    /// assert!(p.write(&[2.0]).is_err());
    /// ```
    fn write(&mut self, q: &[f32; M]) -> Result<(), Self::Error>;
}

/// The node's settings apart from the controller's.
///
/// ```
/// use agent_node::{IdPlan, NodeConfig, SupervisorConfig};
/// // Agent 4 of the paper's graph hears agents 1 and 3; a value older than 2.5 ms is stale.
/// let cfg = NodeConfig { heartbeat_period_us: 100_000, ..NodeConfig::new(4, [1, 3], 2_500) };
/// assert_eq!((cfg.agent, cfg.neighbours), (4, [1, 3]));
/// assert_eq!(cfg.ids, IdPlan::DEFAULT);
/// assert_eq!(cfg.supervisor, SupervisorConfig::OFF);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeConfig<const K: usize> {
    /// This agent's number `i`, its node id (`1..=ids.agents()`); its value frames carry
    /// identifier `ids.value_base() + i`.
    pub agent: u8,
    /// The agents this one hears (`a_ik = 1`), in the order the controller expects; the first
    /// `neighbour_count` entries are used (the controller config's `neighbour_count`).
    pub neighbours: [u8; K],
    /// A value older than this is passed to the controller as `Stale` (µs, > 0).
    pub stale_timeout_us: u64,
    /// Where the value frames and heartbeats sit ([`IdPlan::DEFAULT`] unless moved).
    pub ids: IdPlan,
    /// Heartbeat period (µs); 0: no heartbeat. Needs heartbeat identifiers in `ids`.
    pub heartbeat_period_us: u64,
    /// Safe-state supervision ([`SupervisorConfig::OFF`]: none).
    pub supervisor: SupervisorConfig,
}

impl<const K: usize> NodeConfig<K> {
    /// Agent `agent` hearing `neighbours` with the stale timeout (µs), in the default
    /// identifier plan, without heartbeat or supervision.
    ///
    /// ```
    /// use agent_node::{IdPlan, NodeConfig};
    /// let cfg = NodeConfig::new(1, [], 2_500); // agent 1: the leader only
    /// assert_eq!((cfg.agent, cfg.stale_timeout_us, cfg.heartbeat_period_us), (1, 2_500, 0));
    /// assert_eq!(cfg.ids.value_id(agent_node::wire::Source::Agent(1)), Some(0x102));
    /// ```
    #[must_use]
    pub const fn new(agent: u8, neighbours: [u8; K], stale_timeout_us: u64) -> Self {
        Self {
            agent,
            neighbours,
            stale_timeout_us,
            ids: IdPlan::DEFAULT,
            heartbeat_period_us: 0,
            supervisor: SupervisorConfig::OFF,
        }
    }

    /// What the CANopen parameter store keeps of this configuration.
    ///
    /// ```
    /// use agent_node::NodeConfig;
    /// let cfg = NodeConfig::new(4, [1, 3], 2_500);
    /// let id = cfg.identity();
    /// assert_eq!((id.agent, id.neighbours, id.stale_timeout_us), (4, &[1u8, 3][..], 2_500));
    /// ```
    #[must_use]
    pub fn identity(&self) -> NodeIdentity<'_> {
        NodeIdentity {
            agent: self.agent,
            ids: self.ids,
            neighbours: &self.neighbours,
            stale_timeout_us: self.stale_timeout_us,
            heartbeat_period_us: self.heartbeat_period_us,
            supervisor: self.supervisor,
        }
    }

    /// Take the node-ID, graph row and identifier plan of a CANopen device's `store` (as
    /// written or loaded; a node applies them at its next reset communication) into this
    /// configuration and `controller`: what a board builds its acceptance filters from at boot.
    /// `false`, and nothing changed, when the row does not fit the capacity `K`.
    ///
    /// ```
    /// # mod hw { include!("canopen/doctest_device.rs"); }
    /// # use hw::*;
    /// # let dev = device();
    /// // device(): agent 2 hearing agent 1 and the leader.
    /// let mut cfg = NodeConfig::new(9, [0], 2_500);
    /// let mut ctrl = ControllerConfig::<2>::default();
    /// assert!(cfg.graph_from(&dev.store, &mut ctrl));
    /// assert_eq!((cfg.agent, cfg.neighbours), (2, [1]));
    /// assert_eq!((ctrl.neighbour_count, ctrl.pinned), (1, true));
    /// // A row of one does not fit a node without room for neighbours: nothing changes.
    /// let mut none = NodeConfig::new(9, [], 2_500);
    /// assert!(!none.graph_from(&dev.store, &mut ctrl));
    /// assert_eq!(none.agent, 9);
    /// ```
    #[cfg(feature = "canopen")]
    pub fn graph_from<const N: usize>(
        &mut self,
        store: &ParamStore<N>,
        controller: &mut ControllerConfig<N>,
    ) -> bool {
        let count = store.sections.agent.neighbour_count;
        let Some(row) = store.node.neighbours.get(..count).filter(|_| count <= K) else {
            return false;
        };
        self.neighbours = [0; K];
        for (d, s) in self.neighbours.iter_mut().zip(row) {
            *d = *s;
        }
        self.agent = store.node.pending_node_id;
        self.ids = store.node.ids;
        controller.neighbour_count = count;
        controller.pinned = store.sections.agent.pinned;
        true
    }

    /// The checks [`Node::new`] makes of the node's own settings with the first
    /// `neighbour_count` neighbours (beside the supervision's, `Supervisor::new`): an agent
    /// number of the identifier plan, a stale timeout, heartbeat identifiers for a heartbeat,
    /// and a graph row of distinct agents of the plan other than itself, within the capacity
    /// `K`. The CANopen device checks a row, a node-ID or a plan written over SDO with it too.
    ///
    /// ```
    /// use agent_node::NodeConfig;
    /// assert!(NodeConfig::new(2, [1, 3], 2_500).check(2).is_ok());
    /// assert!(NodeConfig::new(2, [1, 2], 2_500).check(2).is_err()); // hears itself
    /// assert!(NodeConfig::new(2, [1, 1], 2_500).check(2).is_err()); // twice the same agent
    /// assert!(NodeConfig::new(2, [1, 1], 2_500).check(1).is_ok()); // only the first counts
    /// ```
    pub fn check(&self, neighbour_count: usize) -> Result<(), NodeError> {
        Own {
            agent: self.agent,
            stale_timeout_us: self.stale_timeout_us,
            ids: &self.ids,
            heartbeat_period_us: self.heartbeat_period_us,
        }
        .check(&self.neighbours, neighbour_count)
    }
}

/// Counters of one node since it started.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use agent_node::wire::{encode, Source};
/// let mut n = node();
/// let (f, _) = encode::<CanFrame>(Source::Agent(1), 0.5, 0).unwrap();
/// n.can_mut().rx.push_back(f);
/// n.can_mut().rx.push_back(f); // the same sequence counter again: dropped
/// n.tick();
/// let st = n.stats();
/// assert_eq!((st.ticks, st.frames_rx, st.accepted, st.repeated, st.tx_queued), (1, 2, 1, 1, 1));
/// ```
///
/// `#[non_exhaustive]`: the node gains counters; outside this crate it is read field by field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct NodeStats {
    /// Calls of [`Node::tick`].
    pub ticks: u32,
    /// Frames taken from the CAN controller.
    pub frames_rx: u32,
    /// Frames accepted into a neighbour or leader slot.
    pub accepted: u32,
    /// Malformed frames, per kind.
    pub malformed: DecodeStats,
    /// Well-formed frames from agents this node does not hear (or the leader, if not pinned).
    pub ignored: u32,
    /// Well-formed frames carrying this node's own identifier (a misconfigured peer).
    pub own_id: u32,
    /// Frames dropped because their counter repeated the last accepted one.
    pub repeated: u32,
    /// Frames dropped because their counter was behind the last accepted one.
    pub out_of_order: u32,
    /// Sequence counters skipped between accepted frames.
    pub seq_gaps: u32,
    /// Frames flagged `NO_VALUE`.
    pub no_value: u32,
    /// Frames flagged `SATURATED` (received).
    pub saturated_rx: u32,
    /// Own values clamped to the wire range before sending.
    pub saturated_tx: u32,
    /// Receive errors reported by the CAN controller.
    pub rx_errors: u32,
    /// Neighbour links passed as `Stale`, summed over samples.
    pub stale_samples: u32,
    /// Neighbour links passed as `Missing`, summed over samples.
    pub missing_samples: u32,
    /// Samples where the leader link (pinned agents) was stale or missing.
    pub leader_degraded_samples: u32,
    /// Samples where the controller held its command ([`StepFault`]).
    pub faults: u32,
    /// Sensor read errors.
    pub sensor_errors: u32,
    /// Actuator write errors.
    pub actuator_errors: u32,
    /// Frames handed to the CAN controller.
    pub tx_queued: u32,
    /// Transmissions that replaced a frame still pending in the controller.
    pub tx_replaced: u32,
    /// Transmissions refused because every mailbox was full.
    pub tx_busy: u32,
    /// Transmissions refused with an error (e.g. bus-off).
    pub tx_errors: u32,
    /// Deadline overruns: samples skipped between ticks, and those the board reported.
    pub overruns: u32,
    /// Times the node entered its safe state.
    pub safe_state_entries: u32,
    /// Heartbeats handed to the CAN controller.
    pub heartbeats_tx: u32,
    /// Well-formed heartbeats of other nodes received.
    pub heartbeats_rx: u32,
}

/// What happened to this sample's frame.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use agent_node::TxOutcome;
/// let mut n = node();
/// assert_eq!(n.tick().tx, TxOutcome::Queued);
/// assert_eq!(n.can().tx.len(), 1); // y_2 = x_{2,1} broadcast once
/// ```
///
/// `#[non_exhaustive]`: a new way for a frame to stay unsent is a new outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum TxOutcome {
    /// Queued in the CAN controller.
    Queued,
    /// Queued, replacing a frame that was still pending.
    Replaced,
    /// Not sent: every mailbox full.
    Busy,
    /// Not sent: the CAN controller reported an error.
    Error(ErrorKind),
    /// Not sent: the frame type refused the frame.
    EncodeFailed,
    /// Not sent: the node's CANopen device is not operational (its outputs are off).
    Disabled,
}

/// The result of one [`Node::tick`].
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use agent_node::{NodeState, Tick};
/// let mut n = node();
/// n.clock_mut().0 = 5;
/// let t: Tick<2, 2> = n.tick();
/// assert_eq!((t.now_us, t.state), (5, NodeState::Operational));
/// assert!(t.output.u.iter().all(|u| u.is_finite()));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick<const N: usize, const M: usize> {
    /// Clock reading at the sample.
    pub now_us: u64,
    /// The controller's output (commands, errors, link report).
    pub output: StepOutput<N, M>,
    /// The fate of the broadcast frame.
    pub tx: TxOutcome,
    /// The node's state after the tick.
    pub state: NodeState,
}

/// Latest value of one link.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Slot {
    agent: u8,
    /// Latest valid value and its receive time.
    value: Option<(f32, u64)>,
    /// Latest accepted sequence counter and its receive time.
    seq: Option<(u8, u64)>,
    /// The link was reported stale (for logging transitions once).
    stale: bool,
}

impl Slot {
    fn link(&self, now: u64, timeout: u64) -> Link {
        match self.value {
            None => Link::Missing,
            Some((v, t)) if now.saturating_sub(t) <= timeout => Link::Fresh(v),
            Some((v, _)) => Link::Stale(v),
        }
    }

    /// Accept or reject a message; returns `true` if accepted.
    fn update(&mut self, m: &wire::Message, now: u64, timeout: u64, st: &mut NodeStats) -> bool {
        if let Some((last, t)) = self.seq {
            if now.saturating_sub(t) <= timeout {
                match wire::seq_check(last, m.seq) {
                    SeqCheck::Repeated => {
                        st.repeated = st.repeated.saturating_add(1);
                        return false;
                    }
                    SeqCheck::Older => {
                        st.out_of_order = st.out_of_order.saturating_add(1);
                        return false;
                    }
                    SeqCheck::Newer { skipped } => {
                        st.seq_gaps = st.seq_gaps.saturating_add(u32::from(skipped));
                    }
                }
            }
        }
        self.seq = Some((m.seq, now));
        if m.saturated {
            st.saturated_rx = st.saturated_rx.saturating_add(1);
        }
        match m.y {
            Some(y) => self.value = Some((y, now)),
            None => st.no_value = st.no_value.saturating_add(1),
        }
        st.accepted = st.accepted.saturating_add(1);
        true
    }
}

/// One follower agent's node: the controller between its CAN controller, clock, sensors and
/// actuators. `N` state order, `M` actuators, `K` neighbour capacity.
///
/// The examples on `Node` run over mocked hardware (`src/doctest_node.rs`, hidden in them):
/// `node()` is agent 2 of Example 1, hearing agent 1 and the leader, stale after 2.5 ms; its CAN
/// controller keeps the frames it sends in `tx` and hands out those pushed to `rx`; the clock
/// (`.0`, µs), the sensor's state and the actuator's command are plain fields.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use agent_node::wire::{decode, encode, Source};
/// use controller_core::Link;
/// // Agent 2 hears agent 1's value 0.5, runs the law and broadcasts its own output y_2 = 0.1.
/// let mut n = node();
/// let (f, _) = encode::<CanFrame>(Source::Agent(1), 0.5, 0).unwrap();
/// n.can_mut().rx.push_back(f);
/// n.clock_mut().0 = 1_000;
/// let t = n.tick();
/// assert_eq!(n.neighbour_link(0, 1_000), Some(Link::Fresh(0.5)));
/// assert_eq!(t.output.status.links.missing_neighbours, 0);
/// let sent = decode(&n.can().tx[0]).unwrap();
/// assert_eq!(sent.source, Source::Agent(2));
/// assert!((sent.y.unwrap() - 0.1).abs() <= 1.0 / 65536.0); // Q7.16 on the wire
/// ```
pub struct Node<C, Clk, S, A, const N: usize, const M: usize, const K: usize> {
    can: C,
    clock: Clk,
    sensor: S,
    actuator: A,
    controller: Controller<N, M, K>,
    agent: u8,
    pinned: bool,
    timeout_us: u64,
    slots: [Slot; K],
    count: usize,
    leader: Slot,
    seq: u8,
    stats: NodeStats,
    last_fault: Option<StepFault>,
    sensor_failed: bool,
    actuator_failed: bool,
    tx_failed: bool,
    ids: IdPlan,
    supervisor: Supervisor,
    heartbeat_period_us: u64,
    next_heartbeat_us: Option<u64>,
    boot_count: u16,
    /// Sample period `h` (µs), for overruns.
    period_us: u64,
    first_tick_us: Option<u64>,
    last_tick_us: Option<u64>,
    /// Overruns the board reported since the last tick.
    reported_overruns: u32,
    /// The command written at the last tick.
    applied: [f32; M],
    fault_pending: bool,
    /// Some source has a loss timeout.
    supervised: bool,
    /// The last finite own output `y_i` and its clock (the stop profile's velocity).
    last_y: Option<(f32, u64)>,
    /// The reference of a closed-loop safe state.
    safe_reference: SafeReference,
    /// The controller was frozen during the present `Safe` stay (resume on exit).
    frozen_in_safe: bool,
    /// The CiA 301 device (`Node::enable_canopen`); `None`: outputs always enabled.
    #[cfg(feature = "canopen")]
    canopen: Option<CanOpen<N>>,
}

/// The node's CANopen device and what the node keeps for it.
#[cfg(feature = "canopen")]
struct CanOpen<const N: usize> {
    device: Device<N>,
    /// A parameter was written (or restored, or loaded) since the controller was built: the
    /// next NMT start rebuilds it from the object dictionary.
    dirty: bool,
    /// Requests for the application: store, restore, reset node.
    requests: u8,
    /// When the last overrun EMCY went out (they are sent at most once per
    /// [`OVERRUN_EMCY_INHIBIT_US`], carrying the running count).
    last_overrun_emcy_us: Option<u64>,
    /// A device frame held for the next flush: the CAN controller had a frame of the same
    /// identifier pending ([`Node::flush_canopen`]).
    held: Option<CoFrame>,
    /// [`Node::adoptions`].
    adoptions: u16,
}

/// Something the node's CANopen device asks of the application that runs the node.
///
/// ```
/// # mod hw { include!("doctest_node.rs"); }
/// # use hw::*;
/// use agent_node::node::CanOpenRequest;
/// use agent_node::canopen::Identity;
/// // An SDO write of "save" to 0x1010:1 asks the application to persist the parameters.
/// let mut n = node();
/// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
/// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
/// assert_eq!(n.canopen_mut().unwrap().write(0x1010, 1, b"save"), Ok(()));
/// n.tick();
/// assert_eq!(n.take_canopen_request(), Some(CanOpenRequest::Store));
/// assert_eq!(n.take_canopen_request(), None);
/// ```
#[cfg(feature = "canopen")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanOpenRequest {
    /// `0x1010` "save": persist [`Device::save`]'s bytes (flash, a file).
    Store,
    /// `0x1011` "load": forget the persisted copy.
    Restore,
    /// NMT reset node: load the persisted copy again ([`Device::load`]).
    ResetNode,
}

#[cfg(feature = "canopen")]
impl CanOpenRequest {
    const fn bit(self) -> u8 {
        match self {
            Self::Store => 1,
            Self::Restore => 2,
            Self::ResetNode => 4,
        }
    }
}

/// The neighbour slots of the first `count` agents of `neighbours` (checked by
/// [`NodeConfig::check`]), nothing heard yet.
fn slots_of<const K: usize>(neighbours: &[u8], count: usize) -> [Slot; K] {
    let mut slots = [Slot::default(); K];
    for (slot, &a) in slots.iter_mut().zip(neighbours.iter().take(count)) {
        slot.agent = a;
    }
    slots
}

/// `controller` with the rate-limited re-entry a closed-loop safe state needs: a controller
/// without `[safety]` gets the re-entry alone (no limits) at `sup.reentry_rate`, when some
/// source is supervised (module `crate::supervisor`, *Safe policies*).
fn with_reentry<const N: usize>(
    controller: &ControllerConfig<N>,
    sup: &SupervisorConfig,
) -> ControllerConfig<N> {
    let mut c = *controller;
    if sup.supervises_any() && sup.policy.is_closed_loop() && c.safety.is_none() {
        c.safety = Some(SafetyConfig {
            u_max: None,
            du_max: None,
            recovery_rate: sup.reentry_rate,
            ..SafetyConfig::default()
        });
    }
    c
}

/// What a closed-loop safe state tracks (`crate::supervisor`, *Safe policies*).
#[derive(Debug, Clone, Copy, PartialEq)]
enum SafeReference {
    /// [`SafePolicy::HoldPosition`]: the leader's last valid value, if it was ever heard.
    Frozen(Option<f32>),
    /// [`SafePolicy::Stop`].
    Stop(StopProfile),
}

impl<C, Clk, S, A, const N: usize, const M: usize, const K: usize> Node<C, Clk, S, A, N, M, K>
where
    C: Can,
    Clk: Clock,
    S: Sensor<N>,
    A: Actuator<M>,
{
    /// Validate the configuration (logging the culprit on failure) and build the node.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::NodeError;
    /// assert_eq!(node().agent(), 2);
    /// let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// let zero = NodeConfig::new(2, [1], 0); // a stale timeout of 0
    /// let r = Node::new(&zero, &ctrl, Bus::default(), Time(0), State(Ok([0.0; 2])), Drive::default());
    /// let r: Result<Node<_, _, _, _, 2, 2, 1>, _> = r;
    /// assert_eq!(r.err(), Some(NodeError::ZeroTimeout));
    /// ```
    pub fn new(
        cfg: &NodeConfig<K>,
        controller: &ControllerConfig<N>,
        can: C,
        clock: Clk,
        sensor: S,
        actuator: A,
    ) -> Result<Self, NodeError> {
        let r = Self::build(cfg, controller, can, clock, sensor, actuator);
        if let Err(e) = &r {
            error!("agent {}: configuration rejected: {:?}", cfg.agent, e);
        }
        r
    }

    fn build(
        cfg: &NodeConfig<K>,
        controller: &ControllerConfig<N>,
        can: C,
        clock: Clk,
        sensor: S,
        actuator: A,
    ) -> Result<Self, NodeError> {
        let count = controller.neighbour_count;
        cfg.check(count)?;
        let supervisor = Supervisor::new(&cfg.supervisor)?;
        let slots = slots_of(&cfg.neighbours, count);
        let cfg_pinned = controller.pinned;
        let period_us = micros_from_secs(controller.h);
        let controller = Controller::new(&with_reentry(controller, &cfg.supervisor))?;
        Ok(Self {
            can,
            clock,
            sensor,
            actuator,
            pinned: cfg_pinned,
            controller,
            agent: cfg.agent,
            timeout_us: cfg.stale_timeout_us,
            slots,
            count,
            leader: Slot::default(),
            seq: 0,
            stats: NodeStats::default(),
            last_fault: None,
            sensor_failed: false,
            actuator_failed: false,
            tx_failed: false,
            ids: cfg.ids,
            supervisor,
            heartbeat_period_us: cfg.heartbeat_period_us,
            next_heartbeat_us: None,
            boot_count: 0,
            period_us,
            first_tick_us: None,
            reported_overruns: 0,
            last_tick_us: None,
            applied: [0.0; M],
            fault_pending: false,
            supervised: cfg.supervisor.supervises_any(),
            last_y: None,
            safe_reference: SafeReference::Frozen(None),
            frozen_in_safe: false,
            #[cfg(feature = "canopen")]
            canopen: None,
        })
    }

    /// The node's state.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::NodeState;
    /// let mut n = node();
    /// assert_eq!(n.state(), NodeState::Boot);
    /// n.tick(); // nothing supervised: operational at the first tick
    /// assert_eq!(n.state(), NodeState::Operational);
    /// ```
    pub fn state(&self) -> NodeState {
        self.supervisor.state()
    }

    /// The supervisor (state, lost sources, entries).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.tick();
    /// assert!(n.supervisor().lost().is_empty());
    /// assert_eq!(n.supervisor().safe_entries(), 0);
    /// ```
    pub fn supervisor(&self) -> &Supervisor {
        &self.supervisor
    }

    /// The identifier plan.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::IdPlan;
    /// assert_eq!(*node().ids(), IdPlan::DEFAULT);
    /// ```
    pub fn ids(&self) -> &IdPlan {
        &self.ids
    }

    /// The board's reset or boot counter, sent in the heartbeat.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::wire::Heartbeat;
    /// // The boot counter travels in the heartbeat (bytes 2–3).
    /// let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// let cfg = NodeConfig { heartbeat_period_us: 1_000, ..NodeConfig::new(2, [1], 2_500) };
    /// let mut n: Node<_, _, _, _, 2, 2, 1> =
    ///     Node::new(&cfg, &ctrl, Bus::default(), Time(0), State(Ok([0.0; 2])), Drive::default()).unwrap();
    /// n.set_boot_count(7);
    /// n.clock_mut().0 = 1_000; // agent 2's heartbeat goes out one sample after the first tick
    /// n.tick();
    /// n.clock_mut().0 = 2_000;
    /// n.tick();
    /// let hb = n.can().tx.iter().find(|f| f.raw_id() == 0x782).unwrap();
    /// let bytes: [u8; 8] = embedded_can::Frame::data(hb).try_into().unwrap();
    /// assert_eq!(Heartbeat::from_bytes(&bytes).unwrap().boot_count, 7);
    /// ```
    pub fn set_boot_count(&mut self, count: u16) {
        self.boot_count = count;
    }

    /// The board saw a sample miss its slot: a release of its sample timer found the step still
    /// running (one call per such release). Counted at once; the samples the next tick finds
    /// skipped are not counted again (see the module docs).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.record_overrun(); // the sample timer found the step still running
    /// assert_eq!(n.stats().overruns, 1);
    /// ```
    pub fn record_overrun(&mut self) {
        self.stats.overruns = self.stats.overruns.saturating_add(1);
        self.reported_overruns = self.reported_overruns.saturating_add(1);
        self.overrun_emcy();
    }

    /// The board saw a fault of its own — the CAN controller recovered from bus-off
    /// ([`Fault::BusOff`]), received frames were lost ([`Fault::RxOverflow`]), a watchdog
    /// reset found at boot — : an EMCY with `count` (e.g. occurrences since start) when the node
    /// is a CANopen device, sent at once; nothing otherwise. Unlike a change through
    /// `Node::canopen_mut`, the configuration is left as it is.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::Fault;
    /// // Without a CANopen device nothing is sent; with one, an EMCY with the CiA 301 code.
    /// let mut n = node();
    /// n.report_fault(Fault::BusOff, 1);
    /// assert!(n.can().tx.is_empty());
    /// # #[cfg(feature = "canopen")] {
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, agent_node::canopen::Identity::default(), true, 0).unwrap();
    /// n.service(); // boot-up message
    /// n.report_fault(Fault::BusOff, 1);
    /// let emcy = n.can().tx.last().unwrap();
    /// assert_eq!(emcy.raw_id(), 0x80 + 2);
    /// assert_eq!(&embedded_can::Frame::data(emcy)[..2], &0x8140u16.to_le_bytes());
    /// # }
    /// ```
    pub fn report_fault(&mut self, f: Fault, count: u32) {
        self.emcy(f, count);
        self.flush_canopen();
    }

    /// The board found a fault it cannot recover from: the node latches `Fault` at the next
    /// tick (outputs zero, heartbeat `fault`) until it is restarted.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::NodeState;
    /// let mut n = node();
    /// n.enter_fault();
    /// let t = n.tick();
    /// assert_eq!(t.state, NodeState::Fault);
    /// assert_eq!(n.actuator().0, [0.0, 0.0]); // outputs zero until restarted
    /// ```
    pub fn enter_fault(&mut self) {
        self.fault_pending = true;
    }

    /// This agent's number.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// assert_eq!(node().agent(), 2);
    /// ```
    pub fn agent(&self) -> u8 {
        self.agent
    }

    /// Counters since start.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.tick();
    /// n.tick();
    /// assert_eq!(n.stats().ticks, 2);
    /// assert_eq!(n.stats().tx_queued, 2);
    /// ```
    pub fn stats(&self) -> &NodeStats {
        &self.stats
    }

    /// The controller (read-only: state, parameters).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.tick();
    /// assert_eq!(n.controller().state().k, 1); // one sample of the law taken
    /// ```
    pub fn controller(&self) -> &Controller<N, M, K> {
        &self.controller
    }

    /// The actuators (read-only: the commands applied).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// let q = n.tick().output.q;
    /// assert_eq!(n.actuator().0, q);
    /// ```
    pub fn actuator(&self) -> &A {
        &self.actuator
    }

    /// The CAN controller (read-only).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// assert!(n.can().tx.is_empty());
    /// n.tick();
    /// assert_eq!(n.can().tx.len(), 1);
    /// ```
    pub fn can(&self) -> &C {
        &self.can
    }

    /// The CAN controller (the host harness moves frames through it).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::wire::{encode, Source};
    /// let mut n = node();
    /// let (f, _) = encode::<CanFrame>(Source::Leader, 0.25, 3).unwrap();
    /// n.can_mut().rx.push_back(f);
    /// n.poll_rx();
    /// assert_eq!(n.stats().accepted, 1);
    /// ```
    pub fn can_mut(&mut self) -> &mut C {
        &mut self.can
    }

    /// The clock.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.clock_mut().0 = 42;
    /// assert_eq!(n.tick().now_us, 42);
    /// ```
    pub fn clock_mut(&mut self) -> &mut Clk {
        &mut self.clock
    }

    /// The sensors.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.sensor_mut().0 = Ok([0.75, 0.0]);
    /// n.tick();
    /// let sent = agent_node::wire::decode(&n.can().tx[0]).unwrap();
    /// assert_eq!(sent.y, Some(0.75)); // y_2 = x_{2,1}
    /// ```
    pub fn sensor_mut(&mut self) -> &mut S {
        &mut self.sensor
    }

    /// The actuators.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let mut n = node();
    /// n.actuator_mut().0 = [9.0; 2];
    /// n.tick();
    /// assert_ne!(n.actuator().0, [9.0; 2]); // overwritten by the tick's command
    /// ```
    pub fn actuator_mut(&mut self) -> &mut A {
        &mut self.actuator
    }

    /// The link the controller would get for neighbour slot `k` at `now_us` (`None` if `k` is
    /// not a configured neighbour).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::wire::{encode, Source};
    /// use controller_core::Link;
    /// let mut n = node();
    /// assert_eq!(n.neighbour_link(0, 0), Some(Link::Missing)); // never heard
    /// let (f, _) = encode::<CanFrame>(Source::Agent(1), 0.5, 0).unwrap();
    /// n.can_mut().rx.push_back(f);
    /// n.poll_rx(); // received at t = 0
    /// assert_eq!(n.neighbour_link(0, 2_500), Some(Link::Fresh(0.5)));
    /// assert_eq!(n.neighbour_link(0, 2_501), Some(Link::Stale(0.5))); // held, counted stale
    /// assert_eq!(n.neighbour_link(1, 0), None); // one neighbour only
    /// ```
    pub fn neighbour_link(&self, k: usize, now_us: u64) -> Option<Link> {
        self.slots
            .get(..self.count)?
            .get(k)
            .map(|s| s.link(now_us, self.timeout_us))
    }

    /// The agent heard in neighbour slot `k`.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// let n = node();
    /// assert_eq!(n.neighbour_agent(0), Some(1));
    /// assert_eq!(n.neighbour_agent(1), None);
    /// ```
    pub fn neighbour_agent(&self, k: usize) -> Option<u8> {
        self.slots.get(..self.count)?.get(k).map(|s| s.agent)
    }

    /// The agent receives the leader (`r_i = 1`).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// assert!(node().is_pinned()); // r_2 = 1: the default configuration hears the leader
    /// ```
    pub fn is_pinned(&self) -> bool {
        self.pinned
    }

    /// Receive time (µs) of the value held for neighbour slot `k`, if any.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::wire::{encode, Source};
    /// let mut n = node();
    /// assert_eq!(n.neighbour_rx_time(0), None);
    /// let (f, _) = encode::<CanFrame>(Source::Agent(1), 0.5, 0).unwrap();
    /// n.can_mut().rx.push_back(f);
    /// n.clock_mut().0 = 700;
    /// n.poll_rx();
    /// assert_eq!(n.neighbour_rx_time(0), Some(700));
    /// ```
    pub fn neighbour_rx_time(&self, k: usize) -> Option<u64> {
        self.slots.get(..self.count)?.get(k)?.value.map(|(_, t)| t)
    }

    /// Drain up to [`MAX_RX_PER_POLL`] frames from the CAN controller, time-stamped with the
    /// clock now. Call from the CAN receive interrupt; [`Node::tick`] calls it too.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::wire::{encode, Source};
    /// let mut n = node();
    /// let (f, _) = encode::<CanFrame>(Source::Agent(9), 0.5, 0).unwrap();
    /// n.can_mut().rx.push_back(f); // agent 9 is not a neighbour of agent 2
    /// n.poll_rx();
    /// assert_eq!((n.stats().frames_rx, n.stats().ignored), (1, 1));
    /// assert!(n.can().rx.is_empty());
    /// ```
    pub fn poll_rx(&mut self) {
        let now = self.clock.now_us();
        self.poll_rx_at(now);
        self.flush_canopen();
    }

    /// A tick while the CANopen device is not operational: actuators zero, no value frame,
    /// the controller not advanced (the tick reports the error a copy of it computes).
    fn disabled_tick(&mut self, now: u64) -> Tick<N, M> {
        let x = self.sensor.read().unwrap_or([f32::NAN; N]);
        let missing = [Link::Missing; K];
        let neighbours = missing.get(..self.count).unwrap_or(&[]);
        let output = self.frozen_output(NodeState::Fault, now, &x, neighbours, Link::Missing);
        if self.actuator.write(&output.q).is_err() {
            self.stats.actuator_errors = self.stats.actuator_errors.saturating_add(1);
        }
        self.applied = output.q;
        self.flush_canopen();
        self.last_tick_us = Some(now);
        Tick {
            now_us: now,
            output,
            tx: TxOutcome::Disabled,
            state: self.supervisor.state(),
        }
    }

    fn poll_rx_at(&mut self, now: u64) {
        for _ in 0..MAX_RX_PER_POLL {
            match self.can.receive() {
                Ok(frame) => {
                    self.stats.frames_rx = self.stats.frames_rx.saturating_add(1);
                    self.on_frame(&frame, now);
                }
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => {
                    self.stats.rx_errors = self.stats.rx_errors.saturating_add(1);
                }
            }
        }
    }

    fn on_frame(&mut self, frame: &C::Frame, now: u64) {
        if self.device_frame(frame, now) {
            return;
        }
        let m = match wire::decode_in(&self.ids, frame) {
            Ok(Decoded::Value(m)) => m,
            Ok(Decoded::Heartbeat { agent, .. }) if agent == self.agent => {
                self.stats.own_id = self.stats.own_id.saturating_add(1);
                warn!("agent {}: received a heartbeat with its own id", agent);
                return;
            }
            Ok(Decoded::Heartbeat { .. }) => {
                self.stats.heartbeats_rx = self.stats.heartbeats_rx.saturating_add(1);
                return;
            }
            Err(e) => {
                self.stats.malformed.record(e);
                if let WireError::UnknownId(id) = e {
                    trace!("agent {}: frame with unknown id {} dropped", self.agent, id);
                } else {
                    trace!("agent {}: malformed frame dropped: {:?}", self.agent, e);
                }
                return;
            }
        };
        let timeout = self.timeout_us;
        let slot = match m.source {
            Source::Leader if self.pinned || self.supervisor.watches_leader() => {
                Some(&mut self.leader)
            }
            Source::Leader => None,
            Source::Agent(a) if a == self.agent => {
                self.stats.own_id = self.stats.own_id.saturating_add(1);
                warn!("agent {}: received a frame with its own id", a);
                return;
            }
            Source::Agent(a) => self.slots[..self.count].iter_mut().find(|s| s.agent == a),
        };
        match slot {
            Some(s) => {
                s.update(&m, now, timeout, &mut self.stats);
            }
            None => self.stats.ignored = self.stats.ignored.saturating_add(1),
        }
    }

    /// One sample: sense, drain, freshness, supervise, step, actuate, broadcast (see the
    /// module docs).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::TxOutcome;
    /// let mut n = node();
    /// let t = n.tick();
    /// assert_eq!(t.tx, TxOutcome::Queued);
    /// assert_eq!(t.output.q, n.actuator().0);
    /// assert_eq!(t.output.status.links.missing_neighbours, 1); // agent 1 not heard yet
    /// ```
    pub fn tick(&mut self) -> Tick<N, M> {
        let now = self.clock.now_us();
        self.stats.ticks = self.stats.ticks.saturating_add(1);
        if !self.canopen_tick(now) {
            return self.disabled_tick(now);
        }
        self.count_overruns(now);
        let first = *self.first_tick_us.get_or_insert(now);
        let x = match self.sensor.read() {
            Ok(x) => {
                if self.sensor_failed {
                    info!("agent {}: sensor read ok again", self.agent);
                    self.emcy_clear(Fault::SensorInvalid);
                }
                self.sensor_failed = false;
                x
            }
            Err(_) => {
                self.stats.sensor_errors = self.stats.sensor_errors.saturating_add(1);
                if !self.sensor_failed {
                    warn!("agent {}: sensor read failed", self.agent);
                    self.emcy(Fault::SensorInvalid, self.stats.sensor_errors);
                }
                self.sensor_failed = true;
                [f32::NAN; N]
            }
        };
        self.poll_rx_at(now);

        let links = self.links(now);
        let leader = if self.pinned {
            let l = self.leader.link(now, self.timeout_us);
            self.log_leader(&l);
            l
        } else {
            Link::Missing
        };
        self.supervise(now, first, &x);
        let neighbours = links.get(..self.count).unwrap_or(&[]);
        let output = match self.supervisor.state() {
            NodeState::Boot | NodeState::Operational => {
                self.controller.step(&x, neighbours, leader)
            }
            NodeState::Safe if self.closed_loop_safe() => {
                self.safe_step(now, &x, neighbours, leader)
            }
            state => {
                self.frozen_in_safe |= state == NodeState::Safe;
                self.frozen_output(state, now, &x, neighbours, leader)
            }
        };
        self.log_fault(output.status.fault);

        match self.actuator.write(&output.q) {
            Ok(()) => self.actuator_failed = false,
            Err(_) => {
                self.stats.actuator_errors = self.stats.actuator_errors.saturating_add(1);
                if !self.actuator_failed {
                    warn!("agent {}: actuator write failed", self.agent);
                }
                self.actuator_failed = true;
            }
        }
        self.applied = output.q;

        if x[0].is_finite() {
            self.last_y = Some((x[0], now));
        }
        let tx = self.broadcast(x[0]);
        self.seq = self.seq.wrapping_add(1) % wire::SEQ_MODULUS;
        self.heartbeat(now, first);
        self.flush_canopen();
        self.last_tick_us = Some(now);
        Tick {
            now_us: now,
            output,
            tx,
            state: self.supervisor.state(),
        }
    }

    /// `Safe` with a closed-loop policy and a working sensor: the controller keeps stepping.
    fn closed_loop_safe(&self) -> bool {
        self.supervisor.policy_in_force().is_closed_loop()
    }

    /// One closed-loop safe step: the controller tracks the safe reference
    /// ([`SafeReference`]) instead of the live leader (and, for `Stop`, the neighbours).
    fn safe_step(
        &mut self,
        now: u64,
        x: &[f32; N],
        neighbours: &[Link],
        leader: Link,
    ) -> StepOutput<N, M> {
        match self.safe_reference {
            SafeReference::Frozen(frozen) => {
                let leader = match (self.pinned, frozen) {
                    (true, Some(v)) => Link::Stale(v),
                    _ => leader,
                };
                self.controller.step(x, neighbours, leader)
            }
            SafeReference::Stop(profile) => {
                let r = Link::Fresh(profile.at(now));
                let all = [r; K];
                let leader = if self.pinned { r } else { Link::Missing };
                self.controller
                    .step(x, all.get(..self.count).unwrap_or(&[]), leader)
            }
        }
    }

    /// `Safe` or `Fault`: the error a copy of the frozen controller computes, with the
    /// open-loop policy's command (zero in `Fault`). Out of line, so the copy's stack is used
    /// only there.
    #[inline(never)]
    fn frozen_output(
        &self,
        state: NodeState,
        now: u64,
        x: &[f32; N],
        neighbours: &[Link],
        leader: Link,
    ) -> StepOutput<N, M> {
        let mut frozen = self.controller;
        let mut o = frozen.step(x, neighbours, leader);
        let dt = self.last_tick_us.map_or(0, |t| now.saturating_sub(t));
        let q = match state {
            NodeState::Safe => safe_command(self.supervisor.policy_in_force(), &self.applied, dt),
            _ => [0.0; M],
        };
        o.u = q;
        o.q = q;
        o
    }

    /// Samples skipped since the last tick (more than 1.5 periods apart: every whole period
    /// beyond the first) that the board has not reported with [`Self::record_overrun`].
    fn count_overruns(&mut self, now: u64) {
        let reported = core::mem::take(&mut self.reported_overruns);
        let (Some(last), p) = (self.last_tick_us, self.period_us) else {
            return;
        };
        let gap = now.saturating_sub(last);
        if p > 0 && gap > p + p / 2 {
            let missed = u32::try_from((gap + p / 2) / p - 1).unwrap_or(u32::MAX);
            let unreported = missed.saturating_sub(reported);
            self.stats.overruns = self.stats.overruns.saturating_add(unreported);
            if unreported > 0 {
                self.overrun_emcy();
            }
        }
    }

    /// Evaluate the supervisor at `now` (first tick at `first`) and act on a transition; with
    /// nothing supervised only the first tick (`Boot → Operational`) and a fault are.
    fn supervise(&mut self, now: u64, first: u64, x: &[f32; N]) {
        if !self.supervised && !self.fault_pending && self.supervisor.state() != NodeState::Boot {
            return;
        }
        // A source whose consumed heartbeat is lost counts as silent for ever, whatever its
        // value frames (docs/NETWORK.md §12, *Heartbeat*).
        let age = |slot: &Slot, hb_lost: bool| {
            if hb_lost {
                u64::MAX
            } else {
                now.saturating_sub(slot.value.map_or(first, |(_, t)| t))
            }
        };
        let mut newest: Option<u64> = None;
        let mut oldest: Option<u64> = None;
        for s in self.slots.iter().take(self.count) {
            let a = age(s, self.heartbeat_lost(s.agent));
            newest = Some(newest.map_or(a, |n| n.min(a)));
            oldest = Some(oldest.map_or(a, |o| o.max(a)));
        }
        let obs = Observation {
            now_us: now,
            stale_timeout_us: self.timeout_us,
            leader_age_us: age(&self.leader, self.leader_heartbeat_lost()),
            newest_neighbour_age_us: newest,
            oldest_neighbour_age_us: oldest,
            sensor_ok: x.iter().all(|v| v.is_finite()),
        };
        let transition = if core::mem::take(&mut self.fault_pending) {
            self.supervisor.fault()
        } else {
            self.supervisor.update(&obs)
        };
        let Some(t) = transition else {
            return;
        };
        self.stats.safe_state_entries = self.supervisor.safe_entries();
        match t.to {
            NodeState::Safe => {
                self.enter_safe(now, x[0]);
                let lost = u8::from(t.lost.leader())
                    | u8::from(t.lost.neighbours()) << 1
                    | u8::from(t.lost.sensor()) << 2;
                self.emcy(Fault::SafeState(lost), self.stats.safe_state_entries);
                warn!(
                    "agent {}: safe state (lost: leader {}, neighbours {}, sensor {})",
                    self.agent,
                    t.lost.leader(),
                    t.lost.neighbours(),
                    t.lost.sensor()
                )
            }
            NodeState::Fault => {
                error!("agent {}: fault, outputs off", self.agent);
                self.emcy(Fault::Fault, 0);
            }
            NodeState::Operational if t.from == NodeState::Safe => {
                self.emcy_clear(Fault::SafeState(0));
                if core::mem::take(&mut self.frozen_in_safe) {
                    self.controller.resume(x[0], &self.applied);
                    info!(
                        "agent {}: operational again, controller resumed",
                        self.agent
                    );
                } else {
                    if let SafeReference::Stop(_) = self.safe_reference {
                        self.controller.reenter_links_from(x[0]);
                    }
                    info!("agent {}: operational again", self.agent);
                }
            }
            NodeState::Operational | NodeState::Boot => {
                debug!("agent {}: {}", self.agent, t.to.as_str());
            }
        }
    }

    /// Capture the safe reference on entering `Safe` at `now` with output `y`.
    fn enter_safe(&mut self, now: u64, y: f32) {
        self.frozen_in_safe = false;
        self.safe_reference = match self.supervisor.config().policy {
            SafePolicy::Stop { decel } => {
                let (y0, w) = match self.last_y {
                    Some((yp, tp)) if y.is_finite() && now > tp => {
                        (y, (y - yp) / ((now - tp) as f32 * 1e-6))
                    }
                    Some((yp, _)) if !y.is_finite() => (yp, 0.0),
                    _ => (y, 0.0),
                };
                SafeReference::Stop(StopProfile::new(y0, w, decel, now))
            }
            _ => SafeReference::Frozen(self.leader.value.map(|(v, _)| v)),
        };
    }

    /// The heartbeat, when due: every period, agent `i`'s first `(i − 1)` samples after the
    /// first tick (modulo the period), so the nodes' heartbeats do not share a sample.
    fn heartbeat(&mut self, now: u64, first: u64) {
        let period = self.heartbeat_period_us;
        if period == 0 {
            return;
        }
        let offset = (u64::from(self.agent.saturating_sub(1)) * self.period_us) % period;
        let due = *self
            .next_heartbeat_us
            .get_or_insert(first.saturating_add(offset));
        if now < due {
            return;
        }
        self.next_heartbeat_us = Some(due.saturating_add(period).max(now.saturating_add(1)));
        let to16 = |v: u32| u16::try_from(v).unwrap_or(u16::MAX);
        let hb = Heartbeat {
            state: self.supervisor.state(),
            lost: self.supervisor.lost(),
            boot_count: self.boot_count,
            overruns: to16(self.stats.overruns),
            safe_entries: to16(self.stats.safe_state_entries),
        };
        let Some(frame) = wire::encode_heartbeat::<C::Frame>(&self.ids, self.agent, &hb) else {
            return;
        };
        if self.transmit_counted(&frame) {
            self.stats.heartbeats_tx = self.stats.heartbeats_tx.saturating_add(1);
            self.status_sent(&hb.to_bytes());
        }
    }

    /// Hand `frame` to the CAN controller; `false` (counted as busy or an error) if refused.
    fn transmit_counted(&mut self, frame: &C::Frame) -> bool {
        match self.can.transmit(frame) {
            Ok(_) => true,
            Err(nb::Error::WouldBlock) => {
                self.stats.tx_busy = self.stats.tx_busy.saturating_add(1);
                false
            }
            Err(nb::Error::Other(_)) => {
                self.stats.tx_errors = self.stats.tx_errors.saturating_add(1);
                false
            }
        }
    }

    fn links(&mut self, now: u64) -> [Link; K] {
        let mut links = [Link::Missing; K];
        let (agent, timeout) = (self.agent, self.timeout_us);
        for (l, s) in links.iter_mut().zip(self.slots.iter_mut().take(self.count)) {
            *l = s.link(now, timeout);
            match *l {
                Link::Stale(_) => {
                    self.stats.stale_samples = self.stats.stale_samples.saturating_add(1);
                    if !s.stale {
                        warn!(
                            "agent {}: neighbour {} stale, holding its last value",
                            agent, s.agent
                        );
                        s.stale = true;
                    }
                }
                Link::Missing => {
                    self.stats.missing_samples = self.stats.missing_samples.saturating_add(1);
                }
                Link::Fresh(_) => {
                    if s.stale {
                        info!("agent {}: neighbour {} fresh again", agent, s.agent);
                        s.stale = false;
                    }
                }
            }
        }
        links
    }

    fn log_leader(&mut self, l: &Link) {
        match l {
            Link::Fresh(_) => {
                if self.leader.stale {
                    info!("agent {}: leader fresh again", self.agent);
                    self.leader.stale = false;
                }
            }
            _ => {
                self.stats.leader_degraded_samples =
                    self.stats.leader_degraded_samples.saturating_add(1);
                if !self.leader.stale && matches!(l, Link::Stale(_)) {
                    warn!("agent {}: leader stale, holding the last y_d", self.agent);
                    self.leader.stale = true;
                }
            }
        }
    }

    fn log_fault(&mut self, fault: Option<StepFault>) {
        if let Some(f) = fault {
            self.stats.faults = self.stats.faults.saturating_add(1);
            if self.last_fault != Some(f) {
                warn!("agent {}: step fault {:?}, command held", self.agent, f);
            }
        } else if self.last_fault.is_some() {
            info!("agent {}: step fault cleared", self.agent);
        }
        self.last_fault = fault;
    }

    fn broadcast(&mut self, y: f32) -> TxOutcome {
        let Some((frame, enc)) =
            wire::encode_in::<C::Frame>(&self.ids, Source::Agent(self.agent), y, self.seq)
        else {
            return TxOutcome::EncodeFailed;
        };
        if enc.saturated {
            self.stats.saturated_tx = self.stats.saturated_tx.saturating_add(1);
        }
        let out = match self.can.transmit(&frame) {
            Ok(None) => TxOutcome::Queued,
            Ok(Some(_)) => {
                self.stats.tx_replaced = self.stats.tx_replaced.saturating_add(1);
                TxOutcome::Replaced
            }
            Err(nb::Error::WouldBlock) => {
                self.stats.tx_busy = self.stats.tx_busy.saturating_add(1);
                TxOutcome::Busy
            }
            Err(nb::Error::Other(e)) => {
                self.stats.tx_errors = self.stats.tx_errors.saturating_add(1);
                TxOutcome::Error(e.kind())
            }
        };
        match out {
            TxOutcome::Queued | TxOutcome::Replaced => {
                self.value_sent(&enc.data);
                self.stats.tx_queued = self.stats.tx_queued.saturating_add(1);
                if self.tx_failed {
                    info!("agent {}: transmitting again", self.agent);
                }
                self.tx_failed = false;
            }
            _ => {
                if !self.tx_failed {
                    warn!("agent {}: transmit failed", self.agent);
                }
                self.tx_failed = true;
            }
        }
        out
    }
}

/// The node's CANopen device (feature `canopen`, default): [`Node::enable_canopen`] and what
/// the node does with it.
#[cfg(feature = "canopen")]
impl<C, Clk, S, A, const N: usize, const M: usize, const K: usize> Node<C, Clk, S, A, N, M, K>
where
    C: Can,
    Clk: Clock,
    S: Sensor<N>,
    A: Actuator<M>,
{
    /// Make the node a CiA 301 device ([`crate::canopen`]): its object dictionary holds the
    /// configurations the node was built with (and the defaults `0x1011` restores), the boot-up
    /// message goes out at the next tick, and the control outputs — actuators and value frames
    /// — are enabled only while the device is NMT operational. `self_starting`: operational at
    /// boot, without an NMT start. `heartbeat_ms`: `0x1017`.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::{Identity, NmtState};
    /// use agent_node::TxOutcome;
    /// let mut n = node();
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), false, 0).unwrap();
    /// // Not self-starting: pre-operational after boot-up, the outputs are off.
    /// assert_eq!(n.tick().tx, TxOutcome::Disabled);
    /// assert_eq!(n.canopen().unwrap().nmt(), NmtState::PreOperational);
    /// ```
    pub fn enable_canopen(
        &mut self,
        cfg: &NodeConfig<K>,
        controller: &ControllerConfig<N>,
        identity: Identity,
        self_starting: bool,
        heartbeat_ms: u16,
    ) -> Result<(), NodeError> {
        let store = ParamStore::new(cfg.identity(), controller)
            .map_err(|_| NodeError::AgentOutsidePlan(cfg.agent))?;
        let mut device = Device::new(store, identity, self_starting);
        device.set_heartbeat_ms(heartbeat_ms);
        self.canopen = Some(CanOpen {
            device,
            dirty: false,
            requests: 0,
            last_overrun_emcy_us: None,
            held: None,
            adoptions: 0,
        });
        Ok(())
    }

    /// The node's plant is on the bus (a bench host's sensor and command frames, one sensor
    /// frame per agent): the device's RPDO18 and TPDO3 describe them (docs/NETWORK.md §12).
    /// Nothing without a device.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::{od::COB_ID_INVALID, Identity};
    /// let mut n = node();
    /// n.enable_plant_pdos(); // no device yet: nothing
    /// assert!(n.canopen().is_none());
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// assert_ne!(n.canopen().unwrap().plant_cob_id(true) & COB_ID_INVALID, 0);
    /// n.enable_plant_pdos();
    /// // RPDO18 valid: agent 2's sensor frame, 0x200 + node-ID.
    /// assert_eq!(n.canopen().unwrap().plant_cob_id(true), 0x202);
    /// ```
    pub fn enable_plant_pdos(&mut self) {
        if let Some(c) = &mut self.canopen {
            c.device.enable_plant_pdos();
        }
    }

    /// The sensor frame `x` came and the command frame `q` went out: the device's `0x2230` and
    /// `0x2231` hold them. Unlike [`Self::canopen_mut`], nothing is rebuilt at the next start.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::od::{COMMAND_OBJECT, SENSOR_OBJECT};
    /// use agent_node::canopen::Identity;
    /// let mut n = node();
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// n.plant_frames(Some([0.1, 0.0]), None); // the state x_2 came, no command went out
    /// let dev = n.canopen().unwrap();
    /// assert_eq!(dev.read(SENSOR_OBJECT, 1).unwrap().as_slice(), &0.1f32.to_le_bytes());
    /// assert_eq!(dev.read(COMMAND_OBJECT, 1).unwrap().as_slice(), &f32::NAN.to_le_bytes());
    /// ```
    pub fn plant_frames(&mut self, x: Option<[f32; 2]>, q: Option<[f32; 2]>) {
        if let Some(c) = &mut self.canopen {
            if let Some(x) = x {
                c.device.sensor_received(x);
            }
            if let Some(q) = q {
                c.device.command_sent(q);
            }
        }
    }

    /// The CANopen device, if enabled.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::Identity;
    /// let mut n = node();
    /// assert!(n.canopen().is_none());
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// assert_eq!(n.canopen().unwrap().node_id(), 2);
    /// ```
    pub fn canopen(&self) -> Option<&Device<N>> {
        self.canopen.as_ref().map(|c| &c.device)
    }

    /// The CANopen device, to load a stored configuration ([`Device::load`]) or report a fault
    /// ([`Device::report`]: bus-off, receive overflow, watchdog reset).
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::Identity;
    /// let mut n = node();
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// n.canopen_mut().unwrap().set_heartbeat_ms(100);
    /// assert_eq!(n.canopen().unwrap().read(0x1017, 0).unwrap().as_slice(), &100u16.to_le_bytes());
    /// ```
    pub fn canopen_mut(&mut self) -> Option<&mut Device<N>> {
        self.canopen.as_mut().map(|c| {
            // Whatever the caller changes is applied at the next NMT start.
            c.dirty = true;
            &mut c.device
        })
    }

    /// The next request of the CANopen device for the application.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::{canopen::Identity, node::CanOpenRequest};
    /// let mut n = node();
    /// assert_eq!(n.take_canopen_request(), None); // no device, no requests
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// n.canopen_mut().unwrap().write(0x1011, 1, b"load").unwrap();
    /// n.service();
    /// assert_eq!(n.take_canopen_request(), Some(CanOpenRequest::Restore));
    /// ```
    pub fn take_canopen_request(&mut self) -> Option<CanOpenRequest> {
        let c = self.canopen.as_mut()?;
        let r = [
            CanOpenRequest::Store,
            CanOpenRequest::Restore,
            CanOpenRequest::ResetNode,
        ]
        .into_iter()
        .find(|r| c.requests & r.bit() != 0)?;
        c.requests &= !r.bit();
        Some(r)
    }

    /// An overrun EMCY (with the count since start) at most this often, so that a node that
    /// keeps missing its deadlines does not flood the bus and the error history (µs).
    fn overrun_emcy(&mut self) {
        let now = self.last_tick_us.unwrap_or(0);
        let Some(c) = &mut self.canopen else {
            return;
        };
        if c.last_overrun_emcy_us
            .is_some_and(|t| now.saturating_sub(t) < OVERRUN_EMCY_INHIBIT_US)
        {
            return;
        }
        c.last_overrun_emcy_us = Some(now);
        self.emcy(Fault::Overrun, self.stats.overruns);
    }

    /// The value frame went out: the device's TPDO1 objects (`0x2200..`) hold it.
    fn value_sent(&mut self, data: &[u8; wire::PAYLOAD_LEN]) {
        if let Some(c) = &mut self.canopen {
            c.device.value_sent(data);
        }
    }

    /// The status PDO went out: the device's TPDO2 objects (`0x2220..`) hold it.
    fn status_sent(&mut self, data: &[u8; wire::HEARTBEAT_LEN]) {
        if let Some(c) = &mut self.canopen {
            c.device.status_sent(data);
        }
    }

    /// The consumed heartbeat (`0x1016`) of `node` is lost.
    fn heartbeat_lost(&self, node: u8) -> bool {
        self.canopen
            .as_ref()
            .is_some_and(|c| c.device.heartbeat_lost(node))
    }

    /// A consumed heartbeat of a node that is none of the neighbours is lost: the leader's
    /// producer (docs/NETWORK.md §12, *Heartbeat*).
    fn leader_heartbeat_lost(&self) -> bool {
        let Some(c) = &self.canopen else {
            return false;
        };
        let neighbours = self.slots.get(..self.count).unwrap_or(&[]);
        c.device
            .lost_heartbeats()
            .any(|n| !neighbours.iter().any(|s| s.agent == n))
    }

    /// Report a fault by EMCY when the node is a CANopen device.
    fn emcy(&mut self, f: Fault, count: u32) {
        if let Some(c) = &mut self.canopen {
            c.device.report(f, u16::try_from(count).unwrap_or(u16::MAX));
        }
    }

    fn emcy_clear(&mut self, f: Fault) {
        if let Some(c) = &mut self.canopen {
            c.device.clear(f);
        }
    }

    /// Send what the device queued (heartbeat, boot-up, EMCY, SDO answers). A CAN controller
    /// whose mailbox replaces a pending frame of the same identifier (`transmit` returning it)
    /// would lose the earlier of two EMCYs of one tick: the earlier goes back into its mailbox
    /// and the later waits for the next flush, so both go out, in order.
    fn flush_canopen(&mut self) {
        loop {
            let Some(c) = &mut self.canopen else {
                return;
            };
            let Some(f) = c.held.take().or_else(|| c.device.next_tx()) else {
                return;
            };
            let Some(frame) = f.to_frame::<C::Frame>() else {
                continue;
            };
            let replaced = match self.can.transmit(&frame) {
                Ok(replaced) => replaced,
                Err(nb::Error::WouldBlock) => {
                    self.stats.tx_busy = self.stats.tx_busy.saturating_add(1);
                    continue;
                }
                Err(nb::Error::Other(_)) => {
                    self.stats.tx_errors = self.stats.tx_errors.saturating_add(1);
                    continue;
                }
            };
            self.stats.tx_queued = self.stats.tx_queued.saturating_add(1);
            let Some(old) = replaced else {
                continue;
            };
            if CoFrame::from_frame(&old).is_some_and(|o| o.id == f.id) {
                if let Ok(Some(_)) = self.can.transmit(&old) {
                    if let Some(c) = &mut self.canopen {
                        c.held = Some(f);
                    }
                    return;
                }
            }
        }
    }

    /// Act on the device's events: a start with changed parameters rebuilds the controller
    /// and the supervisor from the object dictionary (refused, back to pre-operational, with
    /// EMCY `0x6300`, if the set does not validate); a stop or pre-operational zeroes the
    /// outputs and restarts supervision at the next start; a new node-ID after a reset.
    fn canopen_events(&mut self) {
        loop {
            let Some(c) = &mut self.canopen else {
                return;
            };
            let Some(e) = c.device.next_event() else {
                return;
            };
            match e {
                Event::Nmt(canopen::NmtState::Operational) => {
                    if core::mem::take(&mut c.dirty) {
                        if let Err(err) = self.rebuild() {
                            error!(
                                "agent {}: stored configuration refused: {:?}",
                                self.agent, err
                            );
                            self.emcy(Fault::ConfigRejected, 0);
                            if let Some(c) = &mut self.canopen {
                                c.dirty = true;
                                c.device.on_frame(
                                    canopen::NMT_ID,
                                    &[canopen::NmtCommand::EnterPreOperational.code(), 0],
                                    self.last_tick_us.unwrap_or(0),
                                );
                            }
                        }
                    }
                    info!("agent {}: NMT operational", self.agent);
                }
                Event::Nmt(s) => {
                    // Outputs off; supervision and the sample grid start again at the next start.
                    self.first_tick_us = None;
                    self.next_heartbeat_us = None;
                    info!("agent {}: NMT {}", self.agent, s.name());
                }
                Event::Written(..) => c.dirty = true,
                Event::Store => c.requests |= CanOpenRequest::Store.bit(),
                Event::Restore => {
                    c.dirty = true;
                    c.requests |= CanOpenRequest::Restore.bit();
                }
                Event::ResetNode => {
                    c.dirty = true;
                    c.requests |= CanOpenRequest::ResetNode.bit();
                }
                Event::ResetCommunication => self.adopt_node_id(),
                Event::HeartbeatLost(n) => {
                    warn!("agent {}: heartbeat of node {} lost", self.agent, n)
                }
                Event::HeartbeatResumed(n) => {
                    info!("agent {}: heartbeat of node {} back", self.agent, n)
                }
                Event::Sync => {}
            }
        }
    }

    /// The device's node-ID, graph row (neighbours, `pinned`) and identifier plan — written
    /// over SDO and applied by a reset, or loaded from a stored set — become the node's when
    /// [`NodeConfig::check`] accepts them together (within the capacity `K`): the neighbour
    /// slots start empty and the next NMT start rebuilds the controller for the new row. Else
    /// EMCY `0x6300` (count: the node-ID) and the node keeps what it had.
    fn adopt_node_id(&mut self) {
        let Some(c) = &self.canopen else {
            return;
        };
        let id = c.device.node_id();
        if id == self.agent && !c.device.graph_written() {
            return;
        }
        let store = &c.device.store;
        let (count, pinned) = (
            store.sections.agent.neighbour_count,
            store.sections.agent.pinned,
        );
        let (ids, row) = (store.node.ids, store.node.neighbours);
        let own = Own {
            agent: id,
            stale_timeout_us: self.timeout_us,
            ids: &ids,
            heartbeat_period_us: self.heartbeat_period_us,
        };
        if let Err(e) = own.check(row.get(..K).unwrap_or(&row), count) {
            error!(
                "agent {}: node-ID {}, graph row or plan refused: {:?}",
                self.agent, id, e
            );
            self.emcy(Fault::ConfigRejected, u32::from(id));
            return;
        }
        if id != self.agent {
            info!("agent {}: node-ID {} from now on", self.agent, id);
        }
        self.agent = id;
        self.ids = ids;
        self.pinned = pinned;
        self.count = count;
        self.slots = slots_of(&row, count);
        self.leader = Slot::default();
        if let Some(c) = &mut self.canopen {
            c.device.graph_adopted();
            c.dirty = true;
            c.adoptions = c.adoptions.wrapping_add(1);
        }
    }

    /// Adopt the device's node-ID, graph row and plan now, as a reset communication does: for
    /// an application that loads its stored set on NMT reset node (`Device::load`, after the
    /// device's own reset), so that the next start runs on it.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::{od::PARAM_BASE, Identity};
    /// use controller_core::Param;
    /// let mut n = node();
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), false, 0).unwrap();
    /// n.tick(); // boot-up: pre-operational, where the row is writable
    /// let pinned = PARAM_BASE + Param::ALL.iter().position(|p| *p == Param::Pinned).unwrap() as u16;
    /// n.canopen_mut().unwrap().write(pinned, 0, &[0]).unwrap();
    /// assert!(n.canopen().unwrap().graph_written());
    /// n.adopt();
    /// assert!(!n.canopen().unwrap().graph_written());
    /// ```
    pub fn adopt(&mut self) {
        self.adopt_node_id();
    }

    /// Times the node adopted another node-ID, graph row or plan from its device since it
    /// was built (the boot's adoption of a stored set included): a board whose acceptance
    /// filters were set for the earlier ones restarts when it changes.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::{od::PARAM_BASE, Identity};
    /// use controller_core::Param;
    /// let mut n = node();
    /// assert_eq!(n.adoptions(), 0); // no device
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), false, 0).unwrap();
    /// n.adopt();
    /// assert_eq!(n.adoptions(), 0); // nothing written: nothing to adopt
    /// n.tick(); // boot-up: pre-operational
    /// let pinned = PARAM_BASE + Param::ALL.iter().position(|p| *p == Param::Pinned).unwrap() as u16;
    /// n.canopen_mut().unwrap().write(pinned, 0, &[0]).unwrap(); // stop hearing the leader
    /// n.adopt();
    /// assert_eq!(n.adoptions(), 1);
    /// ```
    pub fn adoptions(&self) -> u16 {
        self.canopen.as_ref().map_or(0, |c| c.adoptions)
    }

    /// Controller, supervisor and stale timeout from the object dictionary. Out of line and
    /// cold: it runs once per NMT start after a change, and inlined its frame (the controller
    /// under construction) would be entered by every tick.
    #[cold]
    #[inline(never)]
    fn rebuild(&mut self) -> Result<(), NodeError> {
        let Some(c) = &self.canopen else {
            return Ok(());
        };
        let store = &c.device.store;
        let controller = store.controller()?;
        let sup = store.supervisor();
        let supervisor = Supervisor::new(&sup)?;
        let stale = micros_from_secs(store.node.stale_timeout);
        if stale == 0 {
            return Err(NodeError::ZeroTimeout);
        }
        if c.device.graph_written() || controller.neighbour_count != self.count {
            return Err(NodeError::PendingGraph);
        }
        self.controller = Controller::new(&with_reentry(&controller, &sup))?;
        self.period_us = micros_from_secs(controller.h);
        self.supervisor = supervisor;
        self.supervised = sup.supervises_any();
        self.timeout_us = stale;
        self.applied = [0.0; M];
        Ok(())
    }

    /// The CANopen device's work alone — boot-up, received frames (SDO, NMT, heartbeats),
    /// events, heartbeat — for an application that is not sampling yet (waiting for its host).
    /// Nothing without a device.
    ///
    /// ```
    /// # mod hw { include!("doctest_node.rs"); }
    /// # use hw::*;
    /// use agent_node::canopen::Identity;
    /// let mut n = node();
    /// let (cfg, ctrl) = (NodeConfig::new(2, [1], 2_500),
    ///     ControllerConfig::<2> { neighbour_count: 1, ..Default::default() });
    /// n.enable_canopen(&cfg, &ctrl, Identity::default(), true, 0).unwrap();
    /// n.service(); // boot-up message 0x700 + node-ID, no sample taken
    /// assert_eq!(n.can().tx[0].raw_id(), 0x702);
    /// assert_eq!(n.stats().ticks, 0);
    /// ```
    pub fn service(&mut self) {
        if self.canopen.is_some() {
            let now = self.clock.now_us();
            self.canopen_tick(now);
            self.flush_canopen();
        }
    }

    /// The CANopen part of a tick: boot, frames, events, heartbeat; `false` when the device
    /// is not operational (outputs off). Always `true` without a device.
    fn canopen_tick(&mut self, now: u64) -> bool {
        let Some(c) = &mut self.canopen else {
            return true;
        };
        if c.device.nmt() == canopen::NmtState::Initialising {
            c.device.boot(now);
            self.adopt_node_id();
        }
        self.poll_rx_at(now);
        self.canopen_events();
        if let Some(c) = &mut self.canopen {
            c.device.tick(now);
        }
        self.canopen_events();
        self.canopen
            .as_ref()
            .is_none_or(|c| c.device.outputs_enabled())
    }

    /// A frame for the CANopen device (NMT, SYNC, SDO, heartbeats): taken, `true`.
    fn device_frame(&mut self, frame: &C::Frame, now: u64) -> bool {
        let (Some(c), Some(f)) = (&mut self.canopen, CoFrame::from_frame(frame)) else {
            return false;
        };
        c.device.on_frame(f.id, f.data(), now)
    }
}

/// Without the `canopen` feature (the firmware builds) the node has no device: its hooks do
/// nothing and the outputs are always enabled.
#[cfg(not(feature = "canopen"))]
impl<C, Clk, S, A, const N: usize, const M: usize, const K: usize> Node<C, Clk, S, A, N, M, K>
where
    C: Can,
    Clk: Clock,
    S: Sensor<N>,
    A: Actuator<M>,
{
    fn canopen_tick(&mut self, _now: u64) -> bool {
        true
    }

    fn flush_canopen(&mut self) {}

    fn emcy(&mut self, _f: Fault, _count: u32) {}

    fn emcy_clear(&mut self, _f: Fault) {}

    fn overrun_emcy(&mut self) {}

    fn value_sent(&mut self, _data: &[u8; wire::PAYLOAD_LEN]) {}

    fn status_sent(&mut self, _data: &[u8; wire::HEARTBEAT_LEN]) {}

    fn heartbeat_lost(&self, _node: u8) -> bool {
        false
    }

    fn leader_heartbeat_lost(&self) -> bool {
        false
    }

    fn device_frame(&mut self, _frame: &C::Frame, _now: u64) -> bool {
        false
    }
}
