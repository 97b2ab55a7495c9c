//! Cross-crate integration tests. The helpers here serve the tests in `tests/tests/`: where the
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

/// Path of the built `host-sim` binary: `$HOST_SIM_BIN`, else `target/<profile>/host-sim` of
/// this test build, built on demand with `$CARGO build -p host-sim` (a no-op after
/// `cargo test --workspace`). Panics with instructions when it cannot be found.
pub fn host_sim_bin() -> PathBuf {
    static BIN: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    let r = BIN.get_or_init(|| {
        let path = candidate().ok_or("cannot locate this test binary")?;
        if std::env::var_os("HOST_SIM_BIN").is_none() {
            if let Some(dir) = profile_dir() {
                // Refresh (or create) the binary; keep an existing one if cargo is unavailable.
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
