//! Flash of the controller: the `.text` + `.rodata` of `Controller::step` and its callees, from
//! the ELF's symbol sizes, and in a second figure the configuration code a firmware links with
//! it: `Controller::new` and its callees (`powf`, `logf`, `expf`, …) not already counted for
//! the step.
//!
//! * Code: the call graph from the firmware's `step_entry` wrapper (into which LTO inlines
//!   `step`), found by decoding the Thumb-2 `BL` / `B.W` / `B` instructions of each reached
//!   function (literal pools, marked by the `$d` mapping symbols, are skipped). Panic paths
//!   (`core::panicking`, `core::fmt`, …: the formatting machinery) are not followed or counted;
//!   `memcpy` / `fminf`-style routines the step calls are.
//! * Read-only data: the named `.rodata` objects of controller-core, and those of libm or
//!   micromath when a function of that crate is reached (e.g. libm's `RSQRT_TAB` with
//!   `sqrtf`). Constants kept in literal pools are inside the function sizes. A table used
//!   only by a libm routine that LTO inlined into the step would be missed; none is here.
//!
//! Not counted: the vector table, the runtime, the benchmark loops and the semihosting output.

use crate::task::Result;
use object::{Object, ObjectSection, ObjectSymbol, SectionKind, SymbolKind};
use std::collections::{BTreeMap, BTreeSet};

/// One counted symbol.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Counted {
    pub name: String,
    pub size: u64,
}

/// The counted symbols and their total, for the step and for the configuration.
#[derive(Debug, Clone, Default)]
pub struct Flash {
    pub total: u64,
    pub symbols: Vec<Counted>,
    /// Code and tables reached from `Controller::new` only.
    pub config_total: u64,
    pub config_symbols: Vec<Counted>,
}

/// The entry of the step's call graph.
const ENTRY: &str = "bench_fw::step_entry";
/// The entry of the configuration's call graph.
const CONFIG_ENTRY: &str = "bench_fw::config_entry";

