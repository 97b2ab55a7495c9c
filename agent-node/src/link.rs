//! The serial link between a node and the host that owns its plant and leader: what host-sim's
//! processor-in-the-loop network and the node firmware (`node-fw`, one emulated Cortex-M4F per
//! agent) say to each other over the board's UART.
//!
//! ## Framing: SLCAN (Lawicel ASCII)
//!
//! Every message is a classical CAN frame in the serial-line CAN adapter protocol that
//! CANable/USBtin adapters, Linux `slcand` and python-can's `slcan` interface speak:
//! `tIIIL<data hex>\r` (11-bit id), `TIIIIIIIIL<data hex>\r` (29-bit id), `O\r` open,
//! `C\r` close, `S0`..`S8\r` bit rate (answered with `\r`; an unknown command with `\a`). The
//! node sends its frames unsolicited (no `z` acknowledgement, as in auto-poll mode).
//!
//! ## Two kinds of frames on one link
//!
//! * **Bus frames** (11-bit ids, the wire format of [`crate::wire`], or anything a babbling
//!   node floods): the host delivers those the bus model delivered to this node, and forwards
//!   the node's own frame to the bus model.
//! * **Process-I/O frames** (29-bit ids, [`io`]): configuration, sample timing, sensors,
//!   actuators and diagnostics between the node and the host that owns plant and leader. The
//!   bus protocol never uses 29-bit ids ([`crate::wire::decode`] rejects them), so the two can
//!   never be confused, whatever a babbling node sends. They model the node's local I/O and
//!   are not put through the bus model (on a 1 Mbit/s bus they would not fit into a 1 ms
//!   sample next to the five value frames).
//!
//! ## Two records of this link's own
//!
//! The per-sample exchange between node and host, which never goes on the bus, travels as two
//! compact records instead of 29-bit SLCAN frames: one line each, a letter that no SLCAN
//! dialect uses, the payload in base64 (RFC 4648 alphabet, no padding), `\r`. The emulated
//! UART hands the node one byte per round trip through the emulator, so bytes into the node
//! are the cost of a PIL run; the records carry in 13 and 66 bytes what took 31 and 162
//! bytes as SLCAN frames. `docs/wire.dbc` describes their payloads under the ids [`io::SYNC`]
//! and [`io::REPORT`] (cantools decodes the base64-decoded bytes with them).
//!
//! * [`record::TICK`] `k` (host → node, [`Tick`]): the state `x_i` of sample `t_k` (`f32` LE
//!   each) and, only when it differs from the previous tick's, the interval `t_k − t_{k−1}` in
//!   µs (`u32` LE); the node sets its clock, its sensor, and runs [`crate::Node::tick`].
//! * [`record::REPORT`] `y` (node → host, [`Report`], 48 bytes): `q`, `u`, `e`, `μ̂`, `ξ̂`,
//!   `λ̂`, status, and the instructions of the tick.
//!
//! ## One sample (host → node, then node → host)
//!
//! 1. each bus frame delivered to the node since the last sample and passing its acceptance
//!    filter (the identifiers of the agents it hears, and the leader's if it is pinned — what
//!    a CAN controller's filter, or SLCAN's `M`/`m` acceptance registers, would be set to),
//!    with its delivery time as SLCAN timestamp ([`Slcan::Timed`], µs since the last tick):
//!    the node takes it at that clock reading (the CAN receive interrupt of
//!    [`crate::Node::poll_rx`]);
//! 2. the tick record;
//! 3. the node answers with its bus frame (if the tick queued one) and the report record.
//!
//! Start-up: the host sends the configuration as [`io::CONFIG`] frames (two 32-bit words each,
//! [`encode_config`]) and [`io::CONFIG_END`] (word count); the node answers [`io::READY`] or
//! [`io::REJECTED`]. At the end [`io::STATS_REQUEST`] is answered by [`io::STATS`] (painted
//! stack high-water mark).

use base64::{engine::general_purpose::STANDARD_NO_PAD, Engine as _};
use controller_core::{
    BaselineConfig, ControllerConfig, Feedforward, GainSelection, QuantizerConfig,
    QuantizerDirection, SafetyConfig, SchemeConfig,
};
use embedded_can::{ExtendedId, Frame, Id, StandardId};

use crate::node::NodeConfig;
use crate::supervisor::{NeighbourLoss, SafePolicy, SupervisorConfig};
use crate::wire::IdPlan;

/// 29-bit identifiers of the process-I/O frames.
pub mod io {
    /// host → node: one or two configuration words (`u32` little-endian each), in order.
    pub const CONFIG: u32 = 0x0001_0010;
    /// host → node: end of configuration; 2 bytes, the word count (`u16` LE).
    pub const CONFIG_END: u32 = 0x0001_0011;
    /// node → host: configuration accepted; 1 byte, the agent number.
    pub const READY: u32 = 0x0001_0012;
    /// node → host: configuration rejected; 1 byte, a [`super::ConfigReject`] code.
    pub const REJECTED: u32 = 0x0001_0013;
    /// The DBC id of the [`super::Tick`] record's payload (`docs/wire.dbc` `Sync`); never a
    /// frame on the link.
    pub const SYNC: u32 = 0x0001_0080;
    /// host → node: the clock (µs, low 32 bits, `u32` LE, extended to 64 bits by
    /// [`super::extend_clock`]), when a bus frame's delivery is 2¹⁶ µs or more after the
    /// previous tick (the frame then follows without timestamp).
    pub const CLOCK: u32 = 0x0001_0081;
    /// The DBC id of the [`super::Report`] record's payload (`docs/wire.dbc` `Report`); never
    /// a frame on the link.
    pub const REPORT: u32 = 0x0001_0300;
    /// host → node: report the statistics.
    pub const STATS_REQUEST: u32 = 0x0001_0090;
    /// node → host: stack high-water mark (bytes, `u32` LE), malformed bus frames received
    /// (`u32` LE).
    pub const STATS: u32 = 0x0001_0091;
    /// node → host: the firmware started (power-on or watchdog reset) and waits for its
    /// configuration; 1 byte, the link protocol's version ([`super::PROTOCOL_VERSION`]).
    pub const BOOT: u32 = 0x0001_0001;
    /// host → node: stop the control task at the next tick record (a firmware bug in the
    /// emulator: it spins without feeding the watchdog); no data.
    pub const HANG: u32 = 0x0001_00A0;
    /// node → host: the sample timer released the control task while its previous step was
    /// still running (a deadline overrun); the overruns so far (`u32` LE).
    pub const OVERRUN: u32 = 0x0001_00A1;
    /// host → node: from the next tick record on, each control step takes this many sample
    /// periods of the node's time (`u32` LE, in units of 2⁻¹⁶ period, see
    /// [`super::slow_periods`]; 0 ends it): a step that is too slow for its deadline
    /// (`[[network.event]] kind = "slow"`).
    pub const SLOW: u32 = 0x0001_00A2;
    /// host → node, before `CONFIG_END`: the watchdog's late periods (`u32` LE; 0: no
    /// watchdog). Without it the node uses [`super::DEFAULT_WATCHDOG_PERIODS`].
    pub const WATCHDOG: u32 = 0x0001_0014;
}

