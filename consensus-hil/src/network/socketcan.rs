//! `kind = "socketcan"`: the followers are node processes (`node-linux`, or boards) on a Linux
//! CAN interface; host-sim is the plant and the leader, in real time against the wall clock.
//!
//! Every sample `k` the loop sleeps until `t0 + k h` (an absolute deadline on the monotonic
//! clock), takes the command frames that arrived, sends the leader's value frame `y_d(t_k)`
//! and each agent's sensor frame `x_i(t_k)` (`agent_node::plant_bus`), and hands the latest
//! command of each agent to the plant for `[t_k, t_k + h)`. A node samples on its own timer
//! half a period after the sensor frames, so its command is back before the next sample: the
//! plant applies `q` computed from `x(t_{k-1})`, one sample later than with `kind = "can"`.
//!
//! Counted per agent: samples at which no new command had come since the previous one (the
//! plant held the old command: a *late* command), commands never received (samples minus
//! commands received), and the instant a node fell silent for `node_timeout` (*lost*). Counted
//! for the host: how late each sample's wake-up was (loop lateness). A sample that wakes more
//! than `h/2` late (an overrun) restarts the schedule at its wake-up: simulated time stretches
//! over a stall of the host instead of catching up with a burst of samples. `summary.json` gains a
//! `socketcan` object ([`SocketcanSummary`]), the run directory `socketcan.png`.
//!
//! `nodes = "spawn"` starts one `node-linux` per agent in a process group of their own and
//! stops the group (SIGTERM, then SIGKILL) at the end, on an error and on Ctrl-C. The interface
//! is used as found: host-sim never configures it.

use std::{
    path::{Path, PathBuf},
    process::{Child, Command},
    sync::{Arc, Mutex},
    time::{Duration, Instant, SystemTime},
};

use agent_node::{
    bus_load::SensorFrames,
    canopen::{self, NmtCommand},
    plant_bus::{self, Kind, PlantFrame, PACKED_SENSOR_AGENTS},
    wire::{self, Source},
};
use controller_core::{ControllerConfig, Gains, Params, StepOutput};
use embedded_can::Frame as _;
use node_linux::{
    config::{CanOpenSection, NodeSection, Supervision},
    on_wire, NodeFile,
};
use socketcan::{CanAnyFrame, CanFdSocket, CanFilter, Socket, SocketOptions};

use crate::network::canopen::Master;
use consensus_plot::{
    error::{Error, Result},
    figure::{
        panel::{render, Panel, Series},
        FigureStyle,
    },
};
use consensus_sim::{
    figures::{AgentCommands, KindReport, SocketcanSummary},
    graph::Graph,
    network::{
        spec::{node_config, LostCommand, NetworkSpec, NodesMode},
        trace::{candump_fd_frame_line, candump_line, TraceWriter},
    },
    sim::{Agents, K},
};

/// Process groups of running node processes, stopped by the interrupt hook.
static GROUPS: Mutex<Vec<i32>> = Mutex::new(Vec::new());

/// The `--trace` of the run, drained and flushed by the interrupt hook.
static TRACE: Mutex<Option<Arc<Mutex<BusTrace>>>> = Mutex::new(None);

/// `--trace` on a Linux interface: a socket of its own that receives every frame (classical
/// and CAN FD) with its kernel receive time (`SO_TIMESTAMPNS`), and the candump log.
struct BusTrace {
    socket: CanFdSocket,
    writer: TraceWriter,
    interface: String,
    /// Wall time the socket was opened: the log's time origin, fixed for the whole run.
    origin: SystemTime,
    /// The last stamp written [ns]: stamps never step back.
    last_ns: u64,
}

impl BusTrace {
    /// Writes every frame waiting on the socket, stamped with its kernel receive time since
    /// the origin.
    fn drain(&mut self) {
        let mut lines = Vec::new();
        while let Ok((f, at)) = self.socket.read_frame_with_timestamp() {
            let ns = at
                .duration_since(self.origin)
                .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
                .max(self.last_ns);
            self.last_ns = ns;
            match &f {
                CanAnyFrame::Normal(_) | CanAnyFrame::Remote(_) => {
                    lines.push(candump_line(ns, &self.interface, &f));
                }
                CanAnyFrame::Fd(fd) => {
                    lines.push(candump_fd_frame_line(ns, &self.interface, &f, fd.is_brs()));
                }
                CanAnyFrame::Error(_) => {}
            }
        }
        self.writer.write_lines(lines);
    }

