//! The closed loop of a math back-end against the default build: both paper examples, full
//! runs, each figure's relative drift from `golden/accurate-closed-loop.json` (made by the
//! default build, whose outputs the golden digests of `tests/safety.rs` pin), printed and
//! written to `target/back-end/<back-end>.md` (the tables of `docs/REPRODUCTION.md`, "Math
//! back-ends", `cargo xtask docs`), and held to the back-end's bounds.

use serde_json::Value;

/// The compared figures: `summary.json` keys (`agents.k`: every agent's, the largest drift
/// counts), and `rms_error`, `√(Σ_i ise_i / (agents · t_end))`.
pub const FIGURES: [&str; 6] = [
    "max_error_after_predefined_time",
    "rms_error",
    "max_abs_u",
    "total_u_energy",
    "agents.iae",
    "agents.ise",
];

/// Per scenario, the largest relative drift allowed for each of [`FIGURES`].
pub type Bounds = [(&'static str, [f64; FIGURES.len()])];

fn summary(scenario: &str, back_end: &str) -> Value {
    let dir = super::tmp(&format!("{back_end}-{scenario}"));
    let out = super::bin()
        .arg("run")
        .arg(super::scenario_path(&format!("{scenario}.toml")))
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

fn number(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// The values of figure `key` in a `summary.json` (one per agent for `agents.k`).
fn figures(summary: &Value, key: &str) -> Vec<f64> {
    let per_agent = |k: &str| -> Vec<f64> {
        summary["agents"]
            .as_array()
            .map(|a| a.iter().map(|agent| number(&agent[k])).collect())
            .unwrap_or_default()
    };
    match key {
        "rms_error" => vec![rms(&per_agent("ise"), number(&summary["t_end"]))],
        _ => match key.strip_prefix("agents.") {
            Some(k) => per_agent(k),
            None => vec![number(&summary[key])],
        },
    }
}

/// The values of figure `key` in the golden file (`agents.k` as one array).
fn golden(figures: &Value, key: &str) -> Vec<f64> {
    let values = |v: &Value| match v {
        Value::Array(a) => a.iter().map(number).collect(),
        v => vec![number(v)],
    };
    match key {
        "rms_error" => vec![rms(
            &values(&figures["agents.ise"]),
            number(&figures["t_end"]),
        )],
        _ => values(&figures[key]),
    }
}

/// `√(Σ_i ise_i / (agents · t_end))`.
fn rms(ise: &[f64], t_end: f64) -> f64 {
    (ise.iter().sum::<f64>() / (ise.len() as f64 * t_end)).sqrt()
}

/// Runs both examples with this build, prints the drift table and asserts `bounds`.
pub fn check(back_end: &str, bounds: &Bounds) {
    let reference: Value =
        serde_json::from_str(include_str!("../golden/accurate-closed-loop.json")).expect("JSON");
    let scenarios = reference["scenarios"].as_object().expect("scenarios");
    assert_eq!(scenarios.len(), bounds.len());
    let mut table = format!(
        "| example | figure | default build | `{back_end}` | relative drift |\n| --- | --- | ---: | ---: | ---: |\n"
    );
    let mut failures = Vec::new();
    for (scenario, limits) in bounds {
        let want = &scenarios[*scenario];
        let got = summary(scenario, back_end);
        for (key, &limit) in FIGURES.iter().zip(limits) {
            let want = golden(want, key);
            let got = figures(&got, key);
            assert_eq!(got.len(), want.len(), "{scenario} {key}");
            let (mut worst, mut at) = (0.0f64, 0);
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                let rel = (g - w) / w;
                if rel.is_nan() || rel.abs() > worst.abs() {
                    (worst, at) = (rel, k);
                }
            }
            table += &format!(
                "| {scenario} | {key} | {:.6} | {:.6} | {worst:+.2e} |\n",
                want[at], got[at]
            );
            if worst.is_nan() || worst.abs() > limit {
                failures.push(format!(
                    "{scenario} {key}: {worst:+.3e} from the default build, bound {limit:.3e}"
                ));
            }
        }
    }
    print!("{table}");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/back-end");
    std::fs::create_dir_all(&dir).expect("target/back-end");
    std::fs::write(dir.join(format!("{back_end}.md")), &table).expect("the table");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
