//! Deadline overruns of the node on mocked hardware: each release a board reports as late is
//! counted at once, the samples a late tick finds skipped are counted too, and a late step the
//! board reported and the gap it leaves before the next tick are counted once.

mod common;

use agent_node::NodeConfig;
use common::controller_config;
use hil_mock::mock::{MockActuator, MockCan, MockClock, MockNode, MockSensor};

const MS: u64 = 1_000;

/// Agent 2 of Example 1 (h = 1 ms), nothing supervised.
fn node() -> MockNode<2, 2, 4> {
    MockNode::new(
        &NodeConfig::new(2, [1, 0, 0, 0], 2_500),
        &controller_config(1),
        MockCan::new(1024),
        MockClock::default(),
        MockSensor::default(),
        MockActuator::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn tick_at(n: &mut MockNode<2, 2, 4>, us: u64) {
    n.clock_mut().set(us);
    n.sensor_mut().x = [0.05, 0.2];
    n.tick();
    while n.can_mut().take_tx().is_some() {}
}

#[test]
fn a_reported_late_release_counts_even_when_the_next_tick_is_on_time() {
    let mut n = node();
    tick_at(&mut n, 0);
    tick_at(&mut n, MS);
    // A step that overran its deadline by a little: the board's release found it running
    // once, and the next tick is only 1.2 periods after the last (no sample looks skipped).
    n.record_overrun();
    assert_eq!(n.stats().overruns, 1);
    tick_at(&mut n, 2 * MS + 200);
    assert_eq!(n.stats().overruns, 1);
}

#[test]
fn skipped_samples_count_once_whether_or_not_the_board_reported_them() {
    // Unreported: a tick 6 periods after the last one skipped 5 samples.
    let mut n = node();
    tick_at(&mut n, 0);
    tick_at(&mut n, 6 * MS);
    assert_eq!(n.stats().overruns, 5);
    // Reported: the same 5 releases found the step running; the gap adds nothing.
    let mut r = node();
    tick_at(&mut r, 0);
    for _ in 0..5 {
        r.record_overrun();
    }
    tick_at(&mut r, 6 * MS);
    assert_eq!(r.stats().overruns, 5);
    // Partly reported: 2 of the 5 seen by the board, the other 3 only as a gap.
    let mut p = node();
    tick_at(&mut p, 0);
    p.record_overrun();
    p.record_overrun();
    tick_at(&mut p, 6 * MS);
    assert_eq!(p.stats().overruns, 5);
    // The board's reports apply to one interval only: the next gap counts in full.
    tick_at(&mut p, 9 * MS);
    assert_eq!(p.stats().overruns, 7);
}
