//! Cores without an FPU: what the soft-float step spends its instructions on, and what the
//! operations a fixed-point step would use instead cost there. Run by `cargo xtask
//! bench-target` after the variants; written to `target/bench/softfloat.json`.
//!
//! * **Operations** (`ops`): bench-fw's `ops` build times `f32` add, multiply, divide and
//!   compare (library calls on these cores) and the `fixed` crate's `I16F16` / `I32F32`
//!   saturating add, multiply, `checked_div`, `checked_sqrt` and the wrapping multiply, in
//!   instructions per operation.
//! * **Profile** (`profile`): the `libm` step on the first [`PROFILE_STEPS`] records of the
//!   trace, run with QEMU's `-d in_asm,exec,nochain` log: every executed translation block is
//!   charged its instruction count (from the block's disassembly) to the function it lies in,
//!   from the first entry into `step_entry` on (the configuration before is not counted, the
//!   benchmark harness's own functions are left out). Functions are grouped into the classes of
//!   [`class_of`]; a call of a class is an entry at a function's first instruction from a
//!   function of another class (`__aeabi_fmul` → `__mulsf3` → `__aeabi_lmul` is one multiply).
//!   Figures are per step (per entry into `step_entry`).

use crate::{
    target::{self, Core, Variant},
    task::Result,
};
use serde_json::{json, Map, Value};
use std::{
    collections::{BTreeMap, HashMap},
    fs,
    io::{BufRead, BufReader},
    path::Path,
};

/// Records of the trace the profile replays (each step runs `reps + 1` times).
pub const PROFILE_STEPS: usize = 20;

/// The class of the function `name` (a raw ELF symbol, as QEMU prints it), or `None` for the
/// benchmark harness (not counted).
pub fn class_of(name: &str) -> Option<&'static str> {
    const CLASSES: [(&str, &[&str]); 7] = [
        (
            "f32_mul",
            &["__aeabi_fmul", "__mulsf3", "__aeabi_lmul", "__muldi3"],
        ),
        (
            "f32_add",
            &["__aeabi_fadd", "__aeabi_fsub", "__addsf3", "__subsf3"],
        ),
        ("f32_div", &["__aeabi_fdiv", "__divsf3"]),
        ("f32_compare", &["__aeabi_fcmp", "sf2", "__unordsf2"]),
        (
            "f32_convert",
            &[
                "__aeabi_i2f",
                "__aeabi_ui2f",
                "__aeabi_f2",
                "__float",
                "__fix",
            ],
        ),
        ("f32_normalize", &["__clzsi2"]),
        ("memcpy", &["memcpy", "memset", "memmove"]),
    ];
    for (class, keys) in CLASSES {
        if keys.iter().any(|k| name.contains(k)) {
            return Some(class);
        }
    }
    if name.contains("step_entry") || name.contains("controller_core") || name.contains("libm") {
        return Some("law");
    }
    if name.contains("bench_fw") || name.contains("cortex_m") || name.contains("fmt") {
        return None;
    }
    Some("other")
}

/// Instructions and calls per class, per step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Profile {
    pub steps: u64,
    /// class → (instructions, calls), totals over the run.
    pub classes: BTreeMap<&'static str, (u64, u64)>,
}

/// Parses a QEMU `-d in_asm,exec,nochain` log; `starts` maps function start addresses to names.
pub fn parse_log(log: impl BufRead, starts: &HashMap<u64, String>) -> Result<Profile> {
    let mut block_len: HashMap<u64, u64> = HashMap::new();
    let mut block: Option<(u64, u64)> = None;
    let mut profile = Profile::default();
    let mut started = false;
    let mut previous: Option<&'static str> = None;
    for line in log.lines() {
        let line = line.map_err(|e| format!("QEMU log: {e}"))?;
        if line.starts_with("IN:") {
            block = None;
        } else if let Some(addr) = line
            .strip_prefix("0x")
            .and_then(|r| r.split_once(':'))
            .and_then(|(a, _)| u64::from_str_radix(a, 16).ok())
        {
            let (start, n) = block.map_or((addr, 1), |(s, n)| (s, n + 1));
            block = Some((start, n));
            block_len.insert(start, n);
        } else if let Some(rest) = line.strip_prefix("Trace ") {
            block = None;
            // `Trace 0: 0x7f… [00000000/000004a2/…/…] symbol`
            let pc = rest
                .split_once('[')
                .and_then(|(_, r)| r.split('/').nth(1))
                .and_then(|p| u64::from_str_radix(p, 16).ok())
                .ok_or_else(|| format!("QEMU log: bad exec line `{line}`"))?;
            let name = rest.split_once(']').map_or("", |(_, s)| s.trim());
            started |= name.contains("step_entry");
            let class = class_of(name);
            let entered = class != previous && starts.contains_key(&pc);
            if started {
                if entered && name.contains("step_entry") {
                    profile.steps += 1;
                }
                if let Some(class) = class {
                    let e = profile.classes.entry(class).or_default();
                    e.0 += block_len.get(&pc).copied().unwrap_or(0);
                    e.1 += u64::from(entered);
                }
            }
            previous = class;
        }
    }
    if profile.steps == 0 {
        return Err("QEMU log: the step was never entered".into());
    }
    Ok(profile)
}

