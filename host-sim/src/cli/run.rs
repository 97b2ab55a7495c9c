//! `host-sim run`: one scenario into `summary.json`, `trajectory.csv` and the figures.

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::{Error, Result};
use host_sim::{
    report::{csv::Format, fmt_time},
    run::{run, RunRequest},
};

use crate::cli::{fmt_opt, load, Overrides};

/// Options of `run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
    /// Trajectory file: trajectory.csv, or trajectory.parquet (same columns and values).
    #[arg(long, default_value = "csv", value_parser = ["csv", "parquet"])]
    format: String,
    /// Write every k-th sample to trajectory.csv [default: 1; above 8 agents, the smallest
    /// K that keeps the file within 100 MB].
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    decimate: Option<u64>,
    /// Columns of these agents only in trajectory.csv: 1-based numbers and ranges, e.g.
    /// 1,5,10-20 [default: all].
    #[arg(long, value_name = "LIST")]
    agents: Option<String>,
    /// Worker threads for stepping a large group (256 agents or more) [default: one per
    /// core, or RAYON_NUM_THREADS]; the results are the same at any count.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    threads: Option<usize>,
    /// Skip the figures.
    #[arg(long)]
    no_plots: bool,
    /// No progress bar, no summary on stdout.
    #[arg(long, short)]
    quiet: bool,
    /// Write trajectory.csv even when it is estimated above the size limit (2 GiB).
    #[arg(long)]
    force: bool,
    /// Write every frame on the bus to this file, candump log format (network.kind = "can"
    /// or "pil"); docs/wire.dbc decodes it.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// Write everything on each node's serial link to this file, candump log format
    /// (network.kind = "pil"); docs/wire.dbc decodes it.
    #[arg(long, value_name = "FILE")]
    link_trace: Option<PathBuf>,
}

/// `--threads N`: rayon's global pool with `N` workers (set before anything runs in it).
fn set_threads(n: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::invalid("--threads", "must be >= 1"));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| Error::invalid("--threads", e.to_string()))
}

/// Runs the scenario; prints its summary unless `--quiet`.
pub fn execute(a: RunArgs) -> Result<()> {
    if let Some(n) = a.threads {
        set_threads(n)?;
    }
    let setup = load(&a.scenario, &a.overrides)?;
    let opts = RunRequest {
        out: Some(a.out.clone()),
        format: Format::from_name(&a.format)?,
        decimate: a.decimate,
        agents: a.agents,
        table: false,
        plots: !a.no_plots,
        progress: !a.quiet,
        force: a.force,
        trace: a.trace,
        link_trace: a.link_trace,
    }
    .options(&setup)?;
    let r = run(&setup, &opts)?;
    // The outputs are written; a bench whose node was lost still fails (exit 3).
    let lost = lost_nodes(&r.summary);
    if a.quiet {
        return lost;
    }
    let s = &r.summary;
    outln!(
        "{}: c1 = {:.3}, c2 = {:.3}; max error after 2Ts = {}; settling time ({}) = {}; \
         max |u| = {:.3}; {}",
        s.scenario,
        s.c1,
        s.c2,
        fmt_opt(s.max_error_after_predefined_time),
        s.settle_band,
        fmt_opt(s.settling_time),
        s.max_abs_u,
        match s.divergence {
            Some(d) => format!("DIVERGED at t = {} (agent {})", fmt_time(d.time), d.agent),
            None => "no divergence".into(),
        }
    );
    if let Some(n) = &s.network {
        outln!(
            "network: {} at {} bit/s; bus load {:.2} %; frames sent {}, lost {}, \
             corrupted {}; deadline misses {}; bus-off events {}; age of data used \
             max {:.4} s, mean {:.4} s",
            n.kind,
            n.bitrate,
            n.bus_load_percent,
            n.frames_sent,
            n.frames_lost,
            n.frames_corrupted,
            n.deadline_misses,
            n.bus_off_events,
            n.max_age_s,
            n.mean_age_s
        );
    }
    outln!("wrote {}", a.out.display());
    lost
}

/// `Err` (exit 3) naming every follower of a bench on a real bus that was lost at the end of
/// the run (`socketcan.agents[].state = "lost"`).
fn lost_nodes(s: &consensus_sim::metrics::Summary) -> Result<()> {
    let Some(sc) = &s.socketcan else {
        return Ok(());
    };
    let lost: Vec<String> = sc
        .agents
        .iter()
        .filter(|a| a.state == Some("lost"))
        .map(|a| {
            format!(
                "agent {} lost at t = {:.3} s",
                a.agent,
                a.lost_at_s.unwrap_or(f64::NAN)
            )
        })
        .collect();
    if lost.is_empty() {
        Ok(())
    } else {
        Err(consensus_plot::error::Error::Bench(format!(
            "{} (the plant applied network.lost_command to it; outputs written)",
            lost.join(", ")
        )))
    }
}
