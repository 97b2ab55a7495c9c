//! `cargo xtask bench-gate`: the regression gate on the deterministic target figures.
//!
//! `bench-fw/budget.json` holds one budget per benchmark variant, every variant of
//! [`VARIANTS`] and no other:
//! ```json
//! { "tolerance": 0.10,
//!   "variants": { "libm-n2m2": { "instructions_median": 1234, "instructions_max": 1849,
//!                                "stack_bytes": 400, "flash_bytes": 8214,
//!                                "flash_config_bytes": 3000 }, … } }
//! ```
//! A variant fails the gate when any of its five figures exceeds `budget · (1 + tolerance)`,
//! when its stack or its step's flash exceeds the absolute goals ([`STACK_GOAL`], [`FLASH_GOAL`];
//! set for Example 1's agent, so for the `n = m = 2` variants; `libm-n3m3` is held to its budget
//! only), when a
//! step of the replayed trace faulted, when it ran no step, or when it is missing from
//! `step.json`. A budget that could let anything through is rejected before any comparison:
//! a tolerance outside `[0, MAX_TOLERANCE]`, a missing or unknown variant, a missing, zero or
//! unknown figure.

use crate::{bench_dir, target, target::VARIANTS, workspace_root, Options, Result};
use serde_json::{json, Map, Value};
use std::fs;

/// Default tolerance above the budget, written by `--update-budget`.
pub const TOLERANCE: f64 = 0.10;
/// The largest tolerance a budget may set.
pub const MAX_TOLERANCE: f64 = 0.10;
/// Absolute goal for the painted stack of one step, bytes.
pub const STACK_GOAL: u64 = 512;
/// Absolute goal for the flash of the step and its callees, bytes. The configuration
/// code a firmware links beside it (`flash_config_bytes`) is gated by its budget; step and
/// configuration together are over this goal since `[safety]` (`docs/FIRMWARE.md` §3).
pub const FLASH_GOAL: u64 = 16 * 1024;

/// The gated figures: the key in `step.json` and in the budget, and its unit for messages.
const FIGURES: [(&str, &str); 5] = [
    ("instructions_median", "instructions"),
    ("instructions_max", "instructions"),
    ("stack_bytes", "B"),
    ("flash_bytes", "B"),
    ("flash_config_bytes", "B"),
];

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
    let verdicts =
        compare(&step, &budget).map_err(|e| format!("{}: {e}", budget_path.display()))?;
    let mut failed = false;
    for v in &verdicts {
        println!("{v}");
        failed |= v.starts_with("FAIL");
    }
    if failed {
        Err(format!(
            "bench-gate: figures above budget ({})",
            budget_path.display()
        ))
    } else {
        println!("bench-gate OK");
        Ok(())
    }
}

/// The budget document for the figures of `step` (every variant must have run cleanly).
pub fn budget_from(step: &Value) -> Result<Value> {
    let mut variants = Map::new();
    for v in measured_variants(step)? {
        let name = v["name"].as_str().ok_or("variant without a name")?;
        if let Some(problem) = run_problem(v) {
            return Err(format!("{name}: {problem}: no budget written"));
        }
        let mut limits = Map::new();
        for (key, _) in FIGURES {
            let value = v[key]
                .as_u64()
                .ok_or_else(|| format!("{name}: step.json has no {key}"))?;
            limits.insert(key.to_owned(), json!(value));
        }
        variants.insert(name.to_owned(), Value::Object(limits));
    }
    let budget = json!({ "tolerance": TOLERANCE, "variants": variants });
    validate_budget(&budget)?;
    Ok(budget)
}

/// The validated budget: tolerance, and per variant its limits in [`FIGURES`] order.
struct Budget {
    tolerance: f64,
    variants: Vec<(String, [u64; FIGURES.len()])>,
}

/// Rejects a budget that could let a regression through (module docs).
fn validate_budget(budget: &Value) -> Result<Budget> {
    let doc = budget
        .as_object()
        .ok_or("the budget is not a JSON object")?;
    if let Some(key) = doc
        .keys()
        .find(|k| !["tolerance", "variants"].contains(&k.as_str()))
    {
        return Err(format!("unknown key `{key}`"));
    }
    let tolerance = doc
        .get("tolerance")
        .and_then(Value::as_f64)
        .ok_or("`tolerance` is missing or not a number")?;
    if !(0.0..=MAX_TOLERANCE).contains(&tolerance) {
        return Err(format!(
            "`tolerance` = {tolerance} must lie in [0, {MAX_TOLERANCE}]"
        ));
    }
    let listed = doc
        .get("variants")
        .and_then(Value::as_object)
        .ok_or("`variants` is missing or not an object")?;
    if let Some(name) = listed
        .keys()
        .find(|n| !VARIANTS.iter().any(|v| v.name == n.as_str()))
    {
        return Err(format!(
            "unknown variant `{name}` (the bench runs {})",
            variant_names()
        ));
    }
    let mut variants = Vec::new();
    for v in VARIANTS {
        let limits = listed
            .get(v.name)
            .and_then(Value::as_object)
            .ok_or_else(|| format!("variant `{}` has no budget", v.name))?;
        if let Some(key) = limits.keys().find(|k| !FIGURES.iter().any(|(f, _)| f == k)) {
            return Err(format!("{}: unknown figure `{key}`", v.name));
        }
        let mut values = [0u64; FIGURES.len()];
        for (slot, (key, _)) in values.iter_mut().zip(FIGURES) {
            *slot = limits
                .get(key)
                .and_then(Value::as_u64)
                .filter(|&x| x > 0)
                .ok_or_else(|| format!("{}: `{key}` must be a positive integer", v.name))?;
        }
        variants.push((v.name.to_owned(), values));
    }
    Ok(Budget {
        tolerance,
        variants,
    })
}

