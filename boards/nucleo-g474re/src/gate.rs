//! The output gate: when the motor driver's enable line (PA8) may be high and what the PWM
//! outputs carry. A pure state machine, evaluated once per sample after `Node::tick`, so every
//! path to an enabled driver can be checked on the host (`cargo test --lib`, exhaustive over
//! the inputs below).
//!
//! | gate state | driver enable | PWM duty (both channels) |
//! |---|---|---|
//! | [`GateState::Disabled`] (from reset) | low | neutral, 50 % (zero command) |
//! | [`GateState::Arming`] (one sample) | low | neutral, 50 % |
//! | [`GateState::Enabled`] | high | the node's command `q` |
//!
//! **Arming** needs, in two consecutive samples: the node commanded to run
//! ([`GateInputs::run_commanded`]), its state `Operational`, a fresh sensor value, a fresh
//! leader value (when the node uses the leader), and the CAN controller on the bus. The first
//! such sample writes the neutral duty with the enable still low (TIM3 loads a new duty at its
//! next update event, up to one PWM period later; a whole sample later it is certainly
//! loaded); the second raises the enable.
//!
//! **Staying enabled** needs, every sample: run commanded, on the bus, a fresh sensor value, and
//! a state that drives the plant in closed loop or along a safe-state policy that needs the
//! driver: `Operational`, or `Safe` with any policy but the open-loop `off`. Anything else
//! (`Boot`, `Fault`, bus-off, `Safe` with `off`, a lost sensor, the run command withdrawn)
//! drops the enable in that same sample and returns to `Disabled`, from where only a new
//! arming sequence enables it again. A freshness loss of the leader alone does not drop an
//! enabled driver: the node's supervisor decides what a silent leader means (its safe state).

use agent_node::{NodeState, SafePolicy};

/// Where the gate is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum GateState {
    /// Driver enable low, PWM neutral: the state after reset.
    #[default]
    Disabled,
    /// Driver enable still low, PWM neutral written: one sample before enabling.
    Arming,
    /// Driver enable high, PWM carries the command.
    Enabled,
}

/// What the gate decides on, read once per sample after `Node::tick`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateInputs {
    /// The node was commanded to run ([`RunCommand`]: NMT operational).
    pub run_commanded: bool,
    /// The node's supervisor state after the tick.
    pub state: NodeState,
    /// The safe-state policy configured for `Safe`.
    pub policy: SafePolicy,
    /// The sensor value of this sample is fresh (finite and, on the bench, from a sensor frame
    /// within the stale timeout).
    pub sensor_fresh: bool,
    /// The leader's value is fresh (within the stale timeout), or the node does not use the
    /// leader.
    pub leader_fresh: bool,
    /// The CAN controller is bus-off (or recovering from it).
    pub bus_off: bool,
}

/// What the outputs do this sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GateOutput {
    /// The driver enable line is high.
    pub enable: bool,
    /// The PWM carries the node's command (otherwise the neutral 50 % duty).
    pub drive: bool,
}

impl GateState {
    /// The outputs of this state.
    pub const fn output(self) -> GateOutput {
        match self {
            Self::Disabled | Self::Arming => GateOutput {
                enable: false,
                drive: false,
            },
            Self::Enabled => GateOutput {
                enable: true,
                drive: true,
            },
        }
    }
}

/// The safe-state policy writes zero open loop (CiA 402 "disable voltage"): the driver is
/// not needed for it.
pub const fn is_open_loop_off(policy: SafePolicy) -> bool {
    matches!(policy, SafePolicy::Off)
}

/// The conditions under which an enabled driver stays enabled.
pub fn may_stay_enabled(i: &GateInputs) -> bool {
    let state_drives = match i.state {
        NodeState::Operational => true,
        NodeState::Safe => !is_open_loop_off(i.policy),
        NodeState::Boot | NodeState::Fault => false,
    };
    i.run_commanded && !i.bus_off && i.sensor_fresh && state_drives
}

/// The conditions under which a disabled driver may be armed (and, one sample later, enabled).
pub fn may_arm(i: &GateInputs) -> bool {
    may_stay_enabled(i) && i.state == NodeState::Operational && i.leader_fresh
}

