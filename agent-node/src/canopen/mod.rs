//! A CiA 301 (CANopen) device, sans-I/O, `no_std`, no allocation: the NMT slave, the
//! heartbeat producer and consumer, emergency messages (EMCY) with the error register and the
//! pre-defined error field, and an SDO server (expedited and segmented) over the object
//! dictionary of [`od`], whose manufacturer entries are generated from
//! `controller_core::param`. [`eds::write_eds`] writes the matching CiA 306 EDS.
//!
//! The device sees frames as `(identifier, data)` ([`Device::on_frame`]), is advanced by
//! [`Device::tick`] with the clock, and hands back frames to send ([`Device::next_tx`]) and
//! events for the application ([`Device::next_event`]): NMT changes, resets, SYNC, store and
//! restore requests, heartbeats lost and back. Its PDOs are the node's value frames, described
//! read-only by `0x1400`–`0x1A00` and kept field by field in `0x2200`–`0x2213` ([`od`]).
//!
//! ## Identifiers (predefined connection set, node-ID `id` in `1..=127`)
//!
//! | frame | identifier | data |
//! |---|---|---|
//! | NMT (master → all) | `0x000` | command specifier, node-ID (0: all) |
//! | SYNC | `0x080` | none |
//! | EMCY | `0x080 + id` | error code (u16 LE), error register, 5 bytes [`Fault::info`] |
//! | TPDO`k` / RPDO`k` (predefined) | `0x080 + 0x100 k + id` / `0x100 + 0x100 k + id` | – |
//! | TPDO1 / RPDO1–17 of this device | the value frames' identifiers of its `IdPlan` ([`od`], *PDO mapping*) | [`crate::wire`] |
//! | SDO server → client / client → server | `0x580 + id` / `0x600 + id` | 8 bytes |
//! | heartbeat, boot-up | `0x700 + id` | NMT state: `0x00` boot-up, `0x04` stopped, `0x05` operational, `0x7F` pre-operational |

pub mod eds;
pub mod od;

use od::{
    find, Access, DataType, Field, Item, Kind, Object, ParamStore, Value, COB_ID_INVALID,
    COB_ID_NO_RTR, OBJECTS,
};

use crate::wire::{FrameKind, IdPlan, Source, PAYLOAD_LEN};

/// NMT command identifier.
pub const NMT_ID: u16 = 0x000;
/// SYNC identifier.
pub const SYNC_ID: u16 = 0x080;
/// EMCY of node `id`.
///
/// ```
/// use agent_node::canopen::emcy_id;
/// assert_eq!(emcy_id(2), 0x082);
/// ```
#[must_use]
pub const fn emcy_id(id: u8) -> u16 {
    0x080 + id as u16
}
/// TPDO `k` (1..=4) of node `id`.
///
/// ```
/// use agent_node::canopen::tpdo_id;
/// assert_eq!(tpdo_id(1, 2), 0x182); // the predefined set's TPDO1 (the node's own uses its IdPlan)
/// ```
#[must_use]
pub const fn tpdo_id(k: u8, id: u8) -> u16 {
    0x080 + 0x100 * k as u16 + id as u16
}
/// RPDO `k` (1..=4) of node `id`.
///
/// ```
/// use agent_node::canopen::rpdo_id;
/// assert_eq!(rpdo_id(1, 2), 0x202);
/// ```
#[must_use]
pub const fn rpdo_id(k: u8, id: u8) -> u16 {
    0x100 + 0x100 * k as u16 + id as u16
}
/// SDO server → client of node `id`.
///
/// ```
/// use agent_node::canopen::sdo_tx_id;
/// assert_eq!(sdo_tx_id(2), 0x582);
/// ```
#[must_use]
pub const fn sdo_tx_id(id: u8) -> u16 {
    0x580 + id as u16
}
/// SDO client → server of node `id`.
///
/// ```
/// use agent_node::canopen::sdo_rx_id;
/// assert_eq!(sdo_rx_id(2), 0x602);
/// ```
#[must_use]
pub const fn sdo_rx_id(id: u8) -> u16 {
    0x600 + id as u16
}
/// Heartbeat and boot-up of node `id`.
///
/// ```
/// use agent_node::canopen::heartbeat_id;
/// assert_eq!(heartbeat_id(2), 0x702);
/// ```
#[must_use]
pub const fn heartbeat_id(id: u8) -> u16 {
    0x700 + id as u16
}
/// Highest node-ID.
pub const MAX_NODE_ID: u8 = 127;
/// `0x1010` signature "save" (ISO 8859 `s a v e`, read as u32 LE).
pub const SAVE_SIGNATURE: u32 = 0x6576_6173;
/// `0x1011` signature "load".
pub const LOAD_SIGNATURE: u32 = 0x6461_6F6C;
/// An SDO transfer silent this long is aborted with [`Abort::Timeout`] (µs).
pub const SDO_TIMEOUT_US: u64 = 1_000_000;

/// The NMT states of CiA 301 §7.3.2 and their heartbeat byte.
///
/// ```
/// use agent_node::canopen::NmtState;
/// assert_eq!(NmtState::from_code(0x05), Some(NmtState::Operational));
/// assert_eq!(NmtState::PreOperational.code(), 0x7F);
/// assert_eq!(NmtState::Stopped.name(), "STOPPED");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtState {
    /// Initialisation (sent once as the boot-up message, `0x00`).
    Initialising,
    /// Pre-operational (`0x7F`): SDO, EMCY, heartbeat, no PDO; the only state that accepts
    /// writes of the manufacturer entries.
    PreOperational,
    /// Operational (`0x05`): PDOs too; the control outputs are enabled only here.
    Operational,
    /// Stopped (`0x04`): NMT and heartbeat only.
    Stopped,
}

impl NmtState {
    /// The heartbeat byte.
    ///
    /// ```
    /// use agent_node::canopen::NmtState;
    /// assert_eq!(NmtState::Initialising.code(), 0x00); // the boot-up message
    /// assert_eq!(NmtState::Operational.code(), 0x05);
    /// ```
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Initialising => 0x00,
            Self::PreOperational => 0x7F,
            Self::Operational => 0x05,
            Self::Stopped => 0x04,
        }
    }

    /// The state of a heartbeat byte (the toggle bit 7 of node guarding masked off only for
    /// `0x00`..`0x05`; `0x7F` is pre-operational).
    ///
    /// ```
    /// use agent_node::canopen::NmtState;
    /// assert_eq!(NmtState::from_code(0x7F), Some(NmtState::PreOperational));
    /// assert_eq!(NmtState::from_code(0x85), None); // node guarding's toggle bit: not a heartbeat
    /// ```
    #[must_use]
    pub const fn from_code(c: u8) -> Option<Self> {
        match c {
            0x00 => Some(Self::Initialising),
            0x04 => Some(Self::Stopped),
            0x05 => Some(Self::Operational),
            0x7F => Some(Self::PreOperational),
            _ => None,
        }
    }

    /// The name Python `canopen` and most tools print.
    ///
    /// ```
    /// use agent_node::canopen::NmtState;
    /// assert_eq!(NmtState::PreOperational.name(), "PRE-OPERATIONAL"); // as python-canopen prints it
    /// ```
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Initialising => "INITIALISING",
            Self::PreOperational => "PRE-OPERATIONAL",
            Self::Operational => "OPERATIONAL",
            Self::Stopped => "STOPPED",
        }
    }
}

/// NMT command specifiers (CiA 301 §7.2.8.3.1).
///
/// ```
/// # mod hw { include!("doctest_device.rs"); }
/// # use hw::*;
/// # #[allow(unused_mut)]
/// # let mut dev = device();
/// use agent_node::canopen::{NmtCommand, NmtState, NMT_ID};
/// // The master starts node 2 (NMT 0x01, node-ID 2).
/// dev.on_frame(NMT_ID, &[NmtCommand::Start.code(), 2], 1_000);
/// assert_eq!(dev.nmt(), NmtState::Operational);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtCommand {
    /// `0x01` start remote node.
    Start,
    /// `0x02` stop remote node.
    Stop,
    /// `0x80` enter pre-operational.
    EnterPreOperational,
    /// `0x81` reset node.
    ResetNode,
    /// `0x82` reset communication.
    ResetCommunication,
}

impl NmtCommand {
    /// The command specifier.
    ///
    /// ```
    /// use agent_node::canopen::NmtCommand;
    /// assert_eq!(NmtCommand::ResetNode.code(), 0x81);
    /// ```
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Start => 0x01,
            Self::Stop => 0x02,
            Self::EnterPreOperational => 0x80,
            Self::ResetNode => 0x81,
            Self::ResetCommunication => 0x82,
        }
    }

    /// The command of a specifier.
    ///
    /// ```
    /// use agent_node::canopen::NmtCommand;
    /// assert_eq!(NmtCommand::from_code(0x80), Some(NmtCommand::EnterPreOperational));
    /// assert_eq!(NmtCommand::from_code(0x03), None);
    /// ```
    #[must_use]
    pub const fn from_code(c: u8) -> Option<Self> {
        match c {
            0x01 => Some(Self::Start),
            0x02 => Some(Self::Stop),
            0x80 => Some(Self::EnterPreOperational),
            0x81 => Some(Self::ResetNode),
            0x82 => Some(Self::ResetCommunication),
            _ => None,
        }
    }
}

/// SDO abort codes (CiA 301 §7.2.4.3.17): why the device refused an access.
///
/// `#[non_exhaustive]`: CiA 301 defines more codes than the device sends today.
///
/// ```
/// # mod hw { include!("doctest_device.rs"); }
/// # use hw::*;
/// # #[allow(unused_mut)]
/// # let mut dev = device();
/// use agent_node::canopen::Abort;
/// // A write to a read-only object is refused with its CiA 301 code.
/// let e = dev.write(0x1000, 0, &[0; 4]).unwrap_err();
/// assert_eq!((e, e.code()), (Abort::ReadOnly, 0x0601_0002));
/// assert!(e.to_string().contains("0x06010002"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Abort {
    /// `0x0503_0000` toggle bit not alternated.
    Toggle,
    /// `0x0504_0000` SDO protocol timed out.
    Timeout,
    /// `0x0504_0001` client/server command specifier not valid or unknown.
    Command,
    /// `0x0504_0005` out of memory.
    OutOfMemory,
    /// `0x0601_0001` attempt to read a write-only object.
    WriteOnly,
    /// `0x0601_0002` attempt to write a read-only object.
    ReadOnly,
    /// `0x0602_0000` object does not exist in the object dictionary.
    NoObject,
    /// `0x0604_0043` general parameter incompatibility reason.
    ParamIncompatible,
    /// `0x0607_0010` data type does not match, length of service parameter does not match.
    Length,
    /// `0x0607_0012` length of service parameter too high.
    LengthTooHigh,
    /// `0x0607_0013` length of service parameter too low.
    LengthTooLow,
    /// `0x0609_0011` sub-index does not exist.
    NoSubIndex,
    /// `0x0609_0030` invalid value for parameter (value range exceeded).
    ValueRange,
    /// `0x0609_0031` value of parameter written too high.
    ValueTooHigh,
    /// `0x0609_0032` value of parameter written too low.
    ValueTooLow,
    /// `0x0800_0020` data cannot be transferred or stored to the application.
    Transfer,
    /// `0x0800_0022` … because of the present device state.
    DeviceState,
}

