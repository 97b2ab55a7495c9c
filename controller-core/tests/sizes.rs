//! The footprint of one agent's controller (the figures `docs/FIRMWARE.md` reports through `cargo xtask docs`).

use controller_core::{Controller, Params, State};
use core::mem::size_of;

#[test]
fn example1_controller_footprint() {
    let total = size_of::<Controller<2, 2, 4>>();
    let params = size_of::<Params<2>>();
    let state = size_of::<State<2, 2, 4>>();
    println!("Controller<2, 2, 4>: {total} B (Params<2>: {params} B, State<2, 2, 4>: {state} B)");
    println!(
        "Controller<3, 3, 4>: {} B",
        size_of::<Controller<3, 3, 4>>()
    );
    // The goal for the per-agent state; settings are read-only and can live in flash.
    assert!(state <= 256, "state is {state} B");
    assert!(total <= 512, "controller is {total} B");
}
