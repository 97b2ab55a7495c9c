//! `cargo xtask doc-coverage`: the documentation gate of controller-core and agent-node.
//!
//! Runs rustdoc's coverage report (`--show-coverage --output-format json`, an unstable option)
//! with the pinned nightly [`TOOLCHAIN`] on the build docs.rs makes of each crate of [`CRATES`]
//! (controller-core: default features and `serde`; agent-node: default features, `canopen`
//! included), prints the per-file table, and fails when an item that rustdoc counts lacks
//! documentation or an item that can carry an example has none. rustdoc counts for examples
//! the public functions, methods, structs, enums, traits and unions; not modules, fields,
//! variants, constants, statics, type aliases or trait impls.

use crate::task::{workspace_root, Result};
use serde_json::Value;
use std::process::Command;

/// A published dated nightly (`rustup toolchain install nightly-2026-05-19 --profile minimal`):
/// the JSON coverage report is unstable and may change between nightlies.
pub const TOOLCHAIN: &str = "nightly-2026-05-19";

/// One crate under the gate: its package and the features docs.rs builds.
struct Gate {
    package: &'static str,
    features: &'static str,
}

/// The crates under the gate.
const CRATES: [Gate; 2] = [
    Gate {
        package: "controller-core",
        features: "serde",
    },
    Gate {
        package: "agent-node",
        features: "",
    },
];

/// Per-file counts of rustdoc's coverage report.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Counts {
    total: u64,
    with_docs: u64,
    total_examples: u64,
    with_examples: u64,
}

impl Counts {
    fn of(v: &Value) -> Result<Self> {
        let get = |k: &str| {
            v.get(k)
                .and_then(Value::as_u64)
                .ok_or_else(|| format!("coverage report: no count `{k}` in {v}"))
        };
        Ok(Self {
            total: get("total")?,
            with_docs: get("with_docs")?,
            total_examples: get("total_examples")?,
            with_examples: get("with_examples")?,
        })
    }

    fn add(self, o: Self) -> Self {
        Self {
            total: self.total + o.total,
            with_docs: self.with_docs + o.with_docs,
            total_examples: self.total_examples + o.total_examples,
            with_examples: self.with_examples + o.with_examples,
        }
    }
}

pub fn doc_coverage() -> Result<()> {
    let mut problems = Vec::new();
    for gate in &CRATES {
        if let Err(e) = check(gate) {
            problems.push(format!("{}: {e}", gate.package));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(problems.join("\n"))
    }
}

/// The coverage report of one crate, printed and checked.
fn check(gate: &Gate) -> Result<()> {
    let root = workspace_root();
    let mut cmd = Command::new("cargo");
    cmd.arg(format!("+{TOOLCHAIN}"))
        .args(["rustdoc", "-p", gate.package]);
    if !gate.features.is_empty() {
        cmd.args(["--features", gate.features]);
    }
    let out = cmd
        .arg("--")
        .args([
            "-Z",
            "unstable-options",
            "--show-coverage",
            "--output-format",
            "json",
        ])
        .env("CARGO_TARGET_DIR", root.join("target/nightly"))
        .current_dir(&root)
        .output()
        .map_err(|e| format!("cargo +{TOOLCHAIN}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo +{TOOLCHAIN} rustdoc failed ({}); is the toolchain installed? \
             rustup toolchain install {TOOLCHAIN} --profile minimal\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let report = String::from_utf8_lossy(&out.stdout);
    // The JSON object is the report's last line (cargo's own lines go to stderr).
    let line = report
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .ok_or("coverage report: no JSON in rustdoc's output")?;
    let files: Value = serde_json::from_str(line).map_err(|e| format!("coverage report: {e}"))?;
    let files = files
        .as_object()
        .ok_or("coverage report: not a JSON object")?;
    println!(
        "{:<40} {:>10} {:>10} {:>10}",
        "file", "documented", "examples", "of"
    );
    let mut sum = Counts::default();
    for (file, v) in files {
        let c = Counts::of(v)?;
        println!(
            "{file:<40} {:>5}/{:<4} {:>10} {:>10}",
            c.with_docs, c.total, c.with_examples, c.total_examples
        );
        sum = sum.add(c);
    }
    println!(
        "{:<40} {:>5}/{:<4} {:>10} {:>10}",
        "total", sum.with_docs, sum.total, sum.with_examples, sum.total_examples
    );
    let mut problems = Vec::new();
    if sum.with_docs < sum.total {
        problems.push(format!(
            "{} of {} items without documentation",
            sum.total - sum.with_docs,
            sum.total
        ));
    }
    if sum.with_examples < sum.total_examples {
        problems.push(format!(
            "{} of {} items that can carry an example have none (the table above names the files)",
            sum.total_examples - sum.with_examples,
            sum.total_examples
        ));
    }
    if problems.is_empty() {
        println!(
            "doc-coverage OK: {} of {} items of {} with an example",
            sum.with_examples, sum.total_examples, gate.package
        );
        Ok(())
    } else {
        Err(problems.join("; "))
    }
}
