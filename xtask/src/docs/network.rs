//! Figures of docs/NETWORK.md: the bus runs of `hil-mock/tests` (`network.bus`,
//! `network.silent.KEY`, `network.starved.KEY`), the shipped CAN scenarios and their variants
//! (`network.scenarios`, `network.lossy.KEY`) and the lossy run the emulated nodes match
//! (`network.pil-lossy.KEY`).

use std::{fmt::Write as _, fs, process::Command};

use serde_json::Value;

use super::{fixed, grouped, num, run, Sources};
use crate::task::{cargo, workspace_root, Result};

/// Where `hil-mock/tests` write one JSON per run (`HIL_MOCK_FIGURES_OUT`).
const HIL_MOCK_DIR: &str = "target/docs/hil-mock";

/// Runs of `hil-mock/tests` in the bus table: record, label, window of the error.
const BUS_RUNS: [(&str, &str, &str); 9] = [
    ("ideal", "ideal link (no network)", "t ≥ 4 s"),
    ("can-1m", "1 Mbit/s, no loss", "t ≥ 4 s"),
    (
        "can-500k",
        "500 kbit/s, no loss (2 s; by hand 5 · 95 bit / 500 kbit/s per 1 ms = 95 %)",
        "t ≥ 1 s",
    ),
    ("loss-10", "1 Mbit/s, 10 % loss", "t ≥ 4 s"),
    ("loss-30", "1 Mbit/s, 30 % loss", "t ≥ 4 s"),
    ("silent-3", "agent 3 silent 5–7 s", "t ≥ 8.5 s"),
    (
        "babbling-2",
        "agent 2 babbling id 0, 1.0–1.2 s (3 s run)",
        "t ≥ 2.5 s",
    ),
    ("corruption-2", "2 % corruption (2 s)", "t ≥ 1 s"),
    ("corruption-30", "30 % corruption (2 s)", "t ≥ 1 s"),
];

/// Inline figures of the silent-agent run (`network.silent.KEY`).
pub const SILENT_KEYS: [&str; 6] = [
    "held",
    "agent4-error",
    "agent4-x2",
    "recovered",
    "without",
    "stale-samples",
];

/// Inline figures of the longer starvation (`network.starved.KEY`).
pub const STARVED_KEYS: [&str; 4] = ["escape", "yd-moved", "max-x-0.3", "max-x-0.2"];

/// The shipped-scenario table's runs: scenario, tag, `--set`s, label, bus.
type ScenarioRun = (
    &'static str,
    &'static str,
    &'static [&'static str],
    &'static str,
    &'static str,
);

const SCENARIO_RUNS: [ScenarioRun; 5] = [
    ("example1", "", &[], "`example1.toml` (ideal)", "–"),
    (
        "example1-can",
        "",
        &[],
        "`example1-can.toml`",
        "1 Mbit/s, no loss",
    ),
    (
        "example1-lossy",
        "",
        &[],
        "`example1-lossy.toml`",
        "500 kbit/s, 10 % loss, agent 3 silent 5–7 s",
    ),
    (
        "example1-lossy",
        "-no-events",
        &["network.event=[]"],
        "`example1-lossy.toml`, `--set 'network.event=[]'`",
        "500 kbit/s, 10 % loss",
    ),
    (
        "example1-lossy",
        "-loss30",
        &["network.event=[]", "network.loss=0.3"],
        "same, `--set network.loss=0.3`",
        "500 kbit/s, 30 % loss",
    ),
];

/// Windows of `example1-lossy` (`network.lossy.KEY`): from, until \[s\].
const WINDOWS: [(&str, f64, f64); 4] = [
    ("before", 4.0, 5.0),
    ("silent", 5.0, 7.0),
    ("return", 7.0, 8.5),
    ("after", 8.5, f64::INFINITY),
];

/// Inline figures of `example1-lossy` besides its windows.
const LOSSY_KEYS: [&str; 3] = ["max-u-return", "ideal-after", "after-vs-ideal"];

