//! Shared by the integration tests: a minimal Example 1 plant (LAW §8; RK4, 4 substeps, the
//! intermittent faults), an ideal-link loop, a loop over the CAN network, and a log capture.
#![allow(dead_code)]

use std::cell::RefCell;

use agent_node::{NodeConfig, NodeStats, Tick};
use controller_core::{Controller, ControllerConfig, Link};
use hil_mock::bus::{BusConfig, BusStats, Nanos};
use hil_mock::network::{AgentSetup, CanNetwork};

pub const H: f64 = 1e-3;
pub const H_NS: Nanos = 1_000_000;
const SUBSTEPS: usize = 4;
/// Agent i (0-based) hears these agents (0-based); agent 0 is pinned.
pub const NEIGHBOURS: [&[usize]; 4] = [&[], &[0], &[0], &[0, 2]];
const X0: [[f64; 2]; 4] = [[0.02, 0.8], [0.01, 1.0], [0.01, 0.09], [0.0, 0.7]];

fn faults_active(t: f64) -> bool {
    t >= 2.0 && (t - 2.0).rem_euclid(4.0) < 2.0
}

fn plant(t: f64, x: [f64; 2], q: [f64; 2]) -> [f64; 2] {
    let (a1, a2) = if faults_active(t) {
        (0.5 * q[0], t.sin())
    } else {
        (q[0], q[1])
    };
    [
        x[1] + 0.8 * x[0].powi(3),
        a1 + a2 - 2.0 * x[0] * x[0] + x[1].powi(3) + t.cos(),
    ]
}

fn rk4(t: f64, x: [f64; 2], q: [f64; 2], dt: f64) -> [f64; 2] {
    let add = |x: [f64; 2], k: [f64; 2], s: f64| [x[0] + s * k[0], x[1] + s * k[1]];
    let k1 = plant(t, x, q);
    let k2 = plant(t + dt / 2.0, add(x, k1, dt / 2.0), q);
    let k3 = plant(t + dt / 2.0, add(x, k2, dt / 2.0), q);
    let k4 = plant(t + dt, add(x, k3, dt), q);
    [
        x[0] + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
        x[1] + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
    ]
}

/// Hold `q` over one sample period from `t`.
pub fn integrate(t: f64, x: &mut [f64; 2], q: [f32; 2]) {
    let q = [f64::from(q[0]), f64::from(q[1])];
    let dt = H / SUBSTEPS as f64;
    for s in 0..SUBSTEPS {
        *x = rk4(t + s as f64 * dt, *x, q, dt);
    }
}

pub fn yd(t: f64) -> f64 {
    0.6 * (2.0 * t).sin()
}

pub fn controller_config(i: usize) -> ControllerConfig<2> {
    ControllerConfig::<2> {
        neighbour_count: NEIGHBOURS[i].len(),
        pinned: i == 0,
        ..ControllerConfig::default()
    }
}

/// With `HIL_MOCK_FIGURES_OUT=<dir>`, writes `<dir>/<name>.json`: the run's figures and
/// `extra`, for `cargo xtask docs` (docs/NETWORK.md §3, §5).
pub fn record(name: &str, r: Option<&CanRun>, extra: &[(&str, f64)]) {
    let Some(dir) = std::env::var_os("HIL_MOCK_FIGURES_OUT") else {
        return;
    };
    let mut v = serde_json::Map::new();
    if let Some(r) = r {
        let b = &r.bus;
        let sum = |f: fn(&NodeStats) -> u32| r.nodes.iter().map(f).sum::<u32>();
        let figures = serde_json::json!({
            "max_error": r.max_error,
            "max_state": r.max_state,
            "diverged_at": r.diverged_at,
            "load_percent": b.load_percent(),
            "frames_sent": b.frames_sent,
            "frames_lost": b.frames_lost,
            "frames_corrupted": b.frames_corrupted,
            "deadline_misses": b.deadline_misses,
            "bus_off_events": b.bus_off_events,
            "max_tec": b.nodes.iter().map(|n| n.max_tec).max().unwrap_or(0),
            "babble_frames": b.babble_frames,
            "suppressed": b.suppressed,
            "max_age_s": b.max_age_s(),
            "mean_age_s": b.mean_age_s(),
            "max_latency_s": b.max_latency_ns as f64 * 1e-9,
            "seq_gaps": sum(|n| n.seq_gaps),
            "stale_samples": sum(|n| n.stale_samples),
            "malformed": sum(|n| n.malformed.total()),
        });
        if let serde_json::Value::Object(m) = figures {
            v.extend(m);
        }
    }
    for (k, x) in extra {
        v.insert((*k).to_owned(), serde_json::json!(x));
    }
    let dir = std::path::PathBuf::from(dir);
    std::fs::create_dir_all(&dir).expect("HIL_MOCK_FIGURES_OUT is writable");
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, serde_json::Value::Object(v).to_string())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// Max |y_i − y_d| over samples with t ≥ t_from, the ideal link (every value fresh, no delay).
pub fn run_ideal(t_end: f64, t_from: f64) -> f64 {
    let mut ctrls: Vec<Controller<2, 2, 4>> = (0..4)
        .map(|i| Controller::new(&controller_config(i)).expect("valid Example 1 config"))
        .collect();
    let mut x = X0;
    let steps = (t_end / H).round() as usize;
    let mut worst: f64 = 0.0;
    for k in 0..steps {
        let t = k as f64 * H;
        if t >= t_from {
            for xi in &x {
                worst = worst.max((xi[0] - yd(t)).abs());
            }
        }
        let ys: Vec<f32> = x.iter().map(|xi| xi[0] as f32).collect();
        let mut qs = [[0.0f32; 2]; 4];
        for (i, c) in ctrls.iter_mut().enumerate() {
            let links: Vec<Link> = NEIGHBOURS[i].iter().map(|&k| Link::Fresh(ys[k])).collect();
            let xi = [x[i][0] as f32, x[i][1] as f32];
            qs[i] = c.step(&xi, &links, Link::Fresh(yd(t) as f32)).q;
        }
        for (xi, q) in x.iter_mut().zip(qs) {
            integrate(t, xi, q);
        }
    }
    worst
}

