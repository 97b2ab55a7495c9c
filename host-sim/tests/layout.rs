//! host-sim's module layout (docs/ARCHITECTURE.md, "host-sim modules"): the blocks own their
//! scenario sections and never import `scenario`, no source file sits on an import circle, and
//! no file imports one of a higher layer ([`LAYERS`]).
//!
//! The import graph is read from the sources: every `crate::…` path (in `use` trees and inline)
//! outside comments, resolved to the file that defines the module.

use std::{
    collections::{BTreeMap, BTreeSet},
    path::{Path, PathBuf},
};

/// The blocks below `scenario`: they own their spec types and must not import it.
const BLOCKS: [&str; 8] = [
    "faults.rs",
    "clock.rs",
    "metrics/spec.rs",
    "graph.rs",
    "network",
    "plant",
    "sim.rs",
    "leader.rs",
];

/// The layers of `src/`, lowest first: a file may import files of its own layer and of those
/// below. A file belongs to the layer of the longest path prefix listed here (a directory
/// `plant` covers `plant/…`); every file must have one, so a new module is placed on purpose.
/// The same table is in docs/ARCHITECTURE.md, "host-sim modules".
const LAYERS: &[(&str, &[&str])] = &[
    (
        "foundation: errors, random draws, output files and interrupts",
        &["error.rs", "generate.rs", "report/mod.rs", "figure"],
    ),
    (
        "blocks: one scenario section each, and what the loop and the summary share",
        &[
            "graph.rs",
            "leader.rs",
            "faults.rs",
            "clock.rs",
            "plant",
            "figures.rs",
            "network/spec.rs",
            "network/node.rs",
            "network/ideal.rs",
            "network/trace.rs",
            "metrics/spec.rs",
        ],
    ),
    ("the loop", &["sim.rs", "sim"]),
    ("assembly of a scenario", &["scenario.rs"]),
    (
        "agents over a bus, observers and outputs",
        &[
            "network/mod.rs",
            "network/can.rs",
            "network/pil.rs",
            "network/socketcan.rs",
            "metrics.rs",
            "report",
            "agent.rs",
        ],
    ),
    (
        "commands",
        &["run.rs", "compare.rs", "matrix.rs", "monitor.rs"],
    ),
    ("many runs", &["campaign"]),
    ("crate root and binary", &["lib.rs", "main.rs", "cli"]),
];

/// The layer of `file` (index into [`LAYERS`]).
fn layer(file: &str) -> Option<usize> {
    let covers = |prefix: &str| file == prefix || file.starts_with(&format!("{prefix}/"));
    LAYERS
        .iter()
        .enumerate()
        .flat_map(|(k, (_, prefixes))| prefixes.iter().map(move |p| (k, *p)))
        .filter(|(_, p)| covers(p))
        .max_by_key(|(_, p)| p.len())
        .map(|(k, _)| k)
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `src/`, relative (`plant/mod.rs`), with its text minus comments.
fn sources() -> BTreeMap<String, String> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<String, String>) {
        for e in std::fs::read_dir(dir).expect("src dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root).expect("under src");
                let text = std::fs::read_to_string(&p).expect("source");
                let code: String = text
                    .lines()
                    .map(|l| l.split("//").next().unwrap_or(""))
                    .collect::<Vec<_>>()
                    .join("\n");
                out.insert(rel.to_string_lossy().replace('\\', "/"), code);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(&src(), &src(), &mut out);
    out
}

/// The paths of one `use` tree (`a::{b, c::{d}}` → `a::b`, `a::c::d`).
fn expand(prefix: &str, tree: &str, out: &mut Vec<String>) {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        for part in tree.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            out.push(format!("{prefix}{part}"));
        }
        return;
    };
    let head = &tree[..open];
    let body = &tree[open + 1..tree.rfind('}').expect("balanced use tree")];
    let mut depth = 0;
    let mut start = 0;
    for (i, c) in body.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                expand(&format!("{prefix}{head}"), &body[start..i], out);
                start = i + 1;
            }
            _ => {}
        }
    }
    expand(&format!("{prefix}{head}"), &body[start..], out);
}

/// The `crate::` paths a file's code names.
fn crate_paths(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("crate::") {
        let tail = &rest[at + "crate::".len()..];
        if tail.starts_with('{') {
            let mut depth = 0;
            let end = tail
                .char_indices()
                .find(|&(_, c)| {
                    match c {
                        '{' => depth += 1,
                        '}' => depth -= 1,
                        _ => {}
                    }
                    depth == 0
                })
                .map_or(tail.len(), |(i, _)| i + 1);
            expand("", &tail[..end], &mut out);
            rest = &tail[end..];
        } else {
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            out.push(tail[..end].to_string());
            rest = &tail[end..];
        }
    }
    out
}

