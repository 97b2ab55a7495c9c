//! `trajectory.csv` (docs/SCENARIO.md): `t`, `yd`, then per agent `y{i}`, `x{i}_{j}`, `e{i}_{j}`,
//! `u{i}_{l}`, `q{i}_{l}`, `mu{i}`, `xi{i}`, `lambda{i}`, then at the end of the row every
//! agent's `qf{i}_{l}` (the actuator output after the faults, eq. (3)); every `decimate`-th
//! sample. The same columns go to `trajectory.parquet` ([`super::parquet`]) or stay in memory
//! ([`Table`]).

use std::{
    fs::File,
    io::{BufWriter, Write},
    path::{Path, PathBuf},
    sync::mpsc::{sync_channel, Receiver, SyncSender},
    thread::JoinHandle,
};

use crate::report::{
    parquet,
    plots::MAX_PLOTTED_AGENTS,
    table::{Block, Field, Layout, Table},
    temp_path, TempFile,
};
use consensus_plot::error::{Error, Result};
use consensus_sim::{
    faults::FaultSchedule,
    scenario::Setup,
    sim::{Observer, SampleView},
};

/// Largest `trajectory.csv` a run writes without `--force` \[bytes\] (2 GiB).
pub const SIZE_LIMIT: u64 = 2 << 30;

/// Estimated bytes of one row: about 20 characters per `f64` value (`t`, `yd`, `y`, `x`, `qf`)
/// and 11 per `f32` value (`e`, `u`, `q`, estimates), separators included (Example 1: 836,
/// measured 822).
pub fn row_bytes(agents: usize, n: usize, m: usize) -> u64 {
    let f64_columns = 2 + agents * (1 + n + m);
    let f32_columns = agents * (n + 2 * m + 3);
    (20 * f64_columns + 11 * f32_columns) as u64
}

/// Estimated size of `trajectory.csv` for `setup` with every `decimate`-th sample \[bytes\].
pub fn estimated_size(setup: &Setup, decimate: u64) -> u64 {
    estimated_size_of(setup, decimate, setup.agents())
}

/// As [`estimated_size`] with the columns of `columns` agents (`--agents`).
pub fn estimated_size_of(setup: &Setup, decimate: u64, columns: usize) -> u64 {
    let rows = setup.samples.div_ceil(decimate.max(1));
    rows.saturating_mul(row_bytes(columns, setup.n(), setup.m()))
}

/// The smallest `--decimate` whose estimated `trajectory.csv` is within `limit`.
pub fn decimate_to_fit(setup: &Setup, limit: u64) -> u64 {
    decimate_to_fit_of(setup, limit, setup.agents())
}

fn decimate_to_fit_of(setup: &Setup, limit: u64, columns: usize) -> u64 {
    let rows = (limit / row_bytes(columns, setup.n(), setup.m())).max(1);
    setup.samples.div_ceil(rows).max(1)
}

/// Size a large group's `trajectory.csv` is kept within when `--decimate` is not given \[bytes\].
pub const DEFAULT_LARGE_GROUP_SIZE: u64 = 100_000_000;

/// `--decimate` when not given: 1, or for more than [`MAX_PLOTTED_AGENTS`] agents the smallest
/// decimation that keeps `trajectory.csv` (with `columns` agents' columns) within
/// [`DEFAULT_LARGE_GROUP_SIZE`].
pub fn default_decimate(setup: &Setup, columns: usize) -> u64 {
    if setup.agents() <= MAX_PLOTTED_AGENTS {
        return 1;
    }
    decimate_to_fit_of(setup, DEFAULT_LARGE_GROUP_SIZE, columns)
}

/// `Err` (an invalid `--decimate`, naming the one that fits) when `trajectory.csv` would exceed
/// [`SIZE_LIMIT`].
pub fn check_size(setup: &Setup, decimate: u64) -> Result<()> {
    check_size_of(setup, decimate, setup.agents())
}

