//! The command line through the built binary: exit statuses, one-line messages naming the key,
//! determinism, outputs.

use std::{
    path::{Path, PathBuf},
    process::Output,
};

mod common;

use common::{assert_invalid, bin, tmp};

fn scenario(name: &str) -> PathBuf {
    common::scenario_path(name)
}

fn check_file(text: &str, name: &str) -> Output {
    let d = tmp(&format!("malformed-{name}"));
    let f = d.join("s.toml");
    std::fs::write(&f, text).expect("write");
    bin().arg("check").arg(&f).output().expect("run")
}

#[test]
fn malformed_scenarios_exit_2_naming_the_key() {
    let cases: &[(&str, &str, &str)] = &[
        ("bad-toml", "name = \"x\"\n[simulation\nh = 1", "line 2"),
        ("wrong-type", "[simulation]\nh = \"fast\"", "simulation.h"),
        ("unknown-key", "[simulation]\nhh = 0.001", "hh"),
        ("unknown-section", "[simulations]\nh = 0.001", "simulations"),
        ("negative-h", "[simulation]\nh = -0.001", "simulation.h"),
        ("zero-t-end", "[simulation]\nt_end = 0", "simulation.t_end"),
        ("zero-substeps", "[simulation]\nsubsteps = 0", "simulation.substeps"),
        ("negative-substeps", "[simulation]\nsubsteps = -1", "simulation.substeps"),
        (
            "non-square",
            "[graph]\nadjacency = [[0,0,0],[1,0],[1,0,0]]\npinned = [1]\n[plant]\nx0 = [[0,0],[0,0],[0,0]]",
            "graph.adjacency[2]",
        ),
        (
            "both-graph-forms",
            "[graph]\nadjacency = [[0]]\nneighbours = [[]]",
            "graph.adjacency",
        ),
        ("self-link", "[graph]\nneighbours = [[], [2], [1], [1]]", "graph.neighbours[2]"),
        ("out-of-range-link", "[graph]\nneighbours = [[], [7], [1], [1]]", "graph.neighbours[2]"),
        ("zero-agent", "[graph]\nneighbours = [[], [0], [1], [1]]", "graph.neighbours[2]"),
        ("not-spanning", "[graph]\nneighbours = [[], [1], [4], [3]]", "agent(s) 3, 4"),
        ("no-pinned", "[graph]\npinned = []", "Assumption 2"),
        ("pinned-range", "[graph]\npinned = [9]", "graph.pinned"),
        ("x0-count", "[plant]\nx0 = [[0, 0]]", "plant.x0"),
        ("x0-ragged", "[plant]\nx0 = [[0, 0], [0], [0, 0], [0, 0]]", "plant.x0[2]"),
        ("unknown-model", "[plant]\nmodel = \"pendulum\"", "plant.model"),
        ("manip-key-on-ex1", "[plant]\ninertia = 2.0", "plant.inertia"),
        ("a-check-len", "[controller]\na_check = [90.0]", "controller.a_check"),
        ("zeta", "[controller]\nzeta = 1.5", "controller.zeta"),
        ("scheme", "[controller]\nscheme = \"fixed-time\"", "controller.scheme"),
        ("c1-alone", "[controller]\nc1 = 10.0", "controller.c2"),
        ("kappa-wrong-scheme", "[controller]\nkappa = 2.0", "controller.kappa"),
        ("rho", "[quantizer]\nrho = 1.5", "quantizer.rho"),
        (
            "actuator-range",
            "[faults]\n[[faults.rule]]\nagents = \"all\"\nactuator = 3\nkind = \"partial\"\ngain = 0.5",
            "faults.rule[1].actuator",
        ),
        (
            "agents-word",
            "[faults]\n[[faults.rule]]\nagents = \"some\"\nactuator = 1\nkind = \"partial\"\ngain = 0.5",
            "faults.rule[1].agents",
        ),
        (
            "agents-range",
            "[faults]\n[[faults.rule]]\nagents = [5]\nactuator = 1\nkind = \"partial\"\ngain = 0.5",
            "faults.rule[1].agents",
        ),
        (
            "partial-no-gain",
            "[faults]\n[[faults.rule]]\nagents = \"all\"\nactuator = 1\nkind = \"partial\"",
            "faults.rule[1].gain",
        ),
        (
            "fault-kind",
            "[faults]\n[[faults.rule]]\nagents = \"all\"\nactuator = 1\nkind = \"broken\"",
            "faults.rule[1].kind",
        ),
        (
            "fault-unknown-key",
            "[faults]\n[[faults.rule]]\nagents = \"all\"\nactuator = 1\nkind = \"stuck\"\nbais = 1.0",
            "bais",
        ),
        (
            "assumption-4",
            "[faults]\n[[faults.rule]]\nagents = [2]\nactuator = 1\nkind = \"stuck\"\nstart = 1.0\n\
             [[faults.rule]]\nagents = \"all\"\nactuator = 2\nkind = \"stuck\"\nstart = 3.0\nperiod = 4.0\nlength = 1.0",
            "agent 2",
        ),
        (
            "negative-period",
            "[faults]\n[[faults.rule]]\nagents = \"all\"\nactuator = 1\nkind = \"partial\"\ngain = 0.5\nperiod = -1.0",
            "faults.rule[1].period",
        ),
    ];
    for (name, text, key) in cases {
        eprintln!("case {name}");
        let out = check_file(text, name);
        assert_invalid(&out, key);
    }
}

