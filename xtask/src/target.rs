//! `cargo xtask bench-target`: build `bench-fw` per core and variant, run it on QEMU, collect
//! the figures.

use crate::{
    flash,
    task::{bench_dir, firmware_build_for, workspace_root, Options, Result},
    trace,
};
use serde_json::{json, Value};
use std::{
    fs,
    io::Read,
    path::{Path, PathBuf},
    process::{Command, Stdio},
    time::{Duration, Instant},
};

/// A Cortex-M class: its Rust target and the QEMU 7.2 machine that runs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Core {
    /// `cortex-m0`, …: the `core` of each variant in `step.json`.
    pub id: &'static str,
    /// The Rust target.
    pub target: &'static str,
    /// The QEMU machine (`-M`).
    pub machine: &'static str,
    /// `-cpu`, when the machine's default is not meant.
    pub cpu: Option<&'static str>,
    /// SysTick's clock (the machine's core clock), MHz: with `-icount shift=0` one tick is
    /// `1000 / clock_mhz` instructions. The firmware's calibration loop checks it.
    pub clock_mhz: u64,
    /// Whether the core has a single-precision FPU (else every `f32` operation is a call).
    pub fpu: bool,
}

/// Cortex-M0 on the BBC micro:bit's nRF51822 (256 KiB flash, 16 KiB RAM; 16 MHz).
pub const CORTEX_M0: Core = Core {
    id: "cortex-m0",
    target: "thumbv6m-none-eabi",
    machine: "microbit",
    cpu: None,
    clock_mhz: 16,
    fpu: false,
};
/// Cortex-M3 on the MPS2 FPGA image AN385 (25 MHz).
pub const CORTEX_M3: Core = Core {
    id: "cortex-m3",
    target: "thumbv7m-none-eabi",
    machine: "mps2-an385",
    cpu: None,
    clock_mhz: 25,
    fpu: false,
};
/// Cortex-M4F on the MPS2 FPGA image AN386 (25 MHz).
pub const CORTEX_M4F: Core = Core {
    id: "cortex-m4f",
    target: "thumbv7em-none-eabihf",
    machine: "mps2-an386",
    cpu: Some("cortex-m4"),
    clock_mhz: 25,
    fpu: true,
};
/// Cortex-M7 on the MPS2 FPGA image AN500 (25 MHz).
pub const CORTEX_M7: Core = Core {
    id: "cortex-m7",
    target: "thumbv7em-none-eabihf",
    machine: "mps2-an500",
    cpu: None,
    clock_mhz: 25,
    fpu: true,
};
/// Cortex-M33 (with FPU) on the MPS2 FPGA image AN505 (SSE-200; 20 MHz), run in the Secure
/// state it starts in.
pub const CORTEX_M33: Core = Core {
    id: "cortex-m33",
    target: "thumbv8m.main-none-eabihf",
    machine: "mps2-an505",
    cpu: None,
    clock_mhz: 20,
    fpu: true,
};

/// Every measured core, smallest first.
pub const CORES: [Core; 5] = [CORTEX_M0, CORTEX_M3, CORTEX_M4F, CORTEX_M7, CORTEX_M33];