/// Version of this link protocol, sent in the node's [`io::BOOT`] frame.
pub const PROTOCOL_VERSION: u8 = 3;

/// Late periods of a node's watchdog when the host sends no [`io::WATCHDOG`]: a node none of
/// whose steps has ended before its deadline for this many sample periods (and half of one)
/// is reset.
pub const DEFAULT_WATCHDOG_PERIODS: u32 = 10;

/// One sample period in the units of [`io::SLOW`].
pub const SLOW_PERIOD_UNIT: u32 = 1 << 16;

/// A step's duration of `periods` sample periods in the units of [`io::SLOW`] (rounded to
/// 2⁻¹⁶ period; at least one unit for any `periods > 0`; saturating), or `None` for a value
/// that is not finite and > 0.
///
/// ```
/// use agent_node::link::{slow_periods, SLOW_PERIOD_UNIT};
/// // A step that takes 1.5 sample periods (a deadline overrun of half a period).
/// assert_eq!(slow_periods(1.5), Some(3 * SLOW_PERIOD_UNIT / 2));
/// assert_eq!(slow_periods(1e-9), Some(1)); // at least one unit
/// assert_eq!(slow_periods(0.0), None);
/// assert_eq!(slow_periods(f64::NAN), None);
/// ```
#[must_use]
pub fn slow_periods(periods: f64) -> Option<u32> {
    if !(periods.is_finite() && periods > 0.0) {
        return None;
    }
    // `as` saturates at `u32::MAX`; `+ 0.5` rounds the positive value to the nearest unit.
    let units = periods * f64::from(SLOW_PERIOD_UNIT) + 0.5;
    Some((units as u32).max(1))
}

/// A classical CAN frame (standard or extended id, data or remote, 0..=8 bytes): the frames
/// of SLCAN, of `hil-mock`'s mocked CAN controller and of its bus model.
///
/// ```
/// use agent_node::link::CanFrame;
/// use embedded_can::{Frame, StandardId};
/// // The leader's value frame (11-bit id 0x101) and a process-I/O frame (29 bits).
/// let bus = CanFrame::new(StandardId::new(0x101).unwrap(), &[1, 2, 3, 4]).unwrap();
/// assert_eq!((bus.raw_id(), bus.io_id(), bus.data()), (0x101, None, &[1u8, 2, 3, 4][..]));
/// let io = CanFrame::io(agent_node::link::io::READY, &[3]).unwrap();
/// assert!(io.is_extended() && !io.is_remote_frame());
/// assert!(CanFrame::new(StandardId::ZERO, &[0; 9]).is_none()); // classical CAN: 8 bytes at most
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CanFrame {
    id: Id,
    remote: bool,
    dlc: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A process-I/O data frame with 29-bit identifier `id`; `None` if `id` or `data` is too
    /// long.
    ///
    /// ```
    /// use agent_node::link::{io, CanFrame};
    /// use embedded_can::Frame;
    /// let f = CanFrame::io(io::CONFIG_END, &12u16.to_le_bytes()).unwrap();
    /// assert_eq!(f.io_id(), Some(io::CONFIG_END));
    /// assert_eq!(f.dlc(), 2);
    /// assert!(CanFrame::io(1 << 29, &[]).is_none()); // beyond 29 bits
    /// ```
    #[must_use]
    pub fn io(id: u32, data: &[u8]) -> Option<Self> {
        Self::new(ExtendedId::new(id)?, data)
    }

    /// The 29-bit identifier of a process-I/O frame; `None` for an 11-bit (bus) frame.
    ///
    /// ```
    /// use agent_node::link::{io, CanFrame};
    /// use embedded_can::{Frame, StandardId};
    /// assert_eq!(CanFrame::io(io::BOOT, &[3]).unwrap().io_id(), Some(io::BOOT));
    /// let bus = CanFrame::new(StandardId::new(0x102).unwrap(), &[0; 4]).unwrap();
    /// assert_eq!(bus.io_id(), None); // a bus frame, not process I/O
    /// ```
    #[must_use]
    pub fn io_id(&self) -> Option<u32> {
        match self.id {
            Id::Extended(e) => Some(e.as_raw()),
            Id::Standard(_) => None,
        }
    }

    /// Raw identifier bits (11 or 29) — the arbitration priority (lower wins).
    ///
    /// ```
    /// use agent_node::link::CanFrame;
    /// use embedded_can::{Frame, StandardId};
    /// // The lower identifier wins arbitration: the leader (0x101) before agent 1 (0x102).
    /// let leader = CanFrame::new(StandardId::new(0x101).unwrap(), &[]).unwrap();
    /// let agent1 = CanFrame::new(StandardId::new(0x102).unwrap(), &[]).unwrap();
    /// assert!(leader.raw_id() < agent1.raw_id());
    /// ```
    #[must_use]
    pub fn raw_id(&self) -> u32 {
        match self.id {
            Id::Standard(s) => u32::from(s.as_raw()),
            Id::Extended(e) => e.as_raw(),
        }
    }
}

impl Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let dlc = u8::try_from(data.len()).ok().filter(|&n| n <= 8)?;
        let mut buf = [0; 8];
        buf[..data.len()].copy_from_slice(data);
        Some(Self {
            id: id.into(),
            remote: false,
            dlc,
            data: buf,
        })
    }

    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        let dlc = u8::try_from(dlc).ok().filter(|&n| n <= 8)?;
        Some(Self {
            id: id.into(),
            remote: true,
            dlc,
            data: [0; 8],
        })
    }

    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }

    fn is_remote_frame(&self) -> bool {
        self.remote
    }

    fn id(&self) -> Id {
        self.id
    }

    fn dlc(&self) -> usize {
        usize::from(self.dlc)
    }

    fn data(&self) -> &[u8] {
        if self.remote {
            &[]
        } else {
            &self.data[..usize::from(self.dlc)]
        }
    }
}

/// Longest SLCAN line: `T` + 8 id digits + DLC + 16 data digits + 4 timestamp digits + `\r`.
/// Also the longest line a node receives (a tick record has at most 18 bytes).
pub const SLCAN_MAX_LINE: usize = 31;

/// The letters of this link's own records (module docs, "Two records of this link's own").
pub mod record {
    /// host → node: [`super::Tick`].
    pub const TICK: u8 = b'k';
    /// node → host: [`super::Report`].
    pub const REPORT: u8 = b'y';
}

/// Longest record line: letter, 64 base64 digits of the 48-byte report, `\r`.
pub const RECORD_MAX_LINE: usize = 66;

/// The `k` record: sample `t_k` for the node.
///
/// ```
/// use agent_node::link::{slcan_decode, tick_encode, Slcan, Tick, RECORD_MAX_LINE};
/// // x_i = (0.5, -1) after 1 ms: 12 bytes, 16 base64 digits after the letter `k`.
/// let t = Tick { x: [0.5, -1.0], dt_us: Some(1_000) };
/// let mut line = [0u8; RECORD_MAX_LINE];
/// let n = tick_encode(&t, &mut line);
/// assert_eq!((line[0], n), (b'k', 18));
/// assert_eq!(slcan_decode(&line[..n - 1]), Ok(Slcan::Tick(t)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// The state `x_{i,1}`, `x_{i,2}` (the node's sensor).
    pub x: [f32; 2],
    /// `t_k − t_{k−1}` in µs; `None`: the same as the previous tick's (0 before the first).
    pub dt_us: Option<u32>,
}