fn variant_names() -> String {
    VARIANTS.map(|v| v.name).join(", ")
}

fn measured_variants(step: &Value) -> Result<&Vec<Value>> {
    step["variants"]
        .as_array()
        .ok_or_else(|| "step.json has no variants".to_owned())
}

/// Why a measured variant's figures cannot be trusted, if they cannot.
fn run_problem(v: &Value) -> Option<String> {
    match (v["steps"].as_u64(), v["faulted_steps"].as_u64()) {
        (Some(0), _) => Some("ran no step".to_owned()),
        (None, _) => Some("no `steps` count".to_owned()),
        (_, None) => Some("no `faulted_steps` count".to_owned()),
        (_, Some(f)) if f > 0 => Some(format!(
            "{f} steps faulted (the command was held): the trace does not exercise the law"
        )),
        _ => None,
    }
}

/// One line per budgeted variant and figure, starting with `ok` or `FAIL`; an error for a
/// malformed budget.
pub fn compare(step: &Value, budget: &Value) -> Result<Vec<String>> {
    let budget = validate_budget(budget)?;
    let measured = measured_variants(step)?;
    let pct = budget.tolerance * 100.0;
    let mut out = Vec::new();
    for (name, limits) in &budget.variants {
        let Some(v) = measured
            .iter()
            .find(|v| v["name"].as_str() == Some(name.as_str()))
        else {
            out.push(format!("FAIL {name}: missing from step.json"));
            continue;
        };
        if let Some(problem) = run_problem(v) {
            out.push(format!("FAIL {name}: {problem}"));
        }
        for (&limit, (key, unit)) in limits.iter().zip(FIGURES) {
            let allowed = (limit as f64 * (1.0 + budget.tolerance)).floor() as u64;
            out.push(match v[key].as_u64() {
                None => format!("FAIL {name}: {key} missing from step.json"),
                Some(m) if m > allowed => format!(
                    "FAIL {name}: {key} {m} {unit} > {allowed} (budget {limit} + {pct:.0} %)"
                ),
                Some(m) => format!(
                    "ok   {name}: {key} {m} {unit} ≤ {allowed} (budget {limit} + {pct:.0} %)"
                ),
            });
        }
        if VARIANTS.iter().any(|var| var.name == name && !var.n3) {
            out.extend(goals(name, v));
        }
    }
    Ok(out)
}

