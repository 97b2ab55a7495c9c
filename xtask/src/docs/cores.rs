//! Figures of docs/FIRMWARE.md §3a, "Which microcontroller": the step and a node's tick on every
//! Cortex-M class (`cores.table`), the buyer's table of named CAN parts (`cores.mcu`), and for
//! the cores without an FPU the cost of each operation (`cores.ops`), where the soft-float step's
//! instructions go (`cores.profile`) and what a fixed-point step could gain at best
//! (`cores.fixed-bound`, `cores.fixed-bound.KEY`). Sources: `target/bench/step.json` and
//! `target/bench/softfloat.json`, both written by `cargo xtask bench-target`.
//!
//! **From instructions to cycles.** QEMU counts instructions, not cycles. A core that issues one
//! instruction at a time spends at least one cycle on each; the TRMs' instruction timings (zero
//! wait states) charge most data operations 1 cycle and the common multi-cycle classes 2 to 4:
//! single loads and stores 2, taken branches 1 + P with P = 1 to 3 (Cortex-M3 TRM, ARM DDI 0337,
//! §18.2; the Cortex-M4 the same, its FPU's `VADD`/`VMUL` 1 and `VDIV`/`VSQRT` 14, DDI 0439),
//! on the Cortex-M0 loads 2, taken branches 3, `BL` 4 (DDI 0432, Table 3-1), on the M0+ loads 2,
//! taken branches 2, `BL` 3 (DDI 0484). The Cortex-M7 issues up to two instructions per cycle.
//! So the table gives the cycles of a step as a range, `instructions × CPI` with CPI from
//! [`CPI_LOW`] (1; 0.5 on the M7) to [`CPI_HIGH`] (2: code in which every instruction is a
//! load, a store or a taken branch), with the flash wait states of the named parts assumed
//! hidden by their caches (ART accelerator, instruction cache, prefetch). The verdict takes the
//! pessimistic end.

use super::{fixed, grouped, Sources};
use crate::task::Result;
use serde_json::Value;
use std::fmt::Write as _;

/// Cycles per instruction at the optimistic end (a single-issue core; the M7 dual-issues).
const CPI_LOW: f64 = 1.0;
/// Cycles per instruction at the M7's optimistic end (two instructions per cycle).
const CPI_LOW_DUAL: f64 = 0.5;
/// Cycles per instruction at the pessimistic end.
const CPI_HIGH: f64 = 2.0;
/// The loop the verdict asks for, Hz, and the CPU share it may take.
const LOOP_HZ: f64 = 1000.0;
const SHARE: f64 = 0.5;

/// The named CAN part of each core: core id, part, its core, clock (MHz).
pub const PARTS: [(&str, &str, &str, f64); 5] = [
    ("cortex-m0", "STM32G0B1", "Cortex-M0+, FDCAN, no FPU", 64.0),
    ("cortex-m3", "STM32F103", "Cortex-M3, bxCAN, no FPU", 72.0),
    ("cortex-m4f", "STM32G474", "Cortex-M4F, FDCAN", 170.0),
    ("cortex-m7", "STM32H743", "Cortex-M7, FDCAN", 480.0),
    (
        "cortex-m33",
        "STM32H563",
        "Cortex-M33 with FPU, FDCAN",
        250.0,
    ),
];

/// Keys of `cores.fixed-bound.KEY`.
pub const BOUND_KEYS: [&str; 4] = [
    "soft",
    "i16f16-wrapping-speedup",
    "i16f16-speedup",
    "i32f32-speedup",
];

/// Whether `name` (after `cores.`) is one of this module's figures.
pub fn known(name: &str) -> bool {
    matches!(name, "table" | "mcu" | "ops" | "profile" | "fixed-bound")
        || name
            .strip_prefix("fixed-bound.")
            .is_some_and(|k| BOUND_KEYS.contains(&k))
}

/// Renders `cores.NAME`.
pub fn render(src: &mut Sources, name: &str) -> Result<String> {
    match name {
        "table" => table(&src.bench()?),
        "mcu" => mcu(&src.bench()?),
        "ops" => ops_table(&src.softfloat()?),
        "profile" => profile_table(&src.softfloat()?),
        "fixed-bound" => bound_table(&src.softfloat()?),
        _ => {
            let key = name.strip_prefix("fixed-bound.").unwrap_or(name);
            bound_figure(&src.softfloat()?, key)
        }
    }
}

fn variants(step: &Value) -> Result<&Vec<Value>> {
    step["variants"]
        .as_array()
        .ok_or_else(|| "step.json has no `variants`".to_owned())
}

fn count(v: &Value, key: &str) -> Result<u64> {
    v[key].as_u64().ok_or_else(|| {
        format!(
            "{}: no number `{key}` in step.json",
            v["name"].as_str().unwrap_or("?")
        )
    })
}

