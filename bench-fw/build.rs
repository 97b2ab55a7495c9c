//! Puts the QEMU machine's memory map on the linker search path as `memory.x` and points the
//! firmware at the replayed trace:
//!
//! * `BENCH_MACHINE` (set by `cargo xtask bench-target`): the QEMU machine, whose
//!   `memory/<machine>.x` is linked; `mps2-an386` (the Cortex-M4F) when unset.
//! * `BENCH_TRACE` (set by the xtask): the trace, or an empty one so that a plain `cargo build`
//!   works too (the firmware then reports that it has no steps). The `node` variant embeds
//!   it without the leader's field, which its agent never reads.
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
    let trace = if env::var_os("CARGO_FEATURE_NODE").is_some() {
        node_trace(&trace, &out)
    } else {
        trace
    };
    println!("cargo:rustc-env=BENCH_TRACE_FILE={}", trace.display());
}

/// The node variant's trace: each record without its last field, the leader's `y_d`, which
/// agent 4 (not pinned) never reads (`src/trace.rs`, `STORED`): 16 of 20 bytes per record, so
/// that the whole trace fits the micro:bit's flash beside the node and its CANopen device.
fn node_trace(trace: &std::path::Path, out: &std::path::Path) -> PathBuf {
    let n = if env::var_os("CARGO_FEATURE_N3").is_some() {
        3
    } else {
        2
    };
    // x_1..x_n, the two neighbours' y, y_d; 4 bytes each.
    let record = 4 * (n + 2 + 1);
    let bytes = fs::read(trace).unwrap_or_else(|e| panic!("{}: {e}", trace.display()));
    let kept: Vec<u8> = bytes
        .chunks_exact(record)
        .flat_map(|r| &r[..record - 4])
        .copied()
        .collect();
    let path = out.join("node-trace.f32le");
    fs::write(&path, kept).expect("write the node trace");
    path
}