impl Tick {
    /// The payload and its length: `x` (`f32` LE each), then `dt_us` (`u32` LE) when given.
    ///
    /// ```
    /// use agent_node::link::Tick;
    /// let (b, n) = Tick { x: [1.0, 0.0], dt_us: None }.to_bytes();
    /// assert_eq!(n, 8); // the interval is left out when unchanged
    /// assert_eq!(&b[..4], &1.0f32.to_le_bytes());
    /// assert_eq!(Tick { x: [1.0, 0.0], dt_us: Some(7) }.to_bytes().1, 12);
    /// ```
    #[must_use]
    pub fn to_bytes(&self) -> ([u8; 12], usize) {
        let mut b = [0u8; 12];
        b[..4].copy_from_slice(&self.x[0].to_le_bytes());
        b[4..8].copy_from_slice(&self.x[1].to_le_bytes());
        let len = match self.dt_us {
            Some(dt) => {
                b[8..].copy_from_slice(&dt.to_le_bytes());
                12
            }
            None => 8,
        };
        (b, len)
    }
}

/// The `y` record: what the node did in one tick.
///
/// ```
/// use agent_node::link::{report_encode, slcan_decode, Report, Slcan, RECORD_MAX_LINE};
/// let r = Report { q: [0.1, 0.1], u: [0.12, 0.12], e: [0.02, -0.3], mu: 1.0, xi: 2.0,
///     lambda: 3.0, fault: 0, stale: 1, missing: 0, leader: 0, state: 2, instructions: 9_000,
///     resolution: 1 };
/// let mut line = [0u8; RECORD_MAX_LINE];
/// let n = report_encode(&r, &mut line);
/// assert_eq!(slcan_decode(&line[..n - 1]), Ok(Slcan::Report(r))); // bit-exact round trip
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Report {
    /// Quantized commands written to the actuators.
    pub q: [f32; 2],
    /// Commands before quantization.
    pub u: [f32; 2],
    /// Errors `e_1`, `e_2`.
    pub e: [f32; 2],
    /// Estimates `μ̂`, `ξ̂`, `λ̂`.
    pub mu: f32,
    /// See `mu`.
    pub xi: f32,
    /// See `mu`.
    pub lambda: f32,
    /// Fault code: 0 none, 1 invalid state, 2 non-finite result.
    pub fault: u8,
    /// Stale neighbours.
    pub stale: u8,
    /// Missing neighbours.
    pub missing: u8,
    /// Leader flags: bit 0 stale, bit 1 missing.
    pub leader: u8,
    /// The node's state after the tick ([`crate::NodeState::code`]; 0 operational), sent in
    /// bits 4..5 of the leader flags' byte.
    pub state: u8,
    /// Instructions of the tick.
    pub instructions: u32,
    /// Instructions per count of the tick's counter.
    pub resolution: u32,
}

/// Bytes of a [`Report`]'s payload.
pub const REPORT_BYTES: usize = 48;

impl Report {
    /// The payload: the nine `f32` (`q`, `u`, `e`, `μ̂`, `ξ̂`, `λ̂`), the four status bytes,
    /// `instructions`, `resolution`; little-endian.
    ///
    /// ```
    /// use agent_node::link::{Report, REPORT_BYTES};
    /// let r = Report { q: [0.5, 0.5], u: [0.6, 0.6], e: [0.0; 2], mu: 0.0, xi: 0.0, lambda: 0.0,
    ///     fault: 1, stale: 0, missing: 0, leader: 0, state: 0, instructions: 0, resolution: 1 };
    /// let b: [u8; REPORT_BYTES] = r.to_bytes();
    /// assert_eq!(&b[..4], &0.5f32.to_le_bytes()); // q_1 first
    /// assert_eq!(Report::from_bytes(&b), Some(r));
    /// ```
    #[must_use]
    pub fn to_bytes(&self) -> [u8; REPORT_BYTES] {
        let mut b = [0u8; REPORT_BYTES];
        let floats = [
            self.q[0],
            self.q[1],
            self.u[0],
            self.u[1],
            self.e[0],
            self.e[1],
            self.mu,
            self.xi,
            self.lambda,
        ];
        for (chunk, v) in b.chunks_exact_mut(4).zip(floats) {
            chunk.copy_from_slice(&v.to_le_bytes());
        }
        let flags = (self.leader & 0x0F) | ((self.state & 0x03) << 4);
        b[36..40].copy_from_slice(&[self.fault, self.stale, self.missing, flags]);
        b[40..44].copy_from_slice(&self.instructions.to_le_bytes());
        b[44..48].copy_from_slice(&self.resolution.to_le_bytes());
        b
    }

    /// The report of a payload; `None` unless it has [`REPORT_BYTES`] bytes.
    ///
    /// ```
    /// use agent_node::link::{Report, REPORT_BYTES};
    /// assert!(Report::from_bytes(&[0u8; REPORT_BYTES]).is_some());
    /// assert_eq!(Report::from_bytes(&[0u8; REPORT_BYTES - 1]), None); // wrong length
    /// ```
    #[must_use]
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let b: &[u8; REPORT_BYTES] = b.try_into().ok()?;
        let mut w = [0u32; 12];
        for (word, chunk) in w.iter_mut().zip(b.chunks_exact(4)) {
            *word = u32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
        }
        let f = |k: usize| f32::from_bits(w[k]);
        Some(Self {
            q: [f(0), f(1)],
            u: [f(2), f(3)],
            e: [f(4), f(5)],
            mu: f(6),
            xi: f(7),
            lambda: f(8),
            fault: b[36],
            stale: b[37],
            missing: b[38],
            leader: b[39] & 0x0F,
            state: (b[39] >> 4) & 0x03,
            instructions: w[10],
            resolution: w[11],
        })
    }
}

fn encode_record(letter: u8, payload: &[u8], out: &mut [u8; RECORD_MAX_LINE]) -> usize {
    out[0] = letter;
    let n = STANDARD_NO_PAD
        .encode_slice(payload, &mut out[1..RECORD_MAX_LINE - 1])
        .unwrap_or(0);
    out[n + 1] = b'\r';
    n + 2
}

/// The line of a tick record (ending in `\r`) in `out`; returns its length.
///
/// ```
/// use agent_node::link::{slcan_decode, tick_encode, Slcan, Tick, RECORD_MAX_LINE};
/// let t = Tick { x: [0.5, -1.0], dt_us: None };
/// let mut buf = [0u8; RECORD_MAX_LINE];
/// let n = tick_encode(&t, &mut buf);
/// assert_eq!(&buf[..n], b"kAAAAPwAAgL8\r");
/// assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Tick(t)));
/// ```
pub fn tick_encode(tick: &Tick, out: &mut [u8; RECORD_MAX_LINE]) -> usize {
    let (b, len) = tick.to_bytes();
    encode_record(record::TICK, &b[..len], out)
}