/// The variant of `core` whose name ends in `suffix` (`libm-n2m2`, `node-n2m2`).
fn find<'a>(step: &'a Value, core: &str, suffix: &str) -> Result<&'a Value> {
    variants(step)?
        .iter()
        .find(|v| {
            v["core"] == core
                && v["name"]
                    .as_str()
                    .is_some_and(|n| n == suffix || n == format!("{core}-{suffix}"))
        })
        .ok_or_else(|| format!("step.json has no `{suffix}` variant on {core}"))
}

/// `cores.table`: every core's math back-ends and node tick.
fn table(step: &Value) -> Result<String> {
    let mut t = String::from(
        "| core | target | QEMU machine | variant | instructions min | median | max | stack B | flash B (step + `new`) |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for (core, ..) in PARTS {
        for suffix in ["libm-n2m2", "fast-math-n2m2", "micromath-n2m2", "node-n2m2"] {
            let v = find(step, core, suffix)?;
            let shown = if suffix == "node-n2m2" {
                "`Node::tick` (`libm`)".to_owned()
            } else {
                format!("`{}`", suffix.trim_end_matches("-n2m2"))
            };
            let _ = writeln!(
                t,
                "| {core} | `{}` | `{}` | {shown} | {} | {} | {} | {} | {} |",
                v["target"].as_str().unwrap_or("?"),
                v["machine"].as_str().unwrap_or("?"),
                grouped(count(v, "instructions_min")? as f64, 0),
                grouped(count(v, "instructions_median")? as f64, 0),
                grouped(count(v, "instructions_max")? as f64, 0),
                count(v, "stack_bytes")?,
                grouped(
                    (count(v, "flash_bytes")? + count(v, "flash_config_bytes")?) as f64,
                    0
                ),
            );
        }
    }
    Ok(t)
}

/// Share of a 1 kHz period and the largest rate leaving half the CPU free, for `insns` at
/// `mhz` and `cpi`.
fn load(insns: f64, mhz: f64, cpi: f64) -> (f64, f64) {
    let seconds = insns * cpi / (mhz * 1e6);
    (seconds * LOOP_HZ, SHARE / seconds)
}

/// `cores.mcu`: per named part, the worst step and the worst node tick at its clock.
fn mcu(step: &Value) -> Result<String> {
    let mut t = String::from(
        "| part (core, clock) | measured as | worst instructions | cycles (CPI range) | share of a 1 kHz period | largest rate with half the CPU free | verdict at 1 kHz |\n|---|---|---|---|---|---|---|\n",
    );
    for (core, part, what, mhz) in PARTS {
        let low = if core == "cortex-m7" {
            CPI_LOW_DUAL
        } else {
            CPI_LOW
        };
        for (suffix, label) in [("libm-n2m2", "step"), ("node-n2m2", "node tick")] {
            let v = find(step, core, suffix)?;
            let worst = count(v, "instructions_max")? as f64;
            let (share_lo, rate_hi) = load(worst, mhz, low);
            let (share_hi, rate_lo) = load(worst, mhz, CPI_HIGH);
            let verdict = verdict(worst, mhz, low);
            let _ = writeln!(
                t,
                "| {part} ({what}, {mhz:.0} MHz) | {label} on {core} | {} | {}–{} | {}–{} % | {}–{} Hz | {verdict} |",
                grouped(worst, 0),
                grouped(worst * low, 0),
                grouped(worst * CPI_HIGH, 0),
                fixed(100.0 * share_lo, 1),
                fixed(100.0 * share_hi, 1),
                grouped(round_rate(rate_lo), 0),
                grouped(round_rate(rate_hi), 0),
            );
        }
    }
    Ok(t)
}

/// The verdict at 1 kHz with half the CPU free for `insns` at `mhz`, the CPI at the
/// optimistic end being `low`: fits at the pessimistic CPI, fits only below the CPI that takes
/// half the period (to be measured on the part), or does not fit at the optimistic CPI.
fn verdict(insns: f64, mhz: f64, low: f64) -> String {
    // The CPI at which the work takes exactly the allowed share of the period.
    let limit = SHARE * mhz * 1e6 / (LOOP_HZ * insns);
    if limit >= CPI_HIGH {
        "fits, half the CPU free".to_owned()
    } else if limit >= low {
        format!(
            "fits only at a CPI ≤ {}: measure on the part",
            fixed(limit, 2)
        )
    } else {
        "does not fit with half the CPU free".to_owned()
    }
}

