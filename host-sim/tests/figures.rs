//! The figures carry what a reader needs (checked in the SVG text; the PNGs were looked at):
//! the band, the predefined time(s), units, fault windows, proper symbols, clipped-peak notes.

mod common;

use std::path::Path;

use common::{bin, scenario_path, tmp};

fn run(args: &[&str], dir: &Path) {
    let out = bin()
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .expect("host-sim");
    common::assert_ok(&out);
}

fn svg(dir: &Path, stem: &str) -> String {
    for ext in ["png", "svg"] {
        let f = dir.join(format!("{stem}.{ext}"));
        assert!(std::fs::metadata(&f).is_ok_and(|m| m.len() > 0), "{f:?}");
    }
    std::fs::read_to_string(dir.join(format!("{stem}.svg"))).expect("svg")
}

fn assert_has(text: &str, what: &[&str], file: &str) {
    for w in what {
        assert!(text.contains(w), "{file} should show {w:?}");
    }
}

#[test]
fn run_figures_show_band_predefined_time_units_faults_and_symbols() {
    let dir = tmp("figures-run");
    let e2 = scenario_path("example2.toml");
    let e2 = e2.to_str().expect("path");
    run(&["run", e2, "--set", "simulation.t_end=3", "--quiet"], &dir);
    assert_has(
        &svg(&dir, "tracking"),
        &["2Tₛ = 1 s", "output y [rad]", "y_d (leader)", "y₂"],
        "tracking",
    );
    assert_has(
        &svg(&dir, "errors"),
        &[
            "±b = ±0.05",
            "2Tₛ = 1 s",
            "yᵢ − y_d [rad]",
            "log scale",
            "b = 0.05",
        ],
        "errors",
    );
    let inputs = svg(&dir, "inputs");
    assert_has(
        &inputs,
        &[
            "u, q [N·m]",
            "u − q [N·m]",
            "actuator 1 fault: partial loss",
            "actuator 2 fault: total loss",
            "(clipped)",
            "(identical)",
        ],
        "inputs",
    );
    // Example 2's start-up spike of 16,519 N·m at the first sample after t = 0 (trajectory.csv)
    // is written, not drawn to scale, with its exact time although the curve is decimated.
    assert!(
        inputs.contains("peak −16519 at t = 0.0002 s"),
        "inputs: the clipped peak"
    );
    let est = svg(&dir, "estimates");
    assert_has(&est, &["μ\u{302}", "ξ\u{302}", "λ\u{302}"], "estimates");
    assert!(
        !est.contains("mu_hat") && !est.contains("-0.0<"),
        "estimates: ASCII names or -0.0"
    );
}

#[test]
fn compare_figure_draws_each_schemes_own_deadline() {
    let dir = tmp("figures-compare");
    let a = scenario_path("example2.toml");
    let b = scenario_path("example2-baseline.toml");
    run(
        &[
            "compare",
            a.to_str().expect("path"),
            b.to_str().expect("path"),
            "--set",
            "simulation.t_end=2.5",
            "--quiet",
        ],
        &dir,
    );
    assert_has(
        &svg(&dir, "compare"),
        &[
            "2Tₛ (example2) = t_prescribed (example2-baseline) = 1 s: common instant",
            "example2-baseline: peak −27337",
            "u₁ [N·m]",
        ],
        "compare",
    );
}
