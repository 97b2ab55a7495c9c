//! `cargo xtask docs`: every figure of `README.md` and `docs/*.md` that a command measures sits
//! between `<!-- fig:NAME -->` and `<!-- /fig:NAME -->` and is rewritten from the files that
//! command writes; `--check` compares instead of writing and names every block that differs.
//!
//! A block's body is replaced verbatim: a body that starts on the marker's line is an inline
//! figure (`<!-- fig:bench.libm-n2m2.median -->1,089<!-- /fig:bench.libm-n2m2.median -->`), one
//! that starts on the next line a block (a table). Names are listed by `cargo xtask docs --list`.
//! A marker is a marker wherever it stands, code spans included: prose about markers names them
//! without the comment syntax.
//!
//! Each figure has a source: a file a CI step already writes (`target/bench/step.json`,
//! `target/fault-matrix/*/matrix.json`, `target/torque-limit/torque-limit.json`,
//! `target/ci-pil/pil/summary.json`, `out/campaigns/*/results.csv`) or one this task writes
//! under `target/docs/` by running the command; an existing file is reused (so CI runs nothing twice) unless `--rerun` is given.
//! Wall-clock figures (`wall.*`) depend on the machine: they carry the date and the machine,
//! are skipped by `--check` and rewritten only with `--wall-clock`.

use crate::task::{cargo, workspace_root, Options, Result};
use object::{Object, ObjectSection};
use serde_json::Value;
use std::{
    collections::{BTreeMap, HashSet},
    fmt::Write as _,
    fs,
    ops::Range,
    path::{Path, PathBuf},
    process::Command,
    time::Instant,
};

mod back_end;
mod claims;
mod clocks;
mod cores;
mod images;
mod network;
mod reliability;
mod scaling;

const OPEN: &str = "<!-- fig:";
const CLOSE: &str = "<!-- /fig:";
const END: &str = " -->";

/// One marked figure in a document.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub name: String,
    /// Byte range of the body between the two markers.
    pub body: Range<usize>,
    /// 1-based line of the opening marker.
    pub line: usize,
}

/// The marked blocks of `text`, in order; unclosed, mismatched or nested markers are errors.
pub fn blocks(text: &str) -> Result<Vec<Block>> {
    let line_of = |at: usize| text[..at].matches('\n').count() + 1;
    let mut out = Vec::new();
    let mut open: Option<(String, usize, usize)> = None;
    let mut pos = 0;
    while let Some(k) = text[pos..].find("<!-- ") {
        let at = pos + k;
        let rest = &text[at..];
        let (closing, prefix) = if rest.starts_with(OPEN) {
            (false, OPEN)
        } else if rest.starts_with(CLOSE) {
            (true, CLOSE)
        } else {
            pos = at + 1;
            continue;
        };
        let name_end = rest
            .find(END)
            .ok_or_else(|| format!("line {}: marker without `-->`", line_of(at)))?;
        let name = rest[prefix.len()..name_end].trim();
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(format!("line {}: bad figure name `{name}`", line_of(at)));
        }
        let after = at + name_end + END.len();
        match (closing, open.take()) {
            (false, None) => open = Some((name.to_owned(), after, line_of(at))),
            (false, Some((outer, _, l))) => {
                return Err(format!(
                    "line {}: `fig:{name}` opens inside `fig:{outer}` (opened at line {l})",
                    line_of(at)
                ))
            }
            (true, None) => {
                return Err(format!(
                    "line {}: `/fig:{name}` closes no open block",
                    line_of(at)
                ))
            }
            (true, Some((outer, start, l))) if outer == name => out.push(Block {
                name: outer,
                body: start..at,
                line: l,
            }),
            (true, Some((outer, _, l))) => {
                return Err(format!(
                    "line {}: `/fig:{name}` closes `fig:{outer}` (opened at line {l})",
                    line_of(at)
                ))
            }
        }
        pos = after;
    }
    match open {
        Some((name, _, l)) => Err(format!("line {l}: `fig:{name}` is never closed")),
        None => Ok(out),
    }
}

/// What rewriting one document found.
#[derive(Debug, Default, PartialEq)]
pub struct Rewrite {
    pub text: String,
    /// Blocks whose body changed: name, line, old body, new body.
    pub changed: Vec<(String, usize, String, String)>,
    /// Wall-clock blocks left as they were.
    pub skipped: usize,
}

/// Rewrites every block of `text` with `render` (`Ok(None)`: no such figure, an error);
/// blocks for which `keep` holds are left unchanged.
pub fn rewrite(
    text: &str,
    keep: impl Fn(&str) -> bool,
    mut render: impl FnMut(&str) -> Result<Option<String>>,
) -> Result<Rewrite> {
    let mut r = Rewrite::default();
    let mut last = 0;
    for b in blocks(text)? {
        let old = &text[b.body.clone()];
        r.text.push_str(&text[last..b.body.start]);
        last = b.body.end;
        if keep(&b.name) {
            r.skipped += 1;
            r.text.push_str(old);
            continue;
        }
        let figure = render(&b.name)
            .map_err(|e| format!("line {}: `fig:{}`: {e}", b.line, b.name))?
            .ok_or_else(|| format!("line {}: unknown figure block `fig:{}`", b.line, b.name))?;
        let new = if old.starts_with('\n') {
            format!("\n{}\n", figure.trim_end_matches('\n'))
        } else {
            figure
        };
        if new != old {
            r.changed
                .push((b.name.clone(), b.line, old.to_owned(), new.clone()));
        }
        r.text.push_str(&new);
    }
    r.text.push_str(&text[last..]);
    Ok(r)
}