/// Inline figures of `example1-lossy` over 7.5 s (`network.pil-lossy.KEY`).
pub const PIL_LOSSY_KEYS: [&str; 4] = ["lost", "stale", "suppressed", "can-sent"];

/// Inline figures of the bus trace decoded with cantools (`network.trace.KEY`).
pub const TRACE_KEYS: [&str; 2] = ["frames", "max-diff"];

/// Figures of the node firmware's watchdog (`network.watchdog.KEY`): agent 3 of Example 1
/// over `kind = "pil"`, hung at [`WATCHDOG_EVENT_AT`] or slowed to 5 sample periods per step
/// for 50 ms from then, against `example1-can` (which the PIL run reproduces bit for bit).
pub const WATCHDOG_KEYS: [&str; 6] = [
    "hang-overruns",
    "hang-reset-ms",
    "hang-recovered-s",
    "slow-resets",
    "slow-reset-ms",
    "slow-recovered-s",
];

/// Start of the hang or slow window \[s\], its runs' horizon, and the recovery tolerance (those
/// of `host-sim/tests/pil.rs`).
const WATCHDOG_EVENT_AT: f64 = 0.5;
const WATCHDOG_T_END: &str = "simulation.t_end=3";
const WATCHDOG_RECOVERED: f64 = 0.005;

/// Horizon of the lossy run compared with the emulated nodes \[s\].
const PIL_LOSSY_T_END: &str = "simulation.t_end=7.5";

/// Whether `key` is an inline figure of `example1-lossy`.
pub fn lossy_key(key: &str) -> bool {
    WINDOWS.iter().any(|w| w.0 == key) || LOSSY_KEYS.contains(&key)
}

/// Whether `name` (after `network.`) is a figure of this family.
pub fn known(name: &str) -> bool {
    match name.split_once('.') {
        None => ["bus", "scenarios", "bench-load"].contains(&name),
        Some(("silent", k)) => SILENT_KEYS.contains(&k),
        Some(("starved", k)) => STARVED_KEYS.contains(&k),
        Some(("lossy", k)) => lossy_key(k),
        Some(("pil-lossy", k)) => PIL_LOSSY_KEYS.contains(&k),
        Some(("trace", k)) => TRACE_KEYS.contains(&k),
        Some(("watchdog", k)) => WATCHDOG_KEYS.contains(&k),
        Some(_) => false,
    }
}

/// Renders `name` (after `network.`), a name [`known`] accepts.
pub fn render(src: &mut Sources, name: &str) -> Result<String> {
    match name.split_once('.') {
        None if name == "bus" => bus_table(src),
        None if name == "scenarios" => scenario_table(src),
        None if name == "bench-load" => bench_load_table(src),
        Some(("silent", k)) => silent(src, k),
        Some(("starved", k)) => starved(src, k),
        Some(("lossy", k)) => lossy(src, k),
        Some(("pil-lossy", k)) => pil_lossy(src, k),
        Some(("watchdog", k)) => watchdog(src, k),
        Some(("trace", k)) => {
            let (frames, diff) = parse_decoded(&src.decoded_trace()?)?;
            match k {
                "frames" => Ok(grouped(frames, 0)),
                "max-diff" => Ok(format!("{diff:.1e}")),
                other => Err(format!("no trace figure `{other}`")),
            }
        }
        _ => Err(format!("no network figure `{name}`")),
    }
}

impl Sources {
    /// Every run `hil-mock/tests` recorded, by name.
    fn hil_mock(&mut self) -> Result<Value> {
        self.records(
            "target/docs/hil-mock.json",
            HIL_MOCK_DIR,
            "HIL_MOCK_FIGURES_OUT",
            &[
                "-p",
                "hil-mock",
                "--test",
                "example1_can",
                "--test",
                "faults",
            ],
        )
    }

