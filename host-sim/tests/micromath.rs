//! controller-core's `micromath` option (fast per-step math) keeps the closed loop of both paper
//! examples within 1 % of the accurate build: max error after the predefined time, total
//! control energy, and each agent's IAE and ISE against `tests/golden/accurate-closed-loop.json`
//! (made by the default build, whose outputs the golden digests of `tests/safety.rs` pin).
//!
//! CI: `cargo test -p host-sim --release --features micromath --test micromath -- --ignored`
//! (without the feature it checks that the accurate build still gives the reference figures).

mod common;

use serde_json::Value;

/// The closed-loop tolerance of the `micromath` build.
const TOLERANCE: f64 = 0.01;

fn summary(scenario: &str) -> Value {
    let dir = common::tmp(&format!("micromath-{scenario}"));
    let out = common::bin()
        .arg("run")
        .arg(common::scenario_path(&format!("{scenario}.toml")))
        .arg("--out")
        .arg(&dir)
        .args(["--quiet", "--no-plots"])
        .output()
        .expect("host-sim runs");
    assert!(
        out.status.success(),
        "{scenario}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// The figure `key` of a summary (`agents.k` gives one per agent).
fn figures(summary: &Value, key: &str) -> Vec<f64> {
    let number = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    match key.strip_prefix("agents.") {
        Some(k) => summary["agents"]
            .as_array()
            .map(|a| a.iter().map(|agent| number(&agent[k])).collect())
            .unwrap_or_default(),
        None => vec![number(&summary[key])],
    }
}

#[test]
#[ignore = "full runs: cargo test -p host-sim --release --features micromath --test micromath -- --ignored"]
fn both_examples_within_one_percent_of_the_accurate_build() {
    let reference: Value =
        serde_json::from_str(include_str!("golden/accurate-closed-loop.json")).expect("JSON");
    let scenarios = reference["scenarios"].as_object().expect("scenarios");
    assert_eq!(scenarios.len(), 2);
    for (scenario, want) in scenarios {
        let got = summary(scenario);
        for (key, want) in want.as_object().expect("figures") {
            let want: Vec<f64> = match want {
                Value::Array(a) => a.iter().filter_map(Value::as_f64).collect(),
                v => v.as_f64().into_iter().collect(),
            };
            let got = figures(&got, key);
            assert_eq!(got.len(), want.len(), "{scenario} {key}");
            for (g, w) in got.iter().zip(&want) {
                let rel = (g - w) / w;
                println!(
                    "{scenario} {key}: {g:.6e} (accurate {w:.6e}, {:+.3} %)",
                    100.0 * rel
                );
                assert!(
                    rel.abs() <= TOLERANCE,
                    "{scenario} {key}: {g} vs the accurate build's {w} ({:+.2} %)",
                    100.0 * rel
                );
            }
        }
    }
}
