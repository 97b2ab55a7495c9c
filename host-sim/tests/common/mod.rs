//! Functions shared by host-sim's integration tests (each test binary uses a subset).
#![allow(dead_code)]

use std::{
    path::PathBuf,
    process::{Command, Output},
};

/// The built `host-sim` binary.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

/// A shipped scenario file.
pub fn scenario_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenarios")
        .join(name)
}

/// The committed DBC, `docs/wire.dbc`.
pub fn wire_dbc() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/wire.dbc")
}

/// A fresh, empty directory under cargo's per-target temporary directory.
pub fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("tmp dir");
    d
}

/// Exit 2, exactly one line on stderr naming `key`, no panic.
pub fn assert_invalid(out: &Output, key: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(err.contains(key), "message should name `{key}`: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Exit 0; stderr shown otherwise.
pub fn assert_ok(out: &Output) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Fails the calling test, naming `pip_install`, unless `python3` imports every module of
/// `modules`. The tests that call it are `#[ignore]`d with that reason, so `cargo test` lists them
/// as ignored instead of passing them silently; `.ci/run` runs them with `--ignored`.
pub fn require_python(modules: &str, pip_install: &str) {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(ok, "this check needs python3 with {modules}: {pip_install}");
}
pub mod back_end;
