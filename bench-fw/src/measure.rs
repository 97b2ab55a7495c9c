//! What every variant measures with: SysTick differences, the painted stack, the error exit.

use cortex_m_semihosting::{debug, hprintln};

/// Bytes painted below the stack pointer for the high-water mark (half the Cortex-M0's RAM).
pub(crate) const PAINT_BYTES: usize = 8 * 1024;
const PATTERN: u32 = 0xA5C3_5A3C;

/// SysTick ticks elapsed between two readings of the down-counter (24 bits, reload 0xFF_FFFF).
pub(crate) fn elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & 0x00FF_FFFF
}

/// Paints the [`PAINT_BYTES`] below `sp` with [`PATTERN`]. Inlined into its caller, so no
/// frame of its own lies in the painted region.
#[inline(always)]
pub(crate) fn paint_below(sp: usize) {
    // SAFETY: [sp − PAINT_BYTES, sp) is below the live stack pointer, inside RAM (the smallest,
    // the Cortex-M0's 16 KiB, holds it above the static data), and nothing else (no interrupts
    // are enabled) uses it until the measured call.
    for a in (sp - PAINT_BYTES..sp).step_by(4) {
        unsafe { core::ptr::write_volatile(a as *mut u32, PATTERN) };
    }
}

/// The bytes below `sp` a call overwrote since [`paint_below`].
#[inline(always)]
pub(crate) fn painted_depth(sp: usize) -> u32 {
    let mut lowest = sp;
    for a in (sp - PAINT_BYTES..sp).step_by(4) {
        // SAFETY: as in `paint_below`; the call has returned, the region is plain RAM.
        if unsafe { core::ptr::read_volatile(a as *const u32) } != PATTERN {
            lowest = a;
            break;
        }
    }
    (sp - lowest) as u32
}

/// Reports an error line and ends QEMU with a failure status.
pub(crate) fn fail(why: &str) -> ! {
    hprintln!("BENCH-ERROR {}", why);
    exit(debug::EXIT_FAILURE)
}

pub(crate) fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    loop {
        cortex_m::asm::wfi();
    }
}
