//! The node as a CiA 301 device on mocked hardware: boot-up, outputs only while NMT
//! operational, SDO writes in pre-operational that the next start applies to the controller,
//! a refused write, EMCY on a safe-state entry, a lost consumed heartbeat as a lost source.

mod common;

use agent_node::canopen::{od::PARAM_BASE, Identity};
use agent_node::wire::encode_payload;
use agent_node::{CanFrame, NodeConfig, NodeState, SupervisorConfig, TxOutcome};
use common::controller_config;
use controller_core::Param;
use embedded_can::{Frame, StandardId};
use hil_mock::mock::{MockActuator, MockCan, MockClock, MockNode, MockSensor};

const MS: u64 = 1_000;
/// Agent 2 of Example 1, node-ID 2; its value frames at 0x101 + 2.
const VALUE_ID: u32 = 0x103;

fn node(sup: SupervisorConfig) -> MockNode<2, 2, 4> {
    let mut cfg = NodeConfig::new(2, [1, 0, 0, 0], 2_500);
    cfg.supervisor = sup;
    let ctrl = controller_config(1);
    let mut n = MockNode::new(
        &cfg,
        &ctrl,
        MockCan::new(1024),
        MockClock::default(),
        MockSensor::default(),
        MockActuator::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    n.enable_canopen(&cfg, &ctrl, Identity::default(), false, 0)
        .unwrap_or_else(|e| panic!("{e}"));
    n
}

fn send(n: &mut MockNode<2, 2, 4>, id: u16, data: &[u8]) {
    let f = CanFrame::new(StandardId::new(id).expect("11-bit"), data).expect("classic frame");
    assert!(n.can_mut().push_rx(f));
}

/// One tick at `us`; the frames it sent as (identifier, data).
fn tick_at(n: &mut MockNode<2, 2, 4>, us: u64) -> (TxOutcome, Vec<(u32, Vec<u8>)>) {
    n.clock_mut().set(us);
    n.sensor_mut().x = [0.05, 0.2];
    let t = n.tick();
    let frames = core::iter::from_fn(|| n.can_mut().take_tx())
        .map(|f| (f.raw_id(), f.data().to_vec()))
        .collect();
    (t.tx, frames)
}

fn zeta_index() -> u16 {
    PARAM_BASE
        + Param::ALL
            .iter()
            .position(|p| *p == Param::Zeta)
            .expect("listed") as u16
}

#[test]
fn outputs_only_while_operational_and_a_written_gain_applies_at_the_start() {
    let mut n = node(SupervisorConfig::OFF);
    let (tx, frames) = tick_at(&mut n, 0);
    assert_eq!(tx, TxOutcome::Disabled);
    assert_eq!(frames, vec![(0x702, vec![0x00])], "boot-up only");
    assert_eq!(n.actuator().q, [0.0, 0.0]);
    let c2_before = n.controller().params().gains().c2;

    // ζ = 1.5 refused (value range), ζ = 0.2 taken; both in pre-operational.
    let i = zeta_index().to_le_bytes();
    let mut req = [0x23, i[0], i[1], 0, 0, 0, 0, 0];
    req[4..].copy_from_slice(&1.5f32.to_le_bytes());
    send(&mut n, 0x602, &req);
    let (_, frames) = tick_at(&mut n, MS);
    assert_eq!(
        frames,
        vec![(0x582, vec![0x80, i[0], i[1], 0, 0x30, 0x00, 0x09, 0x06])]
    );
    req[4..].copy_from_slice(&0.2f32.to_le_bytes());
    send(&mut n, 0x602, &req);
    let (_, frames) = tick_at(&mut n, 2 * MS);
    assert_eq!(frames, vec![(0x582, vec![0x60, i[0], i[1], 0, 0, 0, 0, 0])]);
    assert_eq!(
        n.controller().params().gains().c2,
        c2_before,
        "not before the start"
    );

    // NMT start: the value frame goes out and the controller has ζ = 0.2 (c₂ = π/(ζ T_s)
    // halves).
    send(&mut n, 0x000, &[0x01, 2]);
    let (tx, frames) = tick_at(&mut n, 3 * MS);
    assert_eq!(tx, TxOutcome::Queued);
    assert!(frames.iter().any(|(id, _)| *id == VALUE_ID), "{frames:x?}");
    let c2 = n.controller().params().gains().c2;
    assert!(
        (c2 - c2_before / 2.0).abs() < 1e-4 * c2_before,
        "{c2} vs {c2_before}"
    );
    assert_ne!(n.actuator().q, [0.0, 0.0]);

    // Writes are refused while operational (0x0800_0022).
    send(&mut n, 0x602, &req);
    let (_, frames) = tick_at(&mut n, 4 * MS);
    let abort: Vec<_> = frames.iter().filter(|(id, _)| *id == 0x582).collect();
    assert_eq!(abort[0].1[4..8], 0x0800_0022u32.to_le_bytes());

    // NMT stop: outputs off, no value frame.
    send(&mut n, 0x000, &[0x02, 0]);
    let (tx, frames) = tick_at(&mut n, 5 * MS);
    assert_eq!(tx, TxOutcome::Disabled);
    assert!(frames.iter().all(|(id, _)| *id != VALUE_ID), "{frames:x?}");
    assert_eq!(n.actuator().q, [0.0, 0.0]);
}

#[test]
fn a_safe_state_entry_sends_an_emcy_and_its_end_an_error_reset() {
    let sup = SupervisorConfig {
        leader_timeout_us: Some(10 * MS),
        ..SupervisorConfig::OFF
    };
    let mut n = node(sup);
    tick_at(&mut n, 0);
    send(&mut n, 0x000, &[0x01, 0]);
    let mut emcy = Vec::new();
    for k in 1..40 {
        let (_, frames) = tick_at(&mut n, k * MS);
        emcy.extend(frames.into_iter().filter(|(id, _)| *id == 0x082));
    }
    // Leader silent for more than 10 ms: RPDO timeout 0x8250, register 0x11, cause 1 (safe
    // state), lost sources bit 0 (leader), one entry.
    assert_eq!(
        emcy,
        vec![(0x082, vec![0x50, 0x82, 0x11, 1, 0b001, 1, 0, 0])]
    );
    assert_eq!(n.canopen().map(|d| d.error_register()), Some(0x11));
}

/// A consumed heartbeat (`0x1016`) that is lost counts as its source lost for the supervisor,
/// whatever the source's value frames do: node 1 (the neighbour) stands for the neighbour,
/// node 100 (none of the neighbours) for the leader's producer. Back when it returns.
#[test]
fn a_lost_consumed_heartbeat_is_its_source_lost_for_the_supervisor() {
    let sup = SupervisorConfig {
        leader_timeout_us: Some(10 * MS),
        neighbour_timeout_us: Some(10 * MS),
        ..SupervisorConfig::OFF
    };
    let mut n = node(sup);
    tick_at(&mut n, 0);
    let d = n.canopen_mut().expect("device");
    d.set_consumer(1, 1, 20).expect("consumer of the neighbour");
    d.set_consumer(2, 100, 20)
        .expect("consumer of the leader's producer");
    send(&mut n, 0x000, &[0x01, 0]);
    // Values from both sources every ms throughout; heartbeats every 5 ms while `beats` says.
    let mut t = 0;
    let mut run = |n: &mut MockNode<2, 2, 4>, ms: u64, beats: [bool; 2]| {
        let mut emcy = Vec::new();
        for _ in 0..ms {
            t += 1;
            let seq = (t % 64) as u8;
            send(n, 0x101, &encode_payload(0.1, seq).data);
            send(n, 0x102, &encode_payload(0.1, seq).data);
            if t % 5 == 0 {
                for (node, on) in [(1u16, beats[0]), (100, beats[1])] {
                    if on {
                        send(n, 0x700 + node, &[0x05]);
                    }
                }
            }
            let (_, frames) = tick_at(n, t * MS);
            emcy.extend(
                frames
                    .into_iter()
                    .filter(|(id, _)| *id == 0x082)
                    .map(|(_, d)| d),
            );
        }
        (n.state(), emcy)
    };
    let (state, emcy) = run(&mut n, 30, [true, true]);
    assert_eq!((state, emcy), (NodeState::Operational, vec![]));

    // The leader's producer falls silent, its values go on: heartbeat lost (0x8130, node 100),
    // then the safe state with the leader lost (0x8250, lost bit 0).
    // Both EMCYs are raised in one tick; the mock's mailbox replaces a pending frame of the
    // same identifier, so the second goes out at the next tick.
    let (state, emcy) = run(&mut n, 40, [true, false]);
    assert_eq!(state, NodeState::Safe);
    assert_eq!(
        emcy,
        vec![
            vec![0x30, 0x81, 0x11, 9, 100, 0, 0, 0],
            vec![0x50, 0x82, 0x11, 1, 0b001, 1, 0, 0],
        ]
    );
    assert_eq!(history(&n), [0x8250, 0x8130]);
    assert!(n.supervisor().lost().leader() && !n.supervisor().lost().neighbours());

    // It comes back: operational again, the error reset once nothing is active.
    let (state, emcy) = run(&mut n, 10, [true, true]);
    assert_eq!((state, emcy), (NodeState::Operational, vec![vec![0; 8]]));

    // The neighbour's heartbeat stops, its values go on: the neighbours are lost (bit 1).
    let (state, emcy) = run(&mut n, 40, [false, true]);
    assert_eq!(state, NodeState::Safe);
    assert_eq!(
        emcy,
        vec![
            vec![0x30, 0x81, 0x11, 9, 1, 0, 0, 0],
            vec![0x50, 0x82, 0x11, 1, 0b010, 2, 0, 0],
        ]
    );
    assert_eq!(history(&n), [0x8250, 0x8130]);
    assert!(!n.supervisor().lost().leader() && n.supervisor().lost().neighbours());
}

/// The two newest entries of the pre-defined error field `0x1003`.
fn history(n: &MockNode<2, 2, 4>) -> [u32; 2] {
    let d = n.canopen().expect("device");
    [1, 2].map(|sub| {
        let v = d.read(0x1003, sub).expect("entry");
        u32::from_le_bytes(v.as_slice().try_into().expect("4 bytes"))
    })
}

/// A graph row written over SDO (agent 2: from hearing agent 1 to hearing agents 3 and 4)
/// waits for the reset communication — a start before it is refused with EMCY `0x6300` —
/// and the node then hears exactly the new neighbours: their value frames accepted, agent
/// 1's ignored.
#[test]
fn a_row_written_over_sdo_is_heard_after_the_reset_communication() {
    let mut n = node(SupervisorConfig::OFF);
    tick_at(&mut n, 0);
    let row = PARAM_BASE
        + Param::ALL
            .iter()
            .position(|p| *p == Param::Neighbours)
            .expect("listed") as u16;
    let i = row.to_le_bytes();
    // Entry 2 (beyond the count) = 4, entry 1 = 3, count = 2: each confirmed.
    for (k, (sub, v)) in [(2u8, 4u8), (1, 3), (0, 2)].into_iter().enumerate() {
        send(&mut n, 0x602, &[0x2F, i[0], i[1], sub, v, 0, 0, 0]);
        let (_, frames) = tick_at(&mut n, (1 + k as u64) * MS);
        assert_eq!(
            frames,
            vec![(0x582, vec![0x60, i[0], i[1], sub, 0, 0, 0, 0])]
        );
    }
    assert_eq!(n.neighbour_agent(0), Some(1), "not before the reset");
    // A start on a row not yet applied: EMCY 0x6300, back to pre-operational.
    send(&mut n, 0x000, &[0x01, 2]);
    let (tx, frames) = tick_at(&mut n, 4 * MS);
    assert_eq!(tx, TxOutcome::Disabled);
    assert!(
        frames
            .iter()
            .any(|(id, d)| *id == 0x082 && d[..2] == [0x00, 0x63]),
        "{frames:x?}"
    );
    // Reset communication: boot-up, the row applied.
    send(&mut n, 0x000, &[0x82, 2]);
    let (_, frames) = tick_at(&mut n, 5 * MS);
    assert!(frames.contains(&(0x702, vec![0x00])), "{frames:x?}");
    assert_eq!(
        (n.neighbour_agent(0), n.neighbour_agent(1)),
        (Some(3), Some(4))
    );
    send(&mut n, 0x000, &[0x01, 2]);
    tick_at(&mut n, 6 * MS);
    let before = *n.stats();
    for k in 0..20u64 {
        for agent in [1u16, 3, 4] {
            let seq = (k % 64) as u8;
            send(&mut n, 0x101 + agent, &encode_payload(0.1, seq).data);
        }
        let (tx, _) = tick_at(&mut n, (7 + k) * MS);
        assert_eq!(tx, TxOutcome::Queued);
    }
    let s = n.stats();
    assert_eq!(
        s.accepted - before.accepted,
        40,
        "agents 3 and 4, 20 samples"
    );
    assert_eq!(
        s.ignored - before.ignored,
        20,
        "agent 1, no longer a neighbour"
    );
}
