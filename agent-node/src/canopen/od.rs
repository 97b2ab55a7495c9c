//! The object dictionary: a `static` table of objects ([`OBJECTS`]) and the values behind
//! them ([`ParamStore`] for the manufacturer entries; the communication entries live in
//! [`super::Device`]).
//!
//! | index | object |
//! |---|---|
//! | `0x1000`–`0x1200` | communication profile (CiA 301 §7.5): device type, error register, pre-defined error field, COB-IDs, names, store/restore, heartbeat, identity, SDO server |
//! | `0x1400 + k`, `0x1600 + k` | RPDO `k + 1` communication and mapping parameters ([`RPDOS`]: the leader's value frame, then one per neighbour slot) |
//! | `0x1800`, `0x1A00` | TPDO1 communication and mapping parameters: the node's own value frame |
//! | `0x1801`, `0x1A01` | TPDO2 communication and mapping parameters: the node's status PDO (`crate::wire::Heartbeat`) |
//! | `0x1411`, `0x1611` | RPDO18 communication and mapping parameters: a bench host's sensor frame (`crate::plant_bus`) |
//! | `0x1802`, `0x1A02` | TPDO3 communication and mapping parameters: the node's command frame on a bench |
//! | `0x2000 + k` | `controller_core::param::Param::ALL[k]`, named by its scenario key |
//! | `0x2100 + k` | [`Setting::ALL`]`[k]`: the node's own settings, the identifier plan last |
//! | `0x2200`–`0x2203` | the node's own value frame, field by field ([`Field`]; TPDO1 maps them) |
//! | `0x2210`–`0x2213` | the value frames heard, field by field, sub-index `k + 1` = RPDO `k + 1` |
//! | `0x2220`–`0x2224` | the node's last status PDO, field by field ([`StatusField`]; TPDO2 maps them) |
//! | `0x2230`, `0x2231` | the last sensor frame heard (`x_{i,1}`, `x_{i,2}`) and command frame sent (`q_{i,1}`, `q_{i,2}`), `REAL32` arrays (RPDO18 and TPDO3 map them) |
//!
//! ## PDO mapping
//!
//! The value frames of `crate::wire` are the PDOs, with the identifiers of the node's
//! `IdPlan` (not the predefined connection set's `0x180 + id`): the COB-IDs and the mapping are
//! read-only; the COB-IDs follow the identifier plan and the graph row, which are written in
//! their own objects ([`Setting::IdBase`], …, `graph.neighbours`) and applied at the next reset
//! communication. Every value frame (4 bytes) maps the same four
//! fields, bit by bit (granularity 1), least significant bit first:
//!
//! | bits | field | object (own / heard `k`) | type, mapped length |
//! |---|---|---|---|
//! | 0–23 | `y`, Q7.16 (`y = raw / 65536`) | `0x2200` / `0x2210` sub `k` | `INTEGER24`, 24 |
//! | 24–29 | sequence counter (mod 64) | `0x2201` / `0x2211` sub `k` | `UNSIGNED8`, 6 |
//! | 30 | saturated | `0x2202` / `0x2212` sub `k` | `BOOLEAN`, 1 |
//! | 31 | no value (NaN or ±∞ sent) | `0x2203` / `0x2213` sub `k` | `BOOLEAN`, 1 |
//!
//! The status PDO (TPDO2, 8 bytes, on `heartbeat_base + i` of the plan: the frame §10 of
//! docs/NETWORK.md calls the node's heartbeat) maps five objects byte-aligned, bit-exact with
//! `crate::wire::Heartbeat`:
//!
//! | bits | field | object | type, mapped length |
//! |---|---|---|---|
//! | 0–7 | supervisor state (0 operational, 1 boot, 2 safe, 3 fault) | `0x2220` | `UNSIGNED8`, 8 |
//! | 8–15 | lost sources (bit 0 leader, 1 neighbours, 2 sensor) | `0x2221` | `UNSIGNED8`, 8 |
//! | 16–31 | boot counter | `0x2222` | `UNSIGNED16`, 16 |
//! | 32–47 | deadline overruns since start | `0x2223` | `UNSIGNED16`, 16 |
//! | 48–63 | safe-state entries since start | `0x2224` | `UNSIGNED16`, 16 |
//!
//! On a bench whose host simulates the plant (`crate::plant_bus`) the sensor frame
//! (`0x200 + i`) is RPDO18 and the command frame (`0x300 + i`) TPDO3, each two `REAL32`
//! (`0x2230` / `0x2231` sub-indices 1 and 2, 32 bits each, little-endian `f32` as the frames carry
//! them). Their COB-IDs are valid only on a runtime that uses them
//! (`super::Device::enable_plant_pdos`: `node-linux` with one sensor frame per agent); elsewhere
//! bit 31 is set.
//!
//! The manufacturer entries are generated from `controller_core::param` by a `const fn`: a new
//! [`Param`] gets its object without an edit here. A per-step parameter is an `ARRAY`
//! (sub-index 0: the state order `n`, sub-index `j`: step `j`); every other one a `VAR`.
//! Numbers are `REAL32`, counts and names `UNSIGNED8` (the position in the list of names),
//! switches `BOOLEAN`. An optional number (`controller.c1`, `safety.u_max`, …) reads NaN when
//! absent and is cleared by writing NaN.

use controller_core::{
    param::{DefaultValue, Range, DIRECTIONS, FEEDFORWARDS, GAIN_READINGS, SCHEMES},
    ConfigError, ControllerConfig, Feedforward, GainReading, Param, Params, QuantizerDirection,
    Reason, SchemeName, Sections,
};

use super::{Abort, SdoData};
use crate::supervisor::{
    micros_from_secs, NeighbourLoss, SafePolicy, Supervisor, SupervisorConfig,
};

/// Most steps `n` (state order) a per-step array can hold.
pub const MAX_STEPS: u8 = 4;
pub use crate::wire::MAX_NEIGHBOURS;
/// Entries of the heartbeat consumer (`0x1016`).
pub const HEARTBEAT_CONSUMERS: u8 = 8;
/// Entries of the pre-defined error field (`0x1003`).
pub const ERROR_HISTORY: u8 = 8;
/// First index of the generated `controller_core::param` entries.
pub const PARAM_BASE: u16 = 0x2000;
/// First index of the node's settings.
pub const SETTING_BASE: u16 = 0x2100;
/// RPDOs: the leader's value frame (RPDO1), then one per neighbour slot.
pub const RPDOS: u8 = 1 + MAX_NEIGHBOURS as u8;
/// First RPDO communication parameter.
pub const RPDO_COMM_BASE: u16 = 0x1400;
/// First RPDO mapping parameter.
pub const RPDO_MAP_BASE: u16 = 0x1600;
/// TPDO1 communication parameter.
pub const TPDO_COMM: u16 = 0x1800;
/// TPDO1 mapping parameter.
pub const TPDO_MAP: u16 = 0x1A00;
/// TPDO2 communication parameter: the status PDO.
pub const STATUS_TPDO_COMM: u16 = 0x1801;
/// TPDO2 mapping parameter: the status PDO.
pub const STATUS_TPDO_MAP: u16 = 0x1A01;
/// First object of the node's status PDO ([`StatusField`], one `VAR` each).
pub const STATUS_BASE: u16 = 0x2220;
/// RPDO18 communication parameter: a bench host's sensor frame.
pub const SENSOR_RPDO_COMM: u16 = RPDO_COMM_BASE + RPDOS as u16;
/// RPDO18 mapping parameter.
pub const SENSOR_RPDO_MAP: u16 = RPDO_MAP_BASE + RPDOS as u16;
/// TPDO3 communication parameter: the node's command frame on a bench.
pub const COMMAND_TPDO_COMM: u16 = 0x1802;
/// TPDO3 mapping parameter.
pub const COMMAND_TPDO_MAP: u16 = 0x1A02;
/// The last sensor frame heard: `ARRAY` of two `REAL32` (`x_{i,1}`, `x_{i,2}`).
pub const SENSOR_OBJECT: u16 = 0x2230;
/// The last command frame sent: `ARRAY` of two `REAL32` (`q_{i,1}`, `q_{i,2}`).
pub const COMMAND_OBJECT: u16 = 0x2231;
/// Values a sensor or command frame carries.
pub const PLANT_PAIR: u8 = 2;

/// The CiA 301 mapping entry of element `sub` (1 or 2) of a plant-frame object: 32 bits.
///
/// ```
/// use agent_node::canopen::od::{plant_mapping, COMMAND_OBJECT, SENSOR_OBJECT};
/// // RPDO18 maps x_{i,1} to 0x2230:01, TPDO3 q_{i,2} from 0x2231:02, 32 bits each.
/// assert_eq!(plant_mapping(SENSOR_OBJECT, 1), 0x2230_0120);
/// assert_eq!(plant_mapping(COMMAND_OBJECT, 2), 0x2231_0220);
/// ```
pub const fn plant_mapping(index: u16, sub: u8) -> u32 {
    (index as u32) << 16 | (sub as u32) << 8 | 32
}
/// First object of the node's own value frame (one per [`Field`]).
pub const TX_VALUE_BASE: u16 = 0x2200;
/// First object of the value frames heard (one `ARRAY` per [`Field`], one sub-index per RPDO).
pub const RX_VALUE_BASE: u16 = 0x2210;
/// Transmission type of every PDO: 254, event-driven (manufacturer-specific): a value frame
/// goes out once per sample of the node's own clock and is used at the receiver's next sample.
pub const PDO_TRANSMISSION_TYPE: u8 = 0xFE;
/// COB-ID bit 31: the PDO is not valid (not in use).
pub const COB_ID_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: no RTR allowed on this PDO.
pub const COB_ID_NO_RTR: u32 = 1 << 30;

/// One field of a value frame (`crate::wire`), as the PDOs map it.
///
/// ```
/// use agent_node::canopen::od::Field;
/// use agent_node::wire::encode_payload;
/// // The fields of a value frame, bit by bit: y (24), counter (6), saturated, no value.
/// let frame = encode_payload(1.0, 5).data;
/// let raw: Vec<u32> = Field::ALL.iter().map(|f| f.extract(&frame)).collect();
/// assert_eq!(raw, [0x01_0000, 5, 0, 0]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// `y` in Q7.16, 24 bits two's complement.
    Y,
    /// Sequence counter, modulo 64: 6 bits.
    Sequence,
    /// `SATURATED`: 1 bit.
    Saturated,
    /// `NO_VALUE`: 1 bit.
    NoValue,
}

