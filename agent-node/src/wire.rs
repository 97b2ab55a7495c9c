//! The frame codec: identifiers, the `fixed` payload, sequence counters, the heartbeat.
//!
//! ## Identifiers (11-bit standard ids; lower id = higher arbitration priority)
//!
//! An [`IdPlan`] places two blocks of identifiers; [`IdPlan::DEFAULT`]:
//!
//! | sender                  | identifier                                   |
//! |-------------------------|----------------------------------------------|
//! | leader (`y_d`)          | `value_base` = `0x101`                       |
//! | agent `i` (value)       | `value_base + i` (`0x102..=0x164`)           |
//! | agent `i` (heartbeat)   | `heartbeat_base + i` (`0x781..=0x7E3`)       |
//!
//! for up to 99 agents. The leader, the root of the spanning tree, wins arbitration against
//! every agent; agent 1 against agents 2.., and so on; heartbeats lose against every value
//! frame. Both blocks lie in CAN-ID ranges that CiA 301 restricts (no CANopen device may put a
//! PDO, SYNC, TIME or EMCY there) and that the predefined connection set leaves unused:
//! `docs/NETWORK.md` §2 gives the whole map. Every other identifier is *unknown* and rejected
//! by [`decode`].
//!
//! ## Payload (DLC = [`PAYLOAD_LEN`] = 4 bytes)
//!
//! ```text
//! byte 0..3  y  : Q7.16 two's complement, 24 bits, little-endian (a `fixed` I16F16 whose
//!                 value is restricted to [-128, 128 - 2^-16]; resolution 2^-16 ≈ 1.53e-5)
//! byte 3     bits 0..5 : sequence counter, modulo 64 (the sender's sample count)
//!            bit 6     : SATURATED — y was outside [-128, 128) and was clamped
//!            bit 7     : NO_VALUE  — the sender had no valid y (NaN/inf); bytes 0..3 are 0
//! ```
//!
//! Four bytes keep a standard data frame at 95 bits on the wire with worst-case stuffing (see
//! `hil_mock::bus::frame_bits`), so five frames per 1 ms sample (leader + 4 agents of Example 1) fit on a
//! 500 kbit/s bus (95 % load) and use 47.5 % of a 1 Mbit/s bus. An 8-byte payload (135 bits)
//! would not fit at 500 kbit/s.
//!
//! **Range.** ±128 covers the outputs of both paper examples (|y| ≲ 2) with a wide margin.
//! A value outside saturates to the nearest end and is flagged (`SATURATED`): receivers use
//! the clamped value and count the flag. NaN or ±∞ are sent as `NO_VALUE`; a receiver treats
//! such a frame as "nothing received" for that sample (the controller's `Missing`).
//!
//! **Stale and repeated data.** The 6-bit sequence counter lets a receiver reject a repeated
//! frame (same counter) and a late, out-of-order one (counter behind by 1..=32, modulo 64)
//! while the link is fresh; after the freshness timeout any counter is accepted (the sender
//! may have rebooted). The age of a value is measured by the receiver's clock: see
//! [`crate::node`].
//!
//! **Malformed frames.** [`decode`] never panics: it returns a [`WireError`] for an extended
//! id, a remote frame, an unknown id, a length other than 4, or a `NO_VALUE` frame with a
//! non-zero value; [`DecodeStats`] counts them per kind.

use embedded_can::{Frame, Id, StandardId};
use fixed::types::I16F16;

use crate::supervisor::{Lost, NodeState};

/// Identifier of the leader's frames in the default plan.
pub const LEADER_ID: u16 = IdPlan::DEFAULT.value_base();
/// Identifier of agent 1 in the default plan; agent `i` uses `AGENT_ID_BASE + i - 1`.
pub const AGENT_ID_BASE: u16 = LEADER_ID + 1;
/// Highest agent number any plan can carry.
pub const MAX_AGENT: u8 = 255;
/// Neighbour capacity `K` of every node runtime (`node-fw`, `node-linux`, host-sim's nodes):
/// the largest in-degree a scenario may give a follower, and the length of the object
/// dictionary's neighbour list.
pub const MAX_NEIGHBOURS: usize = 16;
/// Data length of a heartbeat frame.
pub const HEARTBEAT_LEN: usize = 8;
/// Highest standard identifier.
pub const MAX_STD_ID: u16 = 0x7FF;
/// Data length of every frame of this protocol.
pub const PAYLOAD_LEN: usize = 4;
/// The sequence counter counts modulo this.
pub const SEQ_MODULUS: u8 = 64;
/// The fixed-point type of `y` on the wire (only its low 24 bits are sent).
pub type WireValue = I16F16;
/// Smallest value on the wire: −128.
pub const Y_MIN: WireValue = WireValue::from_bits(-(1 << 23));
/// Largest value on the wire: 128 − 2⁻¹⁶.
pub const Y_MAX: WireValue = WireValue::from_bits((1 << 23) - 1);

const SEQ_MASK: u8 = SEQ_MODULUS - 1;
const FLAG_SATURATED: u8 = 1 << 6;
const FLAG_NO_VALUE: u8 = 1 << 7;

/// Who sent a frame.
///
/// ```
/// use agent_node::wire::Source;
/// // The leader sends y_d at 0x101, follower i its y_i at 0x101 + i.
/// assert_eq!(Source::Leader.raw_id(), Some(0x101));
/// assert_eq!(Source::Agent(4).raw_id(), Some(0x105));
/// assert_eq!(Source::from_raw_id(0x105), Some(Source::Agent(4)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// The leader (reference `y_d`).
    Leader,
    /// Follower agent `i` (1-based, as in the paper).
    Agent(u8),
}