/// As [`check_size`] with the columns of `columns` agents (`--agents`).
pub fn check_size_of(setup: &Setup, decimate: u64, columns: usize) -> Result<()> {
    let size = estimated_size_of(setup, decimate, columns);
    if size <= SIZE_LIMIT {
        return Ok(());
    }
    let fit = decimate_to_fit_of(setup, SIZE_LIMIT, columns);
    Err(Error::invalid(
        "--decimate",
        format!(
            "trajectory.csv would take about {} ({} samples, every {decimate}), above the limit \
             of {}: use --decimate {fit} (about {}), or --force to write it anyway",
            human_bytes(size),
            setup.samples,
            human_bytes(SIZE_LIMIT),
            human_bytes(estimated_size_of(setup, fit, columns)),
        ),
    ))
}

/// `1.5 GB`-style size (decimal prefixes, 2 significant decimals).
pub fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 6] = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < UNITS.len() {
        v /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.2} {}", UNITS[u])
    }
}

/// `--agents 1,5,10-20`: the 1-based agents (single numbers and inclusive ranges) whose columns
/// `trajectory.csv` gets, as sorted, distinct 0-based indices.
pub fn parse_agents(spec: &str, agents: usize) -> Result<Vec<usize>> {
    let bad = |why: String| Error::invalid("--agents", why);
    let number = |s: &str| -> Result<usize> {
        let k: usize = s
            .trim()
            .parse()
            .map_err(|_| bad(format!("`{}` is not an agent number", s.trim())))?;
        if k < 1 || k > agents {
            return Err(bad(format!(
                "agent {k} out of range 1..={agents} (agents are 1-based)"
            )));
        }
        Ok(k - 1)
    };
    let mut out = Vec::new();
    for part in spec.split(',') {
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (number(a)?, number(b)?);
                if a > b {
                    return Err(bad(format!("range {}-{} runs backwards", a + 1, b + 1)));
                }
                out.extend(a..=b);
            }
            None => out.push(number(part)?),
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// Appends the shortest text that reads back to `v`, exactly as `ryu` writes it (`1e16`,
/// `3.0399042e-10`, `0.0`, `NaN`, `inf`): `zmij` writes the same digits and a `+` in a positive
/// exponent, which is dropped.
#[inline]
pub fn number<F: zmij::Float>(out: &mut Vec<u8>, buf: &mut zmij::Buffer, v: F) {
    let s = buf.format(v).as_bytes();
    match s.iter().position(|&b| b == b'+') {
        Some(p) => {
            out.extend_from_slice(&s[..p]);
            out.extend_from_slice(&s[p + 1..]);
        }
        None => out.extend_from_slice(s),
    }
}

/// Values handed to the writer thread at a time (bounds the memory in flight).
const BLOCK_VALUES: usize = 16_384;

/// Blocks queued for the writer thread at most.
const QUEUE: usize = 4;

/// File format of the trajectory (`--format`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Format {
    /// `trajectory.csv`, `results.csv`.
    #[default]
    Csv,
    /// `trajectory.parquet`, `results.parquet`: the same columns and values.
    Parquet,
}

impl Format {
    /// `csv` or `parquet`; any other name is an invalid `--format`.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "csv" => Ok(Self::Csv),
            "parquet" => Ok(Self::Parquet),
            other => Err(Error::invalid(
                "--format",
                format!("`{other}`: expected csv or parquet"),
            )),
        }
    }

    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::Parquet => "parquet",
        }
    }
}

/// Where the rows go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sink {
    /// A file of this format.
    File(Format, PathBuf),
    /// A [`Table`] in memory, returned by [`TrajectoryObserver::finish`].
    Table,
}

/// The sample times `t_k = k h` with `h` read as the decimal it is written as (its shortest
/// text), so `t_9982 = 9.982` where the product `9982.0 * 0.001` is `9.982000000000001`.
#[derive(Debug, Clone, Copy)]
pub struct SampleClock {
    /// `h = digits · 10^-scale`.
    digits: u64,
    scale: i32,
}

/// `10^k` for `k ≤ 22`, every one exact in `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