impl Field {
    /// The fields in frame order (least significant bit first).
    pub const ALL: [Self; 4] = [Self::Y, Self::Sequence, Self::Saturated, Self::NoValue];

    /// Bits the field takes in the frame (the mapped length).
    ///
    /// ```
    /// use agent_node::canopen::od::Field;
    /// assert_eq!(Field::ALL.iter().map(|f| u32::from(f.bits())).sum::<u32>(), 32); // 4 bytes
    /// assert_eq!(Field::Sequence.bits(), 6); // counter modulo 64
    /// ```
    #[must_use]
    pub const fn bits(self) -> u8 {
        match self {
            Self::Y => 8 * (crate::wire::PAYLOAD_LEN as u8 - 1),
            Self::Sequence => crate::wire::SEQ_MODULUS.trailing_zeros() as u8,
            Self::Saturated | Self::NoValue => 1,
        }
    }

    /// First bit of the field in the frame.
    ///
    /// ```
    /// use agent_node::canopen::od::Field;
    /// assert_eq!((Field::Y.offset(), Field::Sequence.offset(), Field::NoValue.offset()), (0, 24, 31));
    /// ```
    #[must_use]
    pub const fn offset(self) -> u8 {
        let mut off = 0;
        let mut k = 0;
        while k < Self::ALL.len() {
            if Self::ALL[k] as u8 == self as u8 {
                break;
            }
            off += Self::ALL[k].bits();
            k += 1;
        }
        off
    }

    /// Position in [`Self::ALL`].
    ///
    /// ```
    /// use agent_node::canopen::od::{Field, TX_VALUE_BASE};
    /// // The object of the own frame's saturated flag.
    /// assert_eq!(TX_VALUE_BASE + Field::Saturated.position(), 0x2202);
    /// ```
    #[must_use]
    pub const fn position(self) -> u16 {
        self as u16
    }

    /// The object's data type.
    ///
    /// ```
    /// use agent_node::canopen::od::{DataType, Field};
    /// assert_eq!(Field::Y.data_type(), DataType::Integer24);
    /// assert_eq!(Field::NoValue.data_type(), DataType::Boolean);
    /// ```
    #[must_use]
    pub const fn data_type(self) -> DataType {
        match self {
            Self::Y => DataType::Integer24,
            Self::Sequence => DataType::Unsigned8,
            Self::Saturated | Self::NoValue => DataType::Boolean,
        }
    }

    /// `ParameterName` of its objects.
    ///
    /// ```
    /// use agent_node::canopen::od::Field;
    /// assert!(Field::Y.name().contains("Q7.16"));
    /// ```
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Y => "Value y (Q7.16, y = raw / 65536)",
            Self::Sequence => "Value sequence counter (mod 64)",
            Self::Saturated => "Value saturated",
            Self::NoValue => "Value absent (NaN or infinite sent)",
        }
    }

    /// The field of a 4-byte value frame (the raw bits, `y` as its 24-bit pattern).
    ///
    /// ```
    /// use agent_node::canopen::od::Field;
    /// use agent_node::wire::encode_payload;
    /// let nan = encode_payload(f32::NAN, 0).data; // a failed sensor's frame
    /// assert_eq!((Field::NoValue.extract(&nan), Field::Y.extract(&nan)), (1, 0));
    /// let neg = encode_payload(-1.0, 0).data;
    /// assert_eq!(Field::Y.extract(&neg), 0xFF_0000); // -1.0 as a 24-bit pattern
    /// ```
    #[must_use]
    pub fn extract(self, frame: &[u8; crate::wire::PAYLOAD_LEN]) -> u32 {
        let all = u32::from_le_bytes(*frame);
        (all >> self.offset()) & ((1u32 << self.bits()) - 1)
    }

    /// The CiA 301 mapping entry of this field in object `index`, sub-index `sub`:
    /// `index << 16 | sub << 8 | bits`.
    ///
    /// ```
    /// use agent_node::canopen::od::Field;
    /// // TPDO1 maps 0x2200:00, 24 bits.
    /// assert_eq!(Field::Y.mapping(0x2200, 0), 0x2200_0018);
    /// ```
    #[must_use]
    pub const fn mapping(self, index: u16, sub: u8) -> u32 {
        (index as u32) << 16 | (sub as u32) << 8 | self.bits() as u32
    }
}

/// One field of the node's status PDO (`crate::wire::Heartbeat`), as TPDO2 maps it.
///
/// ```
/// use agent_node::canopen::od::StatusField;
/// use agent_node::wire::Heartbeat;
/// use agent_node::{supervisor::Lost, NodeState};
/// let hb = Heartbeat { state: NodeState::Safe, lost: Lost::from_bits(Lost::SENSOR),
///     boot_count: 7, overruns: 0, safe_entries: 1 };
/// // State safe (2), sensor lost (bit 2), boot 7, no overrun, one safe-state entry.
/// assert_eq!(StatusField::ALL.map(|f| f.extract(&hb.to_bytes())), [2, 4, 7, 0, 1]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatusField {
    /// The supervisor's state (`crate::NodeState::code`).
    State,
    /// The supervised sources lost (`crate::supervisor::Lost::bits`).
    Lost,
    /// The board's boot counter.
    BootCount,
    /// Deadline overruns since start (saturating).
    Overruns,
    /// Safe-state entries since start (saturating).
    SafeEntries,
}

impl StatusField {
    /// The fields in frame order.
    pub const ALL: [Self; 5] = [
        Self::State,
        Self::Lost,
        Self::BootCount,
        Self::Overruns,
        Self::SafeEntries,
    ];

    /// Bits the field takes in the frame (the mapped length).
    ///
    /// ```
    /// use agent_node::canopen::od::StatusField;
    /// assert_eq!((StatusField::Lost.bits(), StatusField::Overruns.bits()), (8, 16));
    /// // The five fields fill the 8-byte frame.
    /// assert_eq!(StatusField::ALL.iter().map(|f| u32::from(f.bits())).sum::<u32>(), 64);
    /// ```
    pub const fn bits(self) -> u8 {
        match self {
            Self::State | Self::Lost => 8,
            Self::BootCount | Self::Overruns | Self::SafeEntries => 16,
        }
    }

    /// First bit of the field in the frame.
    ///
    /// ```
    /// use agent_node::canopen::od::StatusField;
    /// assert_eq!(StatusField::BootCount.offset(), 16); // bytes 2..3
    /// // Each field starts where the one before it ends.
    /// for w in StatusField::ALL.windows(2) {
    ///     assert_eq!(w[0].offset() + w[0].bits(), w[1].offset());
    /// }
    /// ```
    pub const fn offset(self) -> u8 {
        match self {
            Self::State => 0,
            Self::Lost => 8,
            Self::BootCount => 16,
            Self::Overruns => 32,
            Self::SafeEntries => 48,
        }
    }

    /// Position in [`Self::ALL`] (its object is [`STATUS_BASE`] plus it).
    ///
    /// ```
    /// use agent_node::canopen::od::{StatusField, STATUS_BASE};
    /// assert_eq!(STATUS_BASE + StatusField::Overruns.position(), 0x2223);
    /// assert!(StatusField::ALL.iter().enumerate().all(|(k, f)| usize::from(f.position()) == k));
    /// ```
    pub const fn position(self) -> u16 {
        self as u16
    }

    /// The object's data type.
    ///
    /// ```
    /// use agent_node::canopen::od::{DataType, StatusField};
    /// assert_eq!(StatusField::Lost.data_type(), DataType::Unsigned8);
    /// // The object is as wide as the mapped field.
    /// for f in StatusField::ALL {
    ///     assert_eq!(f.data_type().size(), Some(usize::from(f.bits() / 8)));
    /// }
    /// ```
    pub const fn data_type(self) -> DataType {
        match self {
            Self::State | Self::Lost => DataType::Unsigned8,
            Self::BootCount | Self::Overruns | Self::SafeEntries => DataType::Unsigned16,
        }
    }

    /// `ParameterName` of its object.
    ///
    /// ```
    /// use agent_node::canopen::od::StatusField;
    /// assert_eq!(StatusField::BootCount.name(), "Status boot counter");
    /// assert!(StatusField::State.name().contains("2 safe")); // the NodeState code
    /// ```
    pub const fn name(self) -> &'static str {
        match self {
            Self::State => "Status supervisor state (0 operational, 1 boot, 2 safe, 3 fault)",
            Self::Lost => "Status lost sources (bit 0 leader, 1 neighbours, 2 sensor)",
            Self::BootCount => "Status boot counter",
            Self::Overruns => "Status deadline overruns",
            Self::SafeEntries => "Status safe-state entries",
        }
    }

    /// The field of an 8-byte status PDO.
    ///
    /// ```
    /// use agent_node::canopen::od::StatusField;
    /// use agent_node::wire::Heartbeat;
    /// use agent_node::{supervisor::Lost, NodeState};
    /// let hb = Heartbeat { state: NodeState::Operational, lost: Lost::default(), boot_count: 2,
    ///     overruns: 300, safe_entries: 0 };
    /// assert_eq!(StatusField::Overruns.extract(&hb.to_bytes()), 300);
    /// assert_eq!(StatusField::BootCount.extract(&hb.to_bytes()), 2);
    /// ```
    pub fn extract(self, frame: &[u8; crate::wire::HEARTBEAT_LEN]) -> u32 {
        let all = u64::from_le_bytes(*frame);
        ((all >> self.offset()) & ((1u64 << self.bits()) - 1)) as u32
    }

    /// The CiA 301 mapping entry of this field: its object, sub-index 0, its length.
    ///
    /// ```
    /// use agent_node::canopen::od::StatusField;
    /// // TPDO2 maps 0x2222:00, 16 bits: the boot counter.
    /// assert_eq!(StatusField::BootCount.mapping(), 0x2222_0010);
    /// assert_eq!(StatusField::State.mapping(), 0x2220_0008);
    /// ```
    pub const fn mapping(self) -> u32 {
        (STATUS_BASE as u32 + self as u32) << 16 | self.bits() as u32
    }
}

/// CiA 301 data types (the EDS `DataType` codes).
///
/// ```
/// use agent_node::canopen::od::DataType;
/// assert_eq!((DataType::Real32.code(), DataType::Real32.size()), (0x0008, Some(4)));
/// assert_eq!(DataType::VisibleString.size(), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataType {
    /// `BOOLEAN` (0x0001).
    Boolean,
    /// `UNSIGNED8` (0x0005).
    Unsigned8,
    /// `UNSIGNED16` (0x0006).
    Unsigned16,
    /// `UNSIGNED32` (0x0007).
    Unsigned32,
    /// `INTEGER24` (0x0010), two's complement (a value frame's `y`).
    Integer24,
    /// `REAL32` (0x0008), IEEE 754 single precision.
    Real32,
    /// `VISIBLE_STRING` (0x0009).
    VisibleString,
}