    /// The JSON files a release `cargo test` with `args` writes into `dir` (named by the
    /// environment variable `env`), merged into one object by file stem at `path`.
    pub(super) fn records(
        &mut self,
        path: &str,
        dir: &'static str,
        env: &str,
        args: &[&str],
    ) -> Result<Value> {
        self.json_file(path, |_, file| {
            let out = workspace_root().join(dir);
            let _ = fs::remove_dir_all(&out);
            run(Command::new(cargo())
                .current_dir(workspace_root())
                .env(env, &out)
                .args(["test", "--release", "--quiet"])
                .args(args))?;
            let mut all = serde_json::Map::new();
            let entries = fs::read_dir(&out).map_err(|e| format!("{dir}: {e}"))?;
            for e in entries.filter_map(|e| e.ok()) {
                let p = e.path();
                let Some(name) = p.file_stem().and_then(|s| s.to_str()) else {
                    continue;
                };
                let text = fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
                let v: Value =
                    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", p.display()))?;
                all.insert(name.to_owned(), v);
            }
            fs::write(file, Value::Object(all).to_string())
                .map_err(|e| format!("{}: {e}", file.display()))
        })
    }

    /// What `host-sim/tests/decode_trace.py` (cantools, `docs/wire.dbc`) prints for 0.3 s of
    /// `example1-can` run with `--trace`, as `host-sim/tests/trace.rs` runs it.
    fn decoded_trace(&mut self) -> Result<String> {
        let path = "target/docs/trace/decoded.txt";
        let file = self.file(path, |s, file| {
            let bin = s.host_sim()?;
            let dir = file.parent().unwrap_or(file);
            let root = workspace_root();
            run(Command::new(bin)
                .current_dir(&root)
                .args(["run", "--quiet", "--no-plots", "--out"])
                .arg(dir)
                .arg("scenarios/example1-can.toml")
                .args(["--set", "simulation.t_end=0.3", "--trace"])
                .arg(dir.join("bus.log")))?;
            let out = run(Command::new("python3")
                .current_dir(&root)
                .args(["host-sim/tests/decode_trace.py", "docs/wire.dbc"])
                .arg(dir.join("bus.log"))
                .arg(dir.join("trajectory.csv"))
                .args(["0.001", "4"]))?;
            fs::write(file, out).map_err(|e| format!("{path}: {e}"))
        })?;
        fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))
    }

    /// One run `hil-mock/tests` recorded.
    fn hil_mock_run(&mut self, name: &str) -> Result<Value> {
        let all = self.hil_mock()?;
        all.get(name)
            .cloned()
            .ok_or_else(|| format!("hil-mock/tests recorded no run `{name}`"))
    }

    /// `summary.json` and `trajectory.csv` of a shipped scenario run with `--set`s.
    fn run_with_trajectory(
        &mut self,
        stem: &str,
        tag: &str,
        sets: &[&str],
    ) -> Result<(Value, Trajectory)> {
        let s = self.summary_with(stem, tag, sets)?;
        let path = format!("target/docs/run/{stem}{tag}/trajectory.csv");
        let text =
            fs::read_to_string(workspace_root().join(&path)).map_err(|e| format!("{path}: {e}"))?;
        let t = Trajectory::parse(&text).map_err(|e| format!("{path}: {e}"))?;
        Ok((s, t))
    }
}

/// The columns of a `trajectory.csv`.
pub struct Trajectory {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Trajectory {
    pub fn parse(csv: &str) -> Result<Self> {
        let mut lines = csv.lines();
        let header: Vec<String> = lines
            .next()
            .ok_or("empty")?
            .split(',')
            .map(str::to_owned)
            .collect();
        let rows = lines
            .enumerate()
            .map(|(k, l)| {
                l.split(',')
                    .map(|c| c.parse::<f64>())
                    .collect::<std::result::Result<Vec<f64>, _>>()
                    .map_err(|_| format!("line {}: not a number", k + 2))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Trajectory { header, rows })
    }

    fn column(&self, name: &str) -> Result<usize> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| format!("no column `{name}`"))
    }

    /// Max of `f(row)` over the samples with `from ≤ t < until`.
    fn max_over(&self, from: f64, until: f64, f: impl Fn(&[f64]) -> f64) -> Result<f64> {
        let t = self.column("t")?;
        self.rows
            .iter()
            .filter(|r| r[t] >= from && r[t] < until)
            .map(|r| f(r))
            .reduce(f64::max)
            .ok_or_else(|| format!("no sample in [{from}, {until})"))
    }