impl Source {
    /// The raw 11-bit identifier of its value frames in the default plan; `None` for
    /// `Agent(0)` and agents beyond the plan.
    ///
    /// ```
    /// use agent_node::wire::Source;
    /// assert_eq!(Source::Agent(1).raw_id(), Some(0x102));
    /// assert_eq!(Source::Agent(0).raw_id(), None); // agents are 1-based, as in the paper
    /// assert_eq!(Source::Agent(100).raw_id(), None); // beyond the default plan's 99
    /// ```
    #[must_use]
    pub const fn raw_id(self) -> Option<u16> {
        IdPlan::DEFAULT.value_id(self)
    }

    /// The standard identifier in the default plan.
    ///
    /// ```
    /// use agent_node::wire::Source;
    /// use embedded_can::StandardId;
    /// assert_eq!(Source::Leader.id(), StandardId::new(0x101));
    /// assert_eq!(Source::Agent(0).id(), None);
    /// ```
    pub fn id(self) -> Option<StandardId> {
        self.raw_id().and_then(StandardId::new)
    }

    /// The sender of a raw 11-bit value-frame identifier of the default plan, `None` when the
    /// id is not one.
    ///
    /// ```
    /// use agent_node::wire::Source;
    /// assert_eq!(Source::from_raw_id(0x101), Some(Source::Leader));
    /// assert_eq!(Source::from_raw_id(0x782), None); // agent 1's heartbeat, not a value frame
    /// ```
    #[must_use]
    pub const fn from_raw_id(raw: u16) -> Option<Self> {
        match IdPlan::DEFAULT.classify(raw) {
            Some(FrameKind::Value(s)) => Some(s),
            _ => None,
        }
    }
}

/// What an identifier of a plan carries.
///
/// ```
/// use agent_node::wire::{FrameKind, IdPlan, Source};
/// let plan = IdPlan::DEFAULT;
/// assert_eq!(plan.classify(0x103), Some(FrameKind::Value(Source::Agent(2))));
/// assert_eq!(plan.classify(0x783), Some(FrameKind::Heartbeat(3)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameKind {
    /// A value frame of the leader or an agent.
    Value(Source),
    /// The heartbeat of agent `i`.
    Heartbeat(u8),
}

/// Where the protocol's identifiers sit: value frames at `value_base` (leader) and
/// `value_base + i` (agent `i`), heartbeats at `heartbeat_base + i`, for agents `1..=agents`.
/// Built only by [`IdPlan::new`], which checks that both blocks are 11-bit and disjoint.
///
/// ```
/// use agent_node::wire::{IdPlan, IdPlanError, Source};
/// // Ten agents moved to 0x200, heartbeats at 0x700 + i.
/// let plan = IdPlan::new(0x200, Some(0x700), 10)?;
/// assert_eq!(plan.value_id(Source::Agent(10)), Some(0x20A));
/// assert_eq!(plan.heartbeat_id(10), Some(0x70A));
/// assert_eq!(IdPlan::new(0x200, Some(0x205), 10), Err(IdPlanError::Overlap));
/// # Ok::<(), IdPlanError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdPlan {
    value_base: u16,
    heartbeat_base: Option<u16>,
    agents: u8,
}

/// Why an identifier plan was refused.
///
/// ```
/// use agent_node::wire::{IdPlan, IdPlanError};
/// assert_eq!(IdPlan::new(0x7FA, None, 10), Err(IdPlanError::ValueRange)); // beyond 0x7FF
/// let e = IdPlan::new(0x100, None, 0).unwrap_err();
/// assert_eq!(e, IdPlanError::NoAgents);
/// assert_eq!(e.to_string(), "an identifier plan needs at least one agent");
/// ```
///
/// `#[non_exhaustive]`: a plan that grows a block of identifiers brings its own check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum IdPlanError {
    /// A plan for no agent.
    NoAgents,
    /// `value_base + agents` exceeds `0x7FF`.
    ValueRange,
    /// `heartbeat_base + agents` exceeds `0x7FF`.
    HeartbeatRange,
    /// The value and heartbeat blocks share an identifier.
    Overlap,
}

impl core::fmt::Display for IdPlanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NoAgents => "an identifier plan needs at least one agent",
            Self::ValueRange => "value identifiers (base + agent) run beyond 0x7FF",
            Self::HeartbeatRange => "heartbeat identifiers (base + agent) run beyond 0x7FF",
            Self::Overlap => "value and heartbeat identifiers overlap",
        })
    }
}

impl core::error::Error for IdPlanError {}

impl IdPlan {
    /// Leader `0x101`, agents `0x102..=0x164`, heartbeats `0x781..=0x7E3`: 99 agents, clear of
    /// every CANopen predefined identifier and of LSS (`0x7E4`, `0x7E5`).
    pub const DEFAULT: Self = Self {
        value_base: 0x101,
        heartbeat_base: Some(0x780),
        agents: 99,
    };