impl DataType {
    /// The CiA 301 code.
    ///
    /// ```
    /// use agent_node::canopen::od::DataType;
    /// assert_eq!(DataType::Unsigned16.code(), 0x0006); // the EDS DataType
    /// ```
    #[must_use]
    pub const fn code(self) -> u16 {
        match self {
            Self::Boolean => 0x0001,
            Self::Unsigned8 => 0x0005,
            Self::Unsigned16 => 0x0006,
            Self::Unsigned32 => 0x0007,
            Self::Integer24 => 0x0010,
            Self::Real32 => 0x0008,
            Self::VisibleString => 0x0009,
        }
    }

    /// Bytes of a value (`None`: variable, a string).
    ///
    /// ```
    /// use agent_node::canopen::od::DataType;
    /// assert_eq!(DataType::Integer24.size(), Some(3));
    /// ```
    #[must_use]
    pub const fn size(self) -> Option<usize> {
        match self {
            Self::Boolean | Self::Unsigned8 => Some(1),
            Self::Unsigned16 => Some(2),
            Self::Integer24 => Some(3),
            Self::Unsigned32 | Self::Real32 => Some(4),
            Self::VisibleString => None,
        }
    }
}

/// Who may read and write an object's values.
///
/// ```
/// use agent_node::canopen::od::{find, Access};
/// assert_eq!(find(0x1000).unwrap().access, Access::Const); // device type
/// assert_eq!(find(0x1017).unwrap().access, Access::ReadWrite); // producer heartbeat time
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Read only, may change (`ro`).
    ReadOnly,
    /// Read only, never changes (`const`).
    Const,
    /// Read and write (`rw`); manufacturer entries only in pre-operational.
    ReadWrite,
}

impl Access {
    /// The EDS `AccessType`.
    ///
    /// ```
    /// use agent_node::canopen::od::Access;
    /// assert_eq!([Access::ReadOnly, Access::Const, Access::ReadWrite].map(Access::eds), ["ro", "const", "rw"]);
    /// ```
    #[must_use]
    pub const fn eds(self) -> &'static str {
        match self {
            Self::ReadOnly => "ro",
            Self::Const => "const",
            Self::ReadWrite => "rw",
        }
    }
}

/// A node setting that is not a controller parameter: its CANopen node-ID and the `[node]`
/// keys of docs/SCENARIO.md (supervision of §10 of docs/NETWORK.md).
///
/// ```
/// use agent_node::canopen::od::{Setting, SETTING_BASE};
/// // The node-ID is the first setting, at 0x2100.
/// assert_eq!(Setting::ALL[0], Setting::NodeId);
/// assert_eq!(Setting::NodeId.spec().key, "node.node_id");
/// assert_eq!(SETTING_BASE, 0x2100);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `node.node_id`: CANopen node-ID = agent number `i` (its value frames, heartbeat, SDO).
    NodeId,
    /// `network.stale_timeout`: a neighbour value older than this is stale.
    StaleTimeout,
    /// `node.safe_state.policy`.
    Policy,
    /// `node.safe_state.stop_decel`.
    StopDecel,
    /// `node.safe_state.sensor_policy`.
    SensorPolicy,
    /// `node.safe_state.ramp_rate`.
    RampRate,
    /// `node.safe_state.reentry_rate`.
    ReentryRate,
    /// `node.safe_state.leader_timeout` (0: not supervised).
    LeaderTimeout,
    /// `node.safe_state.neighbour_timeout` (0: not supervised).
    NeighbourTimeout,
    /// `node.safe_state.neighbour_loss`.
    NeighbourLoss,
    /// `node.safe_state.sensor_timeout` (0: not supervised).
    SensorTimeout,
    /// `node.safe_state.recover_dwell`.
    RecoverDwell,
    /// `node.id_base`: the identifier plan's leader value frame (`IdPlan::value_base`).
    IdBase,
    /// `node.heartbeat_id_base`: agent `i`'s heartbeat at this plus `i` (`0xFFFF`: none).
    HeartbeatIdBase,
    /// `node.agents`: the agents `1..=agents` of the identifier plan.
    Agents,
}

/// Names of `node.safe_state.policy` and `sensor_policy`, in the order of their `UNSIGNED8`.
pub const POLICIES: &[&str] = &["hold-position", "stop", "hold", "ramp", "off"];
/// Names of `node.safe_state.neighbour_loss`.
pub const NEIGHBOUR_LOSSES: &[&str] = &["all", "any"];

/// Key, unit, type and range of a [`Setting`].
///
/// ```
/// use agent_node::canopen::od::{DataType, Setting};
/// let s = Setting::Policy.spec();
/// assert_eq!((s.key, s.data_type), ("node.safe_state.policy", DataType::Unsigned8));
/// assert_eq!(s.names[1], "stop"); // the UNSIGNED8 1 is CiA 402's quick stop
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SettingSpec {
    /// Key as docs/SCENARIO.md names it.
    pub key: &'static str,
    /// Unit (`–`: none).
    pub unit: &'static str,
    /// Type on the bus.
    pub data_type: DataType,
    /// Accepted values, as docs/SCENARIO.md writes them.
    pub range: &'static str,
    /// Names of an `UNSIGNED8` choice (empty otherwise).
    pub names: &'static [&'static str],
}

const fn setting(
    key: &'static str,
    unit: &'static str,
    data_type: DataType,
    range: &'static str,
) -> SettingSpec {
    SettingSpec {
        key,
        unit,
        data_type,
        range,
        names: &[],
    }
}

const fn choice(key: &'static str, names: &'static [&'static str]) -> SettingSpec {
    SettingSpec {
        names,
        ..setting(key, "–", DataType::Unsigned8, "one of the names")
    }
}

impl Setting {
    /// Every setting, in index order (`0x2100 + k`).
    /// The rates come before the policies that need them, so a stored set loads in order.
    /// The identifier plan comes last, so that the indexes of the others never move.
    ///
    /// ```
    /// use agent_node::canopen::od::{Setting, SETTING_BASE};
    /// // The identifier plan is last: node.agents at 0x2100 + 14 = 0x210E.
    /// let k = Setting::ALL.iter().position(|s| *s == Setting::Agents).unwrap();
    /// assert_eq!(SETTING_BASE + k as u16, 0x210E);
    /// assert_eq!(Setting::ALL[k].spec().key, "node.agents");
    /// ```
    pub const ALL: [Self; 15] = [
        Self::NodeId,
        Self::StaleTimeout,
        Self::StopDecel,
        Self::RampRate,
        Self::Policy,
        Self::SensorPolicy,
        Self::ReentryRate,
        Self::LeaderTimeout,
        Self::NeighbourTimeout,
        Self::NeighbourLoss,
        Self::SensorTimeout,
        Self::RecoverDwell,
        Self::IdBase,
        Self::HeartbeatIdBase,
        Self::Agents,
    ];

    /// Key, unit, type, range.
    ///
    /// ```
    /// use agent_node::canopen::od::Setting;
    /// let s = Setting::StaleTimeout.spec();
    /// assert_eq!((s.key, s.unit), ("network.stale_timeout", "s"));
    /// assert!(Setting::ALL.iter().all(|s| !s.spec().key.is_empty()));
    /// ```
    #[must_use]
    pub const fn spec(self) -> SettingSpec {
        use DataType::{Real32 as R, Unsigned16 as U16, Unsigned8 as U8};
        match self {
            Self::NodeId => setting("node.node_id", "–", U8, "1..=127; applied at reset"),
            Self::StaleTimeout => setting("network.stale_timeout", "s", R, "[1e-6, 1e6]"),
            Self::Policy => choice("node.safe_state.policy", POLICIES),
            Self::StopDecel => setting("node.safe_state.stop_decel", "[y]/s2", R, "> 0; NaN: none"),
            Self::SensorPolicy => choice("node.safe_state.sensor_policy", POLICIES),
            Self::RampRate => setting("node.safe_state.ramp_rate", "[u]/s", R, "> 0; NaN: none"),
            Self::ReentryRate => setting("node.safe_state.reentry_rate", "[y]/s", R, "> 0"),
            Self::LeaderTimeout => setting(
                "node.safe_state.leader_timeout",
                "s",
                R,
                "0 (off) or [1e-6, 1e6]",
            ),
            Self::NeighbourTimeout => setting(
                "node.safe_state.neighbour_timeout",
                "s",
                R,
                "0 (off) or [1e-6, 1e6]",
            ),
            Self::NeighbourLoss => choice("node.safe_state.neighbour_loss", NEIGHBOUR_LOSSES),
            Self::SensorTimeout => setting(
                "node.safe_state.sensor_timeout",
                "s",
                R,
                "0 (off) or [1e-6, 1e6]",
            ),
            Self::RecoverDwell => setting("node.safe_state.recover_dwell", "s", R, "[0, 1e6]"),
            Self::IdBase => setting(
                "node.id_base",
                "11-bit id",
                U16,
                "0..=0x7FF, id_base + agents <= 0x7FF; applied at reset",
            ),
            Self::HeartbeatIdBase => setting(
                "node.heartbeat_id_base",
                "11-bit id",
                U16,
                "0..=0x7FF, clear of the value frames, 0xFFFF: none; applied at reset",
            ),
            Self::Agents => setting(
                "node.agents",
                "–",
                U8,
                "1..=255, holding the node-ID and its neighbours; applied at reset",
            ),
        }
    }
}

/// What an object of the table stands for.
///
/// ```
/// use agent_node::canopen::od::{find, Item};
/// use controller_core::Param;
/// assert_eq!(find(0x1017).unwrap().item, Item::HeartbeatProducer);
/// assert_eq!(find(0x2000).unwrap().item, Item::Param(Param::ALL[0]));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Item {
    /// `0x1000` device type.
    DeviceType,
    /// `0x1001` error register.
    ErrorRegister,
    /// `0x1003` pre-defined error field.
    ErrorField,
    /// `0x1005` COB-ID SYNC.
    SyncCobId,
    /// `0x1008` manufacturer device name.
    DeviceName,
    /// `0x100A` manufacturer software version.
    SoftwareVersion,
    /// `0x1010` store parameters.
    Store,
    /// `0x1011` restore default parameters.
    Restore,
    /// `0x1014` COB-ID EMCY.
    EmcyCobId,
    /// `0x1016` consumer heartbeat time.
    HeartbeatConsumer,
    /// `0x1017` producer heartbeat time.
    HeartbeatProducer,
    /// `0x1018` identity.
    Identity,
    /// `0x1200` SDO server parameter.
    SdoServer,
    /// `0x1400 + k`: RPDO `k + 1` communication parameter.
    RpdoComm(u8),
    /// `0x1600 + k`: RPDO `k + 1` mapping parameter.
    RpdoMap(u8),
    /// `0x1800`: TPDO1 communication parameter.
    TpdoComm,
    /// `0x1A00`: TPDO1 mapping parameter.
    TpdoMap,
    /// `0x1801`: TPDO2 communication parameter (the status PDO).
    StatusComm,
    /// `0x1A01`: TPDO2 mapping parameter (the status PDO).
    StatusMap,
    /// `0x2220 + f`: a field of the node's last status PDO.
    Status(StatusField),
    /// `0x1411`: RPDO18 communication parameter (the sensor frame).
    SensorComm,
    /// `0x1611`: RPDO18 mapping parameter.
    SensorMap,
    /// `0x1802`: TPDO3 communication parameter (the command frame).
    CommandComm,
    /// `0x1A02`: TPDO3 mapping parameter.
    CommandMap,
    /// `0x2230`: the last sensor frame heard.
    Sensed,
    /// `0x2231`: the last command frame sent.
    Commanded,
    /// `0x2200 + f`: a field of the node's own value frame.
    TxValue(Field),
    /// `0x2210 + f`: a field of the value frames heard (sub-index `k + 1`: RPDO `k + 1`).
    RxValue(Field),
    /// A controller parameter.
    Param(Param),
    /// A node setting.
    Setting(Setting),
}

