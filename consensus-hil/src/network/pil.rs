//! `[network] kind = "pil"`: processor in the loop. Every follower runs the node firmware
//! (`node-fw`: `agent_node::Node` built for `thumbv7em-none-eabihf`) on its own emulated
//! Cortex-M4F, `qemu-system-arm -M mps2-an386 -icount shift=0`, whose UART0 is the emulator's
//! standard input and output; the host keeps the plant, the leader and `hil-mock`'s bus model
//! (bit timing, loss, corruption, silent and babbling nodes), and speaks the link protocol of
//! [`agent_node::link`] (SLCAN) with each node.
//!
//! Per sample `t_k` (as [`hil_mock::network::CanNetwork::step`] does for host-compiled nodes):
//! the bus runs to `t_k`; each delivered frame goes to every other node that is not bus-off and
//! accepts it, with its delivery time; then the tick record (the state as `f32`, `t_k`) goes
//! to every node, which ticks and answers with its bus frame and its report record; the host
//! submits the nodes' frames and the leader's `y_d(t_k)` at `t_k`. All nodes work on a sample
//! at the same time; each node's input of a sample is one `write`.
//!
//! An emulator that exits (a firmware panic ends QEMU through semihosting), sends something
//! that is not the expected answer, or does not answer within [`ANSWER_TIMEOUT`] stops the run
//! with an error naming the agent. Every emulator is killed when the run ends, on an error
//! and on Ctrl-C / SIGTERM (a handler kills the registered emulators, then exits with 130);
//! and, as no handler sees a SIGKILL, each runs under `setpriv --pdeathsig KILL` (util-linux),
//! so the kernel kills it when host-sim dies, however that happens. Each emulator is pinned
//! to one CPU (`taskset`), see `Launch`.

use std::{
    io::{BufReader, Read, Write},
    path::{Path, PathBuf},
    process::{Child, ChildStdin, Command, Stdio},
    sync::{
        mpsc::{self, Receiver, RecvTimeoutError},
        Arc, Mutex,
    },
    time::Duration,
};

use agent_node::{
    canopen::{CoFrame, NmtCommand},
    link::{self, io, CanFrame, Report, Slcan, Tick, RECORD_MAX_LINE, SLCAN_MAX_LINE},
    wire::{IdPlan, Source},
    NodeState,
};
use controller_core::{ControllerConfig, Estimates, Gains, LinkReport, StepFault, StepOutput};
use embedded_can::Frame;
use hil_mock::{bus::Nanos, host::BusHost, mock::MockFrame};
use plotters::style::{Color, RGBColor};

use crate::network::canopen::Master;
use consensus_plot::{
    error::{Error, Result},
    figure::{
        panel::{color, render, Panel, Series, Shade},
        FigureStyle,
    },
};
use consensus_sim::{
    figures::{EmcyRecord, FirmwareSummary, KindReport, NetworkSummary},
    graph::Graph,
    network::{
        node::{self, NodeSpec},
        spec::{bus_config, node_config, ns, EventName, NetworkKind, NetworkSpec},
        trace::{candump_fd_line, candump_line, TraceWriter, Traces, INTERFACE},
    },
    sim::{Agents, K},
};

/// The emulator.
pub const QEMU: &str = "qemu-system-arm";
/// How to get it (Debian/Ubuntu).
pub const QEMU_INSTALL: &str = "apt-get update && apt-get install -y qemu-system-arm";
/// Environment variable naming the firmware ELF (default: [`default_firmware`]).
pub const FIRMWARE_ENV: &str = "HOST_SIM_NODE_FW";
/// Longest wait for one answer of a node (start-up or one sample); a healthy node answers a
/// sample in well under a millisecond of host time.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(20);
/// Environment variable replacing [`ANSWER_TIMEOUT`] (seconds; for tests of the timeout).
pub const ANSWER_TIMEOUT_ENV: &str = "HOST_SIM_PIL_ANSWER_TIMEOUT";
/// The launcher that makes the kernel kill an emulator when host-sim dies
/// (`prctl(PR_SET_PDEATHSIG)`, kept across its `exec` of QEMU).
pub const PDEATHSIG_LAUNCHER: &str = "setpriv";
/// The launcher that pins an emulator to one CPU.
pub const PIN_LAUNCHER: &str = "taskset";

/// [`ANSWER_TIMEOUT`], or the one [`ANSWER_TIMEOUT_ENV`] sets.
fn answer_timeout() -> Result<Duration> {
    let Some(v) = std::env::var_os(ANSWER_TIMEOUT_ENV) else {
        return Ok(ANSWER_TIMEOUT);
    };
    v.to_str()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .and_then(|s| Duration::try_from_secs_f64(s).ok())
        .filter(|d| !d.is_zero())
        .ok_or_else(|| {
            Error::invalid(
                ANSWER_TIMEOUT_ENV,
                format!("{v:?} is not a positive number of seconds"),
            )
        })
}

/// How every emulator is started: the launchers before `qemu-system-arm` (both from util-linux,
/// on every Debian or Ubuntu system; each is left out, with a warning for the first, when it is
/// not on `PATH`).
struct Launch {
    /// `setpriv --pdeathsig KILL`: the kernel kills the emulator when host-sim dies, also by
    /// SIGKILL, which no handler sees.
    pdeathsig: Option<PathBuf>,
    /// `taskset -c <cpu>`; one CPU per emulator, in turn over the CPUs host-sim may use. Both
    /// of QEMU's busy threads (main loop, virtual CPU) then share a core: every byte into a
    /// node is a hand-over between them, and on one core it costs about a quarter less CPU
    /// time than between two.
    pin: Option<PathBuf>,
    cpus: Vec<usize>,
}

