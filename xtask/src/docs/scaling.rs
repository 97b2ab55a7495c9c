//! Figures of docs/SCALING.md: the tracking error of a line of followers against its length
//! (`scaling.line`, `scaling.line.per-follower`), other generated graphs (`scaling.run.NAME`),
//! the swarm's graph (`scaling.graph.KEY`) and its trajectory file (`scaling.file.KEY`).

use std::{fs, path::Path, process::Command};

use serde_json::Value;

use super::{fixed, grouped, num, run, Sources};
use crate::task::{workspace_root, Result};

/// Lengths of the line in the table.
const LINE: [usize; 6] = [1, 2, 3, 4, 6, 10];

/// A named run: scenario file, `--set`s and other options.
type Run = (
    &'static str,
    &'static str,
    &'static [&'static str],
    &'static [&'static str],
);

/// Named runs.
const RUNS: [Run; 5] = [
    (
        "star-50",
        "line",
        &["graph.generator=\"star\"", "graph.agents=50"],
        &[],
    ),
    (
        "random-50",
        "line",
        &[
            "graph.generator=\"random\"",
            "graph.agents=50",
            "graph.extra_edges=0",
        ],
        &[],
    ),
    (
        "random-50-links",
        "line",
        &[
            "graph.generator=\"random\"",
            "graph.agents=50",
            "graph.extra_edges=100",
        ],
        &[],
    ),
    ("swarm", "swarm-1000", &[], &[]),
    ("swarm-three", "swarm-1000", &[], &["--agents", "1,5,500"]),
];

/// Keys of `scaling.graph.KEY` (the swarm's `graph.json`).
pub const GRAPH_KEYS: [&str; 3] = ["hops_max", "hops_mean", "in_degree_max"];
/// Keys of `scaling.file.KEY`: the swarm's decimation `K`, kept rows, `trajectory.csv` in MB,
/// what every sample would take in GB, and MB of the file of followers 1, 5 and 500 only.
pub const FILE_KEYS: [&str; 5] = [
    "decimate",
    "rows",
    "mb",
    "every-sample-gb",
    "three-agents-mb",
];

/// Whether `name` is a run of [`RUNS`] or `line-N`.
pub fn known_run(name: &str) -> bool {
    RUNS.iter().any(|r| r.0 == name) || line_length(name).is_some()
}

fn line_length(name: &str) -> Option<usize> {
    let n: usize = name.strip_prefix("line-")?.parse().ok()?;
    LINE.contains(&n).then_some(n)
}

/// `summary.json` of run `name` in `target/docs/scaling/<name>/`.
fn summary(src: &mut Sources, name: &str) -> Result<Value> {
    let (file, sets, options): (&str, Vec<String>, &[&str]) = match line_length(name) {
        Some(n) => ("line", vec![format!("graph.agents={n}")], &[]),
        None => {
            let r = RUNS
                .iter()
                .find(|r| r.0 == name)
                .ok_or_else(|| format!("no scaling run `{name}`"))?;
            (r.1, r.2.iter().map(|s| (*s).to_owned()).collect(), r.3)
        }
    };
    let path = format!("target/docs/scaling/{name}/summary.json");
    src.json_file(&path, |s, out| {
        let mut args: Vec<&str> = sets.iter().flat_map(|set| ["--set", set]).collect();
        args.extend(options);
        s.run_scenario(file, &args, out.parent().unwrap_or(out))
    })
}

fn max_error(s: &Value) -> Result<f64> {
    num(s, "max_error_after_predefined_time")
}

/// `scaling.line`: the error after `2 T_s` per length of the line.
pub fn line_table(src: &mut Sources) -> Result<String> {
    let mut head = String::from("| followers in the line |");
    let mut rule = String::from("|---|");
    let mut row = String::from("| `max_error_after_predefined_time` |");
    for n in LINE {
        let e = max_error(&summary(src, &format!("line-{n}"))?)?;
        head += &format!(" {n} |");
        rule += "---|";
        row += &format!(" {} |", fixed(e, 3));
    }
    Ok(format!("{head}\n{rule}\n{row}"))
}

/// `scaling.line.per-follower`: the error added per follower from 1 to 10.
pub fn line_per_follower(src: &mut Sources) -> Result<String> {
    let first = max_error(&summary(src, "line-1")?)?;
    let last = max_error(&summary(src, "line-10")?)?;
    Ok(fixed((last - first) / 9.0, 2))
}

/// `scaling.run.NAME`: the error after `2 T_s` of a run.
pub fn run_figure(src: &mut Sources, name: &str) -> Result<String> {
    Ok(fixed(max_error(&summary(src, name)?)?, 2))
}

/// `scaling.graph.KEY`: from the swarm's `graph.json`.
pub fn graph_figure(src: &mut Sources, key: &str) -> Result<String> {
    let g = src.json_file("target/docs/scaling/swarm-graph/graph.json", |s, out| {
        let bin = s.host_sim()?;
        run(Command::new(bin)
            .current_dir(workspace_root())
            .args(["graph", "scenarios/swarm-1000.toml", "--out"])
            .arg(out.parent().unwrap_or(out)))
        .map(|_| ())
    })?;
    let x = num(&g, key)?;
    Ok(if key == "hops_mean" {
        fixed(x, 1)
    } else {
        grouped(x, 0)
    })
}

fn bytes(p: &Path) -> Result<f64> {
    fs::metadata(p)
        .map(|m| m.len() as f64)
        .map_err(|e| format!("{}: {e}", p.display()))
}

/// `scaling.file.KEY`: the swarm's trajectory file.
pub fn file_figure(src: &mut Sources, key: &str) -> Result<String> {
    let swarm = summary(src, "swarm")?;
    let csv = workspace_root().join("target/docs/scaling/swarm/trajectory.csv");
    let size = bytes(&csv)?;
    let rows = || -> Result<usize> {
        let text = fs::read_to_string(&csv).map_err(|e| format!("{}: {e}", csv.display()))?;
        Ok(text.lines().count().saturating_sub(1))
    };
    let samples = num(&swarm, "samples")?;
    Ok(match key {
        "decimate" => grouped((samples / rows()?.max(1) as f64).round(), 0),
        "rows" => grouped(rows()? as f64, 0),
        "mb" => fixed(size / 1e6, 1),
        "every-sample-gb" => fixed(size / 1e9 * samples / rows()?.max(1) as f64, 1),
        "three-agents-mb" => {
            summary(src, "swarm-three")?;
            let p = workspace_root().join("target/docs/scaling/swarm-three/trajectory.csv");
            fixed(bytes(&p)? / 1e6, 1)
        }
        other => return Err(format!("no figure scaling.file.{other}")),
    })
}
