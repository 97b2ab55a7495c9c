//! `host-sim merge`: the shards of a campaign into one directory.

use std::path::PathBuf;

use clap::Args;
use host_sim::{campaign, error::Result};

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
}

/// Merges the shards and prints the counts.
pub fn execute(a: MergeArgs) -> Result<()> {
    let r = campaign::merge(&a.dirs, &a.out)?;
    print_campaign(&r, &a.out, true);
    Ok(())
}