/// `README.md` and `docs/*.md`, relative to the workspace root.
fn documents(root: &Path) -> Result<Vec<PathBuf>> {
    let mut files = vec![PathBuf::from("README.md")];
    let mut docs: Vec<PathBuf> = fs::read_dir(root.join("docs"))
        .map_err(|e| format!("docs/: {e}"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .filter_map(|p| p.strip_prefix(root).ok().map(Path::to_path_buf))
        .collect();
    docs.sort();
    files.extend(docs);
    Ok(files)
}

/// The `docs` task.
pub fn docs(opts: &Options) -> Result<()> {
    if opts.list {
        for (name, what) in CATALOGUE {
            println!("{name:<22} {what}");
        }
        return Ok(());
    }
    let mut src = Sources::new(opts.rerun);
    // `--only docs/X.md` handles one document; `--only NAME` one figure, wherever it is quoted.
    let only_file = opts.only.as_deref().filter(|o| o.ends_with(".md"));
    let only_figure = opts.only.as_deref().filter(|o| !o.ends_with(".md"));
    let keep = |name: &str| {
        name == REPRODUCTION_TIME
            || (name.starts_with("wall.") && (opts.check || !opts.wall_clock))
            || (FULL_RUNS.contains(&name) && (opts.check || opts.only.as_deref() != Some(name)))
            || only_figure.is_some_and(|only| only != name)
    };
    process(&workspace_root(), only_file, opts.check, keep, |name| {
        render(name, &mut src)
    })?;
    // The images are copies of whole figures: handled with every document, or `--only images`.
    if opts.only.is_none() || opts.only.as_deref() == Some("images") {
        let differ = images::images(&mut src, opts.check, None)?;
        if !differ.is_empty() {
            return Err(format!(
                "{} image(s) differ from what the current code draws (`cargo xtask docs` copies them):\n{}",
                differ.len(),
                differ.join("\n")
            ));
        }
    }
    if opts.only.is_none() || opts.only.as_deref() == Some("eds") {
        eds(opts.check)?;
    }
    if opts.check {
        println!("docs: every measured figure and image matches");
    }
    Ok(())
}

/// Blocks that cost minutes: written only by `--only NAME` (with the date and the command),
/// kept by every other invocation and by `--check`.
const FULL_RUNS: [&str; 3] = [
    "claims.readings",
    "claims.initial-conditions",
    claims::paired::FULL.block,
];

/// The document `cargo xtask reproduction` re-makes, and the block that states its run time.
const REPRODUCTION: &str = "docs/REPRODUCTION.md";
const REPRODUCTION_TIME: &str = "wall.reproduction";

/// `cargo xtask reproduction`: every table, figure and image of `docs/REPRODUCTION.md` re-made
/// from scratch (every source re-produced, as `docs --rerun`, the minutes-long readings table
/// included), then the time it took written into the block `wall.reproduction` with the date and
/// the machine.
pub fn reproduction(_: &Options) -> Result<()> {
    let start = Instant::now();
    let root = workspace_root();
    let mut src = Sources::new(true);
    process(
        &root,
        Some(REPRODUCTION),
        false,
        |name| name.starts_with("wall."),
        |name| render(name, &mut src),
    )?;
    let doc =
        fs::read_to_string(root.join(REPRODUCTION)).map_err(|e| format!("{REPRODUCTION}: {e}"))?;
    images::images(&mut src, false, Some(&doc))?;
    let secs = start.elapsed().as_secs_f64();
    let took = format!(
        "{:.0} min ({secs:.0} s) on {}, {}",
        secs / 60.0,
        machine(),
        today()
    );
    process(
        &root,
        Some(REPRODUCTION),
        false,
        |name| name != REPRODUCTION_TIME,
        |name| Ok((name == REPRODUCTION_TIME).then(|| took.clone())),
    )?;
    println!("{REPRODUCTION}: re-made in {took}");
    Ok(())
}

/// Rewrites (or with `check`, compares) every document under `root`; with `check`, an error
/// names each file, line and block whose figure differs.
fn process(
    root: &Path,
    only: Option<&str>,
    check: bool,
    keep: impl Fn(&str) -> bool,
    mut render: impl FnMut(&str) -> Result<Option<String>>,
) -> Result<()> {
    let mut differ = Vec::new();
    let mut files = documents(root)?;
    if let Some(only) = only {
        files.retain(|f| f == Path::new(only));
        if files.is_empty() {
            return Err(format!("--only {only}: not README.md or a docs/*.md file"));
        }
    }
    for file in files {
        let path = root.join(&file);
        let text = fs::read_to_string(&path).map_err(|e| format!("{}: {e}", file.display()))?;
        let r =
            rewrite(&text, &keep, &mut render).map_err(|e| format!("{}: {e}", file.display()))?;
        for (name, line, old, new) in &r.changed {
            differ.push(format!(
                "{}:{line}: block `fig:{name}` differs from the measured figure\n    document: {}\n    measured: {}",
                file.display(),
                short(old),
                short(new)
            ));
        }
        if !check && !r.changed.is_empty() {
            fs::write(&path, &r.text).map_err(|e| format!("{}: {e}", file.display()))?;
            println!("{}: {} block(s) rewritten", file.display(), r.changed.len());
        }
    }
    if check && !differ.is_empty() {
        return Err(format!(
            "{} figure block(s) differ from what the current code measures (`cargo xtask docs` rewrites them):\n{}",
            differ.len(),
            differ.join("\n")
        ));
    }
    Ok(())
}

/// The first line of a block body, shortened, for messages.
fn short(s: &str) -> String {
    let lines: Vec<&str> = s.trim().lines().collect();
    let first = lines.first().copied().unwrap_or("");
    let mut out: String = first.chars().take(100).collect();
    if lines.len() > 1 || first.chars().count() > 100 {
        let _ = write!(out, " … ({} lines)", lines.len());
    }
    out
}

/// The figure names (patterns) and what they render.
pub const CATALOGUE: [(&str, &str); 63] = [
    ("bench-table", "target bench table, Cortex-M4F step variants (target/bench/step.json)"),
    ("cores.table", "step per math back-end and node tick on every Cortex-M class (step.json)"),
    ("cores.mcu", "named CAN parts: worst step and node tick at the part's clock, share of 1 kHz, verdict"),
    ("cores.ops", "instructions per f32 / I16F16 / I32F32 operation on the cores without an FPU (target/bench/softfloat.json)"),
    ("cores.profile", "where the soft-float step's instructions go, per class (softfloat.json)"),
    ("cores.fixed-bound[.KEY]", "best-case fixed-point step per format (KEY: soft, i16f16-speedup, i16f16-wrapping-speedup, i32f32-speedup)"),
    ("bench.VARIANT.KEY", "one number of step.json's VARIANT (KEY also flash_total)"),
    ("scenarios", "shipped scenario table (host-sim run, stable-h)"),
    ("stable-h", "largest stable sample period per paper scenario (host-sim stable-h)"),
    ("run.SCENARIO.KEY", "one figure of a shipped scenario's summary.json (KEY: max_error, settling_time, max_abs_u, bus_load, saturated, frames_lost)"),
    ("agents.SCENARIO", "per-agent table of a shipped scenario's summary.json"),
    ("headline.SCENARIO", "the headline line of a shipped scenario's summary.json"),
    ("matrix.CASE", "fault matrix table, safety on and off (CASE: example1, example2, example2-fast, example2-umax30)"),
    ("matrix.CASE.met", "fault-matrix cells meeting the goal with safety on"),
    ("matrix.CASE.cells", "fault-matrix cells"),
    ("torque-limit", "Example 2 torque-limit sweep table (host-sim/tests/torque_limit.rs)"),
    ("torque-limit.smallest", "smallest u_max that tracks into the band"),
    ("torque-limit.fails", "largest u_max found not to track"),
    ("pil", "per-agent Node::tick instructions of the 2 s PIL run (target/ci-pil/pil)"),
    ("back-end.NAME[.KEY]", "closed-loop drift table of a math back-end against the default build (NAME: micromath, fast-math; KEY: worst, SCENARIO.worst, SCENARIO.FIGURE; target/back-end/NAME.md of its host-sim test)"),
    ("scaling.line", "error after 2Ts of a line of 1 to 10 followers (scenarios/line.toml, --set graph.agents=N)"),
    ("scaling.line.per-follower", "error after 2Ts added per follower of the line, from 1 to 10"),
    ("scaling.run.NAME", "error after 2Ts of a generated graph (NAME: line-N, star-50, random-50, random-50-links, swarm)"),
    ("scaling.graph.KEY", "the swarm's graph.json (KEY: hops_max, hops_mean, in_degree_max)"),
    ("scaling.file.KEY", "the swarm's trajectory.csv (KEY: decimate, rows, mb, every-sample-gb, three-agents-mb)"),
    ("trajectory.SCENARIO.KEY", "trajectory file of a shipped scenario's run, --no-plots (KEY: csv, parquet = bytes of trajectory.csv, trajectory.parquet; parquet-percent; rows; columns)"),
    ("node-fw.KEY", "node-fw release ELF in bytes (KEY: flash = vector table, .text, .rodata, .data; ram = .data, .bss, .uninit)"),
    ("sizes.KEY", "size_of in bytes (KEY: controller, params, state, controller-n3)"),
    ("campaign.NAME", "Ts x h map summary per Ts (NAME: example1-ts-h, example2-ts-h; out/campaigns/NAME/results.csv)"),
    ("campaign.example1-monte-carlo.KEY", "Monte Carlo figures (KEY: runs, diverged, bounded, error-min, error-max, error-median, error-p95)"),
    ("board.KEY", "NUCLEO-G474RE firmware size in bytes (KEY: text, data, bss, flash, ram, and bench_KEY for the --features bench build; target/board/size.json of cargo xtask board-size)"),
    ("clocks.NAME", "clock campaign table: error after 2Ts vs synchronous per sync, drift, jitter (NAME: clock-drift, clock-drift-example2)"),
    ("clocks.NAME.KEY", "clock campaign figures (KEY: runs, synchronous, synchronous-settling, worst-none, worst-leader, best-none, energy-max, diverged-none, diverged-leader)"),
    ("clocks.goal", "Example 1 over CAN for 60 s: synchronous, free-running clocks, leader sync"),
    ("clocks.goal.RUN", "error after 2Ts of a goal run vs synchronous (RUN: free, leader)"),
    ("network.bus", "NETWORK §5 bus table: Example 1 over the bus of hil-mock/tests (HIL_MOCK_FIGURES_OUT)"),
    ("network.silent.KEY", "agent 3 silent 5–7 s (KEY: held, agent4-error, agent4-x2, recovered, without, stale-samples)"),
    ("network.starved.KEY", "a babbling node for 0.2–0.5 s without safety (KEY: escape, yd-moved, max-x-0.3, max-x-0.2)"),
    ("network.scenarios", "NETWORK §7 table: shipped CAN scenarios and --set variants"),
    ("network.bench-load", "NETWORK §11 table: the bench's frame sets, worst-case load (host-sim check) and modelled (kind = can, plant_frames)"),
    ("network.lossy.KEY", "example1-lossy by window (KEY: before, silent, return, after, max-u-return, ideal-after, after-vs-ideal)"),
    ("network.trace.KEY", "0.3 s of example1-can --trace decoded by cantools with docs/wire.dbc (KEY: frames, max-diff)"),
    ("network.pil-lossy.KEY", "example1-lossy over 7.5 s, which PIL matches (KEY: lost, stale, suppressed, can-sent)"),
    ("network.watchdog.KEY", "example1-pil 3 s, agent 3 hung at 0.5 s or slowed to 5 periods per step on [0.5, 0.55) s, against example1-can (KEY: hang-overruns, hang-reset-ms, hang-recovered-s, slow-resets, slow-reset-ms, slow-recovered-s)"),
    ("reliability.soak", "soak windows, first and last 10 min (controller-core/tests/soak.rs with SOAK_OUT, target/soak/soak.json)"),
    ("reliability.soak.growth", "largest change of a soak figure from the first window to the last"),
    ("reliability.stable-h", "Example 1's largest stable sample period (host-sim stable-h)"),
    ("reliability.extreme.RUN.KEY", "runs of tests/tests/extreme.rs with EXTREME_OUT, release (RUN: ts-0.05, h-10ms, ex2-h-10ms, line-50-can-500k-lossy, all-at-once; KEY: time, agent, max-u, c1, misses, lost)"),
    ("reliability.corruption.CASE.KEY", "Example 1's fault-matrix corruption cells run alone (CASE: 10, 30; KEY: bus-off, misses)"),
    ("reliability.matrix.CASE.KEY", "fault-matrix figures of the prose (KEY: band, band-off, on-max-u, off-max-u, off-diverged-min/max, off-back-max, not-met, not-met-min/max, outage-not-met-min/max, outage-off-back, outage-off-u, stuck-*, named cells)"),
    ("wall.example1-run", "wall time of host-sim run example1 (date and machine; --wall-clock)"),
    ("wall.reproduction", "wall time of `cargo xtask reproduction` (date and machine; written by that command only)"),
    ("claims", "the paper's claims: rule, figures and verdict under each reading (D1 printed gains, D7 permanent faults)"),
    ("claims.readings", "every claim's verdict under each reading (D1 printed gains at h = 1 us, D7 permanent faults); minutes, skipped by --check"),
    ("claims.bands", "settling time of both schemes of Example 2 at bands 0.5x to 2x the final residual"),
    ("claims.ablations", "Example 1's bound after 2Ts with one cause of error removed at a time or the velocity feed-forward added, its fit over Ts, and Example 2 with the feed-forward"),
    ("claims.convergence", "the claims' figures with h halved until they change by less than 1 %"),
    ("claims.further", "checks the paper does not claim: effort of Fig. 8, the baseline tuned to the same settling time"),
    ("claims.untested", "claims no figure of the paper tests: initial conditions (CI's subset), boundedness, Lemma 2's envelope, Lemma 5's differentiator"),
    ("claims.initial-conditions", "every diverging Monte Carlo draw re-run with h halved, per reading; minutes, skipped by --check"),
    ("claims.paper-figures", "peak |u| and residual read off the paper's printed figures beside the measured ones"),
    ("claims.paired", "paired Monte Carlo of Example 2 (1,000 draws, both schemes, bootstrap intervals); minutes, skipped by --check"),
    ("claims.paired-ci", "the paired Monte Carlo's first 20 draws, checked by --check"),
];

/// A figure a block can name.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Figure<'a> {
    BenchTable,
    Cores(&'a str),
    Bench(&'a str, &'a str),
    Scenarios,
    StableH,
    Run(&'a str, &'a str),
    Agents(&'a str),
    Headline(&'a str),
    Matrix(&'a str),
    MatrixMet(&'a str),
    MatrixCells(&'a str),
    Torque,
    TorqueSmallest,
    TorqueFails,
    Pil,
    NodeFw(&'a str),
    Trajectory(&'a str, &'a str),
    BackEnd(&'a str, &'a str),
    ScalingLine,
    ScalingPerFollower,
    ScalingRun(&'a str),
    ScalingGraph(&'a str),
    ScalingFile(&'a str),
    Size(&'a str),
    TsH(&'a str),
    MonteCarlo(&'a str),
    Board(&'a str),
    Clocks(&'a str),
    ClocksKey(&'a str, &'a str),
    ClocksGoal,
    ClocksGoalRun(&'a str),
    Network(&'a str),
    Reliability(&'a str),
    WallExample1,
    /// The run time of `cargo xtask reproduction`, written by that command alone.
    WallReproduction,
    Claims,
    ClaimsBands,
    ClaimsReadings,
    ClaimsConvergence,
    ClaimsFurther,
    ClaimsAblations,
    ClaimsUntested,
    ClaimsInitialConditions,
    ClaimsPaperFigures,
    ClaimsPaired(claims::paired::Study),
}

/// Figures of a `summary.json` that `run.SCENARIO.KEY` renders.
const RUN_KEYS: [&str; 6] = [
    "max_error",
    "settling_time",
    "max_abs_u",
    "bus_load",
    "saturated",
    "frames_lost",
];
/// Fault matrices: `example1`, `example2` (the deploy scenarios, as CI runs them) and
/// `example2-fast` (Example 2's deploy scenario at h = 0.2 ms on a 5 Mbit/s bus),
/// `example2-umax30` (the deploy scenario with `u_max = 30 N m`).
const MATRICES: [&str; 4] = ["example1", "example2", "example2-fast", "example2-umax30"];
/// The shipped campaigns over `Ts × h`.
const TS_H: [&str; 2] = ["example1-ts-h", "example2-ts-h"];
/// Figures of the Monte Carlo campaign: runs, diverged and the error after `2 T_s` of the others.
const MONTE_CARLO: [&str; 7] = [
    "runs",
    "diverged",
    "bounded",
    "error-min",
    "error-max",
    "error-median",
    "error-p95",
];
/// Figures of a run's trajectory file that `trajectory.SCENARIO.KEY` renders.
const TRAJECTORY_KEYS: [&str; 5] = ["csv", "parquet", "parquet-percent", "rows", "columns"];
/// `size_of` figures the sizes test prints.
const SIZES: [&str; 4] = ["controller", "params", "state", "controller-n3"];

/// The figure a block's name stands for; `None` when no figure has that name.
fn parse(name: &str) -> Option<Figure<'_>> {
    let parts: Vec<&str> = name.split('.').collect();
    let scenario = |s: &str| SCENARIOS.iter().any(|x| x.0 == s);
    let matrix = |c: &str| MATRICES.contains(&c);
    Some(match parts.as_slice() {
        ["bench-table"] => Figure::BenchTable,
        ["bench", variant, key] => Figure::Bench(variant, key),
        ["cores", ..] if cores::known(&name["cores.".len()..]) => {
            Figure::Cores(&name["cores.".len()..])
        }
        ["scenarios"] => Figure::Scenarios,
        ["stable-h"] => Figure::StableH,
        ["run", stem, key] if scenario(stem) && RUN_KEYS.contains(key) => Figure::Run(stem, key),
        ["agents", stem] if scenario(stem) => Figure::Agents(stem),
        ["headline", stem] if scenario(stem) => Figure::Headline(stem),
        ["matrix", case] if matrix(case) => Figure::Matrix(case),
        ["matrix", case, "met"] if matrix(case) => Figure::MatrixMet(case),
        ["matrix", case, "cells"] if matrix(case) => Figure::MatrixCells(case),
        ["torque-limit"] => Figure::Torque,
        ["torque-limit", "smallest"] => Figure::TorqueSmallest,
        ["torque-limit", "fails"] => Figure::TorqueFails,
        ["pil"] => Figure::Pil,
        ["node-fw", key] if ["flash", "ram"].contains(key) => Figure::NodeFw(key),
        ["back-end", back, ..] if back_end::known(back) => {
            let key = name.get("back-end.".len() + back.len()..).unwrap_or("");
            Figure::BackEnd(back, key.trim_start_matches('.'))
        }
        ["scaling", "line"] => Figure::ScalingLine,
        ["scaling", "line", "per-follower"] => Figure::ScalingPerFollower,
        ["scaling", "run", run] if scaling::known_run(run) => Figure::ScalingRun(run),
        ["scaling", "graph", key] if scaling::GRAPH_KEYS.contains(key) => Figure::ScalingGraph(key),
        ["scaling", "file", key] if scaling::FILE_KEYS.contains(key) => Figure::ScalingFile(key),
        ["trajectory", stem, key] if scenario(stem) && TRAJECTORY_KEYS.contains(key) => {
            Figure::Trajectory(stem, key)
        }
        ["sizes", key] if SIZES.contains(key) => Figure::Size(key),
        ["campaign", name] if TS_H.contains(name) => Figure::TsH(name),
        ["campaign", "example1-monte-carlo", key] if MONTE_CARLO.contains(key) => {
            Figure::MonteCarlo(key)
        }
        ["board", key] if crate::board::KEYS.contains(key) => Figure::Board(key),
        ["clocks", "goal"] => Figure::ClocksGoal,
        ["clocks", "goal", run] if clocks::goal_run(run) => Figure::ClocksGoalRun(run),
        ["clocks", name] if clocks::CAMPAIGNS.contains(name) => Figure::Clocks(name),
        ["clocks", name, key] if clocks::CAMPAIGNS.contains(name) && clocks::KEYS.contains(key) => {
            Figure::ClocksKey(name, key)
        }
        ["network", ..] if network::known(&name["network.".len()..]) => {
            Figure::Network(&name["network.".len()..])
        }
        ["reliability", ..] if reliability::known(&name["reliability.".len()..]) => {
            Figure::Reliability(&name["reliability.".len()..])
        }
        ["wall", "example1-run"] => Figure::WallExample1,
        ["wall", "reproduction"] => Figure::WallReproduction,
        ["claims"] => Figure::Claims,
        ["claims", "bands"] => Figure::ClaimsBands,
        ["claims", "readings"] => Figure::ClaimsReadings,
        ["claims", "convergence"] => Figure::ClaimsConvergence,
        ["claims", "further"] => Figure::ClaimsFurther,
        ["claims", "ablations"] => Figure::ClaimsAblations,
        ["claims", "untested"] => Figure::ClaimsUntested,
        ["claims", "initial-conditions"] => Figure::ClaimsInitialConditions,
        ["claims", "paper-figures"] => Figure::ClaimsPaperFigures,
        ["claims", "paired"] => Figure::ClaimsPaired(claims::paired::FULL),
        ["claims", "paired-ci"] => Figure::ClaimsPaired(claims::paired::CI),
        _ => return None,
    })
}

/// Renders figure `name`; `Ok(None)` when no figure has that name.
fn render(name: &str, src: &mut Sources) -> Result<Option<String>> {
    let Some(figure) = parse(name) else {
        return Ok(None);
    };
    let text = match figure {
        Figure::BenchTable => bench_table(&src.bench()?)?,
        Figure::Bench(variant, key) => bench_figure(&src.bench()?, variant, key)?,
        Figure::Cores(name) => cores::render(src, name)?,
        Figure::Scenarios => scenario_table(src)?,
        Figure::StableH => stable_h_table(src)?,
        Figure::Run(stem, key) => run_figure(&src.summary(stem)?, key)?,
        Figure::Agents(stem) => agents_table(&src.summary(stem)?)?,
        Figure::Headline(stem) => headline(&src.summary(stem)?)?,
        Figure::Matrix(case) => matrix_table(&src.matrix(case)?)?,
        Figure::MatrixMet(case) => matrix_met(&src.matrix(case)?).to_string(),
        Figure::MatrixCells(case) => matrix_cells(&src.matrix(case)?).to_string(),
        Figure::Torque => torque_table(&src.torque()?)?,
        Figure::TorqueSmallest => fixed(num(&src.torque()?, "smallest")?, 2),
        Figure::TorqueFails => fixed(num(&src.torque()?, "fails")?, 2),
        Figure::Pil => pil_table(&src.pil()?)?,
        Figure::NodeFw(key) => grouped(num(&src.node_fw()?, key)?, 0),
        Figure::Trajectory(stem, key) => trajectory_figure(src, stem, key)?,
        Figure::BackEnd(name, key) => back_end::figure(src, name, key)?,
        Figure::ScalingLine => scaling::line_table(src)?,
        Figure::ScalingPerFollower => scaling::line_per_follower(src)?,
        Figure::ScalingRun(run) => scaling::run_figure(src, run)?,
        Figure::ScalingGraph(key) => scaling::graph_figure(src, key)?,
        Figure::ScalingFile(key) => scaling::file_figure(src, key)?,
        Figure::Size(key) => sizes_figure(&src.sizes()?, key)?,
        Figure::TsH(name) => ts_h_table(&src.campaign(name)?)?,
        Figure::MonteCarlo(key) => monte_carlo(&src.campaign("example1-monte-carlo")?, key)?,
        Figure::Board(key) => grouped(num(&src.board()?, key)?, 0),
        Figure::Clocks(name) => clocks::table(&src.campaign(name)?)?,
        Figure::ClocksKey(name, key) => clocks::figure(&src.campaign(name)?, key)?,
        Figure::ClocksGoal => clocks::goal_table(src)?,
        Figure::ClocksGoalRun(run) => clocks::goal_figure(src, run)?,
        Figure::Network(name) => network::render(src, name)?,
        Figure::Reliability(name) => reliability::render(src, name)?,
        Figure::WallExample1 => wall_example1(src)?,
        Figure::WallReproduction => {
            return Err(format!(
                "written by `cargo xtask reproduction` alone (it measures its own run time), \
                 kept by `docs`; block `fig:{REPRODUCTION_TIME}`"
            ))
        }
        Figure::Claims => claims::table(src)?,
        Figure::ClaimsBands => claims::bands_table(src)?,
        Figure::ClaimsReadings => claims::readings_table(src)?,
        Figure::ClaimsConvergence => claims::convergence_table(src)?,
        Figure::ClaimsFurther => claims::further_table(src)?,
        Figure::ClaimsAblations => claims::ablations_table(src)?,
        Figure::ClaimsUntested => claims::untested_table(src)?,
        Figure::ClaimsInitialConditions => claims::initial_conditions_table(src)?,
        Figure::ClaimsPaperFigures => claims::paper_figures_table(src)?,
        Figure::ClaimsPaired(study) => claims::paired::table(src, study)?,
    };
    Ok(Some(text))
}

// ---------------------------------------------------------------------------------------------
// Sources

/// Where the figures come from; each file is read (or produced) once per invocation.
struct Sources {
    rerun: bool,
    produced: HashSet<PathBuf>,
    host_sim: Option<PathBuf>,
    json: BTreeMap<PathBuf, Value>,
}

/// How `stable-h` searches a scenario: `--band`, `--h-max`.
type Search = Option<(f64, f64)>;

/// Shipped scenarios, what each reproduces, and its `stable-h` search.
const SCENARIOS: [(&str, &str, Search); 8] = [
    (
        "example1",
        "Example 1, Ts = 2 (Figs. 2–7)",
        Some((0.25, 0.05)),
    ),
    ("example1-ts1", "Example 1, Ts = 1", Some((0.25, 0.05))),
    (
        "example2",
        "Example 2, manipulators (Figs. 8–12)",
        Some((0.1, 2e-3)),
    ),
    (
        "example2-baseline",
        "LAW §10 baseline, Ts = 1, c1 = 10, c2 = 9",
        Some((0.1, 2e-3)),
    ),
    (
        "example1-can",
        "Example 1 over a 1 Mbit/s CAN bus, no loss",
        None,
    ),
    (
        "example1-lossy",
        "Example 1, 500 kbit/s, 10 % loss, agent 3 silent 5–7 s",
        None,
    ),
    ("example1-deploy", "`example1-can` with `[safety]`", None),
    (
        "example2-deploy",
        "Example 2 over 1 Mbit/s CAN with `[safety]`, `u_max = 20 N m`",
        None,
    ),
];

impl Sources {
    fn new(rerun: bool) -> Self {
        Sources {
            rerun,
            produced: HashSet::new(),
            host_sim: None,
            json: BTreeMap::new(),
        }
    }

    /// `path` (under the workspace root) after `produce` wrote it, unless it exists and
    /// `--rerun` was not given.
    fn file(
        &mut self,
        path: &str,
        produce: impl FnOnce(&mut Self, &Path) -> Result<()>,
    ) -> Result<PathBuf> {
        let full = workspace_root().join(path);
        let stale = self.rerun && !self.produced.contains(&full);
        if stale || !full.exists() {
            eprintln!("docs: producing {path}");
            if let Some(dir) = full.parent() {
                fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            }
            produce(self, &full)?;
            if !full.exists() {
                return Err(format!("{path} was not written"));
            }
            self.produced.insert(full.clone());
            self.json.remove(&full);
        }
        Ok(full)
    }

    fn json_file(
        &mut self,
        path: &str,
        produce: impl FnOnce(&mut Self, &Path) -> Result<()>,
    ) -> Result<Value> {
        let full = self.file(path, produce)?;
        if let Some(v) = self.json.get(&full) {
            return Ok(v.clone());
        }
        let text = fs::read_to_string(&full).map_err(|e| format!("{path}: {e}"))?;
        let v: Value = serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?;
        self.json.insert(full, v.clone());
        Ok(v)
    }

    /// The release `host-sim` binary, built once.
    fn host_sim(&mut self) -> Result<PathBuf> {
        if let Some(p) = &self.host_sim {
            return Ok(p.clone());
        }
        let root = workspace_root();
        run(Command::new(cargo()).current_dir(&root).args([
            "build",
            "--release",
            "--quiet",
            "-p",
            "host-sim",
        ]))?;
        let p = root.join("target/release/host-sim");
        self.host_sim = Some(p.clone());
        Ok(p)
    }

    fn bench(&mut self) -> Result<Value> {
        self.json_file("target/bench/step.json", |_, _| {
            crate::bench::bench_target(&Options::default()).map(|_| ())
        })
    }

    /// `target/bench/softfloat.json`, written by `cargo xtask bench-target` with `step.json`.
    fn softfloat(&mut self) -> Result<Value> {
        self.json_file("target/bench/softfloat.json", |_, _| {
            crate::bench::bench_target(&Options::default()).map(|_| ())
        })
    }

    fn summary(&mut self, stem: &str) -> Result<Value> {
        self.summary_with(stem, "", &[])
    }

    /// `summary.json` of a shipped scenario run with `--set` for each of `sets`, in
    /// `target/docs/run/<stem><tag>/` (beside it the run's `trajectory.csv`).
    fn summary_with(&mut self, stem: &str, tag: &str, sets: &[&str]) -> Result<Value> {
        if !SCENARIOS.iter().any(|s| s.0 == stem) {
            return Err(format!("`{stem}` is not a shipped scenario of the docs"));
        }
        let path = format!("target/docs/run/{stem}{tag}/summary.json");
        self.json_file(&path, |s, file| {
            let args: Vec<&str> = sets.iter().flat_map(|set| ["--set", set]).collect();
            s.run_scenario(stem, &args, file.parent().unwrap_or(file))
        })
    }

    /// `host-sim run scenarios/<file>.toml --no-plots --quiet <args> --out <dir>`.
    fn run_scenario(&mut self, file: &str, args: &[&str], dir: &Path) -> Result<()> {
        let bin = self.host_sim()?;
        let mut cmd = Command::new(bin);
        cmd.current_dir(workspace_root())
            .args([
                "run",
                &format!("scenarios/{file}.toml"),
                "--no-plots",
                "--quiet",
            ])
            .args(args);
        run(cmd.arg("--out").arg(dir)).map(|_| ())
    }

    /// `trajectory.parquet` of a shipped scenario run with `--format parquet`, in
    /// `target/docs/run/<stem>-parquet/`.
    fn parquet(&mut self, stem: &str) -> Result<PathBuf> {
        let path = format!("target/docs/run/{stem}-parquet/trajectory.parquet");
        self.file(&path, |s, file| {
            s.run_scenario(
                stem,
                &["--format", "parquet"],
                file.parent().unwrap_or(file),
            )
        })
    }

    /// `Σ_i Σ_l Σ_{t_k ≥ from} u_{i,l}² h` for each of `froms`, from the `trajectory.csv` of a
    /// shipped scenario's run (its `total_u_energy` for `from = 0`).
    fn energy_after(&mut self, stem: &str, froms: &[f64]) -> Result<Vec<f64>> {
        self.summary(stem)?;
        let path = format!("target/docs/run/{stem}/trajectory.csv");
        let text =
            fs::read_to_string(workspace_root().join(&path)).map_err(|e| format!("{path}: {e}"))?;
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().ok_or("empty")?.split(',').collect();
        let u: Vec<usize> = (0..header.len())
            .filter(|&k| header[k].starts_with('u') && header[k].contains('_'))
            .collect();
        let (mut sums, mut times) = (vec![0.0; froms.len()], Vec::new());
        for line in lines {
            let v: Vec<&str> = line.split(',').collect();
            let t: f64 = v[0].parse().map_err(|_| format!("{path}: bad t"))?;
            times.push(t);
            let sq: f64 = u
                .iter()
                .map(|&k| v[k].parse::<f64>().map(|x| x * x))
                .sum::<std::result::Result<f64, _>>()
                .map_err(|_| format!("{path}: bad u"))?;
            for (s, from) in sums.iter_mut().zip(froms) {
                if t >= *from {
                    *s += sq;
                }
            }
        }
        let h = times.get(1).zip(times.first()).map_or(0.0, |(b, a)| b - a);
        Ok(sums.into_iter().map(|s| s * h).collect())
    }

    /// `(largest stable h, smallest unstable h)` in seconds.
    fn stable_h(&mut self, stem: &str, band: f64, h_max: f64) -> Result<(f64, Option<f64>)> {
        let path = format!("target/docs/stable-h/{stem}.txt");
        let file = self.file(&path, |s, file| {
            let bin = s.host_sim()?;
            let out = run(Command::new(bin).current_dir(workspace_root()).args([
                "stable-h",
                &format!("scenarios/{stem}.toml"),
                "--band",
                &band.to_string(),
                "--h-max",
                &h_max.to_string(),
            ]))?;
            fs::write(file, out).map_err(|e| format!("{path}: {e}"))
        })?;
        let text = fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))?;
        parse_stable_h(&text).ok_or_else(|| format!("{path}: no `largest stable h = …` line"))
    }

    fn matrix(&mut self, case: &str) -> Result<Matrix> {
        let (scenario, sets): (&str, &[&str]) = match case {
            "example1" => ("example1-deploy", &[]),
            "example2" => ("example2-deploy", &[]),
            "example2-fast" => (
                "example2-deploy",
                &["simulation.h=2e-4", "network.bitrate=5000000"],
            ),
            "example2-umax30" => ("example2-deploy", &["safety.u_max=30"]),
            other => return Err(format!("no fault matrix `{other}`")),
        };
        let dir = format!("target/fault-matrix/{case}");
        let json = self.json_file(&format!("{dir}/matrix.json"), |s, file| {
            let bin = s.host_sim()?;
            let mut cmd = Command::new(bin);
            cmd.current_dir(workspace_root())
                .args(["fault-matrix", &format!("scenarios/{scenario}.toml")])
                .arg("--out")
                .arg(file.parent().unwrap_or(file));
            for set in sets {
                cmd.args(["--set", set]);
            }
            run(&mut cmd).map(|_| ())
        })?;
        let md_path = workspace_root().join(&dir).join("matrix.md");
        let md = fs::read_to_string(&md_path).map_err(|e| format!("{dir}/matrix.md: {e}"))?;
        Ok(Matrix { json, md })
    }

    fn torque(&mut self) -> Result<Value> {
        self.json_file("target/torque-limit/torque-limit.json", |_, file| {
            run(Command::new(cargo())
                .current_dir(workspace_root())
                .env("TORQUE_SWEEP_OUT", file.parent().unwrap_or(file))
                .args([
                    "test",
                    "-p",
                    "host-sim",
                    "--release",
                    "--test",
                    "torque_limit",
                ])
                .args(["--", "--ignored"]))
            .map(|_| ())
        })
    }

    fn pil(&mut self) -> Result<Value> {
        self.json_file("target/ci-pil/pil/summary.json", |s, file| {
            // The firmware the emulators run is built from the current sources, never an
            // older build's ELF (node-fw is outside the workspace: its own directory and lock).
            run(Command::new(cargo())
                .current_dir(workspace_root().join("node-fw"))
                .args(["build", "--release", "--locked", "--quiet"]))?;
            let bin = s.host_sim()?;
            run(Command::new(bin)
                .current_dir(workspace_root())
                .args([
                    "run",
                    "scenarios/example1-pil.toml",
                    "--no-plots",
                    "--quiet",
                ])
                .args(["--set", "simulation.t_end=2", "--out"])
                .arg(file.parent().unwrap_or(file)))
            .map(|_| ())
        })
    }

    /// Flash and static RAM of the node firmware, from its release ELF's sections.
    fn node_fw(&mut self) -> Result<Value> {
        self.json_file("target/docs/node-fw.json", |_, file| {
            let dir = workspace_root().join("node-fw");
            let target_dir = workspace_root().join("target/docs/node-fw-remapped");
            run(crate::task::firmware_build(&dir, &target_dir).arg("--quiet"))?;
            let elf = target_dir.join("thumbv7em-none-eabihf/release/node-fw");
            let data = fs::read(&elf).map_err(|e| format!("{}: {e}", elf.display()))?;
            let obj = object::File::parse(&*data)
                .map_err(|e| format!("{}: cannot parse the ELF: {e}", elf.display()))?;
            let size = |names: &[&str]| -> u64 {
                obj.sections()
                    .filter(|s| s.name().is_ok_and(|n| names.contains(&n)))
                    .map(|s| s.size())
                    .sum()
            };
            let v = serde_json::json!({
                "flash": size(&[".vector_table", ".text", ".rodata", ".data"]),
                "ram": size(&[".data", ".bss", ".uninit"]),
            });
            fs::write(file, v.to_string()).map_err(|e| format!("{}: {e}", file.display()))
        })
    }

    /// `results.csv` of a shipped campaign, where CI's sweep writes it.
    fn campaign(&mut self, name: &str) -> Result<Vec<Row>> {
        let path = format!("out/campaigns/{name}/results.csv");
        let file = self.file(&path, |s, file| {
            let bin = s.host_sim()?;
            let dir = file.parent().unwrap_or(file);
            // A directory left by another campaign or an older run would be resumed.
            let _ = fs::remove_dir_all(dir);
            run(Command::new(bin)
                .current_dir(workspace_root())
                .args([
                    "sweep",
                    &format!("campaigns/{name}.toml"),
                    "--quiet",
                    "--out",
                ])
                .arg(dir))
            .map(|_| ())
        })?;
        let text = fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))?;
        rows(&text).map_err(|e| format!("{path}: {e}"))
    }

    fn board(&mut self) -> Result<Value> {
        self.json_file(crate::board::SIZE_JSON, |_, _| {
            crate::board::board_size(&Options::default())
        })
    }

    fn sizes(&mut self) -> Result<String> {
        let path = "target/docs/sizes.txt";
        let file = self.file(path, |_, file| {
            let out = run(Command::new(cargo())
                .current_dir(workspace_root())
                .args(["test", "-p", "controller-core", "--test", "sizes"])
                .args(["--", "--nocapture"]))?;
            fs::write(file, out).map_err(|e| format!("{path}: {e}"))
        })?;
        fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))
    }
}

/// Runs `cmd`, returns its standard output; a failure is an error naming the command.
fn run(cmd: &mut Command) -> Result<String> {
    let out = cmd
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!("{cmd:?} failed ({})", out.status));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

// ---------------------------------------------------------------------------------------------
// Formatting

/// `x` with `decimals` decimals and thousands separators: `16,519.1`.
pub fn grouped(x: f64, decimals: usize) -> String {
    let s = format!("{:.*}", decimals, x.abs());
    let (int, frac) = s.split_once('.').map_or((s.as_str(), ""), |(i, f)| (i, f));
    let mut out = String::new();
    for (k, c) in int.chars().enumerate() {
        if k > 0 && (int.len() - k) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    if !frac.is_empty() {
        out.push('.');
        out.push_str(frac);
    }
    if x < 0.0 && out.chars().any(|c| c.is_ascii_digit() && c != '0') {
        out.insert(0, '−');
    }
    out
}

fn fixed(x: f64, decimals: usize) -> String {
    format!("{x:.decimals$}")
}

/// `h` in ms, with three significant digits: `6.79 ms`, `0.415 ms`.
fn ms(h: f64) -> String {
    let v = h * 1e3;
    let d = if v >= 10.0 {
        1
    } else if v >= 1.0 {
        2
    } else {
        3
    };
    let s = format!("{v:.d$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    };
    format!("{s} ms")
}

fn num(v: &Value, key: &str) -> Result<f64> {
    v.get(key)
        .and_then(Value::as_f64)
        .ok_or_else(|| format!("no number `{key}`"))
}

fn opt(v: &Value, key: &str) -> Option<f64> {
    v.get(key).and_then(Value::as_f64)
}

// ---------------------------------------------------------------------------------------------
// Target bench

fn variants(step: &Value) -> Result<&Vec<Value>> {
    step["variants"]
        .as_array()
        .ok_or_else(|| "step.json has no `variants`".to_owned())
}

/// Labels of the bench table's first column.
fn variant_label(name: &str) -> String {
    let note = match name {
        "baseline-n2m2" => " (LAW §10)",
        "libm-n3m3" => " (synthetic `x_3`)",
        "safety-n2m2" => " (`[safety]` on: limits, recovery)",
        _ => "",
    };
    format!("`{name}`{note}")
}

fn bench_table(step: &Value) -> Result<String> {
    let mut t = String::from(
        "| variant | instructions min | median | max | stack B | flash B (step) | + flash B (`new`) | state B (`Controller`) | of which `State` |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    // The Cortex-M4F's step variants (the other cores and the node tick: `cores.table`).
    for v in variants(step)?
        .iter()
        .filter(|v| v["core"].as_str().is_none_or(|c| c == "cortex-m4f"))
        .filter(|v| {
            v["measures"]
                .as_str()
                .is_none_or(|m| m == "Controller::step")
        })
    {
        let name = v["name"].as_str().ok_or("a variant without a name")?;
        let mut row = format!("| {} |", variant_label(name));
        for key in [
            "instructions_min",
            "instructions_median",
            "instructions_max",
            "stack_bytes",
            "flash_bytes",
            "flash_config_bytes",
            "state_bytes",
            "mutable_state_bytes",
        ] {
            let x = v[key]
                .as_u64()
                .ok_or_else(|| format!("{name}: no `{key}`"))?;
            let _ = write!(row, " {x} |");
        }
        t.push_str(&row);
        t.push('\n');
    }
    Ok(t)
}

fn bench_figure(step: &Value, variant: &str, key: &str) -> Result<String> {
    let v = variants(step)?
        .iter()
        .find(|v| v["name"] == variant)
        .ok_or_else(|| format!("no variant `{variant}` in step.json"))?;
    let get = |k: &str| {
        v[k].as_u64()
            .ok_or_else(|| format!("{variant}: no number `{k}`"))
    };
    let x = match key {
        "flash_total" => get("flash_bytes")? + get("flash_config_bytes")?,
        "median" | "min" | "max" => get(&format!("instructions_{key}"))?,
        k => get(k)?,
    };
    Ok(grouped(x as f64, 0))
}

// ---------------------------------------------------------------------------------------------
// Shipped scenarios

fn settling(s: &Value) -> String {
    opt(s, "settling_time").map_or_else(
        || "never settled in 0.05".to_owned(),
        |t| fixed(t, 2) + " s",
    )
}

/// `trajectory.SCENARIO.KEY`: sizes of the run's trajectory files, and the CSV's shape.
fn trajectory_figure(src: &mut Sources, stem: &str, key: &str) -> Result<String> {
    src.summary(stem)?;
    let csv_path = workspace_root().join(format!("target/docs/run/{stem}/trajectory.csv"));
    let bytes = |p: &Path| {
        fs::metadata(p)
            .map(|m| m.len())
            .map_err(|e| format!("{}: {e}", p.display()))
    };
    let csv = bytes(&csv_path)?;
    let shape = || -> Result<(usize, usize)> {
        let text =
            fs::read_to_string(&csv_path).map_err(|e| format!("{}: {e}", csv_path.display()))?;
        let mut lines = text.lines();
        let columns = lines.next().map_or(0, |h| h.split(',').count());
        Ok((lines.count(), columns))
    };
    Ok(match key {
        "csv" => grouped(csv as f64, 0),
        "parquet" => grouped(bytes(&src.parquet(stem)?)? as f64, 0),
        "parquet-percent" => {
            let parquet = bytes(&src.parquet(stem)?)?;
            fixed(100.0 * parquet as f64 / csv.max(1) as f64, 0)
        }
        "rows" => grouped(shape()?.0 as f64, 0),
        "columns" => grouped(shape()?.1 as f64, 0),
        other => return Err(format!("no trajectory figure `{other}`")),
    })
}

fn run_figure(s: &Value, key: &str) -> Result<String> {
    Ok(match key {
        "max_error" => fixed(num(s, "max_error_after_predefined_time")?, 3),
        "settling_time" => settling(s),
        "max_abs_u" => grouped(num(s, "max_abs_u")?, 1),
        "bus_load" => fixed(num(&s["network"], "bus_load_percent")?, 1),
        "saturated" => fixed(100.0 * num(s, "saturated_fraction")?, 1),
        "frames_lost" => grouped(num(&s["network"], "frames_lost")?, 0),
        other => return Err(format!("no run figure `{other}`")),
    })
}

fn scenario_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from(
        "| scenario | reproduces | h | bus load | max error after 2Ts | settling time (b = 0.05) | max \\|u\\| | largest stable h |\n|---|---|---|---|---|---|---|---|\n",
    );
    for (stem, what, search) in SCENARIOS {
        let s = src.summary(stem)?;
        let load = s["network"]["bus_load_percent"]
            .as_f64()
            .map_or("–".to_owned(), |l| fixed(l, 1) + " %");
        let stable = match search {
            Some((band, h_max)) => ms(src.stable_h(stem, band, h_max)?.0),
            None => "–".to_owned(),
        };
        let _ = writeln!(
            t,
            "| `{stem}.toml` | {what} | {} | {load} | {} | {} | {} | {stable} |",
            ms(num(&s, "h")?),
            fixed(num(&s, "max_error_after_predefined_time")?, 3),
            settling(&s),
            grouped(num(&s, "max_abs_u")?, 1),
        );
    }
    Ok(t)
}

/// Actuators per follower of both paper examples.
const EXAMPLE_ACTUATORS: f64 = 2.0;

/// Quantizer output changes over all followers and actuators, per sample and actuator.
fn change_rate(s: &Value) -> Result<f64> {
    let agents = s["agents"].as_array().ok_or("summary: no `agents`")?;
    let changes: f64 = agents
        .iter()
        .map(|a| num(a, "quantizer_changes"))
        .sum::<Result<f64>>()?;
    Ok(changes / (num(s, "samples")? * agents.len() as f64 * EXAMPLE_ACTUATORS))
}

fn parse_stable_h(text: &str) -> Option<(f64, Option<f64>)> {
    let line = text
        .lines()
        .rev()
        .find(|l| l.starts_with("largest stable h") || l.starts_with("stable at h-max"))?;
    let value_after = |key: &str| -> Option<f64> {
        let at = line.find(key)? + key.len();
        line[at..]
            .split_whitespace()
            .next()?
            .trim_end_matches([';', ')', ','])
            .parse()
            .ok()
    };
    if let Some(h) = value_after("largest stable h = ") {
        Some((h, value_after("unstable at ")))
    } else {
        value_after("stable at h-max = ").map(|h| (h, None))
    }
}

fn stable_h_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from(
        "| scenario | band | largest stable h | smallest unstable h found | shipped h |\n|---|---|---|---|---|\n",
    );
    for (stem, _, search) in SCENARIOS {
        let Some((band, h_max)) = search else {
            continue;
        };
        let (stable, unstable) = src.stable_h(stem, band, h_max)?;
        let shipped = num(&src.summary(stem)?, "h")?;
        let _ = writeln!(
            t,
            "| `{stem}` | {band} | {} | {} | {} |",
            ms(stable),
            unstable.map_or("–".to_owned(), ms),
            ms(shipped)
        );
    }
    Ok(t)
}

fn headline(s: &Value) -> Result<String> {
    Ok(format!(
        "c1 = {}, c2 = {}, 2Ts = {} s, h = {} s, max error after 2Ts = {}, settling time (b = 0.05) = {}, max |u| = {}, total u energy = {}",
        fixed(num(s, "c1")?, 3),
        fixed(num(s, "c2")?, 3),
        num(s, "predefined_time")?,
        num(s, "h")?,
        fixed(num(s, "max_error_after_predefined_time")?, 4),
        opt(s, "settling_time").map_or("null".to_owned(), |t| fixed(t, 4)),
        fixed(num(s, "max_abs_u")?, 1),
        fixed(num(s, "total_u_energy")?, 1),
    ))
}

/// Three significant digits, in scientific notation below 0.01.
fn sig3(x: f64) -> String {
    if x == 0.0 {
        "0".to_owned()
    } else if x.abs() < 0.01 {
        format!("{x:.2e}")
    } else {
        let decimals = (2 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    }
}

fn agents_table(s: &Value) -> Result<String> {
    let mut t = String::from(
        "| agent | IAE | ISE | max \\|u\\| | u energy | quantizer changes | levels used | peak \\|x\\| | final μ̂ | final ξ̂ | final λ̂ |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for a in s["agents"].as_array().ok_or("no `agents`")? {
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            num(a, "agent")?,
            fixed(num(a, "iae")?, 4),
            fixed(num(a, "ise")?, 5),
            fixed(num(a, "max_abs_u")?, 1),
            fixed(num(a, "u_energy")?, 1),
            num(a, "quantizer_changes")?,
            opt(a, "levels_used").map_or("–".to_owned(), |l| l.to_string()),
            fixed(num(a, "peak_abs_state")?, 3),
            sig3(num(a, "final_mu")?),
            sig3(num(a, "final_xi")?),
            sig3(num(a, "final_lambda")?),
        );
    }
    Ok(t)
}

// ---------------------------------------------------------------------------------------------
// Fault matrix

/// `matrix.json` (the figures) and `matrix.md` (host-sim's verdict per row).
struct Matrix {
    json: Value,
    md: String,
}

/// Verdicts of `matrix.md` with safety on, by cell number.
fn verdicts(md: &str) -> BTreeMap<usize, bool> {
    md.lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split(" | ").map(str::trim).collect();
            let k: usize = cells.first()?.parse().ok()?;
            (cells.get(3) == Some(&"on")).then(|| (k, cells.last() == Some(&"met")))
        })
        .collect()
}

fn matrix_met(m: &Matrix) -> usize {
    verdicts(&m.md).values().filter(|&&met| met).count()
}

fn matrix_cells(m: &Matrix) -> usize {
    verdicts(&m.md).len()
}

fn matrix_table(m: &Matrix) -> Result<String> {
    let rows = m.json.as_array().ok_or("matrix.json is not a list")?;
    let verdict = verdicts(&m.md);
    let mut cells: Vec<(String, String, Option<&Value>, Option<&Value>)> = Vec::new();
    for r in rows {
        let fault = r["fault"].as_str().unwrap_or("").to_owned();
        let case = r["case"].as_str().unwrap_or("").to_owned();
        let k = match cells.iter().position(|c| c.0 == fault && c.1 == case) {
            Some(k) => k,
            None => {
                cells.push((fault, case, None, None));
                cells.len() - 1
            }
        };
        if r["safety"].as_bool() == Some(true) {
            cells[k].3 = Some(r);
        } else {
            cells[k].2 = Some(r);
        }
    }
    let secs = |r: &Value, key: &str| opt(r, key).map_or("–".to_owned(), |x| fixed(x, 3));
    let mut t = String::from(
        "| # | fault | case | off: diverged at | off: max \\|u\\| | off: back in band [s] | on: max \\|u\\| (whole run) | on: max error after recovery | on: back in band [s] | goal met (on) |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (k, (fault, case, off, on)) in cells.iter().enumerate() {
        let off_cols = off.map_or("– | – | –".to_owned(), |r| {
            match opt(r, "diverged_at") {
                Some(d) => format!("{} | diverged | –", fixed(d, 3)),
                None => format!(
                    "– | {} | {}",
                    grouped(num(r, "max_abs_u").unwrap_or(f64::NAN), 0),
                    secs(r, "back_in_band_s")
                ),
            }
        });
        let on_cols = on.map_or("– | – | –".to_owned(), |r| {
            match opt(r, "diverged_at") {
                Some(d) => format!("diverged at {} s | – | –", fixed(d, 3)),
                None => format!(
                    "{} | {} | {}",
                    grouped(num(r, "max_abs_u_run").unwrap_or(f64::NAN), 1),
                    secs(r, "max_error_after_recovery"),
                    secs(r, "back_in_band_s")
                ),
            }
        });
        let goal = match verdict.get(&(k + 1)) {
            Some(true) => "yes",
            Some(false) => "**no**",
            None => "–",
        };
        let _ = writeln!(
            t,
            "| {} | {fault} | {case} | {off_cols} | {on_cols} | {goal} |",
            k + 1
        );
    }
    Ok(t)
}

// ---------------------------------------------------------------------------------------------
// Campaigns

/// One row of a campaign's `results.csv`: its cells up to `status`, by column name.
type Row = BTreeMap<String, String>;

/// The rows of `results.csv`; cells after `status` (a quoted error message, draws) are left out.
fn rows(csv: &str) -> Result<Vec<Row>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().ok_or("empty")?.split(',').collect();
    let end = header
        .iter()
        .position(|h| *h == "status")
        .ok_or("no `status` column")?;
    Ok(lines
        .map(|l| {
            header[..=end]
                .iter()
                .zip(l.split(','))
                .map(|(h, c)| ((*h).to_owned(), c.to_owned()))
                .collect()
        })
        .collect())
}

fn cell(r: &Row, key: &str) -> Result<Option<f64>> {
    match r.get(key).map(String::as_str) {
        None => Err(format!("no column `{key}`")),
        Some("") => Ok(None),
        Some(c) => c
            .parse()
            .map(Some)
            .map_err(|_| format!("`{key}` = `{c}` is not a number")),
    }
}

fn diverged(r: &Row) -> bool {
    r.get("diverged").map(String::as_str) == Some("true")
}

/// A cell of a `Ts × h` grid: `h`, diverged, max error after `2 Ts`.
type GridCell = (f64, bool, Option<f64>);

/// Per `Ts`: the largest `h` of the grid up to which no run diverges, the smallest that
/// diverges, and the largest error after `2 Ts` of the stable cells.
fn ts_h_table(rows: &[Row]) -> Result<String> {
    let mut by_ts: Vec<(f64, Vec<GridCell>)> = Vec::new();
    for r in rows {
        if r.get("status").map(String::as_str) != Some("ok") {
            return Err(format!("run {} is not ok", r.get("run").map_or("?", |v| v)));
        }
        let ts = cell(r, "controller.ts")?.ok_or("a row without controller.ts")?;
        let h = cell(r, "simulation.h")?.ok_or("a row without simulation.h")?;
        let cell = (h, diverged(r), cell(r, "max_error_after_predefined_time")?);
        match by_ts.iter_mut().find(|(t, _)| *t == ts) {
            Some((_, cells)) => cells.push(cell),
            None => by_ts.push((ts, vec![cell])),
        }
    }
    by_ts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut t = String::from(
        "| Ts | stable up to h (grid) | diverges from h | max error after 2Ts (stable cells) |\n|---|---|---|---|\n",
    );
    for (ts, mut cells) in by_ts {
        cells.sort_by(|a, b| a.0.total_cmp(&b.0));
        let first_bad = cells.iter().position(|c| c.1);
        let stable = &cells[..first_bad.unwrap_or(cells.len())];
        let up_to = match (stable.last(), first_bad) {
            (None, _) => "none".to_owned(),
            (Some(c), None) => format!("≥ {}", ms(c.0)),
            (Some(c), Some(_)) => ms(c.0),
        };
        let from = first_bad.map_or("–".to_owned(), |k| ms(cells[k].0));
        let err = stable
            .iter()
            .filter_map(|c| c.2)
            .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))))
            .map_or("–".to_owned(), |e| fixed(e, 3));
        let _ = writeln!(t, "| {ts} | {up_to} | {from} | {err} |");
    }
    Ok(t)
}

/// Nearest-rank percentile of sorted values.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let k = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[k.clamp(1, sorted.len()) - 1]
}

fn monte_carlo(rows: &[Row], key: &str) -> Result<String> {
    let mut errors: Vec<f64> = Vec::new();
    for r in rows.iter().filter(|r| !diverged(r)) {
        errors.push(
            cell(r, "max_error_after_predefined_time")?
                .ok_or("a bounded run without an error after 2Ts")?,
        );
    }
    errors.sort_by(f64::total_cmp);
    if errors.is_empty() && key.starts_with("error") {
        return Err("every run diverged".into());
    }
    Ok(match key {
        "runs" => grouped(rows.len() as f64, 0),
        "diverged" => grouped((rows.len() - errors.len()) as f64, 0),
        "bounded" => grouped(errors.len() as f64, 0),
        "error-min" => fixed(errors[0], 3),
        "error-max" => fixed(errors[errors.len() - 1], 3),
        "error-median" => fixed(percentile(&errors, 50.0), 3),
        "error-p95" => fixed(percentile(&errors, 95.0), 3),
        other => return Err(format!("no Monte Carlo figure `{other}`")),
    })
}

// ---------------------------------------------------------------------------------------------
// Torque limit, PIL, sizes

fn torque_table(v: &Value) -> Result<String> {
    let mut t = String::from(
        "| u_max [N m] | settling time (b = 0.05) [s] | max error after 2Ts | saturated | tracks |\n|---|---|---|---|---|\n",
    );
    for p in v["points"].as_array().ok_or("no `points`")? {
        let f = |k: &str| opt(p, k).map_or("never".to_owned(), |x| fixed(x, 3));
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} % | {} |",
            fixed(num(p, "u_max")?, 2),
            f("settling_time"),
            f("max_error_after_predefined_time"),
            fixed(100.0 * num(p, "saturated_fraction")?, 1),
            if p["tracks"].as_bool() == Some(true) {
                "yes"
            } else {
                "no"
            }
        );
    }
    Ok(t)
}

fn pil_table(s: &Value) -> Result<String> {
    let t_end = num(s, "t_end")?;
    let mut t = format!(
        "| agent ({} s run) | ticks | instructions min | median | p99 | max | stack B |\n|---|---|---|---|---|---|---|\n",
        t_end
    );
    for a in s["firmware"]
        .as_array()
        .ok_or("no `firmware` (not a PIL run?)")?
    {
        let g = |k: &str| num(a, k).map(|x| grouped(x, 0));
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} | {} |",
            g("agent")?,
            g("steps")?,
            g("instructions_min")?,
            g("instructions_median")?,
            g("instructions_p99")?,
            g("instructions_max")?,
            g("stack_bytes")?
        );
    }
    Ok(t)
}

/// `size_of` figures from the output of `controller-core/tests/sizes.rs`.
fn sizes_figure(out: &str, key: &str) -> Result<String> {
    let pattern = match key {
        "controller" => "Controller<2, 2, 4>: ",
        "params" => "Params<2>: ",
        "state" => "State<2, 2, 4>: ",
        "controller-n3" => "Controller<3, 3, 4>: ",
        other => return Err(format!("no size `{other}`")),
    };
    let at = out
        .find(pattern)
        .ok_or_else(|| format!("the sizes test printed no `{pattern}`"))?;
    let bytes: String = out[at + pattern.len()..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    if bytes.is_empty() {
        return Err(format!("no number after `{pattern}`"));
    }
    Ok(bytes)
}

// ---------------------------------------------------------------------------------------------
// Wall-clock figures (exempt from --check)

fn wall_example1(src: &mut Sources) -> Result<String> {
    let bin = src.host_sim()?;
    let out = workspace_root().join("target/docs/wall/example1");
    let mut times = Vec::new();
    for _ in 0..20 {
        let start = Instant::now();
        run(Command::new(&bin)
            .current_dir(workspace_root())
            .args([
                "run",
                "scenarios/example1.toml",
                "--no-plots",
                "--quiet",
                "--out",
            ])
            .arg(&out))?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    Ok(format!(
        "{:.1} ms best of 20, median {:.1} ms ({}, {})",
        times[0],
        times[10],
        today(),
        machine()
    ))
}

/// The UTC date, `YYYY-MM-DD`.
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (y, m, d) = civil_from_days((secs / 86_400) as i64);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Proleptic Gregorian date of a day count since 1970-01-01 (Howard Hinnant's algorithm).
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// CPU model, core count and the one-minute load average.
fn machine() -> String {
    let model = fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, m)| m.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned());
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let load = fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(|l| format!(", load {l}")))
        .unwrap_or_default();
    format!("{model}, {cores} cores{load}")
}

/// `docs/agent-node.eds`: the CiA 306 data sheet of the node's object dictionary, written from
/// the same table the SDO server serves (`agent_node::canopen::eds`); `check` compares.
fn eds(check: bool) -> Result<()> {
    let path = workspace_root().join("docs/agent-node.eds");
    let device = agent_node::canopen::eds::reference_device()
        .ok_or("the reference node's configuration is not representable")?;
    let mut want = String::new();
    agent_node::canopen::eds::write_eds(&mut want, &device, "agent-node.eds")
        .map_err(|e| format!("writing the EDS: {e}"))?;
    let have = fs::read_to_string(&path).unwrap_or_default();
    if have == want {
        return Ok(());
    }
    if check {
        return Err(
            "docs/agent-node.eds differs from the object dictionary (`cargo xtask docs --only eds` rewrites it)"
                .into(),
        );
    }
    fs::write(&path, want).map_err(|e| format!("docs/agent-node.eds: {e}"))?;
    println!("docs/agent-node.eds: rewritten");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures(name: &str) -> Result<Option<String>> {
        Ok(match name {
            "a" => Some("1,089".into()),
            "t" => Some("| x |\n|---|\n| 1 |\n".into()),
            _ => None,
        })
    }

    #[test]
    fn finds_inline_and_block_figures_with_their_lines() {
        let text = "x <!-- fig:a -->1<!-- /fig:a --> y\n<!-- fig:t -->\n| x |\n<!-- /fig:t -->\n";
        let b = blocks(text).expect("valid markers");
        assert_eq!(b.len(), 2);
        assert_eq!(
            (b[0].name.as_str(), &text[b[0].body.clone()], b[0].line),
            ("a", "1", 1)
        );
        assert_eq!(
            (b[1].name.as_str(), &text[b[1].body.clone()], b[1].line),
            ("t", "\n| x |\n", 2)
        );
    }

    #[test]
    fn rewrites_inline_figures_in_place_and_tables_on_their_own_lines() {
        let text = "costs <!-- fig:a -->1,244<!-- /fig:a --> instructions\n<!-- fig:t -->\nold\n<!-- /fig:t -->\nend\n";
        let r = rewrite(text, |_| false, figures).expect("known figures");
        assert_eq!(
            r.text,
            "costs <!-- fig:a -->1,089<!-- /fig:a --> instructions\n<!-- fig:t -->\n| x |\n|---|\n| 1 |\n<!-- /fig:t -->\nend\n"
        );
        assert_eq!(r.changed.len(), 2);
        let again = rewrite(&r.text, |_| false, figures).expect("known figures");
        assert_eq!(again.text, r.text);
        assert!(
            again.changed.is_empty(),
            "a rewritten document is up to date"
        );
    }

    #[test]
    fn a_changed_figure_is_reported_with_its_block_and_line() {
        let text = "line one\nit costs <!-- fig:a -->1,244<!-- /fig:a -->\n";
        let r = rewrite(text, |_| false, figures).expect("known figure");
        assert_eq!(
            r.changed,
            vec![("a".to_owned(), 2, "1,244".to_owned(), "1,089".to_owned())]
        );
    }

    #[test]
    fn an_unknown_block_is_an_error_naming_it() {
        let text = "\n\n<!-- fig:nope -->1<!-- /fig:nope -->\n";
        let e = rewrite(text, |_| false, figures).expect_err("unknown figure");
        assert!(
            e.contains("unknown figure block `fig:nope`") && e.contains("line 3"),
            "{e}"
        );
    }

    #[test]
    fn kept_blocks_are_neither_rendered_nor_reported() {
        let text = "<!-- fig:wall.x -->5 ms (2026-01-01)<!-- /fig:wall.x -->";
        let r = rewrite(text, |n| n.starts_with("wall."), figures).expect("kept");
        assert_eq!((r.text.as_str(), r.changed.len(), r.skipped), (text, 0, 1));
    }

    #[test]
    fn bad_markers_are_errors() {
        for (text, says) in [
            ("<!-- fig:a -->1", "never closed"),
            ("1<!-- /fig:a -->", "closes no open block"),
            ("<!-- fig:a -->1<!-- /fig:b -->", "closes `fig:a`"),
            (
                "<!-- fig:a --><!-- fig:b --><!-- /fig:b --><!-- /fig:a -->",
                "opens inside",
            ),
            ("<!-- fig:a b -->1<!-- /fig:a b -->", "bad figure name"),
        ] {
            let e = blocks(text).expect_err(text);
            assert!(e.contains(says), "{text}: {e}");
        }
        assert!(blocks("<!-- a comment --> and <!-- bench-table -->").is_ok_and(|b| b.is_empty()));
    }

    #[test]
    fn numbers_are_grouped_by_thousands() {
        assert_eq!(grouped(1089.0, 0), "1,089");
        assert_eq!(grouped(16519.06, 1), "16,519.1");
        assert_eq!(grouped(987.0, 0), "987");
        assert_eq!(grouped(1_234_567.0, 0), "1,234,567");
        assert_eq!(grouped(-0.04, 1), "0.0");
    }

    #[test]
    fn estimates_keep_three_significant_digits() {
        assert_eq!(sig3(0.0632), "0.0632");
        assert_eq!(sig3(0.182), "0.182");
        assert_eq!(sig3(0.11), "0.110");
        assert_eq!(sig3(3.83e-6), "3.83e-6");
        assert_eq!(sig3(12.34), "12.3");
    }

    #[test]
    fn sample_periods_in_milliseconds() {
        assert_eq!(ms(0.006_79), "6.79 ms");
        assert_eq!(ms(0.000_415), "0.415 ms");
        assert_eq!(ms(0.001), "1 ms");
        assert_eq!(ms(0.0002), "0.2 ms");
    }

    #[test]
    fn stable_h_lines_are_parsed() {
        let out =
            "h = 1e-3: ok\nlargest stable h = 6.7900e-3 s (unstable at 6.9100e-3 s; band 0.25)\n";
        assert_eq!(parse_stable_h(out), Some((6.79e-3, Some(6.91e-3))));
        assert_eq!(
            parse_stable_h("stable at h-max = 5.0000e-2 s (band 0.25)"),
            Some((0.05, None))
        );
        assert_eq!(parse_stable_h("unstable even at h-min"), None);
    }

    #[test]
    fn fault_matrix_verdicts_count_safety_on_rows() {
        let md = "| # | fault | case | safety | a | b | c | d | goal |\n|---|---|---|---|---|---|---|---|---|\n\
                  | 1 | f | c | off | – | 1 | 0 | 0 | – |\n| 1 | f | c | on | – | 1 | 0 | 0 | met |\n\
                  | 2 | g | c | on | 1 | 1 | – | – | **not met** |\n";
        let m = Matrix {
            json: Value::Null,
            md: md.into(),
        };
        assert_eq!((matrix_met(&m), matrix_cells(&m)), (1, 2));
    }

    #[test]
    fn sizes_come_from_the_test_output() {
        let out = "Controller<2, 2, 4>: 464 B (Params<2>: 260 B, State<2, 2, 4>: 204 B)\nController<3, 3, 4>: 560 B\n";
        assert_eq!(sizes_figure(out, "controller").as_deref(), Ok("464"));
        assert_eq!(sizes_figure(out, "state").as_deref(), Ok("204"));
        assert_eq!(sizes_figure(out, "controller-n3").as_deref(), Ok("560"));
        assert!(sizes_figure(out, "nope").is_err());
    }

    /// A workspace with `README.md` and `docs/B.md`, each quoting figure `a`.
    fn workspace(name: &str, quoted: &str) -> PathBuf {
        let root = std::env::temp_dir().join(format!("xtask-docs-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&root);
        fs::create_dir_all(root.join("docs")).expect("temporary directory");
        let doc = format!("# B\nsteps cost <!-- fig:a -->{quoted}<!-- /fig:a --> instructions\n");
        fs::write(root.join("README.md"), "no figures\n").expect("write");
        fs::write(root.join("docs/B.md"), &doc).expect("write");
        root
    }

    #[test]
    fn check_fails_naming_file_line_and_block_and_writes_nothing() {
        let root = workspace("check", "1,244");
        let e = process(&root, None, true, |_| false, figures).expect_err("a stale figure");
        assert!(e.contains("docs/B.md:2: block `fig:a` differs"), "{e}");
        assert!(
            e.contains("document: 1,244") && e.contains("measured: 1,089"),
            "{e}"
        );
        let doc = fs::read_to_string(root.join("docs/B.md")).expect("read");
        assert!(doc.contains("-->1,244<"), "--check must not write");
        process(&root, None, false, |_| false, figures).expect("rewrite");
        process(&root, None, true, |_| false, figures).expect("up to date after the rewrite");
        let _ = fs::remove_dir_all(&root);
    }

    #[test]
    fn check_passes_when_every_figure_matches() {
        let root = workspace("match", "1,089");
        process(&root, None, true, |_| false, figures).expect("figures match");
        let _ = fs::remove_dir_all(&root);
    }

    #[test]
    fn every_block_in_the_repository_names_a_known_figure() {
        let root = workspace_root();
        let mut names = 0;
        for file in documents(&root).expect("README.md and docs/") {
            let text = fs::read_to_string(root.join(&file)).expect("readable");
            for b in blocks(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display())) {
                assert!(
                    parse(&b.name).is_some(),
                    "{}:{}: unknown figure block `fig:{}`",
                    file.display(),
                    b.line,
                    b.name
                );
                names += 1;
            }
        }
        assert!(names > 0, "the documents quote no measured figure");
    }

    #[test]
    fn names_with_an_unknown_scenario_key_or_case_are_unknown() {
        assert_eq!(
            parse("run.example1.max_error"),
            Some(Figure::Run("example1", "max_error"))
        );
        assert_eq!(parse("board.flash"), Some(Figure::Board("flash")));
        for name in [
            "run.example9.max_error",
            "run.example1.nope",
            "matrix.example3",
            "sizes.x",
            "pil.x",
            "board.x",
            "board",
        ] {
            assert_eq!(parse(name), None, "{name}");
        }
    }

    #[test]
    fn ts_h_maps_give_the_stable_range_per_ts() {
        let csv = "run,controller.ts,simulation.h,diverged,divergence_time,settling_time,max_error_after_predefined_time,max_abs_u,total_u_energy,status,error\n\
                   0,1,0.001,false,,,0.09,1,1,ok,\n1,1,0.002,false,,,0.091,1,1,ok,\n2,1,0.003,true,0.01,,,1,1,ok,\n\
                   3,2,0.001,false,,,0.17,1,1,ok,\n4,2,0.003,false,,,0.171,1,1,ok,\n\
                   5,0.5,0.001,true,0.01,,,1,1,ok,\n";
        let t = ts_h_table(&rows(csv).expect("csv")).expect("table");
        let lines: Vec<&str> = t.lines().skip(2).collect();
        assert_eq!(
            lines,
            [
                "| 0.5 | none | 1 ms | – |",
                "| 1 | 2 ms | 3 ms | 0.091 |",
                "| 2 | ≥ 3 ms | – | 0.171 |"
            ]
        );
    }

    #[test]
    fn monte_carlo_figures_count_and_rank_the_bounded_runs() {
        let mut csv =
            String::from("run,diverged,max_error_after_predefined_time,status,error,draw\n");
        for k in 0..20 {
            let diverged = k % 4 == 0;
            let e = if diverged {
                String::new()
            } else {
                format!("0.{:03}", 100 + k)
            };
            csv.push_str(&format!("{k},{diverged},{e},ok,,\"a, b\"\n"));
        }
        let r = rows(&csv).expect("csv");
        let f = |k: &str| monte_carlo(&r, k).expect(k);
        assert_eq!(
            (f("runs"), f("diverged"), f("bounded")),
            ("20".into(), "5".into(), "15".into())
        );
        assert_eq!(
            (f("error-min"), f("error-max")),
            ("0.101".into(), "0.119".into())
        );
        assert_eq!(f("error-median"), "0.110");
        assert_eq!(f("error-p95"), "0.119");
    }

    #[test]
    fn days_since_the_epoch_are_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_788), (2026, 12, 1));
    }
}
