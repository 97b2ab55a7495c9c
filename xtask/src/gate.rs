//! `cargo xtask bench-gate`: the regression gate on the deterministic target figures.
//!
//! `bench-fw/budget.json` holds one budget per benchmark variant (per core: the Cortex-M4F's
//! names carry no prefix, the other cores' start with `cortex-m0-`, …), every variant of
//! [`VARIANTS`] and no other:
//! ```json
//! { "tolerance": 0.10,
//!   "variants": { "libm-n2m2": { "flash_bytes": 8214, "flash_config_bytes": 3000,
//!                                "flash_config_bytes_reason": "why it rose",
//!                                "instructions_max": 1849, "instructions_median": 1234,
//!                                "stack_bytes": 400, "state_bytes": 424 }, … } }
//! ```
//! A variant fails the gate when
//!
//! * any of its six figures ([`FIGURES`]: instructions median and max, peak stack, step flash,
//!   configuration flash, `size_of` the controller) exceeds `budget · (1 + tolerance)`;
//! * for Example 1's agent's step on a core with an FPU (the `n = m = 2` variants; `libm-n3m3`,
//!   the node ticks and the soft-float cores, whose step links the `f32` library routines, are
//!   held to their budgets only): its stack exceeds [`STACK_GOAL`], or its step flash plus its configuration flash
//!   exceeds [`FLASH_GOAL`] (16 KiB), whatever the budget;
//! * a step of the replayed trace faulted, it ran no step, or it is missing from `step.json`.
//!
//! A budget that could let anything through is rejected before any comparison: a tolerance
//! outside `[0, MAX_TOLERANCE]`, a missing or unknown variant, a missing, zero or unknown
//! figure, a reason that is not a non-empty string or names no figure.
//!
//! `--update-budget` writes the budget from the measured figures. A figure above the committed
//! budget by more than its tolerance needs `--reason "…"`, written as `<figure>_reason` next to
//! each such figure; without one the update is refused and nothing is written. A reason stays
//! with its figure until the figure falls below the value it explained. The gate prints every
//! reason of the budget.

use crate::{
    target::VARIANTS,
    task::{bench_dir, workspace_root, Options, Result},
};
use serde_json::{json, Map, Value};
use std::fs;

/// Default tolerance above the budget, written by `--update-budget`.
pub const TOLERANCE: f64 = 0.10;
/// The largest tolerance a budget may set.
pub const MAX_TOLERANCE: f64 = 0.10;
/// Absolute goal for the painted stack of one step of Example 1's agent, bytes.
pub const STACK_GOAL: u64 = 512;
/// Absolute goal for the flash of Example 1's agent: the step and its callees plus the
/// configuration code linked beside it (`flash_bytes + flash_config_bytes`), bytes.
pub const FLASH_GOAL: u64 = 16 * 1024;

/// The gated figures: the key in `step.json` and in the budget, and its unit for messages.
const FIGURES: [(&str, &str); 6] = [
    ("instructions_median", "instructions"),
    ("instructions_max", "instructions"),
    ("stack_bytes", "B"),
    ("flash_bytes", "B"),
    ("flash_config_bytes", "B"),
    ("state_bytes", "B"),
];

/// The suffix of a figure's reason key in the budget.
const REASON: &str = "_reason";

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
        crate::bench::bench_target(opts)?
    };
    let committed = fs::read_to_string(&budget_path)
        .ok()
        .and_then(|t| serde_json::from_str::<Value>(&t).ok());
    if opts.update_budget {
        let budget = updated_budget(&step, committed.as_ref(), opts.reason.as_deref())
            .map_err(|e| format!("{}: {e}", budget_path.display()))?;
        let text = serde_json::to_string_pretty(&budget).map_err(|e| e.to_string())?;
        fs::write(&budget_path, text + "\n")
            .map_err(|e| format!("{}: {e}", budget_path.display()))?;
        println!("wrote {}", budget_path.display());
        return Ok(());
    }
    if opts.reason.is_some() {
        return Err("--reason goes with --update-budget".into());
    }
    let budget = committed.ok_or_else(|| {
        format!(
            "{}: missing or not JSON (`cargo xtask bench-gate --update-budget` writes it)",
            budget_path.display()
        )
    })?;
    let verdicts =
        compare(&step, &budget).map_err(|e| format!("{}: {e}", budget_path.display()))?;
    let mut failed = false;
    for v in &verdicts {
        println!("{v}");
        failed |= v.starts_with("FAIL");
    }
    if failed {
        Err(format!(
            "bench-gate: figures above budget or goal ({})",
            budget_path.display()
        ))
    } else {
        println!("bench-gate OK");
        Ok(())
    }
}