/// The line of a report record (ending in `\r`) in `out`; returns its length.
///
/// ```
/// use agent_node::link::{report_encode, Report, RECORD_MAX_LINE};
/// let r = Report { q: [0.0; 2], u: [0.0; 2], e: [0.0; 2], mu: 0.0, xi: 0.0, lambda: 0.0,
///     fault: 0, stale: 0, missing: 0, leader: 0, state: 0, instructions: 0, resolution: 0 };
/// let mut line = [0u8; RECORD_MAX_LINE];
/// // 48 bytes are 64 base64 digits: `y`, the digits, `\r` fill the longest record line.
/// assert_eq!(report_encode(&r, &mut line), RECORD_MAX_LINE);
/// assert_eq!((line[0], line[RECORD_MAX_LINE - 1]), (b'y', b'\r'));
/// ```
pub fn report_encode(report: &Report, out: &mut [u8; RECORD_MAX_LINE]) -> usize {
    encode_record(record::REPORT, &report.to_bytes(), out)
}

/// One SLCAN command, or one of this link's own records.
///
/// ```
/// use agent_node::link::{slcan_decode, Slcan};
/// assert_eq!(slcan_decode(b"O"), Ok(Slcan::Open));
/// assert_eq!(slcan_decode(b"C"), Ok(Slcan::Close));
/// assert_eq!(slcan_decode(b"S8"), Ok(Slcan::Bitrate(8))); // 1 Mbit/s
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Slcan {
    /// `t`, `T`, `r`, `R`: a frame.
    Frame(CanFrame),
    /// A frame followed by SLCAN's 4-digit timestamp extension (`Z1` mode of Lawicel
    /// adapters, there in ms); on this link: µs since the last [`Tick`].
    Timed(CanFrame, u16),
    /// `O`: open the channel.
    Open,
    /// `C`: close the channel.
    Close,
    /// `S0`..`S8`: the standard bit-rate codes (10 k .. 1 Mbit/s).
    Bitrate(u8),
    /// `k`: this link's tick record.
    Tick(Tick),
    /// `y`: this link's report record.
    Report(Report),
}

/// Why an SLCAN line was rejected.
///
/// `#[non_exhaustive]`: the link may learn further SLCAN commands, each with its own refusal.
///
/// ```
/// use agent_node::link::{slcan_decode, SlcanError};
/// assert_eq!(slcan_decode(b"x"), Err(SlcanError::UnknownCommand));
/// assert_eq!(slcan_decode(b"t10G0"), Err(SlcanError::Malformed)); // `G` is no hex digit
/// assert!(!SlcanError::Malformed.to_string().is_empty());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlcanError {
    /// Empty line or unknown command letter.
    UnknownCommand,
    /// Wrong length, a non-hex digit, an out-of-range id or DLC.
    Malformed,
}

impl core::fmt::Display for SlcanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::UnknownCommand => "an empty SLCAN line or an unknown command letter",
            Self::Malformed => "a malformed SLCAN line (length, hex digit, identifier or DLC)",
        })
    }
}

impl core::error::Error for SlcanError {}

const HEX: &[u8; 16] = b"0123456789ABCDEF";

