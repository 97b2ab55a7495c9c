//! `host-sim`: run, check, search the stable sample period, compare, campaigns (docs/SCENARIO.md).
//! Argument parsing and dispatch; each command lives in its own module under `cli/`.

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use consensus_plot::error::Result;
use host_sim::report;

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
  host-sim run scenarios/example1-socketcan.toml --out out/sc --trace out/sc/vcan0.log
  host-sim monitor vcan0 --dbc docs/wire.dbc

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

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Run one scenario; writes summary.json, trajectory.csv and plots into --out.
    Run(cli::run::RunArgs),
    /// Validate a scenario and print it resolved (defaults filled, overrides applied).
    Check(cli::check::CheckArgs),
    /// Find the largest stable sample period h by bisection (geometric) over [h-min, h-max].
    ///
    /// A run is stable when it does not diverge and its max error after 2Ts is within --band.
    StableH(cli::stable_h::StableHArgs),
    /// Fault matrix of a CAN scenario: silent neighbour / leader, babbling nodes, frame loss,
    /// corruption, NaN sensor bursts, stuck actuators; each with [safety] as given and off.
    ///
    /// Writes matrix.md, matrix.json and matrix.png into --out (docs/RELIABILITY.md §4).
    FaultMatrix(cli::fault_matrix::FaultMatrixArgs),
    /// Run two scenarios; write one table (compare.md, compare.json) and overlaid plots.
    Compare(cli::compare::CompareArgs),
    /// Run a campaign (grid axes, Monte Carlo draws) in parallel into results.csv; resumable.
    Sweep(cli::sweep::SweepArgs),
    /// Combine the directories of all shards of a campaign into one (as an unsharded sweep).
    Merge(cli::merge::MergeArgs),
    /// Draw the scenario's communication graph (followers, links, leader pinning) into --out.
    Graph(cli::graph::GraphArgs),
    /// Live table of a CAN bus running the product: per agent y, x, q, frame rates, node
    /// state (heartbeat); error frames.
    Monitor(cli::monitor::MonitorArgs),
    /// Write each follower's node file (agent-<i>.toml, for node-linux) and CANopen EDS
    /// (agent-<i>.eds) into --out without running the scenario.
    Nodes(cli::nodes::NodesArgs),
}

fn dispatch(cmd: Cmd) -> Result<()> {
    match cmd {
        Cmd::Run(a) => cli::run::execute(a),
        Cmd::Check(a) => cli::check::execute(a),
        Cmd::StableH(a) => cli::stable_h::execute(a),
        Cmd::FaultMatrix(a) => cli::fault_matrix::execute(a),
        Cmd::Compare(a) => cli::compare::execute(a),
        Cmd::Sweep(a) => cli::sweep::execute(a),
        Cmd::Merge(a) => cli::merge::execute(a),
        Cmd::Graph(a) => cli::graph::execute(a),
        Cmd::Monitor(a) => cli::monitor::execute(a),
        Cmd::Nodes(a) => cli::nodes::execute(a),
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            for line in cli::option_errors(&e) {
                eprintln!("host-sim: {line}");
            }
            return ExitCode::from(2);
        }
    };
    if let Err(e) = report::remove_temp_files_on_interrupt() {
        eprintln!("host-sim: note: {e}; an interrupted run may leave .*.tmp.* files behind");
    }
    match dispatch(cli.cmd) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            for line in e.to_string().lines() {
                eprintln!("host-sim: {line}");
            }
            ExitCode::from(e.exit_code())
        }
    }
}
