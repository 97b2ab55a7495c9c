//! `cargo xtask bench-target`: build `bench-fw` per variant, run it on QEMU, collect the figures.

use crate::{bench_dir, firmware_build, flash, trace, workspace_root, Options, Result};
use serde_json::{json, Value};
use std::{
    fs,
    io::Read,
    path::{Path, PathBuf},
    process::{Command, Stdio},
    time::{Duration, Instant},
};

/// The firmware target.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The QEMU invocation (the ELF follows `-kernel`).
pub const QEMU_ARGS: [&str; 14] = [
    "-M",
    "mps2-an386",
    "-cpu",
    "cortex-m4",
    "-nographic",
    "-monitor",
    "none",
    "-serial",
    "none",
    "-semihosting-config",
    "enable=on,target=native",
    "-icount",
    "shift=0",
    "-kernel",
];
const QEMU: &str = "qemu-system-arm";
/// A run that takes longer than this is killed (a healthy one takes seconds).
const QEMU_TIMEOUT: Duration = Duration::from_secs(600);

/// One benchmark variant: a name and the firmware's cargo features.
#[derive(Debug, Clone, Copy)]
pub struct Variant {
    pub name: &'static str,
    pub features: &'static str,
    pub n3: bool,
}

/// The benchmark variants: Example 1's agent (`n = m = 2`) per per-step math back-end, the
/// prescribed-time baseline and `[safety]` on, and `n = m = 3`.
pub const VARIANTS: [Variant; 6] = [
    Variant {
        name: "libm-n2m2",
        features: "libm",
        n3: false,
    },
    Variant {
        name: "micromath-n2m2",
        features: "micromath",
        n3: false,
    },
    Variant {
        name: "fast-math-n2m2",
        features: "fast-math",
        n3: false,
    },
    Variant {
        name: "baseline-n2m2",
        features: "libm,baseline",
        n3: false,
    },
    Variant {
        name: "libm-n3m3",
        features: "libm,n3",
        n3: true,
    },
    Variant {
        name: "safety-n2m2",
        features: "libm,safety",
        n3: false,
    },
];

/// The figures of one variant.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Figures {
    pub steps: u64,
    pub reps: u64,
    pub min: u64,
    pub median: u64,
    pub max: u64,
    pub mean: u64,
    pub coarse_mean: u64,
    pub stack: u64,
    pub state: u64,
    pub mutable_state: u64,
    pub faults: u64,
}

/// Runs the whole benchmark; returns the `step.json` document.
pub fn bench_target(opts: &Options) -> Result<Value> {
    check_prerequisites()?;
    let dir = bench_dir();
    let trace = trace::obtain()?;
    let (trace_n2, trace_n3) = trace::write(&trace, &dir)?;
    eprintln!(
        "trace: {} steps of agent 4 from the {}",
        trace.samples.len(),
        trace.source
    );
    let mut variants = Vec::new();
    let mut rows = Vec::new();
    for (k, v) in VARIANTS.into_iter().enumerate() {
        let trace_file = if v.n3 { &trace_n3 } else { &trace_n2 };
        eprintln!("bench: variant {}/{}: {}", k + 1, VARIANTS.len(), v.name);
        let elf = build(&v, trace_file, &dir)?;
        eprintln!("bench: running {} on QEMU", v.name);
        let output = run_qemu(&elf)?;
        let fig = parse_output(&output).map_err(|e| format!("{}: {e}\n{output}", v.name))?;
        let data = fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let fl = flash::controller_flash(&data)?;
        if opts.verbose {
            eprintln!("{}: {}", v.name, output.trim());
            for s in &fl.symbols {
                eprintln!("  {:>6}  {}", s.size, s.name);
            }
        }
        if fig.faults > 0 {
            eprintln!(
                "warning: {}: {} steps held the command (StepFault)",
                v.name, fig.faults
            );
        }
        rows.push((v.name, fig.clone(), fl.total, fl.config_total));
        variants.push(json!({
            "name": v.name,
            "instructions_min": fig.min,
            "instructions_median": fig.median,
            "instructions_max": fig.max,
            "instructions_mean": fig.mean,
            "instructions_mean_coarse": fig.coarse_mean,
            "stack_bytes": fig.stack,
            "flash_bytes": fl.total,
            "flash_config_bytes": fl.config_total,
            "state_bytes": fig.state,
            "mutable_state_bytes": fig.mutable_state,
            "features": v.features,
            "steps": fig.steps,
            "faulted_steps": fig.faults,
            "flash_symbols": fl.symbols.iter().map(|s| json!({"name": s.name, "bytes": s.size})).collect::<Vec<_>>(),
            "flash_config_symbols": fl.config_symbols.iter().map(|s| json!({"name": s.name, "bytes": s.size})).collect::<Vec<_>>(),
        }));
    }
    let doc = json!({
        "machine": "QEMU mps2-an386 (Cortex-M4F), -icount shift=0",
        "units": "instructions executed per Controller::step call (QEMU models no cycle timing); stack and flash in bytes; state_bytes = size_of Controller (settings + state), mutable_state_bytes = size_of State",
        "method": format!(
            "SysTick at 25 MHz = 1 tick per 40 instructions; each step timed {} times on copies of the same state, minus the copy loop, so the resolution is 80/{} instructions; peak stack by painting below the caller's SP; flash = sizes of the ELF symbols of step and its callees (controller_core, libm, micromath); flash_config = those of Controller::new and its callees not counted for the step",
            rows.first().map_or(0, |r| r.1.reps),
            rows.first().map_or(0, |r| r.1.reps)
        ),
        "trace": trace.source,
        "qemu_version": qemu_version(),
        "variants": variants,
    });
    let path = dir.join("step.json");
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    fs::write(&path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    print_table(&rows);
    println!("wrote {}", path.display());
    Ok(doc)
}

/// Says what is missing and how to install it; installs nothing.
pub fn check_prerequisites() -> Result<()> {
    let mut missing = Vec::new();
    if find_in_path(QEMU).is_none() {
        missing.push(format!(
            "`{QEMU}` is not on PATH (Debian/Ubuntu: `sudo apt-get install qemu-system-arm`)"
        ));
    }
    if !target_installed() {
        missing.push(format!(
            "the Rust target `{TARGET}` is not installed (`rustup target add {TARGET}`)"
        ));
    }
    if missing.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "bench-target needs what is not here (nothing was installed):\n  - {}",
            missing.join("\n  - ")
        ))
    }
}

