//! Puts bench-fw's `memory/mps2-an386.x` (the mps2-an386 memory map, shared) and this board's
//! `device.x` (the interrupt handlers' default bindings) on the linker search path.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(
        out.join("memory.x"),
        include_bytes!("../bench-fw/memory/mps2-an386.x"),
    )
    .expect("write memory.x");
    fs::write(out.join("device.x"), include_bytes!("device.x")).expect("write device.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../bench-fw/memory/mps2-an386.x");
    println!("cargo:rerun-if-changed=device.x");
}
