//! The CiA 301 device of the node firmware (`node-fw`, agent-node's `canopen` feature) over the
//! link of a real QEMU node: this test is the NMT master and SDO client at the host's end of
//! the SLCAN link (docs/NETWORK.md §9, §12) and checks every answer byte by byte — boot-up,
//! heartbeats in each NMT state, SDO upload (expedited and segmented) and download (refused
//! and taken), the outputs gated by NMT start and stop, and the EMCY of an overrun and of a
//! watchdog reset; and host-sim's `pil` kind as the nodes' NMT master, with their NMT states
//! and EMCY in `summary.json`. `#[ignore]`d with the other QEMU tests (needs `qemu-system-arm` and
//! `cd node-fw && cargo build --release`): `cargo test -p host-sim --test pil_canopen --
//! --ignored`.

mod common;

use std::{
    io::{BufRead, BufReader, Write},
    path::PathBuf,
    process::{Child, ChildStdin, Command, Stdio},
    sync::mpsc::{self, Receiver},
    time::Duration,
};

use agent_node::{
    canopen::{od::PARAM_BASE, DEVICE_NAME},
    link::{self, io, CanFrame, Report, Slcan, Tick, RECORD_MAX_LINE, SLCAN_MAX_LINE},
    node::NodeConfig,
    wire::{self, IdPlan, Source, MAX_NEIGHBOURS},
};
use common::{assert_ok, bin, scenario_path, tmp};
use controller_core::{ControllerConfig, Param};
use embedded_can::Frame as _;

/// The node's agent number, its CANopen node-ID.
const AGENT: u8 = 1;
/// Sample period [µs].
const H_US: u32 = 10_000;
/// Samples in one `0x1017` heartbeat period of the firmware (100 ms) and one to spare.
const HEARTBEAT_SAMPLES: usize = 11;
/// Longest wait for one line of the node.
const TIMEOUT: Duration = Duration::from_secs(20);

fn firmware() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../node-fw/target/thumbv7em-none-eabihf/release/node-fw")
}

/// What the node printed.
#[derive(Debug)]
enum Line {
    Frame(CanFrame),
    Report(Report),
    Other(String),
    Eof,
}

/// One QEMU node and the host's end of its link.
struct Link {
    child: Child,
    stdin: ChildStdin,
    rx: Receiver<Line>,
    first_tick: bool,
}

impl Drop for Link {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn node_config() -> NodeConfig<MAX_NEIGHBOURS> {
    let mut neighbours = [0; MAX_NEIGHBOURS];
    neighbours[0] = 2;
    NodeConfig::new(AGENT, neighbours, 50_000)
}

fn controller_config() -> ControllerConfig<2> {
    ControllerConfig::<2> {
        h: H_US as f32 * 1e-6,
        neighbour_count: 1,
        pinned: true,
        ..ControllerConfig::default()
    }
}

impl Link {
    /// Boots the firmware and configures agent [`AGENT`] with the watchdog's late periods
    /// `watchdog_periods` (0: none); returns the link after the node's `READY`.
    fn start(watchdog_periods: u32) -> Self {
        assert!(
            Command::new("qemu-system-arm")
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
                && firmware().is_file(),
            "this check needs qemu-system-arm and {} (apt-get install qemu-system-arm; cd node-fw && cargo build --release)",
            firmware().display()
        );
        let mut child = Command::new("qemu-system-arm")
            .args(["-M", "mps2-an386", "-cpu", "cortex-m4", "-nographic"])
            .args(["-monitor", "none", "-serial", "stdio"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-icount", "shift=0", "-kernel"])
            .arg(firmware())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start qemu-system-arm");
        let stdin = child.stdin.take().expect("piped stdin");
        let stdout = child.stdout.take().expect("piped stdout");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            // Every line of the node ends in `\r`.
            for line in BufReader::new(stdout).split(b'\r') {
                let Ok(line) = line else { break };
                let text = line.trim_ascii();
                if text.is_empty() {
                    continue;
                }
                let decoded = match link::slcan_decode(text) {
                    Ok(Slcan::Frame(f) | Slcan::Timed(f, _)) => Line::Frame(f),
                    Ok(Slcan::Report(r)) => Line::Report(r),
                    _ => Line::Other(String::from_utf8_lossy(text).into_owned()),
                };
                if tx.send(decoded).is_err() {
                    return;
                }
            }
            let _ = tx.send(Line::Eof);
        });
        let mut l = Self {
            child,
            stdin,
            rx,
            first_tick: true,
        };
        let boot = l.frame();
        assert_eq!(
            (boot.io_id(), boot.data()),
            (Some(io::BOOT), &[link::PROTOCOL_VERSION][..])
        );
        l.configure(watchdog_periods);
        l
    }

