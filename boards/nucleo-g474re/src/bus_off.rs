//! Bus-off recovery as ISO 11898-1 allows it, without a power cycle.
//!
//! A CAN controller whose transmit error counter passes 255 goes bus-off: it stops driving the
//! bus. ISO 11898-1 lets it return, with both error counters at zero, after it has seen 128
//! occurrences of 11 consecutive recessive bits. The FDCAN enters bus-off by setting
//! `FDCAN_CCCR.INIT` itself (`FDCAN_PSR.BO` = 1) and starts counting those sequences only once
//! software clears `INIT` again; `PSR.BO` clears when the count completes (RM0440 §44.4.1,
//! "Bus-off recovery"). Embassy's FDCAN driver does the same: on the bus-off interrupt it
//! clears `INIT`.
//!
//! [`BusOffRecovery`] decides, once per sample, from `PSR.BO`: at the first sample that sees
//! bus-off it asks for one restart (clear `INIT`: the firmware's `Fdcan1::restart`) and counts
//! it; while the FDCAN counts recessive sequences it waits (a second restart would set and
//! clear `INIT` again and restart the count); only when bus-off lasts [`RETRY_SAMPLES`] after
//! a restart (a controller that did not leave `INIT`, or a bus held dominant) does it ask
//! again. At 1 Mbit/s an idle bus completes the recovery in 128 × 11 µs = 1.4 ms; a busy bus
//! supplies one sequence per frame (every end of frame plus intermission is 11 recessive bits).

/// Samples of uninterrupted bus-off after a restart before another restart (100 ms at 1 kHz).
pub const RETRY_SAMPLES: u32 = 100;

/// The recovery's decision for this sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Nothing to do.
    None,
    /// Clear `INIT`: start the recovery sequence.
    Restart,
}

/// Bus-off recovery state and counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusOffRecovery {
    /// Samples since the last restart while still bus-off; `None`: on the bus.
    waiting: Option<u32>,
    bus_offs: u32,
    restarts: u32,
    recoveries: u32,
}

impl BusOffRecovery {
    /// On the bus, nothing counted.
    pub const fn new() -> Self {
        Self {
            waiting: None,
            bus_offs: 0,
            restarts: 0,
            recoveries: 0,
        }
    }

    /// This sample's `PSR.BO`; what to do.
    pub fn update(&mut self, bus_off: bool) -> Action {
        match (self.waiting, bus_off) {
            (None, false) => Action::None,
            (Some(_), false) => {
                self.waiting = None;
                self.recoveries = self.recoveries.saturating_add(1);
                Action::None
            }
            (None, true) => {
                self.bus_offs = self.bus_offs.saturating_add(1);
                self.restart()
            }
            (Some(n), true) if n + 1 >= RETRY_SAMPLES => self.restart(),
            (Some(n), true) => {
                self.waiting = Some(n + 1);
                Action::None
            }
        }
    }

    fn restart(&mut self) -> Action {
        self.waiting = Some(0);
        self.restarts = self.restarts.saturating_add(1);
        Action::Restart
    }

    /// Bus-off now (entered and not yet recovered).
    pub const fn is_off(&self) -> bool {
        self.waiting.is_some()
    }

    /// Times the controller went bus-off.
    pub const fn bus_offs(&self) -> u32 {
        self.bus_offs
    }

    /// Restarts asked for (one per bus-off, more if one did not complete).
    pub const fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Times the controller came back on the bus.
    pub const fn recoveries(&self) -> u32 {
        self.recoveries
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_restart_per_bus_off_then_wait_for_the_recessive_sequences() {
        let mut r = BusOffRecovery::new();
        assert_eq!(r.update(false), Action::None);
        assert!(!r.is_off());
        assert_eq!(r.update(true), Action::Restart);
        assert!(r.is_off());
        // The FDCAN counts 128 × 11 recessive bits: no second restart meanwhile.
        for _ in 0..3 {
            assert_eq!(r.update(true), Action::None);
        }
        assert_eq!(r.update(false), Action::None);
        assert!(!r.is_off());
        assert_eq!((r.bus_offs(), r.restarts(), r.recoveries()), (1, 1, 1));
        // A second bus-off later is counted again.
        assert_eq!(r.update(true), Action::Restart);
        assert_eq!(r.update(false), Action::None);
        assert_eq!((r.bus_offs(), r.restarts(), r.recoveries()), (2, 2, 2));
    }

    #[test]
    fn a_recovery_that_does_not_complete_is_restarted_every_retry_period() {
        let mut r = BusOffRecovery::new();
        let restarts = (0..10 * RETRY_SAMPLES)
            .filter(|_| r.update(true) == Action::Restart)
            .count();
        assert_eq!(restarts, 10);
        assert_eq!((r.bus_offs(), r.restarts(), r.recoveries()), (1, 10, 0));
        assert!(r.is_off());
    }
}
