//! The README is a front page that tells the truth: short, with the two set-up commands, every
//! document it maps present; no document speaks of the project's process; the shipped-scenario
//! table of `docs/REPRODUCTION.md` holds what fresh runs print, at the precision it quotes.

mod common;

use host_sim::{run::simulate, scenario};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// `README.md` and every `docs/*.md` but `docs/ARCHITECTURE.md`, which keeps the project's
/// dependency history.
fn documents() -> Vec<String> {
    let mut files = vec!["README.md".to_string()];
    for e in std::fs::read_dir(root().join("docs")).expect("docs") {
        let name = e.expect("entry").file_name().to_string_lossy().into_owned();
        if name.ends_with(".md") && name != "ARCHITECTURE.md" {
            files.push(format!("docs/{name}"));
        }
    }
    files.sort();
    files
}

#[test]
fn the_readme_is_a_front_page_with_the_two_set_up_commands() {
    let text = read("README.md");
    let lines = text.lines().count();
    assert!(lines <= 150, "README.md has {lines} lines (at most 150)");
    for command in [
        "cargo run --release -p host-sim -- run scenarios/example1.toml --out out/example1",
        "cargo test --workspace",
        "host-sim/doc/example1-errors.png",
    ] {
        assert!(text.contains(command), "README.md should show `{command}`");
    }
}

/// Repository paths quoted in backticks: `docs/X.md`, `scenarios/x.toml`, ….
fn quoted_paths(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|s| {
            [
                "docs/",
                "scenarios/",
                "campaigns/",
                "host-sim/",
                "controller-core/",
                "xtask/",
            ]
            .iter()
            .any(|p| s.starts_with(p))
                && !s.contains(['*', '<', ' ', '{', '…'])
        })
        .map(|s| s.split(['#', ':']).next().unwrap_or(s).to_string())
        .collect()
}

#[test]
fn every_path_the_readme_names_exists_and_every_document_is_on_its_map() {
    let text = read("README.md");
    for path in quoted_paths(&text) {
        assert!(
            root().join(&path).exists(),
            "README.md names `{path}`, which does not exist"
        );
    }
    for doc in documents().iter().skip(1) {
        assert!(
            text.contains(&format!("`{doc}`")),
            "README.md's map of docs/ misses `{doc}`"
        );
    }
}

/// A word that reads like a commit hash: 7 to 40 hexadecimal digits, letters and digits mixed.
fn looks_like_a_hash(word: &str) -> bool {
    (7..=40).contains(&word.len())
        && word
            .chars()
            .all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase())
        && word.chars().any(|c| c.is_ascii_digit())
        && word.chars().any(|c| c.is_ascii_alphabetic())
}

/// Process words in `text`: issue numbers, commit hashes as version labels, roles.
fn process_words(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let words: Vec<&str> = text
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    for (k, w) in words.iter().enumerate() {
        let next_is_number = words
            .get(k + 1)
            .is_some_and(|n| n.chars().all(|c| c.is_ascii_digit()));
        let lower = w.to_ascii_lowercase();
        // Proptest's stored failures are named `cc <hash>`: a seed, not a version label.
        let seed = k > 0 && words[k - 1] == "cc";
        if ((lower == "issue" || lower == "issues") && next_is_number)
            || lower == "helper"
            || lower == "helpers"
            || (looks_like_a_hash(w) && !seed)
        {
            found.push(format!("{w} {}", words.get(k + 1).unwrap_or(&"")));
        }
    }
    found
}

/// Every text file of the repository (sources, manifests, scripts, documents, golden files),
/// relative to its root; build outputs, lock files and this file (whose test strings are
/// process words on purpose) are left out.
fn repository_texts() -> Vec<String> {
    fn walk(dir: &std::path::Path, rel: &str, out: &mut Vec<String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let path = if rel.is_empty() {
                name.clone()
            } else {
                format!("{rel}/{name}")
            };
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                if !matches!(name.as_str(), "target" | ".git" | "out") {
                    walk(&e.path(), &path, out);
                }
            } else if [
                ".rs", ".md", ".toml", ".py", ".fnv", ".json", ".dbc", ".x", "run",
            ]
            .iter()
            .any(|ext| name.ends_with(ext))
                && path != "host-sim/tests/readme.rs"
            {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root(), "", &mut files);
    files.sort();
    files
}

