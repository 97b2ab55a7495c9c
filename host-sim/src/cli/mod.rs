//! The commands of `host-sim`, one module each: its options (`clap` derive) and an `execute`
//! that runs it and prints its echo. The files a command writes are its results; the echo on
//! standard output is informational.

use std::path::Path;

use clap::Args;
use host_sim::{
    campaign::SweepReport,
    error::Result,
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

pub mod check;
pub mod compare;
pub mod fault_matrix;
pub mod merge;
pub mod run;
pub mod stable_h;
pub mod sweep;

/// `--set KEY=VALUE`, shared by the commands that read a scenario.
#[derive(Args, Debug, Clone)]
pub struct Overrides {
    /// Override a scenario key: dotted key and TOML value (repeatable), e.g. controller.ts=1
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

/// The scenario at `path` with `o` applied; notes on standard error when the file sets no key.
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

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "none".into(), |v| format!("{v:.4}"))
}

/// The echo of `sweep` and `merge`.
fn print_campaign(r: &SweepReport, out: &Path, merged: bool) {
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
