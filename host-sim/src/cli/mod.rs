//! The commands of `host-sim`, one module each: its options (`clap` derive) and an `execute`
//! that runs it and prints its echo. The files a command writes are its results; the echo on
//! standard output is informational.

use std::path::Path;

use clap::Args;
use consensus_plot::error::Result;
use consensus_sim::scenario::{self, Setup};
use host_sim::campaign::SweepReport;

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
pub mod graph;
pub mod merge;
pub mod monitor;
pub mod nodes;
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

/// A command-line error of clap as the lines `invalid option: <option>: <reason>` of
/// docs/SCENARIO.md §1 (one per missing option), instead of clap's usage block.
pub fn option_errors(e: &clap::Error) -> Vec<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    let ctx = |k| match e.get(k) {
        Some(ContextValue::String(s)) => vec![s.clone()],
        Some(ContextValue::Strings(v)) => v.clone(),
        _ => Vec::new(),
    };
    let first = |k| ctx(k).into_iter().next().unwrap_or_default();
    // `--out <OUT>` names the option `--out`; a positional `<SCENARIO>` stays as it is.
    let name = |a: String| match a.split_once(' ') {
        Some((opt, _)) if opt.starts_with('-') => opt.to_string(),
        _ => a,
    };
    let arg = || name(first(ContextKind::InvalidArg));
    let line = |opt: String, why: String| format!("invalid option: {opt}: {why}");
    let suggestion = || {
        let s = first(ContextKind::SuggestedArg);
        let s = if s.is_empty() {
            first(ContextKind::SuggestedSubcommand)
        } else {
            s
        };
        if s.is_empty() {
            String::new()
        } else {
            format!(" (did you mean {s}?)")
        }
    };
    match e.kind() {
        ErrorKind::MissingRequiredArgument => ctx(ContextKind::InvalidArg)
            .into_iter()
            .map(|a| line(name(a), "missing (required)".into()))
            .collect(),
        ErrorKind::UnknownArgument => vec![line(arg(), format!("unknown option{}", suggestion()))],
        ErrorKind::InvalidSubcommand => vec![line(
            first(ContextKind::InvalidSubcommand),
            format!("unknown command{} (see host-sim --help)", suggestion()),
        )],
        ErrorKind::InvalidValue => {
            let valid = ctx(ContextKind::ValidValue);
            let why = if valid.is_empty() {
                "a value is required".to_string()
            } else {
                format!("expected one of {}", valid.join(", "))
            };
            vec![line(
                arg(),
                format!("`{}`: {why}", first(ContextKind::InvalidValue)),
            )]
        }
        ErrorKind::ValueValidation => {
            let why = std::error::Error::source(e).map_or_else(String::new, |s| s.to_string());
            vec![line(
                arg(),
                format!("`{}`: {why}", first(ContextKind::InvalidValue)),
            )]
        }
        ErrorKind::ArgumentConflict => vec![line(
            arg(),
            format!("cannot be used with {}", name(first(ContextKind::PriorArg))),
        )],
        ErrorKind::MissingSubcommand | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            vec![line(
                "command".into(),
                "missing (see host-sim --help)".into(),
            )]
        }
        _ => {
            let text = e.render().to_string();
            let why = text
                .lines()
                .next()
                .unwrap_or_default()
                .trim_start_matches("error: ")
                .to_string();
            let opt = arg();
            vec![line(
                if opt.is_empty() {
                    "command".into()
                } else {
                    opt
                },
                why,
            )]
        }
    }
}
