//! The board's decisions around each `Node::tick`, composed as the firmware's control task
//! runs them: bus-off recovery before the tick; after it, the run command, the leader's
//! freshness and the output gate; at the end, whether the step ended in time and so may feed
//! the watchdog ([`BoardLogic::step_ended`]). The firmware (`src/main.rs`) only moves register values in
//! and out of [`BoardLogic`], so the host tests below drive it with a real `agent_node::Node`.

use agent_node::{NodeState, SafePolicy};

use crate::{
    bus_off::{Action, BusOffRecovery},
    gate::{Freshness, GateInputs, GateOutput, OutputGate, RunCommand},
};

/// What the board decides beside the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardLogic {
    gate: OutputGate,
    run: RunCommand,
    leader: Freshness,
    uses_leader: bool,
    bus_off: BusOffRecovery,
    period_us: u32,
    stale_timeout_us: u64,
    late_steps: u32,
}

impl BoardLogic {
    /// After reset: driver disabled, not commanded, leader never heard, on the bus.
    /// `uses_leader`: the node takes the leader's frames (`can_setup::uses_leader`).
    pub const fn new(uses_leader: bool, period_us: u32, stale_timeout_us: u64) -> Self {
        Self {
            gate: OutputGate::new(),
            run: RunCommand::new(),
            leader: Freshness::new(),
            uses_leader,
            bus_off: BusOffRecovery::new(),
            period_us,
            stale_timeout_us,
            late_steps: 0,
        }
    }

    /// Before the tick: this sample's `FDCAN_PSR.BO`; whether to restart the FDCAN.
    pub fn before_tick(&mut self, bus_off: bool) -> Action {
        self.bus_off.update(bus_off)
    }

    /// After the tick: whether the CANopen device is NMT operational (the run command), the
    /// node's state, its safe-state policy, whether a valid leader value arrived during the
    /// sample and whether the sensor value is fresh; the outputs to apply.
    pub fn after_tick(
        &mut self,
        nmt_operational: bool,
        state: NodeState,
        policy: SafePolicy,
        leader_heard: bool,
        sensor_fresh: bool,
    ) -> GateOutput {
        self.leader.tick(leader_heard);
        let inputs = GateInputs {
            run_commanded: self.run.update(nmt_operational, state),
            state,
            policy,
            sensor_fresh,
            leader_fresh: !self.uses_leader
                || self.leader.is_fresh(self.period_us, self.stale_timeout_us),
            bus_off: self.bus_off.is_off(),
        };
        self.gate.update(&inputs)
    }

    /// The step ended; `late`: the next release had already come (TIM6's update flag set
    /// again before the step's end). Whether to feed the watchdog: only after a step that
    /// ended in time, so that steps late for as many consecutive periods as the IWDG's timeout
    /// spans (five) reset the board, while a single late step does not.
    pub fn step_ended(&mut self, late: bool) -> bool {
        if late {
            self.late_steps = self.late_steps.saturating_add(1);
        }
        !late
    }

    /// Steps that ended after the next release since reset.
    pub const fn late_steps(&self) -> u32 {
        self.late_steps
    }

    /// The output gate (state, counters).
    pub const fn gate(&self) -> &OutputGate {
        &self.gate
    }

    /// The bus-off recovery (counters).
    pub const fn bus_off(&self) -> &BusOffRecovery {
        &self.bus_off
    }
}

#[cfg(test)]
mod tests {
    //! The board's logic around a real `agent_node::Node` (the shipped configuration: agent 4
    //! of Example 1, neighbours 1 and 3, leader supervised) on the bench's sensor and actuator,
    //! over a CAN controller of the test's own.

    use std::{cell::Cell, collections::VecDeque, rc::Rc};

    use agent_node::{
        wire::{self, Source},
        CanFrame, Clock, Node, NodeState, SafePolicy,
    };

    use super::*;
    use crate::{
        bench::{BusActuator, BusSensor},
        can_setup::uses_leader,
        config::{self, NODE, SAMPLE_PERIOD_US},
        gate::GateState,
    };

