//! `host-sim/examples/pendulum.rs` (a plant given in Rust, run through the library) builds,
//! runs and follows the leader.

mod common;

#[allow(dead_code)]
#[path = "../examples/pendulum.rs"]
mod pendulum;

#[test]
fn the_pendulum_example_follows_the_leader() {
    let out = common::tmp("example-pendulum");
    let s = pendulum::run(&out, 3.0).expect("the example runs");
    assert!(!s.diverged, "{:?}", s.divergence);
    let err = s
        .max_error_after_predefined_time
        .expect("samples after 2Ts");
    assert!(err < 0.1, "max |y_i - y_d| after 2Ts = {err}");
    assert_eq!(s.model, "library");
    for f in [
        "summary.json",
        "trajectory.csv",
        "tracking.png",
        "errors.png",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
}
