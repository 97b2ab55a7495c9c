//! controller-core's `fast-math` back-end (its own fast approximations, `math::fast`, per
//! step) in the closed loop of both paper examples, against the default build's figures: each
//! figure's drift is held to its measured level (the table of `docs/REPRODUCTION.md`, "Math back-ends",
//! is this test's output). Without the feature it checks that the default build still gives
//! the reference figures (no drift).
//!
//! CI: `cargo test -p host-sim --release --features fast-math --test fast_math -- --ignored --nocapture`.

mod common;

use common::back_end::{check, FIGURES};

/// Largest relative drift per figure of [`FIGURES`], measured and rounded up.
const BOUNDS: [(&str, [f64; FIGURES.len()]); 2] = [
    ("example1", [1.6e-4, 4.2e-6, 4.3e-6, 3.8e-5, 2e-5, 2.9e-5]),
    ("example2", [4.6e-6, 5.7e-7, 1.6e-5, 3.4e-5, 3e-6, 4.5e-6]),
];

#[test]
#[ignore = "full runs: cargo test -p host-sim --release --features fast-math --test fast_math -- --ignored"]
fn both_examples_within_the_measured_drift_of_the_default_build() {
    check("fast-math", &BOUNDS);
}