impl SampleClock {
    /// The clock of sample period `h` (finite, > 0).
    pub fn new(h: f64) -> Self {
        let text = zmij::Buffer::new().format(h).to_string();
        let (mantissa, exp) = match text.split_once(['e', 'E']) {
            Some((m, e)) => (m, e.trim_start_matches('+').parse::<i32>().unwrap_or(0)),
            None => (text.as_str(), 0),
        };
        let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
        let frac = frac.trim_end_matches('0');
        let digits = format!("{int}{frac}").parse::<u64>().unwrap_or(0);
        let scale = i32::try_from(frac.len()).unwrap_or(0) - exp;
        Self { digits, scale }
    }

    /// `t_k`: the double nearest to the exact decimal product `k · h`.
    pub fn at(&self, k: u64) -> f64 {
        let product = u128::from(k) * u128::from(self.digits);
        let exact_int = product < (1 << 53);
        match usize::try_from(self.scale) {
            Ok(s) if exact_int && s < POW10.len() => product as f64 / POW10[s],
            _ => format!("{product}e{}", -self.scale)
                .parse()
                .unwrap_or(f64::NAN),
        }
    }
}

/// Streams rows to a temporary file ([`TrajectoryObserver::finish`] renames it into place) or
/// into a [`Table`].
///
/// The loop only copies each kept row's values; a writer thread formats them (by hand, a
/// number never needs CSV quoting, with `zmij`: the same text the `csv` crate wrote with `ryu`
/// before, see [`number`]) and writes the file, so the text costs no time of the loop when a
/// second core is free.
pub struct TrajectoryObserver {
    block: Block,
    rows: usize,
    rows_per_block: usize,
    tx: Option<SyncSender<Block>>,
    writer: Option<JoinHandle<Written>>,
    decimate: u64,
    agents: Vec<usize>,
    clock: SampleClock,
    faults: FaultSchedule,
    /// The temporary file and where it goes (`None`: a table).
    file: Option<(TempFile, PathBuf)>,
}

/// The column names of the trajectory of `agents` (0-based) with `n` states and `m` actuators.
pub fn header(agents: &[usize], n: usize, m: usize) -> Vec<String> {
    let layout = Layout::new(agents.len(), n, m);
    layout
        .columns(agents)
        .into_iter()
        .map(|(name, _)| name)
        .collect()
}

/// What the writer thread hands back: a table when the sink is [`Sink::Table`].
type Written = std::io::Result<Option<Table>>;

impl TrajectoryObserver {
    /// Opens `path` as CSV (via a temporary name) and writes the header: every agent's
    /// columns; times of sample period `h`.
    pub fn create(
        path: &Path,
        agents: usize,
        n: usize,
        m: usize,
        decimate: u64,
        h: f64,
    ) -> Result<Self> {
        Self::create_for(
            Sink::File(Format::Csv, path.to_path_buf()),
            (0..agents).collect(),
            (n, m),
            decimate,
            h,
        )
    }

    /// Rows of the columns of `agents` only (0-based, ascending) of a loop of `(n, m)` to
    /// `sink`.
    pub fn create_for(
        sink: Sink,
        agents: Vec<usize>,
        (n, m): (usize, usize),
        decimate: u64,
        h: f64,
    ) -> Result<Self> {
        let total = agents.iter().max().map_or(0, |a| a + 1);
        let layout = Layout::new(agents.len(), n, m);
        let names = header(&agents, n, m);
        let (tx, rx) = sync_channel(QUEUE);
        let spawn = |what: &str, f: Box<dyn FnOnce() -> Written + Send>| {
            std::thread::Builder::new()
                .name(what.into())
                .spawn(f)
                .map_err(|e| Error::Io(format!("{what}: {e}")))
        };
        let (writer, file) = match sink {
            Sink::File(format, path) => {
                let tmp = TempFile::new(temp_path(&path));
                let file = File::create(tmp.path()).map_err(|e| Error::io(tmp.path(), e))?;
                let writer = match format {
                    Format::Csv => {
                        let mut out = BufWriter::with_capacity(1 << 16, file);
                        writeln!(out, "{}", names.join(","))
                            .map_err(|e| Error::io(tmp.path(), e))?;
                        spawn(
                            "trajectory.csv",
                            Box::new(move || write_rows(out, &rx, layout).map(|()| None)),
                        )?
                    }
                    Format::Parquet => spawn(
                        "trajectory.parquet",
                        Box::new(move || {
                            parquet::write_trajectory(file, &names, layout, &rx).map(|()| None)
                        }),
                    )?,
                };
                (writer, Some((tmp, path)))
            }
            Sink::Table => (
                spawn(
                    "trajectory table",
                    Box::new(move || Ok(Some(Table::from_blocks(names, layout, &rx)))),
                )?,
                None,
            ),
        };
        let per_row = layout.wide_row() + layout.narrow_row();
        Ok(Self {
            block: Block::default(),
            rows: 0,
            rows_per_block: (BLOCK_VALUES / per_row).max(1),
            tx: Some(tx),
            writer: Some(writer),
            decimate: decimate.max(1),
            agents,
            clock: SampleClock::new(h),
            faults: FaultSchedule::healthy(total, m),
            file,
        })
    }

