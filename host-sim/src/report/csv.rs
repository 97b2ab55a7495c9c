//! `trajectory.csv` (docs/SCENARIO.md): `t`, `yd`, then per agent `y{i}`, `x{i}_{j}`, `e{i}_{j}`,
//! `u{i}_{l}`, `q{i}_{l}`, `mu{i}`, `xi{i}`, `lambda{i}`; every `decimate`-th sample.

use std::{
    fs::File,
    io::BufWriter,
    path::{Path, PathBuf},
};

use crate::{
    error::{Error, Result},
    report::{temp_path, TempFile},
    scenario::Setup,
    sim::{Observer, SampleView},
};

/// Largest `trajectory.csv` a run writes without `--force` [bytes] (2 GiB).
pub const SIZE_LIMIT: u64 = 2 << 30;

/// Estimated bytes of one row: about 20 characters per `f64` value (`t`, `yd`, `y`, `x`) and 11
/// per `f32` value (`e`, `u`, `q`, estimates), separators included (Example 1: 676, measured 674).
pub fn row_bytes(agents: usize, n: usize, m: usize) -> u64 {
    let f64_columns = 2 + agents * (1 + n);
    let f32_columns = agents * (n + 2 * m + 3);
    (20 * f64_columns + 11 * f32_columns) as u64
}

/// Estimated size of `trajectory.csv` for `setup` with every `decimate`-th sample [bytes].
pub fn estimated_size(setup: &Setup, decimate: u64) -> u64 {
    let rows = setup.samples.div_ceil(decimate.max(1));
    rows.saturating_mul(row_bytes(setup.agents(), setup.n(), setup.m()))
}

/// The smallest `--decimate` whose estimated `trajectory.csv` is within `limit`.
pub fn decimate_to_fit(setup: &Setup, limit: u64) -> u64 {
    let rows = (limit / row_bytes(setup.agents(), setup.n(), setup.m())).max(1);
    setup.samples.div_ceil(rows).max(1)
}

/// `Err` (an invalid `--decimate`, naming the one that fits) when `trajectory.csv` would exceed
/// [`SIZE_LIMIT`].
pub fn check_size(setup: &Setup, decimate: u64) -> Result<()> {
    let size = estimated_size(setup, decimate);
    if size <= SIZE_LIMIT {
        return Ok(());
    }
    let fit = decimate_to_fit(setup, SIZE_LIMIT);
    Err(Error::invalid(
        "--decimate",
        format!(
            "trajectory.csv would take about {} ({} samples, every {decimate}), above the limit \
             of {}: use --decimate {fit} (about {}), or --force to write it anyway",
            human_bytes(size),
            setup.samples,
            human_bytes(SIZE_LIMIT),
            human_bytes(estimated_size(setup, fit)),
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

/// Streams rows to a temporary file; [`CsvObserver::finish`] renames it into place.
pub struct CsvObserver {
    wtr: csv::Writer<BufWriter<File>>,
    decimate: u64,
    tmp: TempFile,
    path: PathBuf,
    fmt: ryu::Buffer,
}

impl CsvObserver {
    /// Opens `path` (via a temporary name) and writes the header.
    pub fn create(path: &Path, agents: usize, n: usize, m: usize, decimate: u64) -> Result<Self> {
        let tmp = TempFile::new(temp_path(path));
        let file = File::create(tmp.path()).map_err(|e| Error::io(tmp.path(), e))?;
        let mut wtr =
            csv::WriterBuilder::new().from_writer(BufWriter::with_capacity(1 << 16, file));
        let mut header = vec!["t".to_string(), "yd".to_string()];
        for i in 1..=agents {
            header.push(format!("y{i}"));
            header.extend((1..=n).map(|j| format!("x{i}_{j}")));
            header.extend((1..=n).map(|j| format!("e{i}_{j}")));
            header.extend((1..=m).map(|l| format!("u{i}_{l}")));
            header.extend((1..=m).map(|l| format!("q{i}_{l}")));
            header.extend([format!("mu{i}"), format!("xi{i}"), format!("lambda{i}")]);
        }
        wtr.write_record(&header)
            .map_err(|e| Error::io(tmp.path(), e))?;
        Ok(Self {
            wtr,
            decimate: decimate.max(1),
            tmp,
            path: path.to_path_buf(),
            fmt: ryu::Buffer::new(),
        })
    }

    /// Flushes and renames the file into place.
    pub fn finish(mut self) -> Result<()> {
        self.wtr
            .flush()
            .map_err(|e| Error::io(self.tmp.path(), e))?;
        drop(self.wtr);
        self.tmp.persist(&self.path)
    }

    fn f64(&mut self, v: f64) -> csv::Result<()> {
        self.wtr.write_field(self.fmt.format(v))
    }

    fn f32(&mut self, v: f32) -> csv::Result<()> {
        self.wtr.write_field(self.fmt.format(v))
    }

    fn row<const N: usize, const M: usize>(&mut self, s: &SampleView<'_, N, M>) -> csv::Result<()> {
        self.f64(s.t)?;
        self.f64(s.yd)?;
        for (x, o) in s.x.iter().zip(s.out) {
            self.f64(x[0])?;
            for &v in x {
                self.f64(v)?;
            }
            for &v in &o.e {
                self.f32(v)?;
            }
            for &v in o.u.iter().chain(&o.q) {
                self.f32(v)?;
            }
            self.f32(o.estimates.mu)?;
            self.f32(o.estimates.xi)?;
            self.f32(o.estimates.lambda)?;
        }
        self.wtr.write_record(None::<&[u8]>)
    }
}

impl<const N: usize, const M: usize> Observer<N, M> for CsvObserver {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        if !s.k.is_multiple_of(self.decimate) {
            return Ok(());
        }
        self.row(s).map_err(|e| Error::io(self.tmp.path(), e))
    }
}

#[cfg(test)]
mod cleanup_tests {
    use super::*;

    #[test]
    fn an_unfinished_csv_leaves_no_file_behind() -> Result<()> {
        let dir = std::env::temp_dir().join(format!("host-sim-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let path = dir.join("trajectory.csv");
        let obs = CsvObserver::create(&path, 1, 2, 2, 1)?;
        let tmp = obs.tmp.path().to_path_buf();
        assert!(tmp.exists());
        drop(obs); // the run was cut short
        assert!(!tmp.exists() && !path.exists());
        let obs = CsvObserver::create(&path, 1, 2, 2, 1)?;
        obs.finish()?;
        assert!(path.exists() && !tmp.exists());
        std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))
    }
}
