//! The module layout of every crate of the workspace: no source file sits on an import circle,
//! and no module imports through its crate's root (`crate::Name` for a re-export of `lib.rs`),
//! which would hide the module it really depends on and put the root in the middle of the graph.
//! The layers of the simulator's crates (consensus-plot, consensus-sim, consensus-hil, host-sim)
//! are held here too, on top of that ([`LAYERS`], one table per crate).
//!
//! The import graph is read from the sources: every `crate::…` path (in `use` trees and inline)
//! outside comments and unit tests (a file's trailing `#[cfg(test)] mod`, files named
//! `*tests.rs`), resolved to the file that defines the module, or to the crate root when its
//! first segment is an item of the root. Tests may reach up; the product code may not.

use std::{
    collections::{BTreeMap, BTreeSet},
    path::{Path, PathBuf},
};

/// Every crate of the workspace with a `src/` of its own, and the firmware crates outside it.
const CRATES: [&str; 13] = [
    "controller-core",
    "agent-node",
    "hil-mock",
    "node-linux",
    "consensus-plot",
    "consensus-sim",
    "consensus-hil",
    "host-sim",
    "python",
    "xtask",
    "node-fw",
    "bench-fw",
    "boards/nucleo-g474re",
];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `.rs` file under `dir`, relative (`plant/mod.rs`), with its text minus comments.
fn sources(dir: &Path) -> BTreeMap<String, String> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<String, String>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|x| x == "rs")
                && !p.to_string_lossy().ends_with("tests.rs")
            {
                let rel = p.strip_prefix(root).expect("under src");
                let text = std::fs::read_to_string(&p).expect("source");
                let code: String = text
                    .lines()
                    .map(|l| l.split("//").next().unwrap_or(""))
                    .collect::<Vec<_>>()
                    .join("\n");
                let code = match code.find("#[cfg(test)]\nmod ") {
                    Some(at) => code[..at].to_string(),
                    None => code,
                };
                out.insert(rel.to_string_lossy().replace('\\', "/"), code);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
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
    let body = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
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
        let before = rest[..at].chars().next_back();
        let tail = &rest[at + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            // `$crate::` of a macro, or a name ending in `crate`.
            rest = tail;
            continue;
        }
        let head_len = tail
            .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
            .unwrap_or(tail.len());
        if tail[head_len..].starts_with('{') {
            let (head, tree) = tail.split_at(head_len);
            let mut depth = 0;
            let end = tree
                .char_indices()
                .find(|&(_, c)| {
                    match c {
                        '{' => depth += 1,
                        '}' => depth -= 1,
                        _ => {}
                    }
                    depth == 0
                })
                .map_or(tree.len(), |(i, _)| i + 1);
            expand(head, &tree[..end], &mut out);
            rest = &tree[end..];
        } else {
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            out.push(tail[..end].trim_end_matches(':').to_string());
            rest = &tail[end..];
        }
    }
    out
}

/// The crate root among `files`: `lib.rs`, else `main.rs`.
fn crate_root(files: &BTreeMap<String, String>) -> &'static str {
    if files.contains_key("lib.rs") {
        "lib.rs"
    } else {
        "main.rs"
    }
}

/// The file defining the longest module prefix of `path` (`network::trace::X` →
/// `network/trace.rs`); the crate root for an item of the root (`crate::ConfigError`).
fn resolve(path: &str, files: &BTreeMap<String, String>) -> Option<String> {
    let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    (1..=segs.len())
        .rev()
        .find_map(|k| {
            let m = segs[..k].join("/");
            [format!("{m}.rs"), format!("{m}/mod.rs")]
                .into_iter()
                .find(|f| files.contains_key(f))
        })
        .or_else(|| (!segs.is_empty()).then(|| crate_root(files).to_string()))
}

type Graph = BTreeMap<String, BTreeSet<String>>;

fn graph(files: &BTreeMap<String, String>) -> Graph {
    files
        .iter()
        .map(|(f, code)| {
            let deps = crate_paths(code)
                .iter()
                .filter_map(|p| resolve(p, files))
                .filter(|d| d != f)
                .collect();
            (f.clone(), deps)
        })
        .collect()
}

