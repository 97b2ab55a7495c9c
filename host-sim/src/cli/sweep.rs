//! `host-sim sweep`: a campaign (or one shard of it) into `results.csv`.

use std::{path::PathBuf, time::Instant};

use clap::Args;
use consensus_plot::error::Result;
use host_sim::{
    campaign::{self, Shard, SweepOptions},
    report::csv::Format,
};

use crate::cli::print_campaign;

/// Options of `sweep`.
#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Campaign file (TOML); its scenario path is relative to it.
    campaign: PathBuf,
    /// Output directory (results.csv, campaign.json, runs.journal, figures).
    #[arg(long)]
    out: PathBuf,
    /// Also write results.parquet (same columns and values as results.csv, which stays).
    #[arg(long, default_value = "csv", value_parser = ["csv", "parquet"])]
    format: String,
    /// Run only shard k of N (runs with run mod N = k - 1); combine with `merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// No progress bar, no summary on stdout.
    #[arg(long, short)]
    quiet: bool,
}

/// Runs the campaign; prints its counts and throughput unless `--quiet`.
pub fn execute(a: SweepArgs) -> Result<()> {
    let shard = a.shard.as_deref().map_or(Ok(Shard::ALL), Shard::parse)?;
    let started = Instant::now();
    let opts = SweepOptions {
        progress: !a.quiet,
        format: Format::from_name(&a.format)?,
        ..SweepOptions::default()
    };
    let r = campaign::sweep_with(&a.campaign, &a.out, shard, &opts)?;
    if !a.quiet {
        print_campaign(&r, &a.out, false);
        let s = started.elapsed().as_secs_f64();
        outln!("{:.1} s, {:.1} runs/s", s, r.ran as f64 / s.max(1e-9));
    }
    Ok(())
}