    /// Max over agents and samples in `[from, until)` of `|y_i − y_d|`.
    pub fn max_error(&self, from: f64, until: f64) -> Result<f64> {
        let yd = self.column("yd")?;
        let ys: Vec<usize> = (0..self.header.len())
            .filter(|&k| {
                let h = &self.header[k];
                h.len() > 1 && h.starts_with('y') && h[1..].chars().all(|c| c.is_ascii_digit())
            })
            .collect();
        if ys.is_empty() {
            return Err("no output column `y<i>`".into());
        }
        self.max_over(from, until, |r| {
            ys.iter().map(|&k| (r[k] - r[yd]).abs()).fold(0.0, f64::max)
        })
    }

    /// Max over commands `u<i>_<l>` and samples in `[from, until)` of `|u|`.
    pub fn max_abs_u(&self, from: f64, until: f64) -> Result<f64> {
        let us: Vec<usize> = (0..self.header.len())
            .filter(|&k| self.header[k].starts_with('u') && self.header[k].contains('_'))
            .collect();
        self.max_over(from, until, |r| {
            us.iter().map(|&k| r[k].abs()).fold(0.0, f64::max)
        })
    }
}

/// Frames decoded and the largest `|decoded − csv|` of `decode_trace.py`'s line
/// `decoded 1495 frames over 299 samples; max |y - csv| = 7.611e-06`.
fn parse_decoded(out: &str) -> Result<(f64, f64)> {
    let line = out
        .lines()
        .find(|l| l.starts_with("decoded "))
        .ok_or("decode_trace.py printed no `decoded …` line")?;
    let frames = line["decoded ".len()..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .ok_or_else(|| format!("no frame count in `{line}`"))?;
    let diff = line
        .rsplit_once("= ")
        .and_then(|(_, x)| x.trim().parse().ok())
        .ok_or_else(|| format!("no max difference in `{line}`"))?;
    Ok((frames, diff))
}

/// `−0.2174`: a signed value with a true minus sign.
fn signed(x: f64, decimals: usize) -> String {
    let s = fixed(x.abs(), decimals);
    if x < 0.0 && s.chars().any(|c| c.is_ascii_digit() && c != '0') {
        format!("−{s}")
    } else {
        s
    }
}

/// An age or latency in seconds: `1.000 ms`, `2.001 s`.
fn duration(s: f64) -> String {
    if s >= 0.1 {
        format!("{} s", fixed(s, 3))
    } else {
        format!("{} ms", fixed(s * 1e3, 3))
    }
}

/// A latency in seconds as whole microseconds: `472 µs`.
fn micros(s: f64) -> String {
    format!("{} µs", grouped(s * 1e6, 0))
}

fn count(v: &Value, key: &str) -> Result<String> {
    num(v, key).map(|x| grouped(x, 0))
}

/// The bus table of §5 from the runs `hil-mock/tests` recorded.
pub fn bus_table(src: &mut Sources) -> Result<String> {
    let ideal = num(&src.hil_mock_run("ideal")?, "max_error")?;
    let mut t = String::from(
        "| run | max \\|y_i − y_d\\| (window) | bus load | sent | lost | corrupted | deadline misses | seq gaps | stale link-samples | age of data used max / mean | other |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (name, label, window) in BUS_RUNS {
        let r = src.hil_mock_run(name)?;
        let e = num(&r, "max_error")?;
        let mut error = format!("{} ({window})", fixed(e, 4));
        if name == "can-1m" {
            error = format!(
                "{} ({window}; {:+.1} % vs ideal)",
                fixed(e, 4),
                100.0 * (e / ideal - 1.0)
            );
        }
        if name == "silent-3" {
            error = format!(
                "{} ({window}; {} without)",
                fixed(e, 4),
                fixed(num(&r, "max_error_without")?, 4)
            );
        }
        if r.get("frames_sent").is_none() {
            let _ = writeln!(
                t,
                "| {label} | {error} | – | – | – | – | – | – | – | – | – |"
            );
            continue;
        }
        let mut other = vec![format!("latency ≤ {}", micros(num(&r, "max_latency_s")?))];
        for (key, what) in [
            ("suppressed", "suppressed"),
            (
                "babble_frames",
                "babble frames (counted malformed by every receiver)",
            ),
            ("bus_off_events", "bus-off events with recovery"),
        ] {
            if num(&r, key)? > 0.0 {
                other.push(format!("{} {what}", count(&r, key)?));
            }
        }
        if num(&r, "frames_corrupted")? > 0.0 {
            other.push(format!("max TEC {}", count(&r, "max_tec")?));
        }
        let _ = writeln!(
            t,
            "| {label} | {error} | {} % | {} | {} | {} | {} | {} | {} | {} / {} | {} |",
            fixed(num(&r, "load_percent")?, 2),
            count(&r, "frames_sent")?,
            count(&r, "frames_lost")?,
            count(&r, "frames_corrupted")?,
            count(&r, "deadline_misses")?,
            count(&r, "seq_gaps")?,
            count(&r, "stale_samples")?,
            duration(num(&r, "max_age_s")?),
            duration(num(&r, "mean_age_s")?),
            other.join(", ")
        );
    }
    Ok(t)
}

/// One figure of the silent-agent run of `hil-mock/tests/faults.rs`.
pub fn silent(src: &mut Sources, key: &str) -> Result<String> {
    let r = src.hil_mock_run("silent-3")?;
    Ok(match key {
        "held" => signed(num(&r, "held_y3")?, 4),
        "agent4-error" => fixed(num(&r, "agent4_max_error_silent")?, 2),
        "agent4-x2" => fixed(num(&r, "agent4_max_x2_after")?, 2),
        "recovered" => fixed(num(&r, "max_error")?, 4),
        "without" => fixed(num(&r, "max_error_without")?, 4),
        "stale-samples" => count(&r, "agent4_stale_samples")?,
        other => return Err(format!("no silent-agent figure `{other}`")),
    })
}

/// One figure of the longer starvation of `hil-mock/tests/faults.rs`.
pub fn starved(src: &mut Sources, key: &str) -> Result<String> {
    Ok(match key {
        "escape" => fixed(
            1e3 * num(&src.hil_mock_run("starvation")?, "escape_after_s")?,
            0,
        ),
        "yd-moved" => fixed(num(&src.hil_mock_run("starvation")?, "yd_moved")?, 2),
        "max-x-0.3" => fixed(num(&src.hil_mock_run("babbling-2-0.3s")?, "max_state")?, 1),
        "max-x-0.2" => fixed(num(&src.hil_mock_run("babbling-2")?, "max_state")?, 1),
        other => return Err(format!("no starvation figure `{other}`")),
    })
}

/// The shipped CAN scenarios and their variants (§7).
pub fn scenario_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from(
        "| scenario | bus | max \\|y_i − y_d\\| after 2Ts | bus load | sent | lost | stale link-samples | age of data used max / mean | deadline misses | other |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (stem, tag, sets, label, bus) in SCENARIO_RUNS {
        let s = src.summary_with(stem, tag, sets)?;
        let error = fixed(num(&s, "max_error_after_predefined_time")?, 4);
        let n = &s["network"];
        if !n.is_object() {
            let _ = writeln!(
                t,
                "| {label} | {bus} | {error} | – | – | – | – | – | – | – |"
            );
            continue;
        }
        let mut other = vec![format!("latency ≤ {}", micros(num(n, "max_latency_s")?))];
        if num(n, "suppressed")? > 0.0 {
            other.push(format!("suppressed {}", count(n, "suppressed")?));
        }
        other.push(format!("max \\|u\\| {}", grouped(num(&s, "max_abs_u")?, 0)));
        let _ = writeln!(
            t,
            "| {label} | {bus} | {error} | {} % | {} | {} | {} | {} / {} | {} | {} |",
            fixed(num(n, "bus_load_percent")?, 2),
            count(n, "frames_sent")?,
            count(n, "frames_lost")?,
            count(n, "stale_samples")?,
            duration(num(n, "max_age_s")?),
            duration(num(n, "mean_age_s")?),
            count(n, "deadline_misses")?,
            other.join(", ")
        );
    }
    Ok(t)
}

