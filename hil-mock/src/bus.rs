//! A CAN-like bus simulator, event-driven, time in nanoseconds.
//!
//! ## Model
//!
//! * **Timing.** A frame occupies the bus for [`frame_bits`] bit times: the classical CAN frame
//!   from start-of-frame to end-of-frame with worst-case bit stuffing (one stuff bit per four
//!   bits of the stuffed region SOF..CRC delimiter, as Linux `can_frame_bits()`), plus the
//!   3-bit intermission. A standard frame with 4 data bytes is 95 bits; with 8, 135 bits. With
//!   a data bit rate (`BusConfig::data_bitrate`) every frame is a CAN FD frame with bit-rate
//!   switching, its data phase at that rate (`agent_node::bus_load`).
//! * **Arbitration.** When the bus is idle and frames are pending, the lowest identifier
//!   among the frames pending at that instant wins (ties, which CAN forbids, go to the lower
//!   node index); the others wait for the bus to be idle again. A node has one mailbox per
//!   identifier (its own frame of lowest identifier arbitrates first); per identifier:
//!   submitting a new one while the previous is still waiting *replaces* it and counts a
//!   **deadline miss** (the old sample never made it onto the wire).
//! * **Latency.** Receivers get a frame `latency` after its end-of-frame (driver/ISR delay);
//!   the bus itself is free right away.
//! * **Loss** (probability `loss`, seeded): the frame is transmitted but reaches no receiver
//!   (a gateway drop / receive overrun; CAN's acknowledge would normally trigger a
//!   retransmission, this models the cases where it does not). Counted in `frames_lost`.
//! * **Corruption** (probability `corruption`, seeded): the receivers' CRC check fails, so every
//!   receiver drops the frame and an error frame follows (6 + 8 bits + 3 intermission); the
//!   transmitter's TEC += 8, each other active node's REC += 1, and the frame is retransmitted
//!   (re-arbitrated) if `auto_retransmit` is set, else dropped. Counted in `frames_corrupted`.
//! * **Error counters** (ISO 11898-1, simplified): a successful transmission decrements the
//!   transmitter's TEC and every receiver's REC (not below 0). A node is *error-passive*
//!   while TEC ≥ 128 or REC ≥ 128 (no behavioural difference modelled: passive error flags
//!   and the suspend-transmission time are ignored), and *bus-off* when TEC > 255: its
//!   pending frame is discarded, it neither transmits nor receives, and submissions are
//!   refused. It recovers (TEC = REC = 0, error-active) 128 × 11 bit times after it went
//!   bus-off — the time 128 sequences of 11 recessive bits take on an idle bus; the real
//!   controller waits longer on a busy bus.
//! * **Events.** Between `from_ns` and `until_ns` a node can be *silent* (crashed transmitter:
//!   its frames never reach the wire, counted `suppressed`; it still receives), or *babbling*
//!   (it always has a frame with the given identifier — by default `0x000`, the highest
//!   priority — and 8 bytes of garbage pending, so it wins every arbitration and starves
//!   everyone else; receivers count its frames as unknown ids).
//! * **Deadline.** With `deadline_ns > 0`, a frame delivered later than `deadline_ns` after it
//!   was submitted also counts as a deadline miss (`late`).
//!
//! ## Use
//!
//! Submit frames at non-decreasing times with [`Bus::submit`]; [`Bus::advance_to`] runs the
//! bus up to `t` and returns the frames whose delivery time is `≤ t`, in delivery order;
//! [`Bus::stats`] gives the statistics. [`crate::network::CanNetwork`] wires nodes, bus and
//! leader together for a sampled-data loop.

use std::collections::VecDeque;

use embedded_can::Frame;
use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use agent_node::bus_load::{self, Bitrates, Format, FrameBits};

use crate::mock::MockFrame;

/// Simulated time, nanoseconds.
pub type Nanos = u64;

/// Bits of the error frame that follows a detected error: 6-bit flag, 8-bit delimiter, 3-bit
/// intermission (overlapping flags of other nodes are not modelled).
pub const ERROR_FRAME_BITS: u32 = 17;
/// Bus-off recovery: 128 occurrences of 11 recessive bits.
pub const BUS_OFF_RECOVERY_BITS: u64 = 128 * 11;
/// TEC/REC at or above this: error-passive.
pub const ERROR_PASSIVE_LIMIT: u16 = 128;
/// TEC above this: bus-off.
pub const BUS_OFF_LIMIT: u16 = 255;

