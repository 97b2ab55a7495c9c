//! The frames between a node and a host that simulates its plant on the same CAN bus
//! (`[network] kind = "socketcan"`): the host's sensor frames and the node's command frames.
//! Standard 11-bit identifiers, one per agent:
//!
//! | frame    | sender → receiver | identifier (agent `i`) | payload |
//! |----------|-------------------|------------------------|---------|
//! | sensor   | host → node `i`   | [`SENSOR_BASE`] `+ i` = `0x201..=0x2FF`  | `x_{i,1}`, `x_{i,2}`: `f32` LE each (8 bytes) |
//! | command  | node `i` → host   | [`COMMAND_BASE`] `+ i` = `0x301..=0x3FF` | `q_{i,1}`, `q_{i,2}`: `f32` LE each (8 bytes) |
//!
//! The value frames of [`crate::wire`] (`0x100..=0x1FF`) win arbitration against both;
//! sensor frames against commands, so a sample's state is on the bus before the commands it
//! causes. The `f32` payloads carry exactly the values the simulated nodes of `kind = "can"`
//! read and write. What a node is doing is said by CANopen (CiA 301, [`crate::canopen`]): its
//! NMT state in the heartbeat at `0x700 + i`, the host's silence by EMCY `0x8250`
//! ([`crate::canopen::Fault::HostLost`]); the host ends a run with an NMT stop. An identifier
//! plan (`crate::wire::IdPlan`) must keep its blocks clear of `0x200..=0x3FF`.

use embedded_can::{Frame, Id, StandardId};

/// Identifier of agent `i`'s sensor frame: `SENSOR_BASE + i`.
pub const SENSOR_BASE: u16 = 0x200;
/// Identifier of agent `i`'s command frame: `COMMAND_BASE + i`.
pub const COMMAND_BASE: u16 = 0x300;
/// Data length of sensor and command frames.
pub const PAIR_LEN: usize = 8;

/// The kind of a plant-bus frame.
///
/// ```
/// use agent_node::plant_bus::Kind;
/// // Agent 3's sensor and command frames.
/// let ids = [Kind::Sensor, Kind::Command].map(|k| k.id(3).unwrap().as_raw());
/// assert_eq!(ids, [0x203, 0x303]);
/// assert_eq!(Kind::classify(0x303), Some((Kind::Command, 3)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// host → node: the agent's state `x_i`.
    Sensor,
    /// node → host: the agent's quantized commands `q_i`.
    Command,
}

impl Kind {
    const fn base(self) -> u16 {
        match self {
            Self::Sensor => SENSOR_BASE,
            Self::Command => COMMAND_BASE,
        }
    }

    /// The identifier of agent `agent`'s frame of this kind; `None` for agent 0.
    ///
    /// ```
    /// use agent_node::plant_bus::Kind;
    /// assert_eq!(Kind::Sensor.id(1).map(|i| i.as_raw()), Some(0x201));
    /// assert_eq!(Kind::Sensor.id(0), None);
    /// ```
    #[must_use]
    pub fn id(self, agent: u8) -> Option<StandardId> {
        if agent == 0 {
            return None;
        }
        StandardId::new(self.base() + u16::from(agent))
    }

    /// The kind and agent of a raw 11-bit identifier, `None` when it is not a plant-bus frame.
    ///
    /// ```
    /// use agent_node::plant_bus::Kind;
    /// assert_eq!(Kind::classify(0x3FF), Some((Kind::Command, 255)));
    /// assert_eq!(Kind::classify(0x403), None); // no plant-bus frame: status is CANopen's
    /// assert_eq!(Kind::classify(0x101), None); // the leader's value frame
    /// assert_eq!(Kind::classify(0x200), None); // agent 0
    /// ```
    #[must_use]
    pub const fn classify(raw: u16) -> Option<(Self, u8)> {
        let kind = match raw & 0x700 {
            SENSOR_BASE => Self::Sensor,
            COMMAND_BASE => Self::Command,
            _ => return None,
        };
        match (raw & 0xFF) as u8 {
            0 => None,
            agent => Some((kind, agent)),
        }
    }
}

/// Two `f32`, little-endian: the payload of sensor and command frames.
///
/// ```
/// use agent_node::plant_bus::{decode_pair, encode_pair};
/// let b = encode_pair([0.5, -2.0]); // x_{i,1}, x_{i,2}, f32 LE
/// assert_eq!(&b[..4], &0.5f32.to_le_bytes());
/// assert_eq!(decode_pair(&b), Some([0.5, -2.0]));
/// ```
#[must_use]
pub fn encode_pair(v: [f32; 2]) -> [u8; PAIR_LEN] {
    let mut b = [0; PAIR_LEN];
    b[..4].copy_from_slice(&v[0].to_le_bytes());
    b[4..].copy_from_slice(&v[1].to_le_bytes());
    b
}