    /// Sends the configuration and waits for `READY`.
    fn configure(&mut self, watchdog_periods: u32) {
        let words = link::encode_config(&node_config(), &controller_config());
        let words = words.as_slice().expect("fits the link");
        let mut out = Vec::new();
        for pair in words.chunks(2) {
            let bytes: Vec<u8> = pair.iter().flat_map(|w| w.to_le_bytes()).collect();
            push_frame(&mut out, &io_frame(io::CONFIG, &bytes));
        }
        push_frame(
            &mut out,
            &io_frame(io::WATCHDOG, &watchdog_periods.to_le_bytes()),
        );
        let count = u16::try_from(words.len()).expect("few words");
        push_frame(&mut out, &io_frame(io::CONFIG_END, &count.to_le_bytes()));
        self.write(&out);
        let ready = self.frame();
        assert_eq!(
            (ready.io_id(), ready.data()),
            (Some(io::READY), &[AGENT][..])
        );
        self.first_tick = true;
    }

    fn write(&mut self, bytes: &[u8]) {
        self.stdin.write_all(bytes).expect("write to the UART");
        self.stdin.flush().expect("flush the UART");
    }

    fn line(&mut self) -> Line {
        self.rx
            .recv_timeout(TIMEOUT)
            .expect("the node answers within 20 s")
    }

    /// The next line, which must be a frame.
    fn frame(&mut self) -> CanFrame {
        match self.line() {
            Line::Frame(f) => f,
            Line::Other(text) => panic!("expected a frame, got the line {text:?}"),
            other => panic!("expected a frame, got {other:?}"),
        }
    }

    /// One sample: `frames` (bus frames and process-I/O frames), then the tick record; the
    /// node's frames up to its report, and the report.
    fn sample(&mut self, frames: &[CanFrame]) -> (Vec<CanFrame>, Report) {
        let mut out = Vec::new();
        for f in frames {
            push_frame(&mut out, f);
        }
        let tick = Tick {
            x: [1.0, 0.0],
            dt_us: std::mem::take(&mut self.first_tick).then_some(H_US),
        };
        let mut buf = [0u8; RECORD_MAX_LINE];
        let n = link::tick_encode(&tick, &mut buf);
        out.extend_from_slice(&buf[..n]);
        self.write(&out);
        let mut got = Vec::new();
        loop {
            match self.line() {
                Line::Frame(f) => got.push(f),
                Line::Report(r) => return (got, r),
                other => panic!("expected the answer to a tick, got {other:?}"),
            }
        }
    }

    /// Samples until a frame `id` with `data` comes (at most `samples` of them); every frame
    /// seen on the way.
    fn until(&mut self, id: u16, data: &[u8], samples: usize) -> Vec<CanFrame> {
        let mut seen = Vec::new();
        for _ in 0..samples {
            let (f, _) = self.sample(&[]);
            seen.extend(f);
            if seen.iter().any(|f| is(f, id, data)) {
                return seen;
            }
        }
        panic!(
            "no frame {id:#05x} {data:02x?} in {samples} samples: {:?}",
            ids(&seen)
        );
    }

    /// One SDO request to the node; its one answer.
    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        let (got, _) = self.sample(&[std_frame(0x600 + u16::from(AGENT), &req)]);
        let answers: Vec<&CanFrame> = got
            .iter()
            .filter(|f| std_id(f) == Some(0x580 + u16::from(AGENT)))
            .collect();
        assert_eq!(answers.len(), 1, "one SDO answer to {req:02x?}: {got:?}");
        answers[0].data().try_into().expect("8 data bytes")
    }

    fn upload(&mut self, index: u16, sub: u8) -> [u8; 8] {
        let i = index.to_le_bytes();
        self.sdo([0x40, i[0], i[1], sub, 0, 0, 0, 0])
    }

    fn download_f32(&mut self, index: u16, sub: u8, v: f32) -> [u8; 8] {
        let (i, b) = (index.to_le_bytes(), v.to_le_bytes());
        self.sdo([0x23, i[0], i[1], sub, b[0], b[1], b[2], b[3]])
    }

