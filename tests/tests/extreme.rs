//! Extreme but valid scenarios: a very short predefined time, ζ close to 1, 50 agents
//! on a line graph, a 10 ms sample period, and all of them at once. Each run either finishes or
//! reports its divergence with time and agent; never a panic, never a NaN or ∞ in
//! `trajectory.csv`, and `summary.json` is always valid JSON. With `EXTREME_OUT=<dir>` each
//! run's `summary.json` is also copied to `<dir>/<run>.json` (docs/RELIABILITY.md, `cargo xtask
//! docs`).

use std::{fmt::Write as _, path::Path};

use integration_tests::{host_sim_bin, scenarios_dir, scratch};

/// `[graph]` and `[plant]` of `n` agents on a line: agent 1 pinned, agent i hears agent i − 1.
fn line_graph(n: usize) -> String {
    let mut s = String::from("[graph]\nneighbours = [[]");
    for i in 1..n {
        let _ = write!(s, ", [{i}]");
    }
    s.push_str("]\npinned = [1]\n\n[plant]\nx0 = [");
    for i in 0..n {
        let sep = if i == 0 { "" } else { ", " };
        // Spread initial states, as in Example 1.
        let _ = write!(
            s,
            "{sep}[{}, {}]",
            0.01 * (i % 5) as f64,
            0.2 * (i % 7) as f64
        );
    }
    s.push_str("]\n");
    s
}

/// Checks one finished run in `out`; returns whether it diverged.
fn check_outputs(name: &str, out: &Path, stdout: &str) -> bool {
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .unwrap_or_else(|e| panic!("{name}: summary.json: {e}"));
    let v: serde_json::Value =
        serde_json::from_str(&summary).unwrap_or_else(|e| panic!("{name}: summary.json: {e}"));
    let diverged = v["diverged"]
        .as_bool()
        .unwrap_or_else(|| panic!("{name}: `diverged` missing"));
    if diverged {
        let d = &v["divergence"];
        let t = d["time"].as_f64();
        let agent = d["agent"].as_u64();
        assert!(
            t.is_some_and(f64::is_finite) && agent.is_some_and(|a| a >= 1),
            "{name}: divergence must give time and agent: {d}"
        );
        assert!(stdout.contains("DIVERGED at t = "), "{name}: {stdout}");
    } else {
        assert!(v["divergence"].is_null(), "{name}");
    }
    // Every number in the summary is finite (serde_json cannot even write NaN; be explicit).
    fn finite(name: &str, v: &serde_json::Value) {
        match v {
            serde_json::Value::Number(n) => {
                assert!(n.as_f64().is_some_and(f64::is_finite), "{name}: {n}")
            }
            serde_json::Value::Array(a) => a.iter().for_each(|x| finite(name, x)),
            serde_json::Value::Object(o) => o.values().for_each(|x| finite(name, x)),
            _ => {}
        }
    }
    finite(name, &v);
    if let Some(load) = v["network"]["bus_load_percent"].as_f64() {
        assert!((0.0..=100.0).contains(&load), "{name}: bus load {load} %");
    }
    let csv = std::fs::read_to_string(out.join("trajectory.csv"))
        .unwrap_or_else(|e| panic!("{name}: trajectory.csv: {e}"));
    let mut lines = csv.lines();
    let header = lines.next().unwrap_or_else(|| panic!("{name}: empty CSV"));
    let cols = header.split(',').count();
    let mut rows = 0;
    for (r, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), cols, "{name}: row {} is ragged", r + 2);
        for (c, cell) in cells.iter().enumerate() {
            let ok = cell.parse::<f64>().is_ok_and(f64::is_finite);
            assert!(
                ok,
                "{name}: row {}, column `{}`: `{cell}` is not a finite number",
                r + 2,
                header.split(',').nth(c).unwrap_or("?")
            );
        }
        rows += 1;
    }
    assert!(rows > 0, "{name}: no rows");
    // No temporary file left behind.
    let tmp: Vec<_> = std::fs::read_dir(out)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert!(
        tmp.iter().all(|f| !f.to_string_lossy().contains(".tmp")),
        "{name}: temporary files left: {tmp:?}"
    );
    diverged
}

fn run(name: &str, scenario: &Path, sets: &[&str]) -> bool {
    let out = scratch(&format!("extreme-{name}"));
    let mut cmd = std::process::Command::new(host_sim_bin());
    cmd.arg("run")
        .arg(scenario)
        .arg("--out")
        .arg(&out)
        .arg("--no-plots")
        .env("RUST_BACKTRACE", "1");
    for s in sets {
        cmd.args(["--set", s]);
    }
    let r = cmd.output().unwrap_or_else(|e| panic!("{name}: {e}"));
    let stderr = String::from_utf8_lossy(&r.stderr);
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert_eq!(r.status.code(), Some(0), "{name}: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    let d = check_outputs(name, &out, &stdout);
    println!("{name}: {}", stdout.lines().next().unwrap_or(""));
    if let Some(dir) = std::env::var_os("EXTREME_OUT") {
        let dir = Path::new(&dir);
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("EXTREME_OUT: {e}"));
        std::fs::copy(out.join("summary.json"), dir.join(format!("{name}.json")))
            .unwrap_or_else(|e| panic!("EXTREME_OUT: {e}"));
    }
    d
}

#[test]
fn extreme_valid_scenarios_run_or_report_divergence() {
    let ex1 = scenarios_dir().join("example1.toml");
    let ex2 = scenarios_dir().join("example2.toml");
    let dir = scratch("extreme-scenarios");
    let line50 = dir.join("line50.toml");
    let text = format!("name = \"line50\"\n\n{}", line_graph(50));
    std::fs::write(&line50, text).unwrap_or_else(|e| panic!("{e}"));

    // Short horizons: the binary runs unoptimised here.
    run(
        "ts-0.05",
        &ex1,
        &["controller.ts=0.05", "simulation.t_end=0.5"],
    );
    run(
        "zeta-0.99",
        &ex1,
        &["controller.zeta=0.99", "simulation.t_end=0.5"],
    );
    run("line-50", &line50, &["simulation.t_end=0.3"]);
    // Example 1's largest stable h is 6.79 ms: 10 ms is beyond it.
    run("h-10ms", &ex1, &["simulation.h=0.01", "simulation.t_end=3"]);
    // Example 2 at 10 ms (its largest stable h is 0.415 ms): must diverge, reported.
    let d = run(
        "ex2-h-10ms",
        &ex2,
        &["simulation.h=0.01", "simulation.t_end=2"],
    );
    assert!(d, "Example 2 at h = 10 ms is expected to diverge");
    // The largest divergence bound allowed (f32::MAX): states up to the limit of the
    // controllers' type; outputs must stay finite all the same.
    run(
        "ex2-h-10ms-bound-3e38",
        &ex2,
        &[
            "simulation.h=0.01",
            "simulation.t_end=2",
            "simulation.divergence_bound=3e38",
            "simulation.substeps=1",
        ],
    );
    // 50 firmware nodes over a 500 kbit/s CAN bus with 10 % loss: the bus cannot carry 51
    // frames per 1 ms sample (deadline misses, stale links); the run must still finish.
    run(
        "line-50-can-500k-lossy",
        &line50,
        &[
            "network.kind=can",
            "network.bitrate=500000",
            "network.loss=0.1",
            "network.seed=7",
            "simulation.t_end=0.2",
        ],
    );
    // All at once.
    run(
        "all-at-once",
        &line50,
        &[
            "controller.ts=0.05",
            "controller.zeta=0.99",
            "simulation.h=0.01",
            "simulation.t_end=2",
        ],
    );
}
