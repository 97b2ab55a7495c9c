//! `cargo xtask bench-gate`: the regression gate on the deterministic instruction counts.
//!
//! `bench-fw/budget.json`:
//! ```json
//! { "tolerance": 0.10,
//!   "variants": { "libm-n2m2": { "instructions_median": 1234 }, … } }
//! ```
//! A variant whose median instructions per step exceed `budget · (1 + tolerance)` fails the
//! gate, and so does a budgeted variant missing from `step.json`.

use crate::{bench_dir, target, workspace_root, Options, Result};
use serde_json::{json, Value};
use std::fs;

/// Default tolerance above the budget.
pub const TOLERANCE: f64 = 0.10;

pub fn bench_gate(opts: &Options) -> Result<()> {
    let budget_path = workspace_root().join("bench-fw").join("budget.json");
    let step_path = bench_dir().join("step.json");
    let step: Value = if opts.no_run {
        let text = fs::read_to_string(&step_path).map_err(|e| {
            format!(
                "{}: {e} (run `cargo xtask bench-target` first)",
                step_path.display()
            )
        })?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", step_path.display()))?
    } else {
        target::bench_target(opts)?
    };
    if opts.update_budget {
        let budget = budget_from(&step)?;
        let text = serde_json::to_string_pretty(&budget).map_err(|e| e.to_string())?;
        fs::write(&budget_path, text + "\n")
            .map_err(|e| format!("{}: {e}", budget_path.display()))?;
        println!("wrote {}", budget_path.display());
        return Ok(());
    }
    let text =
        fs::read_to_string(&budget_path).map_err(|e| format!("{}: {e}", budget_path.display()))?;
    let budget: Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", budget_path.display()))?;
    let verdicts = compare(&step, &budget)?;
    let mut failed = false;
    for v in &verdicts {
        println!("{v}");
        failed |= v.starts_with("FAIL");
    }
    if failed {
        Err(format!(
            "bench-gate: instruction count above budget ({})",
            budget_path.display()
        ))
    } else {
        println!("bench-gate OK");
        Ok(())
    }
}

/// The budget document for the medians of `step`.
pub fn budget_from(step: &Value) -> Result<Value> {
    let mut variants = serde_json::Map::new();
    for v in step["variants"]
        .as_array()
        .ok_or("step.json has no variants")?
    {
        let name = v["name"].as_str().ok_or("variant without a name")?;
        let median = v["instructions_median"]
            .as_u64()
            .ok_or("variant without instructions_median")?;
        variants.insert(name.to_owned(), json!({ "instructions_median": median }));
    }
    Ok(json!({ "tolerance": TOLERANCE, "variants": variants }))
}

/// One line per budgeted variant, starting with `ok` or `FAIL`.
pub fn compare(step: &Value, budget: &Value) -> Result<Vec<String>> {
    let tolerance = budget["tolerance"].as_f64().unwrap_or(TOLERANCE);
    let measured = step["variants"]
        .as_array()
        .ok_or("step.json has no variants")?;
    let mut out = Vec::new();
    for (name, b) in budget["variants"]
        .as_object()
        .ok_or("budget has no variants")?
    {
        let limit = b["instructions_median"]
            .as_u64()
            .ok_or_else(|| format!("budget of {name} has no instructions_median"))?;
        let allowed = (limit as f64 * (1.0 + tolerance)).floor() as u64;
        match measured
            .iter()
            .find(|v| v["name"].as_str() == Some(name.as_str()))
            .and_then(|v| v["instructions_median"].as_u64())
        {
            None => out.push(format!("FAIL {name}: missing from step.json")),
            Some(m) if m > allowed => out.push(format!(
                "FAIL {name}: median {m} instructions > {allowed} (budget {limit} + {:.0} %)",
                tolerance * 100.0
            )),
            Some(m) => out.push(format!(
                "ok   {name}: median {m} instructions ≤ {allowed} (budget {limit} + {:.0} %)",
                tolerance * 100.0
            )),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gate_passes_within_tolerance_and_fails_above() {
        let step = json!({ "variants": [
            { "name": "a", "instructions_median": 1100 },
            { "name": "b", "instructions_median": 1101 },
        ]});
        let budget = json!({ "tolerance": 0.1, "variants": {
            "a": { "instructions_median": 1000 },
            "b": { "instructions_median": 1000 },
            "c": { "instructions_median": 1000 },
        }});
        let v = compare(&step, &budget).unwrap_or_default();
        assert!(v[0].starts_with("ok   a"), "{v:?}");
        assert!(v[1].starts_with("FAIL b"), "{v:?}");
        assert!(
            v[2].starts_with("FAIL c") && v[2].contains("missing"),
            "{v:?}"
        );
        let b = budget_from(&step).unwrap_or_default();
        assert_eq!(b["variants"]["b"]["instructions_median"], 1101);
    }
}
