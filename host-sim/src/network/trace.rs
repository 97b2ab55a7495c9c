//! `--trace <file>`: every frame that reached the bus, one candump log line per frame,
//! `(<seconds>.<microseconds>) can0 <ID>#<DATA>`, with the simulation time (end of frame) as
//! timestamp. python-can's `LogReader`, `canplayer` and SavvyCAN read it; `docs/wire.dbc`
//! decodes its payloads.

use std::{
    fmt::Write as _,
    fs::File,
    io::{BufWriter, Write},
    path::{Path, PathBuf},
};

use embedded_can::{Frame, Id};
use hil_mock::{bus::Nanos, mock::MockFrame};

use crate::error::{Error, Result};

/// Interface name written on every line.
pub const INTERFACE: &str = "can0";

/// One candump log line (without the newline) for `frame` seen at `t_ns` on `interface`.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use hil_mock::mock::MockFrame;
/// let id = StandardId::new(0x101).unwrap();
/// let f = MockFrame::new(id, &[0xDE, 0xAD, 0x0B, 0x01]).unwrap();
/// assert_eq!(
///     host_sim::network::trace::candump_line(1_000_123_456, "can0", &f),
///     "(1.000123) can0 101#DEAD0B01"
/// );
/// ```
pub fn candump_line(t_ns: Nanos, interface: &str, frame: &MockFrame) -> String {
    let us = t_ns / 1000;
    let mut s = format!("({}.{:06}) {interface} ", us / 1_000_000, us % 1_000_000);
    // Writing into a String cannot fail.
    let _ = match frame.id() {
        Id::Standard(id) => write!(s, "{:03X}#", id.as_raw()),
        Id::Extended(id) => write!(s, "{:08X}#", id.as_raw()),
    };
    if frame.is_remote_frame() {
        s.push('R');
    } else {
        for b in frame.data() {
            let _ = write!(s, "{b:02X}");
        }
    }
    s
}

/// A candump log file being written.
pub struct TraceWriter {
    out: BufWriter<File>,
    path: PathBuf,
    error: Option<Error>,
}

impl TraceWriter {
    /// Creates (truncates) `path`, and its directory if needed.
    pub fn create(path: &Path) -> Result<Self> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::report::create_dir(dir)?;
        }
        let file = File::create(path).map_err(|e| Error::io(path, e))?;
        Ok(Self {
            out: BufWriter::with_capacity(1 << 16, file),
            path: path.to_path_buf(),
            error: None,
        })
    }

    /// Appends `frames` (end-of-frame time, frame) on `interface`; the first I/O error is kept
    /// for [`TraceWriter::finish`] and later frames are dropped.
    pub fn write(&mut self, interface: &str, frames: &[(Nanos, MockFrame)]) {
        if self.error.is_some() {
            return;
        }
        for (t, f) in frames {
            if let Err(e) = writeln!(self.out, "{}", candump_line(*t, interface, f)) {
                self.error = Some(Error::io(&self.path, e));
                return;
            }
        }
    }

    /// Flushes the file; reports the first write error.
    pub fn finish(&mut self) -> Result<()> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        self.out.flush().map_err(|e| Error::io(&self.path, e))
    }
}
