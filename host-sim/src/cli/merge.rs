//! `host-sim merge`: the shards of a campaign into one directory.

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::Result;
use host_sim::{campaign, report::csv::Format};

use crate::cli::print_campaign;

/// Options of `merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Shard output directories.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Also write results.parquet (same columns and values as results.csv, which stays).
    #[arg(long, default_value = "csv", value_parser = ["csv", "parquet"])]
    format: String,
}

/// Merges the shards and prints the counts.
pub fn execute(a: MergeArgs) -> Result<()> {
    let r = campaign::merge_with(&a.dirs, &a.out, Format::from_name(&a.format)?)?;
    print_campaign(&r, &a.out, true);
    Ok(())
}