/// The two `f32` of a sensor or command payload; `None` unless it has [`PAIR_LEN`] bytes.
///
/// ```
/// use agent_node::plant_bus::decode_pair;
/// assert_eq!(decode_pair(&[0; 8]), Some([0.0, 0.0]));
/// assert_eq!(decode_pair(&[0; 7]), None);
/// ```
#[must_use]
pub fn decode_pair(data: &[u8]) -> Option<[f32; 2]> {
    let b: &[u8; PAIR_LEN] = data.try_into().ok()?;
    let f = |k: usize| f32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
    Some([f(0), f(4)])
}

/// Followers per packed sensor frame (`network.sensor_frames = "packed"`, CAN FD): 8 states
/// of 8 bytes fill the largest FD payload.
pub const PACKED_SENSOR_AGENTS: u8 = 8;

/// The first agent of `agent`'s packed sensor frame: the frame goes out with that agent's
/// sensor identifier ([`Kind::id`]) and carries agents `first..first + 8` in order. `None` for
/// agent 0.
///
/// ```
/// use agent_node::plant_bus::packed_first;
/// // Agents 1..=8 share the first packed frame, 9..=16 the second.
/// assert_eq!((packed_first(1), packed_first(8), packed_first(9)), (Some(1), Some(1), Some(9)));
/// assert_eq!(packed_first(0), None);
/// ```
#[must_use]
pub const fn packed_first(agent: u8) -> Option<u8> {
    if agent == 0 {
        return None;
    }
    Some((agent - 1) / PACKED_SENSOR_AGENTS * PACKED_SENSOR_AGENTS + 1)
}

/// Writes the states `x` (agents `first, first + 1, …` in order; at most
/// [`PACKED_SENSOR_AGENTS`]) into `out` as consecutive sensor payloads; the bytes written, or
/// `None` when `out` is too short.
///
/// ```
/// use agent_node::plant_bus::{decode_packed, encode_packed};
/// // The states of agents 9 and 10 in one CAN FD payload.
/// let mut out = [0u8; 64];
/// assert_eq!(encode_packed(&[[1.0, 0.0], [2.0, 0.5]], &mut out), Some(16));
/// assert_eq!(decode_packed(9, 10, &out), Some([2.0, 0.5]));
/// assert_eq!(encode_packed(&[[0.0; 2]; 2], &mut [0u8; 8]), None); // too short
/// ```
pub fn encode_packed(x: &[[f32; 2]], out: &mut [u8]) -> Option<usize> {
    let x = x.get(..x.len().min(usize::from(PACKED_SENSOR_AGENTS)))?;
    let len = x.len() * PAIR_LEN;
    for (chunk, v) in out.get_mut(..len)?.chunks_exact_mut(PAIR_LEN).zip(x) {
        chunk.copy_from_slice(&encode_pair(*v));
    }
    Some(len)
}

/// Agent `agent`'s state in a packed sensor payload whose first agent is `first`; `None` when
/// the payload does not reach it (an FD frame is padded to its length: trailing bytes are
/// ignored).
///
/// ```
/// use agent_node::plant_bus::{decode_packed, encode_packed};
/// let mut out = [0u8; 24];
/// encode_packed(&[[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], &mut out).unwrap();
/// assert_eq!(decode_packed(1, 3, &out), Some([3.0, 3.0]));
/// assert_eq!(decode_packed(1, 4, &out), None); // the payload does not reach agent 4
/// assert_eq!(decode_packed(2, 1, &out), None); // before the first agent
/// ```
#[must_use]
pub fn decode_packed(first: u8, agent: u8, data: &[u8]) -> Option<[f32; 2]> {
    let k = usize::from(agent.checked_sub(first)?);
    if k >= usize::from(PACKED_SENSOR_AGENTS) {
        return None;
    }
    decode_pair(data.get(k * PAIR_LEN..(k + 1) * PAIR_LEN)?)
}

/// A frame of `kind` for `agent` with payload `v`; `None` for agent 0.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::plant_bus::{decode, pair_frame, Kind, PlantFrame};
/// let f: CanFrame = pair_frame(Kind::Command, 2, [0.1, 0.1]).unwrap();
/// assert_eq!(f.raw_id(), 0x302);
/// assert_eq!(decode(&f), Some(PlantFrame::Command(2, [0.1, 0.1])));
/// ```
#[must_use]
pub fn pair_frame<F: Frame>(kind: Kind, agent: u8, v: [f32; 2]) -> Option<F> {
    F::new(kind.id(agent)?, &encode_pair(v))
}

