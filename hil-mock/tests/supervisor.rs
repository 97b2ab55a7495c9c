//! The node's supervisor on mocked hardware: safe-state entry and exit per source, each
//! policy, fault, heartbeat schedule and content, overruns, a moved identifier plan, and the
//! configuration errors.

mod common;

use agent_node::supervisor::{
    NeighbourLoss, NodeState, SafePolicy, SupervisorConfig, SupervisorError,
};
use agent_node::wire::{self, Decoded, IdPlan, Source};
use agent_node::{NodeConfig, NodeError};
use common::controller_config;
use hil_mock::mock::{MockActuator, MockCan, MockClock, MockFrame, MockNode, MockSensor};

const MS: u64 = 1_000;

/// Agent `agent` of Example 1 (`index` its 0-based controller) with `cfg`'s node settings.
fn node(cfg: NodeConfig<4>, index: usize) -> MockNode<2, 2, 4> {
    MockNode::new(
        &cfg,
        &controller_config(index),
        MockCan::new(1024),
        MockClock::default(),
        MockSensor::default(),
        MockActuator::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Agent 1 (pinned) watching the leader with `timeout_ms`, policy `policy`.
fn watching_leader(policy: SafePolicy, timeout_ms: u64, dwell_ms: u64) -> MockNode<2, 2, 4> {
    let mut cfg = NodeConfig::new(1, [0; 4], 2_500);
    cfg.supervisor = SupervisorConfig {
        policy,
        leader_timeout_us: Some(timeout_ms * MS),
        recover_dwell_us: dwell_ms * MS,
        ..SupervisorConfig::OFF
    };
    node(cfg, 0)
}

fn value(plan: &IdPlan, source: Source, y: f32, seq: u8) -> MockFrame {
    wire::encode_in::<MockFrame>(plan, source, y, seq)
        .expect("in plan")
        .0
}

/// Tick at `ms` with state `x`, the leader's value delivered just before when `leader`.
fn tick_at(n: &mut MockNode<2, 2, 4>, ms: u64, leader: bool) -> agent_node::Tick<2, 2> {
    n.clock_mut().set(ms * MS);
    if leader {
        let seq = (ms % 64) as u8;
        n.can_mut()
            .push_rx(value(&IdPlan::DEFAULT, Source::Leader, 0.1, seq));
    }
    n.sensor_mut().x = [0.05, 0.2];
    let t = n.tick();
    while n.can_mut().take_tx().is_some() {}
    t
}

#[test]
fn leader_loss_enters_safe_after_the_timeout_and_holds_the_last_command() {
    let mut n = watching_leader(SafePolicy::Hold, 10, 5);
    let mut last_q = [0.0; 2];
    for ms in 0..20 {
        let t = tick_at(&mut n, ms, true);
        assert_eq!(t.state, NodeState::Operational, "{ms} ms");
        last_q = t.output.q;
    }
    // Last leader value at 19 ms: lost when older than 10 ms, i.e. at 30 ms.
    for ms in 20..=29 {
        assert_eq!(
            tick_at(&mut n, ms, false).state,
            NodeState::Operational,
            "{ms} ms"
        );
        last_q = n.actuator().q;
    }
    for ms in 30..40 {
        let t = tick_at(&mut n, ms, false);
        assert_eq!(t.state, NodeState::Safe, "{ms} ms");
        assert_eq!(t.output.q, last_q);
        assert_eq!(n.actuator().q, last_q);
    }
    assert!(n.supervisor().lost().leader());
    assert_eq!(n.stats().safe_state_entries, 1);
    let frozen = n.controller().time();
    // Back at 40 ms: operational after the 5 ms dwell, the controller resumed from t = 0.
    for ms in 40..45 {
        assert_eq!(tick_at(&mut n, ms, true).state, NodeState::Safe, "{ms} ms");
    }
    assert_eq!(n.controller().time(), frozen, "not advanced while safe");
    let t = tick_at(&mut n, 45, true);
    assert_eq!(t.state, NodeState::Operational);
    assert!(n.controller().time() < 0.0015, "{}", n.controller().time());
    assert_eq!(n.stats().safe_state_entries, 1);
}

#[test]
fn ramp_policy_moves_every_command_to_zero_at_its_rate() {
    let mut n = watching_leader(SafePolicy::Ramp { rate: 500.0 }, 2, 0);
    tick_at(&mut n, 0, true);
    tick_at(&mut n, 1, false);
    tick_at(&mut n, 2, false);
    let before = n.actuator().q;
    let t = tick_at(&mut n, 3, false);
    assert_eq!(t.state, NodeState::Safe);
    assert!(before.iter().all(|q| q.abs() > 1.0), "{before:?}");
    // 500 per s over 1 ms.
    for (q, b) in t.output.q.iter().zip(before) {
        assert!((q.abs() - (b.abs() - 0.5)).abs() < 1e-4, "{q} from {b}");
    }
    for ms in 4..200 {
        tick_at(&mut n, ms, false);
    }
    assert_eq!(n.actuator().q, [0.0, 0.0]);
}

#[test]
fn off_policy_writes_zero_and_fault_is_latched_with_zero() {
    let mut n = watching_leader(SafePolicy::Off, 2, 0);
    tick_at(&mut n, 0, true);
    assert_ne!(n.actuator().q, [0.0, 0.0]);
    for ms in 1..5 {
        tick_at(&mut n, ms, false);
    }
    assert_eq!(n.state(), NodeState::Safe);
    assert_eq!(n.actuator().q, [0.0, 0.0]);

    let mut n = watching_leader(SafePolicy::Hold, 2, 0);
    tick_at(&mut n, 0, true);
    n.enter_fault();
    for ms in 1..10 {
        let t = tick_at(&mut n, ms, true);
        assert_eq!(t.state, NodeState::Fault);
        assert_eq!(t.output.q, [0.0, 0.0]);
    }
    assert_eq!(n.stats().safe_state_entries, 0);
}

#[test]
fn sensor_loss_and_neighbour_loss_enter_safe() {
    let mut cfg = NodeConfig::new(1, [0; 4], 2_500);
    cfg.supervisor = SupervisorConfig {
        sensor_timeout_us: Some(3 * MS),
        ..SupervisorConfig::OFF
    };
    let mut n = node(cfg, 0);
    tick_at(&mut n, 0, true);
    n.sensor_mut().fail = true;
    let mut states = Vec::new();
    for ms in 1..=5 {
        n.clock_mut().set(ms * MS);
        states.push(n.tick().state);
    }
    // Invalid from 1 ms: lost once invalid for more than 3 ms, at 5 ms.
    assert_eq!(states[..4], [NodeState::Operational; 4]);
    assert_eq!(states[4], NodeState::Safe);
    assert!(n.supervisor().lost().sensor());

    // Agent 4 hears 1 and 3: with `all`, 1 silent and 3 talking is no loss.
    let mut cfg = NodeConfig::new(4, [1, 3, 0, 0], 2_500);
    cfg.supervisor = SupervisorConfig {
        neighbour_timeout_us: Some(5 * MS),
        neighbour_loss: NeighbourLoss::All,
        ..SupervisorConfig::OFF
    };
    let mut n = node(cfg, 3);
    for ms in 0..20u64 {
        n.clock_mut().set(ms * MS);
        n.can_mut().push_rx(value(
            &IdPlan::DEFAULT,
            Source::Agent(3),
            0.1,
            (ms % 64) as u8,
        ));
        assert_eq!(n.tick().state, NodeState::Operational, "{ms} ms");
    }
    for ms in 20..30u64 {
        n.clock_mut().set(ms * MS);
        n.tick();
    }
    assert_eq!(n.state(), NodeState::Safe);
    assert!(n.supervisor().lost().neighbours());
}

#[test]
fn heartbeat_goes_every_period_after_the_value_frame_with_state_and_counters() {
    let mut cfg = NodeConfig::new(2, [1, 0, 0, 0], 2_500);
    cfg.heartbeat_period_us = 5 * MS;
    let mut n = node(cfg, 1);
    n.set_boot_count(7);
    let mut beats = Vec::new();
    for ms in 0..21u64 {
        // 12 ms late: 2 samples skipped.
        let t = if ms >= 12 { ms + 2 } else { ms };
        n.clock_mut().set(t * MS);
        n.tick();
        let first = n.can_mut().take_tx().expect("value frame");
        assert!(matches!(wire::decode(&first), Ok(m) if m.source == Source::Agent(2)));
        if let Some(f) = n.can_mut().take_tx() {
            match wire::decode_in(&IdPlan::DEFAULT, &f) {
                Ok(Decoded::Heartbeat { agent, heartbeat }) => {
                    assert_eq!(agent, 2);
                    beats.push((t, heartbeat));
                }
                other => panic!("{other:?}"),
            }
        }
        assert!(n.can_mut().take_tx().is_none());
    }
    // Agent 2: one sample after the first tick, then every 5 ms.
    let times: Vec<u64> = beats.iter().map(|b| b.0).collect();
    assert_eq!(times, [1, 6, 11, 16, 21]);
    let last = beats.last().expect("beats").1;
    assert_eq!(last.state, NodeState::Operational);
    assert_eq!(
        (last.boot_count, last.overruns, last.safe_entries),
        (7, 2, 0)
    );
    assert_eq!(n.stats().heartbeats_tx, 5);
    assert_eq!(n.stats().overruns, 2);
    n.record_overrun();
    assert_eq!(n.stats().overruns, 3);
}

#[test]
fn a_moved_plan_moves_only_the_identifiers() {
    let moved = IdPlan::new(0x020, Some(0x680), 4).expect("valid");
    let mut cfg = NodeConfig::new(1, [0; 4], 2_500);
    cfg.ids = moved;
    let mut a = node(cfg, 0);
    let mut b = node(NodeConfig::new(1, [0; 4], 2_500), 0);
    for ms in 0..50u64 {
        let seq = (ms % 64) as u8;
        for (n, plan) in [(&mut a, moved), (&mut b, IdPlan::DEFAULT)] {
            n.clock_mut().set(ms * MS);
            n.can_mut().push_rx(value(&plan, Source::Leader, 0.3, seq));
            n.sensor_mut().x = [0.01 * ms as f32, 0.0];
            n.tick();
        }
        let (fa, fb) = (
            a.can_mut().take_tx().expect("a"),
            b.can_mut().take_tx().expect("b"),
        );
        assert_eq!((fa.raw_id(), fb.raw_id()), (0x021, 0x102));
        assert_eq!(
            embedded_can::Frame::data(&fa),
            embedded_can::Frame::data(&fb)
        );
        assert_eq!(a.actuator().q, b.actuator().q);
    }
    // A frame of the default plan is unknown to the moved node.
    a.can_mut()
        .push_rx(value(&IdPlan::DEFAULT, Source::Leader, 0.3, 0));
    a.poll_rx();
    assert_eq!(a.stats().malformed.unknown_id, 1);
}

#[test]
fn node_configuration_errors_are_named() {
    let try_node = |cfg: NodeConfig<4>| {
        MockNode::<2, 2, 4>::new(
            &cfg,
            &controller_config(3),
            MockCan::new(8),
            MockClock::default(),
            MockSensor::default(),
            MockActuator::default(),
        )
        .err()
    };
    let small = IdPlan::new(0x101, None, 3).expect("valid");
    let mut cfg = NodeConfig::new(4, [1, 3, 0, 0], 2_500);
    cfg.ids = small;
    assert_eq!(try_node(cfg), Some(NodeError::AgentOutsidePlan(4)));
    let mut cfg = NodeConfig::new(2, [1, 4, 0, 0], 2_500);
    cfg.ids = small;
    assert_eq!(try_node(cfg), Some(NodeError::BadNeighbour(4)));
    let mut cfg = NodeConfig::new(4, [1, 3, 0, 0], 2_500);
    cfg.ids = IdPlan::new(0x101, None, 4).expect("valid");
    cfg.heartbeat_period_us = 1;
    assert_eq!(try_node(cfg), Some(NodeError::NoHeartbeatIds));
    let mut cfg = NodeConfig::new(4, [1, 3, 0, 0], 2_500);
    cfg.supervisor.policy = SafePolicy::Ramp { rate: -1.0 };
    assert_eq!(
        try_node(cfg),
        Some(NodeError::Supervisor(SupervisorError::RampRate))
    );
    let mut cfg = NodeConfig::new(4, [1, 3, 0, 0], 2_500);
    cfg.supervisor.sensor_timeout_us = Some(0);
    assert_eq!(
        try_node(cfg).map(|e| e.to_string()),
        Some("sensor timeout must be > 0".to_string())
    );
}

/// Tick at `ms` with state `x`, the leader's value `leader` delivered just before (if any).
fn tick_with(
    n: &mut MockNode<2, 2, 4>,
    ms: u64,
    x: [f32; 2],
    leader: Option<f32>,
) -> agent_node::Tick<2, 2> {
    n.clock_mut().set(ms * MS);
    if let Some(y) = leader {
        n.can_mut()
            .push_rx(value(&IdPlan::DEFAULT, Source::Leader, y, (ms % 64) as u8));
    }
    n.sensor_mut().x = x;
    let t = n.tick();
    while n.can_mut().take_tx().is_some() {}
    t
}

#[test]
fn hold_position_keeps_the_loop_closed_on_the_frozen_leader_value_until_the_dwell_ends() {
    let mut n = watching_leader(SafePolicy::HoldPosition, 10, 5);
    // The same node unsupervised: what the law does with a silent leader on its own.
    let mut free = node(NodeConfig::new(1, [0; 4], 2_500), 0);
    let x = [0.05, 0.2];
    for ms in 0..40 {
        let leader = (ms < 20).then_some(0.1);
        let t = tick_with(&mut n, ms, x, leader);
        let f = tick_with(&mut free, ms, x, leader);
        let want = if ms < 30 {
            NodeState::Operational
        } else {
            NodeState::Safe
        };
        assert_eq!(t.state, want, "{ms} ms");
        // Closed loop: the same commands as the unsupervised law, which holds y_d too.
        assert_eq!(t.output.q, f.output.q, "{ms} ms");
        assert_eq!(t.output.estimates, f.output.estimates, "{ms} ms");
    }
    assert!(
        (n.controller().time() - 0.040).abs() < 1e-6,
        "kept stepping"
    );
    // The leader returns at 0.3: frozen at 0.1 during the 5 ms dwell, then re-entering at the
    // default re-entry rate of 1 per s (1e-3 per sample).
    for ms in 40..50 {
        let t = tick_with(&mut n, ms, x, Some(0.3));
        let y_d = if ms < 45 {
            0.1
        } else {
            0.1 + 1e-3 * (ms - 44) as f32
        };
        assert_eq!(t.state == NodeState::Safe, ms < 45, "{ms} ms");
        assert!(
            (t.output.e[0] - (x[0] - y_d)).abs() < 1e-4,
            "{ms} ms: {:?}",
            t.output.e
        );
    }
    // Never resumed: the controller's time went on through the safe state.
    assert!((n.controller().time() - 0.050).abs() < 1e-6);
    assert_eq!(n.stats().safe_state_entries, 1);
}

#[test]
fn stop_brings_the_agent_s_own_reference_to_rest_at_its_deceleration() {
    let mut n = watching_leader(SafePolicy::Stop { decel: 2.0 }, 10, 0);
    // The agent moves at 1 unit/s; the leader goes silent after 19 ms: safe at 30 ms.
    let y = |ms: u64| 0.001 * ms as f32;
    for ms in 0..30 {
        let leader = (ms < 20).then_some(y(ms));
        assert_eq!(
            tick_with(&mut n, ms, [y(ms), 1.0], leader).state,
            NodeState::Operational
        );
    }
    // Reference y(30) + τ − τ²: the pinned agent's e₁ = y − ref = τ² while it keeps moving.
    for ms in 30..600 {
        let t = tick_with(&mut n, ms, [y(ms), 1.0], None);
        assert_eq!(t.state, NodeState::Safe);
        let tau = (ms - 30) as f32 * 1e-3;
        let rest = tau.min(0.5);
        let reference = y(30) + rest - rest * rest;
        assert!(
            (t.output.e[0] - (y(ms) - reference)).abs() < 2e-4,
            "{ms} ms: e₁ {} want {}",
            t.output.e[0],
            y(ms) - reference
        );
    }
    assert!(
        n.controller().time() > 0.59,
        "closed loop: the controller steps"
    );
}

#[test]
fn a_lost_sensor_gets_the_open_loop_sensor_policy_and_the_controller_resumes_after() {
    let mut cfg = NodeConfig::new(1, [0; 4], 2_500);
    cfg.supervisor = SupervisorConfig {
        sensor_timeout_us: Some(3 * MS),
        sensor_policy: SafePolicy::Off,
        ..SupervisorConfig::OFF
    };
    assert_eq!(
        cfg.supervisor.policy,
        SafePolicy::HoldPosition,
        "the default"
    );
    let mut n = node(cfg, 0);
    for ms in 0..10 {
        tick_with(&mut n, ms, [0.05, 0.2], Some(0.1));
    }
    assert_ne!(n.actuator().q, [0.0, 0.0]);
    n.sensor_mut().fail = true;
    for ms in 10..20 {
        let t = tick_with(&mut n, ms, [0.05, 0.2], Some(0.1));
        assert_eq!(t.state == NodeState::Safe, ms >= 14, "{ms} ms");
        if ms >= 14 {
            assert_eq!(n.actuator().q, [0.0, 0.0], "{ms} ms");
        }
    }
    n.sensor_mut().fail = false;
    let t = tick_with(&mut n, 20, [0.05, 0.2], Some(0.1));
    assert_eq!(t.state, NodeState::Operational);
    assert!(n.controller().time() < 0.0015, "resumed after an open loop");

    // A closed-loop sensor policy is refused.
    let mut cfg = NodeConfig::new(1, [0; 4], 2_500);
    cfg.supervisor.sensor_policy = SafePolicy::HoldPosition;
    assert!(matches!(
        MockNode::<2, 2, 4>::new(
            &cfg,
            &controller_config(0),
            MockCan::new(8),
            MockClock::default(),
            MockSensor::default(),
            MockActuator::default(),
        ),
        Err(NodeError::Supervisor(
            SupervisorError::SensorPolicyClosedLoop
        ))
    ));
}
