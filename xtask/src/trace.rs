//! The replayed step inputs: agent 4 of Example 1 (hears agents 1 and 3, not pinned) with the
//! quantizer and the intermittent actuator faults on, so level changes and fault windows are in
//! the sequence.
//!
//! Source: a `host-sim` run of `scenarios/example1.toml` (its `trajectory.csv`); when host-sim
//! cannot run, the bench fails with its message rather than measuring something else.
//!
//! Records written for the firmware, little-endian `f32`: `x_1..x_n, y_1, y_3, y_d` per step.
//! `n = 3` has no recorded run; its trace is the `n = 2` one with a synthetic but plausible third
//! state `x_3`: the low-passed rate of `x_2` (what an acceleration state looks like).

use crate::task::{bench_dir, cargo, workspace_root, Result};
use std::{fs, path::Path, process::Command};

/// Sample period \[s\] (Example 1).
pub const H: f64 = 1e-3;
/// Length of the replayed run \[s\]: covers the fault windows [2, 4) and [6, 8).
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

/// Runs `host-sim` on `scenarios/example1.toml` and parses its `trajectory.csv`.
pub fn obtain() -> Result<Trace> {
    let root = workspace_root();
    if !root.join("host-sim/src/main.rs").exists() {
        return Err("host-sim has no binary yet".into());
    }
    let out = bench_dir().join("trace");
    eprintln!(
        "bench: building host-sim (release; a few minutes on a fresh checkout) and running \
         scenarios/example1.toml for the trace"
    );
    let status = Command::new(cargo())
        .current_dir(&root)
        .args(["run", "--release", "-p", "host-sim", "--", "run", "--quiet"])
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
}
