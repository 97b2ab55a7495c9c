//! The emulated board (QEMU `mps2-an386`): the only modules with `unsafe` are this one and
//! `pac` (vector table), all of it register or raw-memory access.
//!
//! * **UART0** (CMSDK APB UART at `0x4000_4000`, bound to QEMU's first `-serial`): DATA `0x0`,
//!   STATE `0x4` (bit 0 TX full, bit 1 RX full), CTRL `0x8` (bit 0 TX enable, bit 1 RX enable,
//!   bit 3 RX interrupt enable), INTSTATUS `0xC`, BAUDDIV `0x10` (QEMU ignores transmissions
//!   while it is below 16). Receive interrupt: IRQ 0.
//! * **Sample timer**: CMSDK APB timer 0 at `0x4000_0000` (IRQ 8), clocked at 25 MHz: CTRL
//!   `0x0` (bit 0 enable, bit 3 interrupt enable), VALUE `0x4`, RELOAD `0x8`, INTSTATUS /
//!   INTCLEAR `0xC`.
//! * **Watchdog**: CMSDK APB watchdog at `0x4000_8000`, 25 MHz: LOAD `0x0` (a write reloads the
//!   count), VALUE `0x4` (the count), CONTROL `0x8` (bit 0 INTEN: interrupt on the first
//!   expiry, the NMI; bit 1 RESEN: QEMU resets the machine on the second expiry without a clear
//!   in between). The NMI resets the core at the first expiry (`SYSRESETREQ`); the second
//!   expiry's reset stays as the backstop of a core that cannot take the NMI.
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

const TIMER0: usize = 0x4000_0000;
const TIMER_CTRL: usize = 0x0;
const TIMER_VALUE: usize = 0x4;
const TIMER_RELOAD: usize = 0x8;
const TIMER_INTCLEAR: usize = 0xC;
/// Timer CTRL: enable (bit 0) and interrupt enable (bit 3).
const TIMER_RUN: u32 = 0b1001;
/// Timer CTRL: interrupt enabled, counter stopped.
const TIMER_PAUSED: u32 = 0b1000;

const WDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = 0x0;
const WDOG_VALUE: usize = 0x4;
const WDOG_CONTROL: usize = 0x8;
/// Watchdog CONTROL: INTEN | RESEN.
const WDOG_ON: u32 = 0b11;

/// Timer and watchdog counts per µs (the board's 25 MHz peripheral clock).
pub const COUNTS_PER_US: u32 = 25;
/// Instructions per SysTick count under `-icount shift=0` (25 MHz, 1 ns per instruction).
pub const INSN_PER_TICK: u32 = 40;
/// Bytes painted below the stack pointer at start-up.
pub const PAINT_BYTES: usize = 64 * 1024;
const PATTERN: u32 = 0xA5C3_5A3C;

fn read(addr: usize) -> u32 {
    // SAFETY: callers pass an aligned register of the mps2-an386 memory map (UART0, timer 0,
    // watchdog), each a plain 32-bit device register.
    unsafe { core::ptr::read_volatile(addr as *const u32) }
}

fn write(addr: usize, v: u32) {
    // SAFETY: as in `read`.
    unsafe { core::ptr::write_volatile(addr as *mut u32, v) }
}

/// UART0, the node's SLCAN link to the host.
#[derive(Debug)]
pub struct Uart(());

impl Uart {
    /// Enables transmitter, receiver and the receive interrupt (IRQ 0, which RTIC unmasks for
    /// the task bound to it).
    pub fn init() -> Self {
        write(UART0 + BAUDDIV, 16);
        write(UART0 + CTRL, CTRL_ON);
        Self(())
    }

    /// Sends `bytes` (one SLCAN line), waiting while the transmitter is full before the
    /// first byte. QEMU hands each byte to the host at once and clears TX-full before the
    /// store returns unless the host stops reading; checking once per line instead of once
    /// per byte halves the emulated register accesses (each one a trip through QEMU's device
    /// lock), and a byte lost to a stalled host would make the host stop the run on a
    /// malformed line, never pass unnoticed.
    pub fn write_all(&mut self, bytes: &[u8]) {
        while read(UART0 + STATE) & TX_FULL != 0 {}
        for &b in bytes {
            write(UART0 + DATA, u32::from(b));
        }
    }
}

/// UART0's receiver, owned by the receive interrupt.
#[derive(Debug)]
pub struct UartRx(());

impl UartRx {
    /// The receiver; [`Uart::init`] switches it on.
    pub fn new() -> Self {
        Self(())
    }

    /// The received byte, if any, and clears the receive interrupt (QEMU then hands over
    /// the next byte).
    pub fn take(&mut self) -> Option<u8> {
        if read(UART0 + STATE) & RX_FULL == 0 {
            return None;
        }
        let b = (read(UART0 + DATA) & 0xFF) as u8;
        write(UART0 + INTSTATUS, RX_INT);
        Some(b)
    }
}

/// With interrupts masked (the control task's way of running, [`mask_interrupts`]): sleeps
/// (`wfi`) until an interrupt is pending unless `ready()` holds, then lets the pending
/// handlers run and masks again. Handlers thus nest on the control task only here, at a fixed
/// depth of its stack, so the stack high-water mark does not depend on when bytes arrive.
pub fn sleep_unless(ready: impl FnOnce() -> bool) {
    if !ready() {
        cortex_m::asm::wfi();
    }
    unmask_interrupts();
    cortex_m::interrupt::disable();
}