/// The budget for the figures of `step` (every variant must have run cleanly), checked
/// against the `committed` one: a figure above
/// it by more than its tolerance needs `reason` (written next to it); the committed reasons
/// of figures that did not fall below the value they explained are kept.
pub fn updated_budget(
    step: &Value,
    committed: Option<&Value>,
    reason: Option<&str>,
) -> Result<Value> {
    if reason.is_some_and(|r| r.trim().is_empty()) {
        return Err("--reason needs a text".into());
    }
    let old_tolerance = committed
        .and_then(|b| b["tolerance"].as_f64())
        .unwrap_or(TOLERANCE);
    let mut variants = Map::new();
    let mut unexplained = Vec::new();
    let mut used_reason = false;
    for v in measured_variants(step)? {
        let name = v["name"].as_str().ok_or("variant without a name")?;
        if let Some(problem) = run_problem(v) {
            return Err(format!("{name}: {problem}: no budget written"));
        }
        let old = committed.map(|b| &b["variants"][name]);
        let mut limits = Map::new();
        for (key, unit) in FIGURES {
            let value = v[key]
                .as_u64()
                .ok_or_else(|| format!("{name}: step.json has no {key}"))?;
            limits.insert(key.to_owned(), json!(value));
            let before = old.and_then(|o| o[key].as_u64());
            let old_reason = old.and_then(|o| o[format!("{key}{REASON}")].as_str());
            let raised = before.filter(|&b| value > allowed(b, old_tolerance));
            let why = match (raised, reason) {
                (Some(b), None) => {
                    unexplained.push(format!(
                        "{name}: {key} {value} {unit} is above the committed {b} {unit} + {:.0} %",
                        100.0 * old_tolerance
                    ));
                    None
                }
                (Some(_), Some(r)) => {
                    used_reason = true;
                    Some(r)
                }
                (None, _) => old_reason.filter(|_| before.is_none_or(|b| value >= b)),
            };
            if let Some(why) = why {
                limits.insert(format!("{key}{REASON}"), json!(why));
            }
        }
        variants.insert(name.to_owned(), Value::Object(limits));
    }
    if !unexplained.is_empty() {
        return Err(format!(
            "update refused, nothing written: a figure raised beyond the tolerance needs \
             `--reason \"…\"`:\n  {}",
            unexplained.join("\n  ")
        ));
    }
    if reason.is_some() && !used_reason {
        return Err("--reason given, but no figure rose beyond the tolerance".into());
    }
    let budget = json!({ "tolerance": TOLERANCE, "variants": variants });
    validate_budget(&budget)?;
    Ok(budget)
}

/// `limit · (1 + tolerance)`, rounded down.
fn allowed(limit: u64, tolerance: f64) -> u64 {
    (limit as f64 * (1.0 + tolerance)).floor() as u64
}

/// One budgeted variant: its limits in [`FIGURES`] order and the reasons given for them.
struct Limits {
    name: String,
    values: [u64; FIGURES.len()],
    reasons: Vec<(String, String)>,
}