/// Files reachable from `from`.
fn reach(g: &Graph, from: &str) -> BTreeSet<String> {
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

/// What is wrong with one crate's layout, one line each.
fn problems(krate: &str) -> Vec<String> {
    let files = sources(&root().join(krate).join("src"));
    let top = crate_root(&files);
    let g = graph(&files);
    let mut out = Vec::new();
    for (f, deps) in &g {
        if f != top && deps.contains(top) {
            out.push(format!(
                "{krate}/src/{f} imports through the crate root (name the module instead)"
            ));
        }
    }
    for (f, deps) in &g {
        if f == top {
            continue;
        }
        let back: Vec<&String> = deps
            .iter()
            .filter(|d| *d != top && reach(&g, d).contains(f))
            .collect();
        if !back.is_empty() {
            out.push(format!(
                "{krate}/src/{f} is on an import circle through {back:?}"
            ));
        }
    }
    out
}

#[test]
fn the_reader_sees_nested_trees_root_items_and_skips_macro_paths() {
    let code = "use crate::{\n    error::{Error, Result},\n    Param,\n};\nfn f() { crate::graph::MAX; $crate::x::Y; }\nuse crate::net::{self, od::Store};";
    assert_eq!(
        crate_paths(code),
        [
            "error::Error",
            "error::Result",
            "Param",
            "graph::MAX",
            "net::self",
            "net::od::Store"
        ]
    );
    let files: BTreeMap<String, String> = ["lib.rs", "error.rs", "graph/mod.rs"]
        .into_iter()
        .map(|f| (f.to_string(), String::new()))
        .collect();
    assert_eq!(resolve("error::Error", &files).as_deref(), Some("error.rs"));
    assert_eq!(
        resolve("graph::MAX", &files).as_deref(),
        Some("graph/mod.rs")
    );
    assert_eq!(resolve("Param", &files).as_deref(), Some("lib.rs"));
}

#[test]
fn a_circle_and_an_import_through_the_root_are_both_found() {
    let dir = std::env::temp_dir().join(format!("layout-probe-{}", std::process::id()));
    let src = dir.join("probe/src");
    std::fs::create_dir_all(&src).expect("temporary crate");
    for (f, code) in [
        ("lib.rs", "pub mod a;\npub mod b;\npub use a::A;"),
        ("a.rs", "use crate::b::B;\npub struct A;"),
        ("b.rs", "use crate::{a::A, A as Again};\npub struct B;"),
    ] {
        std::fs::write(src.join(f), code).expect("probe file");
    }
    let files = sources(&src);
    let g = graph(&files);
    assert!(g["b.rs"].contains("lib.rs") && g["a.rs"].contains("b.rs"));
    let found = {
        let top = crate_root(&files);
        let through_root = g
            .iter()
            .filter(|(f, d)| *f != top && d.contains(top))
            .count();
        let circular = g
            .keys()
            .filter(|f| *f != top && reach(&g, f).contains(*f))
            .count();
        (through_root, circular)
    };
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(
        found,
        (1, 2),
        "b imports through the root; a and b are on a circle"
    );
}

#[test]
fn no_crate_has_an_import_circle_or_imports_through_its_root() {
    let all: Vec<String> = CRATES.iter().flat_map(|c| problems(c)).collect();
    assert!(all.is_empty(), "module layout:\n{}", all.join("\n"));
}

// The simulator's layers (docs/ARCHITECTURE.md, "host-sim modules"): the blocks own their
// scenario sections and never import `scenario`, and in every crate no file imports one of a
// higher layer. Between the crates, Cargo holds the order: consensus-plot ← consensus-sim ←
// consensus-hil ← host-sim, and a crate cannot name one that depends on it.

/// The blocks of consensus-sim below `scenario`: they own their spec types and must not import
/// it.
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

/// A crate's layers, lowest first: its name and, per layer, what it holds and its path prefixes.
type Layers = &'static [(&'static str, &'static [&'static str])];

