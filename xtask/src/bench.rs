//! `cargo xtask bench-target`: the step and node tick on every core (`target.rs`), then the
//! soft-float analysis of the cores without an FPU (`softfloat.rs`), into `target/bench/`.

use serde_json::Value;

use crate::{
    softfloat, target,
    task::{bench_dir, Options, Result},
};

/// Every figure of the target benchmark; returns `step.json`'s document.
pub fn bench_target(opts: &Options) -> Result<Value> {
    let (doc, trace_n2) = target::measure_steps(opts)?;
    softfloat::run(&trace_n2, &bench_dir())?;
    Ok(doc)
}