impl Abort {
    /// The 32-bit code.
    ///
    /// ```
    /// use agent_node::canopen::Abort;
    /// assert_eq!(Abort::NoObject.code(), 0x0602_0000);
    /// assert_eq!(Abort::ValueTooHigh.code(), 0x0609_0031);
    /// ```
    #[must_use]
    pub const fn code(self) -> u32 {
        match self {
            Self::Toggle => 0x0503_0000,
            Self::Timeout => 0x0504_0000,
            Self::Command => 0x0504_0001,
            Self::OutOfMemory => 0x0504_0005,
            Self::WriteOnly => 0x0601_0001,
            Self::ReadOnly => 0x0601_0002,
            Self::NoObject => 0x0602_0000,
            Self::ParamIncompatible => 0x0604_0043,
            Self::Length => 0x0607_0010,
            Self::LengthTooHigh => 0x0607_0012,
            Self::LengthTooLow => 0x0607_0013,
            Self::NoSubIndex => 0x0609_0011,
            Self::ValueRange => 0x0609_0030,
            Self::ValueTooHigh => 0x0609_0031,
            Self::ValueTooLow => 0x0609_0032,
            Self::Transfer => 0x0800_0020,
            Self::DeviceState => 0x0800_0022,
        }
    }
}

/// The code and CiA 301's words for it, e.g. `SDO abort 0x06010002: attempt to write a
/// read-only object`.
impl core::fmt::Display for Abort {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let what = match self {
            Self::Toggle => "toggle bit not alternated",
            Self::Timeout => "SDO protocol timed out",
            Self::Command => "command specifier not valid or unknown",
            Self::OutOfMemory => "out of memory",
            Self::WriteOnly => "attempt to read a write-only object",
            Self::ReadOnly => "attempt to write a read-only object",
            Self::NoObject => "object does not exist in the object dictionary",
            Self::ParamIncompatible => "general parameter incompatibility",
            Self::Length => "data type or length of service parameter does not match",
            Self::LengthTooHigh => "length of service parameter too high",
            Self::LengthTooLow => "length of service parameter too low",
            Self::NoSubIndex => "sub-index does not exist",
            Self::ValueRange => "invalid value for parameter (value range exceeded)",
            Self::ValueTooHigh => "value of parameter written too high",
            Self::ValueTooLow => "value of parameter written too low",
            Self::Transfer => "data cannot be transferred or stored to the application",
            Self::DeviceState => {
                "data cannot be transferred or stored because of the present device state"
            }
        };
        write!(f, "SDO abort {:#010x}: {what}", self.code())
    }
}

impl core::error::Error for Abort {}

/// Bytes of one SDO value (the longest is a string object).
///
/// ```
/// use agent_node::canopen::SdoData;
/// let mut d = SdoData::default();
/// assert!(d.extend(b"save"));
/// assert_eq!(d.as_slice(), b"save");
/// assert!(!d.extend(&[0; SdoData::CAPACITY])); // does not fit: nothing appended
/// assert_eq!(d.as_slice().len(), 4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SdoData {
    buf: [u8; SdoData::CAPACITY],
    len: usize,
}

impl Default for SdoData {
    fn default() -> Self {
        Self {
            buf: [0; Self::CAPACITY],
            len: 0,
        }
    }
}

impl SdoData {
    /// Most bytes of a value.
    pub const CAPACITY: usize = 32;

    /// The bytes.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// // The producer heartbeat time (0x1017) reads as UNSIGNED16, little-endian.
    /// dev.set_heartbeat_ms(250);
    /// assert_eq!(dev.read(0x1017, 0).unwrap().as_slice(), &250u16.to_le_bytes());
    /// ```
    #[must_use]
    pub fn as_slice(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// Append `bytes`; `false` (and nothing appended) when they do not fit.
    ///
    /// ```
    /// use agent_node::canopen::SdoData;
    /// let mut d = SdoData::default();
    /// assert!(d.extend(&[1, 2]) && d.extend(&[3]));
    /// assert_eq!(d.as_slice(), &[1, 2, 3]);
    /// ```
    pub fn extend(&mut self, bytes: &[u8]) -> bool {
        let end = self.len + bytes.len();
        match self.buf.get_mut(self.len..end) {
            Some(dst) => {
                dst.copy_from_slice(bytes);
                self.len = end;
                true
            }
            None => false,
        }
    }
}

/// A classical CAN frame as the device sees it: 11-bit identifier, up to 8 data bytes.
///
/// ```
/// use agent_node::canopen::CoFrame;
/// use agent_node::link::CanFrame;
/// let f = CoFrame::new(0x702, &[0x05]); // node 2's heartbeat: operational
/// let can: CanFrame = f.to_frame().unwrap();
/// assert_eq!(CoFrame::from_frame(&can), Some(f));
/// assert_eq!(f.data(), &[0x05]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CoFrame {
    /// Identifier.
    pub id: u16,
    /// Data length.
    pub len: u8,
    /// Data (`len` bytes used).
    pub data: [u8; 8],
}

impl CoFrame {
    /// A frame of `data` (at most 8 bytes; more are cut).
    ///
    /// ```
    /// use agent_node::canopen::CoFrame;
    /// let f = CoFrame::new(0x080, &[]); // SYNC
    /// assert_eq!((f.id, f.len), (0x080, 0));
    /// assert_eq!(CoFrame::new(0x602, &[0; 10]).len, 8); // more than 8 bytes are cut
    /// ```
    #[must_use]
    pub fn new(id: u16, data: &[u8]) -> Self {
        let mut f = Self {
            id,
            len: data.len().min(8) as u8,
            data: [0; 8],
        };
        for (d, s) in f.data.iter_mut().zip(data) {
            *d = *s;
        }
        f
    }

    /// The data bytes.
    ///
    /// ```
    /// use agent_node::canopen::CoFrame;
    /// assert_eq!(CoFrame::new(0x582, &[0x60, 0x17, 0x10, 0]).data(), &[0x60, 0x17, 0x10, 0]);
    /// ```
    #[must_use]
    pub fn data(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&self.data)
    }

    /// As an `embedded-can` frame (`None` if the type refuses it).
    ///
    /// ```
    /// use agent_node::canopen::CoFrame;
    /// use agent_node::link::CanFrame;
    /// use embedded_can::Frame;
    /// let f: CanFrame = CoFrame::new(0x082, &[0; 8]).to_frame().unwrap();
    /// assert_eq!((f.raw_id(), f.dlc()), (0x082, 8));
    /// assert!(CoFrame::new(0x800, &[]).to_frame::<CanFrame>().is_none()); // beyond 11 bits
    /// ```
    #[must_use]
    pub fn to_frame<F: embedded_can::Frame>(&self) -> Option<F> {
        let id = embedded_can::StandardId::new(self.id)?;
        F::new(id, self.data())
    }

    /// From an `embedded-can` data frame with a standard identifier.
    ///
    /// ```
    /// use agent_node::canopen::CoFrame;
    /// use agent_node::link::CanFrame;
    /// use embedded_can::{ExtendedId, Frame};
    /// let ext = CanFrame::new(ExtendedId::new(0x702).unwrap(), &[5]).unwrap();
    /// assert_eq!(CoFrame::from_frame(&ext), None); // CANopen uses 11-bit identifiers
    /// ```
    pub fn from_frame<F: embedded_can::Frame>(f: &F) -> Option<Self> {
        match f.id() {
            embedded_can::Id::Standard(id) if !f.is_remote_frame() => {
                Some(Self::new(id.as_raw(), f.data()))
            }
            _ => None,
        }
    }
}

/// What the application learns from the device.
///
/// ```
/// # mod hw { include!("doctest_device.rs"); }
/// # use hw::*;
/// # #[allow(unused_mut)]
/// # let mut dev = device();
/// use agent_node::canopen::{Event, NmtState, SYNC_ID};
/// dev.on_frame(SYNC_ID, &[], 10);
/// assert_eq!(dev.next_event(), Some(Event::Sync));
/// dev.on_frame(0x000, &[0x01, 0], 20); // NMT start, all nodes
/// assert_eq!(dev.next_event(), Some(Event::Nmt(NmtState::Operational)));
/// ```
///
/// `#[non_exhaustive]`: the device tells the application more as it learns more services.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Event {
    /// The NMT state changed to this one (outputs are enabled only in `Operational`).
    Nmt(NmtState),
    /// NMT reset node: reload the stored parameters, then the device resets communication.
    ResetNode,
    /// NMT reset communication (done; the node-ID written to `node.node_id` is now in use).
    ResetCommunication,
    /// A SYNC frame.
    #[default]
    Sync,
    /// `0x1010` "save": persist [`Device::save`]'s bytes.
    Store,
    /// `0x1011` "load": the defaults are back in the store; forget the persisted copy.
    Restore,
    /// A manufacturer entry was written (index, sub-index).
    Written(u16, u8),
    /// The heartbeat of this node-ID (a consumer of `0x1016`) timed out.
    HeartbeatLost(u8),
    /// A lost heartbeat came back.
    HeartbeatResumed(u8),
}

/// A fault the node reports by EMCY, with its CiA 301 error code.
///
/// ```
/// use agent_node::canopen::Fault;
/// // The supervisor lost the leader (bit 0): RPDO timeout, a communication error.
/// let f = Fault::SafeState(0b001);
/// assert_eq!((f.code(), f.register_bits()), (0x8250, 0x11));
/// assert_eq!(Fault::SafeState(0b100).code(), 0x7300); // the sensor alone
/// assert_eq!(f.info(3), [1, 0b001, 3, 0, 0]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The supervisor entered its safe state; the lost sources (bit 0 leader, 1 neighbours,
    /// 2 sensor). `0x8250` RPDO timeout for a value source, `0x7300` sensor for the sensor.
    SafeState(u8),
    /// A sensor read failed or gave a non-finite state: `0x7300`.
    SensorInvalid,
    /// The board restarted after a watchdog reset: `0x6100` internal software.
    WatchdogReset,
    /// A control step overran its deadline: `0x6200` user software.
    Overrun,
    /// The CAN controller recovered from bus-off: `0x8140`.
    BusOff,
    /// Received frames were lost (receive FIFO overflow): `0x8110` CAN overrun.
    RxOverflow,
    /// The stored configuration was refused at start-up: `0x6300` data set.
    ConfigRejected,
    /// The node latched its `Fault` state: `0x1000` generic error.
    Fault,
    /// A consumed heartbeat (`0x1016`) timed out; its node-ID: `0x8130`.
    HeartbeatLost(u8),
    /// The host that simulates the node's plant went silent: no sensor frame (the sensor
    /// RPDO) within the node's host timeout while running: `0x8250` RPDO timeout. The node
    /// stops after it (`node-linux`: exit 3).
    HostLost,
}

