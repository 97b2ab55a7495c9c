//! `host-sim`: run, check, search the stable sample period, compare, campaigns (docs/SCENARIO.md).

use std::{
    path::{Path, PathBuf},
    process::ExitCode,
};

use clap::{Args, Parser, Subcommand};
use host_sim::{
    campaign::{self, Shard},
    compare::compare,
    error::{Error, Result},
    matrix,
    report::{
        self,
        csv::{check_size_of, default_decimate, estimated_size_of, human_bytes, parse_agents},
        fmt_time,
    },
    run::{run, stable_h, RunOptions},
    scenario::{self, Setup},
};

/// `println!` that ignores a closed standard output (`host-sim check … | head -1`): the echo is
/// informational, the files are the results, and a closed pipe must not panic the process.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// `print!` that ignores a closed standard output (see [`outln`]).
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}

const EXAMPLES: &str = "\
Examples:
  host-sim run scenarios/example1.toml --out out/example1
  host-sim run scenarios/example1.toml --out out/ts1 --set controller.ts=1 --decimate 10
  host-sim run scenarios/example1-can.toml --out out/can --trace out/can/bus.log
  host-sim check scenarios/example2.toml --set simulation.h=2e-4
  host-sim stable-h scenarios/example2.toml --band 0.1
  host-sim compare scenarios/example2.toml scenarios/example2-baseline.toml --out out/cmp
  host-sim sweep campaigns/example1-ts-h.toml --out out/map1
  host-sim sweep campaigns/example1-ts-h.toml --out out/s2 --shard 2/4
  host-sim merge out/s1 out/s2 out/s3 out/s4 --out out/map1

Exit status: 0 run finished (also when it diverged: see summary.json), 2 bad input (invalid
scenario or option, missing scenario file), 1 I/O error, 130 interrupted (temporary files are
removed). Keys, units and outputs: docs/SCENARIO.md.";

