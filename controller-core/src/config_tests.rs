//! Every [`Reason`] a configuration is rejected for is reached by a configuration that should
//! produce it; the exhaustive `match` makes a new reason fail to compile here until it has a case.

use crate::{
    Agent, BaselineConfig, ConfigError, Controller, ControllerConfig, ControllerSection,
    GainSelection, Gains, Param, QuantizerConfig, QuantizerSection, Reason, SafetyConfig,
    SafetySection, SchemeConfig,
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

/// One configuration per way to be wrong, and the error it must give.
fn cases() -> [(Result<C, ConfigError>, ConfigError); 26] {
    use Param as P;
    use Reason as R;
    let e = ConfigError::new;
    let baseline = |mu_max, kappa| {
        SchemeConfig::PrescribedTime(BaselineConfig {
            kappa,
            mu_max,
            t_prescribed: None,
        })
    };
    [
        (with(|c| c.h = f32::NAN), e(P::H, R::NonFinite)),
        (with(|c| c.zeta = 1.0), e(P::Zeta, R::OutOfRange)),
        (with(|c| c.ts = -1.0), e(P::Ts, R::NonPositive)),
        (with(|c| c.h = 0.0), e(P::H, R::NonPositive)),
        (
            with(|c| c.quantizer = quantizer(1.2, 0.01)),
            e(P::Rho, R::OutOfRange),
        ),
        (
            with(|c| c.quantizer = quantizer(0.9, 0.0)),
            e(P::UMin, R::NonPositive),
        ),
        (
            with(|c| c.phi_low[1] = 0.0),
            e(P::PhiLow, R::NonPositive).at_step(2),
        ),
        (
            with(|c| c.phi_low[0] = 2.0),
            e(P::PhiLow, R::Exceeds(P::PhiUp)).at_step(1),
        ),
        (
            with(|c| c.a_check[1] = 0.0),
            e(P::ACheck, R::Zero).at_step(2),
        ),
        (with(|c| c.mtn_order = 0), e(P::MtnOrder, R::OutOfRange)),
        (with(|c| c.mtn_order = 9), e(P::MtnOrder, R::OutOfRange)),
        (
            with(|c| c.neighbour_count = 5),
            e(P::Neighbours, R::OverCapacity),
        ),
        (with(|c| c.pinned = false), e(P::Neighbours, R::Isolated)),
        (with(|c| c.gamma = 0.0), e(P::Gamma, R::NonPositive)),
        (
            with(|c| c.eps_bar[0] = -0.1),
            e(P::EpsBar, R::Negative).at_step(1),
        ),
        (with(|c| c.zeta = 1e-30), e(P::C1, R::TooLarge)),
        (with(|c| c.gamma = 1e-40), e(P::Gamma, R::DerivedOverflow)),
        (with(|c| c.varpi_min = 1.0), e(P::VarpiMin, R::OutOfRange)),
        (
            with(|c| c.mu0 = 2e6),
            e(P::EstimateMax, R::BelowInitialEstimates),
        ),
        (
            with(|c| c.scheme = baseline(0.5, 2.0)),
            e(P::MuMax, R::OutOfRange),
        ),
        (
            Gains::predefined_time(1.0, 0.5, 0, 1.0, 1.0, 1.0).map(|_| default_controller()),
            e(P::StateOrder, R::OutOfRange),
        ),
        (
            with(|c| {
                c.safety = Some(SafetyConfig {
                    u_max: Some(0.005),
                    ..SafetyConfig::default()
                })
            }),
            if cfg!(feature = "safety") {
                e(P::UMax, R::NotAbove(P::UMin))
            } else {
                e(P::SafetyEnabled, R::NotBuilt)
            },
        ),
        (
            sections::<3>(|_| {}),
            e(
                P::ACheck,
                R::StepCount {
                    expected: 2,
                    got: 3,
                },
            ),
        ),
        (sections::<2>(|c| c.c1 = Some(9.0)), e(P::C2, R::Unpaired)),
        (
            sections::<2>(|c| {
                c.c1 = Some(9.0);
                c.c2 = Some(9.0);
                c.gain_reading = crate::GainReading::Printed;
            }),
            e(P::GainReading, R::Conflicts(P::C1)),
        ),
        (
            sections::<2>(|c| c.kappa = Some(2.0)),
            e(P::Kappa, R::BaselineOnly),
        ),
    ]
}

/// A controller from the default sections (`S` entries per step) changed by `f`.
fn sections<const S: usize>(
    f: impl FnOnce(&mut ControllerSection<f32, heapless::Vec<f32, S>>),
) -> Result<C, ConfigError> {
    let mut c = ControllerSection::default();
    f(&mut c);
    let cfg = ControllerConfig::from_sections(
        Agent::default(),
        &c,
        &QuantizerSection::default(),
        &SafetySection::default(),
    )?;
    C::new(&cfg)
}

fn default_controller() -> C {
    C::new(&ControllerConfig::default()).expect("the default configuration is valid")
}

#[test]
fn every_reason_is_reached() {
    let mut seen = [false; 17];
    for (i, (got, want)) in cases().into_iter().enumerate() {
        assert_eq!(got.err(), Some(want), "case {i}");
        let slot = match want.reason() {
            Reason::NonFinite => 0,
            Reason::NonPositive => 1,
            Reason::Negative => 2,
            Reason::Zero => 3,
            Reason::OutOfRange => 4,
            Reason::TooLarge => 5,
            Reason::DerivedOverflow => 6,
            Reason::Exceeds(_) => 7,
            Reason::NotAbove(_) => 8,
            Reason::BelowInitialEstimates => 9,
            Reason::OverCapacity => 10,
            Reason::Isolated => 11,
            Reason::StepCount { .. } => 12,
            Reason::Unpaired => 13,
            Reason::BaselineOnly => 14,
            Reason::NotBuilt => 15,
            Reason::Conflicts(_) => 16,
        };
        seen[slot] = true;
    }
    // The one of the two a build cannot reach: with the `safety` feature or without it.
    seen[if cfg!(feature = "safety") { 15 } else { 8 }] = true;
    assert!(seen.iter().all(|&s| s), "{seen:?}");
}

#[test]
fn the_printed_gain_reading_gives_the_printed_gains() {
    let printed = sections::<2>(|c| c.gain_reading = crate::GainReading::Printed)
        .expect("Example 1 with the printed reading is valid");
    let want = crate::Gains::printed(2.0, 0.1, 2, 80.0, 50.0, 50.0).expect("valid");
    assert_eq!(printed.params().gains().c1, want.c1);
    assert!((printed.params().gains().c1 - 2862.0).abs() < 1.0);
    let reconstructed = sections::<2>(|_| {}).expect("valid");
    assert!((reconstructed.params().gains().c1 - 16.26).abs() < 0.01);
    assert_eq!(
        sections::<2>(|c| {
            c.gain_reading = crate::GainReading::Printed;
            c.tau = -1.0;
        })
        .err(),
        Some(ConfigError::new(Param::Tau, Reason::NonPositive))
    );
}

#[test]
fn more_parameters_are_named() {
    use ConfigError as E;
    let q = |rho| with(|c| c.quantizer = quantizer(rho, 0.01)).err();
    assert_eq!(
        q(f32::INFINITY),
        Some(E::new(Param::Rho, Reason::NonFinite))
    );
    assert_eq!(
        with(|c| c.p = -1.0).err(),
        Some(E::new(Param::P, Reason::NonPositive))
    );
    assert_eq!(
        with(|c| c.diff_l2 = 0.0).err(),
        Some(E::new(Param::DiffL2, Reason::NonPositive))
    );
    assert_eq!(
        with(|c| c.lambda0 = -1.0).err(),
        Some(E::new(Param::Lambda0, Reason::Negative))
    );
    assert_eq!(
        with(|c| c.varpi_decay = -0.7).err(),
        Some(E::new(Param::VarpiDecay, Reason::Negative))
    );
    assert_eq!(
        with(|c| c.a_check[0] = f32::NAN).err(),
        Some(E::new(Param::ACheck, Reason::NonFinite).at_step(1))
    );
    assert_eq!(
        with(|c| c.gains = GainSelection::Explicit { c1: 0.0, c2: 9.0 }).err(),
        Some(E::new(Param::C1, Reason::NonPositive))
    );
    assert_eq!(
        with(|c| c.scheme = SchemeConfig::PrescribedTime(BaselineConfig {
            kappa: 0.0,
            ..BaselineConfig::default()
        }))
        .err(),
        Some(E::new(Param::Kappa, Reason::NonPositive))
    );
    // Subnormal or huge values whose reciprocal or product with A_i overflows.
    let tiny = |c: &mut ControllerConfig<2>| {
        c.phi_low = [1e-40; 2];
        c.phi_up = [1e-40; 2];
    };
    assert_eq!(
        with(tiny).err(),
        Some(E::new(Param::PhiLow, Reason::DerivedOverflow).at_step(1))
    );
    let huge_up = |c: &mut ControllerConfig<2>| {
        c.pinned = true;
        c.neighbour_count = 2;
        c.phi_up = [f32::MAX; 2];
    };
    assert_eq!(
        with(huge_up).err(),
        Some(E::new(Param::PhiUp, Reason::DerivedOverflow).at_step(1))
    );
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
    assert_eq!(
        safety(Some(-1.0), None, 1.0),
        Some(E::new(Param::UMax, Reason::NonPositive))
    );
    assert_eq!(
        safety(None, Some(f32::NAN), 1.0),
        Some(E::new(Param::DuMax, Reason::NonFinite))
    );
    assert_eq!(
        safety(None, None, -1.0),
        Some(E::new(Param::RecoveryRate, Reason::NonPositive))
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
        Some(E::new(Param::RecoveryJump, Reason::Negative))
    );
    // Messages name the parameter.
    extern crate std;
    use std::string::ToString;
    assert!(E::new(Param::Gamma, Reason::NonPositive)
        .to_string()
        .contains("gamma"));
    assert!(E::new(Param::ACheck, Reason::Zero)
        .at_step(2)
        .to_string()
        .contains("a_check[2]"));
}

#[test]
fn errors_lists_every_problem_and_starts_with_the_error_of_new() {
    use ConfigError as E;
    let mut cfg = ControllerConfig::<2> {
        zeta: 1.5,
        ..ControllerConfig::default()
    };
    cfg.a_check[1] = 0.0;
    cfg.phi_low[0] = 2.0;
    cfg.h = f32::NAN;
    cfg.gamma = -1.0;
    cfg.varpi_min = 1.0;
    let all = cfg.errors(4);
    assert_eq!(all.first().copied(), C::new(&cfg).err());
    assert_eq!(
        all.as_slice(),
        [
            E::new(Param::H, Reason::NonFinite),
            E::new(Param::Zeta, Reason::OutOfRange),
            E::new(Param::PhiLow, Reason::Exceeds(Param::PhiUp)).at_step(1),
            E::new(Param::ACheck, Reason::Zero).at_step(2),
            E::new(Param::Gamma, Reason::NonPositive),
            E::new(Param::VarpiMin, Reason::OutOfRange),
        ]
    );
    assert!(ControllerConfig::<2>::default().errors(4).is_empty());
}

#[test]
fn every_single_mistake_gives_one_error_equal_to_that_of_new() {
    let tiny = ControllerConfig::<2> {
        phi_low: [1e-40; 2],
        phi_up: [1e-40; 2],
        ..ControllerConfig::default()
    };
    for cfg in [
        tiny,
        ControllerConfig {
            pinned: false,
            ..ControllerConfig::default()
        },
        ControllerConfig {
            mu0: 2e6,
            ..ControllerConfig::default()
        },
        ControllerConfig {
            zeta: 1e-30,
            ..ControllerConfig::default()
        },
    ] {
        let all = cfg.errors(4);
        assert_eq!(all.first().copied(), C::new(&cfg).err(), "{all:?}");
        assert!(
            all.iter()
                .all(|e| !matches!(e.reason(), Reason::Exceeds(_))),
            "{all:?}"
        );
    }
    for f in [
        (|c: &mut ControllerConfig<2>| c.pinned = false) as fn(&mut ControllerConfig<2>),
        |c| c.mu0 = 2e6,
        |c| c.zeta = 1e-30,
        |c| c.phi_low[1] = -1.0,
        |c| c.varpi0 = 1e-7,
        |c| c.h = -1.0,
        |c| c.gains = GainSelection::Explicit { c1: 0.0, c2: 9.0 },
    ] {
        let mut cfg = ControllerConfig::<2>::default();
        f(&mut cfg);
        let all = cfg.errors(4);
        assert_eq!(all.len(), 1, "{all:?}");
        assert_eq!(all.first().copied(), C::new(&cfg).err());
    }
}

#[test]
fn from_sections_all_reports_every_layout_problem() {
    let c = ControllerSection::<f32, heapless::Vec<f32, 3>> {
        phi_low: heapless::Vec::from_slice(&[1.0]).unwrap_or_default(),
        c1: Some(9.0),
        kappa: Some(2.0),
        ..ControllerSection::default()
    };
    let (cfg, errors) = ControllerConfig::<2>::from_sections_all(
        Agent::default(),
        &c,
        &QuantizerSection::default(),
        &SafetySection::default(),
    );
    let params: heapless::Vec<Param, 8> = errors.iter().map(ConfigError::param).collect();
    assert_eq!(
        params.as_slice(),
        [
            Param::C2,
            Param::Kappa,
            Param::ACheck,
            Param::PhiLow,
            Param::PhiUp,
            Param::EpsBar
        ]
    );
    assert!(
        cfg.errors(4).is_empty(),
        "the rejected values fall back to defaults"
    );
}