/// Process words in source and data files, where numeric literals and digests look like hashes:
/// issue numbers, roles, and a hash named as a version (a branch or `commit` followed by a hash).
fn process_words_in_code(text: &str) -> Vec<String> {
    let words: Vec<&str> = text
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .collect();
    let mut found = Vec::new();
    for (k, w) in words.iter().enumerate() {
        let lower = w.to_ascii_lowercase();
        let next = words.get(k + 1).copied().unwrap_or("");
        let after = words.get(k + 2).copied().unwrap_or("");
        let names_a_version = (lower == "main" || lower == "commit")
            && (looks_like_a_hash(next) || (next == "at" && looks_like_a_hash(after)));
        if ((lower == "issue" || lower == "issues")
            && next.chars().all(|c| c.is_ascii_digit())
            && !next.is_empty())
            || lower == "helper"
            || lower == "helpers"
            || names_a_version
        {
            found.push(format!("{w} {next}"));
        }
    }
    found
}

#[test]
fn no_file_of_the_repository_speaks_of_issue_numbers_commit_hashes_or_roles() {
    assert_eq!(
        process_words_in_code(concat!(
            "made by main at ",
            "3a8062c for issue ",
            "14 by a helper; 0x1e30f32"
        )),
        ["main at", concat!("issue ", "14"), "helper 0x1e30f32"]
    );
    let files = repository_texts();
    assert!(
        files.iter().any(|f| f == "controller-core/src/lib.rs"),
        "{files:?}"
    );
    let mut offending = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(root().join(file)) else {
            continue;
        };
        let found = if file.ends_with(".md") {
            process_words(&text)
        } else {
            process_words_in_code(&text)
        };
        if !found.is_empty() {
            offending.push(format!("{file}: {found:?}"));
        }
    }
    assert!(
        offending.is_empty(),
        "process words:\n{}",
        offending.join("\n")
    );
}

#[test]
fn no_document_speaks_of_issue_numbers_commit_hashes_or_roles() {
    assert_eq!(
        process_words(concat!(
            "before issue ",
            "14, main at ",
            "42ec565, a helper"
        )),
        [concat!("issue ", "14"), "42ec565 a", "helper "]
    );
    assert!(process_words("the cc 97ab7197 seed, 1,089 instructions, 0x00010010").is_empty());
    for doc in documents() {
        let found = process_words(&read(&doc));
        assert!(found.is_empty(), "{doc}: process words {found:?}");
    }
}

/// Cells of the table row whose first cell is `` `key` ``.
fn row(text: &str, key: &str) -> Vec<String> {
    let line = text
        .lines()
        .find(|l| l.starts_with(&format!("| `{key}`")))
        .unwrap_or_else(|| panic!("no row for {key}"));
    line.trim_matches('|')
        .split(" | ")
        .map(|c| c.trim().to_string())
        .collect()
}

/// The first number in `cell` (thousands separators allowed) and its decimals.
fn quoted(cell: &str) -> (f64, i32) {
    let start = cell.find(|c: char| c.is_ascii_digit()).expect("a number");
    let digits: String = cell[start..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == ',')
        .filter(|c| *c != ',')
        .collect();
    let digits = digits.trim_end_matches('.');
    let decimals = digits.split_once('.').map_or(0, |(_, f)| f.len() as i32);
    (digits.parse().expect("number"), decimals)
}

/// `actual` rounds to the quoted figure: within half a unit of its last digit.
fn assert_quoted(what: &str, cell: &str, actual: f64) {
    let (q, decimals) = quoted(cell);
    let half_unit = 0.5 * 10f64.powi(-decimals) * (1.0 + 1e-9);
    assert!(
        (q - actual).abs() <= half_unit,
        "{what}: quoted {cell}, measured {actual}"
    );
}

#[test]
fn the_scenario_table_matches_the_runs_at_its_quoted_precision() {
    let text = read("docs/REPRODUCTION.md");
    for file in [
        "example1.toml",
        "example1-ts1.toml",
        "example2.toml",
        "example2-baseline.toml",
        "example1-can.toml",
        "example1-lossy.toml",
    ] {
        // scenario | reproduces | h | bus load | max error after 2Ts | settling time | max |u| | stable h
        let cells = row(&text, file);
        let setup = scenario::load(&common::scenario_path(file), &[]).expect("scenario");
        let s = simulate(&setup).expect("run");
        let err = s.max_error_after_predefined_time.expect("error after 2Ts");
        assert_quoted(&format!("{file} max error"), &cells[4], err);
        match s.settling_time {
            None => assert!(cells[5].starts_with("never"), "{file}: {}", cells[5]),
            Some(t) => assert_quoted(&format!("{file} settling time"), &cells[5], t),
        }
        assert_quoted(&format!("{file} max |u|"), &cells[6], s.max_abs_u);
        match &s.network {
            Some(n) => assert_quoted(&format!("{file} bus load"), &cells[3], n.bus_load_percent),
            None => assert_eq!(cells[3], "–", "{file}"),
        }
    }
}