    /// Reads lines until the node's boot frame (after a reset), at most 2000 of them.
    fn until_boot(&mut self) {
        for _ in 0..2000 {
            if let Line::Frame(f) = self.line() {
                if f.io_id() == Some(io::BOOT) {
                    return;
                }
            }
        }
        panic!("no boot frame after the node stopped");
    }
}

fn io_frame(id: u32, data: &[u8]) -> CanFrame {
    CanFrame::io(id, data).expect("a process-I/O frame")
}

fn std_frame(id: u16, data: &[u8]) -> CanFrame {
    let id = embedded_can::StandardId::new(id).expect("11-bit identifier");
    CanFrame::new(id, data).expect("at most 8 bytes")
}

fn push_frame(out: &mut Vec<u8>, f: &CanFrame) {
    let mut buf = [0u8; SLCAN_MAX_LINE];
    let n = link::slcan_encode(f, &mut buf);
    out.extend_from_slice(&buf[..n]);
}

fn std_id(f: &CanFrame) -> Option<u16> {
    match f.id() {
        embedded_can::Id::Standard(s) => Some(s.as_raw()),
        embedded_can::Id::Extended(_) => None,
    }
}

fn is(f: &CanFrame, id: u16, data: &[u8]) -> bool {
    std_id(f) == Some(id) && f.data() == data
}

fn ids(frames: &[CanFrame]) -> Vec<String> {
    frames
        .iter()
        .map(|f| match std_id(f) {
            Some(id) => format!("{id:03x}#{:02x?}", f.data()),
            None => format!("io {:08x}", f.io_id().unwrap_or(0)),
        })
        .collect()
}

/// The leader's value frame `y_d = 0` (sequence `seq`): with the node's state at 1, an error
/// the controller answers with a command.
fn leader(seq: u8) -> CanFrame {
    wire::encode_in::<CanFrame>(&IdPlan::DEFAULT, Source::Leader, 0.0, seq)
        .expect("the leader's frame")
        .0
}

fn param_index(p: Param) -> u16 {
    let k = Param::ALL.iter().position(|q| *q == p).expect("listed");
    PARAM_BASE + u16::try_from(k).expect("few parameters")
}

const HEARTBEAT: u16 = 0x700 + AGENT as u16;
const EMCY: u16 = 0x080 + AGENT as u16;
/// The node's value frame (the default identifier plan: `0x101 + agent`).
const VALUE: u16 = 0x101 + AGENT as u16;