/// Object code: a single value or an array of them (sub-index 0: the highest sub-index).
///
/// ```
/// use agent_node::canopen::od::{find, Kind, PARAM_BASE};
/// use controller_core::Param;
/// // A per-step parameter (ǎ_j) is an ARRAY with one entry per step; T_s a VAR.
/// let at = |p: Param| PARAM_BASE + Param::ALL.iter().position(|q| *q == p).unwrap() as u16;
/// assert!(matches!(find(at(Param::ACheck)).unwrap().kind, Kind::Array { .. }));
/// assert_eq!(find(at(Param::Ts)).unwrap().kind, Kind::Var);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `VAR` (object code 7), sub-index 0 only.
    Var,
    /// `ARRAY` (8): sub-index 0 `UNSIGNED8` count, `1..=len` of [`Object::data_type`].
    Array {
        /// Highest sub-index the table has.
        len: u8,
    },
    /// `RECORD` (9) of `UNSIGNED32` entries: like an array, each sub-index with a name.
    Record {
        /// Highest sub-index.
        len: u8,
    },
}

/// One object of the dictionary.
///
/// ```
/// use agent_node::canopen::od::{find, Access, DataType, PARAM_BASE};
/// use controller_core::Param;
/// let k = Param::ALL.iter().position(|p| *p == Param::Ts).unwrap() as u16;
/// let o = find(PARAM_BASE + k).unwrap();
/// assert_eq!((o.name(), o.data_type, o.access), ("controller.ts", DataType::Real32, Access::ReadWrite));
/// assert!(!o.pdo);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Object {
    /// Index.
    pub index: u16,
    /// Object code.
    pub kind: Kind,
    /// Type of the value(s) (sub-index 0 of an array is `UNSIGNED8`).
    pub data_type: DataType,
    /// Access of the value(s).
    pub access: Access,
    /// What it stands for.
    pub item: Item,
    /// Mappable into a PDO.
    pub pdo: bool,
}

const fn comm(index: u16, kind: Kind, data_type: DataType, access: Access, item: Item) -> Object {
    Object {
        index,
        kind,
        data_type,
        access,
        item,
        pdo: false,
    }
}

const COMM: [Object; 13] = {
    use Access::{Const as C, ReadOnly as RO, ReadWrite as RW};
    use DataType::{Unsigned16 as U16, Unsigned32 as U32, Unsigned8 as U8, VisibleString as S};
    use Kind::{Array, Record, Var};
    [
        comm(0x1000, Var, U32, C, Item::DeviceType),
        comm(0x1001, Var, U8, RO, Item::ErrorRegister),
        comm(
            0x1003,
            Array { len: ERROR_HISTORY },
            U32,
            RO,
            Item::ErrorField,
        ),
        comm(0x1005, Var, U32, C, Item::SyncCobId),
        comm(0x1008, Var, S, C, Item::DeviceName),
        comm(0x100A, Var, S, C, Item::SoftwareVersion),
        comm(0x1010, Record { len: 1 }, U32, RW, Item::Store),
        comm(0x1011, Record { len: 1 }, U32, RW, Item::Restore),
        comm(0x1014, Var, U32, RO, Item::EmcyCobId),
        comm(
            0x1016,
            Array {
                len: HEARTBEAT_CONSUMERS,
            },
            U32,
            RW,
            Item::HeartbeatConsumer,
        ),
        comm(0x1017, Var, U16, RW, Item::HeartbeatProducer),
        comm(0x1018, Record { len: 4 }, U32, RO, Item::Identity),
        comm(0x1200, Record { len: 2 }, U32, RO, Item::SdoServer),
    ]
};

/// Type of a parameter's object.
///
/// ```
/// use agent_node::canopen::od::{param_type, DataType};
/// use controller_core::Param;
/// assert_eq!(param_type(Param::Zeta), DataType::Real32); // ζ ∈ (0, 1)
/// assert_eq!(param_type(Param::MtnOrder), DataType::Unsigned8); // a count
/// ```
#[must_use]
pub const fn param_type(p: Param) -> DataType {
    match p.spec().range {
        Range::Bool => DataType::Boolean,
        Range::Count { .. } | Range::OneOf(_) => DataType::Unsigned8,
        _ => match p {
            Param::Neighbours | Param::StateOrder => DataType::Unsigned8,
            Param::Pinned => DataType::Boolean,
            _ => DataType::Real32,
        },
    }
}

/// Read-only parameters: the plant is not the node's to change. The graph row (`graph.neighbours`,
/// `graph.pinned`) is written in pre-operational and applied at the next reset communication.
///
/// ```
/// use agent_node::canopen::od::{param_access, Access};
/// use controller_core::Param;
/// assert_eq!(param_access(Param::Ts), Access::ReadWrite);
/// assert_eq!(param_access(Param::Neighbours), Access::ReadWrite); // applied at reset communication
/// assert_eq!(param_access(Param::StateOrder), Access::ReadOnly); // the plant is not the node's
/// ```
#[must_use]
pub const fn param_access(p: Param) -> Access {
    match (p, p.spec().range) {
        (Param::Neighbours | Param::Pinned, _) => Access::ReadWrite,
        (_, Range::Elsewhere) => Access::ReadOnly,
        _ => Access::ReadWrite,
    }
}

const fn param_object(k: usize, p: Param) -> Object {
    let spec = p.spec();
    let kind = if spec.per_step {
        Kind::Array { len: MAX_STEPS }
    } else if matches!(p, Param::Neighbours) {
        Kind::Array {
            len: MAX_NEIGHBOURS as u8,
        }
    } else {
        Kind::Var
    };
    Object {
        index: PARAM_BASE + k as u16,
        kind,
        data_type: param_type(p),
        access: param_access(p),
        item: Item::Param(p),
        pdo: false,
    }
}

const fn setting_object(k: usize, s: Setting) -> Object {
    let spec = s.spec();
    Object {
        index: SETTING_BASE + k as u16,
        kind: Kind::Var,
        data_type: spec.data_type,
        access: Access::ReadWrite,
        item: Item::Setting(s),
        pdo: false,
    }
}

/// A read-only record of the PDO communication or mapping parameters.
const fn pdo_record(index: u16, len: u8, item: Item) -> Object {
    comm(
        index,
        Kind::Record { len },
        DataType::Unsigned32,
        Access::ReadOnly,
        item,
    )
}

/// The PDO parameters, in index order: RPDO communication (the value frames', then the
/// sensor frame's), RPDO mapping (the same), TPDO1–3 communication, TPDO1–3 mapping.
const PDO_COUNT: usize = 2 * (RPDOS as usize + 1) + 6;

const fn pdo_objects() -> [Object; PDO_COUNT] {
    let fields = Field::ALL.len() as u8;
    let rpdos = RPDOS as usize + 1;
    let mut t = [pdo_record(TPDO_COMM, 0, Item::TpdoComm); PDO_COUNT];
    let mut k = 0;
    while k < RPDOS as usize {
        t[k] = pdo_record(RPDO_COMM_BASE + k as u16, 2, Item::RpdoComm(k as u8));
        t[rpdos + k] = pdo_record(RPDO_MAP_BASE + k as u16, fields, Item::RpdoMap(k as u8));
        k += 1;
    }
    t[rpdos - 1] = pdo_record(SENSOR_RPDO_COMM, 2, Item::SensorComm);
    t[2 * rpdos - 1] = pdo_record(SENSOR_RPDO_MAP, PLANT_PAIR, Item::SensorMap);
    let status = StatusField::ALL.len() as u8;
    t[PDO_COUNT - 6] = pdo_record(TPDO_COMM, 2, Item::TpdoComm);
    t[PDO_COUNT - 5] = pdo_record(STATUS_TPDO_COMM, 2, Item::StatusComm);
    t[PDO_COUNT - 4] = pdo_record(COMMAND_TPDO_COMM, 2, Item::CommandComm);
    t[PDO_COUNT - 3] = pdo_record(TPDO_MAP, fields, Item::TpdoMap);
    t[PDO_COUNT - 2] = pdo_record(STATUS_TPDO_MAP, status, Item::StatusMap);
    t[PDO_COUNT - 1] = pdo_record(COMMAND_TPDO_MAP, PLANT_PAIR, Item::CommandMap);
    t
}

/// A read-only, PDO-mappable pair of `REAL32`: a bench's sensor or command frame.
const fn plant(index: u16, item: Item) -> Object {
    Object {
        index,
        kind: Kind::Array { len: PLANT_PAIR },
        data_type: DataType::Real32,
        access: Access::ReadOnly,
        item,
        pdo: true,
    }
}

/// The process-data objects of the value frames (own fields, then the heard ones), of the
/// status PDO, and of the bench's sensor and command frames.
const VALUE_COUNT: usize = 2 * Field::ALL.len() + StatusField::ALL.len() + 2;

