//! Failing inputs found by the property runs (CI logs, replayed seeds), kept as plain tests so
//! each stays fixed. Each test names where the case came from.

use controller_core::{
    Controller, ControllerConfig, GainSelection, HysteresisQuantizer, Link, QuantizerConfig,
    QuantizerDirection, SchemeConfig,
};

fn near_max_quantizer() -> QuantizerConfig {
    QuantizerConfig {
        rho: 0.4660296,
        u_min: 0.9543642,
        direction: QuantizerDirection::Signed,
    }
}

/// The million-case property run (183,567th case) found a finite `u` near `f32::MAX` quantized
/// to `±∞` with no fault: the level above the top finite level overflowed. This is the shrunk
/// case, replayed through the whole step.
#[test]
fn finite_command_near_f32_max_gives_a_finite_quantized_command() {
    let cfg = ControllerConfig::<2> {
        h: 1e-4,
        neighbour_count: 1,
        pinned: true,
        ts: 6.05802,
        zeta: 0.080764085,
        gains: GainSelection::Auto,
        a_check: [435.99646, 426.28207],
        p: 178.74849,
        eta: 91.272415,
        tau: 55.70309,
        gamma: 0.33658797,
        mtn_order: 1,
        phi_low: [1.8039627; 2],
        phi_up: [4.9608364; 2],
        mu0: 4.6767554,
        xi0: 4.874346,
        lambda0: 1.4612558,
        quantizer: Some(near_max_quantizer()),
        scheme: SchemeConfig::PredefinedTime,
        ..ControllerConfig::default()
    };
    let mut c = Controller::<2, 2, 4>::new(&cfg).unwrap();
    let links = [
        Link::Missing,
        Link::Fresh(-3.4028235e38),
        Link::Fresh(0.97239524),
        Link::Stale(1.0183837),
        Link::Fresh(0.8326088),
    ];
    let xs = [
        [0.70723313, 0.0],
        [2.7028322, -0.8598837],
        [2.2347162, 2.5602107],
    ];
    let saturation = c.params().quantizer().unwrap().saturation();
    let mut saw_huge_command = false;
    for x in &xs {
        let out = c.step(x, &links, Link::Fresh(1.6143822e27));
        for (&u, &q) in out.u.iter().zip(&out.q) {
            assert!(u.is_finite() && q.is_finite(), "u {u} q {q}: {out:?}");
            assert!(
                q.abs() <= saturation,
                "q {q} above the top level {saturation}"
            );
            saw_huge_command |= u.abs() > 1e38;
        }
    }
    // The case still reaches the top of the level range (else it tests nothing).
    assert!(
        saw_huge_command,
        "the replayed case no longer produces |u| > 1e38"
    );
}

/// The same quantizer alone: rising to `3.34e38` and falling from it. Falling, the
/// bracket value `b = |u| (1+δ)` overflowed: the incremental search returned `∞` and the closed
/// form the lowest level (`1.30`).
#[test]
fn quantizer_near_f32_max_is_finite_and_search_agrees() {
    let qz = HysteresisQuantizer::new(&near_max_quantizer()).unwrap();
    let sat = qz.saturation();
    assert!(sat.is_finite() && sat > f32::MAX * 0.4660296);
    let mut s = qz.state();
    for &u in &[
        3.3372123e38f32,
        3.0e38,
        f32::MAX,
        -f32::MAX,
        f32::MAX,
        1.0,
        -3.0e38,
        -3.3e38,
    ] {
        let (pu, pq) = (s.prev_u, s.prev_q);
        let q = qz.quantize(&mut s, u);
        assert!(q.is_finite() && q.abs() <= sat, "u {u} → q {q}");
        assert_eq!(q, qz.quantize_reference(pu, pq, u), "u {u}");
        // Large commands keep their sign and at least ρ of their size.
        if u.abs() > 1.0 {
            assert!(q.signum() == u.signum() && q.abs() >= 0.4660296 * u.abs() * 0.999);
        }
    }
}
