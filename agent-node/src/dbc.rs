//! Every frame kind of the bus and of the serial link, described signal by signal, and the
//! DBC file written from that description ([`write_dbc`], committed as `docs/wire.dbc`), so
//! cantools, SavvyCAN or a bus analyser decode traces without a second copy of the layout.
//!
//! * Bus, in the default identifier plan ([`IdPlan::DEFAULT`]): one value frame
//!   ([`VALUE_SIGNALS`], [`crate::wire`]) per sender, the leader and every agent of the plan,
//!   and one heartbeat ([`HEARTBEAT_SIGNALS`]) per agent; and per agent the sensor and command
//!   frames of a host that simulates the plants on the bus ([`crate::plant_bus`]) and the node's
//!   CANopen heartbeat (`0x700 + i`, its NMT state) ([`PLANT_MESSAGES`]).
//! * Link ([`crate::link`]): the process-I/O frames of [`crate::link::io`] and the payloads of the
//!   tick and report records ([`IO_MESSAGES`]). The records are not CAN frames; the DBC gives
//!   their base64-decoded payload an id ([`crate::link::io::SYNC`], [`crate::link::io::REPORT`]) so the same
//!   tools decode them.
//!
//! Signals are little-endian (Intel); a message id with bit 31 set is a 29-bit identifier, as
//! DBC writes them.

use core::fmt::{self, Write};

use crate::{
    link::io,
    wire::{IdPlan, Source, HEARTBEAT_LEN, PAYLOAD_LEN},
};

/// How a signal's raw bits become a value.
///
/// ```
/// use agent_node::dbc::{Encoding, VALUE_SIGNALS};
/// use agent_node::wire::encode_payload;
/// // The value frame's `y` is Q7.16: a scaled two's complement signal of resolution 2^-16.
/// let y = &VALUE_SIGNALS[0];
/// assert!(matches!(y.encoding, Encoding::Scaled { factor, .. } if factor == 1.0 / 65536.0));
/// assert_eq!(y.value(&encode_payload(-0.5, 0).data), Some(-0.5));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Encoding {
    /// An unsigned integer.
    Unsigned,
    /// An IEEE 754 `f32` (32 bits).
    Float,
    /// A two's complement integer times `factor`, within `[min, max]`.
    Scaled {
        /// Value of one raw count.
        factor: f64,
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
    },
}

/// One signal of a message.
///
/// ```
/// use agent_node::dbc::VALUE_SIGNALS;
/// use agent_node::wire::encode_payload;
/// // Decode agent 3's value frame signal by signal, as cantools does with docs/wire.dbc.
/// let data = encode_payload(0.25, 7).data;
/// let get = |name| VALUE_SIGNALS.iter().find(|s| s.name == name).unwrap().value(&data);
/// assert_eq!((get("y"), get("seq")), (Some(0.25), Some(7.0)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signal {
    /// DBC name.
    pub name: &'static str,
    /// First bit (bit 0 is the least significant bit of byte 0).
    pub start: u16,
    /// Bits.
    pub len: u16,
    /// How the bits are read.
    pub encoding: Encoding,
    /// Largest value of an [`Encoding::Unsigned`] signal that has a documented range (flags,
    /// counters); `None`: the full width.
    pub max: Option<u32>,
    /// What it means, for `CM_ SG_` (written once, on the leader's message, for value frames).
    pub comment: Option<&'static str>,
}

impl Signal {
    const fn unsigned(name: &'static str, start: u16, len: u16) -> Self {
        Self {
            name,
            start,
            len,
            encoding: Encoding::Unsigned,
            max: None,
            comment: None,
        }
    }

    const fn float(name: &'static str, start: u16) -> Self {
        Self {
            name,
            start,
            len: 32,
            encoding: Encoding::Float,
            max: None,
            comment: None,
        }
    }

