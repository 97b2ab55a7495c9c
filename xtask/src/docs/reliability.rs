//! Figures of docs/RELIABILITY.md: the soak windows (`reliability.soak`), the extreme runs
//! (`reliability.extreme.RUN.KEY`, `reliability.stable-h`), the corruption cells' bus figures
//! (`reliability.corruption.CASE.KEY`) and the figures the fault-matrix prose quotes
//! (`reliability.matrix.CASE.KEY`).

use std::{collections::BTreeMap, fmt::Write as _, process::Command};

use serde_json::Value;

use super::{fixed, grouped, ms, num, opt, run, verdicts, Matrix, Sources, MATRICES, SCENARIOS};
use crate::task::{cargo, workspace_root, Result};

/// Where the soak test writes its windows (`SOAK_OUT`); outside `target/docs`, so a CI step
/// that runs the soak with it set is reused.
const SOAK_JSON: &str = "target/soak/soak.json";

/// Runs of `tests/tests/extreme.rs` the text quotes.
const EXTREME: [&str; 5] = [
    "ts-0.05",
    "h-10ms",
    "ex2-h-10ms",
    "line-50-can-500k-lossy",
    "all-at-once",
];

/// Inline figures of an extreme run.
const EXTREME_KEYS: [&str; 6] = ["time", "agent", "max-u", "c1", "misses", "lost"];

/// Corruption cells of Example 1's fault matrix, run alone: case, `--set`s. The horizon is
/// the matrix's for whole-run faults: `t_f = 2 T_s + 1 s` plus `2·2T_s + 1 s` (T_s = 2).
const CORRUPTION: [(&str, &[&str]); 2] = [
    ("10", &["network.corruption=0.1", "simulation.t_end=14"]),
    ("30", &["network.corruption=0.3", "simulation.t_end=14"]),
];

/// Inline figures of a corruption cell.
const CORRUPTION_KEYS: [&str; 2] = ["bus-off", "misses"];

/// Inline figures of a fault matrix quoted in the prose.
const MATRIX_KEYS: [&str; 16] = [
    "band",
    "band-off",
    "on-max-u",
    "off-max-u",
    "off-diverged-min",
    "off-diverged-max",
    "off-back-max",
    "babbling-2s-diverged",
    "babbling-2s-off-u",
    "silent-agent1-0.5s-off-u",
    "silent-leader-0.5s-off-u",
    "not-met",
    "not-met-min",
    "not-met-max",
    "outage-not-met-min",
    "outage-not-met-max",
];

/// Figures of the leader's 1 s outage and of the stuck agent, in the same matrices.
const CELL_KEYS: [&str; 5] = [
    "outage-off-back",
    "outage-off-u",
    "stuck-diverged",
    "stuck-into-fault",
    "stuck-back",
];

/// Whether `name` (after `reliability.`) is a figure of this family.
pub fn known(name: &str) -> bool {
    if let Some((run, key)) = name
        .strip_prefix("extreme.")
        .and_then(|r| r.rsplit_once('.'))
    {
        return EXTREME.contains(&run) && EXTREME_KEYS.contains(&key);
    }
    let parts: Vec<&str> = name.splitn(3, '.').collect();
    match parts.as_slice() {
        ["soak"] | ["soak", "growth"] | ["stable-h"] => true,
        ["corruption", case, key] => {
            CORRUPTION.iter().any(|c| c.0 == *case) && CORRUPTION_KEYS.contains(key)
        }
        ["matrix", case, key] => {
            MATRICES.contains(case) && (MATRIX_KEYS.contains(key) || CELL_KEYS.contains(key))
        }
        _ => false,
    }
}

/// Renders `name` (after `reliability.`), a name [`known`] accepts.
pub fn render(src: &mut Sources, name: &str) -> Result<String> {
    if let Some((run, key)) = name
        .strip_prefix("extreme.")
        .and_then(|r| r.rsplit_once('.'))
    {
        return extreme(src, run, key);
    }
    let parts: Vec<&str> = name.splitn(3, '.').collect();
    match parts.as_slice() {
        ["soak"] => soak_table(&src.soak()?),
        ["soak", "growth"] => soak_growth(&src.soak()?),
        ["stable-h"] => {
            let (stem, _, search) = SCENARIOS
                .iter()
                .find(|s| s.0 == "example1")
                .ok_or("no scenario example1")?;
            let (band, h_max) = search.ok_or("example1 has no stable-h search")?;
            Ok(ms(src.stable_h(stem, band, h_max)?.0))
        }
        ["corruption", case, key] => {
            let sets = CORRUPTION
                .iter()
                .find(|c| c.0 == *case)
                .ok_or_else(|| format!("no corruption cell `{case}`"))?
                .1;
            let s = src.summary_with("example1-deploy", &format!("-corruption-{case}"), sets)?;
            let n = &s["network"];
            match *key {
                "bus-off" => Ok(grouped(num(n, "bus_off_events")?, 0)),
                "misses" => Ok(grouped(num(n, "deadline_misses")?, 0)),
                other => Err(format!("no corruption figure `{other}`")),
            }
        }
        ["matrix", case, key] => matrix_figure(&src.matrix(case)?, key),
        _ => Err(format!("no reliability figure `{name}`")),
    }
}

