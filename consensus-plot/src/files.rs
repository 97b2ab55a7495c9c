//! Output files of docs/SCENARIO.md (`summary.json`, `trajectory.csv`, figures): every file is
//! written under a temporary name and renamed into place; the temporary files are removed on
//! Ctrl-C or SIGTERM.

use std::{
    path::{Path, PathBuf},
    sync::{Mutex, MutexGuard},
};

use crate::error::{Error, Result};

/// The temporary files this process has open, removed on Ctrl-C or SIGTERM.
static TEMP_FILES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temp_files() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMP_FILES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Exit status of a run interrupted by Ctrl-C or SIGTERM (128 + SIGINT, the shell convention).
pub const INTERRUPTED: i32 = 130;

/// Further clean-ups of an interrupted run (e.g. stopping emulators), run before the temporary
/// files are removed.
static ON_INTERRUPT: Mutex<Vec<fn()>> = Mutex::new(Vec::new());

/// Registers `f` to run on Ctrl-C or SIGTERM (the process has one handler:
/// [`remove_temp_files_on_interrupt`]).
pub fn also_on_interrupt(f: fn()) {
    let mut hooks = ON_INTERRUPT.lock().unwrap_or_else(|e| e.into_inner());
    if !hooks.contains(&f) {
        hooks.push(f);
    }
}

/// On Ctrl-C (SIGINT) or SIGTERM: runs the hooks of [`also_on_interrupt`], removes every open
/// temporary file, then exits with [`INTERRUPTED`]. Call once per process.
pub fn remove_temp_files_on_interrupt() -> Result<()> {
    ctrlc::set_handler(|| {
        let hooks = ON_INTERRUPT.lock().map(|h| h.clone()).unwrap_or_default();
        for hook in hooks {
            hook();
        }
        for p in temp_files().iter() {
            let _ = std::fs::remove_file(p);
        }
        std::process::exit(INTERRUPTED);
    })
    .map_err(|e| Error::Io(format!("cannot install the Ctrl-C handler: {e}")))
}

/// A temporary file that is removed unless it was renamed into place (a run cut short by an
/// error or an interrupt leaves no stray file behind).
#[derive(Debug)]
pub struct TempFile(PathBuf);

impl TempFile {
    /// Registers `path` (not yet created) for removal.
    pub fn new(path: PathBuf) -> Self {
        temp_files().push(path.clone());
        Self(path)
    }

    /// The temporary path.
    pub fn path(&self) -> &Path {
        &self.0
    }

    /// Renames the file to `to`.
    pub fn persist(self, to: &Path) -> Result<()> {
        std::fs::rename(&self.0, to).map_err(|e| Error::io(to, e))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let mut files = temp_files();
        // After a successful rename there is nothing left to remove.
        let _ = std::fs::remove_file(&self.0);
        if let Some(i) = files.iter().rposition(|p| *p == self.0) {
            files.swap_remove(i);
        }
    }
}

/// A time for messages and tables: seconds with four decimals (`0.0030 s`, `0.0400 s`), so
/// times line up however they were computed.
pub fn fmt_time(t: f64) -> String {
    format!("{t:.4} s")
}

/// `dir/name` written atomically (temp name + rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = TempFile::new(temp_path(path));
    std::fs::write(tmp.path(), bytes).map_err(|e| Error::io(tmp.path(), e))?;
    tmp.persist(path)
}

/// The temporary name of `path`, keeping its extension (plotters picks the format from it).
pub fn temp_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    let name = match path.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!(".{stem}.tmp.{ext}"),
        None => format!(".{stem}.tmp"),
    };
    path.with_file_name(name)
}

/// Creates the output directory.
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}
