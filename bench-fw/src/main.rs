//! Target benchmark of one `Controller::step` on a Cortex-M core, run under QEMU with
//! `-icount shift=0` by `cargo xtask bench-target` (which builds it per core — Cortex-M0 on
//! `microbit`, M3 on `mps2-an385`, M4F on `mps2-an386`, M7 on `mps2-an500`, M33 on `mps2-an505` —,
//! writes the replayed trace and reads the lines this firmware prints through semihosting).
//!
//! What is measured, per step of a recorded input sequence (agent 4 of Example 1: own state,
//! the `y` of neighbours 1 and 3):
//!
//! * **Instructions.** SysTick runs from the machine's core clock and `-icount shift=0` advances
//!   the virtual clock 1 ns per instruction, so one tick is `1000 / f_MHz` instructions (40 at
//!   the MPS2's 25 MHz). To resolve single instructions each step is run [`REPS`] times on copies
//!   of the same controller state; the same loop without the call (the copy only) is timed too,
//!   and `(ticks(step loop) − ticks(copy loop)) · (1000 / f_MHz) / REPS` is the step's count
//!   (resolution `2 · 1000 / f_MHz / REPS` instructions), computed by the xtask, which knows the
//!   machine's clock. The count includes the call and the return of the `StepOutput`. QEMU
//!   models no pipeline or memory timing: these are instructions, not cycles.
//! * **Stack.** Before the step that advances the controller, the stack below the current stack
//!   pointer is painted with a pattern; afterwards the lowest overwritten word gives the step's
//!   peak stack depth (including its call frame). The maximum over the sequence is reported.
//! * **State.** `size_of` the `Controller` value (settings and state together), and of its
//!   mutable part alone (`State`).
//!
//! Output: one line `T <ticks>` per step (the ticks of its [`REPS`] repetitions; streamed, so
//! that the 16 KiB of the Cortex-M0's RAM need hold no per-step buffer), then one line
//! `BENCH steps=… reps=… stack=… state=… mutable_state=… faults=… overhead_ticks=…
//! coarse_ticks=…`; `coarse_ticks` (one timing of each advancing step, summed) cross-checks the
//! mean of the repeated timings.
#![no_std]
#![no_main]
// The `node` variant times `Node::tick`; the step benchmark's functions stay unused there.
#![cfg_attr(
    any(feature = "node", feature = "ops"),
    allow(dead_code, unused_imports)
)]

use controller_core::{Controller, ControllerConfig, Link, StepOutput};
use core::hint::black_box;
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;

/// Repetitions of each step for a single-instruction resolution (1 k-instruction steps).
#[cfg(not(soft_float))]
const REPS: u32 = 40;
/// Repetitions of each step: without an FPU a step is tens of thousands of instructions, so 4
/// repetitions resolve 0.2 % of it and keep the QEMU run short.
#[cfg(soft_float)]
const REPS: u32 = 4;
/// Iterations of the clock calibration loop: `cortex_m::asm::delay(n)` runs `2 (n + 1)`
/// instructions (`subs`, `bne`), so the xtask can check the SysTick clock it assumes.
const CALIB_LOOPS: u32 = 499_999;
/// Instructions of the calibration loop.
const CALIB_INSNS: u32 = 2 * (CALIB_LOOPS + 1);

type Ctrl = Controller<N, M, K>;

mod measure;
#[cfg(feature = "node")]
mod node;
#[cfg(feature = "ops")]
mod ops;
mod trace;

use measure::{elapsed, exit, fail, paint_below, painted_depth};
use trace::{record, K, M, N, STORED, TRACE};

/// Example 1's configuration for agent 4 (2 neighbours, not pinned), or the baseline.
fn config() -> ControllerConfig<N> {
    #[allow(unused_mut)]
    let mut cfg = ControllerConfig::<N> {
        neighbour_count: K,
        pinned: false,
        ..ControllerConfig::default()
    };
    #[cfg(feature = "baseline")]
    {
        use controller_core::{BaselineConfig, GainSelection, SchemeConfig};
        cfg.scheme = SchemeConfig::PrescribedTime(BaselineConfig::default());
        // The paper's comparison gains (LAW §8, Example 2's baseline).
        cfg.gains = GainSelection::Explicit { c1: 10.0, c2: 9.0 };
    }
    #[cfg(feature = "safety")]
    {
        cfg.safety = Some(controller_core::SafetyConfig {
            u_max: Some(40.0),
            du_max: Some(2000.0),
            recovery_rate: 1.0,
            recovery_jump: 0.05,
        });
    }
    cfg
}

/// The measured call: one step, not inlined into the timing loops.
#[inline(never)]
fn step_entry(c: &mut Ctrl, x: &[f32; N], neighbours: &[Link], leader: Link) -> StepOutput<N, M> {
    c.step(x, neighbours, leader)
}

