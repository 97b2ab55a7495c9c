//! Mocked peripherals: an in-memory CAN controller implementing
//! `embedded_can::nb::Can`, a settable clock, sensors and actuators. They are plain values the
//! host harness reaches through [`agent_node::Node::can_mut`], [`agent_node::Node::clock_mut`], ... —
//! no shared pointers — so a node runs unchanged against them.

use std::collections::VecDeque;

use embedded_can::ErrorKind;

use agent_node::{Actuator, Clock, Sensor};

/// The mock controller's frame: the crate's classical CAN frame (shared with the PIL link).
pub use agent_node::CanFrame as MockFrame;

/// Errors of the mock CAN controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MockCanError {
    /// The controller is bus-off and may not transmit.
    BusOff,
}

impl embedded_can::Error for MockCanError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// Transmit mailboxes of [`MockCan`] (as bxCAN's three).
pub const TX_MAILBOXES: usize = 3;

/// An in-memory CAN controller: a receive FIFO and [`TX_MAILBOXES`] transmit mailboxes.
///
/// `transmit` replaces a frame with the same identifier still in a mailbox and returns it
/// (`Ok(Some(old))`); otherwise it takes a free mailbox; with all full, it replaces the
/// pending frame of lowest priority if that one's identifier is higher than the new one's,
/// else `WouldBlock`. While [`MockCan::set_bus_off`] is on, `transmit` fails with
/// [`MockCanError::BusOff`]. The harness empties the mailboxes with [`MockCan::take_tx`]
/// (highest priority first) and fills the FIFO with [`MockCan::push_rx`]; a full FIFO drops
/// the new frame (an overrun).
#[derive(Debug, Clone)]
pub struct MockCan {
    rx: VecDeque<MockFrame>,
    rx_capacity: usize,
    tx: Vec<MockFrame>,
    bus_off: bool,
    overruns: u32,
}

impl Default for MockCan {
    fn default() -> Self {
        Self::new(64)
    }
}

impl MockCan {
    /// A controller whose receive FIFO holds `rx_capacity` frames.
    pub fn new(rx_capacity: usize) -> Self {
        Self {
            rx: VecDeque::with_capacity(rx_capacity),
            rx_capacity,
            tx: Vec::with_capacity(TX_MAILBOXES),
            bus_off: false,
            overruns: 0,
        }
    }

    /// A frame arrives from the bus; `false` (and an overrun counted) if the FIFO was full.
    pub fn push_rx(&mut self, frame: MockFrame) -> bool {
        if self.rx.len() >= self.rx_capacity {
            self.overruns = self.overruns.saturating_add(1);
            return false;
        }
        self.rx.push_back(frame);
        true
    }

    /// The frame of highest priority waiting in a transmit mailbox, if any (the harness puts
    /// it on the bus).
    pub fn take_tx(&mut self) -> Option<MockFrame> {
        let k = (0..self.tx.len()).min_by_key(|&k| self.tx[k].raw_id())?;
        Some(self.tx.remove(k))
    }

    /// Mirror the bus's error state: a bus-off controller refuses to transmit.
    pub fn set_bus_off(&mut self, bus_off: bool) {
        self.bus_off = bus_off;
    }

    /// Frames dropped because the receive FIFO was full.
    pub fn overruns(&self) -> u32 {
        self.overruns
    }

    /// Frames waiting in the receive FIFO.
    pub fn rx_pending(&self) -> usize {
        self.rx.len()
    }
}

impl embedded_can::nb::Can for MockCan {
    type Frame = MockFrame;
    type Error = MockCanError;

    fn transmit(&mut self, frame: &MockFrame) -> nb::Result<Option<MockFrame>, MockCanError> {
        if self.bus_off {
            return Err(nb::Error::Other(MockCanError::BusOff));
        }
        let id = frame.raw_id();
        if let Some(slot) = self.tx.iter_mut().find(|f| f.raw_id() == id) {
            return Ok(Some(std::mem::replace(slot, *frame)));
        }
        if self.tx.len() < TX_MAILBOXES {
            self.tx.push(*frame);
            return Ok(None);
        }
        match self.tx.iter_mut().max_by_key(|f| f.raw_id()) {
            Some(lowest) if lowest.raw_id() > id => Ok(Some(std::mem::replace(lowest, *frame))),
            _ => Err(nb::Error::WouldBlock),
        }
    }

