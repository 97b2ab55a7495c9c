//! `host-sim check`: validate a scenario and print it resolved.

use std::path::PathBuf;

use clap::Args;
use host_sim::{error::Result, scenario};

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
    Ok(())
}
