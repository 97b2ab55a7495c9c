//! The node as a CiA 301 device on mocked hardware: boot-up, outputs only while NMT
//! operational, SDO writes in pre-operational that the next start applies to the controller,
//! a refused write, EMCY on a safe-state entry.

mod common;

use agent_node::canopen::{od::PARAM_BASE, Identity};
use agent_node::{CanFrame, NodeConfig, SupervisorConfig, TxOutcome};
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
