//! `host-sim check`: validate a scenario and print it resolved.

use std::path::PathBuf;

use clap::Args;
use host_sim::{
    error::Result,
    network::node::PolicyName,
    plant::WithoutFeedback,
    scenario::{self, Setup},
};

use crate::cli::{load, Overrides};

/// Options of `check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Prints the scenario with defaults filled and overrides applied, then its sizes.
pub fn execute(a: CheckArgs) -> Result<()> {
    let setup = load(&a.scenario, &a.overrides)?;
    out!("{}", scenario::to_toml(&setup.scenario));
    outln!(
        "# ok: {} agents, n = {}, m = {}, {} samples",
        setup.agents(),
        setup.n(),
        setup.m(),
        setup.samples
    );
    if let Some(w) = open_loop_warning(&setup) {
        outln!("# warning: {w}");
    }
    Ok(())
}

/// A warning when `[node.safe_state]` pairs an open-loop policy with a plant that may not be
/// bounded without feedback (docs/NETWORK.md §10).
pub fn open_loop_warning(setup: &Setup) -> Option<String> {
    let s = &setup.scenario.node.safe_state;
    let supervised =
        s.leader_timeout.is_some() || s.neighbour_timeout.is_some() || s.sensor_timeout.is_some();
    if !supervised || !s.policy.is_open_loop() {
        return None;
    }
    let name = s.policy.as_str();
    let fix = "policy = \"hold-position\" or \"stop\" keeps the loop closed";
    match setup.plant.without_feedback() {
        WithoutFeedback::Unstable(why) => Some(format!(
            "node.safe_state.policy = \"{name}\" opens the loop, and {why}: {fix}"
        )),
        WithoutFeedback::BoundedAtZero(why) if s.policy == PolicyName::Hold => Some(format!(
            "node.safe_state.policy = \"hold\" holds the last command open loop, and {why}: \
             {fix}, or \"off\" / \"ramp\" ends at zero"
        )),
        WithoutFeedback::BoundedAtZero(_) => None,
        WithoutFeedback::Unknown => Some(format!(
            "node.safe_state.policy = \"{name}\" opens the loop, and host-sim cannot tell \
             whether a custom plant is bounded without feedback: {fix}"
        )),
    }
}
