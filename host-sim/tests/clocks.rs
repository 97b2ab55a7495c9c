//! `[clock]`: without it, or with every value zero and `sync = "none"`, every output file is
//! byte-identical; a drift moves a follower's samples at exactly its rate; bad keys are named.

mod common;

use std::{collections::BTreeMap, path::Path};

use common::{assert_invalid, assert_ok, bin, scenario_path, tmp};

/// Every file under `dir`, by relative path.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir).expect("output dir") {
        let p = e.expect("entry").path();
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        out.insert(name.unwrap_or_default(), std::fs::read(&p).expect("file"));
    }
    out
}

/// `host-sim run` of `scenario` for 1 s with `sets`, into a fresh `dir`; its files (the
/// figures only with `plots`).
fn run(scenario: &str, dir: &str, sets: &[&str], plots: bool) -> BTreeMap<String, Vec<u8>> {
    let out = tmp(dir);
    let mut cmd = bin();
    cmd.arg("run")
        .arg(scenario_path(scenario))
        .arg("--out")
        .arg(&out)
        .args(["--set", "simulation.t_end=1"]);
    if !plots {
        cmd.arg("--no-plots");
    }
    for s in sets {
        cmd.args(["--set", s]);
    }
    assert_ok(&cmd.output().expect("host-sim runs"));
    files(&out)
}

fn summary(files: &BTreeMap<String, Vec<u8>>) -> serde_json::Value {
    serde_json::from_slice(&files["summary.json"]).expect("summary.json")
}

#[test]
fn zero_clocks_give_byte_identical_outputs() {
    for scenario in ["example1.toml", "example1-can.toml"] {
        let plain = run(scenario, &format!("zero-plain-{scenario}"), &[], true);
        assert!(plain.contains_key("trajectory.csv") && plain.contains_key("summary.json"));
        let zero = [
            &[
                "clock.drift_ppm=0",
                "clock.jitter_us=0",
                "clock.offset_us=0",
            ][..],
            &[
                "clock.drift_ppm=[0, 0, 0, 0]",
                "clock.jitter_us=[0, 0, 0, 0]",
                "clock.offset_us=[0.0, 0.0, 0.0, 0.0]",
                "clock.sync=\"none\"",
                "clock.seed=9",
                "clock.draw=\"uniform\"",
            ][..],
        ];
        for (n, sets) in zero.iter().enumerate() {
            let clocked = run(scenario, &format!("zero-{n}-{scenario}"), sets, true);
            assert_eq!(
                plain.keys().collect::<Vec<_>>(),
                clocked.keys().collect::<Vec<_>>(),
                "{scenario} {sets:?}"
            );
            for (name, bytes) in &plain {
                assert!(
                    bytes == &clocked[name],
                    "{scenario} {sets:?}: {name} differs"
                );
            }
        }
    }
}

#[test]
fn a_100_ppm_drift_moves_the_sampling_instants_at_that_rate() {
    // Agent 1's clock is 100 ppm slow, the others exact: its sample k comes k h 1e-4 late,
    // so over 1 s (1000 samples of 1 ms) the largest sampling-instant error is 999 × 1e-4
    // samples, and every other sample is on time.
    for scenario in ["example1.toml", "example1-can.toml"] {
        let s = summary(&run(
            scenario,
            &format!("drift-{scenario}"),
            &["clock.drift_ppm=[100, 0, 0, 0]"],
            false,
        ));
        let e = &s["clock"]["sampling_error"];
        let max = e["max"].as_f64().expect("max");
        assert!((max - 999.0 * 1e-4).abs() < 1e-9, "{scenario}: {max}");
        assert_eq!(e["median"].as_f64(), Some(0.0), "{scenario}");
        // Agent 1 takes 1000 samples in [0, 1 s) when 100 ppm slow: 999 × 1.0001 ms < 1 s.
        assert_eq!(
            s["clock"]["samples_taken"].as_u64(),
            Some(4000),
            "{scenario}"
        );
        assert_eq!(s["diverged"].as_bool(), Some(false));
    }
}

#[test]
fn ideal_leader_sync_without_jitter_samples_on_the_plant_instants() {
    let s = summary(&run(
        "example1.toml",
        "sync-ideal",
        &[
            "clock.sync=\"leader\"",
            "clock.drift_ppm=[1000, -1000, 500, 0]",
        ],
        false,
    ));
    let c = &s["clock"];
    assert_eq!(c["sync"].as_str(), Some("leader"));
    assert_eq!(c["sampling_error"]["max"].as_f64(), Some(0.0));
}

#[test]
fn clock_figure_is_drawn() {
    let f = run("example1-can.toml", "figure", &["clock.jitter_us=50"], true);
    assert!(f.contains_key("clocks.png") && f.contains_key("clocks.svg"));
    let s = summary(&f);
    let units = &s["units"];
    assert_eq!(units["clock.sample_age.p99"].as_str(), Some("samples"));
    let p99 = s["clock"]["sampling_error"]["p99"].as_f64().expect("p99");
    assert!(p99 > 0.0 && p99 < 0.05, "{p99}");
}

#[test]
fn bad_clock_keys_are_named() {
    let check = |scenario: &str, set: &str, key: &str| {
        let out = bin()
            .arg("check")
            .arg(scenario_path(scenario))
            .args(["--set", set])
            .output()
            .expect("host-sim runs");
        assert_invalid(&out, key);
    };
    check("example1.toml", "clock.drift_ppm=[1, 2]", "clock.drift_ppm");
    check("example1.toml", "clock.jitter_us=-1", "clock.jitter_us");
    check("example1.toml", "clock.jitter_us=950", "clock.jitter_us");
    check("example1.toml", "clock.drift_ppm=nan", "clock.drift_ppm");
    check(
        "example1.toml",
        "clock.offset_us=[0, inf, 0, 0]",
        "clock.offset_us[2]",
    );
    check("example1.toml", "clock.sync=\"both\"", "clock.sync");
    check(
        "example1.toml",
        "clock.drift_ppm=\"fast\"",
        "clock.drift_ppm",
    );
    check("example1-pil.toml", "clock.jitter_us=5", "clock");
}

#[test]
fn a_clocked_run_still_detects_divergence() {
    // Gains that overflow (T_s = 1 ms) make Example 1 diverge within 0.2 s, as without clocks.
    let out = tmp("diverge");
    let run = bin()
        .arg("run")
        .arg(scenario_path("example1.toml"))
        .arg("--out")
        .arg(&out)
        .args(["--no-plots", "-q"])
        .args([
            "--set",
            "simulation.t_end=0.2",
            "--set",
            "controller.ts=0.001",
        ])
        .args(["--set", "clock.jitter_us=100", "--set", "clock.seed=3"])
        .output()
        .expect("host-sim runs");
    assert_ok(&run);
    let s = summary(&files(&out));
    assert_eq!(s["diverged"].as_bool(), Some(true), "{s}");
    let t = s["divergence"]["time"].as_f64().expect("divergence time");
    assert!(t > 0.0 && t < 0.2, "{t}");
    assert!(s["clock"].is_object());
}
