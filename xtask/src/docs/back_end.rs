//! Figures of docs/REPRODUCTION.md, "Math back-ends": the closed-loop drift tables that
//! `host-sim/tests/{micromath,fast_math}.rs` write to `target/back-end/NAME.md`
//! (`back-end.NAME`), and single drifts from them (`back-end.NAME.SCENARIO.KEY`,
//! `back-end.NAME.SCENARIO.worst`, `back-end.NAME.worst`).

use std::{fs, process::Command};

use super::{run, Sources};
use crate::task::{cargo, workspace_root, Result};

/// The back-ends with a closed-loop test: feature and test name.
pub const BACK_ENDS: [(&str, &str); 2] = [("micromath", "micromath"), ("fast-math", "fast_math")];

/// One row of a drift table.
#[derive(Debug, Clone, PartialEq)]
struct Drift {
    scenario: String,
    figure: String,
    drift: f64,
}

/// Whether `name` is a back-end with a drift table.
pub fn known(name: &str) -> bool {
    BACK_ENDS.iter().any(|(n, _)| *n == name)
}

/// The drift table of back-end `name`, as its test wrote it (the test runs when the file is
/// missing or `--rerun` was given: two full runs of each paper example in release).
fn table(src: &mut Sources, name: &str) -> Result<String> {
    let (feature, test) = BACK_ENDS
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| format!("no back-end `{name}`"))?;
    let path = format!("target/back-end/{name}.md");
    let file = src.file(&path, |_, _| {
        run(Command::new(cargo()).current_dir(workspace_root()).args([
            "test",
            "-p",
            "host-sim",
            "--release",
            "--features",
            feature,
            "--test",
            test,
            "--",
            "--ignored",
        ]))
        .map(|_| ())
    })?;
    fs::read_to_string(&file).map_err(|e| format!("{path}: {e}"))
}

fn rows(text: &str) -> Result<Vec<Drift>> {
    text.lines()
        .skip(2)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            match cells.as_slice() {
                [scenario, figure, _, _, drift] => Ok(Drift {
                    scenario: (*scenario).to_owned(),
                    figure: (*figure).to_owned(),
                    drift: drift
                        .parse()
                        .map_err(|_| format!("drift table: `{drift}` is not a number"))?,
                }),
                _ => Err(format!("drift table: cannot read the row `{l}`")),
            }
        })
        .collect()
}

/// `x` per cent with two significant digits (`0.047`, `7.5`, `0.0023`).
fn percent(x: f64) -> String {
    let p = 100.0 * x.abs();
    if p == 0.0 || !p.is_finite() {
        return format!("{p}");
    }
    let decimals = (1 - p.log10().floor() as i32).max(0) as usize;
    format!("{p:.decimals$}")
}

/// Renders `back-end.NAME` (`key` empty) or `back-end.NAME.KEY…`.
pub fn figure(src: &mut Sources, name: &str, key: &str) -> Result<String> {
    let text = table(src, name)?;
    let key: Vec<&str> = key.split('.').filter(|k| !k.is_empty()).collect();
    if key.is_empty() {
        return Ok(text.trim_end().to_owned());
    }
    let rows = rows(&text)?;
    let worst = |of: &dyn Fn(&Drift) -> bool| {
        rows.iter()
            .filter(|r| of(r))
            .map(|r| r.drift.abs())
            .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.max(d))))
            .ok_or_else(|| format!("back-end.{name}: no rows for {}", key.join(".")))
    };
    Ok(match key.as_slice() {
        ["worst"] => format!("{:.1e}", worst(&|_| true)?),
        [scenario, "worst"] => format!("{} %", percent(worst(&|r| r.scenario == *scenario)?)),
        [scenario, figure] => {
            let r = rows
                .iter()
                .find(|r| r.scenario == *scenario && r.figure == *figure)
                .ok_or_else(|| format!("back-end.{name}: no row {scenario} {figure}"))?;
            let sign = if r.drift < 0.0 { "−" } else { "+" };
            format!("{sign}{} %", percent(r.drift))
        }
        _ => return Err(format!("no figure back-end.{name}.{}", key.join("."))),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &str = "| example | figure | default build | `micromath` | relative drift |
| --- | --- | ---: | ---: | ---: |
| example1 | max_error_after_predefined_time | 0.170286 | 0.170366 | +4.70e-4 |
| example1 | rms_error | 0.094464 | 0.094504 | +2.41e-3 |
| example2 | max_error_after_predefined_time | 0.058634 | 0.054218 | -7.53e-2 |
";

    #[test]
    fn drifts_are_read_from_the_table_the_test_writes() {
        let r = rows(TABLE).expect("rows");
        assert_eq!(r.len(), 3);
        assert_eq!(r[2].scenario, "example2");
        assert!((r[2].drift + 7.53e-2).abs() < 1e-12);
        assert!(rows("h\n-\n| a | b |\n").is_err());
    }

    #[test]
    fn percents_keep_two_significant_digits() {
        assert_eq!(percent(4.70e-4), "0.047");
        assert_eq!(percent(-7.53e-2), "7.5");
        assert_eq!(percent(2.33e-5), "0.0023");
        assert_eq!(percent(2.41e-3), "0.24");
    }
}