    /// The raw bits of this signal in `data` (little-endian); `None` when `data` is too short.
    ///
    /// ```
    /// use agent_node::dbc::{HEARTBEAT_SIGNALS};
    /// // The heartbeat's first byte is the node's state code (2: safe).
    /// let state = HEARTBEAT_SIGNALS.iter().find(|s| s.name == "state").unwrap();
    /// assert_eq!(state.raw(&[2, 0, 0, 0, 0, 0, 0, 0]), Some(2));
    /// assert_eq!(state.raw(&[]), None); // too short
    /// ```
    #[must_use]
    pub fn raw(&self, data: &[u8]) -> Option<u64> {
        (0..self.len).rev().try_fold(0u64, |v, k| {
            let bit = usize::from(self.start + k);
            let byte = data.get(bit / 8)?;
            Some((v << 1) | u64::from((byte >> (bit % 8)) & 1))
        })
    }

    /// The value of this signal in `data`: raw count, `f32`, or scaled two's complement.
    ///
    /// ```
    /// use agent_node::dbc::PLANT_MESSAGES;
    /// use agent_node::link::pack_f32x2;
    /// // A sensor frame of the plant bus carries x_1, x_2 as f32.
    /// let sensor = &PLANT_MESSAGES[0];
    /// let data = pack_f32x2(0.5, -1.5);
    /// let x: Vec<_> = sensor.signals.iter().map(|s| s.value(&data)).collect();
    /// assert_eq!(x, [Some(0.5), Some(-1.5)]);
    /// ```
    #[must_use]
    pub fn value(&self, data: &[u8]) -> Option<f64> {
        let raw = self.raw(data)?;
        Some(match self.encoding {
            Encoding::Unsigned => raw as f64,
            Encoding::Float => f64::from(f32::from_bits(raw as u32)),
            Encoding::Scaled { factor, .. } => {
                let shift = 64 - u32::from(self.len);
                (((raw << shift) as i64) >> shift) as f64 * factor
            }
        })
    }
}

/// One message kind of the link.
///
/// ```
/// use agent_node::dbc::io_message;
/// use agent_node::link::io;
/// let boot = io_message(io::BOOT).unwrap();
/// assert_eq!((boot.name, boot.sender, boot.len()), ("Boot", "Node", 1));
/// assert_eq!(boot.signals[0].value(&[3]), Some(3.0)); // the link protocol's version
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Message {
    /// DBC name.
    pub name: &'static str,
    /// The 29-bit identifier (a process-I/O frame, or the id a record's payload is given).
    pub id: u32,
    /// Who sends it: `Host` or `Node`.
    pub sender: &'static str,
    /// Signals, by start bit.
    pub signals: &'static [Signal],
    /// What it is, for `CM_ BO_`.
    pub comment: Option<&'static str>,
}

impl Message {
    /// Payload bytes: up to the last bit of the last signal.
    ///
    /// ```
    /// use agent_node::dbc::{io_message, PLANT_MESSAGES};
    /// use agent_node::link::{io, REPORT_BYTES};
    /// assert_eq!(PLANT_MESSAGES[0].len(), 8); // x_1, x_2 as f32
    /// assert_eq!(usize::from(io_message(io::REPORT).unwrap().len()), REPORT_BYTES);
    /// ```
    #[must_use]
    pub fn len(&self) -> u16 {
        self.signals
            .iter()
            .map(|s| (s.start + s.len).div_ceil(8))
            .max()
            .unwrap_or(0)
    }

    /// No signals (a request without data).
    ///
    /// ```
    /// use agent_node::dbc::io_message;
    /// use agent_node::link::io;
    /// assert!(io_message(io::STATS_REQUEST).unwrap().is_empty()); // a request without data
    /// assert!(!io_message(io::STATS).unwrap().is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.signals.is_empty()
    }
}