impl Fault {
    /// CiA 301 emergency error code.
    ///
    /// ```
    /// use agent_node::canopen::Fault;
    /// assert_eq!(Fault::Overrun.code(), 0x6200);
    /// assert_eq!(Fault::HeartbeatLost(4).code(), 0x8130);
    /// ```
    #[must_use]
    pub const fn code(self) -> u16 {
        match self {
            Self::SafeState(lost) if lost & 0b11 == 0 => 0x7300,
            Self::SafeState(_) => 0x8250,
            Self::SensorInvalid => 0x7300,
            Self::WatchdogReset => 0x6100,
            Self::Overrun => 0x6200,
            Self::BusOff => 0x8140,
            Self::RxOverflow => 0x8110,
            Self::ConfigRejected => 0x6300,
            Self::Fault => 0x1000,
            Self::HeartbeatLost(_) => 0x8130,
            Self::HostLost => 0x8250,
        }
    }

    /// Error register (`0x1001`) bits besides generic (bit 0): communication (bit 4) for the
    /// `0x81xx`/`0x82xx` codes, manufacturer-specific (bit 7) for the others.
    ///
    /// ```
    /// use agent_node::canopen::Fault;
    /// assert_eq!(Fault::BusOff.register_bits(), 0x11); // generic + communication
    /// assert_eq!(Fault::Fault.register_bits(), 0x01); // generic only
    /// assert_eq!(Fault::Overrun.register_bits(), 0x81); // generic + manufacturer
    /// ```
    #[must_use]
    pub const fn register_bits(self) -> u8 {
        match self.code() >> 8 {
            0x81 | 0x82 => 0x11,
            0x10 => 0x01,
            _ => 0x81,
        }
    }

    /// Manufacturer-specific EMCY bytes: byte 0 the cause (1 safe state, 2 sensor invalid,
    /// 3 watchdog reset, 4 overrun, 5 bus-off, 6 receive overflow, 7 configuration rejected,
    /// 8 fault, 9 heartbeat lost, 10 host lost), byte 1 the lost sources or the node-ID, bytes 2–3 a
    /// count (u16 LE, e.g. overruns since start), byte 4 zero.
    ///
    /// ```
    /// use agent_node::canopen::Fault;
    /// assert_eq!(Fault::Overrun.info(300), [4, 0, 44, 1, 0]); // cause 4, 300 overruns
    /// assert_eq!(Fault::HeartbeatLost(7).info(0), [9, 7, 0, 0, 0]);
    /// ```
    #[must_use]
    pub const fn info(self, count: u16) -> [u8; 5] {
        let (cause, detail) = match self {
            Self::SafeState(lost) => (1, lost),
            Self::SensorInvalid => (2, 0),
            Self::WatchdogReset => (3, 0),
            Self::Overrun => (4, 0),
            Self::BusOff => (5, 0),
            Self::RxOverflow => (6, 0),
            Self::ConfigRejected => (7, 0),
            Self::Fault => (8, 0),
            Self::HeartbeatLost(id) => (9, id),
            Self::HostLost => (10, 0),
        };
        let c = count.to_le_bytes();
        [cause, detail, c[0], c[1], 0]
    }

    /// A condition that stays until cleared (safe state, sensor, fault, heartbeat), not a
    /// one-off event; its slot in the active set.
    const fn condition(self) -> Option<u16> {
        match self {
            Self::SafeState(_) => Some(1 << 0),
            Self::SensorInvalid => Some(1 << 1),
            Self::Fault => Some(1 << 2),
            Self::HeartbeatLost(_) => Some(1 << 3),
            _ => None,
        }
    }
}

/// `0x1018`.
///
/// ```
/// # mod hw { include!("doctest_device.rs"); }
/// # use hw::*;
/// # #[allow(unused_mut)]
/// # let mut dev = device();
/// let id = Identity { vendor: 0, product: 0x2, revision: 0x1_0000, serial: 42 };
/// let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
/// let store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
/// let dev = Device::new(store, id, false);
/// assert_eq!(dev.read(0x1018, 4).unwrap().as_slice(), &42u32.to_le_bytes()); // serial number
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Identity {
    /// Vendor-ID (0: none assigned by CiA).
    pub vendor: u32,
    /// Product code.
    pub product: u32,
    /// Revision number.
    pub revision: u32,
    /// Serial number.
    pub serial: u32,
}

/// A fixed-capacity FIFO that drops the newest entry when full.
#[derive(Debug, Clone, Copy)]
struct Fifo<T: Copy + Default, const C: usize> {
    buf: [T; C],
    head: usize,
    len: usize,
}

impl<T: Copy + Default, const C: usize> Fifo<T, C> {
    fn new() -> Self {
        Self {
            buf: [T::default(); C],
            head: 0,
            len: 0,
        }
    }

    fn push(&mut self, v: T) -> bool {
        if self.len >= C {
            return false;
        }
        if let Some(slot) = self.buf.get_mut((self.head + self.len) % C) {
            *slot = v;
            self.len += 1;
        }
        true
    }

    fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let v = self.buf.get(self.head).copied();
        self.head = (self.head + 1) % C;
        self.len -= 1;
        v
    }
}

/// One entry of the heartbeat consumer (`0x1016`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Consumer {
    /// `(node-ID << 16) | time_ms` as written.
    raw: u32,
    /// Last heartbeat (µs); `None`: not heard since configured (not yet watched).
    last_us: Option<u64>,
    /// Reported lost.
    lost: bool,
    /// Its last NMT state.
    state: Option<NmtState>,
}

impl Consumer {
    const fn node(&self) -> u8 {
        (self.raw >> 16) as u8
    }
    const fn time_us(&self) -> u64 {
        (self.raw & 0xFFFF) as u64 * 1000
    }
}

/// The SDO server's transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Transfer {
    Idle,
    Download {
        index: u16,
        sub: u8,
        toggle: u8,
        data: SdoData,
        size: Option<usize>,
        since: u64,
    },
    Upload {
        index: u16,
        sub: u8,
        toggle: u8,
        data: SdoData,
        pos: usize,
        since: u64,
    },
}

/// The CANopen device of one node. `N`: state order of its controller.
///
/// The examples on `Device` start from `device()` (`src/canopen/doctest_device.rs`, hidden in
/// them): agent 2 hearing agent 1 and the leader, node-ID 2, booted at `t = 0` and so
/// pre-operational, its boot-up message already taken.
///
/// ```
/// # mod hw { include!("doctest_device.rs"); }
/// # use hw::*;
/// # #[allow(unused_mut)]
/// # let mut dev = device();
/// use agent_node::canopen::{sdo_rx_id, sdo_tx_id, NmtState};
/// // An SDO client reads the producer heartbeat time 0x1017:00 (expedited upload).
/// dev.set_heartbeat_ms(100);
/// assert!(dev.on_frame(sdo_rx_id(2), &[0x40, 0x17, 0x10, 0, 0, 0, 0, 0], 1_000));
/// let resp = dev.next_tx().unwrap();
/// assert_eq!(resp.id, sdo_tx_id(2));
/// assert_eq!(resp.data(), &[0x4B, 0x17, 0x10, 0, 100, 0, 0, 0]); // 2 bytes: 100 ms
/// assert_eq!(dev.nmt(), NmtState::PreOperational);
/// ```
#[derive(Debug, Clone)]
pub struct Device<const N: usize> {
    /// The manufacturer entries' values.
    pub store: ParamStore<N>,
    defaults: ParamStore<N>,
    identity: Identity,
    node_id: u8,
    nmt: NmtState,
    self_starting: bool,
    heartbeat_ms: u16,
    next_heartbeat_us: Option<u64>,
    consumers: [Consumer; od::HEARTBEAT_CONSUMERS as usize],
    active: u16,
    register: u8,
    history: [u32; od::ERROR_HISTORY as usize],
    history_len: u8,
    transfer: Transfer,
    tx: Fifo<CoFrame, 16>,
    events: Fifo<Event, 16>,
    now_us: u64,
    /// The node's last value frame sent (TPDO1).
    tpdo: Option<[u8; PAYLOAD_LEN]>,
    /// The last value frame of each RPDO received in operational.
    rpdo: [Option<[u8; PAYLOAD_LEN]>; od::RPDOS as usize],
    /// The graph row, pinning or identifier plan was written (or restored, or loaded) since
    /// the node last adopted them ([`Self::graph_written`]).
    graph_written: bool,
    /// The node's last status PDO sent (TPDO2).
    status: Option<[u8; crate::wire::HEARTBEAT_LEN]>,
    /// The runtime puts its plant on the bus: RPDO18 (sensor) and TPDO3 (command) are valid.
    plant_pdos: bool,
    /// The last sensor frame heard (RPDO18) and command frame sent (TPDO3).
    sensed: [f32; 2],
    commanded: [f32; 2],
}

impl<const N: usize> Device<N> {
    /// A device in `Initialising` with `store` as its values (and its defaults for `0x1011`);
    /// [`Self::boot`] sends the boot-up message. `self_starting`: enter `Operational` at boot
    /// without waiting for an NMT start (simulations that start every node at `t = 0`).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{heartbeat_id, NmtState};
    /// let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
    /// let store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl).unwrap();
    /// let mut dev = Device::new(store, Identity::default(), true); // self-starting
    /// assert_eq!(dev.nmt(), NmtState::Initialising);
    /// dev.boot(0);
    /// assert_eq!(dev.nmt(), NmtState::Operational);
    /// assert_eq!(dev.next_tx().unwrap().id, heartbeat_id(2)); // the boot-up message
    /// ```
    #[must_use]
    pub fn new(store: ParamStore<N>, identity: Identity, self_starting: bool) -> Self {
        Self {
            node_id: store.node.node_id,
            defaults: store.clone(),
            store,
            identity,
            nmt: NmtState::Initialising,
            self_starting,
            heartbeat_ms: 0,
            next_heartbeat_us: None,
            consumers: [Consumer::default(); od::HEARTBEAT_CONSUMERS as usize],
            active: 0,
            register: 0,
            history: [0; od::ERROR_HISTORY as usize],
            history_len: 0,
            transfer: Transfer::Idle,
            tx: Fifo::new(),
            events: Fifo::new(),
            now_us: 0,
            tpdo: None,
            rpdo: [None; od::RPDOS as usize],
            graph_written: false,
            status: None,
            plant_pdos: false,
            sensed: [f32::NAN; 2],
            commanded: [f32::NAN; 2],
        }
    }

