//! `trajectory.csv` (docs/SCENARIO.md): `t`, `yd`, then per agent `y{i}`, `x{i}_{j}`, `e{i}_{j}`,
//! `u{i}_{l}`, `q{i}_{l}`, `mu{i}`, `xi{i}`, `lambda{i}`; every `decimate`-th sample.

use std::{
    fs::File,
    io::BufWriter,
    path::{Path, PathBuf},
};

use crate::{
    error::{Error, Result},
    report::temp_path,
    sim::{Observer, SampleView},
};

/// A temporary file that is removed unless it was renamed into place (a run cut short by an
/// I/O error leaves no stray file behind).
struct TempFile(PathBuf);

impl Drop for TempFile {
    fn drop(&mut self) {
        // After a successful rename there is nothing left to remove.
        let _ = std::fs::remove_file(&self.0);
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
        let tmp = temp_path(path);
        let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
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
        wtr.write_record(&header).map_err(|e| Error::io(&tmp, e))?;
        Ok(Self {
            wtr,
            decimate: decimate.max(1),
            tmp: TempFile(tmp),
            path: path.to_path_buf(),
            fmt: ryu::Buffer::new(),
        })
    }

    /// Flushes and renames the file into place.
    pub fn finish(mut self) -> Result<()> {
        self.wtr.flush().map_err(|e| Error::io(&self.tmp.0, e))?;
        drop(self.wtr);
        std::fs::rename(&self.tmp.0, &self.path).map_err(|e| Error::io(&self.path, e))
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
        self.row(s).map_err(|e| Error::io(&self.tmp.0, e))
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
        let tmp = obs.tmp.0.clone();
        assert!(tmp.exists());
        drop(obs); // the run was cut short
        assert!(!tmp.exists() && !path.exists());
        let obs = CsvObserver::create(&path, 1, 2, 2, 1)?;
        obs.finish()?;
        assert!(path.exists() && !tmp.exists());
        std::fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))
    }
}
