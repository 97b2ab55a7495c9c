//! docs/SCENARIO.md cannot drift from the code: every key the scenario parser accepts (asked of
//! the parser itself, through serde's `deny_unknown_fields` messages), every value of its
//! enumerations, every `summary.json` key (with a unit in `units`) and every `trajectory.csv`
//! column of real runs appears there; every documented key is accepted, documented defaults
//! are the parser's, and the `[controller]`, `[quantizer]` and `[safety]` rows state the unit,
//! default and range of controller-core's parameter table (`Param::spec`).

mod common;

use std::collections::BTreeSet;

use controller_core::{
    param::{DefaultValue, Range, Spec},
    Param,
};
use host_sim::{error::Error, run::simulate, scenario};
use serde_json::Value;

const PROBE: &str = "__probe";

fn doc() -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/SCENARIO.md");
    std::fs::read_to_string(&p).expect("docs/SCENARIO.md")
}

/// The names between backticks or double quotes after "expected" in a serde message.
fn expected_names(msg: &str) -> Vec<String> {
    let Some(at) = msg.find("expected") else {
        return Vec::new();
    };
    let tail = &msg[at..];
    let mut names = Vec::new();
    for q in ['`', '"'] {
        let mut parts = tail.split(q);
        parts.next();
        while let (Some(name), Some(_)) = (parts.next(), parts.next()) {
            names.push(name.to_string());
        }
    }
    names
}

fn invalid_message(text: &str) -> Option<String> {
    match scenario::parse(text, &[]) {
        Err(Error::Invalid(m)) => Some(m),
        _ => None,
    }
}

/// The fields of the table at `header` (e.g. `[simulation]`, `[[faults.rule]]`, or `""` for the
/// top level), if the parser reads a table there.
fn fields(header: &str) -> Option<Vec<String>> {
    let msg = invalid_message(&format!("{header}\n{PROBE} = 0\n"))?;
    msg.contains(&format!("unknown field `{PROBE}`"))
        .then(|| expected_names(&msg))
}

/// Every accepted key (dotted) with the values of the enumerations among them.
fn accepted_keys(
    prefix: &str,
    header: &str,
    keys: &mut BTreeSet<String>,
    values: &mut BTreeSet<String>,
) {
    let Some(names) = fields(header) else {
        panic!("the parser reads no table at {header:?}");
    };
    assert!(!names.is_empty(), "no field names for {header:?}");
    for name in names {
        let key = if prefix.is_empty() {
            name.clone()
        } else {
            format!("{prefix}.{name}")
        };
        if fields(&format!("[{key}]")).is_some() {
            keys.insert(format!("[{key}]"));
            accepted_keys(&key, &format!("[{key}]"), keys, values);
        } else if fields(&format!("[[{key}]]")).is_some() {
            keys.insert(key.clone());
            accepted_keys(&key, &format!("[[{key}]]"), keys, values);
        } else {
            // A leaf: a string probe names the accepted values of an enumeration.
            let (table, leaf) = key.rsplit_once('.').unwrap_or(("", &key));
            let table = if table.is_empty() {
                String::new()
            } else if header.starts_with("[[") {
                format!("[[{table}]]")
            } else {
                format!("[{table}]")
            };
            let text = format!("{table}\n{leaf} = \"{PROBE}\"\n");
            if let Some(msg) = invalid_message(&text) {
                if msg.contains(PROBE) {
                    values.extend(expected_names(&msg));
                }
            }
            keys.insert(key);
        }
    }
}

#[test]
fn every_scenario_key_the_parser_accepts_is_documented() {
    let (mut keys, mut values) = (BTreeSet::new(), BTreeSet::new());
    accepted_keys("", "", &mut keys, &mut values);
    // The probe must really find the parser's keys, values and nested tables.
    for k in [
        "simulation.h",
        "controller.a_check",
        "faults.rule.kind",
        "[network]",
    ] {
        assert!(keys.contains(k), "probe missed {k}: {keys:?}");
    }
    for v in ["prescribed-time", "magnitude", "stuck", "manipulator"] {
        assert!(values.contains(v), "probe missed value {v}: {values:?}");
    }
    let doc = doc();
    let missing: Vec<_> = keys
        .iter()
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .chain(values.iter().filter(|v| !doc.contains(&format!("\"{v}\""))))
        .collect();
    assert!(
        missing.is_empty(),
        "accepted by the parser but not in docs/SCENARIO.md: {missing:?}"
    );
}