#[test]
#[ignore = "needs qemu-system-arm and the node-fw build; run with --ignored"]
fn nmt_and_sdo_over_the_link_of_a_qemu_node() {
    let mut l = Link::start(0);
    // Boot-up right after READY, no EMCY (a power-on, not a watchdog reset), then the
    // pre-operational heartbeat; no outputs before an NMT start.
    let (first, report) = l.sample(&[]);
    assert_eq!(
        ids(&first),
        ["701#[00]", "701#[7f]"],
        "boot-up and the first heartbeat, nothing else"
    );
    let seen = l.until(HEARTBEAT, &[0x7F], HEARTBEAT_SAMPLES);
    assert!(!seen.iter().chain(&first).any(|f| std_id(f) == Some(VALUE)));
    assert_eq!(report.q, [0.0; 2]);

    // 0x1018 identity: 4 entries, vendor 0, product 2, revision 1 (expedited, 4 bytes).
    assert_eq!(l.upload(0x1018, 0), [0x4F, 0x18, 0x10, 0, 4, 0, 0, 0]);
    assert_eq!(l.upload(0x1018, 2), [0x43, 0x18, 0x10, 2, 2, 0, 0, 0]);
    assert_eq!(l.upload(0x1018, 3), [0x43, 0x18, 0x10, 3, 1, 0, 0, 0]);

    // Controller parameters as configured: h and ζ.
    let cfg = controller_config();
    let (h, zeta) = (param_index(Param::H), param_index(Param::Zeta));
    let (hi, zi) = (h.to_le_bytes(), zeta.to_le_bytes());
    let hb = cfg.h.to_le_bytes();
    assert_eq!(
        l.upload(h, 0),
        [0x43, hi[0], hi[1], 0, hb[0], hb[1], hb[2], hb[3]]
    );
    let before = l.upload(zeta, 0);
    assert_eq!(before[..4], [0x43, zi[0], zi[1], 0]);
    let z0 = f32::from_le_bytes(before[4..8].try_into().expect("4 bytes"));
    assert!(z0 > 0.0 && z0 < 1.0 && z0 != 0.2, "ζ = {z0}");

    // ζ = 1.5 is outside (0, 1): abort 0x0609_0030, ζ unchanged.
    assert_eq!(
        l.download_f32(zeta, 0, 1.5),
        [0x80, zi[0], zi[1], 0, 0x30, 0x00, 0x09, 0x06]
    );
    assert_eq!(l.upload(zeta, 0), before);
    // ζ = 0.2 is taken in pre-operational and reads back.
    assert_eq!(
        l.download_f32(zeta, 0, 0.2),
        [0x60, zi[0], zi[1], 0, 0, 0, 0, 0]
    );
    let z = 0.2f32.to_le_bytes();
    assert_eq!(
        l.upload(zeta, 0),
        [0x43, zi[0], zi[1], 0, z[0], z[1], z[2], z[3]]
    );

    // 0x1008 device name, segmented: initiate with the size, then toggled segments of 7.
    let name = DEVICE_NAME.as_bytes();
    let size = u32::try_from(name.len()).expect("short").to_le_bytes();
    assert_eq!(
        l.upload(0x1008, 0),
        [0x41, 0x08, 0x10, 0, size[0], size[1], size[2], size[3]]
    );
    let mut got = Vec::new();
    for (k, chunk) in name.chunks(7).enumerate() {
        let toggle = if k % 2 == 0 { 0x00 } else { 0x10 };
        let answer = l.sdo([0x60 | toggle, 0, 0, 0, 0, 0, 0, 0]);
        let last = (k + 1) * 7 >= name.len();
        let unused = u8::try_from(7 - chunk.len()).expect("< 8");
        assert_eq!(
            answer[0],
            toggle | (unused << 1) | u8::from(last),
            "segment {k}: {answer:02x?}"
        );
        got.extend_from_slice(&answer[1..8 - usize::from(unused)]);
    }
    assert_eq!(got, name);

    // NMT start: heartbeat 0x05, and the node's value frame at every sample from then on.
    let (after_start, _) = l.sample(&[std_frame(0x000, &[0x01, AGENT]), leader(0)]);
    assert!(
        after_start.iter().any(|f| std_id(f) == Some(VALUE)),
        "a value frame at the tick after the NMT start: {:?}",
        ids(&after_start)
    );
    let seen = l.until(HEARTBEAT, &[0x05], HEARTBEAT_SAMPLES);
    let samples_seen = seen.iter().filter(|f| std_id(f) == Some(VALUE)).count();
    assert!(samples_seen >= 1, "{:?}", ids(&seen));
    let (_, running) = l.sample(&[leader(1)]);
    assert_ne!(
        running.q, [0.0; 2],
        "commands while operational: {running:?}"
    );

    // NMT stop (broadcast): heartbeat 0x04, no value frame, commands zero, no SDO answer.
    let (after_stop, stopped) = l.sample(&[std_frame(0x000, &[0x02, 0]), leader(2)]);
    assert!(
        !after_stop.iter().any(|f| std_id(f) == Some(VALUE)),
        "{:?}",
        ids(&after_stop)
    );
    assert_eq!(stopped.q, [0.0; 2]);
    let seen = l.until(HEARTBEAT, &[0x04], HEARTBEAT_SAMPLES);
    assert!(!seen.iter().any(|f| std_id(f) == Some(VALUE)));
    let (silent, _) = l.sample(&[std_frame(
        0x600 + u16::from(AGENT),
        &[0x40, 0x18, 0x10, 2, 0, 0, 0, 0],
    )]);
    assert!(
        !silent
            .iter()
            .any(|f| std_id(f) == Some(0x580 + u16::from(AGENT))),
        "no SDO in stopped: {:?}",
        ids(&silent)
    );
}