    /// The runtime's plant is on the bus (a bench, `crate::plant_bus`, one sensor frame per
    /// agent): the sensor frame (`0x200 + node-ID`) is RPDO18 and the command frame
    /// (`0x300 + node-ID`) TPDO3, both valid from now on.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// use agent_node::canopen::od::{COB_ID_INVALID, SENSOR_RPDO_COMM};
    /// assert_ne!(dev.plant_cob_id(true) & COB_ID_INVALID, 0); // RPDO18 not in use yet
    /// dev.enable_plant_pdos();
    /// // RPDO18 valid: agent 2's sensor frame, 0x200 + node-ID.
    /// assert_eq!(dev.read(SENSOR_RPDO_COMM, 1).unwrap().as_slice(), &0x202u32.to_le_bytes());
    /// ```
    pub fn enable_plant_pdos(&mut self) {
        self.plant_pdos = true;
    }

    /// The COB-ID entry of RPDO18 (`sensor`) or TPDO3: the plant-bus identifier of this node,
    /// bit 31 set unless [`Self::enable_plant_pdos`]; TPDO3 without RTR.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::od::{COB_ID_INVALID, COB_ID_NO_RTR};
    /// // Node-ID 2 without a plant on the bus: both PDOs carry their identifier but are not valid.
    /// assert_eq!(dev.plant_cob_id(true), COB_ID_INVALID | 0x202); // sensor frame, RPDO18
    /// assert_eq!(dev.plant_cob_id(false), COB_ID_INVALID | COB_ID_NO_RTR | 0x302); // command, TPDO3
    /// ```
    pub fn plant_cob_id(&self, sensor: bool) -> u32 {
        let (kind, rtr) = if sensor {
            (crate::plant_bus::Kind::Sensor, 0)
        } else {
            (crate::plant_bus::Kind::Command, COB_ID_NO_RTR)
        };
        let id = kind
            .id(self.node_id)
            .map_or(COB_ID_INVALID, |i| u32::from(i.as_raw()));
        if self.plant_pdos {
            rtr | id
        } else {
            COB_ID_INVALID | rtr | id
        }
    }

    /// The sensor frame's state `x` came (RPDO18): `0x2230` reads it.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// use agent_node::canopen::od::SENSOR_OBJECT;
    /// // Nothing sensed yet: NaN.
    /// assert_eq!(dev.read(SENSOR_OBJECT, 1).unwrap().as_slice(), &f32::NAN.to_le_bytes());
    /// dev.sensor_received([0.1, -0.2]); // x_{2,1}, x_{2,2}
    /// assert_eq!(dev.read(SENSOR_OBJECT, 2).unwrap().as_slice(), &(-0.2f32).to_le_bytes());
    /// ```
    pub fn sensor_received(&mut self, x: [f32; 2]) {
        self.sensed = x;
    }

    /// The node sent its command frame `q` (TPDO3): `0x2231` reads it.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// use agent_node::canopen::od::COMMAND_OBJECT;
    /// // Nothing commanded yet: NaN.
    /// assert_eq!(dev.read(COMMAND_OBJECT, 1).unwrap().as_slice(), &f32::NAN.to_le_bytes());
    /// dev.command_sent([1.5, -3.0]); // q_{2,1}, q_{2,2}
    /// assert_eq!(dev.read(COMMAND_OBJECT, 1).unwrap().as_slice(), &1.5f32.to_le_bytes());
    /// ```
    pub fn command_sent(&mut self, q: [f32; 2]) {
        self.commanded = q;
    }

    /// The identifier plan of the value frames, which the PDO COB-IDs (`0x1400`, `0x1800`)
    /// report: the node configuration's.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::wire::IdPlan;
    /// assert_eq!(*dev.id_plan(), IdPlan::DEFAULT);
    /// ```
    #[must_use]
    pub fn id_plan(&self) -> &IdPlan {
        &self.store.node.ids
    }

    /// The source RPDO `k + 1` carries, and whether the node listens to it: RPDO1 the leader
    /// (heard when the agent is pinned or supervises the leader), RPDO `k + 1` neighbour slot
    /// `k` (heard for `k <= neighbour_count`).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::wire::Source;
    /// assert_eq!(dev.rpdo_source(0), Some((Source::Leader, true))); // RPDO1: pinned
    /// assert_eq!(dev.rpdo_source(1), Some((Source::Agent(1), true))); // neighbour slot 0
    /// ```
    #[must_use]
    pub fn rpdo_source(&self, k: u8) -> Option<(Source, bool)> {
        let agent = &self.store.sections.agent;
        if k == 0 {
            let heard = agent.pinned || self.store.node.supervisor.leader_timeout_us.is_some();
            return Some((Source::Leader, heard));
        }
        let slot = usize::from(k - 1);
        let n = *self.store.node.neighbours.get(slot)?;
        Some((Source::Agent(n), slot < agent.neighbour_count))
    }

    /// The COB-ID entry of RPDO `k + 1`: the plan's identifier of its source, bit 31 set when
    /// the node does not listen to it.
    fn rpdo_cob_id(&self, k: u8) -> u32 {
        match self.rpdo_source(k) {
            Some((s, heard)) => match self.id_plan().value_id(s) {
                Some(id) if heard => u32::from(id),
                Some(id) => COB_ID_INVALID | u32::from(id),
                None => COB_ID_INVALID,
            },
            None => COB_ID_INVALID,
        }
    }

    /// The COB-ID entry of TPDO1: the identifier the node's value frames go out on (no RTR).
    fn tpdo_cob_id(&self) -> u32 {
        match self.id_plan().value_id(Source::Agent(self.node_id)) {
            Some(id) => COB_ID_NO_RTR | u32::from(id),
            None => COB_ID_INVALID | COB_ID_NO_RTR,
        }
    }

    /// The graph row (`graph.neighbours`, `graph.pinned`) or the identifier plan was written,
    /// restored or loaded since [`Self::graph_adopted`]: the node takes them at its next reset
    /// communication and cannot start on the old ones before.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// use agent_node::canopen::od::PARAM_BASE;
    /// use controller_core::Param;
    /// assert!(!dev.graph_written());
    /// // Agent 2 stops hearing the leader (pre-operational: writable).
    /// let pinned = PARAM_BASE + Param::ALL.iter().position(|p| *p == Param::Pinned).unwrap() as u16;
    /// dev.write(pinned, 0, &[0]).unwrap();
    /// assert!(dev.graph_written());
    /// ```
    pub fn graph_written(&self) -> bool {
        self.graph_written
    }

    /// The node adopted the graph row and plan the store holds.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// dev.write(0x1011, 1, b"load").unwrap(); // restore: the defaults' row waits too
    /// assert!(dev.graph_written());
    /// dev.graph_adopted();
    /// assert!(!dev.graph_written());
    /// ```
    pub fn graph_adopted(&mut self) {
        self.graph_written = false;
    }

    /// The COB-ID entry of TPDO2, the status PDO: `heartbeat_base + node-ID` of the plan (no
    /// RTR); bit 31 set when the plan has no heartbeat block. Sent every `heartbeat_period`
    /// (`NodeConfig::heartbeat_period_us`; 0: never, though valid).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::od::{COB_ID_NO_RTR, STATUS_TPDO_COMM};
    /// // The default plan's heartbeat block: 0x780 + node-ID, valid.
    /// assert_eq!(dev.status_cob_id(), COB_ID_NO_RTR | 0x782);
    /// assert_eq!(dev.read(STATUS_TPDO_COMM, 1).unwrap().as_slice(), &(COB_ID_NO_RTR | 0x782).to_le_bytes());
    /// ```
    pub fn status_cob_id(&self) -> u32 {
        match self.id_plan().heartbeat_id(self.node_id) {
            Some(id) => COB_ID_NO_RTR | u32::from(id),
            None => COB_ID_INVALID | COB_ID_NO_RTR,
        }
    }

    /// The node sent its status PDO (TPDO2) with these bytes: `0x2220..` read them.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # let mut dev = device();
    /// use agent_node::canopen::od::{StatusField, STATUS_BASE};
    /// use agent_node::wire::Heartbeat;
    /// use agent_node::{supervisor::Lost, NodeState};
    /// assert_eq!(dev.read(STATUS_BASE, 0).unwrap().as_slice(), &[1]); // before any: state boot
    /// let hb = Heartbeat { state: NodeState::Safe, lost: Lost::from_bits(Lost::LEADER),
    ///     boot_count: 3, overruns: 0, safe_entries: 1 };
    /// dev.status_sent(&hb.to_bytes());
    /// assert_eq!(dev.read(STATUS_BASE, 0).unwrap().as_slice(), &[2]); // safe
    /// let boot = STATUS_BASE + StatusField::BootCount.position();
    /// assert_eq!(dev.read(boot, 0).unwrap().as_slice(), &3u16.to_le_bytes());
    /// ```
    pub fn status_sent(&mut self, data: &[u8; crate::wire::HEARTBEAT_LEN]) {
        self.status = Some(*data);
    }

    /// The node sent its value frame (TPDO1) with these bytes: `0x2200..` read them.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::wire::encode_payload;
    /// // TPDO1's y field (0x2200) reads the last value frame sent, raw Q7.16.
    /// dev.value_sent(&encode_payload(1.0, 0).data);
    /// assert_eq!(dev.read(0x2200, 0).unwrap().as_slice(), &[0, 0, 1]);
    /// ```
    pub fn value_sent(&mut self, data: &[u8; PAYLOAD_LEN]) {
        self.tpdo = Some(*data);
    }

    /// A value frame on an RPDO the node listens to, in operational: kept for `0x2210..`.
    fn receive_pdo(&mut self, id: u16, data: &[u8]) {
        let (NmtState::Operational, Ok(bytes)) = (self.nmt, <[u8; PAYLOAD_LEN]>::try_from(data))
        else {
            return;
        };
        let Some(FrameKind::Value(source)) = self.id_plan().classify(id) else {
            return;
        };
        let k = (0..od::RPDOS).find(|&k| {
            self.rpdo_source(k)
                .is_some_and(|(s, heard)| heard && s == source)
        });
        if let Some(slot) = k.and_then(|k| self.rpdo.get_mut(usize::from(k))) {
            *slot = Some(bytes);
        }
    }