/// The signals of every value frame (leader and agents): payload of [`crate::wire`].
pub const VALUE_SIGNALS: [Signal; 4] = [
    Signal {
        name: "y",
        start: 0,
        len: 24,
        encoding: Encoding::Scaled {
            factor: 1.0 / 65536.0,
            min: -128.0,
            max: 128.0 - 1.0 / 65536.0,
        },
        max: None,
        comment: Some("Q7.16 value, resolution 2^-16; 0 when no_value"),
    },
    Signal {
        name: "seq",
        start: 24,
        len: 6,
        encoding: Encoding::Unsigned,
        max: Some(63),
        comment: Some("sender's sample count modulo 64"),
    },
    Signal {
        name: "saturated",
        start: 30,
        len: 1,
        encoding: Encoding::Unsigned,
        max: Some(1),
        comment: Some("y was outside [-128, 128) and clamped"),
    },
    Signal {
        name: "no_value",
        start: 31,
        len: 1,
        encoding: Encoding::Unsigned,
        max: Some(1),
        comment: Some("the sender had no finite value"),
    },
];

/// Comment of the leader's value frame.
const LEADER_COMMENT: &str = "Leader reference y_d, one frame per sample";

/// The signals of every heartbeat: [`crate::wire::Heartbeat`].
pub const HEARTBEAT_SIGNALS: [Signal; 8] = [
    Signal {
        name: "state",
        start: 0,
        len: 8,
        encoding: Encoding::Unsigned,
        max: Some(3),
        comment: Some("0 operational, 1 boot, 2 safe, 3 fault"),
    },
    Signal {
        name: "lost_leader",
        start: 8,
        len: 1,
        encoding: Encoding::Unsigned,
        max: Some(1),
        comment: Some("the leader is lost (silent beyond its timeout)"),
    },
    Signal {
        name: "lost_neighbours",
        start: 9,
        len: 1,
        encoding: Encoding::Unsigned,
        max: Some(1),
        comment: Some("the neighbours are lost (all or any, as configured)"),
    },
    Signal {
        name: "lost_sensor",
        start: 10,
        len: 1,
        encoding: Encoding::Unsigned,
        max: Some(1),
        comment: Some("the sensor is lost (invalid beyond its timeout)"),
    },
    Signal {
        name: "reserved",
        start: 11,
        len: 5,
        encoding: Encoding::Unsigned,
        max: Some(0),
        comment: None,
    },
    Signal {
        name: "boot_count",
        start: 16,
        len: 16,
        encoding: Encoding::Unsigned,
        max: None,
        comment: Some("resets or boots counted by the board, 0 if none"),
    },
    Signal {
        name: "overruns",
        start: 32,
        len: 16,
        encoding: Encoding::Unsigned,
        max: None,
        comment: Some("deadline overruns since start, saturating"),
    },
    Signal {
        name: "safe_entries",
        start: 48,
        len: 16,
        encoding: Encoding::Unsigned,
        max: None,
        comment: Some("safe-state entries since start, saturating"),
    },
];

/// Comment of the heartbeats.
const HEARTBEAT_COMMENT: &str =
    "Node heartbeat: state, lost sources and counters, once per heartbeat period";