    /// A plan for agents `1..=agents`; `heartbeat_base` `None`: no heartbeat identifiers.
    ///
    /// ```
    /// use agent_node::wire::{IdPlan, IdPlanError};
    /// assert!(IdPlan::new(0x100, None, 255).is_ok()); // no heartbeats: 0x100..=0x1FF
    /// assert_eq!(IdPlan::new(0x100, Some(0x7F0), 20), Err(IdPlanError::HeartbeatRange));
    /// ```
    pub const fn new(
        value_base: u16,
        heartbeat_base: Option<u16>,
        agents: u8,
    ) -> Result<Self, IdPlanError> {
        if agents == 0 {
            return Err(IdPlanError::NoAgents);
        }
        let n = agents as u16;
        if value_base > MAX_STD_ID - n {
            return Err(IdPlanError::ValueRange);
        }
        if let Some(hb) = heartbeat_base {
            if hb > MAX_STD_ID - n {
                return Err(IdPlanError::HeartbeatRange);
            }
            // [value_base, value_base + n] against [hb + 1, hb + n].
            if hb < value_base + n && value_base <= hb + n {
                return Err(IdPlanError::Overlap);
            }
        }
        Ok(Self {
            value_base,
            heartbeat_base,
            agents,
        })
    }

    /// The leader's identifier.
    ///
    /// ```
    /// use agent_node::wire::IdPlan;
    /// assert_eq!(IdPlan::DEFAULT.value_base(), 0x101); // the leader's identifier
    /// ```
    #[must_use]
    pub const fn value_base(&self) -> u16 {
        self.value_base
    }

    /// Agent `i`'s heartbeat is at this plus `i`; `None`: no heartbeats.
    ///
    /// ```
    /// use agent_node::wire::IdPlan;
    /// assert_eq!(IdPlan::DEFAULT.heartbeat_base(), Some(0x780));
    /// assert_eq!(IdPlan::new(0x100, None, 8)?.heartbeat_base(), None);
    /// # Ok::<(), agent_node::wire::IdPlanError>(())
    /// ```
    #[must_use]
    pub const fn heartbeat_base(&self) -> Option<u16> {
        self.heartbeat_base
    }

    /// Agents `1..=agents()` have identifiers.
    ///
    /// ```
    /// use agent_node::wire::IdPlan;
    /// assert_eq!(IdPlan::DEFAULT.agents(), 99);
    /// ```
    #[must_use]
    pub const fn agents(&self) -> u8 {
        self.agents
    }

    /// The value-frame identifier of `source`; `None` for agent 0 or beyond the plan.
    ///
    /// ```
    /// use agent_node::wire::{IdPlan, Source};
    /// let plan = IdPlan::new(0x300, None, 4)?;
    /// assert_eq!(plan.value_id(Source::Leader), Some(0x300));
    /// assert_eq!(plan.value_id(Source::Agent(4)), Some(0x304));
    /// assert_eq!(plan.value_id(Source::Agent(5)), None);
    /// # Ok::<(), agent_node::wire::IdPlanError>(())
    /// ```
    #[must_use]
    pub const fn value_id(&self, source: Source) -> Option<u16> {
        match source {
            Source::Leader => Some(self.value_base),
            Source::Agent(0) => None,
            Source::Agent(i) if i > self.agents => None,
            Source::Agent(i) => Some(self.value_base + i as u16),
        }
    }

    /// Agent `agent`'s heartbeat identifier; `None` without heartbeats, for agent 0 or
    /// beyond the plan.
    ///
    /// ```
    /// use agent_node::wire::IdPlan;
    /// assert_eq!(IdPlan::DEFAULT.heartbeat_id(1), Some(0x781));
    /// assert_eq!(IdPlan::DEFAULT.heartbeat_id(0), None);
    /// ```
    #[must_use]
    pub const fn heartbeat_id(&self, agent: u8) -> Option<u16> {
        match self.heartbeat_base {
            Some(hb) if agent != 0 && agent <= self.agents => Some(hb + agent as u16),
            _ => None,
        }
    }

    /// What `raw` carries in this plan; `None`: not one of its identifiers.
    ///
    /// ```
    /// use agent_node::wire::{FrameKind, IdPlan, Source};
    /// let plan = IdPlan::DEFAULT;
    /// assert_eq!(plan.classify(0x101), Some(FrameKind::Value(Source::Leader)));
    /// assert_eq!(plan.classify(0x000), None); // NMT: not this protocol's
    /// ```
    #[must_use]
    pub const fn classify(&self, raw: u16) -> Option<FrameKind> {
        let n = self.agents as u16;
        if raw >= self.value_base && raw <= self.value_base + n {
            return Some(FrameKind::Value(if raw == self.value_base {
                Source::Leader
            } else {
                Source::Agent((raw - self.value_base) as u8)
            }));
        }
        match self.heartbeat_base {
            Some(hb) if raw > hb && raw <= hb + n => Some(FrameKind::Heartbeat((raw - hb) as u8)),
            _ => None,
        }
    }
}

impl Default for IdPlan {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One decoded frame.
///
/// ```
/// use agent_node::wire::{decode_payload, encode_payload, Message, Source};
/// // A leader value above the Q7.16 range: sent clamped, flagged saturated.
/// let m: Message = decode_payload(Source::Leader, &encode_payload(200.0, 3).data)?;
/// assert_eq!((m.seq, m.saturated), (3, true));
/// assert!(m.y.unwrap() < 128.0);
/// # Ok::<(), agent_node::wire::WireError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Message {
    /// Sender.
    pub source: Source,
    /// The sender's output (`y_i` or `y_d`); `None` when the sender flagged `NO_VALUE`.
    pub y: Option<f32>,
    /// Sequence counter, `0..64`.
    pub seq: u8,
    /// The sender clamped `y` to the wire range.
    pub saturated: bool,
}

