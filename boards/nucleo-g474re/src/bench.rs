//! The board on the bench of `docs/NETWORK.md` §11 (feature `bench`): a PC on the same CAN bus
//! simulates the plant and the leader, sends each follower a *sensor* frame (`0x200 + i`:
//! `x_{i,1}`, `x_{i,2}`) every sample and applies the follower's latest *command* frame
//! (`0x300 + i`: `q_{i,1}`, `q_{i,2}`), `agent_node::plant_bus`. [`BusSensor`] and
//! [`BusActuator`] take the place of the encoder and the PWM; the output gate
//! ([`crate::gate`]) still decides: a disabled gate sends the neutral command (zero), the
//! bench's equivalent of a disabled driver. What the board does is said by CANopen, as for
//! every bench node: its NMT state in its heartbeat (`0x700 + i`), and the host's silence by
//! EMCY `0x8250` ([`agent_node::canopen::Fault::HostLost`], once per silence: [`HostWatch`]).

use agent_node::{Actuator, Sensor};

use crate::gate::Freshness;

/// The state has no sensor value: no sensor frame yet, or the latest older than the stale
/// timeout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SensorLost;

/// The agent's state from the host's sensor frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusSensor {
    latest: Option<[f32; 2]>,
    age: Freshness,
    period_us: u32,
    stale_timeout_us: u64,
}

impl BusSensor {
    /// Fresh while the latest sensor frame is no older than `stale_timeout_us` at a sample
    /// period of `period_us`.
    pub const fn new(period_us: u32, stale_timeout_us: u64) -> Self {
        Self {
            latest: None,
            age: Freshness::new(),
            period_us,
            stale_timeout_us,
        }
    }

    /// Once per sample, before `Node::tick`: the latest sensor frame received since the last
    /// sample, if any.
    pub fn offer(&mut self, x: Option<[f32; 2]>) {
        if x.is_some() {
            self.latest = x;
        }
        self.age.tick(x.is_some());
    }

    /// A sensor frame has been received at all.
    pub const fn heard(&self) -> bool {
        self.latest.is_some()
    }

    /// The latest value is fresh.
    pub fn is_fresh(&self) -> bool {
        self.latest.is_some() && self.age.is_fresh(self.period_us, self.stale_timeout_us)
    }
}

impl Sensor<2> for BusSensor {
    type Error = SensorLost;

    /// The latest sensor frame's state while fresh.
    fn read(&mut self) -> Result<[f32; 2], SensorLost> {
        match self.latest {
            Some(x) if self.is_fresh() => Ok(x),
            _ => Err(SensorLost),
        }
    }
}

/// The node's commands, kept for the command frame the firmware sends after the gate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BusActuator {
    q: [f32; 2],
}

/// A command that is not a number (the command frame carries zero instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NonFiniteCommand;

impl BusActuator {
    /// The command frame's payload: the node's commands when the gate drives, zero otherwise.
    pub fn command(&self, drive: bool) -> [f32; 2] {
        if drive {
            self.q
        } else {
            [0.0; 2]
        }
    }
}

impl Actuator<2> for BusActuator {
    type Error = NonFiniteCommand;

    fn write(&mut self, q: &[f32; 2]) -> Result<(), NonFiniteCommand> {
        if q.iter().all(|v| v.is_finite()) {
            self.q = *q;
            Ok(())
        } else {
            self.q = [0.0; 2];
            Err(NonFiniteCommand)
        }
    }
}

/// Whether the host is gone: a sensor frame came once, and the latest is no longer fresh.
pub fn host_lost(sensor: &BusSensor) -> bool {
    sensor.heard() && !sensor.is_fresh()
}

/// Reports the host's silence once per silence: the board goes on (its sensor loss is the
/// supervisor's, docs/NETWORK.md §10), the host may come back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HostWatch {
    lost: bool,
}

impl HostWatch {
    /// Nothing lost yet.
    pub const fn new() -> Self {
        Self { lost: false }
    }

    /// This sample's [`host_lost`]; `true` at the sample the host became lost (EMCY due).
    pub fn update(&mut self, lost: bool) -> bool {
        let due = lost && !self.lost;
        self.lost = lost;
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use agent_node::{plant_bus, CanFrame};

    #[test]
    fn the_sensor_is_fresh_only_within_the_stale_timeout_of_the_last_frame() {
        let mut s = BusSensor::new(1_000, 2_500);
        assert_eq!(s.read(), Err(SensorLost));
        assert!(!host_lost(&s), "waiting is not lost");
        s.offer(Some([0.5, -1.0]));
        assert_eq!(s.read(), Ok([0.5, -1.0]));
        assert!(!host_lost(&s));
        s.offer(None);
        s.offer(None);
        assert_eq!(s.read(), Ok([0.5, -1.0]), "2 ms old");
        s.offer(None);
        assert_eq!(s.read(), Err(SensorLost), "3 ms old");
        assert!(host_lost(&s));
        s.offer(Some([1.0, 2.0]));
        assert_eq!(s.read(), Ok([1.0, 2.0]));
    }

    #[test]
    fn the_command_frame_carries_zero_unless_the_gate_drives() {
        let mut a = BusActuator::default();
        assert_eq!(a.write(&[3.0, -4.0]), Ok(()));
        assert_eq!(a.command(true), [3.0, -4.0]);
        assert_eq!(a.command(false), [0.0, 0.0]);
        assert_eq!(a.write(&[f32::NAN, 1.0]), Err(NonFiniteCommand));
        assert_eq!(a.command(true), [0.0, 0.0]);
        // The frame the firmware sends for agent 4, as host-sim decodes it.
        let f: CanFrame =
            plant_bus::pair_frame(plant_bus::Kind::Command, 4, [3.0, -4.0]).expect("frame");
        assert_eq!(
            plant_bus::decode(&f),
            Some(plant_bus::PlantFrame::Command(4, [3.0, -4.0]))
        );
    }

    #[test]
    fn the_host_lost_emcy_is_due_once_per_silence() {
        let mut w = HostWatch::new();
        let due: [bool; 6] = [false, true, true, false, true, true].map(|l| w.update(l));
        assert_eq!(due, [false, true, false, false, true, false]);
    }
}
