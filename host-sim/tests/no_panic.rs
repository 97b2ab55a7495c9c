//! Scenario parsing never panics: arbitrary text and arbitrary `--set` values give a scenario or
//! `Error::Invalid` problems, nothing else.

use host_sim::{scenario, Error};
use proptest::prelude::*;

const KEYS: &[&str] = &[
    "simulation.h",
    "simulation.t_end",
    "simulation.substeps",
    "simulation.settle_band",
    "graph.neighbours",
    "graph.adjacency",
    "graph.pinned",
    "leader.amplitude",
    "plant.model",
    "plant.x0",
    "plant.inertia",
    "controller.scheme",
    "controller.ts",
    "controller.zeta",
    "controller.a_check",
    "controller.mtn_order",
    "controller.c1",
    "controller.varpi_min",
    "quantizer.rho",
    "quantizer.enabled",
    "faults.rule",
    "faults.enabled",
    "name",
];

const VALUES: &[&str] = &[
    "0",
    "-1",
    "1e-9",
    "1e300",
    "-1e300",
    "nan",
    "inf",
    "-inf",
    "true",
    "\"x\"",
    "[]",
    "[[]]",
    "[1, 2]",
    "[[1, 2], [3]]",
    "[[0, 1], [1, 0]]",
    "{}",
    "0.5",
    "4294967296",
    "[[1e308, 1e308]]",
];

fn check(res: Result<scenario::Setup, Error>) -> Result<(), TestCaseError> {
    match res {
        Ok(_) => Ok(()),
        Err(e) if e.problems().iter().all(|p| matches!(p, Error::Invalid(_))) => Ok(()),
        Err(e) => Err(TestCaseError::fail(format!("unexpected error kind: {e}"))),
    }
}

proptest! {
    #[test]
    fn arbitrary_text_is_rejected_cleanly(text in "[\\[\\]a-z_.=\" 0-9\n,-]{0,80}") {
        check(scenario::parse(&text, &[]))?;
    }

    #[test]
    fn arbitrary_overrides_are_rejected_cleanly(
        sets in proptest::collection::vec((0..KEYS.len(), 0..VALUES.len()), 1..4)
    ) {
        let sets: Vec<String> = sets.iter().map(|&(k, v)| format!("{}={}", KEYS[k], VALUES[v])).collect();
        check(scenario::parse("", &sets))?;
    }
}