/// Why a frame was rejected.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{decode, WireError};
/// use embedded_can::{Frame, StandardId};
/// // Agent 1's identifier with 3 data bytes instead of 4.
/// let f = CanFrame::new(StandardId::new(0x102).unwrap(), &[0, 0, 0]).unwrap();
/// let e = decode(&f).unwrap_err();
/// assert_eq!(e, WireError::WrongLength(3));
/// assert_eq!(e.to_string(), "3 data bytes where the frame has 4");
/// ```
///
/// `#[non_exhaustive]`: each new frame kind may bring its own way of being malformed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum WireError {
    /// 29-bit identifier: this protocol uses standard ids only.
    ExtendedId,
    /// Remote transmission request: this protocol sends data frames only.
    Remote,
    /// A standard id that is none of the plan's.
    UnknownId(u16),
    /// Data length other than [`PAYLOAD_LEN`].
    WrongLength(u8),
    /// `NO_VALUE` set with non-zero value bytes; a heartbeat with an unknown state or lost bit.
    BadPayload,
}

impl core::fmt::Display for WireError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ExtendedId => f.write_str("a 29-bit identifier (the protocol uses 11-bit ones)"),
            Self::Remote => f.write_str("a remote frame (the protocol sends data frames only)"),
            Self::UnknownId(id) => write!(f, "identifier {id:#05x} is none of the plan's"),
            Self::WrongLength(n) => write!(f, "{n} data bytes where the frame has {PAYLOAD_LEN}"),
            Self::BadPayload => f.write_str("a payload that breaks the frame's layout"),
        }
    }
}

impl core::error::Error for WireError {}

/// Counts of rejected frames, per kind.
///
/// ```
/// use agent_node::wire::{DecodeStats, WireError};
/// let mut st = DecodeStats::default();
/// st.record(WireError::UnknownId(0x600));
/// st.record(WireError::Remote);
/// assert_eq!((st.unknown_id, st.remote, st.total()), (1, 1, 2));
/// ```
///
/// `#[non_exhaustive]`: one counter per [`WireError`], which grows too; read field by field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct DecodeStats {
    /// [`WireError::ExtendedId`].
    pub extended_id: u32,
    /// [`WireError::Remote`].
    pub remote: u32,
    /// [`WireError::UnknownId`].
    pub unknown_id: u32,
    /// [`WireError::WrongLength`].
    pub wrong_length: u32,
    /// [`WireError::BadPayload`].
    pub bad_payload: u32,
}

impl DecodeStats {
    /// Count one rejection.
    ///
    /// ```
    /// use agent_node::wire::{DecodeStats, WireError};
    /// let mut st = DecodeStats::default();
    /// st.record(WireError::BadPayload);
    /// assert_eq!(st.bad_payload, 1);
    /// ```
    pub fn record(&mut self, e: WireError) {
        let c = match e {
            WireError::ExtendedId => &mut self.extended_id,
            WireError::Remote => &mut self.remote,
            WireError::UnknownId(_) => &mut self.unknown_id,
            WireError::WrongLength(_) => &mut self.wrong_length,
            WireError::BadPayload => &mut self.bad_payload,
        };
        *c = c.saturating_add(1);
    }

    /// All rejected frames.
    ///
    /// ```
    /// use agent_node::wire::{DecodeStats, WireError};
    /// let mut st = DecodeStats::default();
    /// st.record(WireError::WrongLength(3));
    /// st.record(WireError::UnknownId(0x7FF));
    /// st.record(WireError::WrongLength(8));
    /// assert_eq!((st.wrong_length, st.total()), (2, 3));
    /// ```
    #[must_use]
    pub fn total(&self) -> u32 {
        self.extended_id
            .saturating_add(self.remote)
            .saturating_add(self.unknown_id)
            .saturating_add(self.wrong_length)
            .saturating_add(self.bad_payload)
    }
}

/// The payload of one value, and whether it had to be clamped.
///
/// ```
/// use agent_node::wire::encode_payload;
/// let e = encode_payload(f32::NAN, 1); // a failed sensor: NO_VALUE, never a NaN on the wire
/// assert!(e.no_value && !e.saturated);
/// assert_eq!(e.data, [0, 0, 0, 0x81]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Encoded {
    /// The four payload bytes.
    pub data: [u8; PAYLOAD_LEN],
    /// `y` was out of range and was clamped.
    pub saturated: bool,
    /// `y` was NaN or infinite and was sent as `NO_VALUE`.
    pub no_value: bool,
}

/// `y` as the wire's Q7.16 value: rounded to the nearest multiple of 2⁻¹⁶, clamped to
/// [[`Y_MIN`], [`Y_MAX`]] (`true` when clamped). `None` for NaN and ±∞.
///
/// ```
/// use agent_node::wire::quantize;
/// assert_eq!(quantize(0.5), Some((0.5, false)));
/// assert_eq!(quantize(1000.0), Some((128.0 - 1.0 / 65536.0, true)));
/// assert_eq!(quantize(f32::NAN), None);
/// ```
#[must_use]
pub fn quantize(y: f32) -> Option<(f32, bool)> {
    let (v, sat) = to_wire(y)?;
    Some((v.to_num(), sat))
}

