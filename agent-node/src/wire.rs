//! The frame codec: identifiers, the `fixed` payload, sequence counters.
//!
//! ## Identifiers (11-bit standard ids; lower id = higher arbitration priority)
//!
//! | sender            | identifier                 |
//! |-------------------|----------------------------|
//! | leader (`y_d`)    | [`LEADER_ID`] = `0x100`    |
//! | agent `i` (1..=255) | `0x100 + i` (`0x101..=0x1FF`) |
//!
//! The leader, the root of the spanning tree, wins arbitration against every agent; agent 1
//! against agents 2.., and so on. Every other identifier is *unknown* and rejected by
//! [`decode`]; ids below `0x100` stay free for higher-priority traffic (a babbling node in the
//! bus tests uses `0x000`).
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

/// Identifier of the leader's frames.
pub const LEADER_ID: u16 = 0x100;
/// Identifier of agent 1; agent `i` uses `AGENT_ID_BASE + i - 1`.
pub const AGENT_ID_BASE: u16 = 0x101;
/// Highest agent number that has an identifier.
pub const MAX_AGENT: u8 = 255;
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// The leader (reference `y_d`).
    Leader,
    /// Follower agent `i` (1-based, as in the paper).
    Agent(u8),
}

impl Source {
    /// The raw 11-bit identifier; `None` for `Agent(0)`.
    pub const fn raw_id(self) -> Option<u16> {
        match self {
            Self::Leader => Some(LEADER_ID),
            Self::Agent(0) => None,
            Self::Agent(i) => Some(AGENT_ID_BASE + i as u16 - 1),
        }
    }

    /// The standard identifier; `None` for `Agent(0)`.
    pub fn id(self) -> Option<StandardId> {
        self.raw_id().and_then(StandardId::new)
    }

    /// The sender of a raw 11-bit identifier, `None` when the id is not ours.
    pub const fn from_raw_id(raw: u16) -> Option<Self> {
        if raw == LEADER_ID {
            Some(Self::Leader)
        } else if raw >= AGENT_ID_BASE && raw < AGENT_ID_BASE + MAX_AGENT as u16 {
            Some(Self::Agent((raw - AGENT_ID_BASE + 1) as u8))
        } else {
            None
        }
    }
}

/// One decoded frame.
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WireError {
    /// 29-bit identifier: this protocol uses standard ids only.
    ExtendedId,
    /// Remote transmission request: this protocol sends data frames only.
    Remote,
    /// A standard id that is neither the leader's nor an agent's.
    UnknownId(u16),
    /// Data length other than [`PAYLOAD_LEN`].
    WrongLength(u8),
    /// `NO_VALUE` set with non-zero value bytes.
    BadPayload,
}

/// Counts of rejected frames, per kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
    pub fn total(&self) -> u32 {
        self.extended_id
            .saturating_add(self.remote)
            .saturating_add(self.unknown_id)
            .saturating_add(self.wrong_length)
            .saturating_add(self.bad_payload)
    }
}

/// The payload of one value, and whether it had to be clamped.
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

/// A frame from `source` carrying `y` and `seq`, built through the `embedded-can` [`Frame`]
/// constructor of the caller's frame type. `None` if `source` has no id (agent 0) or the frame
/// type refuses a 4-byte data frame.
pub fn encode<F: Frame>(source: Source, y: f32, seq: u8) -> Option<(F, Encoded)> {
    let id = source.id()?;
    let enc = encode_payload(y, seq);
    F::new(id, &enc.data).map(|f| (f, enc))
}

/// Decode a payload (after the identifier was checked).
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

/// Decode any `embedded-can` frame. Never panics.
pub fn decode<F: Frame>(frame: &F) -> Result<Message, WireError> {
    let raw = match frame.id() {
        Id::Standard(s) => s.as_raw(),
        Id::Extended(_) => return Err(WireError::ExtendedId),
    };
    if frame.is_remote_frame() {
        return Err(WireError::Remote);
    }
    let source = Source::from_raw_id(raw).ok_or(WireError::UnknownId(raw))?;
    let data = frame.data();
    if data.len() != PAYLOAD_LEN {
        return Err(WireError::WrongLength(
            u8::try_from(data.len()).unwrap_or(u8::MAX),
        ));
    }
    decode_payload(source, data)
}

/// How a received sequence counter relates to the last accepted one of a fresh link.
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
        assert_eq!(Source::from_raw_id(0x100), Some(Source::Leader));
        assert_eq!(Source::from_raw_id(0x101), Some(Source::Agent(1)));
        assert_eq!(Source::from_raw_id(0x1FF), Some(Source::Agent(255)));
        assert_eq!(Source::from_raw_id(0x200), None);
        assert_eq!(Source::from_raw_id(0x0FF), None);
        assert_eq!(Source::Agent(0).raw_id(), None);
        for i in 1..=255u8 {
            let raw = Source::Agent(i).raw_id();
            assert_eq!(raw.and_then(Source::from_raw_id), Some(Source::Agent(i)));
        }
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
