//! The README's figures are what the code prints: the shipped-scenario table against fresh runs,
//! the instruction counts of the prose against the bench table.

mod common;

use host_sim::{run::simulate, scenario};

fn readme() -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    std::fs::read_to_string(p).expect("README.md")
}

/// Cells of the table row whose first cell is `` `key` ``.
fn row(text: &str, key: &str) -> Vec<String> {
    let line = text
        .lines()
        .find(|l| l.starts_with(&format!("| `{key}`")))
        .unwrap_or_else(|| panic!("no README row for {key}"));
    line.trim_matches('|')
        .split(" | ")
        .map(|c| c.trim().to_string())
        .collect()
}

/// The first number in `cell` (thousands separators allowed).
fn number(cell: &str) -> f64 {
    let start = cell.find(|c: char| c.is_ascii_digit()).expect("a number");
    let digits: String = cell[start..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == ',')
        .filter(|c| *c != ',')
        .collect();
    digits.trim_end_matches('.').parse().expect("number")
}

#[test]
fn the_scenario_table_matches_the_runs() {
    let text = readme();
    for file in [
        "example1.toml",
        "example1-ts1.toml",
        "example2.toml",
        "example2-baseline.toml",
        "example1-can.toml",
        "example1-lossy.toml",
    ] {
        let cells = row(&text, file);
        let setup = scenario::load(&common::scenario_path(file), &[]).expect("scenario");
        let s = simulate(&setup).expect("run");
        let err = s.max_error_after_predefined_time.expect("error after 2Ts");
        assert!(
            (number(&cells[3]) - err).abs() < 6e-4,
            "{file}: README {} vs run {err}",
            cells[3]
        );
        match s.settling_time {
            None => assert!(cells[4].starts_with("never"), "{file}: {}", cells[4]),
            Some(t) => assert!(
                (number(&cells[4]) - t).abs() < 6e-3,
                "{file}: {} vs {t}",
                cells[4]
            ),
        }
        let u = number(&cells[5]);
        assert!(
            (u - s.max_abs_u).abs() <= 0.051 + 5e-5 * s.max_abs_u,
            "{file}: README max |u| {u} vs run {}",
            s.max_abs_u
        );
        if let Some(n) = &s.network {
            let at = cells[1]
                .find("bus load")
                .expect("bus load in the README row");
            let load = number(&cells[1][at..]);
            assert!(
                (load - n.bus_load_percent).abs() < 0.051,
                "{file}: README bus load {load} % vs run {} %",
                n.bus_load_percent
            );
        }
    }
}

/// `n` with a thousands separator: `1,244`, `987`.
fn thousands(n: f64) -> String {
    let n = n as u32;
    if n >= 1000 {
        format!("{},{:03}", n / 1000, n % 1000)
    } else {
        n.to_string()
    }
}

#[test]
fn the_prose_quotes_the_bench_table() {
    let text = readme();
    let libm = number(&row(&text, "libm-n2m2")[2]);
    let micromath = number(&row(&text, "micromath-n2m2")[2]);
    for quote in [
        format!("instructions per step {libm} with `libm`"),
        format!("and {micromath} with `micromath`"),
        format!("from 2308 to {libm}"),
        format!("2,308 → {} instructions per step", thousands(libm)),
        format!("({} instructions per step)", thousands(micromath)),
    ] {
        assert!(text.contains(&quote), "README should say `{quote}`");
    }
}
