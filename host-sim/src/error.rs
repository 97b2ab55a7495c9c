//! The two kinds of failure the CLI reports (docs/SCENARIO.md §1 "Exit status").

use std::fmt;

/// Why a command failed: an invalid scenario or option (exit 2) or an I/O error (exit 1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Error {
    /// The scenario or an option is invalid; the text names the key (an option when it starts
    /// with `--`) and the reason.
    Invalid(String),
    /// Reading or writing a file failed.
    Io(String),
}

impl Error {
    /// An invalid value at `key` (a scenario key, or an option such as `--decimate`).
    pub fn invalid(key: impl fmt::Display, reason: impl fmt::Display) -> Self {
        Self::Invalid(format!("{key}: {reason}"))
    }

    /// An I/O failure on `path`.
    pub fn io(path: &std::path::Path, err: impl fmt::Display) -> Self {
        Self::Io(format!("{}: {err}", path.display()))
    }

    /// Process exit status of docs/SCENARIO.md §1: 2 invalid, 1 I/O.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Invalid(_) => 2,
            Self::Io(_) => 1,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Invalid(m) if m.starts_with("--") => write!(f, "invalid option: {}", one_line(m)),
            Self::Invalid(m) => write!(f, "invalid scenario: {}", one_line(m)),
            Self::Io(m) => write!(f, "I/O error: {}", one_line(m)),
        }
    }
}

impl std::error::Error for Error {}

/// Joins a multi-line message into one line.
fn one_line(m: &str) -> String {
    m.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Result of this crate.
pub type Result<T> = std::result::Result<T, Error>;