fn to_wire(y: f32) -> Option<(WireValue, bool)> {
    if !y.is_finite() {
        return None;
    }
    let v = WireValue::saturating_from_num(y);
    let clamped = v.clamp(Y_MIN, Y_MAX);
    let out_of_range =
        y > Y_MAX.to_num::<f32>() + 0.5 / 65536.0 || y < Y_MIN.to_num::<f32>() - 0.5 / 65536.0;
    Some((clamped, out_of_range || clamped != v))
}

/// The payload for `y` with sequence counter `seq` (taken modulo 64).
///
/// ```
/// use agent_node::wire::encode_payload;
/// // y = 1.0 is 0x010000 in Q7.16 (little-endian), then the flags byte with the counter.
/// assert_eq!(encode_payload(1.0, 5).data, [0x00, 0x00, 0x01, 5]);
/// assert_eq!(encode_payload(1.0, 69).data[3], 5); // counter modulo 64
/// ```
#[must_use]
pub fn encode_payload(y: f32, seq: u8) -> Encoded {
    let mut flags = seq & SEQ_MASK;
    let (bits, saturated, no_value) = match to_wire(y) {
        Some((v, sat)) => (v.to_bits(), sat, false),
        None => (0, false, true),
    };
    if saturated {
        flags |= FLAG_SATURATED;
    }
    if no_value {
        flags |= FLAG_NO_VALUE;
    }
    let b = bits.to_le_bytes();
    Encoded {
        data: [b[0], b[1], b[2], flags],
        saturated,
        no_value,
    }
}

/// A frame from `source` carrying `y` and `seq` under the default plan, built through the
/// `embedded-can` [`Frame`] constructor of the caller's frame type. `None` if `source` has no
/// id (agent 0, or beyond the plan) or the frame type refuses a 4-byte data frame.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{decode, encode, Source};
/// let (f, enc) = encode::<CanFrame>(Source::Agent(2), -0.75, 9).unwrap();
/// assert_eq!(f.raw_id(), 0x103);
/// assert!(!enc.saturated);
/// assert_eq!(decode(&f)?.y, Some(-0.75));
/// assert!(encode::<CanFrame>(Source::Agent(0), 0.0, 0).is_none());
/// # Ok::<(), agent_node::wire::WireError>(())
/// ```
#[must_use]
pub fn encode<F: Frame>(source: Source, y: f32, seq: u8) -> Option<(F, Encoded)> {
    encode_in(&IdPlan::DEFAULT, source, y, seq)
}

/// Decode a payload (after the identifier was checked).
///
/// ```
/// use agent_node::wire::{decode_payload, Source, WireError};
/// // NO_VALUE with non-zero value bytes breaks the layout.
/// assert_eq!(decode_payload(Source::Leader, &[1, 0, 0, 0x80]), Err(WireError::BadPayload));
/// assert_eq!(decode_payload(Source::Leader, &[0, 0, 0, 0x80])?.y, None);
/// # Ok::<(), WireError>(())
/// ```
pub fn decode_payload(source: Source, data: &[u8]) -> Result<Message, WireError> {
    let [b0, b1, b2, flags] = *data else {
        return Err(WireError::WrongLength(
            u8::try_from(data.len()).unwrap_or(u8::MAX),
        ));
    };
    let no_value = flags & FLAG_NO_VALUE != 0;
    let y = if no_value {
        if b0 | b1 | b2 != 0 {
            return Err(WireError::BadPayload);
        }
        None
    } else {
        // Sign-extend the 24-bit value.
        let bits = i32::from_le_bytes([0, b0, b1, b2]) >> 8;
        Some(WireValue::from_bits(bits).to_num::<f32>())
    };
    Ok(Message {
        source,
        y,
        seq: flags & SEQ_MASK,
        saturated: flags & FLAG_SATURATED != 0,
    })
}

/// Decode a value frame of the default plan ([`IdPlan::DEFAULT`]; its heartbeats are
/// [`WireError::UnknownId`] here, see [`decode_in`]). Never panics.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{decode, WireError};
/// use embedded_can::{ExtendedId, Frame, StandardId};
/// let remote = CanFrame::new_remote(StandardId::new(0x101).unwrap(), 4).unwrap();
/// assert_eq!(decode(&remote), Err(WireError::Remote));
/// let ext = CanFrame::new(ExtendedId::new(0x101).unwrap(), &[0; 4]).unwrap();
/// assert_eq!(decode(&ext), Err(WireError::ExtendedId));
/// ```
pub fn decode<F: Frame>(frame: &F) -> Result<Message, WireError> {
    if let Some(raw) = raw_std_id(frame) {
        if let Some(FrameKind::Heartbeat(_)) = IdPlan::DEFAULT.classify(raw) {
            return Err(WireError::UnknownId(raw));
        }
    }
    match decode_in(&IdPlan::DEFAULT, frame)? {
        Decoded::Value(m) => Ok(m),
        Decoded::Heartbeat { .. } => Err(WireError::UnknownId(raw_std_id(frame).unwrap_or(0))),
    }
}

fn raw_std_id<F: Frame>(frame: &F) -> Option<u16> {
    match frame.id() {
        Id::Standard(s) => Some(s.as_raw()),
        Id::Extended(_) => None,
    }
}

