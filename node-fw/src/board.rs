//! The emulated board (QEMU `mps2-an386`): the only module with `unsafe`, all of it register
//! or raw-memory access.
//!
//! * **UART0** (CMSDK APB UART at `0x4000_4000`, bound to QEMU's first `-serial`): DATA `0x0`,
//!   STATE `0x4` (bit 0 TX full, bit 1 RX full), CTRL `0x8` (bit 0 TX enable, bit 1 RX enable),
//!   BAUDDIV `0x10` (QEMU ignores transmissions while it is below 16).
//! * **Instruction counter**: SysTick from the 25 MHz core clock; with QEMU's `-icount shift=0`
//!   one instruction is 1 ns of virtual time, so one SysTick count is [`INSN_PER_TICK`]
//!   instructions (the method of `bench-fw`, there refined by repetition; here a closed-loop
//!   tick runs once, so the resolution is 40 instructions).
//! * **Stack high-water mark**: [`paint_stack`] fills [`PAINT_BYTES`] below the stack pointer
//!   with a pattern at start-up; [`stack_high_water`] finds the lowest overwritten word.

use cortex_m::peripheral::{syst::SystClkSource, SYST};

const UART0: usize = 0x4000_4000;
const DATA: usize = 0x0;
const STATE: usize = 0x4;
const CTRL: usize = 0x8;
const INTSTATUS: usize = 0xC;
const BAUDDIV: usize = 0x10;
const TX_FULL: u32 = 1 << 0;
const RX_FULL: u32 = 1 << 1;
/// CTRL: TX enable, RX enable, RX interrupt enable (bit 3).
const CTRL_ON: u32 = 0b1011;
/// INTSTATUS bit of the receive interrupt (write 1 to clear).
const RX_INT: u32 = 1 << 1;
/// NVIC set-enable and clear-pending registers of IRQs 0..31; UART0 RX is IRQ 0.
const NVIC_ISER0: usize = 0xE000_E100;
const NVIC_ICPR0: usize = 0xE000_E280;
const UART0_RX_IRQ: u32 = 1 << 0;

/// Instructions per SysTick count under `-icount shift=0` (25 MHz, 1 ns per instruction).
pub const INSN_PER_TICK: u32 = 40;
/// Bytes painted below the stack pointer at start-up.
pub const PAINT_BYTES: usize = 64 * 1024;
const PATTERN: u32 = 0xA5C3_5A3C;

fn read(offset: usize) -> u32 {
    // SAFETY: an aligned UART0 register of the mps2-an386 memory map.
    unsafe { core::ptr::read_volatile((UART0 + offset) as *const u32) }
}

fn write(offset: usize, v: u32) {
    // SAFETY: as in `read`.
    unsafe { core::ptr::write_volatile((UART0 + offset) as *mut u32, v) }
}

fn write_nvic(addr: usize, v: u32) {
    // SAFETY: an NVIC register of the Cortex-M4 system control space; only UART0's RX
    // interrupt is touched, and with PRIMASK set it never runs a handler.
    unsafe { core::ptr::write_volatile(addr as *mut u32, v) }
}

/// UART0, the node's SLCAN link to the host.
#[derive(Debug, Clone, Copy)]
pub struct Uart(());

impl Uart {
    /// Enables transmitter, receiver and the receive interrupt, which only wakes the core
    /// from `wfi` (interrupts stay masked: no handler runs).
    pub fn init() -> Self {
        cortex_m::interrupt::disable();
        write(BAUDDIV, 16);
        write(CTRL, CTRL_ON);
        write_nvic(NVIC_ISER0, UART0_RX_IRQ);
        Self(())
    }

    /// Waits (asleep: `wfi`, so QEMU hands the next byte over at once instead of the core
    /// spinning) for one received byte.
    pub fn read_byte(&self) -> u8 {
        loop {
            if read(STATE) & RX_FULL != 0 {
                let b = (read(DATA) & 0xFF) as u8;
                write(INTSTATUS, RX_INT);
                write_nvic(NVIC_ICPR0, UART0_RX_IRQ);
                return b;
            }
            cortex_m::asm::wfi();
        }
    }