    /// A field of a value frame as its object reads: before any frame, a frame flagged
    /// `NO_VALUE` (nothing received, as the wire format defines it).
    fn field_value(frame: Option<[u8; PAYLOAD_LEN]>, f: Field) -> Value {
        let frame = frame.unwrap_or(crate::wire::encode_payload(f32::NAN, 0).data);
        let raw = f.extract(&frame);
        match f.data_type() {
            DataType::Boolean => Value::Bool(raw != 0),
            _ => Value::Unsigned(raw),
        }
    }

    /// Node-ID in use.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// assert_eq!(dev.node_id(), 2); // the agent number i
    /// ```
    #[must_use]
    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    /// NMT state.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::NmtState;
    /// assert_eq!(dev.nmt(), NmtState::PreOperational);
    /// dev.on_frame(0x000, &[0x02, 2], 0); // NMT stop
    /// assert_eq!(dev.nmt(), NmtState::Stopped);
    /// ```
    #[must_use]
    pub fn nmt(&self) -> NmtState {
        self.nmt
    }

    /// The control outputs are enabled (NMT `Operational`).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// assert!(!dev.outputs_enabled()); // pre-operational: actuators and value frames off
    /// dev.on_frame(0x000, &[0x01, 2], 0);
    /// assert!(dev.outputs_enabled());
    /// ```
    #[must_use]
    pub fn outputs_enabled(&self) -> bool {
        self.nmt == NmtState::Operational
    }

    /// PDOs may be sent (NMT `Operational`).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// assert!(!dev.pdo_enabled());
    /// dev.on_frame(0x000, &[0x01, 0], 0); // NMT start, every node
    /// assert!(dev.pdo_enabled());
    /// ```
    #[must_use]
    pub fn pdo_enabled(&self) -> bool {
        self.nmt == NmtState::Operational
    }

    /// `0x1017` producer heartbeat time (ms; 0: off).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::heartbeat_id;
    /// dev.set_heartbeat_ms(100);
    /// dev.tick(0);
    /// let hb = dev.next_tx().unwrap();
    /// assert_eq!((hb.id, hb.data()), (heartbeat_id(2), &[0x7F][..])); // pre-operational
    /// dev.tick(50_000);
    /// assert!(dev.next_tx().is_none()); // next one at 100 ms
    /// ```
    pub fn set_heartbeat_ms(&mut self, ms: u16) {
        self.heartbeat_ms = ms;
        self.next_heartbeat_us = None;
    }

    /// `0x1016` entry `k` (1-based): watch node `node` with `time_ms` (0: off).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{heartbeat_id, Event};
    /// // Watch node 1's heartbeat with 150 ms: heard at 0, silent until 200 ms.
    /// dev.set_consumer(1, 1, 150).unwrap();
    /// dev.on_frame(heartbeat_id(1), &[0x05], 0);
    /// dev.tick(200_000);
    /// assert!(dev.heartbeat_lost(1));
    /// assert_eq!(dev.next_event(), Some(Event::HeartbeatLost(1)));
    /// ```
    pub fn set_consumer(&mut self, k: u8, node: u8, time_ms: u16) -> Result<(), Abort> {
        self.write_consumer(k, (u32::from(node) << 16) | u32::from(time_ms))
    }

    /// The error register (`0x1001`).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::Fault;
    /// assert_eq!(dev.error_register(), 0);
    /// dev.report(Fault::SensorInvalid, 0);
    /// assert_eq!(dev.error_register(), 0x81);
    /// dev.clear(Fault::SensorInvalid);
    /// assert_eq!(dev.error_register(), 0);
    /// ```
    #[must_use]
    pub fn error_register(&self) -> u8 {
        self.register
    }

    /// Boot: the boot-up message, then `PreOperational` (or `Operational` when self-starting).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{Event, NmtState};
    /// dev.boot(5);
    /// assert_eq!(dev.next_tx().unwrap().data(), &[0x00]); // boot-up: initialising
    /// assert_eq!(dev.nmt(), NmtState::PreOperational);
    /// ```
    pub fn boot(&mut self, now_us: u64) {
        self.now_us = now_us;
        self.node_id = self.store.node.pending_node_id;
        self.store.node.node_id = self.node_id;
        self.nmt = NmtState::Initialising;
        self.transfer = Transfer::Idle;
        self.tpdo = None;
        self.rpdo = [None; od::RPDOS as usize];
        self.send(heartbeat_id(self.node_id), &[NmtState::Initialising.code()]);
        self.next_heartbeat_us = None;
        let state = if self.self_starting {
            NmtState::Operational
        } else {
            NmtState::PreOperational
        };
        self.set_nmt(state);
    }

    fn set_nmt(&mut self, s: NmtState) {
        if self.nmt != s {
            self.nmt = s;
            self.events.push(Event::Nmt(s));
        }
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        self.tx.push(CoFrame::new(id, data));
    }

    /// The next frame to send.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{emcy_id, Fault};
    /// assert!(dev.next_tx().is_none());
    /// dev.report(Fault::Overrun, 1);
    /// assert_eq!(dev.next_tx().unwrap().id, emcy_id(2));
    /// ```
    pub fn next_tx(&mut self) -> Option<CoFrame> {
        self.tx.pop()
    }

    /// The next event for the application.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::Event;
    /// dev.write(0x1010, 1, b"save").unwrap();
    /// assert_eq!(dev.next_event(), Some(Event::Store));
    /// assert_eq!(dev.next_event(), None);
    /// ```
    pub fn next_event(&mut self) -> Option<Event> {
        self.events.pop()
    }

    /// Take a received frame; `false` when it is none of the device's (value frames etc.).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// // A value frame is the application's: the device keeps a copy and says `false`.
    /// assert!(!dev.on_frame(0x102, &[0, 0, 1, 0], 0));
    /// assert!(dev.on_frame(0x080, &[], 0)); // SYNC is the device's
    /// ```
    pub fn on_frame(&mut self, id: u16, data: &[u8], now_us: u64) -> bool {
        self.now_us = now_us;
        if id == NMT_ID {
            if let (Some(&cs), Some(&node)) = (data.first(), data.get(1)) {
                if node == 0 || node == self.node_id {
                    self.nmt_command(cs, now_us);
                }
            }
            return true;
        }
        if id == SYNC_ID {
            if matches!(self.nmt, NmtState::Operational | NmtState::PreOperational) {
                self.events.push(Event::Sync);
            }
            return true;
        }
        if id == sdo_rx_id(self.node_id) {
            if matches!(self.nmt, NmtState::Operational | NmtState::PreOperational) {
                let mut req = [0u8; 8];
                for (d, s) in req.iter_mut().zip(data) {
                    *d = *s;
                }
                if let Some(resp) = self.sdo_request(&req, now_us) {
                    self.send(sdo_tx_id(self.node_id), &resp);
                }
            }
            return true;
        }
        if (heartbeat_id(1)..=heartbeat_id(MAX_NODE_ID)).contains(&id) {
            let node = (id - heartbeat_id(0)) as u8;
            self.consume_heartbeat(node, data.first().copied(), now_us);
            return true;
        }
        // A value frame stays the application's (`false`); the device keeps a copy.
        self.receive_pdo(id, data);
        false
    }

    fn nmt_command(&mut self, cs: u8, now_us: u64) {
        match NmtCommand::from_code(cs) {
            Some(NmtCommand::Start) => self.set_nmt(NmtState::Operational),
            Some(NmtCommand::Stop) => self.set_nmt(NmtState::Stopped),
            Some(NmtCommand::EnterPreOperational) => self.set_nmt(NmtState::PreOperational),
            Some(NmtCommand::ResetNode) => {
                self.events.push(Event::ResetNode);
                self.reset_communication(now_us);
            }
            Some(NmtCommand::ResetCommunication) => self.reset_communication(now_us),
            None => {}
        }
    }

    fn reset_communication(&mut self, now_us: u64) {
        let self_starting = self.self_starting;
        self.self_starting = false;
        self.boot(now_us);
        self.self_starting = self_starting;
        self.events.push(Event::ResetCommunication);
    }

    fn consume_heartbeat(&mut self, node: u8, state: Option<u8>, now_us: u64) {
        let state = state.and_then(NmtState::from_code);
        let mut resumed = None;
        for c in self.consumers.iter_mut() {
            if c.time_us() > 0 && c.node() == node {
                c.last_us = Some(now_us);
                c.state = state;
                if c.lost {
                    c.lost = false;
                    resumed = Some(node);
                }
            }
        }
        if let Some(n) = resumed {
            self.events.push(Event::HeartbeatResumed(n));
            if !self.consumers.iter().any(|c| c.lost) {
                self.clear(Fault::HeartbeatLost(n));
            }
        }
    }

    /// The consumed heartbeat (`0x1016`) of `node` timed out and has not come back.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::heartbeat_id;
    /// dev.set_consumer(1, 3, 100).unwrap();
    /// dev.on_frame(heartbeat_id(3), &[0x05], 0);
    /// dev.tick(50_000);
    /// assert!(!dev.heartbeat_lost(3));
    /// dev.tick(101_000);
    /// assert!(dev.heartbeat_lost(3));
    /// ```
    #[must_use]
    pub fn heartbeat_lost(&self, node: u8) -> bool {
        self.consumers
            .iter()
            .any(|c| c.lost && c.time_us() > 0 && c.node() == node)
    }