    fn receive(&mut self) -> nb::Result<MockFrame, MockCanError> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

/// A clock the harness sets.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MockClock {
    now_us: u64,
}

impl MockClock {
    /// Set the time (µs). The harness keeps it monotonic.
    pub fn set(&mut self, now_us: u64) {
        self.now_us = now_us;
    }
}

impl Clock for MockClock {
    fn now_us(&mut self) -> u64 {
        self.now_us
    }
}

/// Sensors reporting the state the harness last set; `fail` makes reads fail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MockSensor<const N: usize> {
    /// The state returned by the next read.
    pub x: [f32; N],
    /// Reads fail while set.
    pub fail: bool,
}

impl<const N: usize> Default for MockSensor<N> {
    fn default() -> Self {
        Self {
            x: [0.0; N],
            fail: false,
        }
    }
}

/// The mock sensor's read error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensorFault;

impl<const N: usize> Sensor<N> for MockSensor<N> {
    type Error = SensorFault;
    fn read(&mut self) -> Result<[f32; N], SensorFault> {
        if self.fail {
            Err(SensorFault)
        } else {
            Ok(self.x)
        }
    }
}

/// Actuators remembering the last commands written (the plant's input, held until the next
/// write); `fail` makes writes fail (the previous commands stay).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MockActuator<const M: usize> {
    /// The commands applied to the plant.
    pub q: [f32; M],
    /// Successful writes.
    pub writes: u32,
    /// Writes fail while set.
    pub fail: bool,
}

impl<const M: usize> Default for MockActuator<M> {
    fn default() -> Self {
        Self {
            q: [0.0; M],
            writes: 0,
            fail: false,
        }
    }
}

/// The mock actuator's write error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ActuatorFault;

impl<const M: usize> Actuator<M> for MockActuator<M> {
    type Error = ActuatorFault;
    fn write(&mut self, q: &[f32; M]) -> Result<(), ActuatorFault> {
        if self.fail {
            return Err(ActuatorFault);
        }
        self.q = *q;
        self.writes = self.writes.saturating_add(1);
        Ok(())
    }
}

/// A node on mocked hardware.
pub type MockNode<const N: usize, const M: usize, const K: usize> =
    agent_node::Node<MockCan, MockClock, MockSensor<N>, MockActuator<M>, N, M, K>;

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::Frame;
    use embedded_can::{nb::Can, StandardId};

    fn frame(id: u16) -> MockFrame {
        MockFrame::new(StandardId::new(id).expect("11-bit"), &[1, 2, 3]).expect("≤ 8 bytes")
    }

    #[test]
    fn mailboxes_replace_the_same_id_then_the_lowest_priority() {
        let mut c = MockCan::default();
        assert_eq!(c.transmit(&frame(0x105)), Ok(None));
        assert_eq!(c.transmit(&frame(0x105)), Ok(Some(frame(0x105))));
        assert_eq!(c.transmit(&frame(0x785)), Ok(None));
        assert_eq!(c.transmit(&frame(0x106)), Ok(None));
        // Full: a higher-priority frame displaces the lowest-priority one, a lower one waits.
        assert_eq!(c.transmit(&frame(0x104)), Ok(Some(frame(0x785))));
        assert_eq!(c.transmit(&frame(0x107)), Err(nb::Error::WouldBlock));
        assert_eq!(c.take_tx(), Some(frame(0x104)));
        assert_eq!(c.take_tx(), Some(frame(0x105)));
        assert_eq!(c.take_tx(), Some(frame(0x106)));
        assert_eq!(c.take_tx(), None);
        c.set_bus_off(true);
        assert_eq!(
            c.transmit(&frame(0x105)),
            Err(nb::Error::Other(MockCanError::BusOff))
        );
    }

    #[test]
    fn fifo_overrun_is_counted() {
        let mut c = MockCan::new(2);
        assert!(c.push_rx(frame(1)));
        assert!(c.push_rx(frame(2)));
        assert!(!c.push_rx(frame(3)));
        assert_eq!(c.overruns(), 1);
        assert_eq!(c.receive(), Ok(frame(1)));
        assert_eq!(c.receive(), Ok(frame(2)));
        assert_eq!(c.receive(), Err(nb::Error::WouldBlock));
        assert!(MockFrame::new(StandardId::ZERO, &[0; 9]).is_none());
    }
}
