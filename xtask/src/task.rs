//! What every task shares: the options, the result type, where the workspace and the bench
//! outputs are, and how a firmware crate outside the workspace is built.

use std::path::{Path, PathBuf};

/// Command-line options shared by the tasks.
#[derive(Debug, Clone, Default)]
pub struct Options {
    pub verbose: bool,
    pub no_run: bool,
    pub update_budget: bool,
    pub check: bool,
    pub rerun: bool,
    pub wall_clock: bool,
    pub list: bool,
    pub reason: Option<String>,
    /// `docs --only NAME`: render only the blocks of that figure, keep every other as it is.
    pub only: Option<String>,
}

impl Options {
    /// The options after the task name.
    pub fn parse(args: &[String]) -> Result<Self> {
        let mut o = Options::default();
        let mut args = args.iter();
        while let Some(a) = args.next() {
            match a.as_str() {
                "--verbose" | "-v" => o.verbose = true,
                "--no-run" => o.no_run = true,
                "--update-budget" => o.update_budget = true,
                "--check" => o.check = true,
                "--rerun" => o.rerun = true,
                "--wall-clock" => o.wall_clock = true,
                "--list" => o.list = true,
                "--only" => {
                    o.only = Some(
                        args.next()
                            .ok_or("--only needs a file or a figure name")?
                            .clone(),
                    );
                }
                "--reason" => {
                    o.reason = Some(args.next().ok_or("--reason needs a text")?.clone());
                }
                other => return Err(format!("unknown option `{other}`")),
            }
        }
        Ok(o)
    }
}

/// The workspace root (the parent of this crate's manifest directory).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// `target/bench` under the workspace root (independent of `CARGO_TARGET_DIR`, so the
/// documented output path holds).
pub fn bench_dir() -> PathBuf {
    workspace_root().join("target").join("bench")
}

/// The `cargo` that runs this task.
pub fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned())
}

/// `cargo build --release --locked` of a firmware crate outside the workspace into `target_dir`,
/// run from its directory so its `.cargo/config.toml` (target, linker scripts) applies, with no
/// host flags leaking into the target build. The checkout's and Cargo home's paths are remapped to
/// fixed prefixes, so the panic locations kept in flash, and with them the measured sizes, are
/// the same wherever the repository and the registry lie. Cargo leaves `--remap-path-prefix` out
/// of its fingerprints, so `target_dir` must hold no build made without these flags: it is a
/// directory of its own, not the crate's `target`.
pub fn firmware_build(dir: &Path, target_dir: &Path) -> std::process::Command {
    firmware_build_for(dir, target_dir, "thumbv7em-none-eabihf")
}

/// [`firmware_build`] for the Rust target `triple` (passed as `--target`).
pub fn firmware_build_for(dir: &Path, target_dir: &Path, triple: &str) -> std::process::Command {
    let mut c = std::process::Command::new(cargo());
    c.current_dir(dir)
        .args([
            "build",
            "--release",
            "--locked",
            "--target",
            triple,
            "--config",
        ])
        .arg(remap_config(triple))
        .arg("--target-dir")
        .arg(target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET");
    c
}

/// The `--config` value that adds the path remapping of [`firmware_build`] to the target's
/// `rustflags` (cargo appends it to those of the crate's `.cargo/config.toml`).
fn remap_config(triple: &str) -> String {
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")));
    let mut flags = vec![format!(
        "--remap-path-prefix={}=/src",
        workspace_root().display()
    )];
    if let Some(home) = cargo_home {
        flags.push(format!("--remap-path-prefix={}=/cargo", home.display()));
    }
    // A JSON array of strings is a TOML inline array.
    format!(
        "target.{}.rustflags={}",
        toml_key(triple),
        serde_json::Value::from(flags)
    )
}

/// A target triple as a TOML key: quoted when it holds a dot (`thumbv8m.main-none-eabihf`).
fn toml_key(triple: &str) -> String {
    if triple.contains('.') {
        format!("\"{triple}\"")
    } else {
        triple.to_owned()
    }
}

/// Result type of the tasks: a message for the user.
pub type Result<T> = std::result::Result<T, String>;
