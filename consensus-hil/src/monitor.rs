//! `host-sim monitor <interface>`: a live table of a bus running the product — per agent its
//! value `y_i`, state `x_i` and commands `q_i` as last seen, frame rates, its NMT state (CANopen
//! heartbeat `0x700 + i`), its supervisor's status (the status PDO at `0x780 + i` of the default
//! identifier plan: state, lost sources, overruns, safe-state entries), and the bus's error
//! frames (error-passive, bus-off, …).
//!
//! Frames are decoded with the product's own codec (`agent_node::wire` for value frames and
//! status PDOs, `agent_node::plant_bus`, and `agent_node::canopen::decode` for NMT, SYNC, EMCY,
//! SDO and heartbeats: per node-ID its NMT state, boot-ups, last EMCY, SDO requests, answers
//! and aborts); with `--dbc`, every other frame whose identifier the DBC file describes is shown
//! with its decoded signals (little-endian signals, `SIG_VALTYPE_` floats).

use std::{
    collections::BTreeMap,
    fmt::Write as _,
    io::Write,
    path::Path,
    time::{Duration, Instant},
};

use agent_node::{
    canopen::{self, Message, NmtState},
    plant_bus::{self, PlantFrame},
    wire::{self, Decoded, Heartbeat, IdPlan, Source},
};
use embedded_can::{Frame, Id};
use socketcan::{CanAnyFrame, CanFdSocket, Socket, SocketOptions};

use consensus_plot::error::{Error, Result};

/// What `monitor` shows and for how long.
#[derive(Debug, Clone)]
pub struct MonitorOptions {
    /// The CAN interface.
    pub interface: String,
    /// A DBC file decoding the frames the codec does not know.
    pub dbc: Option<std::path::PathBuf>,
    /// Print one table after `duration` (default 1 s) and stop.
    pub once: bool,
    /// Stop after this long \[s\]; absent: until Ctrl-C (or 1 s with `once`).
    pub duration: Option<f64>,
    /// Seconds between two tables of the live view.
    pub refresh: f64,
}

/// What was last seen of one agent.
#[derive(Debug, Clone, Default)]
struct AgentRow {
    y: Option<f32>,
    x: Option<[f32; 2]>,
    q: Option<[f32; 2]>,
    /// The last status PDO.
    status: Option<Heartbeat>,
    values: u64,
    sensors: u64,
    commands: u64,
    statuses: u64,
    last: Option<Instant>,
}

/// Everything seen on the bus.
#[derive(Debug, Default)]
struct View {
    leader: Option<f32>,
    leader_frames: u64,
    agents: BTreeMap<u8, AgentRow>,
    other: BTreeMap<u32, (u64, Vec<u8>)>,
    errors: BTreeMap<String, u64>,
    frames: u64,
    canopen: CanOpenView,
}

/// What was seen of the CANopen devices (docs/NETWORK.md §12).
#[derive(Debug, Default)]
struct CanOpenView {
    /// Per node-ID.
    nodes: BTreeMap<u8, CanOpenRow>,
    /// The last NMT commands, newest last.
    nmt: Vec<String>,
    syncs: u64,
}

/// One CANopen device.
#[derive(Debug, Default)]
struct CanOpenRow {
    state: Option<NmtState>,
    boot_ups: u64,
    emcys: u64,
    /// Last EMCY: code, register, cause byte.
    last_emcy: Option<(u16, u8, u8)>,
    sdo_requests: u64,
    sdo_answers: u64,
    /// Aborts: count, the last one's code, index, sub-index.
    aborts: u64,
    last_abort: Option<(u32, u16, u8)>,
}