const fn value_objects() -> [Object; VALUE_COUNT] {
    let n = Field::ALL.len();
    let mut t = [COMM[0]; VALUE_COUNT];
    let mut k = 0;
    while k < n {
        let f = Field::ALL[k];
        t[k] = Object {
            index: TX_VALUE_BASE + k as u16,
            kind: Kind::Var,
            data_type: f.data_type(),
            access: Access::ReadOnly,
            item: Item::TxValue(f),
            pdo: true,
        };
        t[n + k] = Object {
            index: RX_VALUE_BASE + k as u16,
            kind: Kind::Array { len: RPDOS },
            data_type: f.data_type(),
            access: Access::ReadOnly,
            item: Item::RxValue(f),
            pdo: true,
        };
        k += 1;
    }
    let mut j = 0;
    while j < StatusField::ALL.len() {
        let f = StatusField::ALL[j];
        t[2 * n + j] = Object {
            index: STATUS_BASE + j as u16,
            kind: Kind::Var,
            data_type: f.data_type(),
            access: Access::ReadOnly,
            item: Item::Status(f),
            pdo: true,
        };
        j += 1;
    }
    t[VALUE_COUNT - 2] = plant(SENSOR_OBJECT, Item::Sensed);
    t[VALUE_COUNT - 1] = plant(COMMAND_OBJECT, Item::Commanded);
    t
}

const PDO_OBJECTS: [Object; PDO_COUNT] = pdo_objects();
const VALUE_OBJECTS: [Object; VALUE_COUNT] = value_objects();

/// Objects in the dictionary.
pub const OBJECT_COUNT: usize =
    COMM.len() + PDO_COUNT + Param::ALL.len() + Setting::ALL.len() + VALUE_COUNT;

const fn build() -> [Object; OBJECT_COUNT] {
    let mut t = [COMM[0]; OBJECT_COUNT];
    let mut k = 0;
    while k < COMM.len() {
        t[k] = COMM[k];
        k += 1;
    }
    let mut j = 0;
    while j < PDO_COUNT {
        t[k] = PDO_OBJECTS[j];
        k += 1;
        j += 1;
    }
    j = 0;
    while j < Param::ALL.len() {
        t[k] = param_object(j, Param::ALL[j]);
        k += 1;
        j += 1;
    }
    j = 0;
    while j < Setting::ALL.len() {
        t[k] = setting_object(j, Setting::ALL[j]);
        k += 1;
        j += 1;
    }
    j = 0;
    while j < VALUE_COUNT {
        t[k] = VALUE_OBJECTS[j];
        k += 1;
        j += 1;
    }
    t
}

/// The object dictionary, sorted by index: `COMM` entries, the PDO parameters, then one
/// object per [`Param::ALL`] entry, one per [`Setting::ALL`] entry, and the value frames'
/// process data.
pub static OBJECTS: [Object; OBJECT_COUNT] = build();

impl Object {
    /// `ParameterName` (a scenario key for the manufacturer entries). A function of the item,
    /// not a field, so that a firmware that never writes an EDS links none of the names.
    ///
    /// ```
    /// use agent_node::canopen::od::{find, PARAM_BASE};
    /// assert_eq!(find(0x1017).unwrap().name(), "Producer heartbeat time");
    /// assert_eq!(find(PARAM_BASE).unwrap().name(), "simulation.h");
    /// ```
    #[must_use]
    pub const fn name(&self) -> &'static str {
        match self.item {
            Item::DeviceType => "Device type",
            Item::ErrorRegister => "Error register",
            Item::ErrorField => "Pre-defined error field",
            Item::SyncCobId => "COB-ID SYNC",
            Item::DeviceName => "Manufacturer device name",
            Item::SoftwareVersion => "Manufacturer software version",
            Item::Store => "Store parameters",
            Item::Restore => "Restore default parameters",
            Item::EmcyCobId => "COB-ID EMCY",
            Item::HeartbeatConsumer => "Consumer heartbeat time",
            Item::HeartbeatProducer => "Producer heartbeat time",
            Item::Identity => "Identity object",
            Item::SdoServer => "SDO server parameter",
            Item::RpdoComm(_) | Item::SensorComm => "RPDO communication parameter",
            Item::RpdoMap(_) | Item::SensorMap => "RPDO mapping parameter",
            Item::TpdoComm | Item::StatusComm | Item::CommandComm => "TPDO communication parameter",
            Item::TpdoMap | Item::StatusMap | Item::CommandMap => "TPDO mapping parameter",
            Item::Param(p) => p.spec().key,
            Item::Setting(x) => x.spec().key,
            Item::TxValue(f) | Item::RxValue(f) => f.name(),
            Item::Status(f) => f.name(),
            Item::Sensed => "Sensor frame x_i (bench host's plant state)",
            Item::Commanded => "Command frame q_i (the node's commands)",
        }
    }
}

/// The object at `index`.
///
/// ```
/// use agent_node::canopen::od::find;
/// assert_eq!(find(0x1018).unwrap().name(), "Identity object");
/// assert!(find(0x1002).is_none());
/// ```
#[must_use]
pub fn find(index: u16) -> Option<&'static Object> {
    OBJECTS
        .binary_search_by_key(&index, |o| o.index)
        .ok()
        .and_then(|k| OBJECTS.get(k))
}

/// Name of sub-index `sub` of a record or array (the EDS `ParameterName`).
///
/// ```
/// use agent_node::canopen::od::{find, sub_name};
/// let id = find(0x1018).unwrap();
/// assert_eq!((sub_name(id, 0), sub_name(id, 4)), ("Highest sub-index supported", "Serial number"));
/// ```
#[must_use]
pub fn sub_name(o: &Object, sub: u8) -> &'static str {
    match (o.item, sub) {
        (_, 0) => "Highest sub-index supported",
        (Item::Store, _) => "Save all parameters",
        (Item::Restore, _) => "Restore all default parameters",
        (Item::Identity, 1) => "Vendor-ID",
        (Item::Identity, 2) => "Product code",
        (Item::Identity, 3) => "Revision number",
        (Item::Identity, _) => "Serial number",
        (Item::SdoServer, 1) => "COB-ID client to server",
        (Item::SdoServer, _) => "COB-ID server to client",
        (Item::HeartbeatConsumer, _) => "Consumer heartbeat time",
        (Item::ErrorField, _) => "Standard error field",
        (Item::Param(Param::Neighbours), _) => "Neighbour",
        (Item::RpdoComm(_) | Item::TpdoComm | Item::StatusComm, 1) => "COB-ID used by PDO",
        (Item::SensorComm | Item::CommandComm, 1) => "COB-ID used by PDO",
        (Item::RpdoComm(_) | Item::TpdoComm | Item::StatusComm, _) => "Transmission type",
        (Item::SensorComm | Item::CommandComm, _) => "Transmission type",
        (Item::RpdoMap(_) | Item::TpdoMap | Item::StatusMap, _) => "Mapped object",
        (Item::SensorMap | Item::CommandMap, _) => "Mapped object",
        (Item::Sensed | Item::Commanded, 1) => "State or command 1",
        (Item::Sensed | Item::Commanded, _) => "State or command 2",
        (Item::RxValue(_), 1) => "Leader (RPDO1)",
        (Item::RxValue(_), _) => "Neighbour slot (RPDO 2..)",
        _ => "Step",
    }
}

/// Type of sub-index `sub` (`> 0`) of `o`: a PDO's transmission type is `UNSIGNED8`, every
/// other entry the object's [`Object::data_type`].
///
/// ```
/// use agent_node::canopen::od::{find, sub_data_type, DataType, TPDO_COMM};
/// let tpdo = find(TPDO_COMM).unwrap();
/// assert_eq!(sub_data_type(tpdo, 1), DataType::Unsigned32); // COB-ID
/// assert_eq!(sub_data_type(tpdo, 2), DataType::Unsigned8); // transmission type
/// ```
#[must_use]
pub fn sub_data_type(o: &Object, sub: u8) -> DataType {
    match (o.item, sub) {
        (_, 0) if o.kind != Kind::Var => DataType::Unsigned8,
        (Item::RpdoComm(_) | Item::TpdoComm | Item::StatusComm, 2) => DataType::Unsigned8,
        (Item::SensorComm | Item::CommandComm, 2) => DataType::Unsigned8,
        _ => o.data_type,
    }
}

/// Why a [`ConfigError`] refused a write of `written`: `0x0609_0030`/`31`/`32` when the
/// written value is out of its own range, `0x0604_0043` (general parameter incompatibility)
/// when it conflicts with another parameter.
///
/// ```
/// use agent_node::canopen::{od::config_abort, Abort};
/// use controller_core::{ConfigError, Param, Reason};
/// let e = ConfigError::new(Param::PhiLow, Reason::Exceeds(Param::PhiUp));
/// assert_eq!(config_abort(&e, Param::PhiLow), Abort::ValueTooHigh); // φ_low above φ_up
/// assert_eq!(config_abort(&e, Param::PhiUp), Abort::ParamIncompatible); // written φ_up clashes
/// ```
#[must_use]
pub fn config_abort(e: &ConfigError, written: Param) -> Abort {
    if e.param() != written {
        return Abort::ParamIncompatible;
    }
    match e.reason() {
        Reason::Exceeds(_) | Reason::TooLarge | Reason::OverCapacity => Abort::ValueTooHigh,
        Reason::NotAbove(_) | Reason::BelowInitialEstimates => Abort::ValueTooLow,
        Reason::Unpaired
        | Reason::BaselineOnly
        | Reason::Conflicts(_)
        | Reason::NotBuilt
        | Reason::Isolated
        | Reason::StepCount { .. } => Abort::ParamIncompatible,
        _ => Abort::ValueRange,
    }
}