    /// The node-IDs whose consumed heartbeat is lost.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::heartbeat_id;
    /// dev.set_consumer(1, 1, 100).unwrap();
    /// dev.set_consumer(2, 3, 100).unwrap();
    /// dev.on_frame(heartbeat_id(1), &[0x05], 0);
    /// dev.on_frame(heartbeat_id(3), &[0x05], 0);
    /// dev.on_frame(heartbeat_id(3), &[0x05], 90_000);
    /// dev.tick(150_000); // node 1 silent for 150 ms, node 3 for 60 ms
    /// assert_eq!(dev.lost_heartbeats().collect::<Vec<_>>(), [1]);
    /// ```
    pub fn lost_heartbeats(&self) -> impl Iterator<Item = u8> + '_ {
        self.consumers
            .iter()
            .filter(|c| c.lost && c.time_us() > 0)
            .map(Consumer::node)
    }

    /// The last NMT state heard from a consumed node.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{heartbeat_id, NmtState};
    /// dev.set_consumer(1, 1, 100).unwrap();
    /// assert_eq!(dev.consumed_state(1), None);
    /// dev.on_frame(heartbeat_id(1), &[0x7F], 0);
    /// assert_eq!(dev.consumed_state(1), Some(NmtState::PreOperational));
    /// ```
    #[must_use]
    pub fn consumed_state(&self, node: u8) -> Option<NmtState> {
        self.consumers
            .iter()
            .find(|c| c.time_us() > 0 && c.node() == node)
            .and_then(|c| c.state)
    }

    /// Advance to `now_us`: heartbeat producer, consumer timeouts, SDO timeout.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{abort_frame, sdo_rx_id, Abort};
    /// use controller_core::Param;
    /// // A segmented download of T_s begun and abandoned: aborted after one second.
    /// let ts = 0x2000 + Param::ALL.iter().position(|p| *p == Param::Ts).unwrap() as u16;
    /// let [lo, hi] = ts.to_le_bytes();
    /// dev.on_frame(sdo_rx_id(2), &[0x21, lo, hi, 0, 4, 0, 0, 0], 0);
    /// assert_eq!(dev.next_tx().unwrap().data()[0], 0x60); // initiate acknowledged
    /// dev.tick(1_000_001);
    /// assert_eq!(dev.next_tx().unwrap().data(), &abort_frame(ts, 0, Abort::Timeout));
    /// ```
    pub fn tick(&mut self, now_us: u64) {
        self.now_us = now_us;
        if self.heartbeat_ms > 0 && self.nmt != NmtState::Initialising {
            let due = *self.next_heartbeat_us.get_or_insert(now_us);
            if now_us >= due {
                self.send(heartbeat_id(self.node_id), &[self.nmt.code()]);
                let period = u64::from(self.heartbeat_ms) * 1000;
                // The next slot after now, on the grid of the first one.
                let skipped = (now_us - due) / period;
                self.next_heartbeat_us = Some(due + (skipped + 1) * period);
            }
        }
        let mut lost = [0u8; od::HEARTBEAT_CONSUMERS as usize];
        for (c, l) in self.consumers.iter_mut().zip(lost.iter_mut()) {
            if let Some(t) = c.last_us {
                if c.time_us() > 0 && !c.lost && now_us.saturating_sub(t) > c.time_us() {
                    c.lost = true;
                    *l = c.node();
                }
            }
        }
        for node in lost.into_iter().filter(|&n| n != 0) {
            self.events.push(Event::HeartbeatLost(node));
            self.report(Fault::HeartbeatLost(node), 0);
        }
        let since = match self.transfer {
            Transfer::Download { since, .. } | Transfer::Upload { since, .. } => Some(since),
            Transfer::Idle => None,
        };
        if let Some(since) = since {
            if now_us.saturating_sub(since) > SDO_TIMEOUT_US {
                let (index, sub) = self.transfer_object();
                self.transfer = Transfer::Idle;
                let resp = abort_frame(index, sub, Abort::Timeout);
                self.send(sdo_tx_id(self.node_id), &resp);
            }
        }
    }

    fn transfer_object(&self) -> (u16, u8) {
        match self.transfer {
            Transfer::Download { index, sub, .. } | Transfer::Upload { index, sub, .. } => {
                (index, sub)
            }
            Transfer::Idle => (0, 0),
        }
    }

    /// Report a fault: an EMCY frame (in pre-operational and operational), an entry in the
    /// pre-defined error field, and for a condition its error-register bits until
    /// [`Self::clear`]. `count`: see [`Fault::info`].
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::{decode, Fault, Message};
    /// dev.report(Fault::BusOff, 2);
    /// let f = dev.next_tx().unwrap();
    /// let Some(Message::Emcy { node, code, register, info }) = decode(f.id, f.data()) else { panic!() };
    /// assert_eq!((node, code, register), (2, 0x8140, 0x11));
    /// assert_eq!(info, Fault::BusOff.info(2));
    /// assert_eq!(dev.read(0x1003, 1).unwrap().as_slice(), &0x8140u32.to_le_bytes()); // error field
    /// ```
    pub fn report(&mut self, f: Fault, count: u16) {
        if let Some(bit) = f.condition() {
            if self.active & bit != 0 {
                return;
            }
            self.active |= bit;
            self.register |= f.register_bits();
        }
        let code = u32::from(f.code());
        self.history.rotate_right(1);
        if let Some(first) = self.history.first_mut() {
            *first = code;
        }
        self.history_len = (self.history_len + 1).min(od::ERROR_HISTORY);
        let reg = self.register | f.register_bits();
        self.emcy(f.code(), reg, f.info(count));
    }

    /// A condition reported with [`Self::report`] is over; when none is left, the error
    /// register clears and an EMCY "error reset" (`0x0000`) is sent.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::Fault;
    /// dev.report(Fault::SafeState(1), 0);
    /// dev.next_tx();
    /// dev.clear(Fault::SafeState(1));
    /// let reset = dev.next_tx().unwrap();
    /// assert_eq!(&reset.data()[..3], &[0, 0, 0]); // EMCY error reset, register 0
    /// ```
    pub fn clear(&mut self, f: Fault) {
        let Some(bit) = f.condition() else {
            return;
        };
        if self.active & bit == 0 {
            return;
        }
        self.active &= !bit;
        if self.active == 0 {
            self.register = 0;
            self.emcy(0x0000, 0, [0; 5]);
        }
    }

    fn emcy(&mut self, code: u16, reg: u8, info: [u8; 5]) {
        if matches!(self.nmt, NmtState::Operational | NmtState::PreOperational) {
            let c = code.to_le_bytes();
            let data = [c[0], c[1], reg, info[0], info[1], info[2], info[3], info[4]];
            self.send(emcy_id(self.node_id), &data);
        }
    }

    fn sdo_request(&mut self, req: &[u8; 8], now_us: u64) -> Option<[u8; 8]> {
        let cmd = req[0];
        let index = u16::from_le_bytes([req[1], req[2]]);
        let sub = req[3];
        match cmd >> 5 {
            // Initiate download.
            1 => {
                self.transfer = Transfer::Idle;
                let expedited = cmd & 0x02 != 0;
                let sized = cmd & 0x01 != 0;
                let r = if expedited {
                    let n = if sized {
                        usize::from((cmd >> 2) & 3)
                    } else {
                        0
                    };
                    self.write(index, sub, req.get(4..8 - n).unwrap_or(&[]))
                } else {
                    let size = sized
                        .then(|| u32::from_le_bytes([req[4], req[5], req[6], req[7]]) as usize);
                    let fits = match size {
                        Some(s) if s > SdoData::CAPACITY => Err(Abort::LengthTooHigh),
                        _ => Ok(()),
                    };
                    self.check_write(index, sub).and(fits).map(|()| {
                        self.transfer = Transfer::Download {
                            index,
                            sub,
                            toggle: 0,
                            data: SdoData::default(),
                            size,
                            since: now_us,
                        };
                    })
                };
                Some(match r {
                    Ok(()) => [0x60, req[1], req[2], sub, 0, 0, 0, 0],
                    Err(a) => abort_frame(index, sub, a),
                })
            }
            // Download segment.
            0 => {
                if let Err(resp) = self.check_segment(cmd) {
                    return Some(resp);
                }
                let Transfer::Download {
                    index,
                    sub,
                    toggle,
                    mut data,
                    size,
                    ..
                } = self.transfer
                else {
                    return Some(abort_frame(0, 0, Abort::Command));
                };
                let t = toggle;
                let unused = usize::from((cmd >> 1) & 7);
                if !data.extend(req.get(1..8 - unused).unwrap_or(&[])) {
                    self.transfer = Transfer::Idle;
                    return Some(abort_frame(index, sub, Abort::OutOfMemory));
                }
                if cmd & 1 != 0 {
                    self.transfer = Transfer::Idle;
                    let r = match size {
                        Some(s) if s != data.as_slice().len() => Err(Abort::Length),
                        _ => self.write(index, sub, data.as_slice()),
                    };
                    if let Err(a) = r {
                        return Some(abort_frame(index, sub, a));
                    }
                } else {
                    self.transfer = Transfer::Download {
                        index,
                        sub,
                        toggle: toggle ^ 1,
                        data,
                        size,
                        since: now_us,
                    };
                }
                Some([0x20 | (t << 4), 0, 0, 0, 0, 0, 0, 0])
            }
            // Initiate upload.
            2 => {
                self.transfer = Transfer::Idle;
                let data = match self.read(index, sub) {
                    Ok(d) => d,
                    Err(a) => return Some(abort_frame(index, sub, a)),
                };
                let bytes = data.as_slice();
                let mut resp = [0, req[1], req[2], sub, 0, 0, 0, 0];
                if bytes.len() <= 4 {
                    resp[0] = 0x43 | (((4 - bytes.len()) as u8) << 2);
                    for (d, s) in resp.iter_mut().skip(4).zip(bytes) {
                        *d = *s;
                    }
                } else {
                    resp[0] = 0x41;
                    let n = (bytes.len() as u32).to_le_bytes();
                    resp[4..8].copy_from_slice(&n);
                    self.transfer = Transfer::Upload {
                        index,
                        sub,
                        toggle: 0,
                        data,
                        pos: 0,
                        since: now_us,
                    };
                }
                Some(resp)
            }
            // Upload segment.
            3 => {
                if let Err(resp) = self.check_segment(cmd) {
                    return Some(resp);
                }
                let Transfer::Upload {
                    index,
                    sub,
                    toggle,
                    data,
                    pos,
                    ..
                } = self.transfer
                else {
                    return Some(abort_frame(0, 0, Abort::Command));
                };
                let t = toggle;
                let rest = data.as_slice().get(pos..).unwrap_or(&[]);
                let chunk = rest.get(..7).unwrap_or(rest);
                let last = chunk.len() == rest.len();
                let mut resp = [0u8; 8];
                resp[0] = (t << 4) | (((7 - chunk.len()) as u8) << 1) | u8::from(last);
                for (d, s) in resp.iter_mut().skip(1).zip(chunk) {
                    *d = *s;
                }
                self.transfer = if last {
                    Transfer::Idle
                } else {
                    Transfer::Upload {
                        index,
                        sub,
                        toggle: toggle ^ 1,
                        data,
                        pos: pos + chunk.len(),
                        since: now_us,
                    }
                };
                Some(resp)
            }
            // Abort from the client: no answer.
            4 => {
                self.transfer = Transfer::Idle;
                None
            }
            // Block transfers and anything else.
            _ => {
                self.transfer = Transfer::Idle;
                Some(abort_frame(index, sub, Abort::Command))
            }
        }
    }

    /// A segment request (`ccs` 0 download, 3 upload) against the transfer in progress: the
    /// abort frame when there is none of that direction or its toggle bit is wrong (the
    /// transfer then ends).
    fn check_segment(&mut self, cmd: u8) -> Result<(), [u8; 8]> {
        let download = cmd >> 5 == 0;
        let (index, sub, toggle) = match self.transfer {
            Transfer::Download {
                index, sub, toggle, ..
            } if download => (index, sub, toggle),
            Transfer::Upload {
                index, sub, toggle, ..
            } if !download => (index, sub, toggle),
            _ => return Err(abort_frame(0, 0, Abort::Command)),
        };
        if (cmd >> 4) & 1 != toggle {
            self.transfer = Transfer::Idle;
            return Err(abort_frame(index, sub, Abort::Toggle));
        }
        Ok(())
    }

    /// The highest sub-index object `o` has now (0 for a `VAR`).
    fn sub_count(&self, o: &Object) -> u8 {
        match (o.kind, o.item) {
            (Kind::Var, _) => 0,
            (_, Item::ErrorField) => self.history_len,
            (_, Item::Param(controller_core::Param::Neighbours)) => self.store.slots() as u8,
            (_, Item::Param(_)) => N.min(usize::from(od::MAX_STEPS)) as u8,
            (Kind::Array { len } | Kind::Record { len }, _) => len,
        }
    }

    fn object(&self, index: u16, sub: u8) -> Result<&'static Object, Abort> {
        let o = find(index).ok_or(Abort::NoObject)?;
        if sub > self.sub_count(o) {
            return Err(Abort::NoSubIndex);
        }
        Ok(o)
    }

    /// Read an entry (the SDO upload's data).
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::Abort;
    /// use controller_core::Param;
    /// // T_s of Theorem 1 at 0x2000 + its position in Param::ALL: REAL32, 2 s by default.
    /// let ts = 0x2000 + Param::ALL.iter().position(|p| *p == Param::Ts).unwrap() as u16;
    /// assert_eq!(dev.read(ts, 0).unwrap().as_slice(), &2.0f32.to_le_bytes());
    /// assert_eq!(dev.read(0x5FFF, 0).unwrap_err(), Abort::NoObject);
    /// ```
    pub fn read(&self, index: u16, sub: u8) -> Result<SdoData, Abort> {
        let o = self.object(index, sub)?;
        if sub == 0 && o.kind != Kind::Var {
            // The graph row's sub-index 0 is how many of its entries are heard.
            let n = match o.item {
                Item::Param(controller_core::Param::Neighbours) => {
                    self.store.sections.agent.neighbour_count as u8
                }
                _ => self.sub_count(o),
            };
            return Ok(Value::Unsigned(u32::from(n)).encode(DataType::Unsigned8));
        }
        let u = |v: u32| Ok(Value::Unsigned(v));
        let v = match o.item {
            Item::DeviceType => u(0),
            Item::ErrorRegister => u(u32::from(self.register)),
            Item::ErrorField => u(self
                .history
                .get(usize::from(sub).wrapping_sub(1))
                .copied()
                .unwrap_or(0)),
            Item::SyncCobId => u(u32::from(SYNC_ID)),
            Item::DeviceName => return Ok(string(DEVICE_NAME)),
            Item::SoftwareVersion => return Ok(string(env!("CARGO_PKG_VERSION"))),
            Item::Store | Item::Restore => u(1),
            Item::EmcyCobId => u(u32::from(emcy_id(self.node_id))),
            Item::HeartbeatConsumer => u(self
                .consumers
                .get(usize::from(sub).wrapping_sub(1))
                .map_or(0, |c| c.raw)),
            Item::HeartbeatProducer => u(u32::from(self.heartbeat_ms)),
            Item::Identity => u(match sub {
                1 => self.identity.vendor,
                2 => self.identity.product,
                3 => self.identity.revision,
                _ => self.identity.serial,
            }),
            Item::SdoServer => u(u32::from(if sub == 1 {
                sdo_rx_id(self.node_id)
            } else {
                sdo_tx_id(self.node_id)
            })),
            Item::Param(p) => self.store.read_param(p, sub).ok_or(Abort::NoSubIndex),
            Item::Setting(s) => Ok(self.store.read_setting(s)),
            Item::RpdoComm(k) if sub == 1 => u(self.rpdo_cob_id(k)),
            Item::TpdoComm if sub == 1 => u(self.tpdo_cob_id()),
            Item::StatusComm if sub == 1 => u(self.status_cob_id()),
            Item::RpdoComm(_) | Item::TpdoComm | Item::StatusComm => {
                u(u32::from(od::PDO_TRANSMISSION_TYPE))
            }
            Item::StatusMap => od::StatusField::ALL
                .get(usize::from(sub).wrapping_sub(1))
                .map(|f| Value::Unsigned(f.mapping()))
                .ok_or(Abort::NoSubIndex),
            Item::SensorComm if sub == 1 => u(self.plant_cob_id(true)),
            Item::CommandComm if sub == 1 => u(self.plant_cob_id(false)),
            Item::SensorComm | Item::CommandComm => u(u32::from(od::PDO_TRANSMISSION_TYPE)),
            Item::SensorMap if (1..=od::PLANT_PAIR).contains(&sub) => {
                u(od::plant_mapping(od::SENSOR_OBJECT, sub))
            }
            Item::CommandMap if (1..=od::PLANT_PAIR).contains(&sub) => {
                u(od::plant_mapping(od::COMMAND_OBJECT, sub))
            }
            Item::SensorMap | Item::CommandMap => Err(Abort::NoSubIndex),
            // Before any frame: NaN (nothing sensed or commanded yet).
            Item::Sensed => self
                .sensed
                .get(usize::from(sub).wrapping_sub(1))
                .map(|v| Value::Real(*v))
                .ok_or(Abort::NoSubIndex),
            Item::Commanded => self
                .commanded
                .get(usize::from(sub).wrapping_sub(1))
                .map(|v| Value::Real(*v))
                .ok_or(Abort::NoSubIndex),
            // Before the first status PDO: state boot (1), nothing lost, counters 0.
            Item::Status(f) => u(f.extract(&self.status.unwrap_or([1, 0, 0, 0, 0, 0, 0, 0]))),
            Item::RpdoMap(k) => Field::ALL
                .get(usize::from(sub).wrapping_sub(1))
                .map(|f| Value::Unsigned(f.mapping(od::RX_VALUE_BASE + f.position(), k + 1)))
                .ok_or(Abort::NoSubIndex),
            Item::TpdoMap => Field::ALL
                .get(usize::from(sub).wrapping_sub(1))
                .map(|f| Value::Unsigned(f.mapping(od::TX_VALUE_BASE + f.position(), 0)))
                .ok_or(Abort::NoSubIndex),
            Item::TxValue(f) => Ok(Self::field_value(self.tpdo, f)),
            Item::RxValue(f) => self
                .rpdo
                .get(usize::from(sub).wrapping_sub(1))
                .map(|r| Self::field_value(*r, f))
                .ok_or(Abort::NoSubIndex),
        }?;
        Ok(v.encode(od::sub_data_type(o, sub)))
    }

    fn check_write(&self, index: u16, sub: u8) -> Result<&'static Object, Abort> {
        let o = self.object(index, sub)?;
        if sub == 0 && o.kind != Kind::Var {
            match o.item {
                Item::ErrorField => return Ok(o),
                Item::Param(controller_core::Param::Neighbours) => {}
                _ => return Err(Abort::ReadOnly),
            }
        }
        if o.access != Access::ReadWrite {
            return Err(Abort::ReadOnly);
        }
        if matches!(o.item, Item::Param(_) | Item::Setting(_))
            && self.nmt != NmtState::PreOperational
        {
            return Err(Abort::DeviceState);
        }
        Ok(o)
    }

    /// Write an entry (the SDO download's data): refused with the abort code, the value left
    /// unchanged, unless every check passes.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use agent_node::canopen::Abort;
    /// use controller_core::Param;
    /// let ts = 0x2000 + Param::ALL.iter().position(|p| *p == Param::Ts).unwrap() as u16;
    /// assert_eq!(dev.write(ts, 0, &0.5f32.to_le_bytes()), Ok(()));
    /// assert_eq!(dev.store.controller().unwrap().ts, 0.5);
    /// // T_s > 0 (Theorem 1): refused, the value left as it was.
    /// assert_eq!(dev.write(ts, 0, &(-1.0f32).to_le_bytes()), Err(Abort::ValueRange));
    /// assert_eq!(dev.write(ts, 0, &[0; 2]), Err(Abort::LengthTooLow));
    /// ```
    pub fn write(&mut self, index: u16, sub: u8, bytes: &[u8]) -> Result<(), Abort> {
        let o = self.check_write(index, sub)?;
        let t = if sub == 0 && o.kind != Kind::Var {
            DataType::Unsigned8
        } else {
            o.data_type
        };
        let v = Value::decode(t, bytes)?;
        let raw = match v {
            Value::Unsigned(u) => u,
            _ => 0,
        };
        match o.item {
            Item::ErrorField if raw == 0 => {
                self.history_len = 0;
                self.history = [0; od::ERROR_HISTORY as usize];
            }
            Item::ErrorField => return Err(Abort::ValueRange),
            Item::Store if raw == SAVE_SIGNATURE => {
                self.events.push(Event::Store);
            }
            Item::Restore if raw == LOAD_SIGNATURE => {
                self.store = self.defaults.clone();
                // The defaults' row and plan, like a written one, wait for a reset (not compared
                // with the adopted ones: the board's flash).
                self.graph_written = true;
                self.events.push(Event::Restore);
            }
            Item::Store | Item::Restore => return Err(Abort::Transfer),
            Item::HeartbeatConsumer => self.write_consumer(sub, raw)?,
            Item::HeartbeatProducer => self.set_heartbeat_ms(raw as u16),
            Item::Param(p) => {
                self.store.write_param(p, sub, v)?;
                self.graph_written |= matches!(
                    p,
                    controller_core::Param::Neighbours | controller_core::Param::Pinned
                );
                self.events.push(Event::Written(index, sub));
            }
            Item::Setting(s) => {
                self.store.write_setting(s, v)?;
                self.graph_written |= matches!(
                    s,
                    od::Setting::IdBase | od::Setting::HeartbeatIdBase | od::Setting::Agents
                );
                self.events.push(Event::Written(index, sub));
            }
            _ => return Err(Abort::ReadOnly),
        }
        Ok(())
    }

    fn write_consumer(&mut self, k: u8, raw: u32) -> Result<(), Abort> {
        let node = (raw >> 16) as u8;
        if raw >> 24 != 0 || node > MAX_NODE_ID {
            return Err(Abort::ValueRange);
        }
        let dup = self.consumers.iter().enumerate().any(|(j, c)| {
            j + 1 != usize::from(k) && raw & 0xFFFF != 0 && c.time_us() > 0 && c.node() == node
        });
        if dup {
            return Err(Abort::ParamIncompatible);
        }
        let c = self
            .consumers
            .get_mut(usize::from(k).wrapping_sub(1))
            .ok_or(Abort::NoSubIndex)?;
        *c = Consumer {
            raw,
            ..Consumer::default()
        };
        Ok(())
    }

    /// The persisted form of every writable manufacturer entry and the heartbeat settings
    /// (`0x1016`, `0x1017`): a `CO1\0` tag, then records `index (u16 LE), sub, length, bytes`.
    /// Returns the bytes written into `out`, `None` if it is too small.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// use controller_core::Param;
    /// let ts = 0x2000 + Param::ALL.iter().position(|p| *p == Param::Ts).unwrap() as u16;
    /// dev.write(ts, 0, &0.5f32.to_le_bytes()).unwrap();
    /// let mut flash = [0u8; 2048];
    /// let n = dev.save(&mut flash).unwrap();
    /// assert_eq!(&flash[..4], b"CO1\0");
    /// let mut fresh = device();
    /// fresh.load(&flash[..n]).unwrap();
    /// assert_eq!(fresh.store.controller().unwrap().ts, 0.5);
    /// assert_eq!(fresh.store.sections, dev.store.sections);
    /// assert!(dev.save(&mut [0u8; 8]).is_none()); // too small
    /// ```
    pub fn save(&self, out: &mut [u8]) -> Option<usize> {
        let mut w = Writer { out, pos: 0 };
        w.put(STORE_TAG)?;
        for o in OBJECTS.iter().filter(|o| persisted(o)) {
            let subs = match (o.kind, o.item) {
                (Kind::Var, _) => 0..=0,
                // The graph row: the entries heard, then their count (loaded in this order).
                (_, Item::Param(controller_core::Param::Neighbours)) => {
                    1..=self.store.sections.agent.neighbour_count as u8
                }
                _ => 1..=self.sub_count(o),
            };
            let count = matches!(o.item, Item::Param(controller_core::Param::Neighbours));
            for sub in subs.chain(count.then_some(0)) {
                if let Ok(d) = self.read(o.index, sub) {
                    let i = o.index.to_le_bytes();
                    w.put(&[i[0], i[1], sub, d.as_slice().len() as u8])?;
                    w.put(d.as_slice())?;
                }
            }
        }
        Some(w.pos)
    }

    /// Load what [`Self::save`] wrote, as writes in pre-operational; on any refusal nothing
    /// changes and the abort is returned.
    ///
    /// ```
    /// # mod hw { include!("doctest_device.rs"); }
    /// # use hw::*;
    /// # #[allow(unused_mut)]
    /// # let mut dev = device();
    /// let before = dev.store.clone();
    /// assert!(dev.load(b"not a store").is_err());
    /// assert_eq!(dev.store.sections, before.sections); // nothing changed
    /// ```
    pub fn load(&mut self, bytes: &[u8]) -> Result<(), Abort> {
        let saved = (
            self.store.clone(),
            self.heartbeat_ms,
            self.consumers,
            self.nmt,
        );
        self.nmt = NmtState::PreOperational;
        let r = self.load_records(bytes);
        self.nmt = saved.3;
        if r.is_err() {
            self.store = saved.0;
            self.heartbeat_ms = saved.1;
            self.consumers = saved.2;
        }
        // Loading is not a bus write: no `Written` events.
        let mut kept = Fifo::<Event, 16>::new();
        while let Some(e) = self.events.pop() {
            if !matches!(e, Event::Written(..)) {
                kept.push(e);
            }
        }
        self.events = kept;
        r
    }

    fn load_records(&mut self, bytes: &[u8]) -> Result<(), Abort> {
        let mut rest = bytes.strip_prefix(STORE_TAG).ok_or(Abort::Transfer)?;
        // A stored graph row is written entry by entry onto an empty row (a permutation of the
        // present row would meet itself), then its count checks it whole; pinned meanwhile, so
        // that the empty row is a valid configuration, until the stored `graph.pinned` (the
        // next record) says.
        let row = OBJECTS
            .iter()
            .find(|o| o.item == Item::Param(controller_core::Param::Neighbours))
            .map(|o| o.index);
        if records(rest).any(|(index, sub, _)| Some(index) == row && sub == 0) {
            self.store.sections.agent.neighbour_count = 0;
            self.store.sections.agent.pinned = true;
        }
        // Records one by one: a later record may need an earlier one (c1 with c2), so a
        // refusal is retried after the others once.
        let mut retry = false;
        while let [i0, i1, sub, len, tail @ ..] = rest {
            let n = usize::from(*len);
            let data = tail.get(..n).ok_or(Abort::Transfer)?;
            let index = u16::from_le_bytes([*i0, *i1]);
            if self.write(index, *sub, data).is_err() {
                retry = true;
            }
            rest = tail.get(n..).unwrap_or(&[]);
        }
        if !rest.is_empty() {
            return Err(Abort::Transfer);
        }
        if retry {
            let mut rest = bytes.get(STORE_TAG.len()..).unwrap_or(&[]);
            while let [i0, i1, sub, len, tail @ ..] = rest {
                let n = usize::from(*len);
                let data = tail.get(..n).unwrap_or(&[]);
                self.write(u16::from_le_bytes([*i0, *i1]), *sub, data)?;
                rest = tail.get(n..).unwrap_or(&[]);
            }
        }
        Ok(())
    }
}

