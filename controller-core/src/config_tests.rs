//! Every [`ConfigError`] variant is reached by a configuration that should produce it; the
//! exhaustive `match` makes a new variant fail to compile here until it has a case.

use crate::{
    BaselineConfig, ConfigError, Controller, ControllerConfig, GainSelection, Gains,
    QuantizerConfig, SafetyConfig, SchemeConfig,
};

type C = Controller<2, 2, 4>;

fn with(f: impl FnOnce(&mut ControllerConfig<2>)) -> Result<C, ConfigError> {
    let mut cfg = ControllerConfig::<2>::default();
    f(&mut cfg);
    C::new(&cfg)
}

fn quantizer(rho: f32, u_min: f32) -> Option<QuantizerConfig> {
    Some(QuantizerConfig {
        rho,
        u_min,
        ..QuantizerConfig::default()
    })
}

/// One configuration per variant, and the variant it must give.
fn cases() -> [(Result<C, ConfigError>, ConfigError); 22] {
    use ConfigError as E;
    let baseline = |mu_max, kappa| {
        SchemeConfig::PrescribedTime(BaselineConfig {
            kappa,
            mu_max,
            t_prescribed: None,
        })
    };
    [
        (with(|c| c.h = f32::NAN), E::NonFinite("h")),
        (with(|c| c.zeta = 1.0), E::ZetaOutOfRange),
        (with(|c| c.ts = -1.0), E::NonPositiveTs),
        (with(|c| c.h = 0.0), E::NonPositiveSamplePeriod),
        (
            with(|c| c.quantizer = quantizer(1.2, 0.01)),
            E::RhoOutOfRange,
        ),
        (
            with(|c| c.quantizer = quantizer(0.9, 0.0)),
            E::NonPositiveUMin,
        ),
        (
            with(|c| c.phi_low[1] = 0.0),
            E::NonPositivePhiLow { step: 2 },
        ),
        (
            with(|c| c.phi_low[0] = 2.0),
            E::PhiLowAbovePhiUp { step: 1 },
        ),
        (with(|c| c.a_check[1] = 0.0), E::ZeroACheck { step: 2 }),
        (with(|c| c.mtn_order = 0), E::ZeroMtnOrder),
        (with(|c| c.mtn_order = 9), E::MtnOrderTooLarge),
        (with(|c| c.neighbour_count = 5), E::TooManyNeighbours),
        (with(|c| c.pinned = false), E::Isolated),
        (with(|c| c.gamma = 0.0), E::NonPositive("gamma")),
        (with(|c| c.eps_bar[0] = -0.1), E::Negative("eps_bar")),
        (with(|c| c.zeta = 1e-30), E::GainTooLarge("c1")),
        (with(|c| c.gamma = 1e-40), E::DerivedOverflow("gamma")),
        (with(|c| c.varpi_min = 1.0), E::VarpiMinOutOfRange),
        (with(|c| c.mu0 = 2e6), E::InitialEstimateAboveMax),
        (with(|c| c.scheme = baseline(0.5, 2.0)), E::MuMaxBelowOne),
        (
            Gains::predefined_time(1.0, 0.5, 0, 1.0, 1.0, 1.0).map(|_| default_controller()),
            E::ZeroStateOrder,
        ),
        (
            with(|c| {
                c.safety = Some(SafetyConfig {
                    u_max: Some(0.005),
                    ..SafetyConfig::default()
                })
            }),
            if cfg!(feature = "safety") {
                E::UMaxNotAboveUMin
            } else {
                E::SafetyNotBuilt
            },
        ),
    ]
}

fn default_controller() -> C {
    C::new(&ControllerConfig::default()).expect("the default configuration is valid")
}

