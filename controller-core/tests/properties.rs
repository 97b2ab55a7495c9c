//! Property tests of the core (proptest's default case count under `cargo test`; the
//! million-case run is `cargo test -p controller-core --release --test properties -- --ignored`
//! with `PROPTEST_CASES`, see docs/FIRMWARE.md). Seeds, stored failures and replaying a CI failure:
//! docs/RELIABILITY.md, "Replaying a failure".

use controller_core::{
    smoothing::smooth, BaselineConfig, Controller, ControllerConfig, Feedforward, GainSelection,
    HysteresisQuantizer, Link, QuantizerConfig, QuantizerDirection, SchemeConfig,
};
use proptest::{
    prelude::*,
    test_runner::{FailurePersistence, FileFailurePersistence},
};

fn quantizer_config() -> impl Strategy<Value = QuantizerConfig> {
    (0.05f32..0.99, 1e-4f32..1.0, any::<bool>()).prop_map(|(rho, u_min, magnitude)| {
        QuantizerConfig {
            rho,
            u_min,
            direction: if magnitude {
                QuantizerDirection::Magnitude
            } else {
                QuantizerDirection::Signed
            },
        }
    })
}

/// Commands a controller can produce: mostly moderate, with jumps, repeats and sign flips.
fn command() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -5.0f32..5.0,
        1 => -1e6f32..1e6,
        1 => Just(0.0f32),
        1 => -1e-3f32..1e-3,
    ]
}

/// Lemma 3: q = P u + R with 1−δ ≤ P ≤ 1+δ and |R| ≤ u_min, i.e. q is within u_min of the
/// segment between (1−δ)u and (1+δ)u.
fn satisfies_lemma3(q: f32, u: f32, delta: f32, u_min: f32) -> bool {
    let (a, b) = ((1.0 - delta) * u, (1.0 + delta) * u);
    let (lo, hi) = (a.min(b), a.max(b));
    let dist = if q < lo {
        lo - q
    } else if q > hi {
        q - hi
    } else {
        0.0
    };
    let tol = 1e-6 * (u.abs() + u_min);
    dist <= u_min + tol && (q == 0.0 || q.signum() == u.signum())
}

/// Failing cases are stored in `tests/properties.proptest-regressions` (committed) and replayed
/// before any new case; the run's seed is `PROPTEST_RNG_SEED` (`.cargo/config.toml` fixes it).
fn regressions_file() -> Option<Box<dyn FailurePersistence>> {
    Some(Box::new(FileFailurePersistence::WithSource(
        "proptest-regressions",
    )))
}

proptest! {
    #![proptest_config(ProptestConfig {
        failure_persistence: regressions_file(),
        ..ProptestConfig::default()
    })]

    #[test]
    fn quantizer_satisfies_lemma3(cfg in quantizer_config(),
                                  us in prop::collection::vec(command(), 1..200)) {
        let qz = HysteresisQuantizer::new(&cfg).unwrap();
        let mut s = qz.state();
        for &u in &us {
            let (pu, pq) = (s.prev_u, s.prev_q);
            let q = qz.quantize(&mut s, u);
            prop_assert!(satisfies_lemma3(q, u, qz.delta(), qz.u_min()),
                "q = {q} for u = {u} (δ = {}, u_min = {})", qz.delta(), qz.u_min());
            // The incremental level search agrees with the closed form.
            prop_assert_eq!(q, qz.quantize_reference(pu, pq, u));
        }
    }

    /// Any finite command, up to ±`f32::MAX`, and quantizers from the coarsest to `ρ` next to 1
    /// and `u_min` next to `f32::MAX`: the output is finite, within the top level, of the
    /// command's sign, and the incremental search equals the closed form.
    #[test]
    fn quantizer_output_is_finite_for_any_finite_command(
        rho in prop_oneof![0.001f32..0.999, Just(1.0 - f32::EPSILON / 2.0), Just(f32::MIN_POSITIVE)],
        u_min in prop_oneof![1e-30f32..1e30, Just(f32::MAX), Just(f32::MIN_POSITIVE / 4.0)],
        magnitude in any::<bool>(),
        us in prop::collection::vec(finite(), 1..100)) {
        let direction = if magnitude { QuantizerDirection::Magnitude } else { QuantizerDirection::Signed };
        let qz = HysteresisQuantizer::new(&QuantizerConfig { rho, u_min, direction }).unwrap();
        let mut s = qz.state();
        for &u in &us {
            let (pu, pq) = (s.prev_u, s.prev_q);
            let q = qz.quantize(&mut s, u);
            prop_assert!(q.is_finite() && q.abs() <= qz.saturation(),
                "q = {q} for u = {u} (ρ = {rho}, u_min = {u_min}, top {})", qz.saturation());
            prop_assert!(q == 0.0 || q.signum() == u.signum() || u == pu, "q = {q} for u = {u}");
            prop_assert_eq!(q, qz.quantize_reference(pu, pq, u));
        }
    }

    #[test]
    fn smoothing_is_bounded_and_finite(x in prop_oneof![any::<f32>().prop_filter("finite", |v| v.is_finite()),
                                                         Just(f32::MAX), Just(-f32::MAX), Just(0.0f32)],
                                       w in prop_oneof![1e-30f32..1e3, Just(f32::MAX), Just(1e-6f32)]) {
        let s = smooth(x, w);
        prop_assert!(s.is_finite() && (-1.0..=1.0).contains(&s), "s({x}, {w}) = {s}");
        prop_assert!(x == 0.0 || s.signum() == x.signum() || s == 0.0);
    }
}

