//! The replayed step inputs: agent 4 of Example 1 (hears agents 1 and 3, not pinned) with the
//! quantizer and the intermittent actuator faults on, so level changes and fault windows are in
//! the sequence.
//!
//! Preferred source: a `host-sim` run of `scenarios/example1.toml` (its `trajectory.csv`).
//! Fallback: a minimal Example 1 closed loop built in (the approach of
//! `controller-core/tests/closed_loop.rs`: four `controller-core` agents, RK4 plant, 4 substeps).
//!
//! Records written for the firmware, little-endian `f32`: `x_1..x_n, y_1, y_3, y_d` per step.
//! `n = 3` has no recorded run; its trace is the `n = 2` one with a synthetic but plausible third
//! state `x_3`: the low-passed rate of `x_2` (what an acceleration state looks like).

use crate::{bench_dir, cargo, workspace_root, Result, TraceSource};
use controller_core::{Controller, ControllerConfig, Link};
use std::{fs, path::Path, process::Command};

/// Sample period [s] (Example 1).
pub const H: f64 = 1e-3;
/// Length of the replayed run [s]: covers the fault windows [2, 4) and [6, 8).
pub const T_END: f64 = 10.0;

/// One step's inputs of agent 4: own state, neighbours 1 and 3, leader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub x: [f64; 2],
    pub y1: f64,
    pub y3: f64,
    pub yd: f64,
}

/// The recorded sequence and where it came from.
#[derive(Debug, Clone)]
pub struct Trace {
    pub source: String,
    pub samples: Vec<Sample>,
}

/// Obtains the trace per `source`.
pub fn obtain(source: TraceSource) -> Result<Trace> {
    match source {
        TraceSource::Fallback => Ok(fallback()),
        TraceSource::HostSim => host_sim(),
        TraceSource::Auto => match host_sim() {
            Ok(t) => Ok(t),
            Err(e) => {
                eprintln!("note: host-sim trace unavailable ({e}); using the built-in Example 1 closed loop");
                Ok(fallback())
            }
        },
    }
}

/// Runs `host-sim` and parses its `trajectory.csv`.
fn host_sim() -> Result<Trace> {
    let root = workspace_root();
    if !root.join("host-sim/src/main.rs").exists() {
        return Err("host-sim has no binary yet".into());
    }
    let out = bench_dir().join("trace");
    let status = Command::new(cargo())
        .current_dir(&root)
        .args(["run", "--quiet", "--release", "-p", "host-sim", "--", "run"])
        .arg("scenarios/example1.toml")
        .arg("--out")
        .arg(&out)
        .args(["--set", &format!("simulation.t_end={T_END}")])
        .args(["--set", &format!("simulation.h={H}")])
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("host-sim run failed ({status})"));
    }
    let csv = out.join("trajectory.csv");
    let text = fs::read_to_string(&csv).map_err(|e| format!("{}: {e}", csv.display()))?;
    let samples = parse_trajectory(&text)?;
    Ok(Trace {
        source: "host-sim run scenarios/example1.toml".into(),
        samples,
    })
}

/// Columns `t, yd, y1, y3, x4_1, x4_2` of a host-sim trajectory, one row per sample.
pub fn parse_trajectory(text: &str) -> Result<Vec<Sample>> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or("empty trajectory.csv")?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| format!("trajectory.csv has no column `{name}`"))
    };
    let (ct, cyd, cy1, cy3, cx1, cx2) = (
        col("t")?,
        col("yd")?,
        col("y1")?,
        col("y3")?,
        col("x4_1")?,
        col("x4_2")?,
    );
    let mut samples = Vec::new();
    let mut prev_t: Option<f64> = None;
    for (row, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let get = |c: usize| -> Result<f64> {
            f.get(c)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .ok_or_else(|| format!("trajectory.csv row {}: bad value in column {c}", row + 2))
        };
        let t = get(ct)?;
        if let Some(p) = prev_t {
            if ((t - p) - H).abs() > 1e-6 {
                return Err(format!(
                    "trajectory.csv is not sampled every step (t = {p} then {t}); the trace needs every sample"
                ));
            }
        }
        prev_t = Some(t);
        samples.push(Sample {
            x: [get(cx1)?, get(cx2)?],
            y1: get(cy1)?,
            y3: get(cy3)?,
            yd: get(cyd)?,
        });
    }
    if samples.is_empty() {
        return Err("trajectory.csv has no rows".into());
    }
    Ok(samples)
}

