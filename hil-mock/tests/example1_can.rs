//! Example 1 (LAW §8) with four nodes over the simulated CAN bus, against the ideal link.

mod common;

use agent_node::wire::PAYLOAD_LEN;
use common::{record, run_can, run_ideal, H};
use hil_mock::bus::{frame_bits, BusConfig};

const T_END: f64 = 10.0;
/// 2 T_s: the predefined settling time of Example 1 (T_s = 2).
const T_FROM: f64 = 4.0;
const STALE_US: u64 = 2_500;

#[test]
fn one_mbit_no_loss_matches_the_ideal_link_within_10_percent() {
    let ideal = run_ideal(T_END, T_FROM);
    let can = run_can(
        BusConfig {
            bitrate: 1_000_000,
            deadline_ns: 1_000_000,
            ..BusConfig::default()
        },
        STALE_US,
        T_END,
        T_FROM,
        |_, _, _, _| {},
    );
    record("ideal", None, &[("max_error", ideal)]);
    record("can-1m", Some(&can), &[]);
    let rel = (can.max_error - ideal).abs() / ideal;
    println!(
        "ideal link: max |y_i - y_d| after {T_FROM} s = {ideal:.4}; CAN 1 Mbit/s: {:.4} ({:+.1} %)",
        can.max_error,
        100.0 * (can.max_error - ideal) / ideal
    );
    println!(
        "bus: load {:.2} %, sent {}, lost {}, corrupted {}, deadline misses {}, latency max {:.1} us mean {:.1} us, age max {:.3} ms mean {:.3} ms",
        can.bus.load_percent(),
        can.bus.frames_sent,
        can.bus.frames_lost,
        can.bus.frames_corrupted,
        can.bus.deadline_misses,
        can.bus.max_latency_ns as f64 * 1e-3,
        can.bus.mean_latency_s() * 1e6,
        can.bus.max_age_s() * 1e3,
        can.bus.mean_age_s() * 1e3
    );
    assert!(rel <= 0.10, "CAN {} vs ideal {ideal}", can.max_error);
    assert_eq!(can.bus.frames_lost, 0);
    assert_eq!(can.bus.deadline_misses, 0);
    assert_eq!(can.controller_faults, 0);
    // 5 frames of 95 bits per 1 ms at 1 Mbit/s.
    let expected = 5.0 * f64::from(frame_bits(false, PAYLOAD_LEN, true)) / 1e6 / H * 100.0;
    assert!((can.bus.load_percent() - expected).abs() < 0.1);
    for n in &can.nodes {
        assert_eq!(n.malformed.total(), 0);
        assert_eq!(n.seq_gaps, 0);
        assert_eq!(n.stale_samples, 0);
    }
    // Every value used is one sample old (sent at t, used at t + h).
    assert_eq!(can.bus.max_age_ns, 1_000_000);
}

#[test]
fn bus_load_at_500_kbit_matches_the_hand_computation() {
    // By hand: a standard data frame with 4 data bytes is 19 + 32 + 16 = 67 bits in the
    // stuffed region, + floor(67 / 4) = 16 stuff bits worst case, + 9 (ACK, EOF) + 3
    // (intermission) = 95 bits = 190 us at 500 kbit/s. Leader + 4 agents send one each per
    // 1 ms sample: 950 us busy per 1000 us = 95 %.
    let per_frame_s = 95.0 / 500e3;
    let by_hand = 5.0 * per_frame_s / H * 100.0;
    assert_eq!(frame_bits(false, PAYLOAD_LEN, true), 95);
    let can = run_can(
        BusConfig {
            bitrate: 500_000,
            deadline_ns: 1_000_000,
            ..BusConfig::default()
        },
        STALE_US,
        2.0,
        1.0,
        |_, _, _, _| {},
    );
    record("can-500k", Some(&can), &[]);
    println!(
        "500 kbit/s: load {:.2} % (by hand {by_hand:.2} %), sent {}, deadline misses {}, latency max {:.1} us, max error after 1 s {:.4}",
        can.bus.load_percent(),
        can.bus.frames_sent,
        can.bus.deadline_misses,
        can.bus.max_latency_ns as f64 * 1e-3,
        can.max_error
    );
    assert!(
        (can.bus.load_percent() - by_hand).abs() < 0.1,
        "{} vs {by_hand}",
        can.bus.load_percent()
    );
    // It fits: the lowest-priority frame (agent 4) ends 950 us into the period.
    assert_eq!(can.bus.deadline_misses, 0);
    assert_eq!(can.bus.max_latency_ns, 5 * 190_000 - 6_000);
}
