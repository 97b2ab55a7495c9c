//! `host-sim nodes`: write the node files of a scenario without running it.

use std::path::PathBuf;

use clap::Args;
use consensus_hil::network::socketcan::write_node_files;
use consensus_plot::error::{Error, Result};
use host_sim::report;

use crate::cli::{load, Overrides};

/// Options of `nodes`.
#[derive(Args, Debug)]
pub struct NodesArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    /// Output directory (created): `agent-<i>.toml` and `agent-<i>.eds` per follower.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Writes each follower's `node-linux` configuration and its CANopen EDS into `--out`, as a
/// `kind = "socketcan"` run would, so a bench can be prepared from a scenario.
pub fn execute(a: NodesArgs) -> Result<()> {
    let setup = load(&a.scenario, &a.overrides)?;
    if (setup.n(), setup.m()) != (2, 2) {
        return Err(Error::invalid(
            "plant.model",
            "node files carry the two-state plants of the examples (n = m = 2)",
        ));
    }
    let s = &setup.scenario;
    report::create_dir(&a.out)?;
    let files = write_node_files(
        &s.network,
        &s.node,
        s.simulation.h,
        &setup.graph,
        &setup.controller_configs::<2>()?,
        &a.out,
    )?;
    for f in &files {
        outln!("{}", f.display());
        outln!("{}", f.with_extension("eds").display());
    }
    Ok(())
}
