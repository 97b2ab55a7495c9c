//! Figures of docs/CLOCKS.md: the clock campaigns (`clocks.NAME`, `clocks.NAME.KEY`) and the
//! three 60 s runs of the goal (`clocks.goal`, `clocks.goal.RUN`).

use std::{collections::BTreeMap, fmt::Write as _};

use serde_json::Value;

use super::{cell, diverged, fixed, num, Row, Sources};
use crate::task::Result;

/// The campaigns over sync mode × drift × jitter (`campaigns/NAME.toml`).
pub const CAMPAIGNS: [&str; 2] = ["clock-drift", "clock-drift-example2"];

/// Inline figures of a campaign.
pub const KEYS: [&str; 9] = [
    "runs",
    "synchronous",
    "synchronous-settling",
    "worst-none",
    "worst-leader",
    "best-none",
    "energy-max",
    "diverged-none",
    "diverged-leader",
];

/// The goal's runs: Example 1 over CAN for 60 s, synchronous, with ±100 ppm and 20 µs of
/// jitter, and the same released by the leader's frame.
const GOAL: [(&str, &[&str]); 3] = [
    ("synchronous", &[]),
    (
        "free",
        &[
            "clock.drift_ppm=[100, -100, 100, -100]",
            "clock.jitter_us=20",
            "clock.seed=1",
        ],
    ),
    (
        "leader",
        &[
            "clock.drift_ppm=[100, -100, 100, -100]",
            "clock.jitter_us=20",
            "clock.seed=1",
            "clock.sync=\"leader\"",
        ],
    ),
];

/// Horizon of the goal's runs \[s\].
const GOAL_T_END: f64 = 60.0;

/// Whether `name` is a run of the goal.
pub fn goal_run(name: &str) -> bool {
    GOAL.iter().any(|g| g.0 == name && name != "synchronous")
}

impl Sources {
    /// `summary.json` of the goal's run `name`.
    fn clock_goal(&mut self, name: &str) -> Result<Value> {
        let sets = GOAL
            .iter()
            .find(|g| g.0 == name)
            .ok_or_else(|| format!("no goal run `{name}`"))?
            .1;
        let t_end = format!("simulation.t_end={GOAL_T_END}");
        let all: Vec<&str> = std::iter::once(t_end.as_str())
            .chain(sets.iter().copied())
            .collect();
        self.summary_with("example1-can", &format!("-clock-{name}"), &all)
    }
}

/// Max error after `2 Ts` of a summary (`None` when diverged).
fn error(s: &Value) -> Option<f64> {
    s["max_error_after_predefined_time"]
        .as_f64()
        .filter(|_| s["diverged"] == Value::Bool(false))
}

/// `+1.2 %` (relative difference of `x` to `base`).
fn percent(x: f64, base: f64) -> String {
    format!("{:+.1} %", 100.0 * (x / base - 1.0))
}

/// The goal's table: each run's divergence, error after `2 Ts` against the synchronous run,
/// ages, sampling errors and bus cost.
pub fn goal_table(src: &mut Sources) -> Result<String> {
    let base = error(&src.clock_goal("synchronous")?).ok_or("the synchronous run diverged")?;
    let mut t = String::from(
        "| run (Example 1, CAN, 60 s) | diverged | max error after 2Ts | vs synchronous | value age p99 / max [samples] | sampling error p99 [samples] | frames/s | bus load |\n|---|---|---|---|---|---|---|---|\n",
    );
    for (name, _) in GOAL {
        let s = src.clock_goal(name)?;
        let c = &s["clock"];
        let (age, err) = if c.is_object() {
            (
                format!(
                    "{} / {}",
                    fixed(num(&c["sample_age"], "p99")?, 3),
                    fixed(num(&c["sample_age"], "max")?, 3)
                ),
                fixed(num(&c["sampling_error"], "p99")?, 3),
            )
        } else {
            ("–".into(), "0".into())
        };
        let net = &s["network"];
        let _ = writeln!(
            t,
            "| {name} | {} | {} | {} | {age} | {err} | {} | {} % |",
            s["diverged"],
            error(&s).map_or("–".into(), |e| fixed(e, 4)),
            error(&s).map_or("–".into(), |e| percent(e, base)),
            fixed(num(net, "frames_sent")? / GOAL_T_END, 0),
            fixed(num(net, "bus_load_percent")?, 2),
        );
    }
    Ok(t)
}

/// The goal's run `name` against the synchronous one: `+1.2 %`.
pub fn goal_figure(src: &mut Sources, name: &str) -> Result<String> {
    let base = error(&src.clock_goal("synchronous")?).ok_or("the synchronous run diverged")?;
    let e = error(&src.clock_goal(name)?).ok_or_else(|| format!("the {name} run diverged"))?;
    Ok(percent(e, base))
}

/// One grid point of a clock campaign: per draw, the error after `2 Ts` and the total control
/// energy (`None`: diverged or invalid).
type Point = Vec<Option<(f64, f64)>>;

/// A grid point's `(sync, drift bound, jitter bound)`.
type Coords = (String, f64, f64);

/// The campaign's points by `(sync, drift, jitter)`, in run order.
fn points(rows: &[Row]) -> Result<Vec<(Coords, Point)>> {
    let mut out: Vec<(Coords, Point)> = Vec::new();
    for r in rows {
        let sync = r.get("clock.sync").ok_or("no column clock.sync")?.clone();
        let drift = cell(r, "clock.drift_ppm")?.ok_or("a row without clock.drift_ppm")?;
        let jitter = cell(r, "clock.jitter_us")?.ok_or("a row without clock.jitter_us")?;
        let ok = r.get("status").map(String::as_str) == Some("ok");
        let e = if ok && !diverged(r) {
            cell(r, "max_error_after_predefined_time")?.zip(cell(r, "total_u_energy")?)
        } else {
            None
        };
        let key = (sync, drift, jitter);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, p)) => p.push(e),
            None => out.push((key, vec![e])),
        }
    }
    Ok(out)
}