    /// The `qf` columns through `faults` (without it, `qf = q`).
    pub fn with_faults(self, faults: FaultSchedule) -> Self {
        Self { faults, ..self }
    }

    /// Hands the rows kept so far to the writer; its error if it stopped.
    fn hand_over(&mut self) -> Result<()> {
        self.rows = 0;
        let block = std::mem::take(&mut self.block);
        let sent = self.tx.as_ref().is_some_and(|tx| tx.send(block).is_ok());
        if sent {
            Ok(())
        } else {
            self.join().map(drop)
        }
    }

    /// Waits for the writer: the file is complete and flushed when it returns `Ok`.
    fn join(&mut self) -> Result<Option<Table>> {
        self.tx = None;
        let what = || {
            self.file.as_ref().map_or_else(
                || "trajectory table".into(),
                |(t, _)| t.path().display().to_string(),
            )
        };
        match self.writer.take().map(JoinHandle::join) {
            Some(Ok(Ok(table))) => Ok(table),
            None => Ok(None),
            Some(Ok(Err(e))) => Err(Error::Io(format!("{}: {e}", what()))),
            Some(Err(_)) => Err(Error::Io(format!("{}: the writer thread stopped", what()))),
        }
    }

    /// Writes the last rows, flushes and renames the file into place; the table of
    /// [`Sink::Table`].
    pub fn finish(mut self) -> Result<Option<Table>> {
        if self.rows > 0 {
            self.hand_over()?;
        }
        let table = self.join()?;
        if let Some((tmp, path)) = self.file.take() {
            tmp.persist(&path)?;
        }
        Ok(table)
    }
}

/// Longest number text kept for reuse (`-1.2345678901234567e-308` has 24 characters).
const TEXT: usize = 32;

/// The writer's formatter with memory: a value equal bit for bit to the one above it in its
/// column (a held quantizer level) or to the field before it (identical actuators) is copied,
/// not formatted again.
struct Texts {
    fmt: zmij::Buffer,
    /// Per column: the last value's bits, its text length (0: none) and text.
    above: Vec<(u64, usize, [u8; TEXT])>,
    col: usize,
    /// The field before: its bits, whether it is an `f32`, where its text starts in the line.
    before: (u64, bool, usize),
}

impl Texts {
    fn new(columns: usize) -> Self {
        Self {
            fmt: zmij::Buffer::new(),
            above: vec![(0, 0, [0; TEXT]); columns],
            col: 0,
            before: (0, false, usize::MAX),
        }
    }

    /// Starts a row.
    fn row(&mut self) {
        self.col = 0;
        self.before.2 = usize::MAX;
    }