    /// Drains and flushes the file.
    fn finish(&mut self) -> Result<()> {
        self.drain();
        self.writer.finish()
    }
}

fn flush_trace_on_interrupt() {
    let trace = TRACE.lock().ok().and_then(|t| t.clone());
    if let Some(t) = trace {
        if let Ok(mut t) = t.lock() {
            let _ = t.finish();
        }
    }
}

fn stop_groups_on_interrupt() {
    if let Ok(groups) = GROUPS.lock() {
        for &g in groups.iter() {
            signal_group(g, nix::sys::signal::Signal::SIGTERM);
        }
    }
    eprintln!("host-sim: interrupted; node processes stopped");
}

fn signal_group(pgid: i32, sig: nix::sys::signal::Signal) {
    let _ = nix::sys::signal::killpg(nix::unistd::Pid::from_raw(pgid), sig);
}

/// One agent's side of the loop.
struct Agent {
    q: [f32; 2],
    received: u64,
    this_sample: u64,
    late: u64,
    last_rx: Option<Instant>,
    lost_at: Option<f64>,
    /// Cumulative late commands at each sample (the figure).
    late_series: Vec<u32>,
    /// Command frames since the start of the current duplicate window.
    window_received: u64,
}

/// Sample periods of wall time (`h time_scale`) over which the command frames of each follower
/// are counted for a duplicate identity: a node sends at most one per period on its own timer
/// (a stalled host does not change that), so more than 1.5 per period means two nodes send as
/// the same agent.
const DUPLICATE_WINDOW: u32 = 200;

/// The node processes of `nodes = "spawn"`, stopped when dropped.
struct Spawned {
    children: Vec<(usize, Child)>,
    pgid: Option<i32>,
    dir: Option<PathBuf>,
}

impl Spawned {
    /// Stops the group: SIGTERM, up to 2 s for a clean exit, then SIGKILL.
    fn stop(&mut self) {
        let Some(g) = self.pgid.take() else {
            return;
        };
        signal_group(g, nix::sys::signal::Signal::SIGTERM);
        let until = Instant::now() + Duration::from_secs(2);
        for (i, c) in &mut self.children {
            loop {
                match c.try_wait() {
                    Ok(Some(st)) if !st.success() => {
                        eprintln!("host-sim: node of agent {i} ended with {st}");
                        break;
                    }
                    Ok(Some(_)) | Err(_) => break,
                    Ok(None) if Instant::now() < until => {
                        std::thread::sleep(Duration::from_millis(10));
                    }
                    Ok(None) => {
                        eprintln!("host-sim: node of agent {i} ignored SIGTERM; killed");
                        signal_group(g, nix::sys::signal::Signal::SIGKILL);
                        let _ = c.wait();
                        break;
                    }
                }
            }
        }
        if let Ok(mut groups) = GROUPS.lock() {
            groups.retain(|&x| x != g);
        }
    }
}