#[test]
#[ignore = "needs qemu-system-arm and the node-fw build; run with --ignored"]
fn overrun_and_watchdog_reset_are_reported_by_emcy() {
    // Two late periods: a step of 1.5 periods overruns but is not reset.
    let mut l = Link::start(2);
    l.sample(&[std_frame(0x000, &[0x01, AGENT])]);
    l.until(HEARTBEAT, &[0x05], HEARTBEAT_SAMPLES);
    let slow = link::slow_periods(1.5).expect("positive");
    let mut seen = l.sample(&[io_frame(io::SLOW, &slow.to_le_bytes())]).0;
    seen.extend(l.sample(&[io_frame(io::SLOW, &0u32.to_le_bytes())]).0);
    for _ in 0..3 {
        seen.extend(l.sample(&[]).0);
    }
    assert!(
        seen.iter().any(|f| f.io_id() == Some(io::OVERRUN)),
        "the slow step overran: {:?}",
        ids(&seen)
    );
    // EMCY 0x6200 (user software), error register 0x81 (generic, manufacturer), cause 4
    // (overrun), overruns since start 1.
    let emcy: Vec<&CanFrame> = seen.iter().filter(|f| std_id(f) == Some(EMCY)).collect();
    assert_eq!(emcy.len(), 1, "{:?}", ids(&seen));
    assert_eq!(emcy[0].data(), [0x00, 0x62, 0x81, 4, 0, 1, 0, 0]);

    // A stopped control task: the watchdog resets the node, which boots again.
    l.write(&{
        let mut out = Vec::new();
        push_frame(&mut out, &io_frame(io::HANG, &[]));
        let mut buf = [0u8; RECORD_MAX_LINE];
        let n = link::tick_encode(
            &Tick {
                x: [1.0, 0.0],
                dt_us: None,
            },
            &mut buf,
        );
        out.extend_from_slice(&buf[..n]);
        out
    });
    l.until_boot();
    l.configure(2);
    // Boot-up and the first heartbeat, then EMCY 0x6100 (watchdog reset), register 0x81,
    // cause 3, before the first tick.
    let (first, _) = l.sample(&[]);
    assert_eq!(
        ids(&first),
        [
            "701#[00]",
            "701#[7f]",
            "081#[00, 61, 81, 03, 00, 01, 00, 00]"
        ]
    );
    // The pre-defined error field 0x1003 keeps it: one entry, 0x6100 as its newest.
    assert_eq!(l.upload(0x1003, 1)[4..8], [0x00, 0x61, 0, 0]);
}

/// `firmware[]` of a run's `summary.json`.
fn firmware_summary(dir: &std::path::Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    v["firmware"].as_array().expect("firmware[]").clone()
}

/// A PIL run of Example 1 with `network.canopen = true`, agent 3 hung at 0.1 s: every node
/// ends operational (host-sim started agent 3 again after its reset), agent 3's one EMCY is
/// its watchdog reset (`0x6100`, cause 3), the others sent none; the trajectory is the one of the same run without `network.canopen`, whose
/// summary has neither key.
#[test]
#[ignore = "needs qemu-system-arm and the node-fw build; run with --ignored"]
fn the_pil_master_reports_nmt_states_and_emcy() {
    assert!(firmware().is_file(), "cd node-fw && cargo build --release");
    let hang = "network.event=[{kind = \"hang\", agent = 3, from = 0.1}]";
    let run = |name: &str, canopen: &str| {
        let dir = tmp(name);
        let out = bin()
            .args(["run", "--quiet", "--no-plots", "--out"])
            .arg(&dir)
            .arg(scenario_path("example1-pil.toml"))
            .args(["--set", "simulation.t_end=0.2", "--set", hang])
            .args(["--set", canopen])
            .output()
            .expect("run host-sim");
        assert_ok(&out);
        dir
    };
    let with = run("pil-canopen-summary", "network.canopen=true");
    let without = run("pil-canopen-summary-off", "network.canopen=false");
    let read = |d: &std::path::Path| std::fs::read(d.join("trajectory.csv")).expect("csv");
    assert_eq!(read(&with), read(&without));
    let fw = firmware_summary(&with);
    assert_eq!(fw.len(), 4);
    for (i, a) in fw.iter().enumerate() {
        assert_eq!(a["nmt_state"], "OPERATIONAL", "agent {}: {a}", i + 1);
        let emcy = a["emcy"].as_array().expect("emcy[]");
        let codes: Vec<(u64, u64)> = emcy
            .iter()
            .map(|e| {
                (
                    e["code"].as_u64().unwrap_or(0),
                    e["cause"].as_u64().unwrap_or(0),
                )
            })
            .collect();
        if i == 2 {
            assert_eq!(a["resets"], 1, "{a}");
            // The hung task never ran again to pass its overruns to the node: the reset's
            // EMCY is the one.
            assert_eq!(codes, [(0x6100, 3)], "{a}");
            assert_eq!(emcy[0]["agent"], 3, "{a}");
        } else {
            assert!(codes.is_empty(), "agent {}: {a}", i + 1);
        }
    }
    for a in firmware_summary(&without) {
        assert!(
            a.get("nmt_state").is_none() && a.get("emcy").is_none(),
            "{a}"
        );
    }
}