/// A rate rounded down to 3 significant digits (what a designer would pick).
fn round_rate(hz: f64) -> f64 {
    if hz <= 0.0 || !hz.is_finite() {
        return 0.0;
    }
    let scale = 10f64.powi(hz.log10().floor() as i32 - 2);
    (hz / scale).floor() * scale
}

fn soft_cores(doc: &Value) -> Result<&Vec<Value>> {
    doc["cores"]
        .as_array()
        .ok_or_else(|| "softfloat.json has no `cores`".to_owned())
}

fn op(c: &Value, name: &str) -> Result<f64> {
    c["ops_instructions"][name]
        .as_f64()
        .ok_or_else(|| format!("softfloat.json: no operation `{name}`"))
}

/// `cores.ops`: instructions per operation on each core without an FPU.
fn ops_table(doc: &Value) -> Result<String> {
    const ROWS: [(&str, &str, &str, &str); 5] = [
        ("add", "f32_add", "i16f16_add", "i32f32_add"),
        ("multiply", "f32_mul", "i16f16_mul", "i32f32_mul"),
        (
            "multiply, wrapping",
            "f32_mul",
            "i16f16_mul_wrapping",
            "i32f32_mul_wrapping",
        ),
        ("divide", "f32_div", "i16f16_div", "i32f32_div"),
        ("square root", "", "i16f16_sqrt", "i32f32_sqrt"),
    ];
    let mut t = String::from(
        "| core | operation | `f32` (library call) | `I16F16` | `I32F32` |\n|---|---|---|---|---|\n",
    );
    for c in soft_cores(doc)? {
        let core = c["core"].as_str().unwrap_or("?");
        for (what, f, h, w) in ROWS {
            let f = if f.is_empty() {
                "(the law's own kernel)".to_owned()
            } else {
                fixed(op(c, f)?, 0)
            };
            let _ = writeln!(
                t,
                "| {core} | {what} | {f} | {} | {} |",
                fixed(op(c, h)?, 0),
                fixed(op(c, w)?, 0)
            );
        }
    }
    Ok(t)
}

/// The profile classes in table order, with their labels.
const CLASSES: [(&str, &str); 9] = [
    ("f32_mul", "`f32` multiply (`__mulsf3`, its 64-bit product)"),
    ("f32_add", "`f32` add/subtract (`__addsf3`)"),
    ("f32_div", "`f32` divide (`__divsf3`)"),
    ("f32_compare", "`f32` compare"),
    ("f32_convert", "`f32` ↔ integer"),
    ("f32_normalize", "normalisation (`__clzsi2`)"),
    ("law", "the law's own code (controller-core, kernels)"),
    ("memcpy", "copies (`memcpy`)"),
    ("other", "other"),
];

fn class(c: &Value, name: &str) -> (f64, f64) {
    let v = &c["profile"]["classes"][name];
    (
        v["instructions_per_step"].as_f64().unwrap_or(0.0),
        v["calls_per_step"].as_f64().unwrap_or(0.0),
    )
}

fn profile_total(c: &Value) -> Result<f64> {
    c["profile"]["instructions_per_step"]
        .as_f64()
        .ok_or_else(|| "softfloat.json: no profile total".to_owned())
}

/// `cores.profile`: where the soft-float step's instructions go.
fn profile_table(doc: &Value) -> Result<String> {
    let mut t = String::from(
        "| core | class | instructions per step | share | calls per step | instructions per call |\n|---|---|---|---|---|---|\n",
    );
    for c in soft_cores(doc)? {
        let core = c["core"].as_str().unwrap_or("?");
        let total = profile_total(c)?;
        for (key, label) in CLASSES {
            let (insns, calls) = class(c, key);
            if insns == 0.0 {
                continue;
            }
            let per = if calls > 0.0 && key != "law" {
                fixed(insns / calls, 0)
            } else {
                "–".to_owned()
            };
            let _ = writeln!(
                t,
                "| {core} | {label} | {} | {} % | {} | {per} |",
                grouped(insns, 0),
                fixed(100.0 * insns / total, 1),
                fixed(calls, 1)
            );
        }
        let _ = writeln!(
            t,
            "| {core} | **total** | {} | 100 % | | |",
            grouped(total, 0)
        );
    }
    Ok(t)
}

/// The best-case fixed-point step of core `c`: the law's own code and the copies kept, every
/// `f32` call replaced by the fixed-point operation (`mul`, `add`, `div` names of `ops`;
/// compares and conversions by an add; the normalisation is inside the soft-float routines and
/// goes with them).
fn bound(c: &Value, mul: &str, add: &str, div: &str) -> Result<f64> {
    let kept: f64 = ["law", "memcpy", "other"]
        .iter()
        .map(|k| class(c, k).0)
        .sum();
    let calls = |k: &str| class(c, k).1;
    Ok(kept
        + calls("f32_mul") * op(c, mul)?
        + (calls("f32_add") + calls("f32_compare") + calls("f32_convert")) * op(c, add)?
        + calls("f32_div") * op(c, div)?)
}

