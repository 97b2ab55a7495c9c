//! Puts the QEMU machine's memory map on the linker search path as `memory.x` and points the
//! firmware at the replayed trace:
//!
//! * `BENCH_MACHINE` (set by `cargo xtask bench-target`): the QEMU machine, whose
//!   `memory/<machine>.x` is linked; `mps2-an386` (the Cortex-M4F) when unset.
//! * `BENCH_TRACE` (set by the xtask): the trace, or an empty one so that a plain `cargo build`
//!   works too (the firmware then reports that it has no steps).
//!
//! Targets without an FPU (`…-eabi`, not `…-eabihf`) get `cfg(soft_float)`: their step is
//! tens of times longer, so it is repeated fewer times per measurement.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let machine = env::var("BENCH_MACHINE").unwrap_or_else(|_| "mps2-an386".to_owned());
    let map = PathBuf::from("memory").join(format!("{machine}.x"));
    let text = fs::read(&map).unwrap_or_else(|e| panic!("{}: {e}", map.display()));
    fs::write(out.join("memory.x"), text).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", map.display());
    println!("cargo:rerun-if-env-changed=BENCH_MACHINE");
    println!("cargo:rustc-check-cfg=cfg(soft_float)");
    if !env::var("TARGET").unwrap_or_default().ends_with("eabihf") {
        println!("cargo:rustc-cfg=soft_float");
    }
    println!("cargo:rerun-if-env-changed=BENCH_TRACE");
    let trace = match env::var_os("BENCH_TRACE") {
        Some(t) => PathBuf::from(t),
        None => {
            let empty = out.join("empty-trace.f32le");
            fs::write(&empty, []).expect("write the empty trace");
            empty
        }
    };
    println!("cargo:rerun-if-changed={}", trace.display());
    println!("cargo:rustc-env=BENCH_TRACE_FILE={}", trace.display());
}