/// The frame sets of the bench's load table: tag, `--set`s, label.
const BENCH_FRAME_SETS: [(&str, &[&str], &str); 5] = [
    (
        "",
        &[],
        "classical CAN 1 Mbit/s, one sensor frame per follower",
    ),
    (
        "-fd2",
        &["network.data_bitrate=2000000"],
        "CAN FD 1 / 2 Mbit/s (BRS), one sensor frame per follower",
    ),
    (
        "-fd4",
        &["network.data_bitrate=4000000"],
        "CAN FD 1 / 4 Mbit/s (BRS), one sensor frame per follower",
    ),
    (
        "-fd2-packed",
        &[
            "network.data_bitrate=2000000",
            "network.sensor_frames=packed",
        ],
        "CAN FD 1 / 2 Mbit/s (BRS), packed sensor frame",
    ),
    (
        "-fd4-packed",
        &[
            "network.data_bitrate=4000000",
            "network.sensor_frames=packed",
        ],
        "CAN FD 1 / 4 Mbit/s (BRS), packed sensor frame",
    ),
];

/// The bench's frame sets (Example 1, 4 followers, h = 1 ms): the worst-case load `host-sim
/// check` computes for `scenarios/example1-socketcan.toml`, and the load, deadline misses and
/// latency of `example1-can.toml` with `network.plant_frames = true` over 2 s on the bus model.
pub fn bench_load_table(src: &mut Sources) -> Result<String> {
    let mut t = String::from(
        "| frame set | worst case (`host-sim check`) | modelled (`kind = \"can\"`, 2 s) | deadline misses | latency max |\n|---|---|---|---|---|\n",
    );
    let bin = src.host_sim()?;
    for (tag, sets, label) in BENCH_FRAME_SETS {
        let args: Vec<&str> = sets.iter().flat_map(|s| ["--set", *s]).collect();
        let out = run(Command::new(&bin)
            .current_dir(workspace_root())
            .args(["check", "scenarios/example1-socketcan.toml"])
            .args(&args))?;
        let worst = check_total(&out)
            .ok_or_else(|| format!("host-sim check printed no bus load total for {label}"))?;
        let mut model_sets = vec!["network.plant_frames=true", "simulation.t_end=2"];
        model_sets.extend_from_slice(sets);
        let s = src.summary_with("example1-can", &format!("-bench{tag}"), &model_sets)?;
        let n = &s["network"];
        let _ = writeln!(
            t,
            "| {label} | {worst:.1} % | {} % | {} | {} |",
            fixed(num(n, "bus_load_percent")?, 1),
            count(n, "deadline_misses")?,
            micros(num(n, "max_latency_s")?),
        );
    }
    Ok(t)
}