#[test]
fn bad_files_and_options_exit_2() {
    let out = bin()
        .args(["check", "/nonexistent/scenario.toml"])
        .output()
        .expect("run");
    assert_invalid(&out, "/nonexistent/scenario.toml");
    let ex1 = scenario("example1.toml");
    for (set, key) in [
        ("simulation.h=-1", "simulation.h"),
        ("simulation.h=[1", "--set simulation.h"),
        ("controller.ts", "--set controller.ts"),
        ("name.x=1", "--set name.x"),
        ("controller.bogus=1", "bogus"),
    ] {
        let out = bin()
            .arg("check")
            .arg(&ex1)
            .args(["--set", set])
            .output()
            .expect("run");
        assert_invalid(&out, key);
    }
    let out = bin()
        .arg("run")
        .arg(&ex1)
        .args(["--out", "/tmp/never", "--decimate", "0"])
        .output()
        .expect("run");
    assert_invalid(&out, "--decimate");
    let out = bin().args(["run", "--bogus"]).output().expect("run");
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn unwritable_output_is_an_io_error() {
    let d = tmp("io");
    let blocker = d.join("file");
    std::fs::write(&blocker, "x").expect("write");
    let out = bin()
        .arg("run")
        .arg(scenario("example1.toml"))
        .arg("--out")
        .arg(blocker.join("sub"))
        .args(["--set", "simulation.t_end=0.01", "--no-plots"])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
}

fn run_to(dir: &Path, extra: &[&str]) {
    let out = bin()
        .arg("run")
        .arg(scenario("example1.toml"))
        .arg("--out")
        .arg(dir)
        .args(["--quiet", "--set", "simulation.t_end=2"])
        .args(extra)
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn same_scenario_twice_gives_identical_files() {
    let (a, b) = (tmp("det-a"), tmp("det-b"));
    run_to(&a, &["--no-plots"]);
    run_to(&b, &["--no-plots"]);
    for f in ["summary.json", "trajectory.csv"] {
        let x = std::fs::read(a.join(f)).expect("read");
        let y = std::fs::read(b.join(f)).expect("read");
        assert!(x == y, "{f} differs between two runs");
    }
}

#[test]
fn run_writes_summary_csv_and_plots() {
    let d = tmp("outputs");
    run_to(&d, &["--decimate", "10", "--set", "simulation.t_end=0.5"]);
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("summary.json")).expect("summary"))
            .expect("json");
    for key in [
        "scenario",
        "scheme",
        "c1",
        "c2",
        "predefined_time",
        "settle_band",
        "settling_time",
        "max_error_after_predefined_time",
        "max_abs_u",
        "diverged",
        "divergence",
        "agents",
    ] {
        assert!(summary.get(key).is_some(), "summary.json lacks {key}");
    }
    let agent = &summary["agents"][0];
    for key in [
        "iae",
        "ise",
        "max_abs_u",
        "u_energy",
        "quantizer_changes",
        "levels_used",
        "peak_abs_state",
        "final_mu",
        "final_xi",
        "final_lambda",
    ] {
        assert!(agent.get(key).is_some(), "agent summary lacks {key}");
    }
    let csv = std::fs::read_to_string(d.join("trajectory.csv")).expect("csv");
    let mut lines = csv.lines();
    let header = lines.next().expect("header");
    assert!(
        header.starts_with("t,yd,y1,x1_1,x1_2,e1_1,e1_2,u1_1,u1_2,q1_1,q1_2,mu1,xi1,lambda1,y2,")
    );
    assert_eq!(lines.count(), 50, "500 samples, every 10th");
    for p in ["tracking", "errors", "inputs", "estimates"] {
        for ext in ["png", "svg"] {
            let f = d.join(format!("{p}.{ext}"));
            assert!(
                std::fs::metadata(&f)
                    .map(|m| m.len() > 1000)
                    .unwrap_or(false),
                "{f:?}"
            );
        }
    }
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .expect("dir")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn divergence_exits_0_and_is_reported() {
    let d = tmp("diverge");
    let out = bin()
        .arg("run")
        .arg(scenario("example2.toml"))
        .arg("--out")
        .arg(&d)
        .args([
            "--quiet",
            "--no-plots",
            "--set",
            "simulation.h=1e-3",
            "--set",
            "simulation.t_end=1",
        ])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(0));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(s["diverged"], true);
    assert!(s["divergence"]["time"].as_f64().is_some());
    assert!(s["divergence"]["agent"].as_u64().is_some());
    let csv = std::fs::read_to_string(d.join("trajectory.csv")).expect("csv");
    let cols = csv
        .lines()
        .next()
        .map(|l| l.split(',').count())
        .unwrap_or(0);
    assert!(
        csv.lines().all(|l| l.split(',').count() == cols),
        "every row complete"
    );
}