/// Median of the errors (`pick` 0) or energies (1) of a point (`None` when it has none).
fn median_of(p: &Point, pick: usize) -> Option<f64> {
    let mut v: Vec<f64> = p
        .iter()
        .flatten()
        .map(|&(e, u)| if pick == 0 { e } else { u })
        .collect();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// Median error of a point.
fn median(p: &Point) -> Option<f64> {
    median_of(p, 0)
}

/// The median error and energy of the synchronous point (sync none, no drift, no jitter).
fn synchronous(points: &[(Coords, Point)]) -> Result<(f64, f64)> {
    points
        .iter()
        .find(|((s, d, j), _)| s == "none" && *d == 0.0 && *j == 0.0)
        .and_then(|(_, p)| median_of(p, 0).zip(median_of(p, 1)))
        .ok_or_else(|| "no synchronous point (sync none, drift 0, jitter 0) with a value".into())
}

/// The campaign's table: per sync mode and drift bound, per jitter bound, the median error
/// after `2 Ts` and the median control energy over the draws, each relative to the
/// synchronous run, and the diverged draws.
pub fn table(rows: &[Row]) -> Result<String> {
    let points = points(rows)?;
    let (base, energy) = synchronous(&points)?;
    let mut jitters: Vec<f64> = Vec::new();
    let mut lines: BTreeMap<(usize, u64), (String, f64, Vec<String>)> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for ((sync, drift, jitter), p) in &points {
        if !jitters.contains(jitter) {
            jitters.push(*jitter);
        }
        if !order.contains(sync) {
            order.push(sync.clone());
        }
        let s = order.iter().position(|o| o == sync).unwrap_or(0);
        let div = p.iter().filter(|e| e.is_none()).count();
        let text = match median(p).zip(median_of(p, 1)) {
            Some((m, u)) => {
                let ratios = format!("{}× / {}×", fixed(m / base, 3), fixed(u / energy, 2));
                if div == 0 {
                    ratios
                } else {
                    format!("{ratios} ({div}/{} div.)", p.len())
                }
            }
            None => format!("div. {div}/{}", p.len()),
        };
        lines
            .entry((s, drift.to_bits()))
            .or_insert_with(|| (sync.clone(), *drift, Vec::new()))
            .2
            .push(text);
    }
    let mut t = String::from("| sync | drift bound [ppm] |");
    for j in &jitters {
        let _ = write!(t, " jitter {j} µs |");
    }
    t.push_str("\n|---|---|");
    t.push_str(&"---|".repeat(jitters.len()));
    t.push('\n');
    let mut rows: Vec<_> = lines.into_values().collect();
    rows.sort_by(|a, b| {
        let sa = order.iter().position(|o| *o == a.0);
        let sb = order.iter().position(|o| *o == b.0);
        sa.cmp(&sb).then(a.1.total_cmp(&b.1))
    });
    for (sync, drift, cells) in rows {
        let _ = writeln!(t, "| {sync} | {drift} | {} |", cells.join(" | "));
    }
    Ok(t)
}

/// One inline figure of a campaign ([`KEYS`]).
pub fn figure(rows: &[Row], key: &str) -> Result<String> {
    let points = points(rows)?;
    let (base, energy) = synchronous(&points)?;
    let of = |sync: &'static str| points.iter().filter(move |((s, _, _), _)| s == sync);
    Ok(match key {
        "runs" => rows.len().to_string(),
        "synchronous" => fixed(base, 4),
        "synchronous-settling" => {
            let r = rows
                .iter()
                .find(|r| {
                    r.get("clock.sync").map(String::as_str) == Some("none")
                        && cell(r, "clock.drift_ppm").ok().flatten() == Some(0.0)
                        && cell(r, "clock.jitter_us").ok().flatten() == Some(0.0)
                })
                .ok_or("no synchronous row")?;
            cell(r, "settling_time")?.map_or("never".into(), |t| format!("{} s", fixed(t, 2)))
        }
        "worst-none" | "worst-leader" | "best-none" => {
            let sync = if key == "worst-leader" {
                "leader"
            } else {
                "none"
            };
            let ratios = of(sync)
                .filter(|(_, p)| p.iter().all(Option::is_some))
                .filter_map(|(_, p)| median(p))
                .map(|m| m / base);
            let r = if key == "best-none" {
                ratios.fold(f64::INFINITY, f64::min)
            } else {
                ratios.fold(f64::NEG_INFINITY, f64::max)
            };
            if r.is_finite() {
                format!("{}×", fixed(r, 3))
            } else {
                "–".into()
            }
        }
        "energy-max" => {
            let r = points
                .iter()
                .filter_map(|(_, p)| median_of(p, 1))
                .fold(f64::NEG_INFINITY, f64::max);
            format!("{}×", fixed(r / energy, 2))
        }
        "diverged-none" | "diverged-leader" => {
            let sync = if key == "diverged-none" {
                "none"
            } else {
                "leader"
            };
            let (div, all) = of(sync).fold((0, 0), |(d, a), (_, p)| {
                (d + p.iter().filter(|e| e.is_none()).count(), a + p.len())
            });
            format!("{div} of {all}")
        }
        other => return Err(format!("no clock campaign figure `{other}`")),
    })
}