/// The validated budget: tolerance and the limits of every variant.
struct Budget {
    tolerance: f64,
    variants: Vec<Limits>,
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
    let is_figure = |k: &str| FIGURES.iter().any(|(f, _)| *f == k);
    let mut variants = Vec::new();
    for v in VARIANTS {
        let limits = listed
            .get(v.name)
            .and_then(Value::as_object)
            .ok_or_else(|| format!("variant `{}` has no budget", v.name))?;
        let mut reasons = Vec::new();
        for (key, value) in limits {
            match key.strip_suffix(REASON) {
                _ if is_figure(key) => {}
                Some(figure) if is_figure(figure) => {
                    let text = value
                        .as_str()
                        .filter(|t| !t.trim().is_empty())
                        .ok_or_else(|| format!("{}: `{key}` must be a non-empty string", v.name))?;
                    reasons.push((figure.to_owned(), text.to_owned()));
                }
                _ => return Err(format!("{}: unknown figure `{key}`", v.name)),
            }
        }
        let mut values = [0u64; FIGURES.len()];
        for (slot, (key, _)) in values.iter_mut().zip(FIGURES) {
            *slot = limits
                .get(key)
                .and_then(Value::as_u64)
                .filter(|&x| x > 0)
                .ok_or_else(|| format!("{}: `{key}` must be a positive integer", v.name))?;
        }
        variants.push(Limits {
            name: v.name.to_owned(),
            values,
            reasons,
        });
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

/// One line per budgeted variant and figure, starting with `ok` or `FAIL`, then one `FAIL`
/// line per goal missed and one `note` line per reason of the budget; an error for a
/// malformed budget.
pub fn compare(step: &Value, budget: &Value) -> Result<Vec<String>> {
    let budget = validate_budget(budget)?;
    let measured = measured_variants(step)?;
    let pct = budget.tolerance * 100.0;
    let mut out = Vec::new();
    for Limits {
        name,
        values,
        reasons,
    } in &budget.variants
    {
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
        for (&limit, (key, unit)) in values.iter().zip(FIGURES) {
            let allowed = allowed(limit, budget.tolerance);
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
        if VARIANTS
            .iter()
            .any(|var| var.name == name && !var.n3 && var.core.fpu && !var.is_node())
        {
            out.extend(goals(name, v));
        }
        for (figure, why) in reasons {
            out.push(format!("note {name}: {figure} raised: {why}"));
        }
    }
    Ok(out)
}

/// The absolute goals of Example 1's agent, whatever the budget: stack, and step plus
/// configuration flash.
fn goals(name: &str, v: &Value) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(m) = v["stack_bytes"].as_u64().filter(|&m| m > STACK_GOAL) {
        out.push(format!(
            "FAIL {name}: stack_bytes {m} B > the goal of {STACK_GOAL} B"
        ));
    }
    let (step, config) = (v["flash_bytes"].as_u64(), v["flash_config_bytes"].as_u64());
    match step.zip(config).map(|(s, c)| (s, c, s + c)) {
        Some((s, c, total)) if total > FLASH_GOAL => out.push(format!(
            "FAIL {name}: flash_bytes + flash_config_bytes {s} + {c} = {total} B > the goal of \
             {FLASH_GOAL} B"
        )),
        Some((s, c, total)) => out.push(format!(
            "ok   {name}: flash_bytes + flash_config_bytes {s} + {c} = {total} B ≤ the goal of \
             {FLASH_GOAL} B"
        )),
        None => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether the absolute goals hold `v`: Example 1's step on a core with an FPU.
    fn goal_applies(v: &crate::target::Variant) -> bool {
        !v.n3 && v.core.fpu && !v.is_node()
    }

    /// Index in [`VARIANTS`] (and in the step files below) of the variant named `name`.
    fn at(name: &str) -> usize {
        VARIANTS
            .iter()
            .position(|v| v.name == name)
            .unwrap_or(usize::MAX)
    }

    /// A clean run of every variant at the given figures (configuration flash 2000 B, state
    /// 424 B).
    fn step_at(median: u64, max: u64, stack: u64, flash: u64) -> Value {
        let variants: Vec<Value> = VARIANTS
            .iter()
            .map(|v| {
                json!({ "name": v.name, "instructions_median": median, "instructions_max": max,
                        "stack_bytes": stack, "flash_bytes": flash, "flash_config_bytes": 2000,
                        "state_bytes": 424, "steps": 10_000, "faulted_steps": 0 })
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
                        "flash_config_bytes": 2000, "state_bytes": 424 }),
            );
        }
        json!({ "tolerance": 0.1, "variants": variants })
    }

    fn failures(step: &Value, budget: &Value) -> Vec<String> {
        compare(step, budget)
            .unwrap_or_else(|e| vec![format!("ERROR {e}")])
            .into_iter()
            .filter(|l| l.starts_with("FAIL") || l.starts_with("ERROR"))
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
            ("state_bytes", 467),
        ] {
            let mut step = step_at(1000, 1500, 400, 8000);
            set(&mut step, at("baseline-n2m2"), key, json!(value));
            let f = failures(&step, &budget);
            assert_eq!(f.len(), 1, "{key}: {f:?}");
            assert!(f[0].starts_with("FAIL baseline-n2m2") && f[0].contains(key));
        }
    }

