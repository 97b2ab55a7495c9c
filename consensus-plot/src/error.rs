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
    /// Several independent problems of one scenario, each reported on its own line.
    Several(Vec<Error>),
    /// Stopped at the caller's request (`host_sim::run::Watch::stop`) before the end.
    Interrupted,
    /// A bench on a real bus (`network.kind = "socketcan"`) failed: a node never came, was lost
    /// during the run, or two nodes share one identity.
    Bench(String),
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

    /// Process exit status of docs/SCENARIO.md §1: 2 invalid, 1 I/O, 3 a bench's node failed
    /// (130 interrupted, as a shell reports SIGINT).
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Invalid(_) => 2,
            Self::Io(_) => 1,
            Self::Bench(_) => 3,
            Self::Interrupted => 130,
            Self::Several(all) => all.iter().map(Self::exit_code).max().unwrap_or(2),
        }
    }

    /// The message without its kind; several problems joined by `; `.
    pub fn message(&self) -> String {
        match self {
            Self::Invalid(m) | Self::Io(m) | Self::Bench(m) => m.clone(),
            Self::Interrupted => "interrupted".into(),
            Self::Several(all) => all.iter().map(Self::message).collect::<Vec<_>>().join("; "),
        }
    }

    /// The single problems, in the order found.
    pub fn problems(&self) -> Vec<&Self> {
        match self {
            Self::Several(all) => all.iter().flat_map(Self::problems).collect(),
            e => vec![e],
        }
    }
}

/// Collects the independent problems of one validation, so that one run reports them all.
#[derive(Debug, Default)]
pub struct Problems(Vec<Error>);

impl Problems {
    /// The value of `r`, or `None` with its error kept (once per key).
    pub fn take<T>(&mut self, r: Result<T>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(e) => {
                for p in e.problems() {
                    self.push(p.clone());
                }
                None
            }
        }
    }

    /// Keeps `e` unless a problem of the same key is already kept.
    pub fn push(&mut self, e: Error) {
        let key = |e: &Error| e.message().split(':').next().map(str::to_owned);
        if !self.0.iter().any(|k| key(k) == key(&e)) {
            self.0.push(e);
        }
    }

    /// No problem so far.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `Ok(v)` without problems, else the one problem or all of them.
    pub fn finish<T>(self, v: T) -> Result<T> {
        self.into_error().map_or(Ok(v), Err)
    }

    /// The one problem or all of them; `None` without problems.
    pub fn into_error(mut self) -> Option<Error> {
        match self.0.len() {
            0 => None,
            1 => Some(self.0.remove(0)),
            _ => Some(Error::Several(self.0)),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            // An option (`--out`) or a positional argument (`<interface>`).
            Self::Invalid(m) if m.starts_with("--") || m.starts_with('<') => {
                write!(f, "invalid option: {}", one_line(m))
            }
            Self::Invalid(m) => write!(f, "invalid scenario: {}", one_line(m)),
            Self::Io(m) => write!(f, "I/O error: {}", one_line(m)),
            Self::Bench(m) => write!(f, "bench: {}", one_line(m)),
            Self::Interrupted => f.write_str("interrupted"),
            Self::Several(all) => {
                for (i, e) in all.iter().enumerate() {
                    if i > 0 {
                        f.write_str("\n")?;
                    }
                    write!(f, "{e}")?;
                }
                Ok(())
            }
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