/// A frame of the protocol, decoded.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{decode_in, encode_heartbeat, Decoded, Heartbeat, IdPlan};
/// use agent_node::{supervisor::Lost, NodeState};
/// let hb = Heartbeat { state: NodeState::Safe, lost: Lost::from_bits(Lost::LEADER),
///     boot_count: 1, overruns: 0, safe_entries: 1 };
/// let f: CanFrame = encode_heartbeat(&IdPlan::DEFAULT, 3, &hb).unwrap();
/// assert_eq!(decode_in(&IdPlan::DEFAULT, &f), Ok(Decoded::Heartbeat { agent: 3, heartbeat: hb }));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Decoded {
    /// A value frame.
    Value(Message),
    /// A heartbeat.
    Heartbeat {
        /// Sender.
        agent: u8,
        /// Its content.
        heartbeat: Heartbeat,
    },
}

/// Decode any `embedded-can` frame under `plan`. Never panics.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{decode_in, encode_in, Decoded, IdPlan, Source, WireError};
/// let plan = IdPlan::new(0x200, None, 4).unwrap();
/// let (f, _) = encode_in::<CanFrame>(&plan, Source::Agent(4), 0.5, 0).unwrap();
/// let Ok(Decoded::Value(m)) = decode_in(&plan, &f) else { panic!() };
/// assert_eq!((m.source, m.y), (Source::Agent(4), Some(0.5)));
/// // The same frame under the default plan is none of its identifiers.
/// assert_eq!(decode_in(&IdPlan::DEFAULT, &f), Err(WireError::UnknownId(0x204)));
/// ```
pub fn decode_in<F: Frame>(plan: &IdPlan, frame: &F) -> Result<Decoded, WireError> {
    let raw = raw_std_id(frame).ok_or(WireError::ExtendedId)?;
    if frame.is_remote_frame() {
        return Err(WireError::Remote);
    }
    let data = frame.data();
    let wrong_length = || WireError::WrongLength(u8::try_from(data.len()).unwrap_or(u8::MAX));
    match plan.classify(raw).ok_or(WireError::UnknownId(raw))? {
        FrameKind::Value(source) => {
            if data.len() != PAYLOAD_LEN {
                return Err(wrong_length());
            }
            decode_payload(source, data).map(Decoded::Value)
        }
        FrameKind::Heartbeat(agent) => {
            let b: &[u8; HEARTBEAT_LEN] = data.try_into().map_err(|_| wrong_length())?;
            Heartbeat::from_bytes(b).map(|heartbeat| Decoded::Heartbeat { agent, heartbeat })
        }
    }
}

/// A value frame from `source` under `plan` (see [`encode`]).
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{encode_in, IdPlan, Source};
/// let plan = IdPlan::new(0x200, None, 4).unwrap();
/// let (f, _) = encode_in::<CanFrame>(&plan, Source::Leader, 1.0, 0).unwrap();
/// assert_eq!(f.raw_id(), 0x200);
/// assert!(encode_in::<CanFrame>(&plan, Source::Agent(5), 1.0, 0).is_none()); // beyond the plan
/// ```
#[must_use]
pub fn encode_in<F: Frame>(plan: &IdPlan, source: Source, y: f32, seq: u8) -> Option<(F, Encoded)> {
    let id = StandardId::new(plan.value_id(source)?)?;
    let enc = encode_payload(y, seq);
    F::new(id, &enc.data).map(|f| (f, enc))
}

/// What a node says about itself in its heartbeat (DLC 8, little-endian):
///
/// ```text
/// byte 0     state: 0 operational, 1 boot, 2 safe, 3 fault (NodeState::code)
/// byte 1     lost sources: bit 0 leader, bit 1 neighbours, bit 2 sensor; bits 3..7 zero
/// byte 2..3  boot counter (0 when the board keeps none)
/// byte 4..5  deadline overruns since start (saturating)
/// byte 6..7  safe-state entries since start (saturating)
/// ```
///
/// ```
/// use agent_node::wire::Heartbeat;
/// use agent_node::{supervisor::Lost, NodeState};
/// let hb = Heartbeat { state: NodeState::Operational, lost: Lost::default(), boot_count: 2,
///     overruns: 300, safe_entries: 0 };
/// assert_eq!(hb.to_bytes(), [0, 0, 2, 0, 44, 1, 0, 0]);
/// assert_eq!(Heartbeat::from_bytes(&hb.to_bytes()), Ok(hb));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Heartbeat {
    /// The node's state.
    pub state: NodeState,
    /// Supervised sources lost.
    pub lost: Lost,
    /// Resets or boots counted by the board.
    pub boot_count: u16,
    /// Deadline overruns.
    pub overruns: u16,
    /// Safe-state entries.
    pub safe_entries: u16,
}

impl Heartbeat {
    /// The payload.
    ///
    /// ```
    /// use agent_node::wire::Heartbeat;
    /// use agent_node::{supervisor::Lost, NodeState};
    /// let hb = Heartbeat { state: NodeState::Safe, lost: Lost::from_bits(Lost::SENSOR),
    ///     boot_count: 0, overruns: 0, safe_entries: 3 };
    /// assert_eq!(hb.to_bytes(), [2, 4, 0, 0, 0, 0, 3, 0]);
    /// ```
    #[must_use]
    pub fn to_bytes(&self) -> [u8; HEARTBEAT_LEN] {
        let [b0, b1] = self.boot_count.to_le_bytes();
        let [o0, o1] = self.overruns.to_le_bytes();
        let [s0, s1] = self.safe_entries.to_le_bytes();
        [self.state.code(), self.lost.bits(), b0, b1, o0, o1, s0, s1]
    }

