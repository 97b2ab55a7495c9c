//! `host-sim compare`: two scenarios, one table and overlaid figures.

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::Result;
use host_sim::compare::compare;

use crate::cli::{load, Overrides};

/// Options of `compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// First scenario (e.g. the proposed scheme).
    a: PathBuf,
    /// Second scenario (e.g. the baseline).
    b: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// Runs both scenarios (the same overrides on each) and prints the table.
pub fn execute(a: CompareArgs) -> Result<()> {
    let sa = load(&a.a, &a.overrides)?;
    let sb = load(&a.b, &a.overrides)?;
    let table = compare(&sa, &sb, &a.out, !a.quiet)?;
    out!("{table}");
    outln!("wrote {}", a.out.display());
    Ok(())
}