impl Spawned {
    /// Waits up to `limit` for every node process to exit by itself (after a stop command).
    fn wait_for_exit(&mut self, limit: Duration) {
        let until = Instant::now() + limit;
        while Instant::now() < until {
            let mut running = 0;
            for (_, c) in &mut self.children {
                if matches!(c.try_wait(), Ok(None)) {
                    running += 1;
                }
            }
            if running == 0 {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Spawned {
    fn drop(&mut self) {
        self.stop();
        if let Some(d) = self.dir.take() {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}

/// The agents of `kind = "socketcan"`: node processes on a Linux CAN interface.
pub struct SocketcanAgents<const N: usize, const M: usize> {
    socket: CanFdSocket,
    trace: Option<Arc<Mutex<BusTrace>>>,
    /// Frames go out as CAN FD with bit-rate switching (`network.data_bitrate`).
    fd: bool,
    /// How the sensor frames are laid out.
    sensor_frames: SensorFrames,
    /// What the plant applies to a lost follower.
    lost_command: LostCommand,
    /// Start of the current duplicate-identity window (wall time).
    duplicate_window: Option<Instant>,
    interface: String,
    mode: NodesMode,
    /// The sample period in wall time (`h time_scale`).
    h: Duration,
    node_timeout: Duration,
    start_timeout: Duration,
    t0: Option<(Instant, SystemTime)>,
    agents: Vec<Agent>,
    lateness: Vec<f32>,
    overruns: u64,
    frames_sent: u64,
    send_errors: u64,
    gains: Gains,
    nodes: Spawned,
    last_wake: Option<Instant>,
    last_t: f64,
    /// The first sample's deadline (`t0` moves with every overrun).
    started: Option<Instant>,
    /// host-sim is the nodes' NMT master: their heartbeats and EMCY say their state, its NMT
    /// stop ends the run.
    canopen: Master,
    /// `network.canopen`: the nodes boot pre-operational and wait for the master's NMT start.
    nmt_start: bool,
}

/// Opens `interface` for host-sim (classical and CAN FD frames), with the error naming
/// `network.interface`.
fn open(interface: &str) -> Result<CanFdSocket> {
    let s = node_linux::run::open_fd(interface)
        .map_err(|e| Error::invalid("network.interface", e.to_string()))?;
    s.set_nonblocking(true)
        .map_err(|e| Error::Io(format!("{interface}: {e}")))?;
    Ok(s)
}

impl<const N: usize, const M: usize> SocketcanAgents<N, M> {
    /// Opens the interface of `spec`, writes one node configuration per agent of `graph` (with
    /// the identifier plan, heartbeat and safe state of `[node]`, `node_spec`; controller
    /// configurations `configs`, sample period `h`), starts the nodes
    /// (`nodes = "spawn"`), and records every frame on the interface to `trace` when given.
    pub fn new(
        spec: &NetworkSpec,
        node_spec: &consensus_sim::network::node::NodeSpec,
        h: f64,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        trace: Option<&Path>,
    ) -> Result<Self> {
        if (N, M) != (2, 2) {
            return Err(Error::invalid(
                "network.kind",
                "\"socketcan\" carries the two-state plants of the examples (n = m = 2)",
            ));
        }
        let interface = spec.interface().to_owned();
        let socket = open(&interface)?;
        if spec.data_bitrate.is_some() {
            for name in std::iter::once(&interface).chain(spec.node_interfaces.iter().flatten()) {
                check_fd_mode(name, spec)?;
            }
        }
        let cmd = u32::from(plant_bus::COMMAND_BASE);
        // Commands, and the nodes' status by CANopen: EMCY (0x081..=0x0FF) and heartbeats
        // (0x701..=0x77F).
        let filters = [
            CanFilter::new(cmd, 0x700),
            CanFilter::new(0x080, 0x780),
            CanFilter::new(0x700, 0x780),
        ];
        socket
            .set_filters(&filters)
            .map_err(|e| Error::Io(format!("{interface}: {e}")))?;
        let trace = match trace {
            Some(p) => {
                let s = open(&interface)?;
                s.set_recv_timestamp(true)
                    .map_err(|e| Error::Io(format!("{interface}: {e}")))?;
                let t = Arc::new(Mutex::new(BusTrace {
                    socket: s,
                    writer: TraceWriter::create(p)?,
                    interface: interface.clone(),
                    origin: SystemTime::now(),
                    last_ns: 0,
                }));
                if let Ok(mut slot) = TRACE.lock() {
                    *slot = Some(t.clone());
                }
                consensus_plot::files::also_on_interrupt(flush_trace_on_interrupt);
                Some(t)
            }
            None => None,
        };
        let node_timeout = spec.node_timeout(h);
        let mode = spec.nodes.unwrap_or_default();
        let (dir, keep) = match &spec.node_dir {
            Some(d) => (PathBuf::from(d), true),
            None => (
                std::env::temp_dir().join(format!("host-sim-nodes-{}", std::process::id())),
                false,
            ),
        };
        consensus_plot::files::create_dir(&dir)?;
        let mut nodes = Spawned {
            children: Vec::new(),
            pgid: None,
            dir: (!keep).then(|| dir.clone()),
        };
        let files = write_node_files(spec, node_spec, h, graph, configs, &dir)?;
        if mode == NodesMode::Spawn {
            consensus_plot::files::also_on_interrupt(stop_groups_on_interrupt);
            let program = node_program(spec);
            for (i, f) in files.iter().enumerate() {
                let mut cmd = Command::new(&program);
                cmd.arg(f);
                std::os::unix::process::CommandExt::process_group(
                    &mut cmd,
                    nodes.pgid.unwrap_or(0),
                );
                let child = cmd.spawn().map_err(|e| {
                    Error::invalid(
                        "network.node_program",
                        format!(
                            "cannot start `{}`: {e} (build it: cargo build -p node-linux)",
                            program.display()
                        ),
                    )
                })?;
                if nodes.pgid.is_none() {
                    let g = i32::try_from(child.id()).unwrap_or(i32::MAX);
                    nodes.pgid = Some(g);
                    if let Ok(mut groups) = GROUPS.lock() {
                        groups.push(g);
                    }
                }
                nodes.children.push((i + 1, child));
            }
        } else {
            eprintln!(
                "host-sim: waiting up to {} s for the nodes on {interface}; their configurations: {}",
                spec.start_timeout(),
                dir.display()
            );
        }
        let gains = configs.first().and_then(|c| Params::new(c, K).ok()).map_or(
            Gains {
                c1: f32::NAN,
                c2: f32::NAN,
                k1: f32::NAN,
                k2: f32::NAN,
            },
            |p| *p.gains(),
        );
        Ok(Self {
            socket,
            trace,
            fd: spec.data_bitrate.is_some(),
            sensor_frames: spec.sensor_frames(),
            lost_command: spec.lost_command.unwrap_or_default(),
            duplicate_window: None,
            interface,
            mode,
            h: Duration::from_secs_f64(h * spec.time_scale()),
            node_timeout: Duration::from_secs_f64(node_timeout),
            start_timeout: Duration::from_secs_f64(spec.start_timeout()),
            t0: None,
            agents: (0..configs.len())
                .map(|_| Agent {
                    q: [0.0; 2],
                    received: 0,
                    this_sample: 0,
                    late: 0,
                    last_rx: None,
                    lost_at: None,
                    late_series: Vec::new(),
                    window_received: 0,
                })
                .collect(),
            lateness: Vec::new(),
            overruns: 0,
            frames_sent: 0,
            send_errors: 0,
            gains,
            nodes,
            last_wake: None,
            last_t: 0.0,
            started: None,
            canopen: Master::new(graph.len(), spec.canopen == Some(true)),
            nmt_start: spec.canopen == Some(true),
        })
    }

    /// Whether agent `i + 1` has said it is there (a boot-up or heartbeat).
    fn heard(&self, i: usize) -> bool {
        self.canopen.nmt_state(i + 1).is_some()
    }

    /// Waits until every node has said it is there (a boot-up or heartbeat) and sets `t0`.
    fn start(&mut self) -> Result<()> {
        let until = Instant::now() + self.start_timeout;
        loop {
            self.drain(Instant::now(), 0.0);
            if (0..self.agents.len()).all(|i| self.heard(i)) {
                break;
            }
            if Instant::now() >= until {
                let missing: Vec<String> = self
                    .agents
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !self.heard(*i))
                    .map(|(i, _)| (i + 1).to_string())
                    .collect();
                return Err(Error::Bench(format!(
                    "no node of agent(s) {} on {} within network.start_timeout = {} s ({})",
                    missing.join(", "),
                    self.interface,
                    self.start_timeout.as_secs_f64(),
                    match self.mode {
                        NodesMode::Spawn => "the spawned node processes did not come up",
                        NodesMode::External => "start them with the files of network.node_dir",
                    }
                )));
            }
            self.check_children()?;
            std::thread::sleep(Duration::from_millis(5));
        }
        for a in &mut self.agents {
            a.this_sample = 0;
            a.last_rx = None;
        }
        if self.nmt_start {
            // NMT start to all nodes: their outputs go on from here (docs/NETWORK.md §12).
            self.send(Master::command(NmtCommand::Start, 0).to_frame());
        }
        // Start on a whole period from now, so the nodes' first sample lands mid-period.
        self.t0 = Some((Instant::now() + self.h, SystemTime::now() + self.h));
        self.started = self.t0.map(|(t, _)| t);
        Ok(())
    }

    /// A spawned node that exited before the run started is an error.
    fn check_children(&mut self) -> Result<()> {
        for (i, c) in &mut self.nodes.children {
            if let Ok(Some(st)) = c.try_wait() {
                return Err(Error::Io(format!(
                    "the node process of agent {i} exited before the run started ({st})"
                )));
            }
        }
        Ok(())
    }

    /// Takes every waiting frame (commands, heartbeats, EMCY; the trace socket's all).
    fn drain(&mut self, now: Instant, t: f64) {
        while let Ok(f) = self.socket.read_frame() {
            match plant_bus::decode(&f) {
                Some(PlantFrame::Command(a, q)) => {
                    if let Some(ag) = self.agents.get_mut(usize::from(a) - 1) {
                        ag.q = q;
                        ag.received += 1;
                        ag.window_received += 1;
                        ag.this_sample += 1;
                        ag.last_rx = Some(now);
                    }
                }
                _ => self.take_canopen(&f, t),
            }
        }
        if let Some(Ok(mut t)) = self.trace.as_ref().map(|t| t.lock()) {
            t.drain();
        }
    }

    /// A follower whose command frames came more than 1.5 times per sample over the last
    /// window is two nodes with one identity (a CANopen node-ID duplicate): an error naming it.
    fn check_duplicates(&mut self, t: f64) -> Result<()> {
        let limit = u64::from(DUPLICATE_WINDOW + DUPLICATE_WINDOW / 2);
        let dup = self
            .agents
            .iter()
            .enumerate()
            .find(|(_, a)| a.window_received > limit)
            .map(|(i, a)| (i + 1, a.window_received));
        for a in &mut self.agents {
            a.window_received = 0;
        }
        match dup {
            Some((agent, n)) => Err(Error::Bench(format!(
                "t = {t:.3} s: {n} command frames of agent {agent} in {DUPLICATE_WINDOW} periods: \
                 two nodes send as agent {agent} (one identity, node.agent, on two nodes)"
            ))),
            None => Ok(()),
        }
    }

    /// Stops the nodes at the end of a run, the one place that commands it: CiA 301's NMT stop
    /// to every node (`0x000`, `[0x02, 0]`). The nodes' files say `exit_on_stop`: each answers
    /// with a last heartbeat `STOPPED` and exits 0 (docs/NETWORK.md §11).
    fn stop_the_nodes(&mut self) {
        self.send(Master::command(NmtCommand::Stop, 0).to_frame());
    }

    /// An EMCY or heartbeat of a node.
    fn take_canopen<F: embedded_can::Frame>(&mut self, f: &F, t: f64) {
        if let Some(f) = canopen::CoFrame::from_frame(f) {
            let before = self.canopen.nmt_state(usize::from(f.id & 0x7F));
            self.canopen.take(f.id, f.data(), t);
            // A node leaving operational while the run goes on is worth a line.
            let node = usize::from(f.id & 0x7F);
            let after = self.canopen.nmt_state(node);
            if f.id & 0x780 == 0x700 && before != after && before.is_some() && self.t0.is_some() {
                if let Some(s) = after.filter(|s| *s != "OPERATIONAL") {
                    eprintln!("host-sim: t = {t:.3} s: node of agent {node} is {s}");
                }
            }
        }
    }

    /// Sends `f` as it goes on this bus (CAN FD with bit-rate switching with `fd`).
    fn send(&mut self, f: Option<CanAnyFrame>) {
        match f
            .and_then(|f| on_wire(&f, self.fd))
            .map(|f| self.socket.write_frame(&f))
        {
            Some(Ok(())) => self.frames_sent += 1,
            _ => self.send_errors += 1,
        }
    }

    /// The sensor frames of the states `x` (agent `i + 1` at index `i`): one per agent, or one
    /// CAN FD frame per 8 agents.
    fn send_sensors(&mut self, x: &[[f64; 2]]) {
        let pairs: Vec<[f32; 2]> = x.iter().map(|v| [v[0] as f32, v[1] as f32]).collect();
        match self.sensor_frames {
            SensorFrames::PerAgent => {
                for (i, v) in pairs.iter().enumerate() {
                    let agent = u8::try_from(i + 1).unwrap_or(0);
                    self.send(plant_bus::pair_frame(Kind::Sensor, agent, *v));
                }
            }
            SensorFrames::Packed => {
                let per = usize::from(PACKED_SENSOR_AGENTS);
                for (g, group) in pairs.chunks(per).enumerate() {
                    let first = u8::try_from(g * per + 1).unwrap_or(0);
                    let mut data = [0u8; 64];
                    let frame = plant_bus::encode_packed(group, &mut data).and_then(|len| {
                        CanAnyFrame::new(Kind::Sensor.id(first)?, data.get(..len)?)
                    });
                    self.send(frame);
                }
            }
        }
    }

    /// The figures of `summary.json` `socketcan`.
    pub fn summary(&self) -> SocketcanSummary {
        let n = self.lateness.len();
        let mut sorted: Vec<f32> = self.lateness.clone();
        sorted.sort_by(f32::total_cmp);
        let p99 = sorted
            .get((n * 99).div_ceil(100).saturating_sub(1))
            .copied()
            .unwrap_or(0.0);
        let samples = n as u64;
        SocketcanSummary {
            interface: self.interface.clone(),
            nodes: self.mode.as_str(),
            samples,
            loop_lateness_mean_s: if n == 0 {
                0.0
            } else {
                sorted.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64
            },
            loop_lateness_p99_s: f64::from(p99),
            loop_lateness_max_s: f64::from(sorted.last().copied().unwrap_or(0.0)),
            loop_overruns: self.overruns,
            wall_time_s: match (self.started, self.last_wake) {
                (Some(t0), Some(w)) => w.saturating_duration_since(t0).as_secs_f64(),
                _ => 0.0,
            },
            frames_sent: self.frames_sent,
            send_errors: self.send_errors,
            agents: self
                .agents
                .iter()
                .enumerate()
                .map(|(i, a)| AgentCommands {
                    agent: i + 1,
                    received: a.received,
                    late: a.late,
                    missing: samples.saturating_sub(a.received),
                    lost_at_s: a.lost_at,
                    // A node silent at the end is lost, whatever its last heartbeat said.
                    state: if a.lost_at.is_some() {
                        Some("lost")
                    } else {
                        self.canopen.bench_state(i + 1, a.received > 0)
                    },
                    node_late_ticks: self.canopen.overruns(i + 1),
                    nmt_state: self.canopen.nmt_state(i + 1),
                })
                .collect(),
            emcy: Some(self.canopen.emcy().to_vec()),
        }
    }
}

/// With `network.data_bitrate`, `interface` must carry CAN FD frames (MTU 72, Linux's
/// `CANFD_MTU`): an error naming the key and the command otherwise. An MTU that cannot be read
/// is left to the first send.
fn check_fd_mode(interface: &str, spec: &NetworkSpec) -> Result<()> {
    let path = format!("/sys/class/net/{interface}/mtu");
    let Some(mtu) = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.trim().parse::<u32>().ok())
    else {
        return Ok(());
    };
    if mtu >= 72 {
        return Ok(());
    }
    Err(Error::invalid(
        "network.data_bitrate",
        format!(
            "CAN FD frames need an interface in FD mode, and `{interface}` has MTU {mtu}: \
             `ip link set {interface} mtu 72` for a vcan (down first), `ip link set \
             {interface} type can bitrate {} dbitrate {} fd on` for a controller",
            spec.bitrate,
            spec.data_bitrate.unwrap_or(spec.bitrate)
        ),
    ))
}

/// The first identifier of the plant-bus frames.
fn plan_bus_first() -> u16 {
    plant_bus::SENSOR_BASE
}

/// The node program: `network.node_program`, else `node-linux` beside this executable, else
/// `node-linux` on `PATH`.
fn node_program(spec: &NetworkSpec) -> PathBuf {
    if let Some(p) = &spec.node_program {
        return PathBuf::from(p);
    }
    std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(|d| d.join("node-linux")))
        .filter(|p| p.is_file())
        .unwrap_or_else(|| PathBuf::from("node-linux"))
}

impl<const N: usize, const M: usize> Agents<N, M> for SocketcanAgents<N, M> {
    fn control(
        &mut self,
        k: u64,
        t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()> {
        if self.t0.is_none() {
            self.start()?;
        }
        let Some((t0, _)) = self.t0 else {
            return Err(Error::Io("the run has no start time".into()));
        };
        let deadline = t0 + self.h.mul_f64(k as f64);
        let now = Instant::now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
        let woke = Instant::now();
        self.last_wake = Some(woke);
        let late = woke.saturating_duration_since(deadline);
        self.lateness.push(late.as_secs_f32());
        if late > self.h / 2 {
            // The schedule restarts at this wake-up: simulated time stretches over the stall
            // instead of catching up in a burst of samples the nodes never see.
            self.overruns += 1;
            if let Some((t0, sys0)) = self.t0.as_mut() {
                *t0 += late;
                *sys0 += late;
            }
        }
        self.last_t = t;
        self.drain(woke, t);
        for (i, a) in self.agents.iter_mut().enumerate() {
            if k > 0 && a.this_sample == 0 {
                a.late += 1;
            }
            a.this_sample = 0;
            a.late_series
                .push(u32::try_from(a.late).unwrap_or(u32::MAX));
            let silent = woke.saturating_duration_since(a.last_rx.unwrap_or(t0));
            if a.lost_at.is_none() && silent > self.node_timeout {
                a.lost_at = Some(t);
                eprintln!(
                    "host-sim: t = {t:.3} s: agent {} lost (no command for {:.3} s, node_timeout {:.3} s)",
                    i + 1,
                    silent.as_secs_f64(),
                    self.node_timeout.as_secs_f64()
                );
            } else if a.lost_at.is_some() && silent <= self.node_timeout {
                a.lost_at = None;
                eprintln!("host-sim: t = {t:.3} s: agent {} is back", i + 1);
            }
        }
        let window_start = *self.duplicate_window.get_or_insert(woke);
        if woke.saturating_duration_since(window_start) >= self.h * DUPLICATE_WINDOW {
            self.duplicate_window = Some(woke);
            self.check_duplicates(t)?;
        }
        let seq = (k % u64::from(wire::SEQ_MODULUS)) as u8;
        self.send(wire::encode::<CanAnyFrame>(Source::Leader, yd as f32, seq).map(|(f, _)| f));
        let pairs: Vec<[f64; 2]> = x
            .iter()
            .map(|xi| [xi[0], xi.get(1).copied().unwrap_or(0.0)])
            .collect();
        self.send_sensors(&pairs);
        let zero_lost = self.lost_command == LostCommand::Zero;
        out.extend(self.agents.iter().map(|a| {
            let mut o = super::unreported_output::<N, M>();
            let q = if zero_lost && a.lost_at.is_some() {
                [0.0; 2]
            } else {
                a.q
            };
            for (d, s) in o.q.iter_mut().zip(q) {
                *d = s;
            }
            o.u = o.q;
            // The nodes keep their errors: not on the bus.
            o.e = [f32::NAN; N];
            o
        }));
        Ok(())
    }

    fn gains(&self) -> Gains {
        self.gains
    }

    fn report(&self) -> KindReport {
        KindReport::Socketcan(self.summary())
    }

    /// `socketcan.png` / `.svg`: the host loop's lateness per sample, and each agent's late
    /// commands, cumulative.
    fn draw(
        &self,
        dir: &Path,
        h: f64,
        title: &str,
        output: consensus_plot::figure::Output,
    ) -> Result<()> {
        const STRIDE: usize = 10;
        let lateness = self
            .lateness
            .chunks(STRIDE)
            .enumerate()
            .map(|(b, w)| {
                let peak = w.iter().copied().fold(0.0f32, f32::max);
                ((b * STRIDE) as f64 * h, f64::from(peak) * 1e6)
            })
            .collect();
        let top = Panel {
            title: format!(
                "{title}: host loop lateness on {} (largest of 10 samples)",
                self.interface
            ),
            y_label: "wake-up − deadline [µs]".into(),
            series: vec![Series {
                width: 1,
                ..Series::styled("host-sim".into(), 0, lateness)
            }],
            hlines: vec![(self.h.as_secs_f64() * 0.5e6, "h/2 (wall)".into())],
            ..Panel::default()
        };
        let series = self
            .agents
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let points = a
                    .late_series
                    .iter()
                    .enumerate()
                    .step_by(STRIDE)
                    .map(|(k, &v)| (k as f64 * h, f64::from(v)))
                    .collect();
                Series::styled(format!("agent {}", i + 1), i, points)
            })
            .collect();
        let bottom = Panel {
            title: "late command frames (no new command at the host's sample), cumulative".into(),
            y_label: "samples".into(),
            series,
            ..Panel::default()
        };
        render(
            dir,
            "socketcan",
            &[top, bottom],
            (2, 1),
            FigureStyle::px(1000, 760).with(output),
        )
    }

    fn finish(&mut self) -> Result<()> {
        self.stop_the_nodes();
        self.nodes.wait_for_exit(Duration::from_secs(1));
        self.nodes.stop();
        self.drain(Instant::now(), self.last_t);
        let result = match self.trace.as_ref().map(|t| t.lock()) {
            Some(Ok(mut t)) => t.finish(),
            Some(Err(_)) => Err(Error::Io("the bus trace's lock was poisoned".into())),
            None => Ok(()),
        };
        if let Ok(mut slot) = TRACE.lock() {
            *slot = None;
        }
        result
    }
}

/// Writes one node configuration per agent of `graph` into `dir` (`agent-<i>.toml`, read by
/// `node-linux`: the identifier plan, heartbeat and safe state of `[node]`, `node_spec`;
/// controller configurations `configs`, sample period `h`) and beside each its CANopen EDS
/// (`agent-<i>.eds`, CiA 306, the node's object dictionary with its values); the paths of
/// the configurations.
pub fn write_node_files<const N: usize>(
    spec: &NetworkSpec,
    node_spec: &consensus_sim::network::node::NodeSpec,
    h: f64,
    graph: &Graph,
    configs: &[ControllerConfig<N>],
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    let interface = spec.interface().to_owned();
    let node_timeout = spec.node_timeout(h);
    let mut files = Vec::with_capacity(configs.len());
    for (i, c) in configs.iter().enumerate() {
        let nc = node_config(spec, node_spec, h, graph, i)?;
        let plan = nc.ids;
        let blocks = [
            Some((plan.value_base(), "node.id_base")),
            plan.heartbeat_base().map(|b| (b, "node.heartbeat_id_base")),
        ];
        for (base, key) in blocks.into_iter().flatten() {
            let end = base + u16::from(plan.agents());
            if base <= 0x3FF && end >= plan_bus_first() {
                return Err(Error::invalid(
                    key,
                    "with network.kind = \"socketcan\" the identifiers must stay clear of \
                     0x200..=0x3FF (sensor and command frames)",
                ));
            }
        }
        if nc.agent > 127 {
            return Err(Error::invalid(
                "network.kind",
                "\"socketcan\" nodes are CANopen devices: at most 127 followers (node-IDs 1..=127)",
            ));
        }
        let section = NodeSection {
            agent: i64::from(nc.agent),
            neighbours: graph.neighbours(i).iter().map(|&k| k as i64 + 1).collect(),
            interface: spec
                .node_interfaces
                .as_ref()
                .and_then(|l| l.get(i))
                .unwrap_or(&interface)
                .clone(),
            stale_timeout: Some(nc.stale_timeout_us as f64 * 1e-6),
            host_timeout: node_timeout,
            time_scale: spec.time_scale(),
            supervision: Some(Supervision::of(&nc)),
            start_timeout: Some(spec.start_timeout() + node_timeout),
            fd: spec.data_bitrate.map(|_| true),
            packed_sensors: (spec.sensor_frames() == SensorFrames::Packed).then_some(true),
            node_id: Some(i64::from(nc.agent)),
            // Every bench node is a CANopen device: its heartbeat and EMCY are its status, the
            // master's NMT stop ends its run. Without network.canopen it starts itself.
            canopen: Some(CanOpenSection {
                store: None,
                heartbeat_ms: 100,
                self_starting: spec.canopen != Some(true),
                exit_on_stop: true,
            }),
        };
        let text = NodeFile::to_toml(&section, *c)
            .map_err(|e| Error::Io(format!("node configuration of agent {}: {e}", i + 1)))?;
        NodeFile::parse(&text)
            .map_err(|e| Error::invalid(format!("node configuration of agent {}", i + 1), e))?;
        let path = dir.join(format!("agent-{}.toml", i + 1));
        consensus_plot::files::write_atomic(&path, text.as_bytes())?;
        write_eds(&text, &dir.join(format!("agent-{}.eds", i + 1)), i + 1)?;
        files.push(path);
    }
    Ok(files)
}

/// The EDS of the node configured by `text` (agent `agent`), written to `path`.
fn write_eds(text: &str, path: &Path, agent: usize) -> Result<()> {
    let what = format!("EDS of agent {agent}");
    let file = NodeFile::parse(text).map_err(|e| Error::invalid(what.clone(), e))?;
    let store =
        agent_node::canopen::od::ParamStore::new(file.node_config.identity(), &file.controller)
            .map_err(|_| Error::invalid(what.clone(), "node-ID outside 1..=127"))?;
    let mut device =
        agent_node::canopen::Device::new(store, agent_node::canopen::Identity::default(), false);
    if !file.node.packed_sensors() {
        // node-linux's sensor and command frames are its RPDO18 and TPDO3.
        device.enable_plant_pdos();
    }
    let mut eds = String::new();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    agent_node::canopen::eds::write_eds(&mut eds, &device, &name)
        .map_err(|e| Error::Io(format!("{what}: {e}")))?;
    consensus_plot::files::write_atomic(path, eds.as_bytes())
}