    /// Sends `bytes` (one SLCAN line), waiting while the transmitter is full before the
    /// first byte. QEMU hands each byte to the host at once and clears TX-full before the
    /// store returns unless the host stops reading; checking once per line instead of once
    /// per byte halves the emulated register accesses (each one a trip through QEMU's device
    /// lock), and a byte lost to a stalled host would make the host stop the run on a
    /// malformed line, never pass unnoticed.
    pub fn write_all(&self, bytes: &[u8]) {
        while read(STATE) & TX_FULL != 0 {}
        for &b in bytes {
            write(DATA, u32::from(b));
        }
    }
}

/// SysTick as the instruction counter of one tick: it runs only between [`Counter::start`] and
/// [`Counter::stop`]. Stopped, it leaves QEMU no timer to move virtual time to while the core
/// sleeps in `wfi` (`-icount` then has nothing to account per wake-up), and each count starts
/// at the same instruction, so the counts do not depend on how long the node waited before.
pub struct Counter(SYST);

impl Counter {
    /// Takes SysTick, clocked by the core, stopped.
    pub fn new(mut syst: SYST) -> Self {
        syst.disable_counter();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00FF_FFFF);
        Self(syst)
    }

    /// Restarts the counter from its reload value; returns the first reading.
    pub fn start(&mut self) -> u32 {
        self.0.clear_current();
        self.0.enable_counter();
        SYST::get_current()
    }

    /// Stops the counter; returns the last reading.
    pub fn stop(&mut self) -> u32 {
        let now = SYST::get_current();
        self.0.disable_counter();
        now
    }
}

/// Instructions between two [`Counter`] readings (the counter counts down and wraps at 2²⁴).
pub fn instructions(start: u32, end: u32) -> u32 {
    (start.wrapping_sub(end) & 0x00FF_FFFF) * INSN_PER_TICK
}

/// Where painting started (the stack pointer when [`paint_stack`] ran) and its lowest word.
#[derive(Debug, Clone, Copy)]
pub struct Painted {
    bottom: usize,
}

extern "C" {
    /// Initial stack pointer (top of RAM), from cortex-m-rt's linker script.
    static _stack_start: u32;
}

/// Fills [`PAINT_BYTES`] below the current stack pointer with the pattern. Call once, first
/// thing, with no interrupts enabled.
#[inline(never)]
pub fn paint_stack() -> Painted {
    // The compiler may read the stack pointer before this function's own prologue pushes
    // (shrink-wrapping): the top MARGIN bytes below it are left alone.
    const MARGIN: usize = 256;
    let top = (cortex_m::register::msp::read() as usize & !3) - MARGIN;
    let bottom = top - PAINT_BYTES;
    for a in (bottom..top).step_by(4) {
        // SAFETY: [bottom, top) lies below the live stack pointer and this function's frame,
        // inside the 4 MiB RAM, above .bss (a few KiB at its start); nothing else uses it yet.
        unsafe { core::ptr::write_volatile(a as *mut u32, PATTERN) };
    }
    Painted { bottom }
}

/// Bytes of stack used so far: from the top of the stack down to the lowest word that no
/// longer holds the pattern (the painted region's size if all of it was overwritten).
pub fn stack_high_water(p: Painted) -> u32 {
    // Only the address of the linker symbol is taken (no read).
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let mut lowest = p.bottom + PAINT_BYTES;
    for a in (p.bottom..p.bottom + PAINT_BYTES).step_by(4) {
        // SAFETY: the painted region, plain RAM.
        if unsafe { core::ptr::read_volatile(a as *const u32) } != PATTERN {
            lowest = a;
            break;
        }
    }
    (top - lowest) as u32
}
