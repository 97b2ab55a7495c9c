//! controller-core's `micromath` back-end (the `micromath` crate's `F32Ext` per step) in the
//! closed loop of both paper examples, against the default build's figures: each figure's
//! drift is held to its measured level (the table of `docs/REPRODUCTION.md`, "Math back-ends",
//! is this test's output). Without the feature it checks that the default build still gives
//! the reference figures (no drift).
//!
//! CI: `cargo test -p host-sim --release --features micromath --test micromath -- --ignored --nocapture`.

mod common;

use common::back_end::{check, FIGURES};

/// Largest relative drift per figure of [`FIGURES`], measured and rounded up. Example 2's
/// max error after `2 T_s` is 7.5 % lower: its `ζ = 0.6`, and the crate's `x^0.6` below 1 is
/// up to 6.8 % off (1.2 % for Example 1's `ζ = 0.1`), so the law's `|e|^ζ` weighs the small
/// errors differently.
const BOUNDS: [(&str, [f64; FIGURES.len()]); 2] = [
    ("example1", [4.8e-4, 4.3e-4, 6.8e-4, 2.4e-4, 9.4e-4, 2.5e-3]),
    ("example2", [7.6e-2, 1.2e-2, 2.4e-5, 1.2e-3, 5.1e-2, 2.6e-2]),
];

#[test]
#[ignore = "full runs: cargo test -p host-sim --release --features micromath --test micromath -- --ignored"]
fn both_examples_within_the_measured_drift_of_the_default_build() {
    check("micromath", &BOUNDS);
}