impl Launch {
    fn new() -> Self {
        let pdeathsig = find_in_path(PDEATHSIG_LAUNCHER);
        if pdeathsig.is_none() {
            eprintln!(
                "host-sim: warning: {PDEATHSIG_LAUNCHER} (util-linux) not found: a SIGKILL of \
                 host-sim would leave the emulators running"
            );
        }
        Self {
            pdeathsig,
            pin: find_in_path(PIN_LAUNCHER),
            cpus: allowed_cpus(),
        }
    }

    /// The command that starts agent `agent`'s (1-based) emulator.
    fn command(&self, agent: usize) -> Command {
        let mut argv: Vec<std::ffi::OsString> = Vec::new();
        if let Some(p) = &self.pdeathsig {
            argv.extend([p.as_os_str().into(), "--pdeathsig".into(), "KILL".into()]);
        }
        let cpu = self
            .cpus
            .get((agent + self.cpus.len() - 1) % self.cpus.len().max(1));
        if let (Some(p), Some(cpu)) = (&self.pin, cpu) {
            argv.extend([p.as_os_str().into(), "-c".into(), cpu.to_string().into()]);
        }
        argv.push(QEMU.into());
        let mut c = Command::new(&argv[0]);
        c.args(&argv[1..]);
        c
    }
}

/// The CPUs this process may run on (`Cpus_allowed_list` of `/proc/self/status`, e.g.
/// `0-3,8`); empty when unknown.
fn allowed_cpus() -> Vec<usize> {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return Vec::new();
    };
    status
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .map_or_else(Vec::new, cpu_list)
}

/// The CPUs of a Linux CPU list (`0-3,8`), ascending; empty if it is malformed.
fn cpu_list(list: &str) -> Vec<usize> {
    let mut cpus = Vec::new();
    for part in list.trim().split(',') {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        match (a.trim().parse::<usize>(), b.trim().parse::<usize>()) {
            (Ok(a), Ok(b)) if a <= b => cpus.extend(a..=b),
            _ => return Vec::new(),
        }
    }
    cpus
}

/// The firmware built in the source tree: `node-fw/target/thumbv7em-none-eabihf/release/node-fw`.
pub fn default_firmware() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../node-fw/target/thumbv7em-none-eabihf/release/node-fw")
}

