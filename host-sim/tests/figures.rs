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

/// `host-sim run` of Example 1 with `--set` for each of `sets`, then `flags`, quiet.
fn run_example1(sets: &[&str], flags: &[&str], dir: &Path) {
    let e1 = scenario_path("example1.toml");
    let mut args = vec!["run", e1.to_str().expect("path")];
    for s in sets {
        args.extend(["--set", s]);
    }
    args.extend(flags);
    args.push("--quiet");
    run(&args, dir);
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
            "u, q, qᶠ [N·m]",
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
            "2Tₛ of predefined-time (proposed) = T of prescribed-time [39] = 1 s: common instant",
            "prescribed-time [39]: peak −27337",
            "u₁ [N·m]",
        ],
        "compare",
    ); // The paper's Fig. 8: (a) the prescribed-time baseline, (b) the predefined-time scheme, each
       // with every output and the leader.
    assert_has(
        &svg(&dir, "compare-outputs"),
        &[
            "(a) prescribed-time [39]: outputs yᵢ and leader y_d",
            "(b) predefined-time (proposed): outputs yᵢ and leader y_d",
            "y₂",
            "common instant",
        ],
        "compare-outputs",
    );
}

/// `qf{i}_{l}` is `q{i}_{l}` outside the fault windows and what the fault makes of it inside:
/// Example 1's actuator 1 at half gain, actuator 2 stuck at `sin t` (from `t = 2 s`).
#[test]
fn qf_columns_are_the_actuator_outputs_after_the_faults() {
    let dir = tmp("figures-qf");
    run_example1(&["simulation.t_end=2.5"], &["--no-plots"], &dir);
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).expect("csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (t, q1, q2, qf1, qf2) = (
        col("t"),
        col("q1_1"),
        col("q1_2"),
        col("qf1_1"),
        col("qf1_2"),
    );
    assert_eq!(header.last(), Some(&"qf4_2"), "qf columns end the row");
    let (mut inside, mut outside) = (0, 0);
    for line in lines {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.parse().expect("number"))
            .collect();
        if v[t] < 2.0 {
            // q is the controller's f32, qf the f64 the plant receives.
            let f = |x: f64| x as f32;
            assert_eq!(
                (f(v[qf1]), f(v[qf2])),
                (f(v[q1]), f(v[q2])),
                "healthy at {}",
                v[t]
            );
            outside += 1;
        } else {
            assert!(
                (v[qf1] - 0.5 * v[q1]).abs() <= 1e-6 * v[q1].abs(),
                "half gain at {}",
                v[t]
            );
            assert!(
                (v[qf2] - v[t].sin()).abs() < 1e-12,
                "stuck at sin t at {}",
                v[t]
            );
            inside += 1;
        }
    }
    assert!(
        inside > 100 && outside > 100,
        "{inside} inside, {outside} outside"
    );
}

/// `[figures]` for print: PDF and PNG only, the page 85 mm wide, the time window on the axis.
#[test]
fn figures_section_writes_print_pdfs_in_the_time_window() {
    let dir = tmp("figures-print");
    run_example1(
        &[
            "simulation.t_end=3",
            "figures.format=[\"pdf\", \"svg\"]",
            "figures.dpi=100",
            "figures.t_from=1",
            "figures.t_to=2.5",
        ],
        &[],
        &dir,
    );
    for stem in ["tracking", "errors", "inputs", "estimates"] {
        let pdf = std::fs::read(dir.join(format!("{stem}.pdf"))).expect("pdf");
        assert!(pdf.starts_with(b"%PDF"), "{stem}.pdf");
        assert!(
            !dir.join(format!("{stem}.png")).exists(),
            "no PNG asked for"
        );
    }
    let svg = std::fs::read_to_string(dir.join("tracking.svg")).expect("svg");
    assert!(svg.contains("width=\"85.00mm\""), "85 mm page");
    assert_has(&svg, &[">\n1.0\n<", ">\n2.4\n<"], "tracking.svg");
    assert!(!svg.contains(">\n2.6\n<"), "the axis ends at t_to");
    let inputs = std::fs::read_to_string(dir.join("inputs.svg")).expect("svg");
    assert_has(&inputs, &["qᶠ(u₁)", "partial loss"], "inputs.svg");
    // Agent by agent: agent 1's quantization error comes before agent 2's command.
    let at = |what: &str| inputs.find(what).expect(what);
    assert!(at("agent 1: quantization error") < at("agent 2: command"));
    for i in 1..=4 {
        let one = std::fs::read_to_string(dir.join(format!("inputs-{i}.svg"))).expect("svg");
        assert_has(
            &one,
            &[
                &format!("agent {i}: command"),
                &format!("agent {i}: quantization error"),
            ],
            &format!("inputs-{i}.svg"),
        );
        assert!(!one.contains(&format!("agent {}: command", i % 4 + 1)));
        assert!(dir.join(format!("inputs-{i}.pdf")).exists());
    }
    assert!(!dir.join("inputs-5.svg").exists());
}

/// `leader.y_d = "0.6*sin(2*t)"` is Example 1's default leader: the same trajectory to the byte.
#[test]
fn a_leader_expression_of_the_default_sinusoid_runs_byte_identically() {
    let (a, b) = (tmp("leader-default"), tmp("leader-expression"));
    run_example1(&["simulation.t_end=0.5"], &["--no-plots"], &a);
    run_example1(
        &["simulation.t_end=0.5", "leader.y_d=\"0.6*sin(2*t)\""],
        &["--no-plots"],
        &b,
    );
    let read = |d: &Path| std::fs::read(d.join("trajectory.csv")).expect("csv");
    assert!(read(&a) == read(&b), "trajectory.csv differs");
}

/// A custom plant's `state_units` and `input_unit` label the figures' axes.
#[test]
fn custom_plant_units_label_the_axes() {
    let dir = tmp("figures-units");
    let custom = scenario_path("example1-custom.toml");
    run(
        &[
            "run",
            custom.to_str().expect("path"),
            "--set",
            "simulation.t_end=0.3",
            "--set",
            "plant.state_units=[\"m\", \"m/s\"]",
            "--set",
            "plant.input_unit=\"N\"",
            "--quiet",
        ],
        &dir,
    );
    assert_has(&svg(&dir, "tracking"), &["output y [m]"], "tracking");
    assert_has(&svg(&dir, "inputs"), &["u, q, qᶠ [N]"], "inputs");
}

/// `host-sim graph` draws Fig. 1: the leader, the four followers and the five arrows of the
/// paper's graph (four links, one pinning).
#[test]
fn graph_command_draws_the_communication_graph() {
    let dir = tmp("figures-graph");
    let e1 = scenario_path("example1.toml");
    run(&["graph", e1.to_str().expect("path")], &dir);
    let g = svg(&dir, "graph");
    assert_has(&g, &["4 followers, 4 links", ">\n0\n<", ">\n4\n<"], "graph");
    assert_eq!(
        g.matches("<polygon").count(),
        5,
        "one arrow head per link and pinning"
    );
}