/// The gate's transition: the next state from the current one and this sample's inputs.
pub fn next(state: GateState, i: &GateInputs) -> GateState {
    match state {
        GateState::Disabled if may_arm(i) => GateState::Arming,
        GateState::Arming if may_arm(i) => GateState::Enabled,
        GateState::Enabled if may_stay_enabled(i) => GateState::Enabled,
        _ => GateState::Disabled,
    }
}

/// The output gate of one board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputGate {
    state: GateState,
    enables: u32,
    disables: u32,
}

impl OutputGate {
    /// The gate after reset: disabled.
    pub const fn new() -> Self {
        Self {
            state: GateState::Disabled,
            enables: 0,
            disables: 0,
        }
    }

    /// Evaluate this sample's inputs; the outputs to apply now.
    pub fn update(&mut self, i: &GateInputs) -> GateOutput {
        let next = next(self.state, i);
        match (self.state, next) {
            (GateState::Arming, GateState::Enabled) => {
                self.enables = self.enables.saturating_add(1);
            }
            (GateState::Enabled, GateState::Disabled) => {
                self.disables = self.disables.saturating_add(1);
            }
            _ => {}
        }
        self.state = next;
        next.output()
    }

    /// The current state.
    pub const fn state(&self) -> GateState {
        self.state
    }

    /// Times the driver was enabled since reset.
    pub const fn enables(&self) -> u32 {
        self.enables
    }

    /// Times an enabled driver was disabled since reset.
    pub const fn disables(&self) -> u32 {
        self.disables
    }
}

/// "Commanded to run": the node's CANopen device is NMT operational (CiA 301 §7.3.2: the
/// master's NMT start; stop, enter pre-operational and the resets withdraw it) and, since that
/// start, its supervisor has reached `Operational` (every supervised source heard); a `Fault`
/// withdraws it until the next NMT start. NMT is the one run command: nothing else arms the
/// gate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RunCommand {
    commanded: bool,
    faulted: bool,
}

impl RunCommand {
    /// Not commanded (after reset).
    pub const fn new() -> Self {
        Self {
            commanded: false,
            faulted: false,
        }
    }

    /// Update from the device's NMT state (`nmt_operational`) and the node's state after a
    /// tick; whether the node is commanded to run.
    pub fn update(&mut self, nmt_operational: bool, state: NodeState) -> bool {
        if !nmt_operational {
            *self = Self::new();
            return false;
        }
        match state {
            NodeState::Operational if !self.faulted => self.commanded = true,
            NodeState::Fault => {
                self.commanded = false;
                self.faulted = true;
            }
            _ => {}
        }
        self.commanded
    }
}

/// Age of a value counted in samples: fresh while no older than the stale timeout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Freshness {
    /// Samples since the value last arrived; `None`: never.
    age: Option<u32>,
}

impl Freshness {
    /// Never heard.
    pub const fn new() -> Self {
        Self { age: None }
    }

    /// One sample passed; `arrived`: a new value came during it.
    pub fn tick(&mut self, arrived: bool) {
        self.age = if arrived {
            Some(0)
        } else {
            self.age.map(|a| a.saturating_add(1))
        };
    }