fn find_in_path(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// Emulators alive, for the Ctrl-C handler.
static RUNNING: Mutex<Vec<(u32, Child)>> = Mutex::new(Vec::new());

/// Stops every emulator still running (the interrupt hook of a PIL run).
fn kill_all() {
    if let Ok(mut running) = RUNNING.lock() {
        for (_, c) in running.iter_mut() {
            let _ = c.kill();
            let _ = c.wait();
        }
        running.clear();
    }
    eprintln!("host-sim: interrupted; emulators stopped");
}

/// What an emulator printed: an SLCAN frame, a report record, or anything else (a panic
/// message, `\a`).
enum Output {
    Frame(CanFrame),
    Report(Report),
    Text(String),
    Eof,
}

/// A well-formed line of an emulator.
enum Answer {
    Frame(CanFrame),
    Report(Report),
}

/// One node's emulator.
struct Emulator {
    agent: usize,
    pid: u32,
    stdin: ChildStdin,
    rx: Receiver<Output>,
    stderr: Arc<Mutex<String>>,
    /// Bytes for the next write.
    out: Vec<u8>,
    /// Longest wait for an answer.
    timeout: Duration,
    /// Time of the last tick (the origin of timestamps) [µs].
    sync_us: u64,
    /// Interval before the last tick [µs] (the node's, once it has one).
    tick_dt_us: Option<u32>,
    /// Candump lines of everything on the link since they were last taken (`--link-trace`).
    link_log: Option<Vec<String>>,
    /// The configuration words, sent again when the node boots after a watchdog reset.
    config: Vec<u32>,
    /// The watchdog's late periods (`node.watchdog_periods`), sent with the configuration.
    watchdog_periods: u32,
    /// The step duration the node was last told (`io::SLOW` units; 0: not slowed).
    slow: u32,
    /// The control task stopped (an `OVERRUN` came instead of the report): the host sends
    /// nothing and takes one line per sample until the report or the boot frame.
    hung: bool,
}

impl Emulator {
    fn spawn(
        agent: usize,
        firmware: &Path,
        timeout: Duration,
        launch: &Launch,
        log_link: bool,
    ) -> Result<Self> {
        let mut child = launch
            .command(agent)
            .args(["-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic"])
            .args(["-monitor", "none", "-serial", "stdio"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-icount", "shift=0", "-kernel"])
            .arg(firmware)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| Error::Io(format!("agent {agent}: cannot start {QEMU}: {e}")))?;
        let pid = child.id();
        let (stdin, stdout, stderr) =
            match (child.stdin.take(), child.stdout.take(), child.stderr.take()) {
                (Some(i), Some(o), Some(e)) => (i, o, e),
                _ => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(Error::Io(format!("agent {agent}: {QEMU} has no pipes")));
                }
            };
        if let Ok(mut r) = RUNNING.lock() {
            r.push((pid, child));
        }
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || read_output(stdout, &tx));
        let err = Arc::new(Mutex::new(String::new()));
        let err2 = Arc::clone(&err);
        std::thread::spawn(move || {
            let mut s = String::new();
            let _ = BufReader::new(stderr).read_to_string(&mut s);
            if let Ok(mut e) = err2.lock() {
                e.push_str(&s);
            }
        });
        Ok(Self {
            agent,
            pid,
            stdin,
            rx,
            stderr: err,
            out: Vec::with_capacity(1024),
            timeout,
            sync_us: 0,
            tick_dt_us: None,
            link_log: log_link.then(Vec::new),
            config: Vec::new(),
            watchdog_periods: 0,
            slow: 0,
            hung: false,
        })
    }

    /// Sends the configuration words (`CONFIG` …), the watchdog's late periods (`WATCHDOG`)
    /// and `CONFIG_END`.
    fn send_config(&mut self) -> Result<()> {
        let words = std::mem::take(&mut self.config);
        for pair in words.chunks(2) {
            let bytes: Vec<u8> = pair.iter().flat_map(|w| w.to_le_bytes()).collect();
            self.queue_io(io::CONFIG, &bytes);
        }
        self.queue_io(io::WATCHDOG, &self.watchdog_periods.to_le_bytes());
        let count = u16::try_from(words.len()).unwrap_or(u16::MAX);
        self.queue_io(io::CONFIG_END, &count.to_le_bytes());
        self.config = words;
        self.flush()
    }

    /// Checks a `BOOT` frame: the firmware speaks this host's link protocol.
    fn check_boot(&self, f: &CanFrame) -> Result<()> {
        match (f.io_id(), f.data()) {
            (Some(io::BOOT), [v]) if *v == link::PROTOCOL_VERSION => Ok(()),
            (Some(io::BOOT), d) => Err(self.failure(&format!(
                "firmware speaks link protocol {d:?}, host-sim {}: rebuild node-fw (cd node-fw && \
                 cargo build --release)",
                link::PROTOCOL_VERSION
            ))),
            _ => Err(self.failure(&format!(
                "unexpected start-up frame {f:?} (the boot frame comes first; an older node-fw? \
                 rebuild it: cd node-fw && cargo build --release)"
            ))),
        }
    }

    /// Waits for `READY` (the configuration accepted).
    fn expect_ready(&mut self) -> Result<()> {
        let f = self.next_frame("READY")?;
        match (f.io_id(), f.data()) {
            (Some(io::READY), [a]) if usize::from(*a) == self.agent => Ok(()),
            (Some(io::REJECTED), [code]) => {
                Err(self.failure(&format!("configuration rejected (code {code})")))
            }
            _ => Err(self.failure(&format!("unexpected start-up answer {f:?}"))),
        }
    }

    /// The node booted again (watchdog reset): configure it afresh; its clock restarts, so
    /// the next tick carries the interval from 0.
    fn rejoin(&mut self, f: &CanFrame) -> Result<()> {
        self.check_boot(f)?;
        self.hung = false;
        self.slow = 0;
        self.sync_us = 0;
        self.tick_dt_us = None;
        self.send_config()?;
        self.expect_ready()?;
        self.queue_start();
        Ok(())
    }

    /// The NMT start of this node (its node-ID is its agent number), ahead of its next tick:
    /// the node, pre-operational since its boot (its boot-up message follows `READY`), is
    /// operational from that tick on, so its first tick already computes and sends, as a
    /// node without a CANopen device does (docs/NETWORK.md §9).
    fn queue_start(&mut self) {
        let node = u8::try_from(self.agent).unwrap_or(0);
        if let Some(f) = Master::command(NmtCommand::Start, node).to_frame::<CanFrame>() {
            self.queue(&f, self.sync_us);
        }
    }

    /// Keeps `frame`, seen on the link at `t_us`, for the link trace.
    fn log_frame(&mut self, t_us: u64, frame: &CanFrame) {
        if let Some(log) = self.link_log.as_mut() {
            log.push(candump_line(
                t_us * 1000,
                &format!("node{}", self.agent),
                frame,
            ));
        }
    }

    /// Keeps a record's payload, seen on the link at `t_us`, for the link trace, under the
    /// identifier `id` the DBC gives it.
    fn log_record(&mut self, t_us: u64, id: u32, payload: &[u8]) {
        if let Some(log) = self.link_log.as_mut() {
            let iface = format!("node{}", self.agent);
            log.push(candump_fd_line(t_us * 1000, &iface, id, payload));
        }
    }

    /// `frame` without timestamp, logged at `t_us`.
    fn queue(&mut self, frame: &CanFrame, t_us: u64) {
        let mut buf = [0u8; SLCAN_MAX_LINE];
        let n = link::slcan_encode(frame, &mut buf);
        self.out.extend_from_slice(&buf[..n]);
        self.log_frame(t_us, frame);
    }

    /// A process-I/O frame at the time of the last tick.
    fn queue_io(&mut self, id: u32, data: &[u8]) {
        if let Some(f) = CanFrame::io(id, data) {
            self.queue(&f, self.sync_us);
        }
    }

    /// `frame` at time `t_us`: timestamped relative to the last tick, or after a `CLOCK`
    /// frame when that does not fit 16 bits.
    fn queue_at(&mut self, frame: &CanFrame, t_us: u64) {
        let Ok(ts) = u16::try_from(t_us.saturating_sub(self.sync_us)) else {
            if let Some(clock) = CanFrame::io(io::CLOCK, &(t_us as u32).to_le_bytes()) {
                self.queue(&clock, t_us);
            }
            self.queue(frame, t_us);
            return;
        };
        let mut buf = [0u8; SLCAN_MAX_LINE];
        let n = link::slcan_encode_timed(frame, ts, &mut buf);
        self.out.extend_from_slice(&buf[..n]);
        self.log_frame(t_us, frame);
    }

    /// The tick of sample time `t_us` with the state `x`; the interval only when it changed.
    fn queue_tick(&mut self, x: [f32; 2], t_us: u64) -> Result<()> {
        let dt = u32::try_from(t_us.saturating_sub(self.sync_us))
            .map_err(|_| self.failure("samples more than 2^32 µs apart"))?;
        let tick = Tick {
            x,
            dt_us: (self.tick_dt_us != Some(dt)).then_some(dt),
        };
        let mut buf = [0u8; RECORD_MAX_LINE];
        let n = link::tick_encode(&tick, &mut buf);
        self.out.extend_from_slice(&buf[..n]);
        let (payload, len) = tick.to_bytes();
        self.log_record(t_us, io::SYNC, &payload[..len]);
        self.sync_us = t_us;
        self.tick_dt_us = Some(dt);
        Ok(())
    }

    fn flush(&mut self) -> Result<()> {
        let r = self
            .stdin
            .write_all(&self.out)
            .and_then(|()| self.stdin.flush());
        self.out.clear();
        r.map_err(|e| self.failure(&format!("cannot write to its UART ({e})")))
    }

    /// The next frame or report, or the error that names the agent.
    fn next_answer(&mut self, waiting_for: &str) -> Result<Answer> {
        let what = match self.rx.recv_timeout(self.timeout) {
            Ok(Output::Frame(f)) => {
                self.log_frame(self.sync_us, &f);
                return Ok(Answer::Frame(f));
            }
            Ok(Output::Report(r)) => {
                self.log_record(self.sync_us, io::REPORT, &r.to_bytes());
                return Ok(Answer::Report(r));
            }
            Ok(Output::Text(t)) => format!("sent {t:?} while the host waited for {waiting_for}"),
            Ok(Output::Eof) | Err(RecvTimeoutError::Disconnected) => {
                // Let the stderr reader finish.
                std::thread::sleep(Duration::from_millis(100));
                format!("emulator exited while the host waited for {waiting_for}")
            }
            Err(RecvTimeoutError::Timeout) => format!(
                "no answer within {} s while the host waited for {waiting_for}",
                self.timeout.as_secs_f64()
            ),
        };
        Err(self.failure(&what))
    }

    /// The next frame, or the error that names the agent.
    fn next_frame(&mut self, waiting_for: &str) -> Result<CanFrame> {
        match self.next_answer(waiting_for)? {
            Answer::Frame(f) => Ok(f),
            Answer::Report(_) => Err(self.failure(&format!(
                "sent a report while the host waited for {waiting_for}"
            ))),
        }
    }

    fn failure(&self, what: &str) -> Error {
        let err = self
            .stderr
            .lock()
            .map(|s| s.trim().to_string())
            .unwrap_or_default();
        // The first line is what matters (a QEMU register dump follows a lockup).
        let err: String = err.lines().next().unwrap_or("").chars().take(200).collect();
        let err = if err.is_empty() {
            String::new()
        } else {
            format!("; {QEMU}: {err}")
        };
        Error::Io(format!("PIL agent {}: {what}{err}", self.agent))
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        if let Ok(mut running) = RUNNING.lock() {
            if let Some(pos) = running.iter().position(|(p, _)| *p == self.pid) {
                let (_, mut c) = running.swap_remove(pos);
                let _ = c.kill();
                let _ = c.wait();
            }
        }
    }
}