impl CanOpenView {
    fn take(&mut self, m: Message) {
        match m {
            Message::Nmt { command, node } => {
                let what = command.map_or("unknown command", |c| match c {
                    canopen::NmtCommand::Start => "start",
                    canopen::NmtCommand::Stop => "stop",
                    canopen::NmtCommand::EnterPreOperational => "enter pre-operational",
                    canopen::NmtCommand::ResetNode => "reset node",
                    canopen::NmtCommand::ResetCommunication => "reset communication",
                });
                let to = if node == 0 {
                    "all".to_owned()
                } else {
                    format!("node {node}")
                };
                self.nmt.push(format!("{what} {to}"));
                if self.nmt.len() > 4 {
                    self.nmt.remove(0);
                }
            }
            Message::Sync => self.syncs += 1,
            Message::Emcy {
                node,
                code,
                register,
                info,
            } => {
                let r = self.nodes.entry(node).or_default();
                r.emcys += 1;
                r.last_emcy = Some((code, register, info[0]));
            }
            Message::Sdo {
                node,
                request,
                index,
                sub,
                abort,
                ..
            } => {
                let r = self.nodes.entry(node).or_default();
                if request {
                    r.sdo_requests += 1;
                } else {
                    r.sdo_answers += 1;
                }
                if let Some(code) = abort {
                    r.aborts += 1;
                    r.last_abort = Some((code, index, sub));
                }
            }
            Message::Heartbeat { node, state } => {
                let r = self.nodes.entry(node).or_default();
                if state == Some(NmtState::Initialising) {
                    r.boot_ups += 1;
                }
                r.state = state;
            }
        }
    }

    fn lines(&self, s: &mut String) {
        for (id, r) in &self.nodes {
            let state = r.state.map_or("-", NmtState::name);
            let emcy = r.last_emcy.map_or_else(
                || "none".to_owned(),
                |(c, reg, cause)| format!("{c:#06x} (register {reg:#04x}, cause {cause})"),
            );
            let abort = r.last_abort.map_or_else(String::new, |(c, i, sub)| {
                format!(", last abort {c:#010x} at {i:#06x}/{sub}")
            });
            let _ = writeln!(
                s,
                "canopen node {id}: NMT {state}, {} boot-up(s); EMCY {} (last {emcy}); SDO {} requests, {} answers, {} aborts{abort}",
                r.boot_ups, r.emcys, r.sdo_requests, r.sdo_answers, r.aborts
            );
        }
        if !self.nmt.is_empty() || self.syncs > 0 {
            let _ = writeln!(
                s,
                "canopen NMT: {}; SYNC: {}",
                if self.nmt.is_empty() {
                    "none".to_owned()
                } else {
                    self.nmt.join(", ")
                },
                self.syncs
            );
        }
    }
}

impl View {
    fn take(&mut self, f: &CanAnyFrame, now: Instant) {
        if let CanAnyFrame::Error(e) = f {
            *self
                .errors
                .entry(format!("{}", (*e).into_error()))
                .or_default() += 1;
            return;
        }
        self.frames += 1;
        match wire::decode_in(&IdPlan::DEFAULT, f) {
            Ok(Decoded::Value(m)) => {
                match m.source {
                    Source::Leader => {
                        self.leader = m.y;
                        self.leader_frames += 1;
                    }
                    Source::Agent(i) => {
                        let a = self.agents.entry(i).or_default();
                        a.y = m.y;
                        a.values += 1;
                        a.last = Some(now);
                    }
                }
                return;
            }
            Ok(Decoded::Heartbeat { agent, heartbeat }) => {
                let a = self.agents.entry(agent).or_default();
                a.status = Some(heartbeat);
                a.statuses += 1;
                a.last = Some(now);
                return;
            }
            Err(_) => {}
        }
        fn row(v: &mut View, i: u8, now: Instant) -> &mut AgentRow {
            let a = v.agents.entry(i).or_default();
            a.last = Some(now);
            a
        }
        match plant_bus::decode(f) {
            Some(PlantFrame::Sensor(i, x)) => {
                let a = row(self, i, now);
                a.x = Some(x);
                a.sensors += 1;
            }
            Some(PlantFrame::Command(i, q)) => {
                let a = row(self, i, now);
                a.q = Some(q);
                a.commands += 1;
            }
            None => {
                if let Id::Standard(sid) = f.id() {
                    if let Some(m) = canopen::decode(sid.as_raw(), f.data()) {
                        self.canopen.take(m);
                        return;
                    }
                }
                let id = match f.id() {
                    Id::Standard(s) => u32::from(s.as_raw()),
                    Id::Extended(e) => e.as_raw() | 0x8000_0000,
                };
                let e = self.other.entry(id).or_default();
                e.0 += 1;
                e.1 = f.data().to_vec();
            }
        }
    }