    /// One number and its separator; `bits` and `narrow` tell values apart exactly.
    #[inline]
    fn field<F: zmij::Float>(&mut self, line: &mut Vec<u8>, v: F, bits: u64, narrow: bool) {
        let start = line.len();
        if self.col == self.above.len() {
            self.above.push((0, 0, [0; TEXT]));
        }
        let (was, len, text) = &mut self.above[self.col];
        if *len > 0 && *was == bits {
            line.extend_from_slice(&text[..*len]);
        } else {
            let (b, n, from) = self.before;
            if from != usize::MAX && b == bits && n == narrow {
                line.extend_from_within(from..start - 1);
            } else {
                number(line, &mut self.fmt, v);
            }
            let new = &line[start..];
            *was = bits;
            *len = if new.len() <= TEXT { new.len() } else { 0 };
            text[..*len].copy_from_slice(&new[..*len]);
        }
        self.before = (bits, narrow, start);
        line.push(b',');
        self.col += 1;
    }
}

/// The writer thread: formats every row of every block and writes it.
fn write_rows(
    mut out: BufWriter<File>,
    rx: &Receiver<Block>,
    layout: Layout,
) -> std::io::Result<()> {
    let mut line = Vec::with_capacity(1 << 12);
    let mut texts = Texts::new(layout.wide_row() + layout.narrow_row());
    let fields = layout.fields();
    for block in rx {
        for (w, q) in layout.rows(&block) {
            line.clear();
            texts.row();
            for f in &fields {
                match *f {
                    Field::Wide(i) => {
                        let v = w[i];
                        texts.field(&mut line, v, v.to_bits(), false);
                    }
                    Field::Narrow(i) => {
                        let v = q[i];
                        texts.field(&mut line, v, u64::from(v.to_bits()), true);
                    }
                }
            }
            if let Some(last) = line.last_mut() {
                *last = b'\n';
            }
            out.write_all(&line)?;
        }
    }
    out.flush()
}