/// Splits the emulator's output at `\r` / `\n` into frames and other text.
///
/// QEMU writes the UART's bytes one at a time; reading each as it comes would wake this
/// thread for every byte. After each read the thread pauses for [`READ_PAUSE`], so a node's
/// answer to one sample (about 200 bytes) arrives in a few reads.
fn read_output(mut stdout: impl Read, tx: &mpsc::Sender<Output>) {
    let mut buf = vec![0u8; 1 << 14];
    let mut line = Vec::with_capacity(64);
    loop {
        let n = match stdout.read(&mut buf) {
            Ok(0) | Err(_) => {
                let _ = tx.send(Output::Eof);
                return;
            }
            Ok(n) => n,
        };
        for &b in &buf[..n] {
            if b != b'\r' && b != b'\n' {
                line.push(b);
                continue;
            }
            if line.is_empty() {
                continue;
            }
            let msg = match link::slcan_decode(&line) {
                Ok(Slcan::Frame(f) | Slcan::Timed(f, _)) => Output::Frame(f),
                Ok(Slcan::Report(r)) => Output::Report(r),
                _ => Output::Text(String::from_utf8_lossy(&line).into_owned()),
            };
            line.clear();
            if tx.send(msg).is_err() {
                return;
            }
        }
        std::thread::sleep(READ_PAUSE);
    }
}

/// Pause of the output reader after each read.
const READ_PAUSE: Duration = Duration::from_micros(150);