/// The `(index, sub-index, bytes)` records of a stored dictionary after its tag, up to the
/// first malformed one.
fn records(mut rest: &[u8]) -> impl Iterator<Item = (u16, u8, &[u8])> {
    core::iter::from_fn(move || {
        let [i0, i1, sub, len, tail @ ..] = rest else {
            return None;
        };
        let data = tail.get(..usize::from(*len))?;
        rest = tail.get(data.len()..).unwrap_or(&[]);
        Some((u16::from_le_bytes([*i0, *i1]), *sub, data))
    })
}

/// `0x1008`.
pub const DEVICE_NAME: &str = "agent-node";
const STORE_TAG: &[u8] = b"CO1\0";

fn persisted(o: &Object) -> bool {
    match o.item {
        Item::HeartbeatConsumer | Item::HeartbeatProducer => true,
        Item::Param(_) | Item::Setting(_) => o.access == Access::ReadWrite,
        _ => false,
    }
}

struct Writer<'a> {
    out: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn put(&mut self, b: &[u8]) -> Option<()> {
        let end = self.pos + b.len();
        self.out.get_mut(self.pos..end)?.copy_from_slice(b);
        self.pos = end;
        Some(())
    }
}

fn string(s: &str) -> SdoData {
    let mut d = SdoData::default();
    let b = s.as_bytes();
    d.extend(b.get(..SdoData::CAPACITY).unwrap_or(b));
    d
}