/// The configuration call, kept a function of its own so the xtask can size the code a
/// firmware links for `Controller::new` (gains, quantizer levels: `powf`, `logf`, `expf`).
#[inline(never)]
fn config_entry(cfg: &ControllerConfig<N>) -> Result<Ctrl, controller_core::ConfigError> {
    Ctrl::new(cfg)
}

/// Ticks of `REPS` steps, each on a fresh copy of `saved`.
#[inline(never)]
fn time_steps(saved: &Ctrl, x: &[f32; N], neighbours: &[Link], leader: Link) -> u32 {
    let t0 = SYST::get_current();
    for _ in 0..REPS {
        let mut c = *saved;
        // By reference: the output stays where `step` wrote it (no copy is timed).
        let out = step_entry(
            black_box(&mut c),
            black_box(x),
            black_box(neighbours),
            black_box(leader),
        );
        black_box(&out);
    }
    let t1 = SYST::get_current();
    elapsed(t0, t1)
}

/// Ticks of the same loop without the step (the copy and loop overhead).
#[inline(never)]
fn time_overhead(saved: &Ctrl, x: &[f32; N], neighbours: &[Link], leader: Link) -> u32 {
    let t0 = SYST::get_current();
    for _ in 0..REPS {
        let mut c = *saved;
        black_box(&mut c);
        black_box(x);
        black_box(neighbours);
        black_box(leader);
    }
    let t1 = SYST::get_current();
    elapsed(t0, t1)
}

/// One step on `c` with the stack below the caller's stack pointer painted; returns the output,
/// the stack bytes the step used (its frame included) and the step's SysTick ticks.
#[inline(never)]
fn step_with_stack(
    c: &mut Ctrl,
    x: &[f32; N],
    neighbours: &[Link],
    leader: Link,
) -> (StepOutput<N, M>, u32, u32) {
    let sp = cortex_m::register::msp::read() as usize & !3;
    paint_below(sp);
    let t0 = SYST::get_current();
    let out = step_entry(c, x, neighbours, leader);
    let t1 = SYST::get_current();
    (out, painted_depth(sp), elapsed(t0, t1))
}

#[entry]
fn main() -> ! {
    let Some(mut p) = cortex_m::Peripherals::take() else {
        fail("peripherals already taken")
    };
    p.SYST.set_clock_source(SystClkSource::Core);
    p.SYST.set_reload(0x00FF_FFFF);
    p.SYST.clear_current();
    p.SYST.enable_counter();
    let t0 = SYST::get_current();
    cortex_m::asm::delay(black_box(CALIB_LOOPS));
    let calib_ticks = elapsed(t0, SYST::get_current());

    #[cfg(feature = "ops")]
    ops::run(calib_ticks, CALIB_INSNS);
    #[cfg(not(feature = "ops"))]
    run_trace(calib_ticks);
    exit(debug::EXIT_SUCCESS)
}

/// The step (or node) benchmark over the records of the trace.
#[cfg(not(feature = "ops"))]
fn run_trace(calib_ticks: u32) {
    let steps = TRACE.len() / (STORED * 4);
    if steps == 0 {
        fail("no trace (build through `cargo xtask bench-target`, which sets BENCH_TRACE)")
    }
    #[cfg(feature = "node")]
    node::run(&config(), steps, calib_ticks, CALIB_INSNS);
    #[cfg(not(feature = "node"))]
    run_steps(steps, calib_ticks);
}

/// The step benchmark over `steps` records; prints the step lines and the `BENCH` line.
#[cfg(not(feature = "node"))]
fn run_steps(steps: usize, calib_ticks: u32) {
    let Ok(mut ctrl) = config_entry(black_box(&config())) else {
        fail("invalid configuration")
    };
    let mut stack_peak = 0u32;
    let mut faults = 0u32;
    let mut coarse_ticks = 0u64;
    // The copy loop's cost does not depend on the step: its minimum over the sequence is
    // subtracted by the xtask (robust to a tick boundary falling inside one measurement).
    let mut overhead = u32::MAX;
    for k in 0..steps {
        let (x, neighbours, leader) = record(k);
        let ticks = time_steps(&ctrl, &x, &neighbours, leader);
        hprintln!("T {}", ticks);
        overhead = overhead.min(time_overhead(&ctrl, &x, &neighbours, leader));
        // The single coarse measurement of the advancing step (one-tick resolution).
        let (out, stack, ticks) = step_with_stack(&mut ctrl, &x, &neighbours, leader);
        coarse_ticks += u64::from(ticks);
        stack_peak = stack_peak.max(stack);
        if out.status.fault.is_some() {
            faults += 1;
        }
        black_box(out);
    }
    hprintln!(
        "BENCH steps={} reps={} stack={} state={} mutable_state={} faults={} overhead_ticks={} coarse_ticks={} calib_ticks={} calib_insns={}",
        steps,
        REPS,
        stack_peak,
        core::mem::size_of::<Ctrl>(),
        core::mem::size_of::<controller_core::State<N, M, K>>(),
        faults,
        overhead,
        coarse_ticks,
        calib_ticks,
        CALIB_INSNS
    );
}