    /// The table; rates over `window` seconds against the counts of `before`.
    fn table(&self, before: &Snapshot, window: f64, iface: &str, dbc: Option<&Dbc>) -> String {
        let rate = |now: u64, then: u64| (now.saturating_sub(then)) as f64 / window.max(1e-9);
        let num = |v: Option<f32>| v.map_or_else(|| "-".into(), |v| format!("{v:+.4}"));
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{iface}: {:.0} frames/s; leader y_d = {} ({:.0}/s)",
            rate(self.frames, before.frames),
            num(self.leader),
            rate(self.leader_frames, before.leader_frames)
        );
        let _ = writeln!(
            s,
            "agent  y         x1        x2        q1        q2        y/s   x/s   q/s   NMT              state        lost  overruns  silent"
        );
        for (i, a) in &self.agents {
            let b = before.agents.get(i).copied().unwrap_or_default();
            let (x1, x2) = (num(a.x.map(|x| x[0])), num(a.x.map(|x| x[1])));
            let (q1, q2) = (num(a.q.map(|q| q[0])), num(a.q.map(|q| q[1])));
            let nmt = self
                .canopen
                .nodes
                .get(i)
                .and_then(|r| r.state)
                .map_or("-", NmtState::name);
            let state = a.status.map_or("-", |h| h.state.as_str());
            let lost = a
                .status
                .map_or_else(|| "-".into(), |h| format!("{:#x}", h.lost.bits()));
            let late = a
                .status
                .map_or_else(|| "-".into(), |h| h.overruns.to_string());
            let silent = a.last.map_or_else(
                || "-".into(),
                |t| format!("{:.2}s", t.elapsed().as_secs_f64()),
            );
            let _ = writeln!(
                s,
                "{i:<6} {:<9} {x1:<9} {x2:<9} {q1:<9} {q2:<9} {:<5.0} {:<5.0} {:<5.0} {nmt:<16} {state:<12} {lost:<5} {late:<9} {silent}",
                num(a.y),
                rate(a.values, b.0),
                rate(a.sensors, b.1),
                rate(a.commands, b.2),
            );
        }
        self.canopen.lines(&mut s);
        if self.errors.is_empty() {
            let _ = writeln!(s, "error frames: none");
        } else {
            for (e, n) in &self.errors {
                let _ = writeln!(s, "error frames: {n} × {e}");
            }
        }
        for (id, (n, data)) in &self.other {
            let name = dbc.and_then(|d| d.describe(*id, data));
            let _ = writeln!(
                s,
                "other {:#x}: {n} frames{}",
                id & 0x1FFF_FFFF,
                name.map_or_else(String::new, |d| format!(", {d}"))
            );
        }
        s
    }

    fn snapshot(&self) -> Snapshot {
        Snapshot {
            frames: self.frames,
            leader_frames: self.leader_frames,
            agents: self
                .agents
                .iter()
                .map(|(i, a)| (*i, (a.values, a.sensors, a.commands)))
                .collect(),
        }
    }
}

/// Counters at the start of a rate window.
#[derive(Debug, Default)]
struct Snapshot {
    frames: u64,
    leader_frames: u64,
    agents: BTreeMap<u8, (u64, u64, u64)>,
}

/// One DBC message: name and signals (`name`, start bit, length, signed, factor, float).
#[derive(Debug, Clone)]
struct DbcMessage {
    name: String,
    signals: Vec<(String, u32, u32, bool, f64, bool)>,
}

/// The messages of a DBC file, by DBC id (bit 31 set for 29-bit identifiers).
#[derive(Debug, Default)]
struct Dbc(BTreeMap<u32, DbcMessage>);