    /// The heartbeat of a payload; [`WireError::BadPayload`] for an unknown state or lost bit.
    ///
    /// ```
    /// use agent_node::wire::{Heartbeat, WireError};
    /// assert_eq!(Heartbeat::from_bytes(&[4, 0, 0, 0, 0, 0, 0, 0]), Err(WireError::BadPayload)); // state 4
    /// assert_eq!(Heartbeat::from_bytes(&[0, 8, 0, 0, 0, 0, 0, 0]), Err(WireError::BadPayload)); // lost bit 3
    /// assert!(Heartbeat::from_bytes(&[3, 7, 0, 0, 0, 0, 0, 0]).is_ok());
    /// ```
    pub fn from_bytes(b: &[u8; HEARTBEAT_LEN]) -> Result<Self, WireError> {
        let state = NodeState::from_code(b[0]).ok_or(WireError::BadPayload)?;
        let lost = Lost::from_bits(b[1]);
        if lost.bits() != b[1] {
            return Err(WireError::BadPayload);
        }
        let u16_at = |k: usize| u16::from_le_bytes([b[k], b[k + 1]]);
        Ok(Self {
            state,
            lost,
            boot_count: u16_at(2),
            overruns: u16_at(4),
            safe_entries: u16_at(6),
        })
    }
}

/// Agent `agent`'s heartbeat frame under `plan`; `None` when the plan has no heartbeat id for it.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::wire::{encode_heartbeat, Heartbeat, IdPlan};
/// use agent_node::{supervisor::Lost, NodeState};
/// let hb = Heartbeat { state: NodeState::Boot, lost: Lost::default(), boot_count: 0,
///     overruns: 0, safe_entries: 0 };
/// let f: CanFrame = encode_heartbeat(&IdPlan::DEFAULT, 7, &hb).unwrap();
/// assert_eq!(f.raw_id(), 0x787);
/// let no_hb = IdPlan::new(0x100, None, 8).unwrap();
/// assert!(encode_heartbeat::<CanFrame>(&no_hb, 7, &hb).is_none());
/// ```
#[must_use]
pub fn encode_heartbeat<F: Frame>(plan: &IdPlan, agent: u8, hb: &Heartbeat) -> Option<F> {
    F::new(StandardId::new(plan.heartbeat_id(agent)?)?, &hb.to_bytes())
}

/// How a received sequence counter relates to the last accepted one of a fresh link.
///
/// ```
/// use agent_node::wire::{seq_check, SeqCheck};
/// // Counters 10 then 13: two frames (11, 12) never seen.
/// assert_eq!(seq_check(10, 13), SeqCheck::Newer { skipped: 2 });
/// assert_eq!(seq_check(10, 10), SeqCheck::Repeated);
/// assert_eq!(seq_check(10, 9), SeqCheck::Older);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SeqCheck {
    /// Newer: accept; `skipped` counters in between were never seen (lost or late).
    Newer {
        /// Counters missed between the two.
        skipped: u8,
    },
    /// The same counter again: a repeated frame.
    Repeated,
    /// Behind the last accepted one: a late, out-of-order frame.
    Older,
}