#[test]
fn every_variant_is_reached() {
    let mut seen = [false; 23];
    for (i, (got, want)) in cases().into_iter().enumerate() {
        assert_eq!(got.err(), Some(want), "case {i}");
        let slot = match want {
            ConfigError::NonFinite(_) => 0,
            ConfigError::ZetaOutOfRange => 1,
            ConfigError::NonPositiveTs => 2,
            ConfigError::NonPositiveSamplePeriod => 3,
            ConfigError::RhoOutOfRange => 4,
            ConfigError::NonPositiveUMin => 5,
            ConfigError::NonPositivePhiLow { .. } => 6,
            ConfigError::PhiLowAbovePhiUp { .. } => 7,
            ConfigError::ZeroACheck { .. } => 8,
            ConfigError::ZeroMtnOrder => 9,
            ConfigError::MtnOrderTooLarge => 10,
            ConfigError::TooManyNeighbours => 11,
            ConfigError::Isolated => 12,
            ConfigError::NonPositive(_) => 13,
            ConfigError::Negative(_) => 14,
            ConfigError::VarpiMinOutOfRange => 15,
            ConfigError::InitialEstimateAboveMax => 16,
            ConfigError::MuMaxBelowOne => 17,
            ConfigError::ZeroStateOrder => 18,
            ConfigError::GainTooLarge(_) => 19,
            ConfigError::DerivedOverflow(_) => 20,
            ConfigError::UMaxNotAboveUMin => 21,
            ConfigError::SafetyNotBuilt => 22,
        };
        seen[slot] = true;
    }
    // The one of the two a build cannot reach: with the `safety` feature or without it.
    seen[if cfg!(feature = "safety") { 22 } else { 21 }] = true;
    assert!(seen.iter().all(|&s| s), "{seen:?}");
}

#[test]
fn more_parameters_are_named() {
    use ConfigError as E;
    let q = |rho| with(|c| c.quantizer = quantizer(rho, 0.01)).err();
    assert_eq!(q(f32::INFINITY), Some(E::NonFinite("rho")));
    assert_eq!(with(|c| c.p = -1.0).err(), Some(E::NonPositive("p")));
    assert_eq!(
        with(|c| c.diff_l2 = 0.0).err(),
        Some(E::NonPositive("diff_l2"))
    );
    assert_eq!(
        with(|c| c.lambda0 = -1.0).err(),
        Some(E::Negative("lambda0"))
    );
    assert_eq!(
        with(|c| c.varpi_decay = -0.7).err(),
        Some(E::Negative("varpi_decay"))
    );
    assert_eq!(
        with(|c| c.a_check[0] = f32::NAN).err(),
        Some(E::NonFinite("a_check"))
    );
    assert_eq!(
        with(|c| c.gains = GainSelection::Explicit { c1: 0.0, c2: 9.0 }).err(),
        Some(E::NonPositive("c1"))
    );
    assert_eq!(
        with(|c| c.scheme = SchemeConfig::PrescribedTime(BaselineConfig {
            kappa: 0.0,
            ..BaselineConfig::default()
        }))
        .err(),
        Some(E::NonPositive("kappa"))
    );
    // Subnormal or huge values whose reciprocal or product with A_i overflows (issue 11).
    let tiny = |c: &mut ControllerConfig<2>| {
        c.phi_low = [1e-40; 2];
        c.phi_up = [1e-40; 2];
    };
    assert_eq!(with(tiny).err(), Some(E::DerivedOverflow("phi_low")));
    let huge_up = |c: &mut ControllerConfig<2>| {
        c.pinned = true;
        c.neighbour_count = 2;
        c.phi_up = [f32::MAX; 2];
    };
    assert_eq!(with(huge_up).err(), Some(E::DerivedOverflow("phi_up")));
    let safety = |u_max, du_max, recovery_rate| {
        with(|c| {
            c.safety = Some(SafetyConfig {
                u_max,
                du_max,
                recovery_rate,
                recovery_jump: 0.05,
            })
        })
        .err()
    };
    assert_eq!(safety(Some(-1.0), None, 1.0), Some(E::NonPositive("u_max")));
    assert_eq!(
        safety(None, Some(f32::NAN), 1.0),
        Some(E::NonFinite("du_max"))
    );
    assert_eq!(
        safety(None, None, -1.0),
        Some(E::NonPositive("recovery_rate"))
    );
    assert_eq!(safety(Some(20.0), Some(1e4), f32::INFINITY), None);
    assert_eq!(
        with(|c| {
            c.safety = Some(SafetyConfig {
                recovery_jump: -1.0,
                ..SafetyConfig::default()
            })
        })
        .err(),
        Some(E::Negative("recovery_jump"))
    );
    // Messages name the parameter.
    extern crate std;
    use std::string::ToString;
    assert!(E::NonPositive("gamma").to_string().contains("gamma"));
    assert!(E::ZeroACheck { step: 2 }.to_string().contains("a_check[2]"));
}