/// Bits on the wire of a classical CAN frame with `data_len` data bytes (0 for a remote
/// frame), with worst-case bit stuffing if `stuffing`, including the 3-bit intermission.
///
/// ```
/// use hil_mock::bus::frame_bits;
/// assert_eq!(frame_bits(false, 8, true), 135); // 8 bytes, standard id
/// assert_eq!(frame_bits(false, 4, true), 95); // this project's frames
/// assert_eq!(frame_bits(false, 8, false), 111);
/// assert_eq!(frame_bits(true, 8, true), 160);
/// ```
pub const fn frame_bits(extended: bool, data_len: usize, stuffing: bool) -> u32 {
    bus_load::frame_bits(Format::Classical, extended, data_len, stuffing).total()
}

/// Bits on the wire of `frame` (worst-case stuffing, with intermission).
pub fn bits_of(frame: &MockFrame) -> u32 {
    frame_bits(frame.is_extended(), data_len(frame), true)
}

fn data_len(frame: &MockFrame) -> usize {
    if frame.is_remote_frame() {
        0
    } else {
        frame.data().len()
    }
}

/// What a node does between two times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventKind {
    /// Its frames never reach the bus (crash of the node or its transmitter).
    Silent,
    /// It floods frames with this 11-bit identifier (0 = highest priority).
    Babbling {
        /// Identifier of the babbled frames.
        id: u16,
    },
}

/// A scheduled fault of one node, active on `[from_ns, until_ns)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusEvent {
    /// Bus node index.
    pub node: usize,
    /// What it does.
    pub kind: EventKind,
    /// Start (inclusive).
    pub from_ns: Nanos,
    /// End (exclusive).
    pub until_ns: Nanos,
}

/// Bus settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BusConfig {
    /// Bit rate, bit/s (> 0): the nominal (arbitration) bit rate of CAN FD.
    pub bitrate: u32,
    /// CAN FD with bit-rate switching: the data-phase bit rate, bit/s; `None`: classical CAN.
    /// Every frame is then timed as an FD frame of its length
    /// ([`agent_node::bus_load::frame_bits`]).
    pub data_bitrate: Option<u32>,
    /// From end-of-frame to delivery at the receivers.
    pub latency_ns: Nanos,
    /// Probability that a frame reaches no receiver, in [0, 1].
    pub loss: f64,
    /// Probability that a transmission is corrupted (CRC error at every receiver), in [0, 1).
    pub corruption: f64,
    /// Seed of the loss/corruption random numbers.
    pub seed: u64,
    /// Retransmit corrupted frames (as CAN controllers do by default).
    pub auto_retransmit: bool,
    /// A delivery later than this after submission is a deadline miss (0 = no such check).
    pub deadline_ns: Nanos,
    /// Silent and babbling nodes.
    pub events: Vec<BusEvent>,
}

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            bitrate: 1_000_000,
            data_bitrate: None,
            latency_ns: 0,
            loss: 0.0,
            corruption: 0.0,
            seed: 0,
            auto_retransmit: true,
            deadline_ns: 0,
            events: Vec::new(),
        }
    }
}

/// Why a bus configuration was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum BusConfigError {
    /// `bitrate` is 0.
    ZeroBitrate,
    /// A probability is outside its range or not finite (`"loss"`, `"corruption"`).
    Probability(&'static str),
    /// An event names a node the bus does not have, or ends before it starts.
    BadEvent(usize),
}

impl std::fmt::Display for BusConfigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::ZeroBitrate => f.write_str("bus bit rate must be > 0"),
            Self::Probability(p) => write!(f, "bus `{p}` must be a probability in [0, 1)"),
            Self::BadEvent(i) => write!(f, "bus event {i}: unknown node or empty interval"),
        }
    }
}

impl std::error::Error for BusConfigError {}

/// Why a submission was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SubmitError {
    /// No such node.
    UnknownNode,
    /// The node is bus-off.
    BusOff,
    /// The node is silent (the frame is counted as suppressed).
    Silent,
}

