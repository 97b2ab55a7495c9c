//! `host-sim check`: validate a scenario and print it resolved.

use std::path::PathBuf;

use agent_node::bus_load;
use clap::Args;
use consensus_hil::network::node::PolicyName;
use consensus_plot::error::Result;
use consensus_sim::{
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
    for line in bus_load_lines(&setup) {
        outln!("{line}");
    }
    Ok(())
}

/// The worst-case bus load of the scenario's frame set (docs/NETWORK.md §11), one comment line
/// per frame kind on the bus, the total, and a warning above
/// [`bus_load::LOAD_WARNING_PERCENT`]; nothing for the ideal kind.
pub fn bus_load_lines(setup: &Setup) -> Vec<String> {
    let s = &setup.scenario;
    let Some(set) = s
        .network
        .frame_set(setup.agents(), s.simulation.h, s.node.heartbeat_period)
    else {
        return Vec::new();
    };
    let load = set.load();
    let rates = match set.rates.data {
        Some(d) => format!(
            "CAN FD, {} nominal / {} data (bit-rate switching)",
            human_rate(set.rates.nominal),
            human_rate(d)
        ),
        None => format!("classical CAN, {}", human_rate(set.rates.nominal)),
    };
    let mut lines = vec![format!(
        "# bus load (worst-case stuffing, per sample of h = {} ms): {rates}",
        s.simulation.h * 1e3
    )];
    for k in load.kinds.iter().filter(|k| k.frames > 0.0) {
        lines.push(format!(
            "#   {:<9} {:>7.3} frames × {:>2} B, {:>3} bits = {:>7.1} µs ({:.1} %)",
            k.kind,
            k.frames,
            k.data_len,
            k.bits.total(),
            k.ns_per_sample * 1e-3,
            100.0 * k.ns_per_sample / load.period_ns,
        ));
    }
    let pct = load.percent();
    lines.push(format!(
        "#   total {:.1} µs of {:.1} µs: {pct:.1} %",
        load.busy_ns() * 1e-3,
        load.period_ns * 1e-3
    ));
    if pct > bus_load::LOAD_WARNING_PERCENT {
        lines.push(format!(
            "# warning: the frames take {pct:.1} % of the bus, above {} %: a CAN FD data bit \
             rate (network.data_bitrate), packed sensor frames (network.sensor_frames = \
             \"packed\") or a longer h (docs/NETWORK.md §11)",
            bus_load::LOAD_WARNING_PERCENT
        ));
    }
    lines
}

fn human_rate(r: u32) -> String {
    format!("{} Mbit/s", f64::from(r) / 1e6)
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