/// A received plant-bus frame.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::plant_bus::{decode, pair_frame, Kind, PlantFrame};
/// // The host's sensor frame for agent 1: x_1 = (0.25, 0).
/// let f: CanFrame = pair_frame(Kind::Sensor, 1, [0.25, 0.0]).unwrap();
/// assert_eq!(decode(&f), Some(PlantFrame::Sensor(1, [0.25, 0.0])));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlantFrame {
    /// Agent's state from the host.
    Sensor(u8, [f32; 2]),
    /// Agent's commands from its node.
    Command(u8, [f32; 2]),
}

/// Decodes a plant-bus frame; `None` for any other frame or a malformed payload.
///
/// ```
/// use agent_node::link::CanFrame;
/// use agent_node::plant_bus::{decode, pair_frame, Kind, PlantFrame};
/// use embedded_can::{Frame, StandardId};
/// let f: CanFrame = pair_frame(Kind::Command, 5, [0.25, -1.0]).unwrap();
/// assert_eq!(decode(&f), Some(PlantFrame::Command(5, [0.25, -1.0])));
/// let short = CanFrame::new(StandardId::new(0x205).unwrap(), &[0; 3]).unwrap();
/// assert_eq!(decode(&short), None); // malformed sensor payload
/// ```
pub fn decode<F: Frame>(frame: &F) -> Option<PlantFrame> {
    let Id::Standard(id) = frame.id() else {
        return None;
    };
    if frame.is_remote_frame() {
        return None;
    }
    let (kind, agent) = Kind::classify(id.as_raw())?;
    let data = frame.data();
    Some(match kind {
        Kind::Sensor => PlantFrame::Sensor(agent, decode_pair(data)?),
        Kind::Command => PlantFrame::Command(agent, decode_pair(data)?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::CanFrame;

    #[test]
    fn identifiers_classify_back_to_kind_and_agent() {
        for kind in [Kind::Sensor, Kind::Command] {
            for agent in [1u8, 2, 200, 255] {
                let id = kind.id(agent).expect("agent > 0");
                assert_eq!(Kind::classify(id.as_raw()), Some((kind, agent)));
            }
            assert_eq!(kind.id(0), None);
        }
        // 0x401 was a state frame: the node's status is its CANopen heartbeat now.
        for raw in [0x100, 0x101, 0x1FF, 0x200, 0x300, 0x401, 0x500, 0x701, 0x0] {
            assert_eq!(Kind::classify(raw), None, "{raw:#x}");
        }
    }

    #[test]
    fn frames_decode_to_what_was_encoded() {
        let f: CanFrame = pair_frame(Kind::Sensor, 3, [0.5, -1.25]).expect("frame");
        assert_eq!(decode(&f), Some(PlantFrame::Sensor(3, [0.5, -1.25])));
        let f: CanFrame = pair_frame(Kind::Command, 4, [f32::MAX, -0.0]).expect("frame");
        assert_eq!(decode(&f), Some(PlantFrame::Command(4, [f32::MAX, -0.0])));
    }

    #[test]
    fn packed_sensor_payloads_round_trip_per_agent() {
        let x: [[f32; 2]; 3] = [[1.0, -1.0], [0.5, 2.5], [-3.0, 0.25]];
        let mut out = [0xAA; 64];
        assert_eq!(encode_packed(&x, &mut out), Some(24));
        for (k, v) in x.iter().enumerate() {
            assert_eq!(decode_packed(9, 9 + k as u8, &out), Some(*v));
        }
        // Agent 12 is the fourth of the frame: the padding is not a state.
        assert_eq!(decode_packed(9, 12, &out[..24]), None);
        assert_eq!(decode_packed(9, 8, &out), None);
        assert_eq!(decode_packed(9, 17, &out), None);
        assert_eq!(encode_packed(&x, &mut [0; 16]), None);
        assert_eq!(encode_packed(&[[0.0; 2]; 9], &mut out), Some(64));
    }

    #[test]
    fn packed_groups_start_every_eight_agents() {
        let firsts: [Option<u8>; 6] = [0u8, 1, 8, 9, 16, 255].map(packed_first);
        assert_eq!(
            firsts,
            [None, Some(1), Some(1), Some(9), Some(9), Some(249)]
        );
    }

    #[test]
    fn malformed_frames_are_not_decoded() {
        let short = CanFrame::new(Kind::Command.id(1).expect("id"), &[0; 4]).expect("frame");
        assert_eq!(decode(&short), None);
        // A sensor frame without data is nothing (the end of a run is an NMT stop).
        let empty = CanFrame::new(Kind::Sensor.id(1).expect("id"), &[]).expect("frame");
        assert_eq!(decode(&empty), None);
        let value = CanFrame::new(StandardId::new(0x101).expect("id"), &[0; 4]).expect("frame");
        assert_eq!(decode(&value), None);
    }
}
