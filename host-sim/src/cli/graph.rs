//! `host-sim graph`: draw the scenario's communication graph (the paper's Fig. 1).

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::Result;
use host_sim::report::{self, graph};

use crate::cli::{load, Overrides};

/// Options of `graph`.
#[derive(Args, Debug)]
pub struct GraphArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    /// Output directory (created): `graph.png` and `graph.svg`, or the `[figures]` formats.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Writes the graph figure of the scenario into `--out`.
pub fn execute(a: GraphArgs) -> Result<()> {
    let setup = load(&a.scenario, &a.overrides)?;
    report::create_dir(&a.out)?;
    graph::draw(&a.out, &setup)
}
