//! The interrupt lines of QEMU's `mps2-an386` this firmware uses, as the device module RTIC
//! expects (QEMU 7.2 `hw/arm/mps2.c`: UART0 receive IRQ 0, CMSDK APB timer 0 IRQ 8, dual timer
//! IRQ 10; the watchdog drives the NMI), and the vector table entries for IRQs 0..=10.

/// Priority bits RTIC maps its priorities onto (as on Cortex-M4 parts; QEMU keeps 8).
pub const NVIC_PRIO_BITS: u8 = 3;

/// External interrupts by IRQ number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(clippy::upper_case_acronyms)]
pub enum Interrupt {
    /// UART0 receive (a byte is in DATA).
    UART0RX = 0,
    /// CMSDK APB timer 0 at `0x4000_0000`: the sample period.
    TIMER0 = 8,
    /// CMSDK dual timer (not started: free for RTIC's dispatcher).
    DUALTIMER = 10,
}

pub use Interrupt as interrupt;

// SAFETY: every variant is an IRQ number the board's NVIC implements.
unsafe impl cortex_m::interrupt::InterruptNumber for Interrupt {
    fn number(self) -> u16 {
        self as u16
    }
}

extern "C" {
    fn UART0RX();
    fn TIMER0();
    fn DUALTIMER();
    fn DefaultHandler();
}

/// IRQs 0..=10 (cortex-m-rt's `device` feature places it after the exceptions).
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [unsafe extern "C" fn(); 11] = [
    UART0RX,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    TIMER0,
    DefaultHandler,
    DUALTIMER,
];