/// A node's fault-confinement state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorState {
    /// Normal.
    #[default]
    Active,
    /// TEC or REC ≥ 128.
    Passive,
    /// TEC > 255: off the bus until recovery.
    BusOff,
}

/// Per-node counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NodeBusStats {
    /// Transmit error counter.
    pub tec: u16,
    /// Receive error counter.
    pub rec: u16,
    /// Highest TEC seen.
    pub max_tec: u16,
    /// Current state.
    pub state: ErrorState,
    /// Frames submitted.
    pub submitted: u64,
    /// Frames transmitted without error.
    pub sent: u64,
    /// Deadline misses of this node's frames.
    pub deadline_misses: u64,
    /// Times the node went bus-off.
    pub bus_off_events: u64,
}

/// Statistics of a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BusStats {
    /// Time covered (the last `advance_to`).
    pub elapsed_ns: Nanos,
    /// Time the bus carried frames or error frames.
    pub busy_ns: Nanos,
    /// The part of `busy_ns` after `elapsed_ns`: the frame still on the wire at the last
    /// `advance_to` (its whole duration is booked when it starts).
    pub busy_after_ns: Nanos,
    /// Frames put on the wire, including corrupted attempts and babble.
    pub transmissions: u64,
    /// Frames transmitted without error (delivered + lost).
    pub frames_sent: u64,
    /// Frames delivered to the receivers.
    pub frames_delivered: u64,
    /// Frames transmitted but reaching no receiver.
    pub frames_lost: u64,
    /// Transmissions destroyed by a CRC error (error frame).
    pub frames_corrupted: u64,
    /// Corrupted frames dropped for good (no retransmission, or the sender went bus-off).
    pub frames_dropped: u64,
    /// Frames of babbling nodes on the wire.
    pub babble_frames: u64,
    /// Frames of silent nodes that never reached the wire.
    pub suppressed: u64,
    /// Submissions refused because the node was bus-off.
    pub refused_bus_off: u64,
    /// Pending frames replaced by a newer one before they could be sent.
    pub replaced: u64,
    /// Frames delivered later than the deadline.
    pub late: u64,
    /// `replaced + late`.
    pub deadline_misses: u64,
    /// Times any node went bus-off.
    pub bus_off_events: u64,
    /// Longest time from submission to delivery.
    pub max_latency_ns: Nanos,
    /// Sum of submission-to-delivery times (for the mean).
    pub sum_latency_ns: u128,
    /// Largest age of neighbour data used by a controller (recorded by the harness).
    pub max_age_ns: Nanos,
    /// Sum of recorded ages.
    pub sum_age_ns: u128,
    /// Recorded ages.
    pub ages: u64,
    /// Per node.
    pub nodes: Vec<NodeBusStats>,
}

impl BusStats {
    /// Bus load, percent of the elapsed time.
    pub fn load_percent(&self) -> f64 {
        if self.elapsed_ns == 0 {
            0.0
        } else {
            let busy = self.busy_ns.saturating_sub(self.busy_after_ns);
            100.0 * busy as f64 / self.elapsed_ns as f64
        }
    }

    /// Mean submission-to-delivery time, seconds.
    pub fn mean_latency_s(&self) -> f64 {
        if self.frames_delivered == 0 {
            0.0
        } else {
            self.sum_latency_ns as f64 / self.frames_delivered as f64 * 1e-9
        }
    }

    /// Largest age of neighbour data used, seconds.
    pub fn max_age_s(&self) -> f64 {
        self.max_age_ns as f64 * 1e-9
    }

    /// Mean age of neighbour data used, seconds.
    pub fn mean_age_s(&self) -> f64 {
        if self.ages == 0 {
            0.0
        } else {
            self.sum_age_ns as f64 / self.ages as f64 * 1e-9
        }
    }
}

/// A frame as delivered to the receivers (every node but `from`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Delivery {
    /// Sending node.
    pub from: usize,
    /// The frame.
    pub frame: MockFrame,
    /// When it was submitted (the sender's sample time).
    pub submitted_ns: Nanos,
    /// Start of its (successful) transmission.
    pub start_ns: Nanos,
    /// When the receivers get it (end-of-frame + latency).
    pub at_ns: Nanos,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    frame: MockFrame,
    submitted: Nanos,
    /// Data bytes on the wire (at least the frame's own).
    len: usize,
}

