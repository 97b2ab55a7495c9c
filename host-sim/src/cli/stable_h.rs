//! `host-sim stable-h`: the largest stable sample period by geometric bisection.

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::Result;
use host_sim::{report::fmt_time, run::stable_h};

use crate::cli::{fmt_opt, load, Overrides};

/// Options of `stable-h`.
#[derive(Args, Debug)]
pub struct StableHArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
    /// Error band after 2Ts that counts as stable.
    #[arg(long, default_value_t = 0.25, allow_hyphen_values = true)]
    band: f64,
    /// Smallest h tried [s].
    #[arg(long, default_value_t = 1e-5, allow_hyphen_values = true)]
    h_min: f64,
    /// Largest h tried [s].
    #[arg(long, default_value_t = 1e-2, allow_hyphen_values = true)]
    h_max: f64,
    /// Stop when h_unstable / h_stable < 1 + rel-tol.
    #[arg(long, default_value_t = 0.02, allow_hyphen_values = true)]
    rel_tol: f64,
    /// Print only the result.
    #[arg(long, short)]
    quiet: bool,
}

/// Bisects `h`, printing each trial unless `--quiet`, then the result.
pub fn execute(a: StableHArgs) -> Result<()> {
    let setup = load(&a.scenario, &a.overrides)?;
    let (band, h_min) = (a.band, a.h_min);
    let r = stable_h(&setup.scenario, band, h_min, a.h_max, a.rel_tol, |t| {
        if !a.quiet {
            outln!(
                "h = {:.4e}: {}, max error after 2Ts = {}{}",
                t.h,
                if t.stable { "stable" } else { "unstable" },
                fmt_opt(t.max_error_after_predefined_time),
                t.diverged_at.map_or(String::new(), |d| format!(
                    ", diverged at t = {}",
                    fmt_time(d)
                ))
            );
        }
    })?;
    match (r.largest_stable_h, r.smallest_unstable_h) {
        (Some(s), Some(u)) => {
            outln!("largest stable h = {s:.4e} s (unstable at {u:.4e} s; band {band})")
        }
        (Some(s), None) => outln!("stable at h-max = {s:.4e} s (band {band})"),
        (None, _) => outln!("unstable even at h-min = {h_min:.4e} s (band {band})"),
    }
    Ok(())
}
