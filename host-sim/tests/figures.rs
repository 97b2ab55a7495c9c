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

/// The text of every `<text>` element of an SVG, unescaped enough to read.
fn svg_words(svg: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find("<text") {
        rest = &rest[start..];
        let Some(open) = rest.find('>') else { break };
        let Some(close) = rest.find("</text>") else {
            break;
        };
        if open < close {
            let t = rest[open + 1..close].trim();
            if !t.is_empty() {
                words.push(
                    t.replace("&lt;", "<")
                        .replace("&gt;", ">")
                        .replace("&amp;", "&"),
                );
            }
        }
        rest = &rest[close + 7..];
    }
    words
}

/// The paper's own symbols that look like identifiers: `y_d` (the leader), `u_max`, `u_min`.
const PAPER_SYMBOLS: [&str; 3] = ["y_d", "u_max", "u_min"];

/// What in `text` is a scenario key, a file name or a code identifier: a word of the form
/// `[a-z]+_[a-z]+` other than the paper's symbols, a `section.` prefix of a key, a file
/// extension, or a shipped scenario's name.
fn identifiers(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for word in text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.')) {
        let word = word.trim_matches('.');
        let snake = word.split('.').any(|w| {
            w.split('_').count() > 1
                && w.split('_')
                    .all(|p| !p.is_empty() && p.chars().all(|c| c.is_ascii_lowercase()))
                && !PAPER_SYMBOLS.contains(&w)
        });
        let keyed = [
            "controller.",
            "simulation.",
            "quantizer.",
            "safety.",
            "faults.",
            "network.",
            "plant.",
            "clock.",
            "figures.",
        ]
        .iter()
        .any(|s| word.starts_with(s));
        let file = [".toml", ".csv", ".json", ".png", ".svg", ".md"]
            .iter()
            .any(|e| word.ends_with(e));
        let scenario = word.starts_with("example1") || word.starts_with("example2");
        if snake || keyed || file || scenario {
            found.push(word.to_string());
        }
    }
    found
}

#[test]
fn the_identifier_check_finds_keys_files_and_scenario_names() {
    assert_eq!(
        identifiers("total_u_energy over controller.c1 x controller.c2"),
        ["total_u_energy", "controller.c1", "controller.c2"]
    );
    assert_eq!(
        identifiers("settling time (band settle_band) [s]"),
        ["settle_band"]
    );
    assert_eq!(identifiers("example2-baseline: outputs"), ["example2"]);
    assert_eq!(identifiers("see results.csv"), ["results.csv"]);
    assert!(identifiers("max |yᵢ − y_d| after 2Tₛ [rad]; u_max = 20 N·m").is_empty());
}

