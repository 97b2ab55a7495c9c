//! Every error type of controller-core is a `core::error::Error` whose `Display` says something.

use controller_core::{
    mtn::CapacityError, param::Param, ConfigError, Controller, ControllerConfig, Link, Reason,
    StepFault,
};

/// Compiles only for a `core::error::Error`; returns its message.
fn message<E: core::error::Error>(e: &E) -> String {
    e.to_string()
}

#[test]
fn every_error_type_is_an_error_with_a_message() {
    let cfg = ControllerConfig::<2> {
        ts: 0.0,
        ..Default::default()
    };
    let config = Controller::<2, 2, 0>::new(&cfg).unwrap_err();
    assert_eq!(message(&config), "`ts` must be > 0");

    let reason = Param::Rho.spec().range.check(1.0).unwrap_err();
    assert_eq!(reason, Reason::OutOfRange);
    let reasons = [
        reason,
        Reason::NonFinite,
        Reason::StepCount {
            expected: 2,
            got: 3,
        },
        Reason::Exceeds(Param::PhiUp),
        Reason::Conflicts(Param::C1),
    ];
    for r in reasons {
        assert!(!message(&r).is_empty(), "{r:?}");
    }
    assert!(message(&Reason::Exceeds(Param::PhiUp)).contains("controller.phi_up"));

    let mut c = Controller::<2, 2, 0>::new(&ControllerConfig::default()).unwrap();
    let held = c.step(&[f32::NAN, 0.0], &[], Link::Fresh(0.0));
    let fault = held.status.fault.unwrap();
    assert_eq!(fault, StepFault::InvalidState);
    assert!(message(&fault).contains("NaN"));
    assert!(!message(&StepFault::NonFiniteResult).is_empty());

    let capacity = CapacityError { needed: 9 };
    assert!(message(&capacity).contains('9'));

    // `ConfigError` as a trait object, as `?` into `Box<dyn Error>` uses it.
    let boxed: Box<dyn core::error::Error> = Box::new(ConfigError::new(Param::Gamma, Reason::Zero));
    assert_eq!(boxed.to_string(), "`gamma` must not be 0");
}