/// The node's own settings as they are stored (the [`Setting`] objects).
///
/// ```
/// # use agent_node::canopen::od::ParamStore;
/// # use agent_node::NodeConfig;
/// # use controller_core::ControllerConfig;
/// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
/// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
/// # #[allow(unused_mut)]
/// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
/// assert_eq!((store.node.node_id, store.node.neighbours[0]), (2, 1));
/// assert_eq!(store.node.stale_timeout, 0.0025); // 2.5 ms in seconds
/// assert!(store.node.stop_decel.is_nan()); // no stop policy
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeSettings {
    /// Node-ID in use (= agent number).
    pub node_id: u8,
    /// Where the value frames (the PDOs) sit, as written (`node.id_base`, …; applied by reset
    /// node / reset communication; the PDO COB-IDs report it).
    pub ids: crate::wire::IdPlan,
    /// Node-ID written and not yet applied (applied by reset node / reset communication).
    pub pending_node_id: u8,
    /// The graph row as written (applied by reset node / reset communication): the first
    /// `neighbour_count` entries are the agents heard; the others are kept for a row being
    /// written entry by entry.
    pub neighbours: [u8; MAX_NEIGHBOURS],
    /// The node's own heartbeat period \[µs\] (not an object: it decides whether the plan
    /// needs heartbeat identifiers).
    pub heartbeat_period_us: u64,
    /// Stale timeout (s).
    pub stale_timeout: f32,
    /// Supervision; the policies' rates are [`Self::stop_decel`], [`Self::ramp_rate`].
    pub supervisor: SupervisorConfig,
    /// `stop_decel` (NaN: none).
    pub stop_decel: f32,
    /// `ramp_rate` (NaN: none).
    pub ramp_rate: f32,
}

const fn policy_index(p: SafePolicy) -> u8 {
    match p {
        SafePolicy::HoldPosition => 0,
        SafePolicy::Stop { .. } => 1,
        SafePolicy::Hold => 2,
        SafePolicy::Ramp { .. } => 3,
        SafePolicy::Off => 4,
    }
}

fn policy_from(index: u8, decel: f32, rate: f32) -> Option<SafePolicy> {
    Some(match index {
        0 => SafePolicy::HoldPosition,
        1 => SafePolicy::Stop { decel },
        2 => SafePolicy::Hold,
        3 => SafePolicy::Ramp { rate },
        4 => SafePolicy::Off,
        _ => return None,
    })
}

fn secs(us: Option<u64>) -> f32 {
    us.map_or(0.0, |us| us as f32 / 1e6)
}

/// Seconds to µs for a timeout: 0 is none; finite, in `[0, 1e6]`.
fn micros(s: f32) -> Result<Option<u64>, Abort> {
    if s.is_nan() {
        return Err(Abort::ValueRange);
    }
    if s < 0.0 {
        return Err(Abort::ValueTooLow);
    }
    if s > 1e6 {
        return Err(Abort::ValueTooHigh);
    }
    let us = micros_from_secs(s);
    Ok((us > 0).then_some(us))
}

/// A decoded value of a numeric object.
///
/// ```
/// use agent_node::canopen::od::{DataType, Value};
/// let bytes = Value::Real(0.5).encode(DataType::Real32);
/// assert_eq!(Value::decode(DataType::Real32, bytes.as_slice()), Ok(Value::Real(0.5)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// `BOOLEAN`.
    Bool(bool),
    /// `UNSIGNED8`, `UNSIGNED16`, `UNSIGNED32`.
    Unsigned(u32),
    /// `REAL32`.
    Real(f32),
}

impl Value {
    /// Little-endian bytes of type `t`.
    ///
    /// ```
    /// use agent_node::canopen::od::{DataType, Value};
    /// assert_eq!(Value::Unsigned(0x1234).encode(DataType::Unsigned16).as_slice(), &[0x34, 0x12]);
    /// assert_eq!(Value::Bool(true).encode(DataType::Boolean).as_slice(), &[1]);
    /// ```
    #[must_use]
    pub fn encode(self, t: DataType) -> SdoData {
        let mut d = SdoData::default();
        let (bytes, n) = match (self, t) {
            (Self::Real(v), _) => (v.to_le_bytes(), 4),
            (Self::Bool(b), _) => ([u8::from(b), 0, 0, 0], 1),
            (Self::Unsigned(v), t) => (v.to_le_bytes(), t.size().unwrap_or(4)),
        };
        d.extend(bytes.get(..n).unwrap_or(&bytes));
        d
    }

    /// The value of type `t` in `bytes` (exactly its size, else the length abort).
    ///
    /// ```
    /// use agent_node::canopen::{od::{DataType, Value}, Abort};
    /// assert_eq!(Value::decode(DataType::Unsigned8, &[7]), Ok(Value::Unsigned(7)));
    /// assert_eq!(Value::decode(DataType::Unsigned8, &[7, 0]), Err(Abort::LengthTooHigh));
    /// ```
    pub fn decode(t: DataType, bytes: &[u8]) -> Result<Self, Abort> {
        let size = t.size().ok_or(Abort::ReadOnly)?;
        if bytes.len() > size {
            return Err(Abort::LengthTooHigh);
        }
        if bytes.len() < size {
            return Err(Abort::LengthTooLow);
        }
        let mut b = [0u8; 4];
        for (d, s) in b.iter_mut().zip(bytes) {
            *d = *s;
        }
        Ok(match t {
            DataType::Boolean => match b[0] {
                0 => Self::Bool(false),
                1 => Self::Bool(true),
                _ => return Err(Abort::ValueRange),
            },
            DataType::Real32 => Self::Real(f32::from_le_bytes(b)),
            _ => Self::Unsigned(u32::from_le_bytes(b)),
        })
    }
}

/// The values behind the manufacturer entries: the scenario sections of the controller (as a
/// scenario file gives them) and the node's settings. Every write is checked by the
/// constructors a scenario file goes through — `ControllerConfig::from_sections` and
/// `Params::new` for a controller parameter, `Supervisor::new` for a setting — on a copy, and
/// committed only when they accept it.
///
/// ```
/// # use agent_node::canopen::od::ParamStore;
/// # use agent_node::NodeConfig;
/// # use controller_core::ControllerConfig;
/// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
/// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
/// # #[allow(unused_mut)]
/// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
/// use agent_node::canopen::{od::Value, Abort};
/// use controller_core::Param;
/// // ζ ∈ (0, 1) of (17)–(19): 0.5 accepted, 1.5 refused and the store left as it was.
/// assert_eq!(store.write_param(Param::Zeta, 0, Value::Real(0.5)), Ok(()));
/// assert_eq!(store.write_param(Param::Zeta, 0, Value::Real(1.5)), Err(Abort::ValueRange));
/// assert_eq!(store.controller().unwrap().zeta, 0.5);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ParamStore<const N: usize> {
    /// The controller's sections.
    pub sections: Sections<N>,
    /// The node's settings.
    pub node: NodeSettings,
    /// The node's neighbour capacity `K`.
    pub capacity: usize,
}

/// The parts of a node's configuration the store keeps.
///
/// ```
/// use agent_node::NodeConfig;
/// let cfg = NodeConfig::new(4, [1, 3], 2_500);
/// let id = cfg.identity();
/// assert_eq!((id.agent, id.neighbours), (4, &[1u8, 3][..]));
/// assert_eq!(id.ids.value_base(), 0x101);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct NodeIdentity<'a> {
    /// The agent `i` (and CANopen node-ID).
    pub agent: u8,
    /// Where its value frames (the PDOs) sit.
    pub ids: crate::wire::IdPlan,
    /// Its neighbours, as many as the node's capacity `K`.
    pub neighbours: &'a [u8],
    /// The stale timeout \[µs\].
    pub stale_timeout_us: u64,
    /// The node's own heartbeat period \[µs\] (0: none; else the plan needs heartbeat ids).
    pub heartbeat_period_us: u64,
    /// The supervision settings.
    pub supervisor: SupervisorConfig,
}

/// Why a store could not be built from a configuration.
///
/// ```
/// use agent_node::canopen::od::{ParamStore, StoreError};
/// use agent_node::NodeConfig;
/// use controller_core::ControllerConfig;
/// // Node-IDs end at 127: agent 200 has no CANopen device.
/// let r = ParamStore::new(NodeConfig::new(200, [], 2_500).identity(), &ControllerConfig::<2>::default());
/// let e = r.unwrap_err();
/// assert_eq!(e, StoreError::Unrepresentable);
/// assert!(!e.to_string().is_empty());
/// ```
///
/// `#[non_exhaustive]`: a store that keeps more of the node brings more that may not fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// More neighbours than [`MAX_NEIGHBOURS`] or a node-ID outside `1..=127`.
    Unrepresentable,
}

impl core::fmt::Display for StoreError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Unrepresentable => {
                "the node has no CANopen object dictionary: more neighbours than it holds or a \
                 node-ID outside 1..=127"
            }
        })
    }
}

impl core::error::Error for StoreError {}

impl<const N: usize> ParamStore<N> {
    /// The store of a node built from its configuration (`crate::NodeConfig`'s agent,
    /// neighbours, stale timeout and supervision) and its controller's; `capacity` is the node's
    /// neighbour capacity `K`.
    ///
    /// ```
    /// use agent_node::canopen::od::ParamStore;
    /// use agent_node::NodeConfig;
    /// use controller_core::ControllerConfig;
    /// let ctrl = ControllerConfig::<2>::default();
    /// let store = ParamStore::new(NodeConfig::new(1, [], 2_500).identity(), &ctrl).unwrap();
    /// assert_eq!(store.controller(), Ok(ctrl)); // what the node was built with
    /// assert_eq!(store.capacity, 0);
    /// ```
    pub fn new(
        node: NodeIdentity<'_>,
        controller: &ControllerConfig<N>,
    ) -> Result<Self, StoreError> {
        let mut neighbours = [0u8; MAX_NEIGHBOURS];
        let listed = node
            .neighbours
            .get(..controller.neighbour_count)
            .ok_or(StoreError::Unrepresentable)?;
        if listed.len() > MAX_NEIGHBOURS || !(1..=127).contains(&node.agent) {
            return Err(StoreError::Unrepresentable);
        }
        for (d, s) in neighbours.iter_mut().zip(listed) {
            *d = *s;
        }
        let sup = node.supervisor;
        let (decel, rate) = match (sup.policy, sup.sensor_policy) {
            (SafePolicy::Stop { decel }, _) => (decel, f32::NAN),
            (SafePolicy::Ramp { rate }, _) | (_, SafePolicy::Ramp { rate }) => (f32::NAN, rate),
            _ => (f32::NAN, f32::NAN),
        };
        Ok(Self {
            sections: Sections::from(*controller),
            node: NodeSettings {
                node_id: node.agent,
                ids: node.ids,
                pending_node_id: node.agent,
                neighbours,
                heartbeat_period_us: node.heartbeat_period_us,
                stale_timeout: secs(Some(node.stale_timeout_us)),
                supervisor: sup,
                stop_decel: decel,
                ramp_rate: rate,
            },
            capacity: node.neighbours.len(),
        })
    }

