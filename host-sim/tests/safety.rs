//! `[safety]`: off is the paper's law byte for byte, on bounds every command, bad values are
//! rejected naming the key.

mod common;

use std::{fs, path::Path, process::Output};

fn run(scenario: &str, out: &Path, sets: &[&str]) -> Output {
    let mut cmd = common::bin();
    cmd.arg("run")
        .arg(common::scenario_path(scenario))
        .arg("--out")
        .arg(out)
        .arg("--quiet");
    for s in sets {
        cmd.arg("--set").arg(s);
    }
    let o = cmd.output().expect("host-sim runs");
    assert!(
        o.status.success(),
        "{scenario}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn read(path: &Path) -> Vec<u8> {
    fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&read(&dir.join("summary.json"))).expect("summary.json is JSON")
}

const OUTPUTS: [&str; 10] = [
    "summary.json",
    "trajectory.csv",
    "errors.png",
    "errors.svg",
    "tracking.png",
    "tracking.svg",
    "inputs.png",
    "inputs.svg",
    "estimates.png",
    "estimates.svg",
];

#[test]
fn safety_off_is_byte_identical_to_no_safety_section() {
    // Short horizons (debug build); each covers a fault window or the CAN bus with loss.
    for (scenario, t_end) in [
        ("example1.toml", "2.2"),
        ("example2.toml", "0.2"),
        ("example2-baseline.toml", "0.2"),
        ("example1-lossy.toml", "0.5"),
    ] {
        let t = format!("simulation.t_end={t_end}");
        let name = scenario.trim_end_matches(".toml");
        let (a, b) = (
            common::tmp(&format!("safety-absent-{name}")),
            common::tmp(&format!("safety-off-{name}")),
        );
        run(scenario, &a, &[&t]);
        // Limits given but switched off: they must not act.
        run(
            scenario,
            &b,
            &[
                &t,
                "safety.enabled=false",
                "safety.u_max=1",
                "safety.du_max=1",
            ],
        );
        for f in OUTPUTS {
            let (x, y) = (read(&a.join(f)), read(&b.join(f)));
            assert!(
                x == y,
                "{scenario}: {f} differs with [safety] enabled = false"
            );
        }
        assert_eq!(summary(&a)["saturated_fraction"], 0.0, "{scenario}");
    }
}

/// FNV-1a, 64 bit: enough to tell files apart, no dependency.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Release only (full 10 s runs; `.ci/run`): every output of the shipped paper scenarios equals
/// the one `main` produced before `[safety]` existed (digests in `tests/golden`); the summary
/// only gained its `saturated_fraction` line.
#[test]
#[ignore = "full runs: cargo test -p host-sim --release --test safety -- --ignored"]
fn shipped_paper_scenarios_unchanged_against_main() {
    let golden = include_str!("golden/paper-outputs.fnv");
    let mut checked = 0;
    let mut current: Option<(String, std::path::PathBuf)> = None;
    for line in golden.lines().filter(|l| !l.starts_with('#')) {
        let mut parts = line.split_whitespace();
        let (Some(scenario), Some(file), Some(want)) = (parts.next(), parts.next(), parts.next())
        else {
            panic!("bad golden line {line:?}");
        };
        if current.as_ref().map(|(s, _)| s.as_str()) != Some(scenario) {
            let dir = common::tmp(&format!("golden-{scenario}"));
            run(&format!("{scenario}.toml"), &dir, &[]);
            current = Some((scenario.to_string(), dir));
        }
        let Some((_, dir)) = &current else {
            unreachable!("set above")
        };
        let mut bytes = read(&dir.join(file));
        if file == "summary.json" {
            let text = String::from_utf8(bytes).expect("UTF-8");
            let kept: Vec<&str> = text
                .split_inclusive('\n')
                .filter(|l| !l.contains("\"saturated_fraction\""))
                .collect();
            bytes = kept.concat().into_bytes();
        }
        assert_eq!(
            format!("{:016x}", fnv(&bytes)),
            want,
            "{scenario}/{file} differs from main's"
        );
        checked += 1;
    }
    assert_eq!(checked, 60);
}

#[test]
fn safety_on_bounds_every_command_of_example2() {
    let dir = common::tmp("safety-on-example2");
    run(
        "example2.toml",
        &dir,
        &[
            "simulation.t_end=0.3",
            "safety.enabled=true",
            "safety.u_max=20",
            "safety.du_max=4000",
        ],
    );
    let s = summary(&dir);
    assert_eq!(s["diverged"], false);
    assert!(s["max_abs_u"].as_f64().expect("number") <= 20.0, "{s}");
    let sat = s["saturated_fraction"].as_f64().expect("number");
    assert!(
        sat > 0.0 && sat < 1.0,
        "the 16,519 peak of the paper's law is cut: {sat}"
    );
    let mut csv = csv::Reader::from_path(dir.join("trajectory.csv")).expect("trajectory.csv");
    let head = csv.headers().expect("header").clone();
    let cols: Vec<usize> = (0..head.len())
        .filter(|&c| head[c].starts_with('u'))
        .collect();
    assert_eq!(cols.len(), 8);
    let mut prev: Option<Vec<f64>> = None;
    for r in csv.records() {
        let r = r.expect("CSV row");
        let u: Vec<f64> = cols
            .iter()
            .map(|&c| r[c].parse().expect("number"))
            .collect();
        assert!(u.iter().all(|v| v.abs() <= 20.0), "{r:?}");
        if let Some(p) = &prev {
            // 4000/s at h = 0.2 ms: at most 0.8 per sample (f32 rounding allowed).
            for (a, b) in u.iter().zip(p) {
                assert!((a - b).abs() <= 0.8 + 1e-4, "{r:?}");
            }
        }
        prev = Some(u);
    }
}

#[test]
fn bad_safety_values_name_the_key() {
    for (set, key) in [
        ("safety.u_max=-1", "safety.u_max"),
        ("safety.u_max=0.005", "safety.u_max"),
        ("safety.du_max=0", "safety.du_max"),
        ("safety.du_max=1e300", "safety.du_max"),
        ("safety.recovery_rate=0", "safety.recovery_rate"),
        ("safety.recovery_rate=nan", "safety.recovery_rate"),
        ("safety.recovery_jump=-1", "safety.recovery_jump"),
        ("safety.umax=3", "safety"),
        ("safety.enabled=1", "safety.enabled"),
    ] {
        let out = common::bin()
            .arg("check")
            .arg(common::scenario_path("example1.toml"))
            .args(["--set", set])
            .output()
            .expect("host-sim runs");
        common::assert_invalid(&out, key);
    }
}