    #[test]
    fn state_bytes_above_budget_fail_and_within_tolerance_pass() {
        let budget = budget_at(1000, 1500, 400, 8000);
        let mut step = step_at(1000, 1500, 400, 8000);
        set(&mut step, at("libm-n3m3"), "state_bytes", json!(466));
        assert!(failures(&step, &budget).is_empty());
        set(&mut step, at("libm-n3m3"), "state_bytes", json!(4096));
        assert_eq!(
            failures(&step, &budget),
            vec!["FAIL libm-n3m3: state_bytes 4096 B > 466 (budget 424 + 10 %)"]
        );
        set(&mut step, at("libm-n3m3"), "state_bytes", Value::Null);
        assert_eq!(
            failures(&step, &budget),
            vec!["FAIL libm-n3m3: state_bytes missing from step.json"]
        );
    }

    #[test]
    fn step_files_with_a_fault_a_huge_stack_or_flash_fail() {
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
    fn stack_goal_applies_to_every_example1_variant_with_an_fpu_whatever_the_budget() {
        let n2 = VARIANTS.iter().filter(|v| goal_applies(v)).count();
        let budget = budget_at(1000, 1500, 600, 8000);
        let f = failures(&step_at(1000, 1500, 600, 8000), &budget);
        assert_eq!(f.len(), n2, "{f:?}");
        assert!(f
            .iter()
            .all(|l| l.contains("stack_bytes 600 B > the goal of 512 B")
                && !l.contains("n3m3")
                && !l.contains("cortex-m0-")
                && !l.contains("cortex-m3-")
                && !l.contains("node-")));
    }

    #[test]
    fn step_plus_configuration_flash_over_16_kib_fails_every_example1_variant_with_an_fpu() {
        // Each part within its budget, the sum 14,400 + 2,000 = 16,400 B over the goal.
        let n2 = VARIANTS.iter().filter(|v| goal_applies(v)).count();
        let budget = budget_at(1000, 1500, 400, 14_400);
        let f = failures(&step_at(1000, 1500, 400, 14_400), &budget);
        assert_eq!(f.len(), n2, "{f:?}");
        for v in VARIANTS.iter().filter(|v| goal_applies(v)) {
            let want = format!(
                "FAIL {}: flash_bytes + flash_config_bytes 14400 + 2000 = 16400 B > the goal of 16384 B",
                v.name
            );
            assert!(f.contains(&want), "{want} in {f:?}");
        }
        // One variant alone over it by its configuration code; exactly 16 KiB passes.
        let mut step = step_at(1000, 1500, 400, 14_384);
        assert!(failures(&step, &budget).is_empty());
        set(
            &mut step,
            at("fast-math-n2m2"),
            "flash_config_bytes",
            json!(2001),
        );
        assert_eq!(
            failures(&step, &budget),
            vec!["FAIL fast-math-n2m2: flash_bytes + flash_config_bytes 14384 + 2001 = 16385 B > the goal of 16384 B"]
        );
        // n = m = 3 is held to its budget only.
        let mut step = step_at(1000, 1500, 400, 8000);
        set(
            &mut step,
            at("libm-n3m3"),
            "flash_config_bytes",
            json!(9000),
        );
        let budget = {
            let mut b = budget_at(1000, 1500, 400, 8000);
            b["variants"]["libm-n3m3"]["flash_config_bytes"] = json!(9000);
            b
        };
        assert!(failures(&step, &budget).is_empty());
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
        b["variants"]["fast-math-n2m2"]
            .as_object_mut()
            .map(|o| o.remove("state_bytes"));
        cases.push((b, "state_bytes"));
        let mut b = good.clone();
        b["variants"]["libm-n3m3"]["cycles"] = json!(1);
        cases.push((b, "unknown figure"));
        let mut b = good.clone();
        b["variants"]["libm-n3m3"]["cycles_reason"] = json!("faster");
        cases.push((b, "unknown figure"));
        let mut b = good.clone();
        b["variants"]["libm-n3m3"]["stack_bytes_reason"] = json!(" ");
        cases.push((b, "non-empty string"));
        let mut b = good.clone();
        b["variants"]["libm-n3m3"]["stack_bytes_reason"] = json!(12);
        cases.push((b, "non-empty string"));
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
        let b = updated_budget(&step, None, None).unwrap_or_default();
        assert_eq!(b["variants"]["libm-n3m3"]["instructions_max"], 1700);
        assert_eq!(b["variants"]["libm-n3m3"]["state_bytes"], 424);
        assert!(failures(&step, &b).is_empty());
        let mut faulted = step;
        set(&mut faulted, 0, "faulted_steps", json!(3));
        assert!(updated_budget(&faulted, None, None).is_err_and(|e| e.contains("faulted")));
    }

    #[test]
    fn an_update_raising_a_figure_beyond_tolerance_needs_a_reason() {
        let committed = budget_at(1000, 1500, 400, 8000);
        // Within the tolerance, or lower: no reason needed.
        let mut step = step_at(1100, 1200, 400, 8800);
        assert!(updated_budget(&step, Some(&committed), None).is_ok());
        // Above it: refused, naming the figure.
        set(
            &mut step,
            at("safety-n2m2"),
            "instructions_median",
            json!(1101),
        );
        set(&mut step, at("libm-n2m2"), "state_bytes", json!(500));
        let e = updated_budget(&step, Some(&committed), None)
            .err()
            .unwrap_or_default();
        assert!(e.contains("refused") && e.contains("--reason"), "{e}");
        assert!(
            e.contains(
                "safety-n2m2: instructions_median 1101 instructions is above the committed 1000"
            ),
            "{e}"
        );
        assert!(
            e.contains("libm-n2m2: state_bytes 500 B is above the committed 424"),
            "{e}"
        );
        // With a reason: written next to each raised figure, and printed by the gate.
        let why = "limits checked before the quantizer";
        let b = updated_budget(&step, Some(&committed), Some(why)).unwrap_or_default();
        assert_eq!(
            b["variants"]["safety-n2m2"]["instructions_median_reason"],
            why
        );
        assert_eq!(b["variants"]["libm-n2m2"]["state_bytes_reason"], why);
        assert!(b["variants"]["libm-n2m2"]["instructions_median_reason"].is_null());
        let text = serde_json::to_string_pretty(&b).unwrap_or_default();
        assert!(
            text.contains(&format!(
                "\"state_bytes\": 500,\n      \"state_bytes_reason\": \"{why}\""
            )),
            "{text}"
        );
        let lines = compare(&step, &b).unwrap_or_default();
        assert!(lines.contains(&format!(
            "note safety-n2m2: instructions_median raised: {why}"
        )));
        assert!(lines.contains(&format!("note libm-n2m2: state_bytes raised: {why}")));
        // The next update keeps a reason while its figure holds, drops it once it falls.
        let kept = updated_budget(&step, Some(&b), None).unwrap_or_default();
        assert_eq!(kept["variants"]["libm-n2m2"]["state_bytes_reason"], why);
        set(&mut step, at("libm-n2m2"), "state_bytes", json!(424));
        let dropped = updated_budget(&step, Some(&b), None).unwrap_or_default();
        assert!(dropped["variants"]["libm-n2m2"]["state_bytes_reason"].is_null());
        assert_eq!(
            dropped["variants"]["safety-n2m2"]["instructions_median_reason"],
            why
        );
        // A reason with nothing to explain, or an empty one, is refused too.
        let e = updated_budget(&step_at(1000, 1500, 400, 8000), Some(&committed), Some(why));
        assert!(e.is_err_and(|e| e.contains("no figure rose")));
        assert!(updated_budget(&step, Some(&committed), Some(" ")).is_err());
    }
}