    /// The controller configuration the store holds, validated as a scenario file is.
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use controller_core::Param;
    /// let cfg = store.controller().unwrap();
    /// assert_eq!((cfg.neighbour_count, cfg.pinned, cfg.ts), (1, true, 2.0));
    /// ```
    pub fn controller(&self) -> Result<ControllerConfig<N>, ConfigError> {
        let cfg = self.sections.config()?;
        Params::new(&cfg, self.capacity)?;
        Ok(cfg)
    }

    /// The node's supervision settings.
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use agent_node::SupervisorConfig;
    /// assert_eq!(store.supervisor(), SupervisorConfig::OFF);
    /// ```
    #[must_use]
    pub fn supervisor(&self) -> SupervisorConfig {
        self.node.supervisor
    }

    /// The value of a parameter's object; `sub` is the step of a per-step parameter or the
    /// neighbour slot (1-based), else 0.
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use agent_node::canopen::od::Value;
    /// use controller_core::Param;
    /// assert_eq!(store.read_param(Param::ACheck, 2), Some(Value::Real(90.0))); // ǎ_2
    /// assert_eq!(store.read_param(Param::Neighbours, 1), Some(Value::Unsigned(1))); // slot 1: agent 1
    /// // c_1 absent (computed from Theorem 1): reads NaN.
    /// assert!(matches!(store.read_param(Param::C1, 0), Some(Value::Real(c)) if c.is_nan()));
    /// ```
    #[must_use]
    pub fn read_param(&self, p: Param, sub: u8) -> Option<Value> {
        let s = &self.sections;
        let c = &s.controller;
        let opt = |v: Option<f32>| Value::Real(v.unwrap_or(f32::NAN));
        let step = |v: &heapless::Vec<f32, N>| {
            v.get(usize::from(sub).checked_sub(1)?)
                .copied()
                .map(Value::Real)
        };
        let real = Value::Real;
        Some(match p {
            Param::H => real(s.agent.h),
            Param::Scheme => Value::Unsigned(u32::from(c.scheme == SchemeName::PrescribedTime)),
            Param::Ts => real(c.ts),
            Param::Zeta => real(c.zeta),
            Param::ACheck => return step(&c.a_check),
            Param::P => real(c.p),
            Param::Eta => real(c.eta),
            Param::Tau => real(c.tau),
            Param::Gamma => real(c.gamma),
            Param::MtnOrder => Value::Unsigned(c.mtn_order),
            Param::PhiLow => return step(&c.phi_low),
            Param::PhiUp => return step(&c.phi_up),
            Param::EpsBar => return step(&c.eps_bar),
            Param::DiffL1 => real(c.diff_l1),
            Param::DiffL2 => real(c.diff_l2),
            Param::Varpi0 => real(c.varpi0),
            Param::VarpiDecay => real(c.varpi_decay),
            Param::VarpiMin => real(c.varpi_min),
            Param::Mu0 => real(c.mu0),
            Param::Xi0 => real(c.xi0),
            Param::Lambda0 => real(c.lambda0),
            Param::EstimateMax => real(c.estimate_max),
            Param::C1 => opt(c.c1),
            Param::C2 => opt(c.c2),
            Param::GainReading => {
                Value::Unsigned(u32::from(c.gain_reading == GainReading::Printed))
            }
            Param::Feedforward => {
                Value::Unsigned(u32::from(c.feedforward == Feedforward::Estimated))
            }
            Param::Kappa => opt(c.kappa),
            Param::MuMax => opt(c.mu_max),
            Param::TPrescribed => opt(c.t_prescribed),
            Param::QuantizerEnabled => Value::Bool(s.quantizer.enabled),
            Param::Rho => real(s.quantizer.rho),
            Param::UMin => real(s.quantizer.u_min),
            Param::Direction => Value::Unsigned(u32::from(
                s.quantizer.direction == QuantizerDirection::Magnitude,
            )),
            Param::SafetyEnabled => Value::Bool(s.safety.enabled),
            Param::UMax => opt(s.safety.u_max),
            Param::DuMax => opt(s.safety.du_max),
            Param::RecoveryRate => real(s.safety.recovery_rate),
            Param::RecoveryJump => real(s.safety.recovery_jump),
            Param::Neighbours => Value::Unsigned(u32::from(
                *self
                    .node
                    .neighbours
                    .get(..self.slots())?
                    .get(usize::from(sub).checked_sub(1)?)?,
            )),
            Param::Pinned => Value::Bool(s.agent.pinned),
            Param::StateOrder => Value::Unsigned(N as u32),
        })
    }

    /// Write a parameter (see [`Self::read_param`] for `sub`): checked on a copy by the
    /// scenario file's constructors and committed only if they accept it; the abort says why
    /// not, and the store is unchanged.
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use agent_node::canopen::{od::Value, Abort};
    /// use controller_core::Param;
    /// // T_s > 0 (Theorem 1).
    /// assert_eq!(store.write_param(Param::Ts, 0, Value::Real(0.0)), Err(Abort::ValueRange));
    /// assert_eq!(store.write_param(Param::Ts, 0, Value::Real(0.25)), Ok(()));
    /// assert_eq!(store.read_param(Param::Ts, 0), Some(Value::Real(0.25)));
    /// ```
    pub fn write_param(&mut self, p: Param, sub: u8, v: Value) -> Result<(), Abort> {
        let mut next = self.sections.clone();
        let mut node = self.node;
        if matches!(p, Param::Neighbours | Param::Pinned) {
            self.set_graph(&mut next, &mut node, p, sub, v)?;
        } else {
            set_param(&mut next, p, sub, v)?;
        }
        let cfg = next.config().map_err(|e| config_abort(&e, p))?;
        Params::new(&cfg, self.capacity).map_err(|e| config_abort(&e, p))?;
        self.sections = next;
        self.node = node;
        Ok(())
    }

    /// Entries of the graph row's array (`graph.neighbours` sub-indices `1..=slots`): the
    /// node's neighbour capacity `K`, at most [`MAX_NEIGHBOURS`].
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let dev = device();
    /// use agent_node::canopen::od::PARAM_BASE;
    /// use controller_core::Param;
    /// // device() was built for one neighbour: graph.neighbours has sub-indices 1..=1.
    /// assert_eq!(dev.store.slots(), 1);
    /// let row = PARAM_BASE + Param::ALL.iter().position(|p| *p == Param::Neighbours).unwrap() as u16;
    /// assert!(dev.read(row, 1).is_ok() && dev.read(row, 2).is_err());
    /// ```
    pub fn slots(&self) -> usize {
        self.capacity.min(MAX_NEIGHBOURS)
    }

    /// The node configuration the settings describe, the node-ID as written, checked as
    /// `Node::new` checks a node file ([`crate::NodeConfig::check`]) with `count` neighbours:
    /// `0x0604_0043` when it refuses.
    fn check_node(&self, n: &NodeSettings, count: usize) -> Result<(), Abort> {
        let row = n.neighbours.get(..self.slots()).unwrap_or(&[]);
        let own = crate::own::Own {
            agent: n.pending_node_id,
            stale_timeout_us: 1,
            ids: &n.ids,
            heartbeat_period_us: n.heartbeat_period_us,
        };
        own.check(row, count).map_err(|_| Abort::ParamIncompatible)
    }

    /// Write the graph row: `graph.neighbours` sub-index 0 (how many entries are heard, at
    /// most the capacity: `0x0609_0031`) or an entry `1..=slots` (an agent of the plan:
    /// `0x0609_0032` for 0, `0x0609_0031` beyond the plan), or `graph.pinned`. The row that
    /// results is checked as a node file's ([`crate::NodeConfig::check`]: itself, a duplicate
    /// → `0x0604_0043`) and as a scenario's (`ControllerConfig::from_sections`: neither
    /// neighbours nor the leader → `0x0604_0043`); a refusal leaves it unchanged. Applied at
    /// the next reset communication. Sets `next` and `node`; [`Self::write_param`] checks the
    /// controller and commits.
    fn set_graph(
        &self,
        next: &mut Sections<N>,
        node: &mut NodeSettings,
        p: Param,
        sub: u8,
        v: Value,
    ) -> Result<(), Abort> {
        let count = &mut next.agent.neighbour_count;
        match (p, sub, v) {
            (Param::Pinned, 0, Value::Bool(b)) => next.agent.pinned = b,
            (Param::Neighbours, 0, Value::Unsigned(n)) => {
                *count = usize::try_from(n).map_err(|_| Abort::ValueTooHigh)?;
                if *count > self.slots() {
                    return Err(Abort::ValueTooHigh);
                }
            }
            (Param::Neighbours, _, Value::Unsigned(a)) => {
                let agent = u8::try_from(a).map_err(|_| Abort::ValueTooHigh)?;
                if agent == 0 {
                    return Err(Abort::ValueTooLow);
                }
                if agent > node.ids.agents() {
                    return Err(Abort::ValueTooHigh);
                }
                if agent == node.pending_node_id {
                    return Err(Abort::ParamIncompatible);
                }
                let slot = usize::from(sub)
                    .checked_sub(1)
                    .and_then(|k| node.neighbours.get_mut(k))
                    .ok_or(Abort::NoSubIndex)?;
                *slot = agent;
            }
            _ => return Err(Abort::ValueRange),
        }
        self.check_node(node, next.agent.neighbour_count)
    }

    /// Write the identifier plan (`node.id_base`, `node.heartbeat_id_base`, `node.agents`):
    /// checked by `IdPlan::new` (beyond 11 bits: `0x0609_0031`, no agents: `0x0609_0032`,
    /// value and heartbeat blocks overlapping: `0x0604_0043`) and with the node-ID and the
    /// graph row (an agent outside the plan, a heartbeat without its identifiers:
    /// `0x0604_0043`). Applied at the next reset communication.
    fn write_plan(&mut self, s: Setting, raw: u32) -> Result<(), Abort> {
        use crate::wire::{IdPlan, IdPlanError};
        let ids = self.node.ids;
        let (mut base, mut hb, mut agents) = (ids.value_base(), ids.heartbeat_base(), ids.agents());
        let wide = u16::try_from(raw).map_err(|_| Abort::ValueTooHigh)?;
        match s {
            Setting::IdBase => base = wide,
            Setting::HeartbeatIdBase => hb = (wide != u16::MAX).then_some(wide),
            _ => agents = u8::try_from(raw).map_err(|_| Abort::ValueTooHigh)?,
        }
        let mut n = self.node;
        n.ids = IdPlan::new(base, hb, agents).map_err(|e| match e {
            IdPlanError::NoAgents => Abort::ValueTooLow,
            IdPlanError::ValueRange | IdPlanError::HeartbeatRange => Abort::ValueTooHigh,
            _ => Abort::ParamIncompatible,
        })?;
        self.check_node(&n, self.sections.agent.neighbour_count)?;
        self.node = n;
        Ok(())
    }