/// The fixed-point formats of the bound: label, multiply, add, divide.
const FORMATS: [(&str, &str, &str, &str); 4] = [
    (
        "`I16F16`, saturating",
        "i16f16_mul",
        "i16f16_add",
        "i16f16_div",
    ),
    (
        "`I16F16`, wrapping multiply (ranges proven)",
        "i16f16_mul_wrapping",
        "i16f16_add",
        "i16f16_div",
    ),
    (
        "`I32F32`, saturating",
        "i32f32_mul",
        "i32f32_add",
        "i32f32_div",
    ),
    (
        "`I32F32`, wrapping multiply (ranges proven)",
        "i32f32_mul_wrapping",
        "i32f32_add",
        "i32f32_div",
    ),
];

/// `cores.fixed-bound`: per core and format, the best-case fixed-point step and its speed-up.
fn bound_table(doc: &Value) -> Result<String> {
    let mut t = String::from(
        "| core | soft-float step (profile) | fixed-point format | best-case fixed-point step | speed-up |\n|---|---|---|---|---|\n",
    );
    for c in soft_cores(doc)? {
        let core = c["core"].as_str().unwrap_or("?");
        let soft = profile_total(c)?;
        for (label, mul, add, div) in FORMATS {
            let b = bound(c, mul, add, div)?;
            let _ = writeln!(
                t,
                "| {core} | {} | {label} | {} | {}× |",
                grouped(soft, 0),
                grouped(b, 0),
                fixed(soft / b, 2)
            );
        }
    }
    Ok(t)
}

/// `cores.fixed-bound.KEY`: one figure of the Cortex-M0's bound.
fn bound_figure(doc: &Value, key: &str) -> Result<String> {
    let c = soft_cores(doc)?
        .iter()
        .find(|c| c["core"] == "cortex-m0")
        .ok_or("softfloat.json has no cortex-m0")?;
    let soft = profile_total(c)?;
    let speedup = |(_, mul, add, div): (&str, &str, &str, &str)| -> Result<String> {
        Ok(fixed(soft / bound(c, mul, add, div)?, 2))
    };
    match key {
        "soft" => Ok(grouped(soft, 0)),
        "i16f16-speedup" => speedup(FORMATS[0]),
        "i16f16-wrapping-speedup" => speedup(FORMATS[1]),
        "i32f32-speedup" => speedup(FORMATS[2]),
        _ => Err(format!("cores.fixed-bound has no figure `{key}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn load_and_rates() {
        // 10,000 instructions at 100 MHz and CPI 1: 0.1 ms, 10 % of 1 kHz, 5 kHz at half.
        let (share, rate) = load(10_000.0, 100.0, 1.0);
        assert!((share - 0.1).abs() < 1e-12 && (rate - 5000.0).abs() < 1e-6);
        assert_eq!(round_rate(12_345.0), 12_300.0);
        assert_eq!(round_rate(987.6), 987.0);
    }

    #[test]
    fn verdicts_at_both_ends_of_the_cpi_range() {
        // 100 MHz, 1 kHz, half: 50,000 cycles allowed.
        assert_eq!(verdict(25_000.0, 100.0, 1.0), "fits, half the CPU free");
        assert_eq!(
            verdict(40_000.0, 100.0, 1.0),
            "fits only at a CPI ≤ 1.25: measure on the part"
        );
        assert_eq!(
            verdict(60_000.0, 100.0, 1.0),
            "does not fit with half the CPU free"
        );
        // The dual-issue core fits at half a cycle per instruction.
        assert!(verdict(60_000.0, 100.0, 0.5).starts_with("fits only at a CPI ≤ 0.83"));
    }

    #[test]
    fn the_bound_replaces_each_call_by_its_fixed_point_operation() {
        let c = json!({
            "ops_instructions": {"m": 10.0, "a": 1.0, "d": 100.0},
            "profile": {"instructions_per_step": 5000, "classes": {
                "law": {"instructions_per_step": 1000, "calls_per_step": 1.0},
                "f32_mul": {"instructions_per_step": 2000, "calls_per_step": 20.0},
                "f32_add": {"instructions_per_step": 1500, "calls_per_step": 15.0},
                "f32_div": {"instructions_per_step": 500, "calls_per_step": 2.0},
            }},
        });
        // 1000 kept + 20·10 + 15·1 + 2·100.
        assert_eq!(bound(&c, "m", "a", "d").unwrap_or_default(), 1415.0);
        assert!(bound(&c, "x", "a", "d").is_err());
    }
}