#[derive(Debug, Clone, Default)]
struct Port {
    /// One mailbox per identifier, in submission order.
    pending: Vec<Pending>,
    stats: NodeBusStats,
    bus_off_until: Nanos,
}

impl Port {
    /// The node's frame that arbitrates at `s`: the lowest identifier submitted by then.
    fn first_pending(&self, s: Nanos) -> Option<Pending> {
        self.pending
            .iter()
            .filter(|p| p.submitted <= s)
            .min_by_key(|p| p.frame.raw_id())
            .copied()
    }

    fn remove_first(&mut self, s: Nanos) {
        if let Some(p) = self.first_pending(s) {
            self.pending
                .retain(|q| q.frame.raw_id() != p.frame.raw_id());
        }
    }
}

/// The bus: nodes `0..nodes` share it.
#[derive(Debug, Clone)]
pub struct Bus {
    cfg: BusConfig,
    ports: Vec<Port>,
    rng: ChaCha8Rng,
    free_at: Nanos,
    /// End of the last frame or error frame put on the wire.
    busy_until: Nanos,
    now: Nanos,
    in_transit: VecDeque<Delivery>,
    stats: BusStats,
    babble: MockFrame,
    /// Frames that completed on the wire (end-of-frame time), while recording.
    wire_log: Option<Vec<(Nanos, MockFrame)>>,
}

impl Bus {
    /// A bus with `nodes` nodes (indices `0..nodes`).
    pub fn new(cfg: BusConfig, nodes: usize) -> Result<Self, BusConfigError> {
        if cfg.bitrate == 0 {
            return Err(BusConfigError::ZeroBitrate);
        }
        if !(0.0..=1.0).contains(&cfg.loss) {
            return Err(BusConfigError::Probability("loss"));
        }
        if !(0.0..1.0).contains(&cfg.corruption) {
            return Err(BusConfigError::Probability("corruption"));
        }
        for (i, e) in cfg.events.iter().enumerate() {
            let bad_id = matches!(e.kind, EventKind::Babbling { id } if id > 0x7FF);
            if e.node >= nodes || e.until_ns <= e.from_ns || bad_id {
                return Err(BusConfigError::BadEvent(i));
            }
        }
        let babble = MockFrame::new(embedded_can::StandardId::ZERO, &[0x55; 8])
            .ok_or(BusConfigError::BadEvent(0))?;
        Ok(Self {
            rng: ChaCha8Rng::seed_from_u64(cfg.seed),
            ports: vec![Port::default(); nodes],
            cfg,
            free_at: 0,
            busy_until: 0,
            now: 0,
            in_transit: VecDeque::new(),
            stats: BusStats::default(),
            babble,
            wire_log: None,
        })
    }

    /// Start recording every frame that completes on the wire (delivered or lost; not the
    /// corrupted ones), for a bus trace: see [`Bus::take_wire_log`].
    pub fn record_wire(&mut self) {
        self.wire_log.get_or_insert_with(Vec::new);
    }