/// The rows of docs/SCENARIO.md's key tables (`| key | unit | default | range | meaning |`):
/// key (without backticks), unit, default and range cells.
fn documented_rows() -> Vec<[String; 4]> {
    let doc = doc();
    let mut rows = Vec::new();
    let mut in_keys = false;
    for line in doc.lines() {
        if !line.starts_with('|') {
            in_keys = false;
            continue;
        }
        if line.starts_with("| key | unit | default | range | meaning |") {
            in_keys = true;
            continue;
        }
        if !in_keys || line.starts_with("|---") {
            continue;
        }
        let cells = split_row(line);
        assert!(cells.len() >= 4, "short key row: {line}");
        let key = cells[0].trim_matches('`').to_string();
        rows.push([key, cells[1].clone(), cells[2].clone(), cells[3].clone()]);
    }
    rows
}

/// The cells of a Markdown table row (`\|` stays inside its cell).
fn split_row(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    let mut cells = vec![String::new()];
    let mut prev = ' ';
    for c in inner.chars() {
        if c == '|' && prev != '\\' {
            cells.push(String::new());
        } else if let Some(cell) = cells.last_mut() {
            cell.push(c);
        }
        prev = c;
    }
    cells.iter().map(|c| c.trim().to_string()).collect()
}

#[test]
fn every_documented_scenario_key_is_accepted_by_the_parser() {
    let (mut keys, mut values) = (BTreeSet::new(), BTreeSet::new());
    accepted_keys("", "", &mut keys, &mut values);
    let rows = documented_rows();
    assert!(rows.len() > 50, "found {} key rows", rows.len());
    let unknown: Vec<_> = rows
        .iter()
        .map(|r| &r[0])
        .filter(|k| !keys.contains(*k) && !keys.contains(&format!("[{k}]")))
        .collect();
    assert!(
        unknown.is_empty(),
        "in docs/SCENARIO.md but not accepted by the parser: {unknown:?}"
    );
}

/// A parameter table range as docs/SCENARIO.md writes it.
fn documented_range(spec: &Spec) -> String {
    let range = match spec.range {
        Range::Positive => "`> 0`".to_string(),
        Range::PositiveOrInfinite => "`> 0` (`inf`: at once)".to_string(),
        Range::NonNegative => "`≥ 0`".to_string(),
        Range::OpenUnit => "`(0, 1)`".to_string(),
        Range::NonZero => "`≠ 0`".to_string(),
        Range::AtLeastOne => "`≥ 1`".to_string(),
        Range::UpTo(p) => format!("`(0, {p}]`"),
        Range::AtLeast(p) => format!("`≥ {p}`"),
        Range::Count { min, max } => format!("`{min}..={max}`"),
        Range::OneOf(names) => names
            .iter()
            .map(|n| format!("`\"{n}\"`"))
            .collect::<Vec<_>>()
            .join(", "),
        Range::Bool => "bool".to_string(),
        Range::Elsewhere => "(another section)".to_string(),
    };
    let steps = if spec.per_step { "`n` values " } else { "" };
    format!("{steps}{range}{}", spec.condition)
}

/// The numbers of a default cell such as `` `1e-6` `` or `` `[90.0, 90.0]` ``.
fn numbers(cell: &str) -> Option<Vec<f64>> {
    let inner = cell.strip_prefix('`')?.strip_suffix('`')?;
    let list = inner.trim_start_matches('[').trim_end_matches(']');
    list.split(',').map(|x| x.trim().parse().ok()).collect()
}

/// Whether a default cell states the table's default (a per-step one for the default plant,
/// `n = 2`).
fn default_matches(spec: &Spec, cell: &str) -> bool {
    match spec.default {
        DefaultValue::Num(v) => numbers(cell) == Some(vec![v]),
        DefaultValue::PerStep(v) => numbers(cell) == Some(vec![v; 2]) && cell.contains('['),
        DefaultValue::Computed => cell == "computed (LAW §3)",
        DefaultValue::Same(p) => cell == format!("`{p}`"),
        DefaultValue::None => cell == "none",
        DefaultValue::Bool(b) => cell == format!("`{b}`"),
        DefaultValue::Name(n) => cell == format!("`\"{n}\"`"),
        DefaultValue::Elsewhere => true,
    }
}

