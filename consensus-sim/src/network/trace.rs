//! Traces in candump log format, one line per frame, `(<seconds>.<microseconds>) <interface>
//! <ID>#<DATA>`, simulation time as timestamp; python-can's `LogReader`, `canplayer` and
//! SavvyCAN read them, `docs/wire.dbc` decodes their payloads.
//!
//! * `--trace <file>` (`kind = "can"`, `"pil"`): every frame that reached the bus, on `can0`,
//!   at its end of frame.
//! * `--link-trace <file>` (`kind = "pil"`): everything on each node's serial link, on
//!   `node<i>`: the start-up configuration, the bus frames delivered to the node, its tick and
//!   report records (as CAN FD lines `<ID>##0<DATA>` under the ids the DBC gives them), its
//!   own frame, the statistics; at the sample time the host sent or read them.

use std::{
    fmt::Write as _,
    fs::File,
    io::{BufWriter, Write},
    path::{Path, PathBuf},
};

use embedded_can::{Frame, Id};
use hil_mock::{bus::Nanos, mock::MockFrame};

use crate::network::spec::NetworkKind;
use consensus_plot::error::{Error, Result};

/// Where a run writes its traces (`--trace`, `--link-trace`); `None`: not written.
#[derive(Debug, Clone, Copy, Default)]
pub struct Traces<'a> {
    /// Every frame on the bus.
    pub bus: Option<&'a Path>,
    /// Everything on each node's serial link (`kind = "pil"`).
    pub link: Option<&'a Path>,
}

impl Traces<'_> {
    /// The one check of which traces a network kind writes: the bus trace needs a bus (every
    /// kind but `ideal`), the serial-link trace serial links (`pil` only); else an error naming
    /// the option.
    pub fn check(&self, kind: NetworkKind) -> Result<()> {
        if kind == NetworkKind::Ideal && self.bus.is_some() {
            return Err(Error::invalid(
                "--trace",
                "needs a bus: network.kind = \"can\" or \"pil\"",
            ));
        }
        if kind != NetworkKind::Pil && self.link.is_some() {
            return Err(Error::invalid(
                "--link-trace",
                "needs serial links: network.kind = \"pil\"",
            ));
        }
        Ok(())
    }
}

/// Interface name written on every line of the bus trace.
pub const INTERFACE: &str = "can0";

/// One candump log line (without the newline) for `frame` seen at `t_ns` on `interface`.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use hil_mock::mock::MockFrame;
/// let id = StandardId::new(0x101).unwrap();
/// let f = MockFrame::new(id, &[0xDE, 0xAD, 0x0B, 0x01]).unwrap();
/// assert_eq!(
///     consensus_sim::network::trace::candump_line(1_000_123_456, "can0", &f),
///     "(1.000123) can0 101#DEAD0B01"
/// );
/// ```
pub fn candump_line<F: Frame>(t_ns: Nanos, interface: &str, frame: &F) -> String {
    let mut s = stamp(t_ns, interface);
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

/// One candump log line for a payload of `data.len()` bytes (a CAN FD length) under the
/// 29-bit identifier `id`, seen at `t_ns` on `interface`: how a link record is traced.
///
/// ```
/// assert_eq!(
///     consensus_sim::network::trace::candump_fd_line(2_000_000, "node1", 0x10080, &[0; 8]),
///     "(0.002000) node1 00010080##00000000000000000"
/// );
/// ```
pub fn candump_fd_line(t_ns: Nanos, interface: &str, id: u32, data: &[u8]) -> String {
    let mut s = stamp(t_ns, interface);
    let _ = write!(s, "{id:08X}##0");
    for b in data {
        let _ = write!(s, "{b:02X}");
    }
    s
}

/// One candump log line of a CAN FD frame (`<ID>##<flags><DATA hex>`, flags `1` with
/// bit-rate switching, else `0`), seen at `t_ns` on `interface`.
///
/// ```
/// use embedded_can::{Frame, StandardId};
/// use hil_mock::mock::MockFrame;
/// let f = MockFrame::new(StandardId::new(0x201).unwrap(), &[1, 2]).unwrap();
/// assert_eq!(
///     consensus_sim::network::trace::candump_fd_frame_line(3_000, "vcan0", &f, true),
///     "(0.000003) vcan0 201##10102"
/// );
/// ```
pub fn candump_fd_frame_line<F: Frame>(
    t_ns: Nanos,
    interface: &str,
    frame: &F,
    brs: bool,
) -> String {
    let mut s = stamp(t_ns, interface);
    let _ = match frame.id() {
        Id::Standard(id) => write!(s, "{:03X}##{}", id.as_raw(), u8::from(brs)),
        Id::Extended(id) => write!(s, "{:08X}##{}", id.as_raw(), u8::from(brs)),
    };
    for b in frame.data() {
        let _ = write!(s, "{b:02X}");
    }
    s
}

fn stamp(t_ns: Nanos, interface: &str) -> String {
    let us = t_ns / 1000;
    format!("({}.{:06}) {interface} ", us / 1_000_000, us % 1_000_000)
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
            consensus_plot::files::create_dir(dir)?;
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
        self.write_lines(frames.iter().map(|(t, f)| candump_line(*t, interface, f)));
    }

    /// Appends ready-made `lines` (see [`candump_line`], [`candump_fd_line`]); the first I/O
    /// error is kept for [`TraceWriter::finish`].
    pub fn write_lines(&mut self, lines: impl IntoIterator<Item = String>) {
        if self.error.is_some() {
            return;
        }
        for l in lines {
            if let Err(e) = writeln!(self.out, "{l}") {
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