fn find_in_path(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// The target's `core` is in the sysroot.
fn target_installed() -> bool {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".to_owned());
    let out = Command::new(rustc)
        .args(["--print", "target-libdir", "--target", TARGET])
        .current_dir(workspace_root().join("bench-fw"))
        .output();
    let Ok(out) = out else { return false };
    if !out.status.success() {
        return false;
    }
    let dir = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    fs::read_dir(dir).is_ok_and(|mut d| {
        d.any(|e| e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with("libcore-")))
    })
}

fn qemu_version() -> String {
    Command::new(QEMU)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_owned))
        .unwrap_or_default()
}

/// Builds the firmware for `v`; returns a copy of its ELF named after the variant.
fn build(v: &Variant, trace: &Path, dir: &Path) -> Result<PathBuf> {
    let fw = workspace_root().join("bench-fw");
    let target_dir = dir.join("fw-remapped");
    eprintln!("building {} (features {})", v.name, v.features);
    let status = firmware_build(&fw, &target_dir)
        .args(["--no-default-features", "--features", v.features])
        .env("BENCH_TRACE", trace)
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("building bench-fw ({}) failed", v.name));
    }
    let built = target_dir.join(TARGET).join("release").join("bench-fw");
    let elf = dir.join(format!("{}.elf", v.name));
    fs::copy(&built, &elf).map_err(|e| format!("{} → {}: {e}", built.display(), elf.display()))?;
    Ok(elf)
}

/// Runs the firmware on QEMU and returns its semihosting output.
fn run_qemu(elf: &Path) -> Result<String> {
    let mut child = Command::new(QEMU)
        .args(QEMU_ARGS)
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {QEMU}: {e}"))?;
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "{QEMU} did not finish within {} s on {}",
                QEMU_TIMEOUT.as_secs(),
                elf.display()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut out = String::new();
    let mut err = String::new();
    if let Some(mut s) = child.stdout.take() {
        let _ = s.read_to_string(&mut out);
    }
    if let Some(mut s) = child.stderr.take() {
        let _ = s.read_to_string(&mut err);
    }
    if !status.success() {
        return Err(format!(
            "{QEMU} exited with {status} on {}:\n{out}{err}",
            elf.display()
        ));
    }
    Ok(out)
}

/// Reads the firmware's `BENCH key=value …` line.
pub fn parse_output(output: &str) -> Result<Figures> {
    let line = output
        .lines()
        .find(|l| l.starts_with("BENCH "))
        .ok_or("the firmware printed no BENCH line")?;
    let mut f = Figures::default();
    for kv in line.split_whitespace().skip(1) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| format!("bad field `{kv}`"))?;
        let v: u64 = v.parse().map_err(|_| format!("bad value in `{kv}`"))?;
        match k {
            "steps" => f.steps = v,
            "reps" => f.reps = v,
            "min" => f.min = v,
            "median" => f.median = v,
            "max" => f.max = v,
            "mean" => f.mean = v,
            "coarse_mean" => f.coarse_mean = v,
            "stack" => f.stack = v,
            "state" => f.state = v,
            "mutable_state" => f.mutable_state = v,
            "faults" => f.faults = v,
            _ => {}
        }
    }
    if f.steps == 0 {
        return Err("the firmware ran no step".into());
    }
    Ok(f)
}

fn print_table(rows: &[(&str, Figures, u64, u64)]) {
    println!(
        "{:<16} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "variant", "min", "median", "max", "stack B", "flash B", "+config", "state B"
    );
    for (name, f, flash, config) in rows {
        println!(
            "{:<16} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
            name, f.min, f.median, f.max, f.stack, flash, config, f.state
        );
    }
    println!("(instructions per Controller::step on QEMU mps2-an386, Cortex-M4F; not cycles)");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_bench_line() {
        let out = "noise\nBENCH steps=10 reps=40 min=1 median=2 max=3 stack=4 state=5 faults=0 mean=2 coarse_mean=2 overhead_ticks=9\n";
        let f = parse_output(out).unwrap_or_default();
        assert_eq!((f.steps, f.min, f.median, f.max), (10, 1, 2, 3));
        assert_eq!((f.stack, f.state), (4, 5));
        assert!(parse_output("nothing").is_err());
    }
}