/// Function start addresses of the ELF `data` (Thumb bit cleared) and their raw names.
fn function_starts(data: &[u8]) -> Result<HashMap<u64, String>> {
    use object::{Object, ObjectSymbol, SymbolKind};
    let file = object::File::parse(data).map_err(|e| format!("cannot parse the ELF: {e}"))?;
    Ok(file
        .symbols()
        .filter(|s| s.kind() == SymbolKind::Text)
        .filter_map(|s| Some((s.address() & !1, s.name().ok()?.to_owned())))
        .collect())
}

/// Instructions per operation from the `ops` build's output at `core`'s clock.
pub fn parse_ops(output: &str, core: &Core) -> Result<Map<String, Value>> {
    let line = output
        .lines()
        .find(|l| l.starts_with("BENCH-OPS "))
        .ok_or_else(|| format!("the ops firmware printed no BENCH-OPS line:\n{output}"))?;
    let field = |key: &str| -> Result<u64> {
        line.split_whitespace()
            .find_map(|kv| kv.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("the BENCH-OPS line has no number `{key}`"))
    };
    let (reps, empty) = (field("reps")?, field("empty_ticks")?);
    target::check_calibration(core, field("calib_ticks")?, field("calib_insns")?)?;
    let mut ops = Map::new();
    for l in output.lines().filter_map(|l| l.strip_prefix("OP ")) {
        let (name, ticks) = l
            .split_once(' ')
            .and_then(|(n, t)| Some((n, t.trim().parse::<u64>().ok()?)))
            .ok_or_else(|| format!("bad line `OP {l}`"))?;
        let insns =
            ticks.saturating_sub(empty) as f64 * 1000.0 / (core.clock_mhz as f64 * reps as f64);
        ops.insert(name.to_owned(), json!((insns * 10.0).round() / 10.0));
    }
    if ops.is_empty() {
        return Err("the ops firmware printed no OP line".into());
    }
    Ok(ops)
}

