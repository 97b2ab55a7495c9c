//! Property tests of `[safety]` (`controller_core::safety`): under any input sequence, with any
//! valid limits, the command never leaves `[−u_max, u_max]`, never moves more than `du_max·h`
//! per sample, every output is finite and the estimates stay ≥ 0. Failures print the seed
//! (proptest's persistence file) and replay with it.

use controller_core::{Controller, ControllerConfig, Link, QuantizerConfig, SafetyConfig};
use proptest::prelude::*;

/// Valid safety settings with Example 1's law around them.
fn config() -> impl Strategy<Value = ControllerConfig<2>> {
    (
        prop_oneof![Just(None), (0.05f32..100.0).prop_map(Some)], // u_max
        prop_oneof![Just(None), (1.0f32..1e5).prop_map(Some)],    // du_max
        prop_oneof![Just(f32::INFINITY), 0.01f32..10.0],          // recovery_rate
        0.0f32..0.5,                                              // recovery_jump
        0usize..=4,                                               // neighbours
        any::<bool>(),                                            // pinned
        any::<bool>(),                                            // quantizer
        0.5f32..4.0,                                              // ts
    )
        .prop_map(
            |(u_max, du_max, recovery_rate, recovery_jump, nb, pinned, quantized, ts)| {
                ControllerConfig {
                    neighbour_count: nb,
                    pinned: pinned || nb == 0,
                    ts,
                    quantizer: quantized.then(|| QuantizerConfig {
                        u_min: 0.01,
                        ..QuantizerConfig::default()
                    }),
                    safety: Some(SafetyConfig {
                        u_max: u_max.map(|u| u.max(0.02)),
                        du_max,
                        recovery_rate,
                        recovery_jump,
                    }),
                    ..ControllerConfig::default()
                }
            },
        )
}

/// Any value a link or sensor may deliver, weighted towards plausible ones.
fn value() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -3.0f32..3.0,
        1 => any::<f32>(),
        1 => prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(1e30f32), Just(-f32::MAX)],
    ]
}

fn link() -> impl Strategy<Value = Link> {
    prop_oneof![
        5 => value().prop_map(Link::Fresh),
        3 => value().prop_map(Link::Stale),
        2 => Just(Link::Missing),
    ]
}

type Sample = ([f32; 2], Vec<Link>, Link);

fn sample() -> impl Strategy<Value = Sample> {
    (
        (value(), value()).prop_map(|(a, b)| [a, b]),
        prop::collection::vec(link(), 0..=5),
        link(),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn limited_command_stays_in_bounds_and_finite(cfg in config(),
                                                  samples in prop::collection::vec(sample(), 1..60)) {
        let mut c = Controller::<2, 2, 4>::new(&cfg).expect("valid configuration");
        let sf = cfg.safety.expect("on");
        let u_max = sf.u_max.unwrap_or(f32::INFINITY);
        let du = sf.du_max.map_or(f32::INFINITY, |d| d * cfg.h);
        let mut prev = 0.0f32;
        for (x, neighbours, leader) in &samples {
            let out = c.step(x, neighbours, *leader);
            for v in out.u.iter().chain(&out.q).chain(&out.e).chain(&out.alpha).chain(&out.beta) {
                prop_assert!(v.is_finite(), "{out:?}");
            }
            let u = out.u[0];
            prop_assert!(u.abs() <= u_max, "|u| = {u} above u_max = {u_max}");
            // f32 rounding of prev ± du·h allowed.
            prop_assert!((u - prev).abs() <= du * (1.0 + 1e-5) + 1e-6 * prev.abs(),
                "step {prev} -> {u} beyond du_max·h = {du}");
            let e = out.estimates;
            prop_assert!(e.mu >= 0.0 && e.xi >= 0.0 && e.lambda >= 0.0, "{e:?}");
            if out.status.limited {
                prop_assert!(out.status.fault.is_none());
            }
            prev = u;
        }
    }
}