impl<const N: usize, const M: usize> Observer<N, M> for TrajectoryObserver {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        if !s.k.is_multiple_of(self.decimate) {
            return Ok(());
        }
        let b = &mut self.block;
        b.wide.extend([self.clock.at(s.k), s.yd]);
        for &i in &self.agents {
            let (x, o) = (&s.x[i], &s.out[i]);
            b.wide.push(x[0]);
            b.wide.extend_from_slice(x);
            b.narrow.extend_from_slice(&o.e);
            b.narrow.extend_from_slice(&o.u);
            b.narrow.extend_from_slice(&o.q);
            let e = &o.estimates;
            b.narrow.extend([e.mu, e.xi, e.lambda]);
        }
        for &i in &self.agents {
            let q = &s.out[i].q;
            b.wide
                .extend((0..M).map(|l| self.faults.apply(i, l, s.t, f64::from(q[l]))));
        }
        self.rows += 1;
        if self.rows == self.rows_per_block {
            self.hand_over()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod cleanup_tests {
    use super::*;

    fn same_as_ryu<F: zmij::Float + ryu::Float + Copy + std::fmt::Debug>(v: F) {
        let mut out = Vec::new();
        number(&mut out, &mut zmij::Buffer::new(), v);
        assert_eq!(out, ryu::Buffer::new().format(v).as_bytes(), "{v:?}");
    }

    /// `number` against `ryu` (what trajectory.csv was written with) on special values, both
    /// notations and their boundaries, and a seeded sweep over bit patterns.
    #[test]
    fn numbers_read_as_ryu_writes_them() {
        for v in [
            0.0,
            -0.0,
            1.0,
            -2.5,
            1e15,
            1e16,
            1e-5,
            1e-6,
            1e300,
            5e-324,
            f64::MAX,
        ] {
            same_as_ryu(v);
        }
        for v in [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.1 + 0.2,
            123456789.0,
        ] {
            same_as_ryu(v);
        }
        let mut bits = 0x9E37_79B9_7F4A_7C15_u64;
        for _ in 0..200_000 {
            bits ^= bits << 13;
            bits ^= bits >> 7;
            bits ^= bits << 17;
            same_as_ryu(f64::from_bits(bits));
        }
        for v in [
            0.0,
            -0.0,
            1.0,
            1e7,
            1e15,
            1e16,
            3.0399042e-10,
            3.5456342e-6,
            f32::MAX,
        ] {
            same_as_ryu(v);
        }
        for v in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-45,
            16777216.0,
        ] {
            same_as_ryu(v);
        }
        for b in (0..u32::MAX).step_by(4099) {
            same_as_ryu(f32::from_bits(b));
        }
    }

    /// Reused texts equal fresh ones: repeats above and before, signed zeros, NaN, and an
    /// `f64` and an `f32` with the same bits.
    #[test]
    fn copied_texts_equal_formatted_ones() {
        let rows: [[f64; 4]; 4] = [
            [0.0, 0.0, 1.5, f64::NAN],
            [-0.0, 0.0, 1.5, f64::NAN],
            [f64::from_bits(0x3f80_0000), 1.0, 1.0, 2.0],
            [f64::from_bits(0x3f80_0000), 1.0, 1.0, 1e300],
        ];
        let mut texts = Texts::new(0);
        let (mut line, mut plain) = (Vec::new(), Vec::new());
        let mut fmt = zmij::Buffer::new();
        for r in rows {
            line.clear();
            plain.clear();
            texts.row();
            texts.field(&mut line, r[0], r[0].to_bits(), false);
            let f = r[1] as f32;
            texts.field(&mut line, f, u64::from(f.to_bits()), true);
            texts.field(&mut line, r[2], r[2].to_bits(), false);
            texts.field(&mut line, r[3], r[3].to_bits(), false);
            for (i, v) in r.iter().enumerate() {
                if i == 1 {
                    number(&mut plain, &mut fmt, *v as f32);
                } else {
                    number(&mut plain, &mut fmt, *v);
                }
                plain.push(b',');
            }
            assert_eq!(
                String::from_utf8_lossy(&line),
                String::from_utf8_lossy(&plain)
            );
        }
    }

    /// `t_k` is the double nearest to the decimal `k · h` (the slow path, a parsed decimal,
    /// against the fast one, an exact division), and equals the product where that is exact.
    #[test]
    fn sample_times_are_the_nearest_double_to_k_times_h() {
        assert_eq!(SampleClock::new(1e-3).at(9982), 9.982);
        assert_eq!(SampleClock::new(0.1).at(3), 0.3);
        assert_eq!(SampleClock::new(2e-4).at(12_345), 2.469);
        assert_eq!(SampleClock::new(0.5).at(7), 3.5);
        assert_eq!(SampleClock::new(2.0).at(u64::MAX), 2.0 * u64::MAX as f64);
        for h in [1e-3, 2e-4, 2.5e-4, 1e-5, 0.01, 0.0123, 1.0 / 3.0, 7.0, 1e-7] {
            let c = SampleClock::new(h);
            let digits: u128 = c.digits.into();
            for k in (0..2_000_000_u64).step_by(997).chain([1, 2, 3, 10_000]) {
                let slow: f64 = format!("{}e{}", u128::from(k) * digits, -c.scale)
                    .parse()
                    .unwrap_or(f64::NAN);
                assert_eq!(c.at(k).to_bits(), slow.to_bits(), "h = {h}, k = {k}");
            }
            assert_eq!(
                format!("{}e{}", c.digits, -c.scale).parse::<f64>().ok(),
                Some(h)
            );
        }
    }

    #[test]
    fn an_unfinished_csv_leaves_no_file_behind() -> Result<()> {
        let dir = std::env::temp_dir().join(format!("host-sim-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let path = dir.join("trajectory.csv");
        let obs = TrajectoryObserver::create(&path, 1, 2, 2, 1, 1e-3)?;
        let tmp = obs
            .file
            .as_ref()
            .map(|(t, _)| t.path().to_path_buf())
            .unwrap_or_default();
        assert!(tmp.exists());
        drop(obs); // the run was cut short
        assert!(!tmp.exists() && !path.exists());
        let obs = TrajectoryObserver::create(&path, 1, 2, 2, 1, 1e-3)?;
        obs.finish()?;
        assert!(path.exists() && !tmp.exists());
        std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))
    }
}