/// Closed-loop simulator of the predefined-time consensus controller (controller-core).
#[derive(Parser, Debug)]
#[command(name = "host-sim", version, about, after_help = EXAMPLES)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Args, Debug, Clone)]
struct Overrides {
    /// Override a scenario key: dotted key and TOML value (repeatable), e.g. controller.ts=1
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Run one scenario; writes summary.json, trajectory.csv and plots into --out.
    Run {
        /// Scenario file (TOML).
        scenario: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
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
    },
    /// Validate a scenario and print it resolved (defaults filled, overrides applied).
    Check {
        /// Scenario file (TOML).
        scenario: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Find the largest stable sample period h by bisection (geometric) over [h-min, h-max].
    ///
    /// A run is stable when it does not diverge and its max error after 2Ts is within --band.
    StableH {
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
    },
    /// Fault matrix of a CAN scenario: silent neighbour / leader, babbling nodes, frame loss,
    /// corruption, NaN sensor bursts, stuck actuators; each with [safety] as given and off.
    ///
    /// Writes matrix.md, matrix.json and matrix.png into --out (docs/RELIABILITY.md §4).
    FaultMatrix {
        /// Scenario file (TOML) with [network] kind = "can".
        scenario: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        overrides: Overrides,
    },
    /// Run two scenarios; write one table (compare.md, compare.json) and overlaid plots.
    Compare {
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
    },
    /// Run a campaign (grid axes, Monte Carlo draws) in parallel into results.csv; resumable.
    Sweep {
        /// Campaign file (TOML); its scenario path is relative to it.
        campaign: PathBuf,
        /// Output directory (results.csv, campaign.json, runs.journal, figures).
        #[arg(long)]
        out: PathBuf,
        /// Run only shard k of N (runs with run mod N = k - 1); combine with `merge`.
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// No progress bar, no summary on stdout.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Combine the directories of all shards of a campaign into one (as an unsharded sweep).
    Merge {
        /// Shard output directories.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
}

fn print_campaign(r: &campaign::SweepReport, out: &Path, merged: bool) {
    if merged {
        outln!(
            "{} runs merged: {} diverged, {} invalid",
            r.runs,
            r.diverged,
            r.invalid
        );
    } else {
        outln!(
            "{} runs ({} resumed from the journal, {} run now): {} diverged, {} invalid",
            r.runs,
            r.resumed,
            r.ran,
            r.diverged,
            r.invalid
        );
    }
    for f in &r.figures {
        outln!("figure {}", f.display());
    }
    outln!("wrote {}", out.join("results.csv").display());
}

fn load(path: &Path, o: &Overrides) -> Result<Setup> {
    let setup = scenario::load(path, &o.set)?;
    let empty = std::fs::read_to_string(path)
        .is_ok_and(|t| t.parse::<toml::Table>().is_ok_and(|t| t.is_empty()));
    if empty {
        eprintln!(
            "host-sim: note: {} sets no keys: every key takes its default (Example 1, name \
             \"{}\"; docs/SCENARIO.md §2)",
            path.display(),
            setup.scenario.name
        );
    }
    Ok(setup)
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

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "none".into(), |v| format!("{v:.4}"))
}

fn main_inner(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Run {
            scenario,
            out,
            overrides,
            decimate,
            agents,
            threads,
            no_plots,
            quiet,
            force,
            trace,
            link_trace,
        } => {
            if decimate == Some(0) {
                return Err(Error::invalid("--decimate", "must be >= 1"));
            }
            if let Some(n) = threads {
                set_threads(n)?;
            }
            let setup = load(&scenario, &overrides)?;
            let agents = agents
                .map(|list| parse_agents(&list, setup.agents()))
                .transpose()?;
            let columns = agents.as_ref().map_or(setup.agents(), Vec::len);
            let decimate = match decimate {
                Some(k) => k,
                None => {
                    let k = default_decimate(&setup, columns);
                    if k > 1 {
                        eprintln!(
                            "host-sim: note: {} agents: trajectory.csv keeps one sample in {k} \
                             (--decimate {k}, about {}); --decimate 1 keeps every sample, \
                             --agents a subset of the columns",
                            setup.agents(),
                            human_bytes(estimated_size_of(&setup, k, columns)),
                        );
                    }
                    k
                }
            };
            if !force {
                check_size_of(&setup, decimate, columns)?;
            }
            let opts = RunOptions {
                out: Some(out.clone()),
                decimate,
                agents,
                plots: !no_plots,
                record: false,
                progress: !quiet,
                trace,
                link_trace,
                worst: false,
            };
            let r = run(&setup, &opts)?;
            if !quiet {
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
                outln!("wrote {}", out.display());
            }
            Ok(())
        }
        Cmd::Check {
            scenario,
            overrides,
        } => {
            let setup = load(&scenario, &overrides)?;
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
        Cmd::StableH {
            scenario,
            overrides,
            band,
            h_min,
            h_max,
            rel_tol,
            quiet,
        } => {
            let setup = load(&scenario, &overrides)?;
            let r = stable_h(&setup.scenario, band, h_min, h_max, rel_tol, |t| {
                if !quiet {
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
        Cmd::FaultMatrix {
            scenario,
            out,
            overrides,
        } => {
            let setup = load(&scenario, &overrides)?;
            let s = &setup.scenario;
            let (t_f, _) = matrix::timing(s.controller.ts);
            let cells = matrix::cells(setup.agents(), t_f);
            let results = matrix::run_matrix(s, &cells, true)?;
            let two_ts = setup.predefined_time();
            let u_max = s.safety.enabled.then_some(s.safety.u_max).flatten();
            let table = matrix::markdown(&results, two_ts, u_max);
            report::create_dir(&out)?;
            report::write_atomic(&out.join("matrix.md"), table.as_bytes())?;
            let json = serde_json::to_string_pretty(&results)
                .map_err(|e| Error::Io(format!("matrix.json: {e}")))?;
            report::write_atomic(&out.join("matrix.json"), format!("{json}\n").as_bytes())?;
            matrix::draw(&out.join("matrix.png"), &results, two_ts, u_max, &s.name)?;
            out!("{table}");
            outln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Compare {
            a,
            b,
            out,
            overrides,
            quiet,
        } => {
            let sa = load(&a, &overrides)?;
            let sb = load(&b, &overrides)?;
            let table = compare(&sa, &sb, &out, !quiet)?;
            out!("{table}");
            outln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Sweep {
            campaign,
            out,
            shard,
            quiet,
        } => {
            let shard = shard.as_deref().map_or(Ok(Shard::ALL), Shard::parse)?;
            let started = std::time::Instant::now();
            let r = campaign::sweep(&campaign, &out, shard, !quiet)?;
            if !quiet {
                print_campaign(&r, &out, false);
                let s = started.elapsed().as_secs_f64();
                outln!("{:.1} s, {:.1} runs/s", s, r.ran as f64 / s.max(1e-9));
            }
            Ok(())
        }
        Cmd::Merge { dirs, out } => {
            let r = campaign::merge(&dirs, &out)?;
            print_campaign(&r, &out, true);
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    if let Err(e) = report::remove_temp_files_on_interrupt() {
        eprintln!("host-sim: note: {e}; an interrupted run may leave .*.tmp.* files behind");
    }
    match main_inner(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