/// Random valid configurations of a 2-state, 2-actuator agent with up to 4 neighbours.
fn config() -> impl Strategy<Value = ControllerConfig<2>> {
    let scalars = (
        0.05f32..10.0,                                 // ts
        0.02f32..0.98,                                 // zeta
        (1.0f32..500.0, 1.0f32..500.0),                // a_check
        (0.1f32..200.0, 0.1f32..200.0, 0.1f32..200.0), // p, eta, tau
        0.01f32..1.0,                                  // gamma
        1usize..=4,                                    // mtn order
        (0.1f32..2.0, 1.0f32..3.0),                    // phi_low, phi_up factor
        0usize..=4,                                    // neighbours
        any::<bool>(),                                 // pinned
    );
    let rest = (
        prop::option::of(quantizer_config()),
        prop_oneof![Just(None), (0.5f32..50.0, 0.5f32..50.0).prop_map(Some)],
        any::<bool>(),                           // baseline
        (1e-4f32..0.01),                         // h
        (0.0f32..5.0, 0.0f32..5.0, 0.0f32..5.0), // initial estimates
    );
    (scalars, rest).prop_map(|(s, r)| {
        let (ts, zeta, (a1, a2), (p, eta, tau), gamma, order, (lo, f), nb, pinned) = s;
        let (quantizer, explicit, baseline, h, (mu0, xi0, lambda0)) = r;
        ControllerConfig {
            h,
            neighbour_count: nb,
            pinned: pinned || nb == 0,
            ts,
            zeta,
            gains: explicit.map_or(GainSelection::Auto, |(c1, c2)| GainSelection::Explicit {
                c1,
                c2,
            }),
            a_check: [a1, a2],
            p,
            eta,
            tau,
            gamma,
            mtn_order: order,
            phi_low: [lo, lo],
            phi_up: [lo * f, lo * f],
            quantizer,
            scheme: if baseline {
                SchemeConfig::PrescribedTime(BaselineConfig::default())
            } else {
                SchemeConfig::PredefinedTime
            },
            mu0,
            xi0,
            lambda0,
            ..ControllerConfig::default()
        }
    })
}

/// Any finite f32, weighted towards the plausible range and the extremes.
fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -3.0f32..3.0,
        1 => any::<f32>().prop_filter("finite", |v| v.is_finite()),
        1 => prop_oneof![Just(f32::MAX), Just(-f32::MAX), Just(0.0f32), Just(-0.0f32),
                         Just(f32::MIN_POSITIVE / 4.0), Just(1e30f32)],
    ]
}

fn link() -> impl Strategy<Value = Link> {
    prop_oneof![
        6 => finite().prop_map(Link::Fresh),
        2 => finite().prop_map(Link::Stale),
        1 => Just(Link::Missing),
    ]
}

#[derive(Debug, Clone)]
struct Sample {
    x: [f32; 2],
    neighbours: Vec<Link>,
    leader: Link,
}

fn sample() -> impl Strategy<Value = Sample> {
    (
        (finite(), finite()),
        prop::collection::vec(link(), 0..=5),
        link(),
    )
        .prop_map(|((a, b), neighbours, leader)| Sample {
            x: [a, b],
            neighbours,
            leader,
        })
}