/// Compare `new` with the `last` accepted counter, modulo 64: 1..=31 ahead is newer,
/// 0 is a repeat, 32..=63 ahead (i.e. 1..=32 behind) is older.
///
/// ```
/// use agent_node::wire::{seq_check, SeqCheck};
/// assert_eq!(seq_check(5, 6), SeqCheck::Newer { skipped: 0 });
/// assert_eq!(seq_check(63, 1), SeqCheck::Newer { skipped: 1 });
/// assert_eq!(seq_check(6, 6), SeqCheck::Repeated);
/// assert_eq!(seq_check(6, 5), SeqCheck::Older);
/// ```
#[must_use]
pub fn seq_check(last: u8, new: u8) -> SeqCheck {
    let d = new.wrapping_sub(last) & SEQ_MASK;
    match d {
        0 => SeqCheck::Repeated,
        d if d < SEQ_MODULUS / 2 => SeqCheck::Newer { skipped: d - 1 },
        _ => SeqCheck::Older,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip() {
        assert_eq!(Source::from_raw_id(0x101), Some(Source::Leader));
        assert_eq!(Source::from_raw_id(0x102), Some(Source::Agent(1)));
        assert_eq!(Source::from_raw_id(0x164), Some(Source::Agent(99)));
        assert_eq!(Source::from_raw_id(0x165), None);
        assert_eq!(Source::from_raw_id(0x100), None);
        assert_eq!(Source::from_raw_id(0x781), None);
        assert_eq!(Source::Agent(0).raw_id(), None);
        assert_eq!(Source::Agent(100).raw_id(), None);
        let legacy = IdPlan::new(0x100, None, 255).expect("valid");
        for plan in [IdPlan::DEFAULT, legacy] {
            for i in 1..=plan.agents() {
                let raw = plan.value_id(Source::Agent(i)).expect("in plan");
                assert_eq!(plan.classify(raw), Some(FrameKind::Value(Source::Agent(i))));
                if let Some(hb) = plan.heartbeat_id(i) {
                    assert_eq!(plan.classify(hb), Some(FrameKind::Heartbeat(i)));
                }
            }
        }
        assert_eq!(legacy.value_id(Source::Agent(255)), Some(0x1FF));
        assert_eq!(legacy.heartbeat_id(1), None);
        assert_eq!(IdPlan::DEFAULT.heartbeat_id(99), Some(0x7E3));
        assert_eq!(IdPlan::DEFAULT.heartbeat_id(100), None);
    }

    #[test]
    fn plans_outside_11_bits_or_overlapping_are_refused() {
        assert_eq!(IdPlan::new(0x101, None, 0), Err(IdPlanError::NoAgents));
        assert_eq!(IdPlan::new(0x701, None, 255), Err(IdPlanError::ValueRange));
        assert!(IdPlan::new(0x700, None, 255)
            .is_ok_and(|p| p.value_id(Source::Agent(255)) == Some(0x7FF)));
        assert_eq!(
            IdPlan::new(0x101, Some(0x780), 128),
            Err(IdPlanError::HeartbeatRange)
        );
        assert!(IdPlan::new(0x101, Some(0x780), 127).is_ok());
        assert_eq!(
            IdPlan::new(0x101, Some(0x100), 4),
            Err(IdPlanError::Overlap)
        );
        assert_eq!(
            IdPlan::new(0x101, Some(0x104), 4),
            Err(IdPlanError::Overlap)
        );
        assert!(IdPlan::new(0x101, Some(0x105), 4).is_ok());
        assert!(IdPlan::new(0x106, Some(0x101), 4).is_ok());
        assert_eq!(
            IdPlan::new(0x105, Some(0x101), 4),
            Err(IdPlanError::Overlap)
        );
    }

    #[test]
    fn heartbeats_round_trip_and_bad_ones_are_refused() {
        let hb = Heartbeat {
            state: NodeState::Safe,
            lost: Lost::from_bits(Lost::LEADER | Lost::SENSOR),
            boot_count: 513,
            overruns: 7,
            safe_entries: 65535,
        };
        let plan = IdPlan::DEFAULT;
        let f: crate::link::CanFrame = encode_heartbeat(&plan, 3, &hb).expect("in plan");
        assert_eq!(f.raw_id(), 0x783);
        assert_eq!(f.data(), &[2, 5, 1, 2, 7, 0, 255, 255]);
        assert_eq!(
            decode_in(&plan, &f),
            Ok(Decoded::Heartbeat {
                agent: 3,
                heartbeat: hb
            })
        );
        assert_eq!(decode(&f), Err(WireError::UnknownId(0x783)));
        let mut bad = hb.to_bytes();
        bad[0] = 4;
        assert_eq!(Heartbeat::from_bytes(&bad), Err(WireError::BadPayload));
        let mut bad = hb.to_bytes();
        bad[1] = 8;
        assert_eq!(Heartbeat::from_bytes(&bad), Err(WireError::BadPayload));
        let short = crate::link::CanFrame::new(StandardId::new(0x783).expect("id"), &[0; 4])
            .expect("frame");
        assert_eq!(decode_in(&plan, &short), Err(WireError::WrongLength(4)));
        assert_eq!(
            encode_heartbeat::<crate::link::CanFrame>(
                &IdPlan::new(0x101, None, 4).expect("valid"),
                3,
                &hb
            ),
            None
        );
    }

    #[test]
    fn a_moved_plan_carries_the_same_payload() {
        let moved = IdPlan::new(0x020, Some(0x680), 8).expect("valid");
        let (f, _): (crate::link::CanFrame, _) =
            encode_in(&moved, Source::Agent(2), 0.5, 9).expect("frame");
        let (g, _): (crate::link::CanFrame, _) = encode(Source::Agent(2), 0.5, 9).expect("frame");
        assert_eq!(f.raw_id(), 0x022);
        assert_eq!(f.data(), g.data());
        assert!(
            matches!(decode_in(&moved, &f), Ok(Decoded::Value(m)) if m.source == Source::Agent(2))
        );
        assert_eq!(
            decode_in(&IdPlan::DEFAULT, &f),
            Err(WireError::UnknownId(0x022))
        );
    }

    #[test]
    fn payload_round_trip_and_saturation() {
        for &y in &[0.0f32, 0.6, -0.6, 1.234_567, -127.9, 127.99] {
            let e = encode_payload(y, 70);
            let m = decode_payload(Source::Agent(3), &e.data).expect("valid");
            let back = m.y.expect("value");
            assert!(
                (back - y).abs() <= 0.5 / 65536.0 + 1e-6 * y.abs(),
                "{y} -> {back}"
            );
            assert_eq!(m.seq, 70 % 64);
            assert!(!m.saturated);
        }
        let e = encode_payload(300.0, 1);
        assert!(e.saturated);
        let m = decode_payload(Source::Leader, &e.data).expect("valid");
        assert_eq!(m.y, Some(Y_MAX.to_num()));
        assert!(m.saturated);
        let e = encode_payload(-1e30, 1);
        let m = decode_payload(Source::Leader, &e.data).expect("valid");
        assert_eq!(m.y, Some(-128.0));
        let e = encode_payload(f32::NAN, 2);
        assert!(e.no_value);
        let m = decode_payload(Source::Leader, &e.data).expect("valid");
        assert_eq!(m.y, None);
        assert_eq!(
            decode_payload(Source::Leader, &[1, 0, 0, 0x80]),
            Err(WireError::BadPayload)
        );
        assert_eq!(
            decode_payload(Source::Leader, &[1, 0, 0]),
            Err(WireError::WrongLength(3))
        );
    }
}