/// The messages of the serial link, in the order of a run: start-up, samples, statistics.
pub const IO_MESSAGES: [Message; 14] = [
    Message {
        name: "Boot",
        id: io::BOOT,
        sender: "Node",
        signals: &[Signal::unsigned("protocol", 0, 8)],
        comment: Some(
            "PIL link: the firmware started (power-on or watchdog reset) and waits for its configuration; the link protocol version",
        ),
    },
    Message {
        name: "Config",
        id: io::CONFIG,
        sender: "Host",
        signals: &[
            Signal::unsigned("word1", 0, 32),
            Signal::unsigned("word2", 32, 32),
        ],
        comment: Some(
            "PIL link start-up: one or two configuration words in order (4 bytes for the last one of an odd count)",
        ),
    },
    Message {
        name: "ConfigEnd",
        id: io::CONFIG_END,
        sender: "Host",
        signals: &[Signal::unsigned("words", 0, 16)],
        comment: Some("PIL link start-up: end of the configuration, its word count"),
    },
    Message {
        name: "Ready",
        id: io::READY,
        sender: "Node",
        signals: &[Signal::unsigned("agent", 0, 8)],
        comment: Some("PIL link start-up: configuration accepted by this agent"),
    },
    Message {
        name: "Rejected",
        id: io::REJECTED,
        sender: "Node",
        signals: &[Signal::unsigned("code", 0, 8)],
        comment: Some(
            "PIL link start-up: configuration rejected; 1 word count, 2 bad tag, 3 refused by the node, 4 unexpected frame",
        ),
    },
    Message {
        name: "Sync",
        id: io::SYNC,
        sender: "Host",
        signals: &[
            Signal::float("x1", 0),
            Signal::float("x2", 32),
            Signal::unsigned("dt_us", 64, 32),
        ],
        comment: Some(
            "PIL link only (docs/NETWORK.md 9): payload of the k (tick) record, base64 on the link, not a CAN frame; dt_us only when the interval changed (8 bytes otherwise)",
        ),
    },
    Message {
        name: "Clock",
        id: io::CLOCK,
        sender: "Host",
        signals: &[Signal::unsigned("t_us", 0, 32)],
        comment: Some(
            "PIL link: the clock (low 32 bits, us) before a bus frame delivered 2^16 us or more after the previous tick",
        ),
    },
    Message {
        name: "Report",
        id: io::REPORT,
        sender: "Node",
        signals: &[
            Signal::float("q1", 0),
            Signal::float("q2", 32),
            Signal::float("u1", 64),
            Signal::float("u2", 96),
            Signal::float("e1", 128),
            Signal::float("e2", 160),
            Signal::float("mu", 192),
            Signal::float("xi", 224),
            Signal::float("lambda", 256),
            Signal::unsigned("fault", 288, 8),
            Signal::unsigned("stale", 296, 8),
            Signal::unsigned("missing", 304, 8),
            Signal::unsigned("leader_stale", 312, 1),
            Signal::unsigned("leader_missing", 313, 1),
            Signal::unsigned("state", 316, 2),
            Signal::unsigned("instructions", 320, 32),
            Signal::unsigned("resolution", 352, 32),
        ],
        comment: Some(
            "PIL link only (docs/NETWORK.md 9): payload of the y (report) record, base64 on the link, not a CAN frame",
        ),
    },
    Message {
        name: "StatsRequest",
        id: io::STATS_REQUEST,
        sender: "Host",
        signals: &[],
        comment: Some("PIL link, end of a run: ask the node for its statistics"),
    },
    Message {
        name: "Stats",
        id: io::STATS,
        sender: "Node",
        signals: &[
            Signal::unsigned("stack_bytes", 0, 32),
            Signal::unsigned("malformed", 32, 32),
        ],
        comment: Some("PIL link, end of a run: stack high-water mark and malformed bus frames"),
    },
    Message {
        name: "Hang",
        id: io::HANG,
        sender: "Host",
        signals: &[],
        comment: Some(
            "PIL link, network.event kind = hang: the control task stops at the next tick; only the watchdog brings the node back",
        ),
    },
    Message {
        name: "Overrun",
        id: io::OVERRUN,
        sender: "Node",
        signals: &[Signal::unsigned("overruns", 0, 32)],
        comment: Some(
            "PIL link: the sample timer released the control task while its previous step still ran; overruns since boot",
        ),
    },
    Message {
        name: "Slow",
        id: io::SLOW,
        sender: "Host",
        signals: &[Signal::unsigned("periods_q16", 0, 32)],
        comment: Some(
            "PIL link, network.event kind = slow: from the next tick each control step takes periods_q16 / 65536 sample periods; 0 ends it",
        ),
    },
    Message {
        name: "Watchdog",
        id: io::WATCHDOG,
        sender: "Host",
        signals: &[Signal::unsigned("late_periods", 0, 32)],
        comment: Some(
            "PIL link, start-up before ConfigEnd (node.watchdog_periods): reset after this many periods (and a half) without a step that met its deadline; 0 no watchdog",
        ),
    },
];

