//! `host-sim fault-matrix`: a CAN scenario under every cell of the fault matrix.

use std::path::PathBuf;

use clap::Args;
use consensus_plot::error::{Error, Result};
use host_sim::{matrix, report};

use crate::cli::{load, Overrides};

/// Options of `fault-matrix`.
#[derive(Args, Debug)]
pub struct FaultMatrixArgs {
    /// Scenario file (TOML) with [network] kind = "can".
    scenario: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Runs the matrix; writes `matrix.md`, `matrix.json`, `matrix.png` and prints the table.
pub fn execute(a: FaultMatrixArgs) -> Result<()> {
    let setup = load(&a.scenario, &a.overrides)?;
    let s = &setup.scenario;
    let (t_f, _) = matrix::timing(s.controller.ts);
    let cells = matrix::cells(setup.agents(), t_f);
    let results = matrix::run_matrix(s, &cells, true)?;
    let two_ts = setup.predefined_time();
    let u_max = s.safety.enabled.then_some(s.safety.u_max).flatten();
    let table = matrix::markdown(&results, two_ts, u_max);
    let out = &a.out;
    report::create_dir(out)?;
    report::write_atomic(&out.join("matrix.md"), table.as_bytes())?;
    let json = serde_json::to_string_pretty(&results)
        .map_err(|e| Error::Io(format!("matrix.json: {e}")))?;
    report::write_atomic(&out.join("matrix.json"), format!("{json}\n").as_bytes())?;
    let title = format!("{}: fault matrix", setup.figure_title());
    let text = matrix::FigureText {
        title: &title,
        two_ts,
        units: setup.plant.units(),
    };
    matrix::draw(out, setup.figures(), &results, u_max, text)?;
    out!("{table}");
    outln!("wrote {}", out.display());
    Ok(())
}