/// The QEMU options after `-M machine [-cpu cpu]` (the ELF follows `-kernel`).
pub const QEMU_ARGS: [&str; 10] = [
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
/// How far the calibration loop's ticks may sit from the instructions it runs.
const CALIBRATION_TOLERANCE: f64 = 0.01;

/// One benchmark variant: a name, the firmware's cargo features and the core it runs on.
#[derive(Debug, Clone, Copy)]
pub struct Variant {
    pub name: &'static str,
    pub features: &'static str,
    pub n3: bool,
    pub core: Core,
}

impl Variant {
    /// Whether it times a node's whole tick rather than the step.
    pub fn is_node(&self) -> bool {
        self.features.split(',').any(|f| f == "node")
    }
}

const fn variant(name: &'static str, features: &'static str, core: Core) -> Variant {
    Variant {
        name,
        features,
        n3: false,
        core,
    }
}

/// The benchmark variants. On the Cortex-M4F (names without a core prefix): Example 1's agent
/// (`n = m = 2`) per per-step math back-end, the prescribed-time baseline, `[safety]` on, and
/// `n = m = 3`. On every other core: Example 1's agent per math back-end. On every core: the
/// whole node's tick (`node-n2m2`, agent-node's `Node::tick` around the `libm` step).
pub const VARIANTS: [Variant; 23] = [
    variant("libm-n2m2", "libm", CORTEX_M4F),
    variant("micromath-n2m2", "micromath", CORTEX_M4F),
    variant("fast-math-n2m2", "fast-math", CORTEX_M4F),
    variant("baseline-n2m2", "libm,baseline", CORTEX_M4F),
    Variant {
        name: "libm-n3m3",
        features: "libm,n3",
        n3: true,
        core: CORTEX_M4F,
    },
    variant("safety-n2m2", "libm,safety", CORTEX_M4F),
    variant("node-n2m2", "libm,node", CORTEX_M4F),
    variant("cortex-m0-node-n2m2", "libm,node", CORTEX_M0),
    variant("cortex-m3-node-n2m2", "libm,node", CORTEX_M3),
    variant("cortex-m7-node-n2m2", "libm,node", CORTEX_M7),
    variant("cortex-m33-node-n2m2", "libm,node", CORTEX_M33),
    variant("cortex-m0-libm-n2m2", "libm", CORTEX_M0),
    variant("cortex-m0-micromath-n2m2", "micromath", CORTEX_M0),
    variant("cortex-m0-fast-math-n2m2", "fast-math", CORTEX_M0),
    variant("cortex-m3-libm-n2m2", "libm", CORTEX_M3),
    variant("cortex-m3-micromath-n2m2", "micromath", CORTEX_M3),
    variant("cortex-m3-fast-math-n2m2", "fast-math", CORTEX_M3),
    variant("cortex-m7-libm-n2m2", "libm", CORTEX_M7),
    variant("cortex-m7-micromath-n2m2", "micromath", CORTEX_M7),
    variant("cortex-m7-fast-math-n2m2", "fast-math", CORTEX_M7),
    variant("cortex-m33-libm-n2m2", "libm", CORTEX_M33),
    variant("cortex-m33-micromath-n2m2", "micromath", CORTEX_M33),
    variant("cortex-m33-fast-math-n2m2", "fast-math", CORTEX_M33),
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
    /// The firmware's `BENCH` line.
    pub line: String,
}

/// Runs the whole benchmark; returns the `step.json` document.
/// The step and node-tick figures of every core into `step.json`; returns them, with the
/// Example 1 trace the soft-float analysis replays.
pub fn measure_steps(opts: &Options) -> Result<(Value, PathBuf)> {
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
        eprintln!("bench: running {} on QEMU {}", v.name, v.core.machine);
        let output = run_qemu(&v.core, &elf, &[])?;
        let fig = parse_output(&output, &v.core).map_err(|e| format!("{}: {e}", v.name))?;
        let data = fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
        let fl = if v.is_node() {
            flash::flash_from(&data, flash::NODE_ENTRIES)?
        } else {
            flash::controller_flash(&data)?
        };
        if opts.verbose {
            eprintln!("{}: {}", v.name, fig.line);
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
        rows.push((v, fig.clone(), fl.total, fl.config_total));
        variants.push(json!({
            "name": v.name,
            "measures": if v.is_node() { "Node::tick" } else { "Controller::step" },
            "core": v.core.id,
            "target": v.core.target,
            "machine": v.core.machine,
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
            "reps": fig.reps,
            "faulted_steps": fig.faults,
            "flash_symbols": fl.symbols.iter().map(|s| json!({"name": s.name, "bytes": s.size})).collect::<Vec<_>>(),
            "flash_config_symbols": fl.config_symbols.iter().map(|s| json!({"name": s.name, "bytes": s.size})).collect::<Vec<_>>(),
        }));
    }
    let doc = json!({
        "machine": "QEMU mps2-an386 (Cortex-M4F), -icount shift=0; the other cores' variants name their own (`core`, `target`, `machine`)",
        "units": "instructions executed per Controller::step call (per Node::tick for the node variants, `measures`) (QEMU models no cycle timing); stack and flash in bytes; state_bytes = size_of Controller (settings + state), mutable_state_bytes = size_of State",
        "method": "SysTick at the machine's core clock f (25 MHz on MPS2, 20 MHz on AN505, 16 MHz on the micro:bit; checked by a calibration loop of known length) = 1 tick per 1000/f_MHz instructions; each step timed `reps` times (40 with an FPU, 4 without) on copies of the same state, minus the copy loop, so the resolution is 2·1000/f_MHz/reps instructions; peak stack by painting below the caller's SP; flash = sizes of the ELF symbols of step and its callees (controller_core, libm, micromath, the soft-float routines); flash_config = those of Controller::new and its callees not counted for the step",
        "cores": CORES.iter().map(|c| json!({"core": c.id, "target": c.target, "machine": c.machine, "clock_mhz": c.clock_mhz, "fpu": c.fpu})).collect::<Vec<_>>(),
        "trace": trace.source,
        "qemu_version": qemu_version(),
        "variants": variants,
    });
    let path = dir.join("step.json");
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    fs::write(&path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    print_table(&rows);
    println!("wrote {}", path.display());
    Ok((doc, trace_n2))
}

/// Says what is missing and how to install it; installs nothing.
pub fn check_prerequisites() -> Result<()> {
    let mut missing = Vec::new();
    if find_in_path(QEMU).is_none() {
        missing.push(format!(
            "`{QEMU}` is not on PATH (Debian/Ubuntu: `sudo apt-get install qemu-system-arm`)"
        ));
    }
    let mut targets: Vec<&str> = CORES.iter().map(|c| c.target).collect();
    targets.dedup();
    for target in targets {
        if !target_installed(target) {
            missing.push(format!(
                "the Rust target `{target}` is not installed (`rustup target add {target}`)"
            ));
        }
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
fn target_installed(target: &str) -> bool {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".to_owned());
    let out = Command::new(rustc)
        .args(["--print", "target-libdir", "--target", target])
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
pub fn build(v: &Variant, trace: &Path, dir: &Path) -> Result<PathBuf> {
    let fw = workspace_root().join("bench-fw");
    // One target directory per machine: the memory map is a build input cargo does not
    // fingerprint beyond the build script's rerun, and the M4F and M7 share a target.
    let target_dir = dir.join("fw-remapped").join(v.core.machine);
    eprintln!(
        "building {} (features {}, {})",
        v.name, v.features, v.core.target
    );
    let status = firmware_build_for(&fw, &target_dir, v.core.target)
        .args(["--no-default-features", "--features", v.features])
        .env("BENCH_TRACE", trace)
        .env("BENCH_MACHINE", v.core.machine)
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("building bench-fw ({}) failed", v.name));
    }
    let built = target_dir
        .join(v.core.target)
        .join("release")
        .join("bench-fw");
    let elf = dir.join(format!("{}.elf", v.name));
    fs::copy(&built, &elf).map_err(|e| format!("{} → {}: {e}", built.display(), elf.display()))?;
    Ok(elf)
}

/// The QEMU arguments for `core`, up to `-kernel` (the ELF follows).
pub fn qemu_args(core: &Core) -> Vec<&'static str> {
    let mut args = vec!["-M", core.machine];
    if let Some(cpu) = core.cpu {
        args.extend(["-cpu", cpu]);
    }
    args.extend(QEMU_ARGS);
    args
}

/// Runs the firmware on QEMU (with the `extra` options before `-kernel`) and returns its
/// semihosting output.
pub fn run_qemu(core: &Core, elf: &Path, extra: &[&str]) -> Result<String> {
    let args = qemu_args(core);
    let (options, kernel) = args.split_at(args.len() - 1);
    let mut child = Command::new(QEMU)
        .args(options)
        .args(extra)
        .args(kernel)
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {QEMU}: {e}"))?;
    // Read while QEMU runs: the per-step lines fill a pipe's buffer many times over.
    let readers = [
        child
            .stdout
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
        child
            .stderr
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    ]
    .map(|pipe| {
        std::thread::spawn(move || {
            let mut text = String::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_string(&mut text);
            }
            text
        })
    });
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
    let [out, err] = readers.map(|r| r.join().unwrap_or_default());
    if !status.success() {
        return Err(format!(
            "{QEMU} exited with {status} on {}:\n{out}{err}",
            elf.display()
        ));
    }
    Ok(out)
}

/// Checks the machine's assumed SysTick clock against the calibration loop of `calib_insns`
/// instructions that took `calib_ticks` ticks.
pub fn check_calibration(core: &Core, calib_ticks: u64, calib_insns: u64) -> Result<()> {
    let mhz = core.clock_mhz;
    // Instructions of `t` ticks: t · 1000 / f_MHz (1 ns per instruction).
    let calibrated = calib_ticks * 1000 / mhz;
    if (calibrated as f64 - calib_insns as f64).abs() > CALIBRATION_TOLERANCE * calib_insns as f64 {
        return Err(format!(
            "{}: the calibration loop of {calib_insns} instructions took {calib_ticks} SysTick \
             ticks, {calibrated} instructions at the assumed {mhz} MHz: the clock is wrong",
            core.machine
        ));
    }
    Ok(())
}

/// Reads the firmware's output: one `T <ticks>` line per step, then the `BENCH key=value …`
/// line; turns ticks into instructions at `core`'s clock after checking it against the
/// calibration loop.
pub fn parse_output(output: &str, core: &Core) -> Result<Figures> {
    let line = output
        .lines()
        .find(|l| l.starts_with("BENCH "))
        .ok_or_else(|| format!("the firmware printed no BENCH line:\n{output}"))?;
    let field = |key: &str| -> Result<u64> {
        line.split_whitespace()
            .skip(1)
            .find_map(|kv| kv.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
            .ok_or_else(|| format!("the BENCH line has no `{key}`"))?
            .parse()
            .map_err(|_| format!("the BENCH line's `{key}` is not a number"))
    };
    let ticks: Vec<u64> = output
        .lines()
        .filter_map(|l| l.strip_prefix("T "))
        .map(|t| {
            t.trim()
                .parse()
                .map_err(|_| format!("bad step line `T {t}`"))
        })
        .collect::<Result<_>>()?;
    let steps = field("steps")?;
    if steps == 0 || ticks.len() as u64 != steps {
        return Err(format!(
            "the firmware ran {steps} steps but reported {} step timings",
            ticks.len()
        ));
    }
    let (reps, overhead) = (field("reps")?, field("overhead_ticks")?);
    check_calibration(core, field("calib_ticks")?, field("calib_insns")?)?;
    let mhz = core.clock_mhz;
    let per = mhz * reps;
    let mut counts: Vec<u64> = ticks
        .iter()
        .map(|t| (t.saturating_sub(overhead) * 1000 + per / 2) / per)
        .collect();
    let mean = counts.iter().sum::<u64>() / steps;
    counts.sort_unstable();
    let at = |i: usize| counts.get(i).copied().unwrap_or_default();
    Ok(Figures {
        steps,
        reps,
        min: at(0),
        median: at(counts.len() / 2),
        max: at(counts.len() - 1),
        mean,
        coarse_mean: field("coarse_ticks")? * 1000 / (mhz * steps),
        stack: field("stack")?,
        state: field("state")?,
        mutable_state: field("mutable_state")?,
        faults: field("faults")?,
        line: line.to_owned(),
    })
}

fn print_table(rows: &[(Variant, Figures, u64, u64)]) {
    println!(
        "{:<26} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "variant", "min", "median", "max", "stack B", "flash B", "+config", "state B"
    );
    for (v, f, flash, config) in rows {
        println!(
            "{:<26} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} {:>8}",
            v.name, f.min, f.median, f.max, f.stack, flash, config, f.state
        );
    }
    println!(
        "(instructions per Controller::step on QEMU, -icount shift=0; not cycles. Unprefixed: \
         Cortex-M4F on mps2-an386)"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_step_lines_and_the_bench_line() {
        // 25 MHz, 40 reps: (ticks − overhead) · 40 / 40 instructions.
        let out = "noise\nT 19\nT 12\nT 14\nBENCH steps=3 reps=40 stack=4 state=5 mutable_state=3 faults=0 overhead_ticks=9 coarse_ticks=3 calib_ticks=25000 calib_insns=1000000\n";
        let f = parse_output(out, &CORTEX_M4F).unwrap_or_default();
        assert_eq!((f.steps, f.min, f.median, f.max, f.mean), (3, 3, 5, 10, 6));
        assert_eq!((f.stack, f.state, f.coarse_mean), (4, 5, 40));
        assert!(parse_output("nothing", &CORTEX_M4F).is_err());
        // A step line missing, or a clock that is not the machine's, is an error.
        assert!(parse_output(&out.replace("T 14\n", ""), &CORTEX_M4F).is_err());
        assert!(parse_output(out, &CORTEX_M33).is_err());
    }

    #[test]
    fn every_core_has_variants_and_the_m4f_names_are_unprefixed() {
        for c in CORES {
            assert!(VARIANTS.iter().any(|v| v.core == c), "{}", c.id);
        }
        for v in VARIANTS {
            assert_eq!(
                v.core == CORTEX_M4F,
                !v.name.starts_with("cortex-"),
                "{}",
                v.name
            );
        }
    }
}