fn hex_digit(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

fn hex_value(digits: &[u8]) -> Option<u32> {
    digits
        .iter()
        .try_fold(0u32, |v, &d| Some((v << 4) | u32::from(hex_digit(d)?)))
}

/// The SLCAN line of `frame` (ending in `\r`) in `out`; returns its length.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use agent_node::link::{slcan_decode, slcan_encode, CanFrame, Slcan, SLCAN_MAX_LINE};
/// let f = CanFrame::new(StandardId::new(0x101).unwrap(), &[0x1F, 0x05, 0, 0x01]).unwrap();
/// let mut buf = [0u8; SLCAN_MAX_LINE];
/// let n = slcan_encode(&f, &mut buf);
/// assert_eq!(&buf[..n], b"t10141F050001\r");
/// assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Frame(f)));
/// ```
pub fn slcan_encode(frame: &CanFrame, out: &mut [u8; SLCAN_MAX_LINE]) -> usize {
    encode_line(frame, None, out)
}

/// The SLCAN line of `frame` with the 4-digit timestamp `ts` (see [`Slcan::Timed`]).
///
/// ```
/// use agent_node::link::{slcan_decode, slcan_encode_timed, CanFrame, Slcan, SLCAN_MAX_LINE};
/// use embedded_can::{Frame, StandardId};
/// // Agent 1's frame delivered 250 µs after the last tick.
/// let f = CanFrame::new(StandardId::new(0x102).unwrap(), &[0xAB]).unwrap();
/// let mut buf = [0u8; SLCAN_MAX_LINE];
/// let n = slcan_encode_timed(&f, 250, &mut buf);
/// assert_eq!(&buf[..n], b"t1021AB00FA\r");
/// assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Timed(f, 250)));
/// ```
pub fn slcan_encode_timed(frame: &CanFrame, ts: u16, out: &mut [u8; SLCAN_MAX_LINE]) -> usize {
    encode_line(frame, Some(ts), out)
}

fn encode_line(frame: &CanFrame, ts: Option<u16>, out: &mut [u8; SLCAN_MAX_LINE]) -> usize {
    let (cmd, id, digits) = match (frame.id, frame.remote) {
        (Id::Standard(s), false) => (b't', u32::from(s.as_raw()), 3),
        (Id::Standard(s), true) => (b'r', u32::from(s.as_raw()), 3),
        (Id::Extended(e), false) => (b'T', e.as_raw(), 8),
        (Id::Extended(e), true) => (b'R', e.as_raw(), 8),
    };
    out[0] = cmd;
    for (k, o) in out[1..=digits].iter_mut().enumerate() {
        *o = HEX[((id >> (4 * (digits - 1 - k))) & 0xF) as usize];
    }
    let mut n = digits + 1;
    out[n] = b'0' + frame.dlc;
    n += 1;
    for &b in frame.data() {
        out[n] = HEX[usize::from(b >> 4)];
        out[n + 1] = HEX[usize::from(b & 0xF)];
        n += 2;
    }
    if let Some(ts) = ts {
        for k in 0..4 {
            out[n + k] = HEX[usize::from((ts >> (12 - 4 * k)) & 0xF)];
        }
        n += 4;
    }
    out[n] = b'\r';
    n + 1
}

/// Parse one SLCAN line or record (without its `\r`). Never panics.
///
/// ```
/// use agent_node::link::{slcan_decode, Slcan, SlcanError};
/// use embedded_can::Frame;
/// let Ok(Slcan::Frame(f)) = slcan_decode(b"T0001001221122") else { panic!() };
/// assert_eq!((f.io_id(), f.data()), (Some(0x0001_0012), &[0x11u8, 0x22][..]));
/// assert_eq!(slcan_decode(b""), Err(SlcanError::UnknownCommand));
/// assert_eq!(slcan_decode(b"t1029"), Err(SlcanError::Malformed)); // DLC 9
/// ```
pub fn slcan_decode(line: &[u8]) -> Result<Slcan, SlcanError> {
    let (&cmd, rest) = line.split_first().ok_or(SlcanError::UnknownCommand)?;
    let digits = match cmd {
        record::TICK | record::REPORT => return decode_record(cmd, rest),
        b't' | b'r' => 3,
        b'T' | b'R' => 8,
        b'O' if rest.is_empty() => return Ok(Slcan::Open),
        b'C' if rest.is_empty() => return Ok(Slcan::Close),
        b'S' => {
            return match rest {
                [d @ b'0'..=b'8'] => Ok(Slcan::Bitrate(d - b'0')),
                _ => Err(SlcanError::Malformed),
            }
        }
        _ => return Err(SlcanError::UnknownCommand),
    };
    let id_digits = rest.get(..digits).ok_or(SlcanError::Malformed)?;
    let raw = hex_value(id_digits).ok_or(SlcanError::Malformed)?;
    let dlc = rest
        .get(digits)
        .and_then(|&d| d.checked_sub(b'0'))
        .filter(|&d| d <= 8)
        .ok_or(SlcanError::Malformed)?;
    let id: Id = if digits == 3 {
        StandardId::new(u16::try_from(raw).map_err(|_| SlcanError::Malformed)?)
            .ok_or(SlcanError::Malformed)?
            .into()
    } else {
        ExtendedId::new(raw).ok_or(SlcanError::Malformed)?.into()
    };
    let mut payload = &rest[digits + 1..];
    let data_digits = if cmd == b'r' || cmd == b'R' {
        0
    } else {
        2 * usize::from(dlc)
    };
    let ts = match payload.len().checked_sub(data_digits) {
        Some(0) => None,
        Some(4) => {
            let t = hex_value(&payload[data_digits..]).ok_or(SlcanError::Malformed)?;
            payload = &payload[..data_digits];
            Some(u16::try_from(t).map_err(|_| SlcanError::Malformed)?)
        }
        _ => return Err(SlcanError::Malformed),
    };
    let frame = if cmd == b'r' || cmd == b'R' {
        CanFrame::new_remote(id, usize::from(dlc))
    } else {
        let mut data = [0u8; 8];
        for (d, pair) in data.iter_mut().zip(payload.chunks_exact(2)) {
            *d = u8::try_from(hex_value(pair).ok_or(SlcanError::Malformed)?)
                .map_err(|_| SlcanError::Malformed)?;
        }
        CanFrame::new(id, &data[..usize::from(dlc)])
    };
    let frame = frame.ok_or(SlcanError::Malformed)?;
    Ok(match ts {
        None => Slcan::Frame(frame),
        Some(t) => Slcan::Timed(frame, t),
    })
}

fn decode_record(letter: u8, digits: &[u8]) -> Result<Slcan, SlcanError> {
    let mut b = [0u8; 64];
    let n = STANDARD_NO_PAD
        .decode_slice(digits, &mut b)
        .map_err(|_| SlcanError::Malformed)?;
    let u32_at = |k: usize| u32::from_le_bytes([b[k], b[k + 1], b[k + 2], b[k + 3]]);
    match (letter, n) {
        (record::TICK, 8 | 12) => Ok(Slcan::Tick(Tick {
            x: [f32::from_bits(u32_at(0)), f32::from_bits(u32_at(4))],
            dt_us: (n == 12).then(|| u32_at(8)),
        })),
        (record::REPORT, _) => Report::from_bytes(&b[..n])
            .map(Slcan::Report)
            .ok_or(SlcanError::Malformed),
        _ => Err(SlcanError::Malformed),
    }
}

/// Two `f32` as the 8 data bytes of a process-I/O frame (little-endian).
///
/// ```
/// use agent_node::link::{pack_f32x2, unpack_u32x2};
/// let b = pack_f32x2(0.25, -2.0);
/// let (a, c) = unpack_u32x2(&b).unwrap();
/// assert_eq!((f32::from_bits(a), f32::from_bits(c)), (0.25, -2.0));
/// ```
#[must_use]
pub fn pack_f32x2(a: f32, b: f32) -> [u8; 8] {
    let (a, b) = (a.to_le_bytes(), b.to_le_bytes());
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
}

/// The two `u32` (or `f32` bit patterns) of 8 data bytes; `None` for another length.
///
/// ```
/// use agent_node::link::unpack_u32x2;
/// assert_eq!(unpack_u32x2(&[1, 0, 0, 0, 2, 0, 0, 0]), Some((1, 2)));
/// assert_eq!(unpack_u32x2(&[1, 0, 0, 0]), None);
/// ```
#[must_use]
pub fn unpack_u32x2(data: &[u8]) -> Option<(u32, u32)> {
    let [a0, a1, a2, a3, b0, b1, b2, b3] = *data else {
        return None;
    };
    Some((
        u32::from_le_bytes([a0, a1, a2, a3]),
        u32::from_le_bytes([b0, b1, b2, b3]),
    ))
}

/// The `u32` of 4 data bytes; `None` for another length.
///
/// ```
/// use agent_node::link::unpack_u32;
/// assert_eq!(unpack_u32(&[0x10, 0x27, 0, 0]), Some(10_000));
/// assert_eq!(unpack_u32(&[0; 8]), None);
/// ```
#[must_use]
pub fn unpack_u32(data: &[u8]) -> Option<u32> {
    let [a, b, c, d] = *data else {
        return None;
    };
    Some(u32::from_le_bytes([a, b, c, d]))
}

/// The 64-bit clock (µs) after `last` whose low 32 bits are `low`: the host's time never goes
/// back and advances by less than 2³² µs (71 min) between two messages.
///
/// ```
/// use agent_node::link::extend_clock;
/// assert_eq!(extend_clock(5, 7), 7);
/// assert_eq!(extend_clock(0xFFFF_FFF0, 0x10), 0x1_0000_0010);
/// ```
#[must_use]
pub fn extend_clock(last: u64, low: u32) -> u64 {
    let t = (last & !0xFFFF_FFFF) | u64::from(low);
    if t < last {
        t + (1 << 32)
    } else {
        t
    }
}

/// Configuration words at most (`N` ≤ 4, `K` ≤ 16).
pub const MAX_CONFIG_WORDS: usize = 80;

/// The configuration of one node as 32-bit words: node settings, then every field of the
/// controller configuration (`f32` as bit patterns, options and enums as tags), in the order
/// [`decode_config`] reads them.
///
/// ```
/// use agent_node::link::{decode_config, encode_config};
/// use agent_node::NodeConfig;
/// use controller_core::ControllerConfig;
/// let node = NodeConfig::new(4, [1, 3], 2_500);
/// let ctrl = ControllerConfig::<2> { neighbour_count: 2, pinned: false, ..Default::default() };
/// let words = encode_config(&node, &ctrl);
/// let (n2, c2) = decode_config::<2, 2>(words.as_slice().unwrap()).unwrap();
/// assert_eq!((n2, c2), (node, ctrl));
/// ```
pub struct ConfigWords {
    words: [u32; MAX_CONFIG_WORDS],
    len: usize,
}

impl ConfigWords {
    fn push(&mut self, w: u32) {
        if let Some(slot) = self.words.get_mut(self.len) {
            *slot = w;
        }
        self.len += 1;
    }

    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.push(x.to_bits());
        }
    }

    fn u64(&mut self, v: u64) {
        self.push(v as u32);
        self.push((v >> 32) as u32);
    }

    /// The words; `None` when they did not fit [`MAX_CONFIG_WORDS`].
    ///
    /// ```
    /// use agent_node::link::{encode_config, MAX_CONFIG_WORDS};
    /// use agent_node::NodeConfig;
    /// use controller_core::ControllerConfig;
    /// let words = encode_config(&NodeConfig::new(1, [], 2_500), &ControllerConfig::<2>::default());
    /// let w = words.as_slice().unwrap();
    /// assert!(!w.is_empty() && w.len() <= MAX_CONFIG_WORDS);
    /// // The agent, the neighbour count and r_i in the first word's three low bytes.
    /// assert_eq!(w[0] & 0xFF_FFFF, 1 | (1 << 16)); // agent 1, no neighbour, pinned
    /// ```
    #[must_use]
    pub fn as_slice(&self) -> Option<&[u32]> {
        self.words.get(..self.len)
    }
}