/// The total of `host-sim check`'s bus load lines: `#   total … : 63.6 %`.
fn check_total(out: &str) -> Option<f64> {
    let line = out.lines().find(|l| l.starts_with("#   total "))?;
    line.rsplit_once(": ")?
        .1
        .trim_end_matches(" %")
        .trim()
        .parse()
        .ok()
}

/// One figure of `example1-lossy` by window, against the ideal `example1`.
pub fn lossy(src: &mut Sources, key: &str) -> Result<String> {
    let (_, lossy) = src.run_with_trajectory("example1-lossy", "", &[])?;
    let after = |tr: &Trajectory| tr.max_error(8.5, f64::INFINITY);
    if let Some((_, from, until)) = WINDOWS.iter().find(|w| w.0 == key) {
        return Ok(fixed(lossy.max_error(*from, *until)?, 3));
    }
    Ok(match key {
        "max-u-return" => grouped(lossy.max_abs_u(7.0, 8.5)?, 0),
        "ideal-after" => fixed(after(&src.run_with_trajectory("example1", "", &[])?.1)?, 3),
        "after-vs-ideal" => {
            let ideal = after(&src.run_with_trajectory("example1", "", &[])?.1)?;
            format!("{:+.1} %", 100.0 * (after(&lossy)? / ideal - 1.0))
        }
        other => return Err(format!("no example1-lossy figure `{other}`")),
    })
}