#[test]
fn check_prints_the_resolved_scenario() {
    let out = bin()
        .arg("check")
        .arg(scenario("example1.toml"))
        .args([
            "--set",
            "controller.ts=1",
            "--set",
            "quantizer.enabled=false",
        ])
        .output()
        .expect("run");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("ts = 1.0"), "{text}");
    assert!(text.contains("enabled = false"), "{text}");
    let reparsed: toml::Table = text.parse().expect("check prints valid TOML");
    assert!(reparsed.contains_key("controller"));
}

#[test]
fn check_prints_the_bus_load_of_the_frame_set_and_warns_above_70_percent() {
    let check = |sets: &[&str]| {
        let mut cmd = bin();
        cmd.arg("check").arg(scenario("example1-socketcan.toml"));
        for s in sets {
            cmd.args(["--set", s]);
        }
        let out = cmd.output().expect("run");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    // 5 × 95 + 8 × 135 bits per 1 ms at 1 Mbit/s, and 4 CANopen heartbeats (1 byte, 65 bits)
    // every 100 samples.
    let classical = check(&[]);
    assert!(
        classical.contains("total 1557.6 µs of 1000.0 µs: 155.8 %"),
        "{classical}"
    );
    assert!(
        classical.contains("# warning: the frames take 155.8 %"),
        "{classical}"
    );
    let fd = check(&[
        "network.data_bitrate=4000000",
        "network.sensor_frames=\"packed\"",
    ]);
    assert!(fd.contains("1 Mbit/s nominal / 4 Mbit/s data"), "{fd}");
    assert!(fd.contains("sensor      1.000 frames × 32 B"), "{fd}");
    assert!(fd.contains(": 63.6 %"), "{fd}");
    assert!(!fd.contains("# warning"), "{fd}");
    let reparsed: toml::Table = fd.parse().expect("check prints valid TOML");
    assert!(reparsed.contains_key("network"));
}

#[test]
fn frame_set_keys_are_checked_against_the_kind() {
    for (file, set, key) in [
        (
            "example1-socketcan.toml",
            "network.sensor_frames=\"packed\"",
            "network.sensor_frames",
        ),
        (
            "example1-socketcan.toml",
            "network.plant_frames=true",
            "network.plant_frames",
        ),
        (
            "example1-socketcan.toml",
            "network.data_bitrate=500000",
            "network.data_bitrate",
        ),
        (
            "example1-can.toml",
            "network.sensor_frames=\"per-agent\"",
            "network.sensor_frames",
        ),
        (
            "example1-can.toml",
            "network.lost_command=\"hold\"",
            "network.lost_command",
        ),
        (
            "example1-pil.toml",
            "network.data_bitrate=4000000",
            "network.data_bitrate",
        ),
    ] {
        let out = bin()
            .arg("check")
            .arg(scenario(file))
            .args(["--set", set])
            .output()
            .expect("run");
        let lines = rejected_lines(&out);
        assert!(
            lines.iter().any(|l| l.contains(&format!("{key}:"))),
            "{file} {set}: {lines:?}"
        );
    }
}

/// Exit 2, nothing on standard output, and the stderr lines.
fn rejected_lines(out: &Output) -> Vec<String> {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(out.stdout.is_empty(), "nothing is printed: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err.lines().map(str::to_owned).collect()
}

#[test]
fn five_mistakes_in_five_sections_give_five_lines_in_one_run() {
    let text = "[graph]\nneighbours = [[], [1], [2, 9], [1, 3]]\npinned = [1]\n\
                [controller]\na_check = [90.0]\nzeta = 1.5\n\
                [[faults.rule]]\nagents = \"all\"\nactuator = 1\nkind = \"melted\"\n\
                [network]\nbitrat = 500000\n";
    let lines = rejected_lines(&check_file(text, "five-mistakes"));
    assert_eq!(lines.len(), 5, "{lines:#?}");
    for key in [
        "graph.neighbours[3]",
        "controller.a_check",
        "controller.zeta",
        "faults.rule[1].kind",
        "network.bitrat",
    ] {
        let hits = lines.iter().filter(|l| l.contains(key)).count();
        assert_eq!(hits, 1, "`{key}` once: {lines:#?}");
    }
    assert!(lines
        .iter()
        .all(|l| l.starts_with("host-sim: invalid scenario: ")));
    let d = tmp("five-mistakes-run");
    let f = d.join("s.toml");
    std::fs::write(&f, text).expect("write");
    let out = d.join("out");
    let run = bin()
        .arg("run")
        .arg(&f)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run");
    assert_eq!(rejected_lines(&run).len(), 5);
    assert!(!out.exists(), "nothing is written");
}

const CUSTOM3: &str = "[plant]\nmodel = \"custom\"\nn = 3\nm = 1\n\
                       dynamics = [\"x2\", \"x3\", \"u - x1\"]\n";

#[test]
fn custom_plant_of_three_states_and_one_actuator_fits_the_defaults() {
    let x0 = "x0 = [[0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0], [0.4, 0, 0]]\n";
    let out = check_file(&format!("{CUSTOM3}{x0}"), "custom3-defaults");
    common::assert_ok(&out);
    let resolved = String::from_utf8_lossy(&out.stdout);
    for key in ["a_check", "phi_low", "phi_up", "eps_bar"] {
        let line = resolved
            .lines()
            .find(|l| l.starts_with(&format!("{key} =")))
            .unwrap_or_default();
        assert_eq!(line.matches(',').count(), 2, "three entries: {line}");
    }
    // Example 1's rule on actuator 2 is not applied to a plant with m = 1.
    assert!(resolved.contains("actuator = 1"), "{resolved}");
    assert!(!resolved.contains("actuator = 2"), "{resolved}");
}

#[test]
fn custom_plant_of_three_states_reports_all_its_problems_in_one_run() {
    let text = format!("{CUSTOM3}[controller]\na_check = [1.0, 2.0]\nphi_low = [1.0]\n");
    let lines = rejected_lines(&check_file(&text, "custom3-mistakes"));
    assert_eq!(lines.len(), 3, "{lines:#?}");
    assert!(lines[0].contains("plant.x0") && lines[0].contains("default"));
    assert!(lines[1].contains("controller.a_check") && lines[1].contains("(got 2)"));
    assert!(lines[2].contains("controller.phi_low") && lines[2].contains("(got 1)"));
}

#[test]
fn command_line_errors_are_one_line_naming_the_option() {
    let ex1 = scenario("example1.toml");
    let cases: [(Vec<&str>, &str); 4] = [
        (vec!["run", "EX1"], "host-sim: invalid option: --out: "),
        (
            vec!["run", "EX1", "--out", "/tmp/never", "--bogus"],
            "host-sim: invalid option: --bogus: ",
        ),
        (
            vec!["run", "EX1", "--out", "/tmp/never", "--decimate", "x"],
            "host-sim: invalid option: --decimate: ",
        ),
        (vec!["frobnicate"], "host-sim: invalid option: frobnicate: "),
    ];
    for (args, start) in cases {
        let out = bin()
            .args(args.iter().map(|a| match *a {
                "EX1" => ex1.as_os_str(),
                a => std::ffi::OsStr::new(a),
            }))
            .output()
            .expect("run");
        let lines = rejected_lines(&out);
        assert_eq!(lines.len(), 1, "{args:?}: {lines:#?}");
        assert!(lines[0].starts_with(start), "{args:?}: {lines:#?}");
    }
    for flag in ["--help", "--version"] {
        let out = bin().arg(flag).output().expect("run");
        assert_eq!(out.status.code(), Some(0), "{flag}");
        assert!(!out.stdout.is_empty(), "{flag}");
    }
}

#[test]
fn checks_that_need_a_rejected_part_are_skipped_not_reported() {
    // Agent 7 of the fault rule cannot be judged without a usable graph; zeta can.
    let text = "[graph]\nneighbours = [[], [1], [2, 9], [1, 3]]\n\
                [controller]\nzeta = 2.0\n\
                [[faults.rule]]\nagents = [7]\nactuator = 1\nkind = \"partial\"\ngain = 0.5\n";
    let lines = rejected_lines(&check_file(text, "skipped-checks"));
    assert_eq!(lines.len(), 2, "{lines:#?}");
    assert!(lines[0].contains("graph.neighbours[3]"), "{lines:#?}");
    assert!(lines[1].contains("controller.zeta"), "{lines:#?}");
    assert!(
        !lines[1].contains("agent 1"),
        "no agent without a graph: {lines:#?}"
    );
    // simulation.h is reported once, not again by the controller.
    let lines = rejected_lines(&check_file(
        "[simulation]\nh = -1.0\n[quantizer]\nrho = 3.0\n",
        "h-once",
    ));
    assert_eq!(lines.len(), 2, "{lines:#?}");
    assert!(lines[0].contains("simulation.h") && lines[1].contains("quantizer.rho"));
}

#[test]
fn every_bad_set_is_reported_in_one_run() {
    let out = bin()
        .arg("check")
        .arg(scenario("example1.toml"))
        .args(["--set", "controller.ts", "--set", "name.=1"])
        .output()
        .expect("run");
    let lines = rejected_lines(&out);
    assert_eq!(lines.len(), 2, "{lines:#?}");
    assert!(lines[0].starts_with("host-sim: invalid option: --set controller.ts: "));
    assert!(lines[1].starts_with("host-sim: invalid option: --set name.: "));
}
