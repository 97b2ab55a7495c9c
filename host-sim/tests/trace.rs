//! `--trace`: the candump log of a CAN run decodes, with `docs/wire.dbc` and Python's cantools,
//! back to the values in `trajectory.csv` (within the Q7.16 resolution). The Python check needs
//! `cantools` and `python-can`, so it is `#[ignore]`d with that reason and fails when run without
//! them: `cargo test -p host-sim --test trace -- --ignored` (`.ci/run` does).

mod common;

use std::{path::PathBuf, process::Command};

use common::{assert_invalid, assert_ok, bin, require_python, scenario_path, tmp};

/// 0.3 s of Example 1 over CAN with `--trace`: the trajectory directory and the trace.
fn traced_can_run(name: &str) -> (PathBuf, PathBuf) {
    let dir = tmp(name);
    let trace = dir.join("bus.log");
    let out = bin()
        .args(["run", "--quiet", "--no-plots", "--out"])
        .arg(&dir)
        .arg(scenario_path("example1-can.toml"))
        .args(["--set", "simulation.t_end=0.3", "--trace"])
        .arg(&trace)
        .output()
        .expect("run host-sim");
    assert_ok(&out);
    let log = std::fs::read_to_string(&trace).expect("trace written");
    let lines: Vec<&str> = log.lines().collect();
    // 5 frames per sample, the last sample's still on the bus.
    assert_eq!(lines.len(), 299 * 5);
    assert_eq!(lines[0], "(0.000092) can0 101#00000000");
    assert!(lines[1].starts_with("(0.000187) can0 102#"), "{}", lines[1]);
    (dir, trace)
}

#[test]
fn can_trace_has_five_frames_per_sample() {
    traced_can_run("trace-can");
}

#[test]
#[ignore = "needs python3 with cantools and python-can; run with --ignored"]
fn can_trace_decodes_to_the_trajectory_with_cantools() {
    require_python("can, cantools", "pip install cantools python-can");
    let (dir, trace) = traced_can_run("trace-can-cantools");
    let dbc = common::wire_dbc();
    let py = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/decode_trace.py");
    let check = Command::new("python3")
        .arg(py)
        .arg(dbc)
        .arg(&trace)
        .arg(dir.join("trajectory.csv"))
        .args(["0.001", "4"])
        .output()
        .expect("run python3");
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(
        stdout.contains("decoded 1495 frames over 299 samples"),
        "{stdout}"
    );
}

#[test]
fn trace_needs_a_bus() {
    let dir = tmp("trace-ideal");
    let out = bin()
        .args(["run", "--quiet", "--no-plots", "--out"])
        .arg(&dir)
        .arg(scenario_path("example1.toml"))
        .arg("--trace")
        .arg(dir.join("bus.log"))
        .output()
        .expect("run host-sim");
    assert_invalid(&out, "--trace");
}