    /// The value is no older than `stale_timeout_us` at a sample period of `period_us`.
    pub fn is_fresh(&self, period_us: u32, stale_timeout_us: u64) -> bool {
        self.age
            .is_some_and(|a| u64::from(a) * u64::from(period_us) <= stale_timeout_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STATES: [NodeState; 4] = [
        NodeState::Boot,
        NodeState::Operational,
        NodeState::Safe,
        NodeState::Fault,
    ];
    /// One policy of each class the gate tells apart: closed loop, open loop but not off, off.
    const POLICIES: [SafePolicy; 3] = [
        SafePolicy::HoldPosition,
        SafePolicy::Ramp { rate: 40.0 },
        SafePolicy::Off,
    ];

    /// Every combination of the inputs: 2 × 4 × 3 × 2 × 2 × 2 = 192.
    fn all_inputs() -> Vec<GateInputs> {
        let mut v = Vec::new();
        for run_commanded in [false, true] {
            for state in STATES {
                for policy in POLICIES {
                    for sensor_fresh in [false, true] {
                        for leader_fresh in [false, true] {
                            for bus_off in [false, true] {
                                v.push(GateInputs {
                                    run_commanded,
                                    state,
                                    policy,
                                    sensor_fresh,
                                    leader_fresh,
                                    bus_off,
                                });
                            }
                        }
                    }
                }
            }
        }
        v
    }

    /// The inputs under which the driver must be off whatever happened before.
    fn forbids_enable(i: &GateInputs) -> bool {
        i.state == NodeState::Boot
            || i.state == NodeState::Fault
            || i.bus_off
            || (i.state == NodeState::Safe && i.policy == SafePolicy::Off)
            || !i.run_commanded
            || !i.sensor_fresh
    }

    #[test]
    fn the_gate_starts_disabled_with_neutral_outputs() {
        let g = OutputGate::new();
        assert_eq!(g.state(), GateState::Disabled);
        assert_eq!(
            g.state().output(),
            GateOutput {
                enable: false,
                drive: false
            }
        );
        assert_eq!(OutputGate::default(), g);
    }

    /// Every gate state × every input: the driver is never enabled under an input that forbids
    /// it, and a disabled driver never drives the PWM.
    #[test]
    fn no_state_and_input_enables_the_driver_in_boot_fault_bus_off_or_off() {
        let inputs = all_inputs();
        assert_eq!(inputs.len(), 192);
        let mut forbidden = 0;
        for s in [GateState::Disabled, GateState::Arming, GateState::Enabled] {
            for i in &inputs {
                let o = next(s, i).output();
                assert_eq!(o.enable, o.drive, "{s:?} {i:?}");
                if forbids_enable(i) {
                    forbidden += 1;
                    assert!(!o.enable, "enabled from {s:?} under {i:?}");
                    assert_eq!(next(s, i), GateState::Disabled, "{s:?} {i:?}");
                }
            }
        }
        // The check saw each forbidding input in each state (not a vacuous pass).
        assert!(forbidden > 3 * 150, "{forbidden}");
    }

    /// Every sequence of three samples from reset (192³ ≈ 7.1 million): the driver is enabled
    /// only in the third sample, after two samples that each allowed arming, the first of them
    /// with the PWM neutral and the enable low.
    #[test]
    fn every_path_from_reset_to_an_enabled_driver_passes_an_arming_sample() {
        let inputs = all_inputs();
        let mut enabled_paths = 0u64;
        for a in &inputs {
            let s1 = next(GateState::Disabled, a);
            assert!(!s1.output().enable, "enabled in the first sample: {a:?}");
            for b in &inputs {
                let s2 = next(s1, b);
                if s2.output().enable {
                    assert_eq!(s1, GateState::Arming);
                    assert!(
                        !s1.output().drive && may_arm(a) && may_arm(b),
                        "{a:?} {b:?}"
                    );
                }
                for c in &inputs {
                    let s3 = next(s2, c);
                    if !s3.output().enable {
                        continue;
                    }
                    enabled_paths += 1;
                    assert!(!forbids_enable(c), "{a:?} {b:?} {c:?}");
                    // Enabled: either just armed (b, c allowed arming) or armed by a, b.
                    let armed_now = s2 == GateState::Arming && may_arm(b) && may_arm(c);
                    let armed_before = s2 == GateState::Enabled && may_arm(a) && may_arm(b);
                    assert!(armed_now || armed_before, "{a:?} {b:?} {c:?}");
                }
            }
        }
        // Counted independently: 3 inputs allow arming (Operational, fresh, on the bus, run
        // commanded; any of the 3 policies), 10 allow staying enabled (also Safe with hold or
        // ramp, leader fresh or not). Armed by a, b and kept by c: 3 · 3 · 10 = 90; a not
        // arming, armed by b, c: 189 · 3 · 3 = 1,701.
        println!(
            "paths of 3 samples from reset: {}, enabled at the third: {enabled_paths}",
            inputs.len().pow(3)
        );
        assert_eq!(enabled_paths, 90 + 1_701);
    }

    #[test]
    fn arming_needs_operational_fresh_sensor_and_leader_and_the_run_command() {
        let ok = GateInputs {
            run_commanded: true,
            state: NodeState::Operational,
            policy: SafePolicy::Hold,
            sensor_fresh: true,
            leader_fresh: true,
            bus_off: false,
        };
        let mut g = OutputGate::new();
        assert!(!g.update(&ok).enable, "arming sample");
        assert_eq!(g.state(), GateState::Arming);
        assert!(g.update(&ok).enable);
        assert_eq!(g.enables(), 1);
        let without = [
            GateInputs {
                run_commanded: false,
                ..ok
            },
            GateInputs {
                state: NodeState::Safe,
                ..ok
            },
            GateInputs {
                sensor_fresh: false,
                ..ok
            },
            GateInputs {
                leader_fresh: false,
                ..ok
            },
            GateInputs {
                bus_off: true,
                ..ok
            },
        ];
        for w in without {
            assert_eq!(next(GateState::Disabled, &w), GateState::Disabled, "{w:?}");
            assert_eq!(next(GateState::Arming, &w), GateState::Disabled, "{w:?}");
        }
    }

    #[test]
    fn an_enabled_driver_stays_enabled_in_a_driving_safe_state_and_drops_in_off() {
        let ok = GateInputs {
            run_commanded: true,
            state: NodeState::Operational,
            policy: SafePolicy::Ramp { rate: 40.0 },
            sensor_fresh: true,
            leader_fresh: true,
            bus_off: false,
        };
        let mut g = OutputGate::new();
        g.update(&ok);
        g.update(&ok);
        let silent_leader = GateInputs {
            state: NodeState::Safe,
            leader_fresh: false,
            ..ok
        };
        assert!(g.update(&silent_leader).enable, "ramp needs the driver");
        let off = GateInputs {
            policy: SafePolicy::Off,
            ..silent_leader
        };
        assert!(!g.update(&off).enable, "off: driver disabled");
        assert_eq!(g.disables(), 1);
        // Back to Operational with a fresh leader: one arming sample first.
        assert!(!g.update(&ok).enable);
        assert!(g.update(&ok).enable);
    }

    #[test]
    fn the_run_command_follows_the_supervisor_and_a_fault_withdraws_it() {
        let mut r = RunCommand::new();
        assert!(!r.update(true, NodeState::Boot));
        assert!(
            !r.update(true, NodeState::Safe),
            "safe before ever operational"
        );
        assert!(r.update(true, NodeState::Operational));
        assert!(r.update(true, NodeState::Safe));
        assert!(!r.update(true, NodeState::Fault));
        assert!(!r.update(true, NodeState::Safe));
        assert!(
            !r.update(true, NodeState::Operational),
            "a fault holds until the next NMT start"
        );
    }

    #[test]
    fn only_nmt_operational_commands_the_run() {
        let mut r = RunCommand::new();
        for s in STATES {
            assert!(!r.update(false, s), "pre-operational or stopped: {s:?}");
        }
        assert!(r.update(true, NodeState::Operational));
        // NMT stop (or pre-operational, or a reset) withdraws it at once ...
        assert!(!r.update(false, NodeState::Operational));
        // ... and a new start needs the supervisor's Operational again; it also clears a fault.
        assert!(!r.update(true, NodeState::Safe));
        assert!(!r.update(true, NodeState::Fault));
        assert!(!r.update(false, NodeState::Fault));
        assert!(r.update(true, NodeState::Operational));
    }

    #[test]
    fn freshness_counts_samples_against_the_stale_timeout() {
        let mut f = Freshness::new();
        assert!(!f.is_fresh(1_000, 2_500), "never heard");
        f.tick(true);
        assert!(f.is_fresh(1_000, 2_500));
        f.tick(false);
        f.tick(false);
        assert!(f.is_fresh(1_000, 2_500), "2 ms old");
        f.tick(false);
        assert!(!f.is_fresh(1_000, 2_500), "3 ms old");
        f.tick(true);
        assert!(f.is_fresh(1_000, 2_500));
    }
}
