//! Cross-crate integration tests. The functions here serve the tests in `tests/tests/`: where the
//! built `host-sim` binary is, and the corpus directory.

use std::{
    path::{Path, PathBuf},
    process::Command,
};

/// The corpus of malformed inputs (`tests/corpus`).
pub fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("corpus")
}

/// The shipped scenarios (`scenarios/` at the workspace root).
pub fn scenarios_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios")
}

fn exe_name() -> String {
    format!("host-sim{}", std::env::consts::EXE_SUFFIX)
}

/// The profile directory (`target/<profile>`) this test binary was built into: the test runs
/// from `target/<profile>/deps/<test>-<hash>`.
fn profile_dir() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let deps = exe.parent()?;
    let dir = if deps.file_name().is_some_and(|n| n == "deps") {
        deps.parent()?
    } else {
        deps
    };
    Some(dir.to_path_buf())
}

/// Where the `host-sim` binary of this build is expected: next to the test's `deps` directory
/// (`cargo test --workspace` builds every binary of the workspace there first).
fn candidate() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("HOST_SIM_BIN") {
        return Some(PathBuf::from(p));
    }
    profile_dir().map(|d| d.join(exe_name()))
}

/// Builds `host-sim` for this test's profile and target directory with the `cargo` that runs
/// the test (`$CARGO`), so a `cargo test -p integration-tests` alone also gets a fresh binary.
fn build(profile_dir: &Path) -> Result<(), String> {
    let cargo = std::env::var_os("CARGO").ok_or("CARGO is not set (not run by cargo test)")?;
    let target = profile_dir
        .parent()
        .ok_or("test binary is not under target/<profile>")?;
    let profile = profile_dir
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or("no profile directory")?;
    let mut cmd = Command::new(cargo);
    cmd.args(["build", "--quiet", "-p", "host-sim", "--bin", "host-sim"])
        .env("CARGO_TARGET_DIR", target)
        .current_dir(env!("CARGO_MANIFEST_DIR"));
    match profile {
        "debug" => {}
        "release" => {
            cmd.arg("--release");
        }
        p => {
            cmd.args(["--profile", p]);
        }
    }
    let out = cmd.output().map_err(|e| format!("cannot run cargo: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "cargo build -p host-sim failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// Newest modification time of the files under `dir` (recursively).
fn newest(dir: &Path) -> Option<std::time::SystemTime> {
    let mut best = None;
    for e in std::fs::read_dir(dir).ok()?.filter_map(|e| e.ok()) {
        let t = match e.file_type() {
            Ok(ft) if ft.is_dir() => newest(&e.path()),
            Ok(_) => e.metadata().and_then(|m| m.modified()).ok(),
            Err(_) => None,
        };
        best = best.max(t);
    }
    best
}

/// The binary is missing or older than a source or manifest of a crate it is built from. Only
/// then is cargo called: after `cargo test --workspace` the binary is fresh, and a second
/// cargo with other feature unification would rebuild it for nothing.
fn is_stale(bin: &Path) -> bool {
    let Ok(built) = bin.metadata().and_then(|m| m.modified()) else {
        return true;
    };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    ["host-sim", "hil-mock", "agent-node", "controller-core"]
        .iter()
        .any(|c| {
            let c = root.join(c);
            newest(&c.join("src")).max(newest_file(&c.join("Cargo.toml"))) > Some(built)
        })
        || newest_file(&root.join("Cargo.lock")) > Some(built)
}

fn newest_file(p: &Path) -> Option<std::time::SystemTime> {
    p.metadata().and_then(|m| m.modified()).ok()
}

/// Path of the built `host-sim` binary: `$HOST_SIM_BIN`, else `target/<profile>/host-sim` of
/// this test build (`cargo test --workspace` builds it before the tests run), built with
/// `$CARGO build -p host-sim` when missing or older than its sources (e.g. after
/// `cargo test -p integration-tests` alone). Panics with instructions when it cannot be found.
pub fn host_sim_bin() -> PathBuf {
    static BIN: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    let r = BIN.get_or_init(|| {
        let path = candidate().ok_or("cannot locate this test binary")?;
        if std::env::var_os("HOST_SIM_BIN").is_none() && is_stale(&path) {
            if let Some(dir) = profile_dir() {
                // Build (or refresh) the binary; keep an existing one if cargo is unavailable.
                if let Err(e) = build(&dir) {
                    if !path.is_file() {
                        return Err(e);
                    }
                }
            }
        }
        if path.is_file() {
            Ok(path)
        } else {
            Err(format!("{} does not exist", path.display()))
        }
    });
    match r {
        Ok(p) => p.clone(),
        Err(e) => panic!(
            "the host-sim binary is needed: {e}. Run `cargo build -p host-sim` (same profile and \
             CARGO_TARGET_DIR as the tests) or set HOST_SIM_BIN=/path/to/host-sim"
        ),
    }
}

/// A fresh, empty scratch directory for one test case (under the target directory).
pub fn scratch(name: &str) -> PathBuf {
    let d = profile_dir()
        .unwrap_or_else(std::env::temp_dir)
        .join("integration-scratch")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    if let Err(e) = std::fs::create_dir_all(&d) {
        panic!("cannot create {}: {e}", d.display());
    }
    d
}