/// One figure of `example1-lossy` over 7.5 s (`kind = "can"`), and the frames of the full
/// `example1-can` run.
pub fn pil_lossy(src: &mut Sources, key: &str) -> Result<String> {
    if key == "can-sent" {
        let s = src.summary("example1-can")?;
        return count(&s["network"], "frames_sent");
    }
    let s = src.summary_with("example1-lossy", "-7.5s", &[PIL_LOSSY_T_END])?;
    let n = &s["network"];
    match key {
        "lost" => count(n, "frames_lost"),
        "stale" => count(n, "stale_samples"),
        "suppressed" => count(n, "suppressed"),
        other => Err(format!("no lossy-run figure `{other}`")),
    }
}

/// `summary.json` and `trajectory.csv` of `example1-pil` run to [`WATCHDOG_T_END`] with
/// `event` (a `network.event=…` setting), in `target/docs/run/example1-pil-<tag>/`.
fn pil_event_run(src: &mut Sources, tag: &str, event: &str) -> Result<(Value, Trajectory)> {
    let dir = format!("target/docs/run/example1-pil-{tag}");
    let summary = src.json_file(&format!("{dir}/summary.json"), |s, file| {
        let out = file.parent().unwrap_or(file);
        s.run_scenario(
            "example1-pil",
            &["--set", WATCHDOG_T_END, "--set", event],
            out,
        )
    })?;
    Ok((summary, trajectory_at(&dir)?))
}

fn trajectory_at(dir: &str) -> Result<Trajectory> {
    let path = workspace_root().join(dir).join("trajectory.csv");
    Trajectory::parse(&fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?)
}