    /// The value of a setting's object.
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use agent_node::canopen::od::{Setting, Value};
    /// assert_eq!(store.read_setting(Setting::NodeId), Value::Unsigned(2));
    /// assert_eq!(store.read_setting(Setting::LeaderTimeout), Value::Real(0.0)); // not supervised
    /// ```
    #[must_use]
    pub fn read_setting(&self, s: Setting) -> Value {
        let n = &self.node;
        let sup = &n.supervisor;
        match s {
            Setting::NodeId => Value::Unsigned(u32::from(n.pending_node_id)),
            Setting::StaleTimeout => Value::Real(n.stale_timeout),
            Setting::Policy => Value::Unsigned(u32::from(policy_index(sup.policy))),
            Setting::StopDecel => Value::Real(n.stop_decel),
            Setting::SensorPolicy => Value::Unsigned(u32::from(policy_index(sup.sensor_policy))),
            Setting::RampRate => Value::Real(n.ramp_rate),
            Setting::ReentryRate => Value::Real(sup.reentry_rate),
            Setting::LeaderTimeout => Value::Real(secs(sup.leader_timeout_us)),
            Setting::NeighbourTimeout => Value::Real(secs(sup.neighbour_timeout_us)),
            Setting::NeighbourLoss => {
                Value::Unsigned(u32::from(sup.neighbour_loss == NeighbourLoss::Any))
            }
            Setting::SensorTimeout => Value::Real(secs(sup.sensor_timeout_us)),
            Setting::RecoverDwell => Value::Real(secs(Some(sup.recover_dwell_us))),
            Setting::IdBase => Value::Unsigned(u32::from(n.ids.value_base())),
            Setting::HeartbeatIdBase => {
                Value::Unsigned(u32::from(n.ids.heartbeat_base().unwrap_or(u16::MAX)))
            }
            Setting::Agents => Value::Unsigned(u32::from(n.ids.agents())),
        }
    }

    /// Write a setting, checked on a copy by `Supervisor::new` (and the node's own checks).
    ///
    /// ```
    /// # use agent_node::canopen::od::ParamStore;
    /// # use agent_node::NodeConfig;
    /// # use controller_core::ControllerConfig;
    /// # // The store of agent 2 hearing agent 1 and the leader (Example 1's defaults otherwise).
    /// # let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// # #[allow(unused_mut)]
    /// # let mut store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// use agent_node::canopen::od::{Setting, Value};
    /// // Supervise the leader with a 50 ms timeout.
    /// store.write_setting(Setting::LeaderTimeout, Value::Real(0.05)).unwrap();
    /// assert_eq!(store.supervisor().leader_timeout_us, Some(50_000));
    /// assert!(store.write_setting(Setting::LeaderTimeout, Value::Real(-1.0)).is_err());
    /// ```
    pub fn write_setting(&mut self, s: Setting, v: Value) -> Result<(), Abort> {
        if let (Setting::IdBase | Setting::HeartbeatIdBase | Setting::Agents, Value::Unsigned(u)) =
            (s, v)
        {
            return self.write_plan(s, u);
        }
        let mut n = self.node;
        let real = match v {
            Value::Real(x) => x,
            _ => f32::NAN,
        };
        let index = match v {
            Value::Unsigned(u) => u8::try_from(u).map_err(|_| Abort::ValueTooHigh)?,
            _ => 0,
        };
        if s == Setting::NodeId && (1..=127).contains(&index) {
            // Not one of its own neighbours, and an agent of the plan.
            n.pending_node_id = index;
            self.check_node(&n, self.sections.agent.neighbour_count)?;
        }
        let sup = &mut n.supervisor;
        match s {
            Setting::NodeId if !(1..=127).contains(&index) => return Err(Abort::ValueRange),
            Setting::NodeId => n.pending_node_id = index,
            Setting::StaleTimeout => {
                if micros(real)?.is_none() {
                    return Err(Abort::ValueTooLow);
                }
                n.stale_timeout = real;
            }
            Setting::Policy | Setting::SensorPolicy => {
                let p = policy_from(index, n.stop_decel, n.ramp_rate).ok_or(Abort::ValueRange)?;
                if s == Setting::Policy {
                    sup.policy = p;
                } else {
                    sup.sensor_policy = p;
                }
            }
            Setting::StopDecel => {
                n.stop_decel = real;
                if let SafePolicy::Stop { decel } = &mut sup.policy {
                    *decel = real;
                }
            }
            Setting::RampRate => {
                n.ramp_rate = real;
                for p in [&mut sup.policy, &mut sup.sensor_policy] {
                    if let SafePolicy::Ramp { rate } = p {
                        *rate = real;
                    }
                }
            }
            Setting::ReentryRate => sup.reentry_rate = real,
            Setting::LeaderTimeout => sup.leader_timeout_us = micros(real)?,
            Setting::NeighbourTimeout => sup.neighbour_timeout_us = micros(real)?,
            Setting::NeighbourLoss => {
                sup.neighbour_loss = match index {
                    0 => NeighbourLoss::All,
                    1 => NeighbourLoss::Any,
                    _ => return Err(Abort::ValueRange),
                };
            }
            Setting::SensorTimeout => sup.sensor_timeout_us = micros(real)?,
            Setting::RecoverDwell => sup.recover_dwell_us = micros(real)?.unwrap_or(0),
            Setting::IdBase | Setting::HeartbeatIdBase | Setting::Agents => {
                return Err(Abort::ValueRange)
            }
        }
        Supervisor::new(sup).map_err(|_| Abort::ValueRange)?;
        self.node = n;
        Ok(())
    }
}

/// Set one parameter in `s` (no validation beyond the encoding: names by position, counts).
fn set_param<const N: usize>(
    s: &mut Sections<N>,
    p: Param,
    sub: u8,
    v: Value,
) -> Result<(), Abort> {
    let (real, unsigned, switch) = match v {
        Value::Real(x) => (x, 0, false),
        Value::Unsigned(u) => (f32::NAN, u, false),
        Value::Bool(b) => (f32::NAN, 0, b),
    };
    let opt = (!real.is_nan()).then_some(real);
    let names = |list: &[&str]| {
        if (unsigned as usize) < list.len() {
            Ok(unsigned == 1)
        } else {
            Err(Abort::ValueRange)
        }
    };
    let c = &mut s.controller;
    let step = |v: &mut heapless::Vec<f32, N>| -> Result<(), Abort> {
        let slot = usize::from(sub)
            .checked_sub(1)
            .and_then(|j| v.get_mut(j))
            .ok_or(Abort::NoSubIndex)?;
        *slot = real;
        Ok(())
    };
    match p {
        Param::H => s.agent.h = real,
        Param::Scheme => {
            c.scheme = if names(SCHEMES)? {
                SchemeName::PrescribedTime
            } else {
                SchemeName::PredefinedTime
            };
        }
        Param::Ts => c.ts = real,
        Param::Zeta => c.zeta = real,
        Param::ACheck => step(&mut c.a_check)?,
        Param::P => c.p = real,
        Param::Eta => c.eta = real,
        Param::Tau => c.tau = real,
        Param::Gamma => c.gamma = real,
        Param::MtnOrder => c.mtn_order = unsigned,
        Param::PhiLow => step(&mut c.phi_low)?,
        Param::PhiUp => step(&mut c.phi_up)?,
        Param::EpsBar => step(&mut c.eps_bar)?,
        Param::DiffL1 => c.diff_l1 = real,
        Param::DiffL2 => c.diff_l2 = real,
        Param::Varpi0 => c.varpi0 = real,
        Param::VarpiDecay => c.varpi_decay = real,
        Param::VarpiMin => c.varpi_min = real,
        Param::Mu0 => c.mu0 = real,
        Param::Xi0 => c.xi0 = real,
        Param::Lambda0 => c.lambda0 = real,
        Param::EstimateMax => c.estimate_max = real,
        Param::C1 => c.c1 = opt,
        Param::C2 => c.c2 = opt,
        Param::GainReading => {
            c.gain_reading = if names(GAIN_READINGS)? {
                GainReading::Printed
            } else {
                GainReading::Reconstructed
            };
        }
        Param::Feedforward => {
            c.feedforward = if names(FEEDFORWARDS)? {
                Feedforward::Estimated
            } else {
                Feedforward::Off
            };
        }
        Param::Kappa => c.kappa = opt,
        Param::MuMax => c.mu_max = opt,
        Param::TPrescribed => c.t_prescribed = opt,
        Param::QuantizerEnabled => s.quantizer.enabled = switch,
        Param::Rho => s.quantizer.rho = real,
        Param::UMin => s.quantizer.u_min = real,
        Param::Direction => {
            s.quantizer.direction = if names(DIRECTIONS)? {
                QuantizerDirection::Magnitude
            } else {
                QuantizerDirection::Signed
            };
        }
        Param::SafetyEnabled => s.safety.enabled = switch,
        Param::UMax => s.safety.u_max = opt,
        Param::DuMax => s.safety.du_max = opt,
        Param::RecoveryRate => s.safety.recovery_rate = real,
        Param::RecoveryJump => s.safety.recovery_jump = real,
        Param::Neighbours | Param::Pinned | Param::StateOrder => return Err(Abort::ReadOnly),
    }
    Ok(())
}

/// The default of a parameter as an EDS `DefaultValue` can state it (a number; a name's
/// position; a switch), `None` when computed, absent or given elsewhere.
///
/// ```
/// use agent_node::canopen::od::{param_default, Value};
/// use controller_core::Param;
/// assert_eq!(param_default(Param::Ts), Some(Value::Real(2.0)));
/// assert_eq!(param_default(Param::MtnOrder), Some(Value::Unsigned(2)));
/// assert_eq!(param_default(Param::C1), None); // computed (Theorem 1)
/// ```
#[must_use]
pub fn param_default(p: Param) -> Option<Value> {
    let spec = p.spec();
    match spec.default {
        DefaultValue::Num(v) | DefaultValue::PerStep(v) => Some(match spec.range {
            Range::Count { .. } => Value::Unsigned(v as u32),
            _ => Value::Real(v as f32),
        }),
        DefaultValue::Bool(b) => Some(Value::Bool(b)),
        DefaultValue::Name(n) => match spec.range {
            Range::OneOf(names) => names
                .iter()
                .position(|m| *m == n)
                .map(|k| Value::Unsigned(k as u32)),
            _ => None,
        },
        _ => None,
    }
}