    /// The frames recorded since the last call, in wire order, each with its end-of-frame
    /// time (before the intermission, without `latency`); empty when not recording.
    pub fn take_wire_log(&mut self) -> Vec<(Nanos, MockFrame)> {
        self.wire_log
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// The configuration.
    pub fn config(&self) -> &BusConfig {
        &self.cfg
    }

    /// The worst-case bits of `frame` on this bus: classical, or CAN FD with bit-rate switching
    /// when a data bit rate is set.
    fn frame_bits(&self, frame: &MockFrame, len: usize) -> FrameBits {
        let format = self.rates().format();
        bus_load::frame_bits(format, frame.is_extended(), len, true)
    }

    fn rates(&self) -> Bitrates {
        Bitrates {
            nominal: self.cfg.bitrate,
            data: self.cfg.data_bitrate,
        }
    }

    /// Time of a frame of `bits` up to its end-of-frame, followed by `tail` bits at the nominal
    /// rate (3: the intermission; 17: an error frame instead).
    fn phase_time_ns(&self, bits: FrameBits, tail: u32) -> Nanos {
        FrameBits {
            nominal: bits.nominal.saturating_sub(3) + tail,
            data: bits.data,
        }
        .time_ns(self.rates())
    }

    /// Time of `bits` at the nominal bit rate, rounded up.
    pub fn bit_time_ns(&self, bits: u64) -> Nanos {
        (bits * 1_000_000_000).div_ceil(u64::from(self.cfg.bitrate))
    }

    fn event(&self, node: usize, t: Nanos) -> Option<EventKind> {
        self.cfg
            .events
            .iter()
            .find(|e| e.node == node && e.from_ns <= t && t < e.until_ns)
            .map(|e| e.kind)
    }

    /// Node `node` is silent at `t`.
    pub fn is_silent(&self, node: usize, t: Nanos) -> bool {
        matches!(self.event(node, t), Some(EventKind::Silent))
    }

    /// Node `node` is bus-off at `t` (recovery applied).
    pub fn is_bus_off(&self, node: usize, t: Nanos) -> bool {
        self.ports
            .get(node)
            .is_some_and(|p| p.stats.state == ErrorState::BusOff && t < p.bus_off_until)
    }

    fn recover(&mut self, t: Nanos) {
        for p in &mut self.ports {
            if p.stats.state == ErrorState::BusOff && t >= p.bus_off_until {
                p.stats.state = ErrorState::Active;
                p.stats.tec = 0;
                p.stats.rec = 0;
            }
        }
    }

    /// Node `node` wants to send `frame` from `t` on (`t` ≥ the last `advance_to`). A frame of
    /// the node still pending is replaced (a deadline miss).
    pub fn submit(&mut self, node: usize, t: Nanos, frame: MockFrame) -> Result<(), SubmitError> {
        self.submit_sized(node, t, frame, data_len(&frame))
    }

    /// [`Bus::submit`] of a frame that goes on the wire with `len` data bytes (a CAN FD frame
    /// longer than a [`MockFrame`] holds, e.g. a packed sensor frame): the bus times it at
    /// `len` bytes (at least the frame's own); receivers and the wire log get the frame.
    pub fn submit_sized(
        &mut self,
        node: usize,
        t: Nanos,
        frame: MockFrame,
        len: usize,
    ) -> Result<(), SubmitError> {
        self.recover(t);
        let silent = self.is_silent(node, t);
        let bus_off = self.is_bus_off(node, t);
        let port = self.ports.get_mut(node).ok_or(SubmitError::UnknownNode)?;
        port.stats.submitted += 1;
        if silent {
            self.stats.suppressed += 1;
            return Err(SubmitError::Silent);
        }
        if bus_off {
            self.stats.refused_bus_off += 1;
            return Err(SubmitError::BusOff);
        }
        let new = Pending {
            frame,
            submitted: t,
            len: len.max(data_len(&frame)),
        };
        match port
            .pending
            .iter_mut()
            .find(|p| p.frame.raw_id() == frame.raw_id())
        {
            Some(old) => {
                *old = new;
                port.stats.deadline_misses += 1;
                self.stats.replaced += 1;
                self.stats.deadline_misses += 1;
            }
            None => port.pending.push(new),
        }
        Ok(())
    }

    /// Earliest time ≥ `from` at which some node may have a frame to send (pending frames,
    /// babblers), bus-off nodes from their recovery on.
    fn next_start(&self, from: Nanos, until: Nanos) -> Option<Nanos> {
        let mut best: Option<Nanos> = None;
        for (i, p) in self.ports.iter().enumerate() {
            for pe in &p.pending {
                let mut s = pe.submitted.max(from);
                if p.stats.state == ErrorState::BusOff {
                    s = s.max(p.bus_off_until);
                }
                best = Some(best.map_or(s, |b| b.min(s)));
            }
            for e in self.cfg.events.iter().filter(|e| e.node == i) {
                if let EventKind::Babbling { .. } = e.kind {
                    let mut s = e.from_ns.max(from);
                    if p.stats.state == ErrorState::BusOff {
                        s = s.max(p.bus_off_until);
                    }
                    if s < e.until_ns && s < until {
                        best = Some(best.map_or(s, |b| b.min(s)));
                    }
                }
            }
        }
        best
    }

    /// Run the bus up to `t` and return the deliveries with delivery time ≤ `t`, in order.
    pub fn advance_to(&mut self, t: Nanos) -> Vec<Delivery> {
        let t = t.max(self.now);
        while let Some(s) = self.next_start(self.free_at, t) {
            if s >= t {
                break;
            }
            self.recover(s);
            self.arbitrate_and_send(s);
        }
        self.now = t;
        self.stats.elapsed_ns = t;
        self.stats.busy_after_ns = self.busy_until.saturating_sub(t);
        let mut out = Vec::new();
        while self.in_transit.front().is_some_and(|d| d.at_ns <= t) {
            if let Some(d) = self.in_transit.pop_front() {
                out.push(d);
            }
        }
        out
    }

    /// The delivery time of the next frame to reach the receivers, if it is `≤ t`. Runs the bus
    /// only as far as that delivery needs (no arbitration at or after it), so a node that
    /// reacts to the frame can still submit from its delivery time on; then
    /// [`Bus::advance_to`] that time hands the frame over.
    pub fn next_delivery(&mut self, t: Nanos) -> Option<Nanos> {
        let t = t.max(self.now);
        loop {
            let front = self.in_transit.front().map(|d| d.at_ns);
            if let Some(at) = front.filter(|&at| at <= t) {
                return Some(at);
            }
            match self.next_start(self.free_at, t) {
                Some(s) if s < t => {
                    self.recover(s);
                    self.arbitrate_and_send(s);
                }
                _ => return None,
            }
        }
    }

    fn arbitrate_and_send(&mut self, s: Nanos) {
        // Candidates at s: (id, node, babble?).
        let mut winner: Option<(u32, usize, bool)> = None;
        for i in 0..self.ports.len() {
            let ev = self.event(i, s);
            if self.is_bus_off(i, s) {
                continue;
            }
            if let Some(EventKind::Babbling { id }) = ev {
                let c = (u32::from(id), i, true);
                if winner.is_none_or(|w| (c.0, c.1) < (w.0, w.1)) {
                    winner = Some(c);
                }
            }
            let silent = matches!(ev, Some(EventKind::Silent));
            let port = &mut self.ports[i];
            if silent && !port.pending.is_empty() {
                self.stats.suppressed += port.pending.len() as u64;
                port.pending.clear();
                continue;
            }
            if let Some(p) = port.first_pending(s) {
                let c = (p.frame.raw_id(), i, false);
                if winner.is_none_or(|w| (c.0, c.1) < (w.0, w.1)) {
                    winner = Some(c);
                }
            }
        }
        let Some((id, node, babble)) = winner else {
            // Nothing could go at s (e.g. a silent node's frame was discarded): move on.
            self.free_at = s + 1;
            return;
        };
        let (frame, submitted, len) = if babble {
            let mut f = self.babble;
            if let Some(sid) = u16::try_from(id)
                .ok()
                .and_then(embedded_can::StandardId::new)
            {
                f = MockFrame::new(sid, f.data()).unwrap_or(f);
            }
            (f, s, data_len(&f))
        } else {
            match self.ports[node].first_pending(s) {
                Some(p) => (p.frame, p.submitted, p.len),
                None => return,
            }
        };
        let bits = self.frame_bits(&frame, len);
        self.stats.transmissions += 1;
        if babble {
            self.stats.babble_frames += 1;
        }
        let corrupted = self.cfg.corruption > 0.0 && self.uniform() < self.cfg.corruption;
        if corrupted {
            let dur = self.phase_time_ns(bits, ERROR_FRAME_BITS);
            self.stats.busy_ns += dur;
            self.free_at = s + dur;
            self.busy_until = s + dur;
            self.stats.frames_corrupted += 1;
            self.on_error(node, s, s + dur, babble);
            return;
        }
        let dur = self.phase_time_ns(bits, 3);
        self.stats.busy_ns += dur;
        self.free_at = s + dur;
        self.busy_until = s + dur;
        self.stats.frames_sent += 1;
        self.on_success(node, s, babble);
        // End of frame is before the intermission.
        let end = s + self.phase_time_ns(bits, 0);
        if let Some(log) = self.wire_log.as_mut() {
            log.push((end, frame));
        }
        let lost = self.cfg.loss > 0.0 && self.uniform() < self.cfg.loss;
        if lost {
            self.stats.frames_lost += 1;
            return;
        }
        let at = end + self.cfg.latency_ns;
        let latency = at - submitted;
        self.stats.frames_delivered += 1;
        self.stats.max_latency_ns = self.stats.max_latency_ns.max(latency);
        self.stats.sum_latency_ns += u128::from(latency);
        if !babble && self.cfg.deadline_ns > 0 && latency > self.cfg.deadline_ns {
            self.stats.late += 1;
            self.stats.deadline_misses += 1;
            self.ports[node].stats.deadline_misses += 1;
        }
        self.in_transit.push_back(Delivery {
            from: node,
            frame,
            submitted_ns: submitted,
            start_ns: s,
            at_ns: at,
        });
    }

    fn uniform(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn on_success(&mut self, node: usize, s: Nanos, babble: bool) {
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i == node {
                p.stats.tec = p.stats.tec.saturating_sub(1);
                p.stats.sent += 1;
                if !babble {
                    p.remove_first(s);
                }
            } else if p.stats.state != ErrorState::BusOff {
                p.stats.rec = p.stats.rec.saturating_sub(1);
            }
            update_state(&mut p.stats);
        }
    }

    fn on_error(&mut self, node: usize, start: Nanos, end: Nanos, babble: bool) {
        let recovery = self.bit_time_ns(BUS_OFF_RECOVERY_BITS);
        let retransmit = self.cfg.auto_retransmit;
        for (i, p) in self.ports.iter_mut().enumerate() {
            if i == node {
                p.stats.tec = p.stats.tec.saturating_add(8);
                p.stats.max_tec = p.stats.max_tec.max(p.stats.tec);
                if !babble && !retransmit {
                    p.remove_first(start);
                    self.stats.frames_dropped += 1;
                }
                if p.stats.tec > BUS_OFF_LIMIT {
                    p.stats.state = ErrorState::BusOff;
                    p.stats.bus_off_events += 1;
                    self.stats.bus_off_events += 1;
                    p.bus_off_until = end + recovery;
                    self.stats.frames_dropped += p.pending.len() as u64;
                    p.pending.clear();
                    continue;
                }
            } else if p.stats.state != ErrorState::BusOff {
                p.stats.rec = p.stats.rec.saturating_add(1).min(255);
            }
            update_state(&mut p.stats);
        }
    }

    /// Record the age of a neighbour value a controller used (harness hook).
    pub fn record_age(&mut self, age_ns: Nanos) {
        self.stats.max_age_ns = self.stats.max_age_ns.max(age_ns);
        self.stats.sum_age_ns += u128::from(age_ns);
        self.stats.ages += 1;
    }

    /// Statistics so far.
    pub fn stats(&self) -> BusStats {
        let mut s = self.stats.clone();
        s.nodes = self.ports.iter().map(|p| p.stats).collect();
        s
    }

    /// One node's counters.
    pub fn node_stats(&self, node: usize) -> Option<NodeBusStats> {
        self.ports.get(node).map(|p| p.stats)
    }
}

fn update_state(s: &mut NodeBusStats) {
    if s.state == ErrorState::BusOff {
        return;
    }
    s.state = if s.tec >= ERROR_PASSIVE_LIMIT || s.rec >= ERROR_PASSIVE_LIMIT {
        ErrorState::Passive
    } else {
        ErrorState::Active
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::StandardId;

    fn frame(id: u16, len: usize) -> MockFrame {
        MockFrame::new(StandardId::new(id).expect("11-bit"), &[0xA5; 8][..len]).expect("≤ 8")
    }

    #[test]
    fn lowest_id_wins_and_timing_is_exact() {
        let mut bus = Bus::new(BusConfig::default(), 3).expect("valid");
        bus.submit(0, 0, frame(0x103, 4)).expect("ok");
        bus.submit(1, 0, frame(0x101, 4)).expect("ok");
        bus.submit(2, 0, frame(0x102, 8)).expect("ok");
        let d = bus.advance_to(1_000_000);
        let ids: Vec<u32> = d.iter().map(|d| d.frame.raw_id()).collect();
        assert_eq!(ids, vec![0x101, 0x102, 0x103]);
        // 95 bits at 1 Mbit/s = 95 µs; EOF at 92 µs.
        assert_eq!(d[0].start_ns, 0);
        assert_eq!(d[0].at_ns, 92_000);
        assert_eq!(d[1].start_ns, 95_000);
        assert_eq!(d[2].start_ns, 95_000 + 135_000);
        let s = bus.stats();
        assert_eq!(s.busy_ns, 95_000 * 2 + 135_000);
        assert!((s.load_percent() - 32.5).abs() < 1e-9);
    }

    #[test]
    fn fd_frames_take_their_data_phase_at_the_data_bit_rate() {
        let cfg = BusConfig {
            data_bitrate: Some(4_000_000),
            ..BusConfig::default()
        };
        let mut bus = Bus::new(cfg, 2).expect("valid");
        bus.submit(0, 0, frame(0x101, 4)).expect("ok");
        bus.submit(1, 0, frame(0x102, 8)).expect("ok");
        let d = bus.advance_to(1_000_000);
        // 4 bytes: 34 nominal bits + 73 data bits = 34 µs + 18.25 µs; EOF 3 bits earlier.
        assert_eq!(d[0].at_ns, 31_000 + 18_250);
        assert_eq!(d[1].start_ns, 52_250);
        // 8 bytes: 34 µs + 113 / 4 µs.
        assert_eq!(bus.stats().busy_ns, 52_250 + 62_250);
    }

    #[test]
    fn replaced_frame_is_a_deadline_miss() {
        let mut bus = Bus::new(BusConfig::default(), 2).expect("valid");
        bus.submit(0, 0, frame(0x101, 8)).expect("ok");
        bus.submit(1, 0, frame(0x102, 8)).expect("ok");
        let _ = bus.advance_to(10_000); // 0x101 on the wire, 0x102 waits
        bus.submit(1, 10_000, frame(0x102, 4)).expect("ok");
        assert_eq!(bus.stats().deadline_misses, 1);
    }

    #[test]
    fn corruption_drives_a_node_bus_off_and_it_recovers() {
        let cfg = BusConfig {
            corruption: 0.999,
            ..BusConfig::default()
        };
        let mut bus = Bus::new(cfg, 2).expect("valid");
        bus.submit(0, 0, frame(0x101, 4)).expect("ok");
        let _ = bus.advance_to(100_000_000);
        let s = bus.stats();
        assert!(s.bus_off_events >= 1, "{s:?}");
        assert!(s.nodes[1].rec > 0 || s.nodes[1].state != ErrorState::Active);
        // 32 errors × 8 > 255: bus-off after the 32nd corrupted attempt; recovery after 1408 µs.
        assert!(!bus.is_bus_off(0, 100_000_000));
        assert!(bus.submit(0, 100_000_000, frame(0x101, 4)).is_ok());
    }

    #[test]
    fn a_corrupted_babbler_goes_bus_off_and_the_others_get_through() {
        let cfg = BusConfig {
            corruption: 0.5,
            seed: 1,
            events: vec![BusEvent {
                node: 0,
                kind: EventKind::Babbling { id: 0 },
                from_ns: 0,
                until_ns: 50_000_000,
            }],
            ..BusConfig::default()
        };
        let mut bus = Bus::new(cfg, 2).expect("valid");
        let mut delivered = 0;
        for k in 0..50u64 {
            let _ = bus.submit(1, k * 1_000_000, frame(0x102, 4));
            delivered += bus
                .advance_to((k + 1) * 1_000_000)
                .iter()
                .filter(|d| d.from == 1)
                .count();
        }
        let s = bus.stats();
        assert!(s.nodes[0].bus_off_events > 0, "{s:?}");
        assert!(delivered > 0);
    }

    #[test]
    fn babbler_starves_everyone() {
        let cfg = BusConfig {
            events: vec![BusEvent {
                node: 0,
                kind: EventKind::Babbling { id: 0 },
                from_ns: 0,
                until_ns: 10_000_000,
            }],
            ..BusConfig::default()
        };
        let mut bus = Bus::new(cfg, 2).expect("valid");
        let mut delivered = 0;
        for k in 0..10u64 {
            bus.submit(1, k * 1_000_000, frame(0x102, 4)).expect("ok");
            delivered += bus
                .advance_to((k + 1) * 1_000_000)
                .iter()
                .filter(|d| d.from == 1)
                .count();
        }
        assert_eq!(delivered, 0);
        let s = bus.stats();
        assert_eq!(s.deadline_misses, 9);
        assert!(s.load_percent() > 99.0);
    }
}