/// One watchdog figure: agent 3's firmware counts, the time from the event's start to the
/// node's first reset (the sample whose commands are the booting node's zeros) \[ms\], and to
/// the last sample at which some output `y_i` is more than [`WATCHDOG_RECOVERED`] from the run
/// without the event \[s\].
pub fn watchdog(src: &mut Sources, key: &str) -> Result<String> {
    let (run, figure) = key.split_once('-').ok_or("no run")?;
    let event = match run {
        "hang" => format!("network.event=[{{kind=\"hang\", agent=3, from={WATCHDOG_EVENT_AT}}}]"),
        "slow" => format!(
            "network.event=[{{kind=\"slow\", agent=3, from={WATCHDOG_EVENT_AT}, until={}, periods=5}}]",
            WATCHDOG_EVENT_AT + 0.05
        ),
        other => return Err(format!("no watchdog run `{other}`")),
    };
    let (summary, t) = pil_event_run(src, run, &event)?;
    let agent3 = summary["firmware"]
        .get(2)
        .ok_or("summary.json: no firmware[2]")?
        .clone();
    let time = t.column("t")?;
    let after = |r: &&Vec<f64>| r[time] >= WATCHDOG_EVENT_AT;
    match figure {
        "overruns" => count(&agent3, "overruns"),
        "resets" => count(&agent3, "resets"),
        "reset-ms" => {
            let (u1, u2) = (t.column("u3_1")?, t.column("u3_2")?);
            let reset = t
                .rows
                .iter()
                .filter(after)
                .find(|r| r[u1] == 0.0 && r[u2] == 0.0)
                .ok_or("agent 3 was never reset")?;
            Ok(fixed(1e3 * (reset[time] - WATCHDOG_EVENT_AT), 0))
        }
        "recovered-s" => {
            src.summary_with("example1-can", "-3s", &[WATCHDOG_T_END])?;
            let nominal = trajectory_at("target/docs/run/example1-can-3s")?;
            let ys = ["y1", "y2", "y3", "y4"];
            let columns = |tr: &Trajectory| -> Result<Vec<usize>> {
                ys.iter().map(|y| tr.column(y)).collect()
            };
            let (a, b) = (columns(&t)?, columns(&nominal)?);
            if t.rows.len() != nominal.rows.len() {
                return Err("the run and the run without the event differ in length".into());
            }
            let mut last_off = WATCHDOG_EVENT_AT;
            for (ra, rb) in t.rows.iter().zip(&nominal.rows) {
                if a.iter()
                    .zip(&b)
                    .any(|(&ca, &cb)| (ra[ca] - rb[cb]).abs() > WATCHDOG_RECOVERED)
                {
                    last_off = last_off.max(ra[time]);
                }
            }
            Ok(fixed(last_off - WATCHDOG_EVENT_AT, 2))
        }
        other => Err(format!("no watchdog figure `{other}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "t,yd,y1,x1_1,u1_1,u1_2,y2,u2_1,u2_2\n\
                       0.0,0.0,0.5,0.5,3,-4,0.1,1,1\n\
                       1.0,1.0,0.8,0.8,-9,2,1.3,1,1\n\
                       2.0,0.0,0.0,0.0,1,1,0.05,70,1\n";

    #[test]
    fn window_errors_take_the_worst_agent_inside_the_window_only() {
        let t = Trajectory::parse(CSV).expect("csv");
        assert!((t.max_error(0.0, 1.0).expect("one sample") - 0.5).abs() < 1e-12);
        assert!((t.max_error(1.0, f64::INFINITY).expect("two") - 0.3).abs() < 1e-12);
        assert!(t.max_error(5.0, 6.0).is_err(), "no sample there");
    }

    #[test]
    fn window_commands_are_the_largest_magnitude_of_every_actuator() {
        let t = Trajectory::parse(CSV).expect("csv");
        assert_eq!(t.max_abs_u(0.0, 2.0).expect("two samples"), 9.0);
        assert_eq!(t.max_abs_u(0.0, 3.0).expect("three"), 70.0);
    }

    #[test]
    fn a_bad_cell_names_its_line() {
        let e = Trajectory::parse("t,yd\n0,1\n1,x\n")
            .err()
            .expect("not a number");
        assert!(e.contains("line 3"), "{e}");
    }

    #[test]
    fn signs_and_durations_read_as_in_the_text() {
        assert_eq!(signed(-0.21738, 4), "−0.2174");
        assert_eq!(signed(-0.00001, 4), "0.0000");
        assert_eq!(duration(0.001), "1.000 ms");
        assert_eq!(duration(2.001), "2.001 s");
        assert_eq!(micros(0.000_472), "472 µs");
        assert_eq!(micros(0.001_051), "1,051 µs");
    }

    #[test]
    fn the_decoder_line_gives_frames_and_largest_difference() {
        let out = "noise\ndecoded 1495 frames over 299 samples; max |y - csv| = 7.611e-06\n";
        assert_eq!(parse_decoded(out), Ok((1495.0, 7.611e-6)));
        assert!(parse_decoded("decoded x frames").is_err());
        assert!(parse_decoded("nothing").is_err());
    }

    #[test]
    fn names_of_the_family_are_known_and_others_are_not() {
        for name in [
            "bus",
            "scenarios",
            "silent.held",
            "starved.max-x-0.3",
            "lossy.silent",
            "lossy.max-u-return",
            "pil-lossy.lost",
            "trace.max-diff",
            "bench-load",
        ] {
            assert!(known(name), "{name}");
        }
        for name in [
            "bus.x",
            "silent",
            "silent.nope",
            "lossy.during",
            "pil-lossy",
            "trace",
            "trace.nope",
            "x.held",
        ] {
            assert!(!known(name), "{name}");
        }
    }

    #[test]
    fn the_check_total_is_read_from_its_line() {
        let out = "# ok: 4 agents\n#   value 5.000 frames\n#   total 635.8 µs of 1000.0 µs: 63.6 %\n# warning: x";
        assert_eq!(check_total(out), Some(63.6));
        assert_eq!(check_total("# ok: 4 agents\n"), None);
    }
}