/// What a CAN run measured.
#[derive(Debug, Clone)]
pub struct CanRun {
    /// Max |y_i − y_d| over t ≥ t_from.
    pub max_error: f64,
    /// Max |y_i − y_d| over t ≥ t_from, per agent.
    pub max_error_per_agent: [f64; 4],
    /// Max |x| over the whole run (boundedness).
    pub max_state: f64,
    pub bus: BusStats,
    pub nodes: Vec<NodeStats>,
    pub controller_faults: u32,
    /// The plant left |x| < 1e6 (or became non-finite) at this time; the run stopped there.
    pub diverged_at: Option<f64>,
}

/// Example 1 over the CAN network: `t_end` seconds, error measured from `t_from`; `observe`
/// sees every sample's time, states and ticks.
pub fn run_can(
    bus: BusConfig,
    stale_timeout_us: u64,
    t_end: f64,
    t_from: f64,
    mut observe: impl FnMut(f64, &[[f64; 2]; 4], &[Tick<2, 2>], &CanNetwork<2, 2, 4>),
) -> CanRun {
    let agents: Vec<AgentSetup<2, 4>> = (0..4)
        .map(|i| {
            let mut neighbours = [0u8; 4];
            for (slot, &k) in neighbours.iter_mut().zip(NEIGHBOURS[i]) {
                *slot = k as u8 + 1;
            }
            AgentSetup {
                node: NodeConfig::new(i as u8 + 1, neighbours, stale_timeout_us),
                controller: controller_config(i),
            }
        })
        .collect();
    let mut net = CanNetwork::<2, 2, 4>::new(bus, &agents).expect("valid network");
    let mut x = X0;
    let steps = (t_end / H).round() as u64;
    let mut worst = [0.0f64; 4];
    let mut max_state: f64 = 0.0;
    let mut faults = 0;
    let mut diverged_at = None;
    for k in 0..steps {
        let t = k as f64 * H;
        if t >= t_from {
            for (w, xi) in worst.iter_mut().zip(&x) {
                *w = w.max((xi[0] - yd(t)).abs());
            }
        }
        let states: Vec<[f32; 2]> = x.iter().map(|xi| [xi[0] as f32, xi[1] as f32]).collect();
        let ticks = net.step(k * H_NS, &states, Some(yd(t) as f32));
        faults += ticks
            .iter()
            .filter(|t| t.output.status.fault.is_some())
            .count() as u32;
        observe(t, &x, &ticks, &net);
        for (i, xi) in x.iter_mut().enumerate() {
            integrate(t, xi, net.nodes()[i].actuator().q);
            max_state = max_state.max(xi[0].abs()).max(xi[1].abs());
        }
        if !x.iter().flatten().all(|v| v.is_finite() && v.abs() < 1e6) {
            diverged_at = Some(t);
            break;
        }
    }
    CanRun {
        max_error: worst.iter().copied().fold(0.0, f64::max),
        max_error_per_agent: worst,
        max_state,
        bus: net.stats(),
        nodes: net.nodes().iter().map(|n| *n.stats()).collect(),
        controller_faults: faults,
        diverged_at,
    }
}

thread_local! {
    static LINES: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) };
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        let line = format!("{} {}", record.level(), record.args());
        LINES.with(|l| l.borrow_mut().push(line));
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture;

/// Install the capturing logger (once per test binary); lines are kept per thread.
pub fn capture_logs() {
    let _ = log::set_logger(&CAPTURE);
    log::set_max_level(log::LevelFilter::Debug);
    LINES.with(|l| l.borrow_mut().clear());
}

/// The lines logged on this thread since [`capture_logs`].
pub fn logged() -> Vec<String> {
    LINES.with(|l| l.borrow().clone())
}