    /// Frames waiting for the node, and those it sent.
    #[derive(Default)]
    struct TestCan {
        rx: VecDeque<CanFrame>,
        tx: usize,
    }

    impl embedded_can::nb::Can for TestCan {
        type Frame = CanFrame;
        type Error = embedded_can::ErrorKind;

        fn transmit(&mut self, _: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
            self.tx += 1;
            Ok(None)
        }

        fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
            self.rx.pop_front().ok_or(nb::Error::WouldBlock)
        }
    }

    /// Time set by the test.
    struct TestClock(Rc<Cell<u64>>);

    impl Clock for TestClock {
        fn now_us(&mut self) -> u64 {
            self.0.get()
        }
    }

    type TestNode = Node<TestCan, TestClock, BusSensor, BusActuator, 2, 2, { config::K }>;

    /// The shipped node with `policy`, and the board logic the firmware builds for it.
    fn board(policy: SafePolicy) -> (TestNode, BoardLogic, Rc<Cell<u64>>) {
        let mut cfg = NODE;
        cfg.supervisor.policy = policy;
        build(&cfg, &config::controller())
    }

    /// A node of `cfg` and `controller` on the test's bus and clock, and its board logic.
    fn build(
        cfg: &agent_node::NodeConfig<{ config::K }>,
        controller: &controller_core::ControllerConfig<2>,
    ) -> (TestNode, BoardLogic, Rc<Cell<u64>>) {
        let now = Rc::new(Cell::new(0));
        let node = Node::new(
            cfg,
            controller,
            TestCan::default(),
            TestClock(now.clone()),
            BusSensor::new(SAMPLE_PERIOD_US, cfg.stale_timeout_us),
            BusActuator::default(),
        )
        .unwrap_or_else(|e| panic!("agent {}: {e:?}", cfg.agent));
        let logic = BoardLogic::new(
            uses_leader(cfg, controller.pinned),
            SAMPLE_PERIOD_US,
            cfg.stale_timeout_us,
        );
        (node, logic, now)
    }

    /// What reaches the bus in one sample.
    #[derive(Clone, Copy)]
    struct Sample {
        leader: bool,
        neighbours: bool,
        sensor: bool,
        bus_off: bool,
    }

    const ALL: Sample = Sample {
        leader: true,
        neighbours: true,
        sensor: true,
        bus_off: false,
    };

    /// One control-task release as `src/main.rs` runs it; the outputs and the node's state.
    fn release(
        node: &mut TestNode,
        logic: &mut BoardLogic,
        now: &Cell<u64>,
        k: u64,
        s: Sample,
        policy: SafePolicy,
    ) -> (GateOutput, NodeState) {
        now.set(k * u64::from(SAMPLE_PERIOD_US));
        let seq = (k % u64::from(wire::SEQ_MODULUS)) as u8;
        let mut leader_heard = false;
        let y = 0.01 * k as f32;
        if !s.bus_off {
            let ids = NODE.ids;
            if s.leader {
                let (f, _) = wire::encode_in(&ids, Source::Leader, y, seq).expect("frame");
                node.can_mut().rx.push_back(f);
                leader_heard = true;
            }
            if s.neighbours {
                for a in [1, 3] {
                    let (f, _) = wire::encode_in(&ids, Source::Agent(a), y, seq).expect("frame");
                    node.can_mut().rx.push_back(f);
                }
            }
        }
        let _ = logic.before_tick(s.bus_off);
        node.sensor_mut()
            .offer((s.sensor && !s.bus_off).then_some([y, 0.0]));
        let tick = node.tick();
        let fresh = node.sensor_mut().is_fresh();
        let operational = node.canopen().is_none_or(|d| d.outputs_enabled());
        let out = logic.after_tick(operational, tick.state, policy, leader_heard, fresh);
        (out, tick.state)
    }

    #[test]
    fn the_driver_is_enabled_the_sample_after_the_node_becomes_operational() {
        let policy = SafePolicy::Ramp { rate: 40.0 };
        let (mut node, mut logic, now) = board(policy);
        // 20 ms of nothing but the sensor: Boot, driver off.
        let quiet = Sample {
            leader: false,
            neighbours: false,
            ..ALL
        };
        for k in 0..20 {
            let (out, state) = release(&mut node, &mut logic, &now, k, quiet, policy);
            assert!(!out.enable && !out.drive, "k = {k}: {state:?}");
        }
        // Every source: Operational at once, enabled one arming sample later.
        let mut first_enabled = None;
        let mut first_operational = None;
        for k in 20..40 {
            let (out, state) = release(&mut node, &mut logic, &now, k, ALL, policy);
            if state == NodeState::Operational {
                first_operational.get_or_insert(k);
            }
            if out.enable {
                first_enabled.get_or_insert(k);
            } else {
                assert!(!out.drive);
            }
        }
        let (op, en) = (
            first_operational.expect("operational"),
            first_enabled.expect("enabled"),
        );
        println!("operational at sample {op}, driver enabled at sample {en}");
        assert_eq!(en, op + 1, "one neutral arming sample");
        // The leader falls silent: after 50 ms the node is Safe (ramp) and stays enabled.
        let silent = Sample {
            leader: false,
            ..ALL
        };
        let mut safe_at = None;
        for k in 40..120 {
            let (out, state) = release(&mut node, &mut logic, &now, k, silent, policy);
            if state == NodeState::Safe {
                safe_at.get_or_insert(k);
            }
            assert!(out.enable, "k = {k}: ramp drives through its safe state");
        }
        assert!(
            safe_at.is_some_and(|k| (85..=95).contains(&k)),
            "{safe_at:?}"
        );
        // Bus-off: disabled in that very sample and until the bus is back and re-armed.
        let off = Sample {
            bus_off: true,
            ..ALL
        };
        let (out, _) = release(&mut node, &mut logic, &now, 120, off, policy);
        assert!(!out.enable);
        assert_eq!(logic.bus_off().bus_offs(), 1);
        for k in 121..130 {
            assert!(
                !release(&mut node, &mut logic, &now, k, off, policy)
                    .0
                    .enable
            );
        }
        assert_eq!(logic.gate().state(), GateState::Disabled);
    }

    /// The firmware's node: a CiA 301 device, not self-starting (`src/main.rs`).
    fn canopen_board(agent: u8) -> (TestNode, BoardLogic, Rc<Cell<u64>>) {
        let cfg = config::node(agent).expect("in the plan");
        let controller = config::controller_of(agent).expect("in the plan");
        let (mut node, logic, now) = build(&cfg, &controller);
        node.enable_canopen(
            &cfg,
            &controller,
            agent_node::canopen::Identity::default(),
            false,
            config::CANOPEN_HEARTBEAT_MS,
        )
        .unwrap_or_else(|e| panic!("agent {agent}: {e:?}"));
        (node, logic, now)
    }

    fn nmt(node: &mut TestNode, command: agent_node::canopen::NmtCommand) {
        use embedded_can::{Frame, StandardId};
        let id = StandardId::new(agent_node::canopen::NMT_ID).expect("11 bits");
        let f = CanFrame::new(id, &[command.code(), 0]).expect("2 bytes");
        node.can_mut().rx.push_back(f);
    }

    #[test]
    fn every_agent_of_the_plan_builds_and_the_default_is_the_shipped_node() {
        for agent in 1..=config::PLAN.len() as u8 {
            let (node, _, _) = canopen_board(agent);
            assert_eq!(node.agent(), agent);
            assert_eq!(node.is_pinned(), agent == 1);
        }
        assert_eq!(config::node(config::DEFAULT_AGENT), Some(NODE));
        assert_eq!(
            config::controller_of(config::DEFAULT_AGENT),
            Some(config::controller())
        );
        assert!(config::node(0).is_none() && config::node(5).is_none());
    }

    #[test]
    fn nmt_start_is_the_run_command_and_nmt_stop_drops_the_driver_at_once() {
        use agent_node::canopen::NmtCommand;
        let policy = NODE.supervisor.policy;
        let (mut node, mut logic, now) = canopen_board(config::DEFAULT_AGENT);
        // Every source present, but pre-operational: never enabled.
        for k in 0..50 {
            let (out, _) = release(&mut node, &mut logic, &now, k, ALL, policy);
            assert!(!out.enable && !out.drive, "k = {k}: pre-operational");
        }
        nmt(&mut node, NmtCommand::Start);
        let mut first_enabled = None;
        for k in 50..60 {
            let (out, _) = release(&mut node, &mut logic, &now, k, ALL, policy);
            if out.enable {
                first_enabled.get_or_insert(k);
            }
        }
        let en = first_enabled.expect("enabled after the NMT start");
        println!("NMT start at sample 50, driver enabled at sample {en}");
        assert!(en <= 52, "operational and one arming sample: {en}");
        nmt(&mut node, NmtCommand::Stop);
        let (out, _) = release(&mut node, &mut logic, &now, 60, ALL, policy);
        assert!(
            !out.enable && !out.drive,
            "NMT stop drops the driver in its sample"
        );
        assert_eq!(logic.gate().state(), GateState::Disabled);
        nmt(&mut node, NmtCommand::EnterPreOperational);
        for k in 61..70 {
            assert!(
                !release(&mut node, &mut logic, &now, k, ALL, policy)
                    .0
                    .enable
            );
        }
    }

    /// The flash page the firmware writes for the node's `0x1010` store (the dictionary's
    /// length printed).
    fn stored_page(node: &TestNode) -> Vec<u8> {
        use crate::param_page;
        let mut saved = [0u8; param_page::STORE_CAPACITY];
        let n = node
            .canopen()
            .and_then(|d| d.save(&mut saved))
            .expect("fits the firmware's buffer");
        println!("stored object dictionary: {n} bytes");
        let mut page = vec![0xFF; param_page::PAGE_BYTES];
        for (k, w) in param_page::double_words(&saved[..n])
            .expect("fits")
            .enumerate()
        {
            page[8 * k..8 * k + 8].copy_from_slice(&w);
        }
        page
    }

    /// Commissioning as the README's bench section does it, on the host: a board with nothing
    /// stored boots as the default agent, takes its node-ID and a gain over SDO, stores, and
    /// after the reset boots as that agent with the gain.
    #[test]
    fn a_stored_node_id_and_gain_survive_the_reset_and_make_the_image_that_agent() {
        use crate::param_page::{self, Rejection};
        let erased = vec![0xFF; param_page::PAGE_BYTES];
        let boot = param_page::boot_config(&erased, config::in_plan, config::DEFAULT_AGENT);
        assert_eq!(boot.agent, config::DEFAULT_AGENT);
        assert_eq!(boot.rejected, Some(Rejection::Erased));
        let (mut node, _, _) = canopen_board(boot.agent);
        node.service(); // boot-up: pre-operational
        let p = agent_node::canopen::od::PARAM_BASE
            + controller_core::Param::ALL
                .iter()
                .position(|p| *p == controller_core::Param::Ts)
                .expect("ts") as u16;
        let d = node.canopen_mut().expect("device");
        d.write(param_page::node_id_index(), 0, &[2])
            .expect("node-ID");
        d.write(p, 0, &3.0f32.to_le_bytes()).expect("ts");
        let page = stored_page(&node);
        let boot = param_page::boot_config(&page, config::in_plan, config::DEFAULT_AGENT);
        assert_eq!((boot.agent, boot.rejected), (2, None));
        let (mut node, _, _) = canopen_board(boot.agent);
        let d = node.canopen_mut().expect("device");
        d.load(boot.stored.expect("stored"))
            .expect("the device takes it");
        assert_eq!(d.read(p, 0).expect("ts").as_slice(), 3.0f32.to_le_bytes());
        node.service();
        assert_eq!(node.canopen().map(|d| d.node_id()), Some(2));
        assert_eq!(node.agent(), 2);
        assert_eq!(node.neighbour_agent(0), Some(1));
    }

    /// One image joins any graph: a board with nothing stored (agent 4 of the compiled plan)
    /// takes node-ID 7, a plan of 8 agents and the row "agents 5 and 6" over SDO, stores;
    /// after the reset it boots as agent 7 hearing 5 and 6, its acceptance filters those
    /// agents' frames, and what the filters were set for is what the node runs; only a new
    /// adoption (which restarts the board) counts, not a reset with nothing new.
    #[test]
    fn a_stored_row_and_plan_make_the_filters_and_the_node_after_the_reset() {
        use crate::can_setup::{acceptance, Accept};
        use crate::param_page::{self, row_index};
        use agent_node::canopen::od::{Setting, SETTING_BASE};
        let (mut node, _, _) = canopen_board(config::DEFAULT_AGENT);
        node.service();
        let agents = SETTING_BASE
            + Setting::ALL
                .iter()
                .position(|s| *s == Setting::Agents)
                .expect("agents") as u16;
        let d = node.canopen_mut().expect("device");
        d.write(agents, 0, &[8]).expect("plan");
        d.write(row_index(), 1, &[5]).expect("entry 1");
        d.write(row_index(), 2, &[6]).expect("entry 2");
        d.write(param_page::node_id_index(), 0, &[7])
            .expect("node-ID");
        let page = stored_page(&node);
        // Agent 7 is outside the compiled plan, but the page holds its row.
        let boot = param_page::boot_config(&page, config::in_plan, config::DEFAULT_AGENT);
        assert_eq!((boot.agent, boot.rejected), (7, None));
        // The firmware's boot: the node and its device on the compiled defaults of the agent
        // (agent 4's for one outside the plan), the page loaded, then the filters from what
        // the device loaded.
        let (mut node, _, _) = canopen_board(config::DEFAULT_AGENT);
        node.canopen_mut()
            .expect("device")
            .load(boot.stored.expect("stored"))
            .expect("the device takes it");
        let (mut cfg, mut controller) = (NODE, config::controller());
        assert!(node
            .canopen()
            .is_some_and(|d| cfg.graph_from(&d.store, &mut controller)));
        assert_eq!((cfg.agent, cfg.ids.agents()), (7, 8));
        assert_eq!(&cfg.neighbours[..controller.neighbour_count], &[5, 6]);
        assert!(!controller.pinned);
        let f = acceptance(&cfg, controller.neighbour_count, controller.pinned, false);
        assert_eq!(
            f,
            [
                Some(Accept::Dual(0x000, 0x607)),
                Some(Accept::Single(0x101)),
                Some(Accept::Dual(0x108, 0x787)),
                Some(Accept::Dual(0x106, 0x785)),
                Some(Accept::Dual(0x107, 0x786)),
                None,
                None,
                None,
            ]
        );
        // The node adopts them at its boot-up.
        node.service();
        // What the filters were set for is what the node runs.
        assert_eq!(node.agent(), 7);
        assert_eq!(node.ids(), &cfg.ids);
        assert!(!node.is_pinned());
        assert_eq!(
            (0..config::K)
                .map_while(|k| node.neighbour_agent(k))
                .collect::<Vec<_>>(),
            [5, 6]
        );
        let adopted = node.adoptions();
        assert_eq!(adopted, 1, "the stored set, adopted at the boot-up");
        // A reset communication with nothing new adopts nothing: no restart loop; a new row
        // adopted at the next one counts (the firmware restarts on it).
        nmt(
            &mut node,
            agent_node::canopen::NmtCommand::ResetCommunication,
        );
        node.service();
        assert_eq!(node.adoptions(), adopted);
        node.canopen_mut()
            .expect("device")
            .write(row_index(), 2, &[3])
            .expect("entry 2");
        nmt(
            &mut node,
            agent_node::canopen::NmtCommand::ResetCommunication,
        );
        node.service();
        assert_eq!(node.adoptions(), adopted + 1);
        assert_eq!(node.neighbour_agent(1), Some(3));
        assert_eq!(node.canopen().map(|d| d.node_id()), Some(7));
    }

    #[test]
    fn only_a_step_that_ended_in_time_feeds_the_watchdog() {
        let mut logic = BoardLogic::new(true, 1_000, 2_500);
        let feeds: Vec<bool> = [false, true, true, false, true]
            .into_iter()
            .map(|late| logic.step_ended(late))
            .collect();
        assert_eq!(feeds, [true, false, false, true, false]);
        assert_eq!(logic.late_steps(), 3);
    }

    #[test]
    fn the_open_loop_off_policy_disables_the_driver_in_the_safe_state() {
        let policy = SafePolicy::Off;
        let (mut node, mut logic, now) = board(policy);
        for k in 0..10 {
            release(&mut node, &mut logic, &now, k, ALL, policy);
        }
        assert!(logic.gate().state() == GateState::Enabled);
        let silent = Sample {
            neighbours: false,
            ..ALL
        };
        for k in 10..100 {
            let (out, state) = release(&mut node, &mut logic, &now, k, silent, policy);
            assert_eq!(out.enable, state == NodeState::Operational, "k = {k}");
        }
        assert_eq!(node.state(), NodeState::Safe);
        assert_eq!(logic.gate().disables(), 1);
    }

    /// Random bus traffic for 20 s of samples (seed printed; `BOARD_SEED` replays one): the
    /// driver is enabled only when the node is `Operational` or `Safe` with a driving policy,
    /// on the bus, with a fresh sensor, after an arming sample, and never before the node was
    /// first `Operational`.
    #[test]
    fn random_traffic_never_enables_the_driver_where_it_must_not() {
        let seed = std::env::var("BOARD_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0x5EED_0B0A_4D00_0001_u64);
        println!("BOARD_SEED={seed}");
        let mut x = seed | 1;
        let mut bit = |p_percent: u64| {
            // xorshift64*
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x.wrapping_mul(0x2545_F491_4F6C_DD1D) % 100 < p_percent
        };
        let mut enabled_samples = 0;
        for policy in [
            SafePolicy::HoldPosition,
            SafePolicy::Stop { decel: 2.0 },
            SafePolicy::Hold,
            SafePolicy::Ramp { rate: 40.0 },
            SafePolicy::Off,
        ] {
            let (mut node, mut logic, now) = board(policy);
            let mut was_operational = false;
            let mut last = GateState::Disabled;
            // Bursts: each source is present or absent for runs of samples.
            let mut s = ALL;
            for k in 0..20_000 {
                if k % 50 == 0 {
                    s = Sample {
                        leader: bit(70),
                        neighbours: bit(80),
                        sensor: bit(90),
                        bus_off: bit(5),
                    };
                }
                let (out, state) = release(&mut node, &mut logic, &now, k, s, policy);
                was_operational |= state == NodeState::Operational;
                if out.enable {
                    enabled_samples += 1;
                    assert!(was_operational, "k = {k}");
                    assert!(!s.bus_off && node.sensor_mut().is_fresh(), "k = {k}");
                    assert!(
                        state == NodeState::Operational
                            || (state == NodeState::Safe && policy != SafePolicy::Off),
                        "k = {k}: {state:?} {policy:?}"
                    );
                    assert_ne!(last, GateState::Disabled, "k = {k}: enabled without arming");
                }
                last = logic.gate().state();
            }
        }
        println!("samples with the driver enabled: {enabled_samples} of 60,000");
        assert!(
            enabled_samples > 1_000,
            "the traffic must enable the driver at times"
        );
    }
}
