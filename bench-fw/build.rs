//! Puts `memory.x` on the linker search path and points the firmware at the replayed trace:
//! `BENCH_TRACE` (set by `cargo xtask bench-target`), or an empty trace so that a plain
//! `cargo build` works too (the firmware then reports that it has no steps).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
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