/// Every figure host-sim writes, rendered as SVG, reads as words and units: the run figures of
/// both schemes, the communication graph, the clocks of a CAN run, the comparison, the campaign line, map and Monte
/// Carlo figures, the fault matrix and the torque-limit sweep. `[figures] format` reaches the
/// campaign figures through the campaign's `set` and the fault matrix through the scenario.
#[test]
fn no_figure_text_is_a_scenario_key_a_file_name_or_an_identifier() {
    use host_sim::matrix;

    let dir = tmp("figures-words");
    let e2 = scenario_path("example2.toml");
    let base = scenario_path("example2-baseline.toml");
    let can = scenario_path("example1-can.toml");
    let (e2, base) = (e2.to_str().expect("path"), base.to_str().expect("path"));
    let can = can.to_str().expect("path");
    let short = ["--set", "simulation.t_end=1.5", "--quiet"];
    for (what, args) in [
        ("run", vec!["run", e2]),
        ("baseline", vec!["run", base]),
        ("compare", vec!["compare", e2, base]),
        ("clocks", vec!["run", can, "--set", "clock.offset_us=200"]),
    ] {
        let mut a = args;
        a.extend(short);
        run(&a, &dir.join(what));
    }
    run(&["graph", e2], &dir.join("graph"));
    let campaigns = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/campaigns");
    for name in ["line", "monte-carlo"] {
        let file = campaigns.join(format!("{name}.toml"));
        run(
            &["sweep", file.to_str().expect("path"), "--quiet"],
            &dir.join(name),
        );
    }
    // A map, its figures asked for as SVG only through the campaign's `set`.
    let map = dir.join("map.toml");
    let e1 = scenario_path("example1.toml");
    std::fs::write(
        &map,
        format!(
            "scenario = {:?}\nset = [\"simulation.t_end=1\", 'figures.format=\"svg\"']\n\
             [[axis]]\nkey = \"controller.ts\"\nvalues = [0.5, 1.0]\n\
             [[axis]]\nkey = \"controller.zeta\"\nvalues = [0.1, 0.2]\n\
             [plot]\nmetric = \"total_u_energy\"\n",
            e1.to_str().expect("path")
        ),
    )
    .expect("map campaign");
    run(
        &["sweep", map.to_str().expect("path"), "--quiet"],
        &dir.join("map"),
    );
    assert!(dir.join("map/map.svg").exists(), "the map as SVG");
    assert!(
        !dir.join("map/map.png").exists(),
        "format = \"svg\" of the campaign's set reaches the map"
    );
    // The fault matrix and the torque-limit sweep, drawn from made-up results.
    let results: Vec<matrix::CellResult> = matrix::cells(4, 2.0)
        .into_iter()
        .enumerate()
        .flat_map(|(k, cell)| {
            [false, true].map(|safety| matrix::CellResult {
                cell: cell.clone(),
                safety,
                diverged_at: (k == 1 && !safety).then_some(2.5),
                max_abs_u: 10.0 + k as f64,
                max_abs_u_run: 10.0 + k as f64,
                max_error_after_recovery: Some(0.1),
                back_in_band_s: (k != 2).then_some(0.5),
                band: 0.05,
                saturated_fraction: 0.0,
            })
        })
        .collect();
    let text = matrix::FigureText {
        title: "predefined-time (proposed), Tₛ = 0.5 s: fault matrix",
        two_ts: 1.0,
        units: ("rad", "N·m"),
    };
    let fig = dir.join("matrix");
    std::fs::create_dir_all(&fig).expect("dir");
    matrix::draw(
        &fig,
        host_sim::figure::Output::default(),
        &results,
        Some(20.0),
        text,
    )
    .expect("matrix figure");
    let points: Vec<matrix::LimitPoint> = [100.0, 20.0, 8.0, 5.0]
        .map(|u_max| matrix::LimitPoint {
            u_max,
            settling_time: (u_max > 6.0).then_some(2.0 / u_max.sqrt()),
            max_error_after_predefined_time: Some(0.05),
            saturated_fraction: 0.0,
        })
        .to_vec();
    for ext in ["svg", "png"] {
        let path = fig.join(format!("torque-limit.{ext}"));
        matrix::draw_limit_sweep(&path, &points, 0.05, text).expect("torque-limit figure");
    }

    let mut svgs = Vec::new();
    let mut stack = vec![dir.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "svg") {
                svgs.push(p);
            }
        }
    }
    svgs.sort();
    let stems: Vec<String> = svgs
        .iter()
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    for kind in [
        "tracking",
        "errors",
        "inputs",
        "estimates",
        "graph",
        "clocks",
        "compare",
        "compare-outputs",
        "line",
        "montecarlo",
        "map",
        "matrix",
        "torque-limit",
    ] {
        assert!(
            stems.iter().any(|s| s == kind),
            "no {kind}.svg in {stems:?}"
        );
    }
    let mut bad = Vec::new();
    for p in &svgs {
        let svg = std::fs::read_to_string(p).expect("svg");
        for w in svg_words(&svg) {
            let found = identifiers(&w);
            if !found.is_empty() {
                bad.push(format!("{}: {w:?} ({found:?})", p.display()));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