/// The file defining the longest module prefix of `path` (`network::trace::X` → `network/trace.rs`).
fn resolve(path: &str, files: &BTreeMap<String, String>) -> Option<String> {
    let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    (1..=segs.len()).rev().find_map(|k| {
        let m = segs[..k].join("/");
        [format!("{m}.rs"), format!("{m}/mod.rs")]
            .into_iter()
            .find(|f| files.contains_key(f))
    })
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let files = sources();
    files
        .iter()
        .map(|(f, code)| {
            let deps = crate_paths(code)
                .iter()
                .filter_map(|p| resolve(p, &files))
                .filter(|d| d != f)
                .collect();
            (f.clone(), deps)
        })
        .collect()
}

/// Files reachable from `from`.
fn reach(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = vec![from.to_string()];
    while let Some(f) = stack.pop() {
        for d in g.get(&f).into_iter().flatten() {
            if seen.insert(d.clone()) {
                stack.push(d.clone());
            }
        }
    }
    seen
}

#[test]
fn parser_sees_nested_use_trees() {
    let code = "use crate::{\n    error::{Error, Result},\n    network::trace::{T, I},\n};\nfn f() { crate::graph::MAX; }";
    assert_eq!(
        crate_paths(code),
        [
            "error::Error",
            "error::Result",
            "network::trace::T",
            "network::trace::I",
            "graph::MAX"
        ]
    );
}

#[test]
fn blocks_do_not_import_scenario() {
    let g = graph();
    let in_block = |f: &str, b: &str| f == b || f.starts_with(&format!("{b}/"));
    for b in BLOCKS {
        assert!(g.keys().any(|f| in_block(f, b)), "src/{b} is gone");
    }
    let offenders: Vec<&String> = g
        .iter()
        .filter(|(f, deps)| BLOCKS.iter().any(|b| in_block(f, b)) && deps.contains("scenario.rs"))
        .map(|(f, _)| f)
        .collect();
    assert!(
        offenders.is_empty(),
        "these modules import `scenario` (they must own their spec types): {offenders:?}"
    );
}

#[test]
fn no_import_circle() {
    let g = graph();
    assert!(g.contains_key("scenario.rs"), "src/scenario.rs");
    let circular: Vec<(&String, Vec<&String>)> = g
        .iter()
        .filter(|(f, _)| reach(&g, f).contains(*f))
        .map(|(f, deps)| {
            let back = deps.iter().filter(|d| reach(&g, d).contains(f)).collect();
            (f, back)
        })
        .collect();
    assert!(
        circular.is_empty(),
        "files on an import circle (file, the imports that lead back to it): {circular:?}"
    );
}

#[test]
fn layers_cover_the_sources_and_name_their_files() {
    assert_eq!(layer("report/mod.rs"), Some(0));
    assert_eq!(layer("report/plots.rs"), Some(4));
    assert_eq!(layer("plant/custom/parse.rs"), Some(1));
    assert_eq!(layer("network/spec.rs"), Some(1));
    assert_eq!(layer("network/pil.rs"), Some(4));
    assert_eq!(layer("sim.rs"), Some(2));
    let files = sources();
    let homeless: Vec<&String> = files.keys().filter(|f| layer(f).is_none()).collect();
    assert!(
        homeless.is_empty(),
        "files in no layer of LAYERS (place them, and in docs/ARCHITECTURE.md): {homeless:?}"
    );
    for (_, prefixes) in LAYERS {
        for p in *prefixes {
            assert!(
                files
                    .keys()
                    .any(|f| f == p || f.starts_with(&format!("{p}/"))),
                "LAYERS names src/{p}, which is gone"
            );
        }
    }
}

#[test]
fn no_file_imports_a_higher_layer() {
    let g = graph();
    let upward: Vec<String> = g
        .iter()
        .flat_map(|(f, deps)| deps.iter().map(move |d| (f, d)))
        .filter_map(|(f, d)| {
            let (lf, ld) = (layer(f)?, layer(d)?);
            (ld > lf).then(|| {
                format!(
                    "{f} ({}) imports {d} ({})",
                    LAYERS[lf].0.split(':').next().unwrap_or(""),
                    LAYERS[ld].0.split(':').next().unwrap_or("")
                )
            })
        })
        .collect();
    assert!(
        upward.is_empty(),
        "imports from a higher layer:\n{}",
        upward.join("\n")
    );
}