/// A TOML integer or float as `f64`.
fn number(v: &toml::Value) -> Option<f64> {
    v.as_float().or(v.as_integer().map(|i| i as f64))
}

/// The value at a dotted key of the default scenario as the parser resolves it.
fn parser_default(key: &str) -> Option<toml::Value> {
    let mut v = toml::Value::try_from(scenario::Scenario::default()).ok()?;
    for part in key.split('.') {
        v = v.get(part)?.clone();
    }
    Some(v)
}

#[test]
fn controller_quantizer_and_safety_keys_match_the_parameter_table_both_ways() {
    let owned = ["controller.", "quantizer.", "safety."];
    let rows = documented_rows();
    let table: Vec<Spec> = Param::ALL
        .iter()
        .map(|p| p.spec())
        .filter(|s| owned.iter().any(|o| s.key.starts_with(o)))
        .collect();
    let documented: Vec<&[String; 4]> = rows
        .iter()
        .filter(|r| owned.iter().any(|o| r[0].starts_with(o)))
        .collect();
    let doc_keys: BTreeSet<&str> = documented.iter().map(|r| r[0].as_str()).collect();
    let table_keys: BTreeSet<&str> = table.iter().map(|s| s.key).collect();
    assert_eq!(doc_keys, table_keys, "docs/SCENARIO.md rows vs Param::ALL");
    let mut wrong = Vec::new();
    for spec in &table {
        let Some(row) = documented.iter().find(|r| r[0] == spec.key) else {
            continue;
        };
        let (unit, default, range) = (&row[1], &row[2], &row[3]);
        if *unit != spec.unit {
            wrong.push(format!(
                "{}: unit {unit:?}, table {:?}",
                spec.key, spec.unit
            ));
        }
        if !default_matches(spec, default) {
            wrong.push(format!(
                "{}: default {default:?}, table {:?}",
                spec.key, spec.default
            ));
        }
        let want = documented_range(spec);
        if *range != want {
            wrong.push(format!("{}: range {range:?}, table {want:?}", spec.key));
        }
        // The parser's resolved default is the table's too.
        match (spec.default, parser_default(spec.key)) {
            (DefaultValue::Num(v), Some(p)) if number(&p) != Some(v) => {
                wrong.push(format!("{}: parser default {p}, table {v}", spec.key));
            }
            (DefaultValue::Name(n), Some(p)) if p.as_str() != Some(n) => {
                wrong.push(format!("{}: parser default {p}, table {n}", spec.key));
            }
            (DefaultValue::Bool(b), Some(p)) if p.as_bool() != Some(b) => {
                wrong.push(format!("{}: parser default {p}, table {b}", spec.key));
            }
            _ => {}
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn documented_defaults_of_the_other_sections_are_the_parsers() {
    let mut wrong = Vec::new();
    let mut compared = 0;
    for [key, _, default, _] in documented_rows() {
        let Some(literal) = default.strip_prefix('`').and_then(|d| d.strip_suffix('`')) else {
            continue;
        };
        let (Ok(doc), Some(parsed)) = (
            format!("v = {literal}").parse::<toml::Table>(),
            parser_default(&key),
        ) else {
            continue;
        };
        let doc = &doc["v"];
        let same = *doc == parsed || number(doc).is_some_and(|d| number(&parsed) == Some(d));
        if !same {
            wrong.push(format!("{key}: documented {literal}, parser {parsed}"));
        }
        compared += 1;
    }
    assert!(compared > 30, "only {compared} defaults compared");
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Dotted paths of the keys of `v` (first element of arrays of objects), and the numeric ones.
fn json_keys(prefix: &str, v: &Value, all: &mut BTreeSet<String>, numeric: &mut BTreeSet<String>) {
    let Value::Object(map) = v else { return };
    for (k, x) in map {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        all.insert(key.clone());
        match x {
            Value::Number(_) => {
                numeric.insert(key);
            }
            Value::Array(a) => {
                if let Some(first) = a.first() {
                    json_keys(&key, first, all, numeric);
                }
            }
            Value::Object(_) if k != "units" => json_keys(&key, x, all, numeric),
            _ => {}
        }
    }
}

fn summary(file: &str, sets: &[&str]) -> Value {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let setup = scenario::load(&common::scenario_path(file), &sets).expect("scenario");
    serde_json::to_value(simulate(&setup).expect("run")).expect("json")
}

/// Example 1 for 0.05 s with a `[[metrics.window]]` (the `windows` key).
fn with_window() -> Value {
    let example =
        std::fs::read_to_string(common::scenario_path("example1.toml")).expect("example1");
    let text = format!("{example}\n[[metrics.window]]\nname = \"w\"\nkind = \"iae\"\n");
    let setup = scenario::parse(&text, &["simulation.t_end=0.05".to_string()]).expect("scenario");
    serde_json::to_value(simulate(&setup).expect("run")).expect("json")
}

#[test]
fn every_summary_key_is_documented_with_a_unit() {
    let doc = doc();
    // Diverged (divergence object), CAN (network object), ideal, clocked (clock object).
    let runs = [
        summary(
            "example1.toml",
            &["simulation.t_end=0.2", "controller.ts=0.001"],
        ),
        summary("example1-can.toml", &["simulation.t_end=0.05"]),
        summary("example2.toml", &["simulation.t_end=0.05"]),
        with_window(),
        summary(
            "example1-can.toml",
            &["simulation.t_end=0.05", "clock.jitter_us=10"],
        ),
    ];
    assert!(
        runs[0]["divergence"].is_object(),
        "the first run must diverge"
    );
    assert!(runs[1]["network"].is_object());
    assert!(runs[4]["clock"].is_object());
    for s in &runs {
        let (mut all, mut numeric) = (BTreeSet::new(), BTreeSet::new());
        json_keys("", s, &mut all, &mut numeric);
        for k in &all {
            assert!(
                doc.contains(&format!("`{k}`")),
                "summary.json key `{k}` not in docs/SCENARIO.md"
            );
        }
        let units = s["units"].as_object().expect("units object");
        for k in &numeric {
            let u = units.get(k).and_then(Value::as_str);
            assert!(
                u.is_some_and(|u| !u.is_empty()),
                "no unit for `{k}` in {units:?}"
            );
        }
        for k in units.keys() {
            assert!(
                all.contains(k) || k.starts_with("divergence."),
                "unit for a key that is not in summary.json: {k}"
            );
        }
    }
}

#[test]
fn every_trajectory_column_is_documented() {
    let dir = common::tmp("docs-columns");
    let out = common::bin()
        .arg("run")
        .arg(common::scenario_path("example1.toml"))
        .args(["--out"])
        .arg(&dir)
        .args(["--set", "simulation.t_end=0.01", "--no-plots", "--quiet"])
        .output()
        .expect("host-sim");
    common::assert_ok(&out);
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).expect("csv");
    let header = csv.lines().next().expect("header");
    let doc = doc();
    assert_eq!(header.split(',').count(), 58, "Example 1 has 58 columns");
    for col in header.split(',') {
        // x3_2 -> x{i}_{j} or x{i}_{l}
        let mut template = String::new();
        let mut run = 0;
        let mut chars = col.chars().peekable();
        while let Some(c) = chars.next() {
            if c.is_ascii_digit() {
                while chars.peek().is_some_and(char::is_ascii_digit) {
                    chars.next();
                }
                template.push_str(["{i}", "{j}"][run.min(1)]);
                run += 1;
            } else {
                template.push(c);
            }
        }
        let alt = template.replace("{j}", "{l}");
        assert!(
            doc.contains(&format!("`{template}`")) || doc.contains(&format!("`{alt}`")),
            "trajectory.csv column {col} ({template}) not in docs/SCENARIO.md"
        );
    }
}

/// Unescaped `|` in a Markdown table row (a `|` inside a code span splits the cell too).
fn cell_bars(row: &str) -> usize {
    row.match_indices('|')
        .filter(|(i, _)| !row[..*i].ends_with('\\'))
        .count()
}

#[test]
fn every_markdown_table_row_has_the_cells_of_its_header() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = vec![root.join("README.md")];
    for e in std::fs::read_dir(root.join("docs")).expect("docs") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "md") {
            files.push(p);
        }
    }
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read");
        let mut header = None;
        for (n, line) in text.lines().enumerate() {
            if !line.starts_with('|') {
                header = None;
                continue;
            }
            let bars = cell_bars(line);
            let want = *header.get_or_insert(bars);
            assert_eq!(
                bars,
                want,
                "{}:{}: escape `|` as `\\|`: {line}",
                f.display(),
                n + 1
            );
        }
    }
}
