//! The NUCLEO-G474RE firmware's compiled-in configuration (`boards/nucleo-g474re/src/config.rs`,
//! a target-only crate) checked on the host before it is flashed: the constructors the board
//! calls at boot accept it, and the node built from it broadcasts on the identifier the board's
//! documentation gives.

#[allow(dead_code)]
#[path = "../../boards/nucleo-g474re/src/config.rs"]
mod board;

use agent_node::{wire::Source, Node};
use embedded_can::{Frame as _, Id, StandardId};
use hil_mock::mock::{MockActuator, MockCan, MockClock, MockSensor};

#[test]
fn board_configuration_passes_the_boot_checks_and_broadcasts_on_its_value_id() {
    assert_eq!(board::wiring_error(), None);
    let mut node = Node::new(
        &board::NODE,
        &board::controller(),
        MockCan::default(),
        MockClock::default(),
        MockSensor::<{ board::N }>::default(),
        MockActuator::<{ board::M }>::default(),
    )
    .unwrap_or_else(|e| panic!("config.rs is rejected at boot: {e}"));
    node.clock_mut().set(u64::from(board::SAMPLE_PERIOD_US));
    let tick = node.tick();
    assert!(tick.output.u.iter().all(|u| u.is_finite()), "{tick:?}");
    let raw = board::NODE.ids.value_id(Source::Agent(board::NODE.agent));
    let expected = raw.and_then(StandardId::new).map(Id::Standard);
    let sent = node.can_mut().take_tx().map(|f| f.id());
    assert_eq!(sent, expected);
    assert_eq!(
        raw,
        Some(0x105),
        "docs/FIRMWARE.md gives agent 4's value frames as 0x105"
    );
}