/// The per-agent frames of a bench: the sensor and command frames of [`crate::plant_bus`] and
/// the node's CANopen heartbeat, one message per agent each (`name` is followed by the agent
/// number; `sender` `Agent` means that agent's node).
pub const PLANT_MESSAGES: [Message; 3] = [
    Message {
        name: "Sensor",
        id: crate::plant_bus::SENSOR_BASE as u32,
        sender: "Host",
        signals: &[Signal::float("x1", 0), Signal::float("x2", 32)],
        comment: Some("Plant on the bus: the agent's state x_i at the host's sample"),
    },
    Message {
        name: "Command",
        id: crate::plant_bus::COMMAND_BASE as u32,
        sender: "Agent",
        signals: &[Signal::float("q1", 0), Signal::float("q2", 32)],
        comment: Some("Plant on the bus: the node's quantized commands q_i, one per node sample"),
    },
    Message {
        name: "NmtHeartbeat",
        id: crate::canopen::heartbeat_id(0) as u32,
        sender: "Agent",
        signals: &[Signal {
            comment: Some(
                "CiA 301 NMT state: 0 boot-up, 4 stopped, 5 operational, 127 pre-operational",
            ),
            ..Signal::unsigned("nmt_state", 0, 8)
        }],
        comment: Some(
            "The node's CANopen heartbeat (node-ID = agent), every 0x1017 ms: its state on the bench",
        ),
    },
];

fn write_plant_message(out: &mut impl Write, m: &Message, agent: u8) -> fmt::Result {
    let id = m.id + u32::from(agent);
    write!(out, "BO_ {id} {}{agent}: {} ", m.name, m.len())?;
    match m.sender {
        "Agent" => writeln!(out, "Agent{agent}")?,
        other => writeln!(out, "{other}")?,
    }
    for s in m.signals {
        write_signal(out, s)?;
    }
    out.write_char('\n')
}

/// A DBC message id of a 29-bit identifier (bit 31 set).
const EXTENDED: u32 = 0x8000_0000;

fn write_signal(out: &mut impl Write, s: &Signal) -> fmt::Result {
    let sign = if matches!(s.encoding, Encoding::Unsigned) {
        '+'
    } else {
        '-'
    };
    write!(out, " SG_ {} : {}|{}@1{sign} ", s.name, s.start, s.len)?;
    match (s.encoding, s.max) {
        (Encoding::Scaled { factor, min, max }, _) => write!(out, "({factor},0) [{min}|{max}]")?,
        (_, Some(max)) => write!(out, "(1,0) [0|{max}]")?,
        (_, None) => out.write_str("(1,0) [0|0]")?,
    }
    out.write_str(" \"\" Vector__XXX\n")
}

fn write_value_message(out: &mut impl Write, source: Source, id: u16) -> fmt::Result {
    match source {
        Source::Leader => writeln!(out, "BO_ {id} Leader: {PAYLOAD_LEN} Leader")?,
        Source::Agent(i) => writeln!(out, "BO_ {id} Agent{i}: {PAYLOAD_LEN} Agent{i}")?,
    }
    for s in &VALUE_SIGNALS {
        write_signal(out, s)?;
    }
    out.write_char('\n')
}