/// Why a configuration could not be read (sent back in [`io::REJECTED`]).
///
/// `#[non_exhaustive]`: a longer configuration layout brings new checks; the byte of each
/// reason on the link never changes.
///
/// ```
/// use agent_node::link::{decode_config, encode_config, ConfigReject};
/// use agent_node::NodeConfig;
/// use controller_core::ControllerConfig;
/// let words = encode_config(&NodeConfig::new(1, [], 2_500), &ControllerConfig::<2>::default());
/// let w = words.as_slice().unwrap();
/// // One word short: refused; the code goes back to the host in `io::REJECTED`.
/// let e = decode_config::<2, 0>(&w[..w.len() - 1]).unwrap_err();
/// assert_eq!((e, e as u8), (ConfigReject::WordCount, 1));
/// assert!(!e.to_string().is_empty());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
#[non_exhaustive]
pub enum ConfigReject {
    /// Fewer or more words than the layout needs.
    WordCount = 1,
    /// An enum tag or a count out of range.
    BadTag = 2,
    /// The node rejected the decoded configuration ([`crate::NodeError`]).
    Node = 3,
    /// A frame other than `CONFIG` / `CONFIG_END` arrived before the configuration was complete.
    Unexpected = 4,
}

impl core::fmt::Display for ConfigReject {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::WordCount => "the configuration has fewer or more words than its layout",
            Self::BadTag => "a configuration word holds an enum tag or a count out of range",
            Self::Node => "the node refused the decoded configuration",
            Self::Unexpected => "a frame other than a configuration word came before the end",
        })
    }
}

impl core::error::Error for ConfigReject {}

/// The words of `node` and `ctrl` (see [`ConfigWords`]).
///
/// ```
/// use agent_node::link::{encode_config, unpack_u32x2};
/// use agent_node::NodeConfig;
/// use controller_core::ControllerConfig;
/// // Two words per CONFIG frame, then CONFIG_END with the count.
/// let words = encode_config(&NodeConfig::new(1, [], 2_500), &ControllerConfig::<2>::default());
/// let w = words.as_slice().unwrap();
/// let frames = w.chunks(2).count();
/// assert_eq!(frames, w.len().div_ceil(2));
/// ```
#[must_use]
pub fn encode_config<const N: usize, const K: usize>(
    node: &NodeConfig<K>,
    ctrl: &ControllerConfig<N>,
) -> ConfigWords {
    let mut w = ConfigWords {
        words: [0; MAX_CONFIG_WORDS],
        len: 0,
    };
    let count = u32::try_from(ctrl.neighbour_count).unwrap_or(u32::MAX);
    // Bit 17: the velocity feed-forward of LAW §5a (0, the paper's law, in older words too).
    let feedforward = u32::from(!ctrl.feedforward.is_off()) << 17;
    w.push(u32::from(node.agent) | (count << 8) | (u32::from(ctrl.pinned) << 16) | feedforward);
    w.push(u32::try_from(ctrl.mtn_order).unwrap_or(u32::MAX));
    for chunk in node.neighbours.chunks(4) {
        let mut b = [0u8; 4];
        b[..chunk.len()].copy_from_slice(chunk);
        w.push(u32::from_le_bytes(b));
    }
    w.u64(node.stale_timeout_us);
    // Identifier plan: value base | heartbeat base << 16 (0xFFFF: none), agents.
    let ids = &node.ids;
    w.push(u32::from(ids.value_base()) | (u32::from(ids.heartbeat_base().unwrap_or(0xFFFF)) << 16));
    w.push(u32::from(ids.agents()));
    w.u64(node.heartbeat_period_us);
    // Supervision: policy tag and its rate, timeouts (0: not supervised), loss tag, dwell,
    // sensor-loss policy tag and rate.
    let sup = &node.supervisor;
    w.f32s(&policy_words(sup.policy));
    for t in [
        sup.leader_timeout_us,
        sup.neighbour_timeout_us,
        sup.sensor_timeout_us,
    ] {
        w.u64(t.unwrap_or(0));
    }
    w.f32s(&[match sup.neighbour_loss {
        NeighbourLoss::All => 0.0,
        NeighbourLoss::Any => 1.0,
    }]);
    w.u64(sup.recover_dwell_us);
    w.f32s(&policy_words(sup.sensor_policy));
    w.f32s(&[sup.reentry_rate]);
    w.f32s(&[ctrl.h, ctrl.ts, ctrl.zeta]);
    match ctrl.gains {
        GainSelection::Auto => w.f32s(&[0.0, 0.0, 0.0]),
        GainSelection::Explicit { c1, c2 } => w.f32s(&[1.0, c1, c2]),
    }
    w.f32s(&ctrl.a_check);
    w.f32s(&[ctrl.p, ctrl.eta, ctrl.tau, ctrl.gamma]);
    w.f32s(&ctrl.phi_low);
    w.f32s(&ctrl.phi_up);
    w.f32s(&ctrl.eps_bar);
    w.f32s(&[
        ctrl.diff_l1,
        ctrl.diff_l2,
        ctrl.varpi0,
        ctrl.varpi_decay,
        ctrl.varpi_min,
        ctrl.mu0,
        ctrl.xi0,
        ctrl.lambda0,
        ctrl.estimate_max,
    ]);
    match ctrl.quantizer {
        None => w.f32s(&[0.0, 0.0, 0.0]),
        Some(q) => {
            let dir = match q.direction {
                QuantizerDirection::Signed => 1.0,
                QuantizerDirection::Magnitude => 2.0,
            };
            w.f32s(&[dir, q.rho, q.u_min]);
        }
    }
    match ctrl.scheme {
        SchemeConfig::PredefinedTime => w.f32s(&[0.0, 0.0, 0.0, 0.0]),
        SchemeConfig::PrescribedTime(b) => match b.t_prescribed {
            None => w.f32s(&[1.0, b.kappa, b.mu_max, 0.0]),
            Some(t) => w.f32s(&[2.0, b.kappa, b.mu_max, t]),
        },
    }
    // Safety: a tag, then u_max and du_max (NaN for none), recovery rate and jump.
    match ctrl.safety {
        None => w.f32s(&[0.0, 0.0, 0.0, 0.0, 0.0]),
        Some(s) => w.f32s(&[
            1.0,
            s.u_max.unwrap_or(f32::NAN),
            s.du_max.unwrap_or(f32::NAN),
            s.recovery_rate,
            s.recovery_jump,
        ]),
    }
    w
}