/// Whether a demangled read-only data symbol belongs to the controller's math.
pub fn is_controller_data(name: &str) -> bool {
    [
        "controller_core::",
        "<controller_core::",
        "libm::",
        "micromath::",
        "agent_node::",
        "<agent_node::",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

/// Panic and formatting paths: never followed, never counted.
pub fn is_panic_path(name: &str) -> bool {
    [
        "core::panicking::",
        "core::fmt::",
        "<core::fmt::",
        "core::slice::index::",
        "core::option::expect_failed",
        "core::result::unwrap_failed",
        "rust_begin_unwind",
        "panic_semihosting",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

struct Function {
    name: String,
    end: u64,
    size: u64,
}

/// The entries of the `node` variant's call graphs: a node's tick and its construction.
pub const NODE_ENTRIES: (&str, &str) = ("bench_fw::node::tick_entry", "bench_fw::node::new_entry");

/// Sums the controller's code and data in the ELF `data`.
pub fn controller_flash(data: &[u8]) -> Result<Flash> {
    flash_from(data, (ENTRY, CONFIG_ENTRY))
}

/// Sums the code and data reached from `entries` (the measured call, the construction) in the
/// ELF `data`.
pub fn flash_from(data: &[u8], entries: (&str, &str)) -> Result<Flash> {
    let (entry, config_entry) = entries;
    let file = object::File::parse(data).map_err(|e| format!("cannot parse the ELF: {e}"))?;
    let mut functions: BTreeMap<u64, Function> = BTreeMap::new();
    // Mapping symbols: address → true for data ($d), false for code ($t).
    let mut mapping: BTreeMap<u64, bool> = BTreeMap::new();
    let mut rodata = Vec::new();
    for sym in file.symbols() {
        let Ok(raw) = sym.name() else { continue };
        if raw == "$d" || raw.starts_with("$d.") || raw == "$t" || raw.starts_with("$t.") {
            mapping.insert(sym.address(), raw.starts_with("$d"));
            continue;
        }
        let Some(section) = sym
            .section_index()
            .and_then(|i| file.section_by_index(i).ok())
        else {
            continue;
        };
        if sym.size() == 0 {
            continue;
        }
        let name = format!("{:#}", rustc_demangle::demangle(raw));
        match (sym.kind(), section.kind()) {
            (SymbolKind::Text, SectionKind::Text) => {
                // Thumb function addresses carry bit 0; aliases share an address.
                let start = sym.address() & !1;
                functions.entry(start).or_insert(Function {
                    name,
                    end: start + sym.size(),
                    size: sym.size(),
                });
            }
            (SymbolKind::Data, SectionKind::ReadOnlyData | SectionKind::ReadOnlyString)
                if is_controller_data(&name) =>
            {
                rodata.push(Counted {
                    name,
                    size: sym.size(),
                })
            }
            _ => {}
        }
    }
    let text = file
        .sections()
        .find(|s| s.kind() == SectionKind::Text && s.name().is_ok_and(|n| n == ".text"))
        .ok_or("the ELF has no .text")?;
    let text_addr = text.address();
    let text_bytes = text.data().map_err(|e| format!(".text: {e}"))?;
    let reach = |name: &str| -> Result<BTreeSet<u64>> {
        let entry = functions
            .iter()
            .find(|(_, f)| f.name.contains(name))
            .map(|(a, _)| *a)
            .ok_or_else(|| format!("no `{name}` in the ELF (was it linked?)"))?;
        let mut reached = BTreeSet::from([entry]);
        let mut todo = vec![entry];
        while let Some(start) = todo.pop() {
            let Some(f) = functions.get(&start) else {
                continue;
            };
            for target in branch_targets(text_bytes, text_addr, start, f.end, &mapping) {
                if (start..f.end).contains(&target) {
                    continue;
                }
                let Some(callee) = functions.get(&target) else {
                    continue;
                };
                if is_panic_path(&callee.name) {
                    continue;
                }
                if reached.insert(target) {
                    todo.push(target);
                }
            }
        }
        Ok(reached)
    };
    let step = reach(entry)?;
    let config: BTreeSet<u64> = reach(config_entry)?.difference(&step).copied().collect();
    let counted = |set: &BTreeSet<u64>| -> Vec<Counted> {
        set.iter()
            .filter_map(|a| functions.get(a))
            .map(|f| Counted {
                name: f.name.clone(),
                size: f.size,
            })
            .collect()
    };
    let (mut symbols, mut config_symbols) = (counted(&step), counted(&config));
    // Read-only tables of a math crate count where one of its functions is reached (they are
    // inlined there, or called): with the step if the step reaches it, else with the
    // configuration; controller-core's with the step (the step is its code).
    let crates = |symbols: &[Counted]| -> BTreeSet<String> {
        symbols
            .iter()
            .map(|f| crate_of(&f.name).to_owned())
            .collect()
    };
    let (step_crates, config_crates) = (crates(&symbols), crates(&config_symbols));
    for d in rodata {
        let krate = crate_of(&d.name);
        if krate == "controller_core" || step_crates.contains(krate) {
            symbols.push(d);
        } else if config_crates.contains(krate) {
            config_symbols.push(d);
        }
    }
    let sorted = |mut v: Vec<Counted>| {
        v.sort_by(|a, b| b.size.cmp(&a.size).then(a.name.cmp(&b.name)));
        let total = v.iter().map(|s| s.size).sum();
        (total, v)
    };
    let ((total, symbols), (config_total, config_symbols)) =
        (sorted(symbols), sorted(config_symbols));
    Ok(Flash {
        total,
        symbols,
        config_total,
        config_symbols,
    })
}

/// The crate a demangled symbol belongs to (`<a::B as c::D>::f` → `a`).
fn crate_of(name: &str) -> &str {
    name.trim_start_matches('<')
        .split("::")
        .next()
        .unwrap_or("")
}

/// Targets of the direct branches (`BL`, `B.W`, 16-bit `B`) in the code of `[start, end)`.
fn branch_targets(
    text: &[u8],
    text_addr: u64,
    start: u64,
    end: u64,
    mapping: &BTreeMap<u64, bool>,
) -> Vec<u64> {
    let half = |addr: u64| -> Option<u32> {
        let o = usize::try_from(addr.checked_sub(text_addr)?).ok()?;
        let b = text.get(o..o + 2)?;
        Some(u32::from(u16::from_le_bytes([b[0], b[1]])))
    };
    let in_data = |addr: u64| mapping.range(..=addr).next_back().is_some_and(|(_, d)| *d);
    let mut out = Vec::new();
    let mut pc = start;
    while pc + 2 <= end {
        if in_data(pc) {
            // Skip to the next code mapping symbol (or the end).
            pc = mapping
                .range(pc + 1..end)
                .find(|(_, d)| !**d)
                .map_or(end, |(a, _)| *a);
            continue;
        }
        let Some(h1) = half(pc) else { break };
        if matches!(h1 >> 11, 0b11101..=0b11111) {
            let Some(h2) = half(pc + 2) else { break };
            if h1 >> 11 == 0b11110 && (h2 >> 14) & 1 == 1 && (h2 >> 12) & 1 == 1 {
                // BL (T1) or B.W (T4): S:I1:I2:imm10:imm11:0.
                let s = (h1 >> 10) & 1;
                let (j1, j2) = ((h2 >> 13) & 1, (h2 >> 11) & 1);
                let (i1, i2) = (!(j1 ^ s) & 1, !(j2 ^ s) & 1);
                let imm = (s << 24)
                    | (i1 << 23)
                    | (i2 << 22)
                    | ((h1 & 0x3ff) << 12)
                    | ((h2 & 0x7ff) << 1);
                let offset = ((imm << 7) as i32) >> 7;
                out.push((pc as i64 + 4 + i64::from(offset)) as u64);
            }
            pc += 4;
        } else {
            if h1 >> 11 == 0b11100 {
                // B (T2), a possible tail call.
                let offset = (((h1 & 0x7ff) << 21) as i32) >> 20;
                out.push((pc as i64 + 4 + i64::from(offset)) as u64);
            }
            pc += 2;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classification() {
        assert!(is_controller_data("libm::math::generic::sqrt::RSQRT_TAB"));
        assert!(!is_controller_data("cortex_m_semihosting::hio::X"));
        assert!(is_panic_path("core::panicking::panic_fmt"));
        assert!(is_panic_path("core::fmt::write"));
        assert!(!is_panic_path("libm::math::powf::powf"));
    }

    #[test]
    fn decodes_thumb2_branches() {
        // At 0x100: `bl 0x17ec`-style encoding: BL from 0x100 to 0x200 is offset 0xfc:
        // h1 = 0xf000, h2 = 0xf87e (imm11 = 0x7e → 0xfc). Then `b.n` back to 0x100 (offset −8).
        let code: [u8; 8] = [0x00, 0xf0, 0x7e, 0xf8, 0x00, 0xbf, 0xfb, 0xe7];
        let t = branch_targets(&code, 0x100, 0x100, 0x108, &BTreeMap::new());
        assert_eq!(t, vec![0x200, 0x100]);
    }
}