impl Sources {
    /// The soak test's windows, written with `SOAK_OUT`.
    fn soak(&mut self) -> Result<Value> {
        self.json_file(SOAK_JSON, |_, file| {
            run(Command::new(cargo())
                .current_dir(workspace_root())
                .env("SOAK_OUT", file.parent().unwrap_or(file))
                .args(["test", "-p", "controller-core", "--release", "--quiet"])
                .args(["--test", "soak", "--", "--ignored"]))
            .map(|_| ())
        })
    }
}

/// The soak table: per window, the largest error, estimates and command.
pub fn soak_table(v: &Value) -> Result<String> {
    let mut t = String::from(
        "| window | max \\|y_i − y_d\\| | max μ̂ | max ξ̂ | max λ̂ | max \\|u\\| |\n|---|---|---|---|---|---|\n",
    );
    for (key, label) in [
        ("first", "first 10 min after `2 T_s`"),
        ("last", "last 10 min"),
    ] {
        let w = &v[key];
        let _ = writeln!(
            t,
            "| {label} | {} | {} | {} | {} | {} |",
            fixed(num(w, "error")?, 4),
            sci(num(w, "mu")?),
            fixed(num(w, "xi")?, 4),
            fixed(num(w, "lambda")?, 3),
            fixed(num(w, "u")?, 2),
        );
    }
    Ok(t)
}

/// The largest growth of a soak figure from the first window to the last: `+0.5 %`.
pub fn soak_growth(v: &Value) -> Result<String> {
    let mut worst = f64::NEG_INFINITY;
    for key in ["error", "mu", "xi", "lambda", "u"] {
        let (first, last) = (num(&v["first"], key)?, num(&v["last"], key)?);
        if first <= 0.0 {
            return Err(format!("soak: first window's `{key}` is {first}"));
        }
        worst = worst.max(last / first - 1.0);
    }
    Ok(format!("{:+.1} %", 100.0 * worst))
}

/// `9.96e-5`: three significant digits in scientific notation.
fn sci(x: f64) -> String {
    let s = format!("{x:.2e}");
    s.replace("e-0", "e-").replace("e0", "e")
}

/// `7.7e7`: two significant digits in scientific notation.
fn sci2(x: f64) -> String {
    format!("{x:.1e}")
}

fn extreme(src: &mut Sources, name: &str, key: &str) -> Result<String> {
    let all = src.records(
        "target/docs/extreme.json",
        "target/docs/extreme",
        "EXTREME_OUT",
        &["-p", "integration-tests", "--test", "extreme"],
    )?;
    let s = all
        .get(name)
        .ok_or_else(|| format!("tests/tests/extreme.rs recorded no run `{name}`"))?;
    let d = &s["divergence"];
    Ok(match key {
        "time" => fixed(
            num(d, "time").map_err(|e| format!("{name} did not diverge: {e}"))?,
            3,
        ),
        "agent" => grouped(num(d, "agent")?, 0),
        "max-u" => sci2(num(s, "max_abs_u")?),
        "c1" => grouped(num(s, "c1")?, 0),
        "misses" => grouped(num(&s["network"], "deadline_misses")?, 0),
        "lost" => grouped(num(&s["network"], "frames_lost")?, 0),
        other => return Err(format!("no extreme-run figure `{other}`")),
    })
}

/// One row of `matrix.json`, with its cell number (as `matrix.md` numbers them).
struct CellRow<'a> {
    number: usize,
    fault: &'a str,
    case: &'a str,
    safety: bool,
    row: &'a Value,
}

/// The rows of a matrix, numbered by cell in order of appearance.
fn cell_rows(m: &Matrix) -> Result<Vec<CellRow<'_>>> {
    let rows = m.json.as_array().ok_or("matrix.json is not a list")?;
    let mut numbers: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    let mut out = Vec::new();
    for r in rows {
        let fault = r["fault"].as_str().ok_or("a row without `fault`")?;
        let case = r["case"].as_str().ok_or("a row without `case`")?;
        let next = numbers.len() + 1;
        let number = *numbers.entry((fault, case)).or_insert(next);
        out.push(CellRow {
            number,
            fault,
            case,
            safety: r["safety"].as_bool().ok_or("a row without `safety`")?,
            row: r,
        });
    }
    Ok(out)
}