/// `docs/wire.dbc`: nodes, every value frame and heartbeat of the default identifier plan, the
/// plant-bus frames of every agent of the plan, every link message, comments, and the `f32`
/// signal types, in that order.
///
/// ```
/// use agent_node::dbc::write_dbc;
/// let mut dbc = String::new();
/// write_dbc(&mut dbc).unwrap();
/// assert!(dbc.starts_with("VERSION"));
/// assert!(dbc.contains("BO_ 257 Leader: 4 Leader")); // 0x101, the leader's value frame
/// assert!(dbc.contains("SG_ y "));
/// ```
pub fn write_dbc(out: &mut impl Write) -> fmt::Result {
    let plan = IdPlan::DEFAULT;
    out.write_str("VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: Host Node Leader")?;
    for i in 1..=plan.agents() {
        write!(out, " Agent{i}")?;
    }
    out.write_str("\n\n")?;
    let senders = core::iter::once(Source::Leader).chain((1..=plan.agents()).map(Source::Agent));
    for source in senders {
        if let Some(id) = plan.value_id(source) {
            write_value_message(out, source, id)?;
        }
    }
    for i in 1..=plan.agents() {
        if let Some(id) = plan.heartbeat_id(i) {
            writeln!(out, "BO_ {id} Heartbeat{i}: {HEARTBEAT_LEN} Agent{i}")?;
            for s in &HEARTBEAT_SIGNALS {
                write_signal(out, s)?;
            }
            out.write_char('\n')?;
        }
    }
    for m in &PLANT_MESSAGES {
        for agent in 1..=plan.agents() {
            write_plant_message(out, m, agent)?;
        }
    }
    for m in &IO_MESSAGES {
        writeln!(
            out,
            "BO_ {} {}: {} {}",
            m.id | EXTENDED,
            m.name,
            m.len(),
            m.sender
        )?;
        for s in m.signals {
            write_signal(out, s)?;
        }
        out.write_char('\n')?;
    }
    let leader = plan.value_base();
    writeln!(out, "CM_ BO_ {leader} \"{LEADER_COMMENT}\";")?;
    for s in &VALUE_SIGNALS {
        if let Some(c) = s.comment {
            writeln!(out, "CM_ SG_ {leader} {} \"{c}\";", s.name)?;
        }
    }
    if let Some(hb) = plan.heartbeat_id(1) {
        writeln!(out, "CM_ BO_ {hb} \"{HEARTBEAT_COMMENT}\";")?;
        for s in &HEARTBEAT_SIGNALS {
            if let Some(c) = s.comment {
                writeln!(out, "CM_ SG_ {hb} {} \"{c}\";", s.name)?;
            }
        }
    }
    for m in &PLANT_MESSAGES {
        let first = m.id + 1;
        if let Some(c) = m.comment {
            writeln!(out, "CM_ BO_ {first} \"{c}\";")?;
        }
        for s in m.signals {
            if let Some(c) = s.comment {
                writeln!(out, "CM_ SG_ {first} {} \"{c}\";", s.name)?;
            }
        }
    }
    for m in &IO_MESSAGES {
        if let Some(c) = m.comment {
            writeln!(out, "CM_ BO_ {} \"{c}\";", m.id | EXTENDED)?;
        }
    }
    for m in &PLANT_MESSAGES {
        for agent in 1..=plan.agents() {
            for s in m.signals.iter().filter(|s| s.encoding == Encoding::Float) {
                writeln!(
                    out,
                    "SIG_VALTYPE_ {} {} : 1;",
                    m.id + u32::from(agent),
                    s.name
                )?;
            }
        }
    }
    for m in &IO_MESSAGES {
        for s in m.signals.iter().filter(|s| s.encoding == Encoding::Float) {
            writeln!(out, "SIG_VALTYPE_ {} {} : 1;", m.id | EXTENDED, s.name)?;
        }
    }
    Ok(())
}