/// Masks every interrupt but the NMI (PRIMASK).
pub fn mask_interrupts() {
    cortex_m::interrupt::disable();
}

/// Undoes [`mask_interrupts`].
pub fn unmask_interrupts() {
    // SAFETY: the control task masks interrupts itself and unmasks them before it returns,
    // waits or spins; no critical section of RTIC's (which raise BASEPRI) spans this.
    unsafe { cortex_m::interrupt::enable() };
}

/// CMSDK APB timer 0: releases the control task once per sample period.
#[derive(Debug)]
pub struct SampleTimer {
    counts: u32,
}

impl SampleTimer {
    /// Starts the periodic interrupt every `period_us` µs (at least 1).
    pub fn start(period_us: u32) -> Self {
        let counts = period_us.max(1).saturating_mul(COUNTS_PER_US);
        write(TIMER0 + TIMER_CTRL, 0);
        write(TIMER0 + TIMER_RELOAD, counts);
        write(TIMER0 + TIMER_VALUE, counts);
        write(TIMER0 + TIMER_INTCLEAR, 1);
        write(TIMER0 + TIMER_CTRL, TIMER_RUN);
        Self { counts }
    }

    /// Timer counts per period.
    pub fn counts(&self) -> u32 {
        self.counts
    }

    /// In the release interrupt: clears it and starts the next period now, so the period is
    /// measured from the release the core saw (not from the nominal expiry).
    pub fn restart(&self) {
        write(TIMER0 + TIMER_INTCLEAR, 1);
        write(TIMER0 + TIMER_VALUE, self.counts);
    }

    /// Stops the count where it is (the remaining part of the period is kept).
    pub fn pause() {
        write(TIMER0 + TIMER_CTRL, TIMER_PAUSED);
    }

    /// Counts on from where [`Self::pause`] stopped.
    pub fn resume() {
        write(TIMER0 + TIMER_CTRL, TIMER_RUN);
    }

    /// Counts left in the current period (down to 0 at the next release).
    pub fn value() -> u32 {
        read(TIMER0 + TIMER_VALUE)
    }
}

/// The CMSDK APB watchdog as the deadline watchdog of the control task: fed only by a step
/// that ended before its deadline, frozen (neither fed nor counting on) while the node waits
/// for the host, and resetting the node at its first expiry.
#[derive(Debug)]
pub struct Watchdog;

/// The watchdog's count kept while it is frozen ([`Watchdog::freeze`]).
#[derive(Debug, Clone, Copy)]
pub struct Frozen(u32);

impl Watchdog {
    /// Starts it with `counts` (25 MHz counts) to its expiry: interrupt (the NMI, which resets
    /// the core) on the first expiry, machine reset on the second.
    pub fn enable(counts: u32) -> Self {
        Self::feed(counts);
        write(WDOG + WDOG_CONTROL, WDOG_ON);
        Self
    }

    /// Feeds it: the expiry (the reset) comes `counts` (at least 1) from now.
    pub fn feed(counts: u32) {
        write(WDOG + WDOG_LOAD, counts.max(1));
    }

    /// Stops its count where it is (reloads it with the longest timeout, 2³² counts, 172 s, and
    /// keeps what was left): the wait for the host is not the node's time. Not a feed:
    /// [`Self::thaw`] puts the count back.
    pub fn freeze() -> Frozen {
        let left = read(WDOG + WDOG_VALUE);
        write(WDOG + WDOG_LOAD, u32::MAX);
        Frozen(left)
    }

    /// Counts on from where [`Self::freeze`] stopped it.
    pub fn thaw(f: Frozen) {
        Self::feed(f.0);
    }
}

/// The watchdog's first expiry (QEMU's mps2 wires WDOGINT to the NMI): no step ended in time
/// for the configured late periods, so the node resets now (`SYSRESETREQ`, which QEMU turns
/// into a machine reset; the watchdog's own reset at the second expiry is the backstop).
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    // SAFETY: a plain word of RAM that nothing else writes; the core resets right after.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(RESET_CAUSE), WATCHDOG_RESET) };
    cortex_m::peripheral::SCB::sys_reset();
}

/// [`RESET_CAUSE`] after the watchdog's reset.
const WATCHDOG_RESET: u32 = 0x5744_5253;

/// Why the core last reset: outside `.data` and `.bss` (`.uninit`, which the start-up code
/// leaves alone and QEMU's machine reset does not reload), so it survives the reset.
#[link_section = ".uninit.RESET_CAUSE"]
static mut RESET_CAUSE: u32 = 0;

/// `true` once after a reset by the watchdog (the NMI marked it); any other start — power-on,
/// whatever the RAM then holds — reads `false`. Clears the mark.
pub fn take_watchdog_reset() -> bool {
    // SAFETY: a word of RAM only this function and the NMI handler touch; called in `init`,
    // before interrupts run.
    let cause = unsafe { core::ptr::read_volatile(core::ptr::addr_of!(RESET_CAUSE)) };
    // SAFETY: as above.
    unsafe { core::ptr::write_volatile(core::ptr::addr_of_mut!(RESET_CAUSE), 0) };
    cause == WATCHDOG_RESET
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