/// A CANopen frame as a bus monitor reads it ([`decode`]).
///
/// ```
/// use agent_node::canopen::{decode, Message, NmtCommand};
/// assert_eq!(decode(0x000, &[0x81, 3]),
///     Some(Message::Nmt { command: Some(NmtCommand::ResetNode), node: 3 }));
/// assert_eq!(decode(0x080, &[]), Some(Message::Sync));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message {
    /// NMT command to `node` (0: all).
    Nmt {
        /// The command (`None`: an unknown specifier).
        command: Option<NmtCommand>,
        /// Addressed node-ID, 0 for all.
        node: u8,
    },
    /// SYNC.
    Sync,
    /// Emergency of `node`.
    Emcy {
        /// Sender.
        node: u8,
        /// Error code (`0x0000`: error reset).
        code: u16,
        /// Error register.
        register: u8,
        /// Manufacturer-specific bytes ([`Fault::info`]).
        info: [u8; 5],
    },
    /// An SDO frame between a client and server `node`.
    Sdo {
        /// The server.
        node: u8,
        /// Client → server (a request), else the server's answer.
        request: bool,
        /// Command byte.
        command: u8,
        /// Index and sub-index (of an initiate or abort frame; else 0).
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The abort code of an abort frame.
        abort: Option<u32>,
    },
    /// Heartbeat or boot-up of `node`.
    Heartbeat {
        /// Sender.
        node: u8,
        /// Its NMT state (`None`: an unknown byte).
        state: Option<NmtState>,
    },
}

/// The CANopen message of a frame of the predefined connection set; `None` for PDOs and
/// identifiers outside the set.
///
/// ```
/// use agent_node::canopen::{abort_frame, decode, Abort, Message, NmtState};
/// assert_eq!(decode(0x705, &[0x05]), Some(Message::Heartbeat { node: 5, state: Some(NmtState::Operational) }));
/// let abort = abort_frame(0x2000, 0, Abort::ValueRange);
/// let Some(Message::Sdo { node, request, index, abort: code, .. }) = decode(0x585, &abort) else { panic!() };
/// assert_eq!((node, request, index, code), (5, false, 0x2000, Some(0x0609_0030)));
/// assert_eq!(decode(0x185, &[0; 4]), None); // a PDO
/// ```
#[must_use]
pub fn decode(id: u16, data: &[u8]) -> Option<Message> {
    let node = (id & 0x7F) as u8;
    let byte = |k: usize| data.get(k).copied().unwrap_or(0);
    match id & !0x7F {
        _ if id == NMT_ID => Some(Message::Nmt {
            command: NmtCommand::from_code(byte(0)),
            node: byte(1),
        }),
        _ if id == SYNC_ID => Some(Message::Sync),
        0x080 => Some(Message::Emcy {
            node,
            code: u16::from_le_bytes([byte(0), byte(1)]),
            register: byte(2),
            info: [byte(3), byte(4), byte(5), byte(6), byte(7)],
        }),
        0x580 | 0x600 if node > 0 => {
            let command = byte(0);
            let initiate_or_abort = matches!(command >> 5, 1..=4) || command == 0x80;
            let (index, sub) = if initiate_or_abort && command >> 5 != 3 {
                (u16::from_le_bytes([byte(1), byte(2)]), byte(3))
            } else {
                (0, 0)
            };
            Some(Message::Sdo {
                node,
                request: id & !0x7F == 0x600,
                command,
                index,
                sub,
                abort: (command == 0x80)
                    .then(|| u32::from_le_bytes([byte(4), byte(5), byte(6), byte(7)])),
            })
        }
        0x700 if node > 0 => Some(Message::Heartbeat {
            node,
            state: NmtState::from_code(byte(0)),
        }),
        _ => None,
    }
}

/// The SDO abort frame's data.
///
/// ```
/// use agent_node::canopen::{abort_frame, Abort};
/// assert_eq!(abort_frame(0x1017, 0, Abort::ReadOnly), [0x80, 0x17, 0x10, 0, 0x02, 0, 0x01, 0x06]);
/// ```
#[must_use]
pub fn abort_frame(index: u16, sub: u8, a: Abort) -> [u8; 8] {
    let i = index.to_le_bytes();
    let c = a.code().to_le_bytes();
    [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
}

#[cfg(test)]
mod tests;