/// The smallest and the largest of `values`, with `decimals` decimals.
fn range(values: &[f64], decimals: usize) -> Result<(String, String)> {
    let lo = values
        .iter()
        .copied()
        .reduce(f64::min)
        .ok_or("no such cell")?;
    let hi = values
        .iter()
        .copied()
        .reduce(f64::max)
        .ok_or("no such cell")?;
    Ok((fixed(lo, decimals), fixed(hi, decimals)))
}

/// One figure of a fault matrix the prose quotes.
pub fn matrix_figure(m: &Matrix, key: &str) -> Result<String> {
    let rows = cell_rows(m)?;
    let met = verdicts(&m.md);
    let side = |on: bool| rows.iter().filter(move |r| r.safety == on);
    let field = |r: &CellRow, k: &str| {
        num(r.row, k).map_err(|e| format!("cell {} ({}, {}): {e}", r.number, r.fault, r.case))
    };
    let cell = |fault: &str, case: &str, on: bool| {
        rows.iter()
            .find(|r| r.fault == fault && r.case == case && r.safety == on)
            .ok_or_else(|| format!("no cell `{fault}`, `{case}` with safety {on}"))
    };
    let not_met = |outage: bool| -> Vec<&CellRow> {
        side(true)
            .filter(|r| met.get(&r.number) == Some(&false))
            .filter(|r| !outage || r.fault != "all actuators stuck")
            .collect()
    };
    let backs = |cells: Vec<&CellRow>| -> Result<Vec<f64>> {
        cells.iter().map(|r| field(r, "back_in_band_s")).collect()
    };
    let outage = || cell("silent leader", "1 s", false);
    let stuck = |on: bool| cell("all actuators stuck", "agent 2, 0.5 s", on);
    Ok(match key {
        "band" | "band-off" => {
            let r = side(key == "band").next().ok_or("no such rows")?;
            fixed(field(r, "band")?, 4)
        }
        "on-max-u" => fixed(
            side(true)
                .filter_map(|r| opt(r.row, "max_abs_u_run"))
                .fold(0.0, f64::max),
            0,
        ),
        "off-max-u" => grouped(
            side(false)
                .filter_map(|r| opt(r.row, "max_abs_u"))
                .fold(0.0, f64::max),
            0,
        ),
        "off-diverged-min" | "off-diverged-max" => {
            let times: Vec<f64> = side(false)
                .filter_map(|r| opt(r.row, "diverged_at"))
                .collect();
            let (lo, hi) = range(&times, 3)?;
            if key.ends_with("min") {
                lo
            } else {
                hi
            }
        }
        "off-back-max" => fixed(
            side(false)
                .filter_map(|r| opt(r.row, "back_in_band_s"))
                .fold(0.0, f64::max),
            1,
        ),
        "babbling-2s-diverged" => fixed(
            field(cell("babbling node", "agent 1, 2 s", false)?, "diverged_at")?,
            3,
        ),
        "babbling-2s-off-u" => grouped(
            field(cell("babbling node", "agent 1, 2 s", false)?, "max_abs_u")?,
            0,
        ),
        "silent-agent1-0.5s-off-u" => grouped(
            field(
                cell("silent neighbour", "agent 1, 0.5 s", false)?,
                "max_abs_u",
            )?,
            0,
        ),
        "silent-leader-0.5s-off-u" => grouped(
            field(cell("silent leader", "0.5 s", false)?, "max_abs_u")?,
            0,
        ),
        "not-met" => not_met(false).len().to_string(),
        "not-met-min" | "not-met-max" | "outage-not-met-min" | "outage-not-met-max" => {
            let (lo, hi) = range(&backs(not_met(key.starts_with("outage")))?, 3)?;
            if key.ends_with("min") {
                lo
            } else {
                hi
            }
        }
        "outage-off-back" => fixed(field(outage()?, "back_in_band_s")?, 2),
        "outage-off-u" => grouped(field(outage()?, "max_abs_u")?, 0),
        "stuck-diverged" => fixed(field(stuck(true)?, "diverged_at")?, 3),
        "stuck-into-fault" => {
            let r = stuck(true)?;
            fixed(field(r, "diverged_at")? - field(r, "from")?, 2)
        }
        "stuck-back" => fixed(field(stuck(true)?, "back_in_band_s")?, 3),
        other => return Err(format!("no fault-matrix figure `{other}`")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix() -> Matrix {
        let row = |fault: &str, case: &str, on: bool, extra: Value| {
            let mut v = serde_json::json!({
                "fault": fault, "case": case, "from": 2.0, "safety": on, "band": if on { 0.0655 } else { 0.07 },
                "diverged_at": null, "max_abs_u": 20.0, "max_abs_u_run": 20.0, "back_in_band_s": 0.5,
            });
            if let (Value::Object(m), Value::Object(e)) = (&mut v, extra) {
                m.extend(e);
            }
            v
        };
        let json = Value::Array(vec![
            row(
                "silent leader",
                "1 s",
                true,
                serde_json::json!({"back_in_band_s": 1.189}),
            ),
            row(
                "silent leader",
                "1 s",
                false,
                serde_json::json!({"max_abs_u": 926.7, "back_in_band_s": 0.218}),
            ),
            row(
                "babbling node",
                "agent 1, 1 s",
                true,
                serde_json::json!({"back_in_band_s": 1.215}),
            ),
            row(
                "babbling node",
                "agent 1, 1 s",
                false,
                serde_json::json!({"diverged_at": 0.005}),
            ),
            row(
                "all actuators stuck",
                "agent 2, 0.5 s",
                true,
                serde_json::json!({"back_in_band_s": 1.057}),
            ),
            row(
                "all actuators stuck",
                "agent 2, 0.5 s",
                false,
                serde_json::json!({"diverged_at": 2.283, "max_abs_u": 16524.2}),
            ),
        ]);
        let md = "| 1 | silent leader | 1 s | on | – | 20 | 0.1 | 1.189 | **not met** |\n\
                  | 2 | babbling node | agent 1, 1 s | on | – | 20 | 0.1 | 1.215 | **not met** |\n\
                  | 3 | all actuators stuck | agent 2, 0.5 s | on | – | 20 | 0.1 | 1.055 | **not met** |\n";
        Matrix {
            json,
            md: md.into(),
        }
    }

    #[test]
    fn prose_figures_pick_their_cells_and_ranges() {
        let m = matrix();
        let f = |k: &str| matrix_figure(&m, k).expect(k);
        assert_eq!(
            (f("band"), f("band-off")),
            ("0.0655".into(), "0.0700".into())
        );
        assert_eq!(
            (f("not-met"), f("not-met-min"), f("not-met-max")),
            ("3".into(), "1.057".into(), "1.215".into())
        );
        assert_eq!(
            (f("outage-not-met-min"), f("outage-not-met-max")),
            ("1.189".into(), "1.215".into())
        );
        assert_eq!(
            (f("outage-off-back"), f("outage-off-u")),
            ("0.22".into(), "927".into())
        );
        assert_eq!(
            (f("off-diverged-min"), f("off-diverged-max")),
            ("0.005".into(), "2.283".into())
        );
        assert_eq!(
            (f("stuck-back"), f("off-max-u")),
            ("1.057".into(), "16,524".into())
        );
        assert!(
            matrix_figure(&m, "babbling-2s-diverged").is_err(),
            "no such cell here"
        );
    }

    #[test]
    fn soak_windows_make_the_table() {
        let v = serde_json::json!({
            "first": {"error": 0.17461, "mu": 9.96e-5, "xi": 0.48461, "lambda": 2.5131, "u": 15.532},
            "last": {"error": 0.1754, "mu": 9.95e-5, "xi": 0.4844, "lambda": 2.507, "u": 15.46},
        });
        let t = soak_table(&v).expect("both windows");
        assert!(
            t.contains(
                "| first 10 min after `2 T_s` | 0.1746 | 9.96e-5 | 0.4846 | 2.513 | 15.53 |"
            ),
            "{t}"
        );
        assert!(soak_table(&serde_json::json!({"first": {}})).is_err());
    }

    #[test]
    fn names_of_the_family_are_known_and_others_are_not() {
        for name in [
            "soak",
            "soak.growth",
            "stable-h",
            "extreme.ts-0.05.time",
            "extreme.ex2-h-10ms.agent",
            "extreme.line-50-can-500k-lossy.misses",
            "corruption.30.bus-off",
            "matrix.example2-fast.outage-off-u",
            "matrix.example1.silent-agent1-0.5s-off-u",
        ] {
            assert!(known(name), "{name}");
        }
        for name in [
            "soak.x",
            "extreme.ts-0.05",
            "extreme.ts.time",
            "extreme.nope.time",
            "corruption.20.bus-off",
            "matrix.example3.band",
            "matrix.example1.nope",
        ] {
            assert!(!known(name), "{name}");
        }
        assert_eq!(sci(9.96e-5), "9.96e-5");
        assert_eq!(sci2(76_633_384.0), "7.7e7");
    }
}