fn check_output(out: &controller_core::StepOutput<2, 2>) -> Result<(), TestCaseError> {
    let all = out
        .u
        .iter()
        .chain(&out.q)
        .chain(&out.e)
        .chain(&out.alpha)
        .chain(&out.beta);
    for v in all {
        prop_assert!(v.is_finite(), "non-finite output {out:?}");
    }
    let est = out.estimates;
    prop_assert!(
        est.mu >= 0.0 && est.xi >= 0.0 && est.lambda >= 0.0,
        "{est:?}"
    );
    prop_assert!(est.mu.is_finite() && est.xi.is_finite() && est.lambda.is_finite());
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: regressions_file(),
        ..ProptestConfig::default()
    })]

    #[test]
    fn step_is_total_on_finite_inputs(cfg in config(),
                                      samples in prop::collection::vec(sample(), 1..40)) {
        let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
        for s in &samples {
            let out = c.step(&s.x, &s.neighbours, s.leader);
            check_output(&out)?;
        }
    }

    /// The same with the velocity feed-forward of LAW §5a on (its differentiator of `w_i`
    /// joins the finiteness check and the held-step rule).
    #[test]
    fn step_with_feedforward_is_total_on_finite_inputs(cfg in config(),
                                                       samples in prop::collection::vec(sample(), 1..40)) {
        let cfg = ControllerConfig { feedforward: Feedforward::Estimated, ..cfg };
        let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
        for s in &samples {
            let out = c.step(&s.x, &s.neighbours, s.leader);
            check_output(&out)?;
            prop_assert!(c.state().feedforward.is_finite());
        }
    }

    #[test]
    fn step_recovers_after_non_finite_inputs(cfg in config(),
                                             bad in prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)],
                                             which in 0usize..4) {
        let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
        let good = |c: &mut Controller<2, 2, 4>| {
            let links = [Link::Fresh(0.1); 4];
            c.step(&[0.05, 0.2], &links[..cfg.neighbour_count], Link::Fresh(0.0))
        };
        let before = good(&mut c);
        let mut x = [0.05f32, 0.2];
        let mut links = [Link::Fresh(0.1); 4];
        let mut leader = Link::Fresh(0.0);
        match which {
            0 => x[0] = bad,
            1 => x[1] = bad,
            2 => links[0] = Link::Fresh(bad),
            _ => leader = Link::Stale(bad),
        }
        let out = c.step(&x, &links[..cfg.neighbour_count], leader);
        check_output(&out)?;
        if which < 2 {
            // Own state invalid: the command is held, nothing committed.
            prop_assert!(out.status.fault.is_some());
            prop_assert_eq!(out.u, before.u);
            prop_assert_eq!(out.q, before.q);
        }
        let after = good(&mut c);
        check_output(&after)?;
        prop_assert!(after.status.fault.is_none(), "did not recover: {:?}", after.status);
    }
}

/// Any f32 at all, including NaN, ±∞, ±0 and subnormals.
fn hostile() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -3.0f32..3.0,
        2 => any::<f32>(),
        1 => prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY),
                         Just(f32::MAX), Just(-f32::MAX), Just(0.0f32), Just(-0.0f32),
                         Just(f32::MIN_POSITIVE / 8.0), Just(-f32::MIN_POSITIVE / 8.0)],
    ]
}

fn hostile_link() -> impl Strategy<Value = Link> {
    prop_oneof![
        4 => hostile().prop_map(Link::Fresh),
        2 => hostile().prop_map(Link::Stale),
        1 => Just(Link::Missing),
    ]
}

fn hostile_cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000_000)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: hostile_cases(),
        failure_persistence: regressions_file(),
        ..ProptestConfig::default()
    })]

    /// The million-case run (ignored by default; see docs/FIRMWARE.md): any config, any inputs, NaN and ∞
    /// included. No panic, every output finite, estimates ≥ 0, a non-finite own state always
    /// gives the `InvalidState` fault, and valid inputs afterwards give a fault-free step.
    #[test]
    #[ignore]
    fn step_survives_hostile_inputs(cfg in config(),
                                    xs in prop::collection::vec((hostile(), hostile()), 1..6),
                                    links in prop::collection::vec(hostile_link(), 0..=5),
                                    leader in hostile_link()) {
        let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
        for &(a, b) in &xs {
            let out = c.step(&[a, b], &links, leader);
            check_output(&out)?;
            if !(a.is_finite() && b.is_finite()) {
                prop_assert_eq!(out.status.fault, Some(controller_core::StepFault::InvalidState));
            }
        }
        let ok = [Link::Fresh(0.1); 4];
        let out = c.step(&[0.05, 0.2], &ok[..cfg.neighbour_count], Link::Fresh(0.0));
        check_output(&out)?;
        prop_assert!(out.status.fault.is_none(), "did not recover: {:?}", out.status);
    }
}