/// Operations and profile of every core without an FPU; writes `softfloat.json`.
pub fn run(trace_n2: &Path, dir: &Path) -> Result<Value> {
    let mut cores = Vec::new();
    for core in target::CORES.into_iter().filter(|c| !c.fpu) {
        let ops_variant = Variant {
            name: "ops",
            features: "libm,ops",
            n3: false,
            core,
        };
        eprintln!("bench: operation costs on {}", core.id);
        let elf = target::build(&ops_variant, trace_n2, dir)?;
        let ops = parse_ops(&target::run_qemu(&core, &elf, &[])?, &core)?;

        eprintln!("bench: profile of the soft-float step on {}", core.id);
        let record = trace_n2
            .metadata()
            .map_err(|e| format!("{}: {e}", trace_n2.display()))?;
        let bytes = fs::read(trace_n2).map_err(|e| format!("{}: {e}", trace_n2.display()))?;
        let short = dir.join("trace-n2-profile.f32le");
        let keep = (PROFILE_STEPS * 5 * 4).min(record.len() as usize);
        fs::write(&short, bytes.get(..keep).unwrap_or(&bytes))
            .map_err(|e| format!("{}: {e}", short.display()))?;
        let step_variant = Variant {
            name: "profile",
            features: "libm",
            n3: false,
            core,
        };
        let elf = target::build(&step_variant, &short, dir)?;
        let log = dir.join(format!("profile-{}.log", core.id));
        let log_arg = log.to_string_lossy().into_owned();
        target::run_qemu(
            &core,
            &elf,
            &["-d", "in_asm,exec,nochain", "-D", log_arg.as_str()],
        )?;
        let data = fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let file = fs::File::open(&log).map_err(|e| format!("{}: {e}", log.display()))?;
        let profile = parse_log(BufReader::new(file), &function_starts(&data)?)?;
        let _ = fs::remove_file(&log);
        let steps = profile.steps;
        let classes: Map<String, Value> = profile
            .classes
            .iter()
            .map(|(c, (insns, calls))| {
                (
                    (*c).to_owned(),
                    json!({
                        "instructions_per_step": insns / steps,
                        "calls_per_step": (*calls as f64 / steps as f64 * 10.0).round() / 10.0,
                    }),
                )
            })
            .collect();
        let total: u64 = profile.classes.values().map(|(i, _)| i).sum::<u64>() / steps;
        cores.push(json!({
            "core": core.id,
            "target": core.target,
            "machine": core.machine,
            "ops_instructions": ops,
            "profile": {
                "steps": steps,
                "instructions_per_step": total,
                "classes": classes,
            },
        }));
    }
    let doc = json!({
        "units": "ops_instructions: instructions per operation (QEMU -icount shift=0); profile: instructions and calls per Controller::step of the libm build, per class of function",
        "method": format!("ops: {} operations per timing on black_box operands, minus the empty loop; profile: QEMU -d in_asm,exec,nochain over the first {PROFILE_STEPS} records of the trace (each step run reps + 1 times), each executed block charged to its function", 64),
        "cores": cores,
    });
    let path = dir.join("softfloat.json");
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    fs::write(&path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_of_the_soft_float_routines_and_the_harness() {
        assert_eq!(class_of("__aeabi_fmul"), Some("f32_mul"));
        assert_eq!(
            class_of("_RNvNtNtCs1_17compiler_builtins5float3add8___addsf3"),
            Some("f32_add")
        );
        assert_eq!(class_of("__aeabi_fcmpgt"), Some("f32_compare"));
        assert_eq!(class_of("__aeabi_i2f"), Some("f32_convert"));
        assert_eq!(
            class_of("_ZN8bench_fw10step_entry17h41231c93e04c19d0E"),
            Some("law")
        );
        assert_eq!(class_of("_ZN8bench_fw15step_with_stack17hE"), None);
    }

    #[test]
    fn charges_blocks_to_functions_from_the_first_step_on() {
        let log = "\
IN: config
0x00000100:  2001  movs r0, #1
0x00000102:  4770  bx lr

Trace 0: 0x7f00 [00000000/00000100/00000000/00000000] config
IN: step_entry
0x00000200:  b580  push {r7, lr}
0x00000202:  f000  bl #0x300

Trace 0: 0x7f10 [00000000/00000200/00000000/00000000] step_entry
IN: __aeabi_fmul
0x00000300:  2001  movs r0, #1
0x00000302:  2001  movs r0, #1
0x00000304:  4770  bx lr

IN: __mulsf3
0x00000400:  2001  movs r0, #1
0x00000402:  4770  bx lr

Trace 0: 0x7f20 [00000000/00000300/00000000/00000000] __aeabi_fmul
Trace 0: 0x7f20 [00000000/00000300/00000000/00000000] __aeabi_fmul
Trace 0: 0x7f30 [00000000/00000400/00000000/00000000] __mulsf3
Trace 0: 0x7f10 [00000000/00000200/00000000/00000000] step_entry
";
        let starts: HashMap<u64, String> = [
            (0x100, "config".to_owned()),
            (0x200, "step_entry".to_owned()),
            (0x300, "__aeabi_fmul".to_owned()),
            (0x400, "__mulsf3".to_owned()),
        ]
        .into();
        let p = parse_log(log.as_bytes(), &starts).unwrap_or_default();
        assert_eq!(p.steps, 2);
        assert_eq!(p.classes.get("law"), Some(&(4, 2)));
        // Re-entering the block at the function's start from within it, or the multiply's
        // wrapper calling its routine, is not another call.
        assert_eq!(p.classes.get("f32_mul"), Some(&(8, 1)));
        assert!(!p.classes.contains_key("other"));
    }
}