/// The link message of a 29-bit identifier.
///
/// ```
/// use agent_node::dbc::io_message;
/// use agent_node::link::io;
/// assert_eq!(io_message(io::READY).map(|m| m.name), Some("Ready"));
/// assert!(io_message(0x7FF).is_none()); // a bus identifier, not a link message
/// ```
#[must_use]
pub fn io_message(id: u32) -> Option<&'static Message> {
    IO_MESSAGES.iter().find(|m| m.id == id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{
        link::{Report, Tick},
        wire::encode_payload,
    };

    fn value_of(m: &Message, name: &str, data: &[u8]) -> f64 {
        m.signals
            .iter()
            .find(|s| s.name == name)
            .and_then(|s| s.value(data))
            .unwrap_or(f64::NAN)
    }

    #[test]
    fn value_signals_read_what_the_codec_wrote() {
        let m = Message {
            name: "value",
            id: 0,
            sender: "",
            signals: &VALUE_SIGNALS,
            comment: None,
        };
        for (y, seq) in [(0.5f32, 3u8), (-1.25, 63), (-127.5, 0), (1000.0, 7)] {
            let e = encode_payload(y, seq);
            let back = crate::wire::decode_payload(Source::Leader, &e.data).expect("valid");
            assert_eq!(
                value_of(&m, "y", &e.data),
                f64::from(back.y.expect("value"))
            );
            assert_eq!(value_of(&m, "seq", &e.data), f64::from(seq % 64));
            assert_eq!(
                value_of(&m, "saturated", &e.data),
                f64::from(u8::from(e.saturated))
            );
            assert_eq!(value_of(&m, "no_value", &e.data), 0.0);
        }
        let e = encode_payload(f32::NAN, 1);
        assert_eq!(value_of(&m, "no_value", &e.data), 1.0);
        assert_eq!(usize::from(m.len()), PAYLOAD_LEN);
    }

    #[test]
    fn record_signals_read_what_the_codec_wrote() {
        let r = Report {
            q: [1.5, -2.0],
            u: [3.25, 4.0],
            e: [-5.0, 6.5],
            mu: 0.25,
            xi: 7.0,
            lambda: 1.5,
            fault: 2,
            stale: 3,
            missing: 4,
            leader: 2,
            state: 2,
            instructions: 1_600,
            resolution: 40,
        };
        let m = io_message(io::REPORT).expect("described");
        let b = r.to_bytes();
        assert_eq!(usize::from(m.len()), b.len());
        let want = [
            ("q1", 1.5),
            ("q2", -2.0),
            ("u1", 3.25),
            ("u2", 4.0),
            ("e1", -5.0),
            ("e2", 6.5),
            ("mu", 0.25),
            ("xi", 7.0),
            ("lambda", 1.5),
            ("fault", 2.0),
            ("stale", 3.0),
            ("missing", 4.0),
            ("leader_stale", 0.0),
            ("leader_missing", 1.0),
            ("state", 2.0),
            ("instructions", 1600.0),
            ("resolution", 40.0),
        ];
        for (name, v) in want {
            assert_eq!(value_of(m, name, &b), v, "{name}");
        }
        let t = Tick {
            x: [0.5, -1.0],
            dt_us: Some(1000),
        };
        let (b, n) = t.to_bytes();
        let m = io_message(io::SYNC).expect("described");
        assert_eq!(usize::from(m.len()), n);
        assert_eq!(value_of(m, "x1", &b), 0.5);
        assert_eq!(value_of(m, "x2", &b), -1.0);
        assert_eq!(value_of(m, "dt_us", &b), 1000.0);
    }

    #[test]
    fn heartbeat_signals_read_what_the_codec_wrote() {
        use crate::supervisor::{Lost, NodeState};
        let hb = crate::wire::Heartbeat {
            state: NodeState::Safe,
            lost: Lost::from_bits(Lost::NEIGHBOURS | Lost::SENSOR),
            boot_count: 3,
            overruns: 40_000,
            safe_entries: 12,
        };
        let m = Message {
            name: "hb",
            id: 0,
            sender: "",
            signals: &HEARTBEAT_SIGNALS,
            comment: None,
        };
        let b = hb.to_bytes();
        assert_eq!(usize::from(m.len()), HEARTBEAT_LEN);
        for (name, v) in [
            ("state", 2.0),
            ("lost_leader", 0.0),
            ("lost_neighbours", 1.0),
            ("lost_sensor", 1.0),
            ("reserved", 0.0),
            ("boot_count", 3.0),
            ("overruns", 40_000.0),
            ("safe_entries", 12.0),
        ] {
            assert_eq!(value_of(&m, name, &b), v, "{name}");
        }
    }

    #[test]
    fn every_io_id_is_described_once() {
        let ids = [
            io::BOOT,
            io::CONFIG,
            io::CONFIG_END,
            io::READY,
            io::REJECTED,
            io::SYNC,
            io::CLOCK,
            io::REPORT,
            io::STATS_REQUEST,
            io::STATS,
            io::HANG,
            io::OVERRUN,
            io::SLOW,
            io::WATCHDOG,
        ];
        for id in ids {
            assert_eq!(
                IO_MESSAGES.iter().filter(|m| m.id == id).count(),
                1,
                "{id:#x}"
            );
        }
        assert_eq!(ids.len(), IO_MESSAGES.len());
    }
}