/// The output a report carries (`N = M = 2`, checked when the agents start).
fn report_output<const N: usize, const M: usize>(r: &Report) -> StepOutput<N, M> {
    let mut out = super::unreported_output();
    for (dst, src) in [(&mut out.q[..], r.q), (&mut out.u[..], r.u)]
        .into_iter()
        .chain([(&mut out.e[..], r.e)])
    {
        dst.iter_mut().zip(src).for_each(|(d, s)| *d = s);
    }
    out.estimates = Estimates {
        mu: r.mu,
        xi: r.xi,
        lambda: r.lambda,
    };
    out.status.fault = match r.fault {
        0 => None,
        1 => Some(StepFault::InvalidState),
        _ => Some(StepFault::NonFiniteResult),
    };
    out.status.links = LinkReport {
        stale_neighbours: r.stale,
        missing_neighbours: r.missing,
        leader_stale: r.leader & 1 != 0,
        leader_missing: r.leader & 2 != 0,
        ..LinkReport::default()
    };
    out
}

fn nearest_rank(sorted: &[u32], p: f64) -> u32 {
    if sorted.is_empty() {
        return 0;
    }
    let rank = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

/// Every follower on its own emulated Cortex-M4F, the leader and the bus on the host.
pub struct PilAgents<const N: usize, const M: usize> {
    emus: Vec<Emulator>,
    /// The bus, the links' sample times, the leader's counter and the identifier plan.
    host: BusHost,
    h_ns: Nanos,
    bitrate: u32,
    pinned: Vec<bool>,
    neighbours: Vec<Vec<usize>>,
    /// Acceptance filter of each node: the standard identifiers it hears.
    accept: Vec<Vec<u32>>,
    /// Scratch for the ages of one agent's links.
    ages: Vec<Nanos>,
    costs: Vec<Vec<u32>>,
    /// Sample index of each entry of `costs`.
    cost_samples: Vec<Vec<u64>>,
    resolution: u32,
    stale_samples: u64,
    stacks: Vec<u32>,
    malformed: u64,
    gains: Gains,
    trace: Option<TraceWriter>,
    link_trace: Option<TraceWriter>,
    /// Per agent, the sample times of its `hang` events not yet sent.
    hang_at: Vec<Vec<Nanos>>,
    /// Per agent, its `slow` events: `[from, until)` [ns] and the step duration (`io::SLOW`
    /// units).
    slow_at: Vec<Vec<(Nanos, Nanos, u32)>>,
    /// Per agent, the output of its last report: what a hung node's actuators hold.
    held: Vec<StepOutput<N, M>>,
    /// Per agent, its overruns and the times of its hangs and resets (kept when the
    /// emulators end).
    events: Vec<NodeEvents>,
    /// host-sim as the nodes' NMT master: their CANopen frames on the links.
    canopen: Master,
    /// `network.canopen = true`: the NMT states and EMCY go to `summary.json`.
    report_canopen: bool,
}

/// What happened to one node's control task during the run.
#[derive(Debug, Clone, Default)]
struct NodeEvents {
    overruns: u32,
    hangs: Vec<f64>,
    /// Slow intervals `[from, until)` [s] (`until` `None`: to the end of the run).
    slow: Vec<(f64, Option<f64>)>,
    resets: Vec<f64>,
    /// Safe-state intervals `[from, to)` [s]; `to` is `None` while the node is in it.
    safe: Vec<(f64, Option<f64>)>,
}

impl NodeEvents {
    /// Follows the node state a report carries ([`NodeState::code`]) at sample time `t`.
    fn state(&mut self, code: u8, t: f64) {
        let safe = code == NodeState::Safe.code();
        match self.safe.last_mut() {
            Some((_, to @ None)) if !safe => *to = Some(t),
            Some((_, None)) => {}
            _ if safe => self.safe.push((t, None)),
            _ => {}
        }
    }
}

impl<const N: usize, const M: usize> PilAgents<N, M> {
    /// Starts one emulator per agent of the validated `graph` and configures its node with
    /// its controller configuration (`configs`, in agent order) and neighbours, on the bus of
    /// `[network]` (`spec`, sample period `h`, `samples` samples); every frame on the bus, and
    /// everything on the links, go to the candump logs of `traces` when given.
    pub fn new(
        spec: &NetworkSpec,
        node_spec: &NodeSpec,
        h: f64,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        samples: u64,
        traces: Traces<'_>,
    ) -> Result<Self> {
        if N != 2 || M != 2 {
            return Err(Error::invalid(
                "network.kind",
                "\"pil\" supports plants with n = 2 states and m = 2 actuators",
            ));
        }
        if find_in_path(QEMU).is_none() {
            return Err(Error::invalid(
                "network.kind",
                format!("\"pil\" needs {QEMU} on PATH; install it: {QEMU_INSTALL}"),
            ));
        }
        let watchdog_periods = node::watchdog_periods(node_spec, Some(h))?;
        let firmware = std::env::var_os(FIRMWARE_ENV).map_or_else(default_firmware, PathBuf::from);
        let timeout = answer_timeout()?;
        let launch = Launch::new();
        if !firmware.is_file() {
            return Err(Error::invalid(
                "network.kind",
                format!(
                    "\"pil\" needs the node firmware at {} (build it: cd node-fw && cargo build \
                     --release; or set {FIRMWARE_ENV})",
                    firmware.display()
                ),
            ));
        }
        // Without it Ctrl-C still ends the process group; only a lone SIGINT to host-sim would
        // leave emulators behind.
        consensus_plot::files::also_on_interrupt(kill_all);
        let agents = graph.len();
        let mut emus = Vec::with_capacity(agents);
        let mut pinned = Vec::with_capacity(agents);
        let mut neighbours = Vec::with_capacity(agents);
        let mut gains = None;
        let mut ids = IdPlan::DEFAULT;
        let mut watch_leader = false;
        for (i, &ctrl) in configs.iter().enumerate() {
            let node = node_config(spec, node_spec, h, graph, i)?;
            ids = node.ids;
            watch_leader = node.supervisor.leader_timeout_us.is_some();
            let heard = graph.neighbours(i);
            if gains.is_none() {
                let c = controller_core::Controller::<N, M, K>::new(&ctrl)
                    .map_err(|e| Error::invalid(format!("controller (agent {})", i + 1), e))?;
                gains = Some(*c.params().gains());
            }
            pinned.push(ctrl.pinned);
            neighbours.push(heard.iter().map(|k| k + 1).collect());
            let mut emu =
                Emulator::spawn(i + 1, &firmware, timeout, &launch, traces.link.is_some())?;
            let words = link::encode_config(&node, &ctrl);
            emu.config = words
                .as_slice()
                .ok_or_else(|| {
                    Error::invalid("network.kind", "configuration too large for the PIL link")
                })?
                .to_vec();
            emu.watchdog_periods = watchdog_periods;
            emu.send_config()?;
            emus.push(emu);
        }
        for emu in &mut emus {
            let f = emu.next_frame("the boot frame")?;
            emu.check_boot(&f)?;
            emu.expect_ready()?;
            emu.queue_start();
        }
        let mut hang_at = vec![Vec::new(); agents];
        for e in spec.event.iter().filter(|e| e.kind == EventName::Hang) {
            let a = e.agent.and_then(|a| usize::try_from(a).ok()).unwrap_or(0);
            if let Some(v) = hang_at.get_mut(a.wrapping_sub(1)) {
                v.push(ns(e.from));
            }
        }
        let mut slow_at = vec![Vec::new(); agents];
        let mut events = vec![NodeEvents::default(); agents];
        for e in spec.event.iter().filter(|e| e.kind == EventName::Slow) {
            let a = e.agent.and_then(|a| usize::try_from(a).ok()).unwrap_or(0);
            let units = e.periods.and_then(link::slow_periods).unwrap_or(0);
            if let (Some(v), Some(ev)) = (
                slow_at.get_mut(a.wrapping_sub(1)),
                events.get_mut(a.wrapping_sub(1)),
            ) {
                v.push((ns(e.from), e.until.map_or(Nanos::MAX, ns), units));
                ev.slow.push((e.from, e.until));
            }
        }
        let accept = neighbours
            .iter()
            .zip(&pinned)
            .map(|(heard, &p): (&Vec<usize>, &bool)| {
                let leader = (p || watch_leader).then_some(Source::Leader);
                heard
                    .iter()
                    .map(|&a| Source::Agent(u8::try_from(a).unwrap_or(0)))
                    .chain(leader)
                    .filter_map(|s| ids.value_id(s).map(u32::from))
                    .collect()
            })
            .collect();
        let cfg = bus_config(spec, h);
        let bitrate = cfg.bitrate;
        let mut host = BusHost::new(cfg, agents, ids).map_err(|e| Error::invalid("network", e))?;
        let trace = traces.bus.map(TraceWriter::create).transpose()?;
        if trace.is_some() {
            host.bus_mut().record_wire();
        }
        let link_trace = traces.link.map(TraceWriter::create).transpose()?;
        let mut agents = Self {
            emus,
            host,
            h_ns: ns(h),
            bitrate,
            pinned,
            neighbours,
            accept,
            ages: Vec::new(),
            costs: vec![Vec::with_capacity(usize::try_from(samples).unwrap_or(0)); agents],
            cost_samples: vec![Vec::with_capacity(usize::try_from(samples).unwrap_or(0)); agents],
            resolution: 0,
            stale_samples: 0,
            stacks: vec![0; agents],
            malformed: 0,
            gains: gains.unwrap_or(Gains {
                c1: f32::NAN,
                c2: f32::NAN,
                k1: f32::NAN,
                k2: f32::NAN,
            }),
            trace,
            link_trace,
            hang_at,
            slow_at,
            held: vec![super::unreported_output(); agents],
            events,
            canopen: Master::new(agents, spec.canopen == Some(true)),
            report_canopen: spec.canopen == Some(true),
        };
        agents.write_link_log();
        Ok(agents)
    }

    /// Moves what the links carried since the last call into the link trace.
    fn write_link_log(&mut self) {
        if let Some(w) = self.link_trace.as_mut() {
            for log in self.emus.iter_mut().filter_map(|e| e.link_log.as_mut()) {
                w.write_lines(log.drain(..));
            }
        }
    }

    /// Per-agent figures of the firmware (after the run).
    pub fn firmware(&self) -> Vec<FirmwareSummary> {
        self.costs
            .iter()
            .zip(&self.stacks)
            .enumerate()
            .map(|(i, (c, &stack))| {
                let mut s = c.clone();
                s.sort_unstable();
                FirmwareSummary {
                    agent: i + 1,
                    steps: s.len(),
                    instructions_min: s.first().copied().unwrap_or(0),
                    instructions_median: nearest_rank(&s, 0.5),
                    instructions_p99: nearest_rank(&s, 0.99),
                    instructions_max: s.last().copied().unwrap_or(0),
                    instructions_resolution: self.resolution,
                    stack_bytes: stack,
                    overruns: self.events[i].overruns,
                    resets: u32::try_from(self.events[i].resets.len()).unwrap_or(u32::MAX),
                    safe_state_entries: u32::try_from(self.events[i].safe.len())
                        .unwrap_or(u32::MAX),
                    nmt_state: self
                        .report_canopen
                        .then(|| self.canopen.nmt_state(i + 1))
                        .flatten(),
                    emcy: self.report_canopen.then(|| {
                        self.canopen
                            .emcy()
                            .iter()
                            .filter(|e| usize::from(e.agent) == i + 1)
                            .cloned()
                            .collect::<Vec<EmcyRecord>>()
                    }),
                }
            })
            .collect()
    }

    /// Instructions of every tick, per agent (for the figure).
    pub fn costs(&self) -> &[Vec<u32>] {
        &self.costs
    }

    /// Agent `j`'s answer to the sample at `t_ns`: its report; or, when its control task is
    /// stopped, the output its actuators hold (an `OVERRUN` frame: the timer released the task
    /// again) or, after a watchdog reset (the boot frame), no command until it reports again.
    fn collect(&mut self, j: usize, t_ns: Nanos) -> Result<StepOutput<N, M>> {
        loop {
            let emu = &mut self.emus[j];
            let waiting = if emu.hung {
                "the next line of a stopped node (OVERRUN or its boot frame)"
            } else {
                "the answer to a tick"
            };
            let f = match emu.next_answer(waiting)? {
                Answer::Report(r) => {
                    emu.hung = false;
                    self.events[j].state(r.state, t_ns as f64 * 1e-9);
                    let out = report_output(&r);
                    self.stale_samples += u64::from(r.stale);
                    self.costs[j].push(r.instructions);
                    self.cost_samples[j].push(t_ns / self.h_ns.max(1));
                    self.resolution = r.resolution;
                    self.held[j] = out;
                    return Ok(out);
                }
                Answer::Frame(f) => f,
            };
            match f.io_id() {
                // The node's CANopen frames (EMCY, heartbeat, SDO answers) are for its master
                // at the other end of the link; the bus model carries the control traffic only,
                // the frames of the host-compiled nodes of `kind = "can"`.
                None if CoFrame::from_frame(&f)
                    .is_some_and(|c| self.canopen.take(c.id, c.data(), t_ns as f64 * 1e-9)) => {}
                None => {
                    let frame = MockFrame::new(f.id(), f.data())
                        .ok_or_else(|| emu.failure("sent a frame the bus cannot carry"))?;
                    // Refusals (silent, bus-off) are counted by the bus.
                    let _ = self.host.bus_mut().submit(j + 1, t_ns, frame);
                }
                Some(io::OVERRUN) => {
                    self.events[j].overruns += 1;
                    emu.hung = true;
                    return Ok(self.held[j]);
                }
                Some(io::BOOT) => {
                    emu.rejoin(&f)?;
                    let t = t_ns as f64 * 1e-9;
                    self.events[j].resets.push(t);
                    self.events[j].state(NodeState::Boot.code(), t);
                    let held = &mut self.held[j];
                    held.q = [0.0; M];
                    held.u = [0.0; M];
                    return Ok(*held);
                }
                Some(_) => {
                    return Err(emu.failure(&format!("unexpected frame {f:?} in a tick's answer")))
                }
            }
        }
    }

    /// Records the ages at `t_ns` of the values every agent's controller uses: its
    /// neighbours', and the leader's when pinned.
    fn record_ages(&mut self, t_ns: Nanos) {
        for (j, (heard, &pinned)) in self.neighbours.iter().zip(&self.pinned).enumerate() {
            let leader = pinned.then_some(0);
            self.ages.clear();
            let senders = heard.iter().copied().chain(leader);
            self.host.link_ages(j, t_ns, senders, &mut self.ages);
        }
    }
}

impl<const N: usize, const M: usize> Agents<N, M> for PilAgents<N, M> {
    fn control(
        &mut self,
        k: u64,
        _t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()> {
        let t_ns = k.saturating_mul(self.h_ns);
        let (emus, accept) = (&mut self.emus, &self.accept);
        self.host.deliver_until(t_ns, |j, d| {
            let (Some(emu), Some(accept)) = (emus.get_mut(j), accept.get(j)) else {
                return false;
            };
            if emu.hung || (!d.frame.is_extended() && !accept.contains(&d.frame.raw_id())) {
                return false;
            }
            let Some(frame) = CanFrame::new(d.frame.id(), d.frame.data()) else {
                return false;
            };
            emu.queue_at(&frame, d.at_ns / 1000);
            true
        });
        let t_us = t_ns / 1000;
        for ((((emu, xi), hangs), slows), events) in self
            .emus
            .iter_mut()
            .zip(x)
            .zip(&mut self.hang_at)
            .zip(&self.slow_at)
            .zip(&mut self.events)
        {
            if emu.hung {
                continue;
            }
            // The step duration of this sample's window (the first that holds it), told to
            // the node when it differs from what it was last told (also after a reset).
            let slow = slows
                .iter()
                .find(|(from, until, _)| (*from..*until).contains(&t_ns))
                .map_or(0, |w| w.2);
            if slow != emu.slow {
                emu.queue_io(io::SLOW, &slow.to_le_bytes());
                emu.slow = slow;
            }
            if let Some(pos) = hangs.iter().position(|&from| from <= t_ns) {
                hangs.swap_remove(pos);
                events.hangs.push(t_ns as f64 * 1e-9);
                emu.queue_io(io::HANG, &[]);
            }
            emu.queue_tick([xi[0] as f32, xi[1] as f32], t_us)?;
            emu.flush()?;
        }
        for j in 0..self.emus.len() {
            out.push(self.collect(j, t_ns)?);
        }
        self.record_ages(t_ns);
        self.host.send_leader(t_ns, yd as f32);
        if let Some(w) = self.trace.as_mut() {
            w.write(INTERFACE, &self.host.bus_mut().take_wire_log());
        }
        self.write_link_log();
        Ok(())
    }

    fn gains(&self) -> Gains {
        self.gains
    }

    fn report(&self) -> KindReport {
        KindReport::Pil {
            network: NetworkSummary::new(
                NetworkKind::Pil,
                self.bitrate,
                &self.host.bus().stats(),
                self.malformed,
                self.stale_samples,
            ),
            firmware: PilAgents::firmware(self),
        }
    }

    /// `firmware.png` / `.svg`: instructions of every tick against time, per agent (the
    /// largest of each 10 consecutive ticks, so no peak is lost), and the median.
    fn draw(
        &self,
        dir: &Path,
        h: f64,
        title: &str,
        output: consensus_plot::figure::Output,
    ) -> Result<()> {
        const STRIDE: u64 = 10;
        let series = self
            .costs
            .iter()
            .zip(&self.cost_samples)
            .enumerate()
            .map(|(i, (c, k))| {
                let mut points: Vec<(f64, f64)> = Vec::new();
                let mut bucket = None;
                for (&k, &c) in k.iter().zip(c) {
                    let b = k / STRIDE;
                    match points.last_mut() {
                        Some(p) if bucket == Some(b) => p.1 = p.1.max(f64::from(c)),
                        _ => points.push(((b * STRIDE) as f64 * h, f64::from(c))),
                    }
                    bucket = Some(b);
                }
                Series {
                    width: 1,
                    ..Series::styled(format!("agent {}", i + 1), i, points)
                }
            })
            .collect();
        let end = self
            .cost_samples
            .iter()
            .filter_map(|k| k.last())
            .max()
            .map_or(0.0, |&k| k as f64 * h);
        let mut shades = Vec::new();
        let mut vlines = Vec::new();
        for (i, ev) in self.events.iter().enumerate() {
            for (n, &from) in ev.hangs.iter().enumerate() {
                let to = ev.resets.get(n).copied().unwrap_or(end);
                shades.push(Shade {
                    from,
                    to,
                    color: {
                        let c = color(i);
                        RGBColor(c.0, c.1, c.2).mix(0.15)
                    },
                    label: format!("agent {}: control task stopped", i + 1),
                    hatch: true,
                });
            }
            for &(from, until) in &ev.slow {
                shades.push(Shade {
                    from,
                    to: until.unwrap_or(end).min(end),
                    color: {
                        let c = color(i);
                        RGBColor(c.0, c.1, c.2).mix(0.10)
                    },
                    label: format!("agent {}: slow steps", i + 1),
                    hatch: false,
                });
            }
            for &t in &ev.resets {
                vlines.push((t, format!("agent {}: watchdog reset", i + 1)));
            }
            for &(from, to) in &ev.safe {
                shades.push(Shade {
                    from,
                    to: to.unwrap_or(end),
                    color: RGBColor(214, 39, 40).mix(0.10),
                    label: format!("agent {}: safe state", i + 1),
                    hatch: false,
                });
            }
        }
        let panel = Panel {
            title: format!(
                "{title}: node firmware instructions per tick (QEMU mps2-an386, Cortex-M4F)"
            ),
            y_label: "instructions per tick".into(),
            series,
            shades,
            vlines,
            ..Panel::default()
        };
        render(
            dir,
            "firmware",
            &[panel],
            (1, 1),
            FigureStyle::px(1000, 560).with(output),
        )
    }

    fn finish(&mut self) -> Result<()> {
        // A node whose control task is stopped answers nothing (its stack stays unknown, 0).
        for emu in self.emus.iter_mut().filter(|e| !e.hung) {
            emu.queue_io(io::STATS_REQUEST, &[]);
            emu.flush()?;
        }
        for (j, emu) in self.emus.iter_mut().enumerate().filter(|(_, e)| !e.hung) {
            let f = emu.next_frame("STATS")?;
            match (f.io_id(), link::unpack_u32x2(f.data())) {
                (Some(io::STATS), Some((stack, malformed))) => {
                    self.stacks[j] = stack;
                    self.malformed += u64::from(malformed);
                }
                _ => return Err(emu.failure(&format!("unexpected answer to STATS_REQUEST {f:?}"))),
            }
        }
        self.write_link_log();
        self.emus.clear();
        if let Some(w) = self.link_trace.as_mut() {
            w.finish()?;
        }
        self.trace.as_mut().map_or(Ok(()), TraceWriter::finish)
    }
}

#[cfg(test)]
mod tests {
    use super::cpu_list;

    #[test]
    fn cpu_lists_parse() {
        assert_eq!(cpu_list("0-1\n"), vec![0, 1]);
        assert_eq!(cpu_list(" 0-2,8,10-11"), vec![0, 1, 2, 8, 10, 11]);
        assert_eq!(cpu_list("3"), vec![3]);
        for bad in ["", "2-1", "a", "0-"] {
            assert!(cpu_list(bad).is_empty(), "{bad:?}");
        }
    }
}