/// The layers of each of the simulator's crates' `src/`, lowest first: a file may import files
/// of its own layer and of those below. A file belongs to the layer of the longest path prefix
/// listed (a directory `plant` covers `plant/…`); every file must have one, so a new module is
/// placed on purpose. The same tables are in docs/ARCHITECTURE.md, "host-sim modules".
const LAYERS: &[(&str, Layers)] = &[
    (
        "consensus-plot",
        &[
            ("errors", &["error.rs"]),
            ("output files and interrupts", &["files.rs"]),
            ("the figure toolkit", &["figure"]),
            ("crate root", &["lib.rs"]),
        ],
    ),
    (
        "consensus-sim",
        &[
            ("foundation: random draws", &["generate.rs"]),
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
                "agents over the modelled bus, observers",
                &["network/can.rs", "metrics.rs", "agent.rs"],
            ),
            ("crate root and module lists", &["lib.rs", "network/mod.rs"]),
        ],
    ),
    (
        "consensus-hil",
        &[
            (
                "blocks: the CANopen master, the live-bus decoder",
                &["network/canopen.rs", "monitor.rs"],
            ),
            (
                "kinds: hardware in the loop",
                &["network/pil.rs", "network/socketcan.rs"],
            ),
            ("agents of every bus kind", &["network/mod.rs"]),
            ("crate root", &["lib.rs"]),
        ],
    ),
    (
        "host-sim",
        &[
            (
                "outputs: the trajectory, tables, figures of a run",
                &["report"],
            ),
            (
                "commands",
                &["run.rs", "compare.rs", "matrix.rs", "front.rs"],
            ),
            ("many runs", &["campaign"]),
            ("crate root and binary", &["lib.rs", "main.rs", "cli"]),
        ],
    ),
];

/// The layer of `file` in `layers` (an index into it).
fn layer(layers: Layers, file: &str) -> Option<usize> {
    let covers = |prefix: &str| file == prefix || file.starts_with(&format!("{prefix}/"));
    layers
        .iter()
        .enumerate()
        .flat_map(|(k, (_, prefixes))| prefixes.iter().map(move |p| (k, *p)))
        .filter(|(_, p)| covers(p))
        .max_by_key(|(_, p)| p.len())
        .map(|(k, _)| k)
}

/// The layers of `krate`.
fn layers_of(krate: &str) -> Layers {
    LAYERS
        .iter()
        .find(|(c, _)| *c == krate)
        .map(|(_, l)| *l)
        .unwrap_or_else(|| panic!("{krate} has no layers"))
}

/// A crate's sources and import graph.
fn crate_graph(krate: &str) -> (BTreeMap<String, String>, Graph) {
    let files = sources(&root().join(krate).join("src"));
    let g = graph(&files);
    (files, g)
}

#[test]
fn blocks_do_not_import_scenario() {
    let (_, g) = crate_graph("consensus-sim");
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
fn every_layered_crate_is_a_crate_of_the_workspace() {
    for (krate, _) in LAYERS {
        assert!(CRATES.contains(krate), "{krate} is not in CRATES");
    }
}

#[test]
fn layers_cover_the_sources_and_name_their_files() {
    let sim = layers_of("consensus-sim");
    assert_eq!(layer(sim, "plant/custom/parse.rs"), Some(1));
    assert_eq!(layer(sim, "network/spec.rs"), Some(1));
    assert_eq!(layer(sim, "network/can.rs"), Some(4));
    assert_eq!(layer(sim, "sim.rs"), Some(2));
    assert_eq!(layer(sim, "sim/clocked.rs"), Some(2));
    assert_eq!(layer(layers_of("host-sim"), "report/mod.rs"), Some(0));
    assert_eq!(layer(layers_of("consensus-hil"), "network/pil.rs"), Some(1));
    for (krate, layers) in LAYERS {
        let (files, _) = crate_graph(krate);
        let homeless: Vec<&String> = files
            .keys()
            .filter(|f| layer(layers, f).is_none())
            .collect();
        assert!(
            homeless.is_empty(),
            "{krate}: files in no layer of LAYERS (place them, and in docs/ARCHITECTURE.md): \
             {homeless:?}"
        );
        for (_, prefixes) in *layers {
            for p in *prefixes {
                assert!(
                    files
                        .keys()
                        .any(|f| f == p || f.starts_with(&format!("{p}/"))),
                    "LAYERS names {krate}/src/{p}, which is gone"
                );
            }
        }
    }
}

#[test]
fn no_file_imports_a_higher_layer() {
    let upward: Vec<String> = LAYERS
        .iter()
        .flat_map(|(krate, layers)| {
            let (_, g) = crate_graph(krate);
            g.iter()
                .flat_map(|(f, deps)| deps.iter().map(move |d| (f.clone(), d.clone())))
                .filter_map(|(f, d)| {
                    let (lf, ld) = (layer(layers, &f)?, layer(layers, &d)?);
                    (ld > lf).then(|| {
                        format!(
                            "{krate}/src/{f} ({}) imports {d} ({})",
                            layers[lf].0.split(':').next().unwrap_or(""),
                            layers[ld].0.split(':').next().unwrap_or("")
                        )
                    })
                })
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        upward.is_empty(),
        "imports from a higher layer:\n{}",
        upward.join("\n")
    );
}