/// A safe policy as a tag and its one parameter.
fn policy_words(p: SafePolicy) -> [f32; 2] {
    match p {
        SafePolicy::Hold => [0.0, 0.0],
        SafePolicy::Ramp { rate } => [1.0, rate],
        SafePolicy::Off => [2.0, 0.0],
        SafePolicy::HoldPosition => [3.0, 0.0],
        SafePolicy::Stop { decel } => [4.0, decel],
    }
}

struct Reader<'a> {
    words: &'a [u32],
    at: usize,
}

impl Reader<'_> {
    fn u32(&mut self) -> Result<u32, ConfigReject> {
        let w = *self.words.get(self.at).ok_or(ConfigReject::WordCount)?;
        self.at += 1;
        Ok(w)
    }

    fn u64(&mut self) -> Result<u64, ConfigReject> {
        Ok(u64::from(self.u32()?) | (u64::from(self.u32()?) << 32))
    }

    fn f32(&mut self) -> Result<f32, ConfigReject> {
        self.u32().map(f32::from_bits)
    }

    fn f32s<const N: usize>(&mut self) -> Result<[f32; N], ConfigReject> {
        let mut a = [0.0; N];
        for x in &mut a {
            *x = self.f32()?;
        }
        Ok(a)
    }

    /// The words of [`policy_words`].
    fn policy(&mut self) -> Result<SafePolicy, ConfigReject> {
        let tag = self.tag(4)?;
        let v = self.f32()?;
        Ok(match tag {
            0 => SafePolicy::Hold,
            1 => SafePolicy::Ramp { rate: v },
            2 => SafePolicy::Off,
            3 => SafePolicy::HoldPosition,
            _ => SafePolicy::Stop { decel: v },
        })
    }

    fn tag(&mut self, max: u8) -> Result<u8, ConfigReject> {
        let t = self.f32()?;
        (0..=max)
            .find(|&k| t == f32::from(k))
            .ok_or(ConfigReject::BadTag)
    }
}