/// The absolute goals, whatever the budget: stack and the step's flash.
fn goals(name: &str, v: &Value) -> Vec<String> {
    let mut out = Vec::new();
    for (key, goal) in [("stack_bytes", STACK_GOAL), ("flash_bytes", FLASH_GOAL)] {
        if let Some(m) = v[key].as_u64().filter(|&m| m > goal) {
            out.push(format!("FAIL {name}: {key} {m} B > the goal of {goal} B"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clean run of every variant at the given figures.
    fn step_at(median: u64, max: u64, stack: u64, flash: u64) -> Value {
        let variants: Vec<Value> = VARIANTS
            .iter()
            .map(|v| {
                json!({ "name": v.name, "instructions_median": median, "instructions_max": max,
                        "stack_bytes": stack, "flash_bytes": flash, "flash_config_bytes": 2000,
                        "steps": 10_000, "faulted_steps": 0 })
            })
            .collect();
        json!({ "variants": variants })
    }

    fn budget_at(median: u64, max: u64, stack: u64, flash: u64) -> Value {
        let mut variants = Map::new();
        for v in VARIANTS {
            variants.insert(
                v.name.to_owned(),
                json!({ "instructions_median": median, "instructions_max": max,
                        "stack_bytes": stack, "flash_bytes": flash,
                        "flash_config_bytes": 2000 }),
            );
        }
        json!({ "tolerance": 0.1, "variants": variants })
    }

    fn failures(step: &Value, budget: &Value) -> Vec<String> {
        compare(step, budget)
            .unwrap_or_else(|e| vec![format!("ERROR {e}")])
            .into_iter()
            .filter(|l| !l.starts_with("ok"))
            .collect()
    }

    fn set(doc: &mut Value, variant: usize, key: &str, value: Value) {
        doc["variants"][variant][key] = value;
    }

    #[test]
    fn passes_within_tolerance() {
        let budget = budget_at(1000, 1500, 400, 8000);
        assert!(failures(&step_at(1100, 1650, 440, 8800), &budget).is_empty());
        assert!(failures(&step_at(1000, 1500, 400, 8000), &budget).is_empty());
    }

    #[test]
    fn each_figure_above_tolerance_fails() {
        let budget = budget_at(1000, 1500, 400, 8000);
        for (key, value) in [
            ("instructions_median", 1101),
            ("instructions_max", 1651),
            ("stack_bytes", 441),
            ("flash_bytes", 8801),
            ("flash_config_bytes", 2201),
        ] {
            let mut step = step_at(1000, 1500, 400, 8000);
            set(&mut step, 2, key, json!(value));
            let f = failures(&step, &budget);
            assert_eq!(f.len(), 1, "{key}: {f:?}");
            assert!(f[0].starts_with("FAIL baseline-n2m2") && f[0].contains(key));
        }
    }

    #[test]
    fn huge_stack_and_flash_and_faulted_steps_fail_with_medians_in_budget() {
        let budget = budget_at(1234, 1849, 400, 8214);
        // Stack 99,999, flash 999,999 and every step faulted, medians in budget.
        let mut step = step_at(1234, 1849, 400, 8214);
        set(&mut step, 0, "stack_bytes", json!(99_999));
        set(&mut step, 0, "flash_bytes", json!(999_999));
        set(&mut step, 0, "faulted_steps", json!(10_000));
        let f = failures(&step, &budget);
        // Faulted; stack and flash each above budget and above the goal.
        assert_eq!(f.len(), 5, "{f:?}");
        assert!(f.iter().any(|l| l.contains("faulted")));
        assert!(f.iter().all(|l| l.starts_with("FAIL libm-n2m2")));
        // A run of no step, a variant without figures, a missing variant.
        let mut step = step_at(1234, 1849, 400, 8214);
        set(&mut step, 1, "steps", json!(0));
        set(&mut step, 3, "instructions_max", Value::Null);
        let f = failures(&step, &budget);
        assert!(f.iter().any(|l| l.contains("ran no step")), "{f:?}");
        assert!(
            f.iter().any(|l| l.contains("instructions_max missing")),
            "{f:?}"
        );
        let mut step = step_at(1234, 1849, 400, 8214);
        step["variants"].as_array_mut().map(|v| v.remove(0));
        assert_eq!(
            failures(&step, &budget),
            vec!["FAIL libm-n2m2: missing from step.json"]
        );
    }

    #[test]
    fn absolute_goals_apply_whatever_the_budget() {
        let n2 = VARIANTS.iter().filter(|v| !v.n3).count();
        let budget = budget_at(1000, 1500, 600, 20_000);
        let f = failures(&step_at(1000, 1500, 600, 20_000), &budget);
        assert_eq!(f.len(), 2 * n2, "{f:?}");
        assert!(f.iter().all(|l| l.contains("goal") && !l.contains("n3m3")));
        assert!(
            f[1].contains("flash_bytes 20000 B > the goal of 16384 B"),
            "{f:?}"
        );
    }

    #[test]
    fn a_budget_that_lets_anything_through_is_rejected() {
        let step = step_at(1000, 1500, 400, 8000);
        let good = budget_at(1000, 1500, 400, 8000);
        let mut cases: Vec<(Value, &str)> = Vec::new();
        let mut b = good.clone();
        b["tolerance"] = json!(10);
        cases.push((b, "tolerance"));
        let mut b = good.clone();
        b["tolerance"] = json!(-0.1);
        cases.push((b, "tolerance"));
        let mut b = good.clone();
        b.as_object_mut().map(|o| o.remove("tolerance"));
        cases.push((b, "tolerance"));
        let mut b = good.clone();
        b["variants"] = json!({});
        cases.push((b, "has no budget"));
        let mut b = good.clone();
        b["variants"]["libm-n2m2-fast"] = b["variants"]["libm-n2m2"].clone();
        cases.push((b, "unknown variant"));
        let mut b = good.clone();
        b["variants"]["micromath-n2m2"]["stack_bytes"] = json!(0);
        cases.push((b, "positive integer"));
        let mut b = good.clone();
        b["variants"]["micromath-n2m2"]
            .as_object_mut()
            .map(|o| o.remove("flash_bytes"));
        cases.push((b, "flash_bytes"));
        let mut b = good.clone();
        b["variants"]["libm-n3m3"]["cycles"] = json!(1);
        cases.push((b, "unknown figure"));
        let mut b = good;
        b["slack"] = json!(1);
        cases.push((b, "unknown key"));
        for (budget, says) in cases {
            match compare(&step, &budget) {
                Err(e) => assert!(e.contains(says), "{e} should say {says}"),
                Ok(v) => panic!("accepted {budget}: {v:?}"),
            }
        }
    }

    #[test]
    fn budget_from_a_clean_run_round_trips_and_refuses_a_faulted_one() {
        let step = step_at(1101, 1700, 400, 8000);
        let b = budget_from(&step).unwrap_or_default();
        assert_eq!(b["variants"]["libm-n3m3"]["instructions_max"], 1700);
        assert!(failures(&step, &b).is_empty());
        let mut faulted = step;
        set(&mut faulted, 0, "faulted_steps", json!(3));
        assert!(budget_from(&faulted).is_err_and(|e| e.contains("faulted")));
    }
}