/// Agent `i` (0-based) hears these agents; agent 0 is pinned (SPEC §8).
const NEIGHBOURS: [&[usize]; 4] = [&[], &[0], &[0], &[0, 2]];
const X0: [[f64; 2]; 4] = [[0.02, 0.8], [0.01, 1.0], [0.01, 0.09], [0.0, 0.7]];
const SUBSTEPS: usize = 4;

fn faults_active(t: f64) -> bool {
    t >= 2.0 && (t - 2.0).rem_euclid(4.0) < 2.0
}

/// Example 1's plant with the faults of SPEC §8.
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

/// The built-in Example 1 closed loop (`T_s = 2`, quantizer and faults on), recording agent 4.
pub fn fallback() -> Trace {
    let mut ctrls: Vec<Controller<2, 2, 4>> = NEIGHBOURS
        .iter()
        .enumerate()
        .filter_map(|(i, n)| {
            let cfg = ControllerConfig::<2> {
                neighbour_count: n.len(),
                pinned: i == 0,
                ..ControllerConfig::default()
            };
            Controller::new(&cfg).ok()
        })
        .collect();
    let mut x = X0;
    let steps = (T_END / H).round() as usize;
    let mut samples = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = k as f64 * H;
        let yd = 0.6 * (2.0 * t).sin();
        samples.push(Sample {
            x: x[3],
            y1: x[0][0],
            y3: x[2][0],
            yd,
        });
        let ys: Vec<f32> = x.iter().map(|xi| xi[0] as f32).collect();
        let mut qs = [[0.0f64; 2]; 4];
        for (i, c) in ctrls.iter_mut().enumerate() {
            let links: Vec<Link> = NEIGHBOURS[i].iter().map(|&k| Link::Fresh(ys[k])).collect();
            let out = c.step(
                &[x[i][0] as f32, x[i][1] as f32],
                &links,
                Link::Fresh(yd as f32),
            );
            qs[i] = [f64::from(out.q[0]), f64::from(out.q[1])];
        }
        let dt = H / SUBSTEPS as f64;
        for (xi, q) in x.iter_mut().zip(&qs) {
            for s in 0..SUBSTEPS {
                *xi = rk4(t + s as f64 * dt, *xi, *q, dt);
            }
        }
    }
    Trace {
        source: "built-in Example 1 closed loop (xtask/src/trace.rs)".into(),
        samples,
    }
}

/// Writes the `n = 2` records and the `n = 3` records (synthetic `x_3`); returns their paths.
pub fn write(trace: &Trace, dir: &Path) -> Result<(std::path::PathBuf, std::path::PathBuf)> {
    fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut n2 = Vec::new();
    let mut n3 = Vec::new();
    let mut x3 = 0.0f64;
    let mut prev_x2 = trace.samples.first().map_or(0.0, |s| s.x[1]);
    // First-order low-pass of the rate of x_2, time constant 20 ms.
    let a = H / (0.02 + H);
    for s in &trace.samples {
        x3 += a * ((s.x[1] - prev_x2) / H - x3);
        prev_x2 = s.x[1];
        for v in [s.x[0], s.x[1], s.y1, s.y3, s.yd] {
            n2.extend_from_slice(&(v as f32).to_le_bytes());
        }
        for v in [s.x[0], s.x[1], x3, s.y1, s.y3, s.yd] {
            n3.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    let (p2, p3) = (dir.join("trace-n2.f32le"), dir.join("trace-n3.f32le"));
    write_if_changed(&p2, &n2)?;
    write_if_changed(&p3, &n3)?;
    Ok((p2, p3))
}

/// Leaves the file (and so the firmware build) alone when the content is the same.
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<()> {
    if fs::read(path).is_ok_and(|old| old == bytes) {
        return Ok(());
    }
    fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_host_sim_columns() {
        let csv = "t,yd,y1,y2,y3,y4,x4_1,x4_2\n0,0,0.02,0.01,0.01,0,0,0.7\n0.001,0.0012,0.021,0.011,0.0101,0.0007,0.0007,0.69\n";
        let s = parse_trajectory(csv).unwrap_or_default();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].x, [0.0007, 0.69]);
        assert_eq!((s[1].y1, s[1].y3, s[1].yd), (0.021, 0.0101, 0.0012));
        assert!(parse_trajectory("t,yd\n0,0\n").is_err());
    }

    #[test]
    fn fallback_exercises_quantizer_and_faults() {
        let t = fallback();
        assert_eq!(t.samples.len(), (T_END / H).round() as usize);
        assert!(t.samples.iter().all(|s| s.x.iter().all(|v| v.is_finite())));
        // Agent 4 ends up near the leader.
        let last = t.samples.last().map_or(f64::NAN, |s| (s.x[0] - s.yd).abs());
        assert!(last < 0.3, "agent 4 error at the end = {last}");
    }
}
