//! The `ops` variant: instructions per arithmetic operation on the core, `f32` (a library call
//! on a core without an FPU) against the `fixed` crate's `I16F16` and `I32F32` — the numbers
//! that bound what a fixed-point step could gain over the soft-float one.
//!
//! Each operation runs [`OPS_REPS`] times on operands passed through `black_box` (so neither is
//! a constant and the result is kept); the same loop returning its first operand is timed as
//! well and subtracted. Fixed-point operations are the saturating ones (and `checked_div`,
//! `checked_sqrt`): a control law may not wrap or panic; the `_wrapping` multiplications are the
//! lower bound of one whose operands' ranges were proven. Operands are typical of the law's
//! signals (an error of 0.37, a gain of 1.9).
//!
//! Output: `OP <name> <ticks of OPS_REPS operations>` per operation, then `BENCH-OPS reps=…
//! empty_ticks=… calib_ticks=… calib_insns=…`.

use core::hint::black_box;
use cortex_m::peripheral::SYST;
use cortex_m_semihosting::hprintln;
use fixed::types::{I16F16, I32F32};

use crate::measure::elapsed;

/// Operations per timing.
const OPS_REPS: u32 = 64;

/// Ticks of [`OPS_REPS`] applications of `op` to `a` and `b`.
#[inline(never)]
fn time<T: Copy>(a: T, b: T, op: impl Fn(T, T) -> T) -> u32 {
    let t0 = SYST::get_current();
    for _ in 0..OPS_REPS {
        black_box(op(black_box(a), black_box(b)));
    }
    elapsed(t0, SYST::get_current())
}

/// Times every operation; prints the `OP` lines and the `BENCH-OPS` line.
pub fn run(calib_ticks: u32, calib_insns: u32) {
    let (fa, fb) = (0.37f32, -1.9f32);
    let (ha, hb) = (I16F16::from_num(0.37), I16F16::from_num(-1.9));
    let (wa, wb) = (I32F32::from_num(0.37), I32F32::from_num(-1.9));
    let empty = time(fa, fb, |a, _| a)
        .min(time(ha, hb, |a, _| a))
        .min(time(wa, wb, |a, _| a));
    let ops: [(&str, u32); 14] = [
        ("f32_add", time(fa, fb, |a, b| a + b)),
        ("f32_mul", time(fa, fb, |a, b| a * b)),
        ("f32_div", time(fa, fb, |a, b| a / b)),
        ("f32_lt", time(fa, fb, |a, b| if a < b { a } else { b })),
        ("i16f16_add", time(ha, hb, I16F16::saturating_add)),
        ("i16f16_mul", time(ha, hb, I16F16::saturating_mul)),
        ("i16f16_mul_wrapping", time(ha, hb, I16F16::wrapping_mul)),
        (
            "i16f16_div",
            time(ha, hb, |a, b| a.checked_div(b).unwrap_or(I16F16::MAX)),
        ),
        (
            "i16f16_sqrt",
            time(ha, hb, |a, _| a.checked_sqrt().unwrap_or(I16F16::ZERO)),
        ),
        ("i32f32_add", time(wa, wb, I32F32::saturating_add)),
        ("i32f32_mul", time(wa, wb, I32F32::saturating_mul)),
        ("i32f32_mul_wrapping", time(wa, wb, I32F32::wrapping_mul)),
        (
            "i32f32_div",
            time(wa, wb, |a, b| a.checked_div(b).unwrap_or(I32F32::MAX)),
        ),
        (
            "i32f32_sqrt",
            time(wa, wb, |a, _| a.checked_sqrt().unwrap_or(I32F32::ZERO)),
        ),
    ];
    for (name, ticks) in ops {
        hprintln!("OP {} {}", name, ticks);
    }
    hprintln!(
        "BENCH-OPS reps={} empty_ticks={} calib_ticks={} calib_insns={}",
        OPS_REPS,
        empty,
        calib_ticks,
        calib_insns
    );
}