/// The node and controller configuration of [`encode_config`]'s words. Values are checked
/// later by [`crate::Node::new`]; here only the layout (count, tags) is.
///
/// ```
/// use agent_node::link::{decode_config, encode_config, ConfigReject};
/// use agent_node::NodeConfig;
/// use controller_core::ControllerConfig;
/// let ctrl = ControllerConfig::<2> { ts: 0.5, ..Default::default() };
/// let words = encode_config(&NodeConfig::new(1, [], 2_500), &ctrl);
/// let (_, back) = decode_config::<2, 0>(words.as_slice().unwrap()).unwrap();
/// assert_eq!(back.ts, 0.5); // T_s of Theorem 1, bit for bit
/// assert_eq!(decode_config::<2, 0>(&[]).unwrap_err(), ConfigReject::WordCount);
/// ```
pub fn decode_config<const N: usize, const K: usize>(
    words: &[u32],
) -> Result<(NodeConfig<K>, ControllerConfig<N>), ConfigReject> {
    let mut r = Reader { words, at: 0 };
    let head = r.u32()?;
    let mtn_order = usize::try_from(r.u32()?).map_err(|_| ConfigReject::BadTag)?;
    let mut neighbours = [0u8; K];
    for chunk in neighbours.chunks_mut(4) {
        let b = r.u32()?.to_le_bytes();
        chunk.copy_from_slice(&b[..chunk.len()]);
    }
    let stale_timeout_us = r.u64()?;
    let bases = r.u32()?;
    let agents = u8::try_from(r.u32()?).map_err(|_| ConfigReject::BadTag)?;
    let hb = (bases >> 16) as u16;
    let ids = IdPlan::new(
        (bases & 0xFFFF) as u16,
        (hb != 0xFFFF).then_some(hb),
        agents,
    )
    .map_err(|_| ConfigReject::BadTag)?;
    let heartbeat_period_us = r.u64()?;
    let policy = r.policy()?;
    let mut timeout = || r.u64().map(|t| (t != 0).then_some(t));
    let (leader_timeout_us, neighbour_timeout_us, sensor_timeout_us) =
        (timeout()?, timeout()?, timeout()?);
    let neighbour_loss = match r.tag(1)? {
        0 => NeighbourLoss::All,
        _ => NeighbourLoss::Any,
    };
    let supervisor = SupervisorConfig {
        policy,
        leader_timeout_us,
        neighbour_timeout_us,
        neighbour_loss,
        sensor_timeout_us,
        recover_dwell_us: r.u64()?,
        sensor_policy: r.policy()?,
        reentry_rate: r.f32()?,
    };
    let [h, ts, zeta] = r.f32s()?;
    let gains = match r.tag(1)? {
        0 => {
            r.f32s::<2>()?;
            GainSelection::Auto
        }
        _ => {
            let [c1, c2] = r.f32s()?;
            GainSelection::Explicit { c1, c2 }
        }
    };
    let a_check = r.f32s()?;
    let [p, eta, tau, gamma] = r.f32s()?;
    let phi_low = r.f32s()?;
    let phi_up = r.f32s()?;
    let eps_bar = r.f32s()?;
    let [diff_l1, diff_l2, varpi0, varpi_decay, varpi_min, mu0, xi0, lambda0, estimate_max] =
        r.f32s()?;
    let quantizer = match r.tag(2)? {
        0 => {
            r.f32s::<2>()?;
            None
        }
        d => {
            let [rho, u_min] = r.f32s()?;
            let direction = if d == 1 {
                QuantizerDirection::Signed
            } else {
                QuantizerDirection::Magnitude
            };
            Some(QuantizerConfig {
                rho,
                u_min,
                direction,
            })
        }
    };
    let scheme = match r.tag(2)? {
        0 => {
            r.f32s::<3>()?;
            SchemeConfig::PredefinedTime
        }
        t => {
            let [kappa, mu_max, tp] = r.f32s()?;
            SchemeConfig::PrescribedTime(BaselineConfig {
                kappa,
                mu_max,
                t_prescribed: (t == 2).then_some(tp),
            })
        }
    };
    let safety = match r.tag(1)? {
        0 => {
            r.f32s::<4>()?;
            None
        }
        _ => {
            let [u_max, du_max, recovery_rate, recovery_jump] = r.f32s()?;
            Some(SafetyConfig {
                u_max: (!u_max.is_nan()).then_some(u_max),
                du_max: (!du_max.is_nan()).then_some(du_max),
                recovery_rate,
                recovery_jump,
            })
        }
    };
    if r.at != words.len() {
        return Err(ConfigReject::WordCount);
    }
    let node = NodeConfig {
        agent: (head & 0xFF) as u8,
        neighbours,
        stale_timeout_us,
        ids,
        heartbeat_period_us,
        supervisor,
    };
    let ctrl = ControllerConfig {
        h,
        neighbour_count: ((head >> 8) & 0xFF) as usize,
        pinned: (head >> 16) & 1 == 1,
        ts,
        zeta,
        gains,
        a_check,
        p,
        eta,
        tau,
        gamma,
        mtn_order,
        phi_low,
        phi_up,
        eps_bar,
        diff_l1,
        diff_l2,
        varpi0,
        varpi_decay,
        varpi_min,
        mu0,
        xi0,
        lambda0,
        estimate_max,
        quantizer,
        scheme,
        safety,
        feedforward: if (head >> 17) & 1 == 1 {
            Feedforward::Estimated
        } else {
            Feedforward::Off
        },
    };
    Ok((node, ctrl))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_periods_are_fixed_point_and_refuse_what_is_not_a_duration() {
        assert_eq!(slow_periods(1.0), Some(SLOW_PERIOD_UNIT));
        assert_eq!(slow_periods(5.0), Some(5 * SLOW_PERIOD_UNIT));
        assert_eq!(slow_periods(0.5), Some(SLOW_PERIOD_UNIT / 2));
        assert_eq!(slow_periods(1e-9), Some(1));
        assert_eq!(slow_periods(1e12), Some(u32::MAX));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(slow_periods(bad), None, "{bad}");
        }
    }

    #[test]
    fn config_round_trips() {
        let mut node = NodeConfig::<16>::new(
            4,
            [1, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9],
            (7 << 32) | 2500,
        );
        let mut ctrl = ControllerConfig::<2> {
            neighbour_count: 2,
            pinned: false,
            gains: GainSelection::Explicit { c1: 10.0, c2: 9.0 },
            quantizer: None,
            ..ControllerConfig::default()
        };
        for scheme in [
            SchemeConfig::PredefinedTime,
            SchemeConfig::PrescribedTime(BaselineConfig::default()),
            SchemeConfig::PrescribedTime(BaselineConfig {
                t_prescribed: Some(3.0),
                ..BaselineConfig::default()
            }),
        ] {
            ctrl.scheme = scheme;
            let w = encode_config(&node, &ctrl);
            let words = w.as_slice().expect("fits");
            assert_eq!(decode_config::<2, 16>(words), Ok((node, ctrl)));
            assert_eq!(
                decode_config::<2, 16>(&words[..words.len() - 1]),
                Err(ConfigReject::WordCount)
            );
        }
        for safety in [
            SafetyConfig {
                u_max: Some(40.0),
                du_max: None,
                ..SafetyConfig::default()
            },
            SafetyConfig {
                u_max: None,
                du_max: Some(2000.0),
                recovery_rate: f32::INFINITY,
                recovery_jump: 0.0,
            },
        ] {
            ctrl.safety = Some(safety);
            let w = encode_config(&node, &ctrl);
            assert_eq!(
                decode_config::<2, 16>(w.as_slice().expect("fits")),
                Ok((node, ctrl))
            );
        }
        let d = ControllerConfig::<2>::default();
        let w = encode_config(&node, &d);
        // docs/NETWORK.md §9: Example 1's node (n = 2, 16 neighbour slots) in 65 words.
        assert_eq!(w.as_slice().map(<[u32]>::len), Some(65));
        assert_eq!(
            decode_config::<2, 16>(w.as_slice().expect("fits")),
            Ok((node, d))
        );
        for (ids, policy, loss) in [
            (
                IdPlan::new(0x020, None, 30),
                SafePolicy::Off,
                NeighbourLoss::Any,
            ),
            (
                IdPlan::new(0x101, Some(0x780), 99),
                SafePolicy::Ramp { rate: 12.5 },
                NeighbourLoss::All,
            ),
            (
                IdPlan::new(0x101, Some(0x780), 4),
                SafePolicy::Stop { decel: 3.5 },
                NeighbourLoss::All,
            ),
            (
                IdPlan::new(0x101, None, 4),
                SafePolicy::HoldPosition,
                NeighbourLoss::Any,
            ),
        ] {
            node.ids = ids.expect("valid plan");
            node.heartbeat_period_us = (1 << 33) | 100_000;
            node.supervisor = SupervisorConfig {
                policy,
                leader_timeout_us: Some(100_000),
                neighbour_timeout_us: None,
                neighbour_loss: loss,
                sensor_timeout_us: Some(u64::MAX),
                recover_dwell_us: 50_000,
                sensor_policy: SafePolicy::Ramp { rate: 2.0 },
                reentry_rate: f32::INFINITY,
            };
            let big = ControllerConfig::<4> {
                neighbour_count: 2,
                pinned: false,
                ..ControllerConfig::default()
            };
            let w = encode_config(&node, &big);
            assert_eq!(
                decode_config::<4, 16>(w.as_slice().expect("fits")),
                Ok((node, big))
            );
        }
    }

    #[test]
    fn slcan_rejects_garbage_without_panicking() {
        for line in [
            &b""[..],
            b"x",
            b"t",
            b"t10",
            b"t1014",
            b"t1019",
            b"t80000",
            b"tG000",
            b"t1012ABC",
            b"T2000000000",
            b"r1011AA",
            b"S9",
            b"k",
            b"kAAAA",
            b"kAAAAPwAAgL8A",
            b"kAAAAPwAAgL8AAAAAAA",
            b"kAAAAP!AAgL8",
            b"y",
            b"yAAAAPwAAgL8",
        ] {
            assert!(slcan_decode(line).is_err(), "{line:?}");
        }
        assert_eq!(slcan_decode(b"O"), Ok(Slcan::Open));
        assert_eq!(slcan_decode(b"S8"), Ok(Slcan::Bitrate(8)));
        let f = CanFrame::io(io::SYNC, &pack_f32x2(1.0, -2.0)).expect("frame");
        let mut buf = [0u8; SLCAN_MAX_LINE];
        let n = slcan_encode(&f, &mut buf);
        assert_eq!(n, SLCAN_MAX_LINE - 4);
        assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Frame(f)));
        let n = slcan_encode_timed(&f, 0xBEEF, &mut buf);
        assert_eq!(n, SLCAN_MAX_LINE);
        assert_eq!(&buf[n - 5..n], b"BEEF\r");
        assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Timed(f, 0xBEEF)));
        assert!(slcan_decode(&buf[..n - 2]).is_err());
    }

    #[test]
    fn records_round_trip_and_reject_garbage() {
        let mut buf = [0u8; RECORD_MAX_LINE];
        for tick in [
            Tick {
                x: [f32::MIN_POSITIVE, -0.0],
                dt_us: Some(u32::MAX),
            },
            Tick {
                x: [f32::NAN, 1e30],
                dt_us: None,
            },
        ] {
            let n = tick_encode(&tick, &mut buf);
            assert!(n <= 18);
            let Ok(Slcan::Tick(back)) = slcan_decode(&buf[..n - 1]) else {
                panic!("{:?}", &buf[..n]);
            };
            assert_eq!(back.x.map(f32::to_bits), tick.x.map(f32::to_bits));
            assert_eq!(back.dt_us, tick.dt_us);
        }
        let report = Report {
            q: [1.0, -2.0],
            u: [3.5, f32::INFINITY],
            e: [1e-9, -1e9],
            mu: 0.25,
            xi: 7.0,
            lambda: 1.5,
            fault: 2,
            stale: 3,
            missing: 4,
            leader: 3,
            state: 2,
            instructions: 1_600,
            resolution: 40,
        };
        let n = report_encode(&report, &mut buf);
        assert_eq!(n, RECORD_MAX_LINE);
        assert_eq!(slcan_decode(&buf[..n - 1]), Ok(Slcan::Report(report)));
        assert!(slcan_decode(&buf[..n - 2]).is_err());
    }
}