impl Dbc {
    fn load(path: &Path) -> Result<Self> {
        // A DBC that cannot be read is bad input, as a scenario file is for `run` (exit 2).
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::invalid("--dbc", format!("{}: {e}", path.display())))?;
        let mut d = Dbc::default();
        let mut current: Option<u32> = None;
        for (n, line) in text.lines().enumerate() {
            let bad = || {
                Error::invalid(
                    "--dbc",
                    format!("{}:{}: cannot read `{line}`", path.display(), n + 1),
                )
            };
            let t = line.trim();
            if let Some(rest) = t.strip_prefix("BO_ ") {
                let mut w = rest.split_whitespace();
                let id: u32 = w.next().and_then(|v| v.parse().ok()).ok_or_else(bad)?;
                let name = w.next().ok_or_else(bad)?.trim_end_matches(':').to_owned();
                d.0.insert(
                    id,
                    DbcMessage {
                        name,
                        signals: Vec::new(),
                    },
                );
                current = Some(id);
            } else if let Some(rest) = t.strip_prefix("SG_ ") {
                let (name, spec) = rest.split_once(':').ok_or_else(bad)?;
                let spec = spec.trim();
                let (bits, rest) = spec.split_once('@').ok_or_else(bad)?;
                let (start, len) = bits.split_once('|').ok_or_else(bad)?;
                let signed = rest.get(1..2) == Some("-");
                let factor = rest
                    .split_once('(')
                    .and_then(|(_, r)| r.split_once(','))
                    .and_then(|(f, _)| f.parse().ok())
                    .unwrap_or(1.0);
                let sig = (
                    name.trim().to_owned(),
                    start.trim().parse().map_err(|_| bad())?,
                    len.trim().parse().map_err(|_| bad())?,
                    signed,
                    factor,
                    false,
                );
                if let Some(m) = current.and_then(|id| d.0.get_mut(&id)) {
                    m.signals.push(sig);
                }
            } else if let Some(rest) = t.strip_prefix("SIG_VALTYPE_ ") {
                let mut w = rest.split_whitespace();
                let id: Option<u32> = w.next().and_then(|v| v.parse().ok());
                let name = w.next();
                if let (Some(m), Some(name)) = (id.and_then(|id| d.0.get_mut(&id)), name) {
                    for s in m.signals.iter_mut().filter(|s| s.0 == name) {
                        s.5 = true;
                    }
                }
            } else if !t.starts_with("CM_") {
                current = current.filter(|_| t.is_empty() || t.starts_with("SG_"));
            }
        }
        Ok(d)
    }

    /// `Name: sig=value …` of a frame the file describes.
    fn describe(&self, id: u32, data: &[u8]) -> Option<String> {
        let m = self.0.get(&id)?;
        let mut s = m.name.clone();
        s.push(':');
        for (name, start, len, signed, factor, float) in &m.signals {
            let raw = (0..*len).rev().try_fold(0u64, |v, k| {
                let bit = (start + k) as usize;
                data.get(bit / 8)
                    .map(|b| (v << 1) | u64::from((b >> (bit % 8)) & 1))
            });
            let Some(raw) = raw else { continue };
            let v = if *float && *len == 32 {
                f64::from(f32::from_bits(raw as u32))
            } else if *signed && *len < 64 {
                let shift = 64 - len;
                (((raw << shift) as i64) >> shift) as f64 * factor
            } else {
                raw as f64 * factor
            };
            let _ = write!(s, " {name}={v}");
        }
        Some(s)
    }
}

/// Runs the monitor, writing tables to `out`; the number of frames seen.
pub fn monitor(opts: &MonitorOptions, out: &mut impl Write) -> Result<u64> {
    let dbc = opts.dbc.as_deref().map(Dbc::load).transpose()?;
    let socket = open(&opts.interface)?;
    let start = Instant::now();
    let duration = opts
        .duration
        .or(opts.once.then_some(1.0))
        .map(Duration::from_secs_f64);
    let refresh = Duration::from_secs_f64(opts.refresh.max(0.05));
    let mut view = View::default();
    let mut before = Snapshot::default();
    let mut window_start = start;
    loop {
        let now = Instant::now();
        let done = duration.is_some_and(|d| now.duration_since(start) >= d);
        if done || (!opts.once && now.duration_since(window_start) >= refresh) {
            let window = now.duration_since(window_start).as_secs_f64();
            let table = view.table(&before, window, &opts.interface, dbc.as_ref());
            let clear = if opts.once { "" } else { "\x1b[H\x1b[2J" };
            let _ = write!(out, "{clear}{table}");
            let _ = out.flush();
            if done {
                return Ok(view.frames);
            }
            before = view.snapshot();
            window_start = now;
        }
        match socket.read_frame_timeout(Duration::from_millis(20)) {
            Ok(f) => view.take(&f, Instant::now()),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) => return Err(Error::Io(format!("{}: {e}", opts.interface))),
        }
    }
}

fn open(interface: &str) -> Result<CanFdSocket> {
    // An interface that cannot be opened is bad input, as `network.interface` is for `run`.
    let s = node_linux::open_fd(interface).map_err(|e| Error::invalid("<interface>", e))?;
    s.set_error_filter_accept_all()
        .map_err(|e| Error::Io(format!("{interface}: {e}")))?;
    Ok(s)
}
