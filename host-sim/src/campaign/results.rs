//! `results.csv` and the run journal: one CSV row per run, appended to `runs.journal` as one
//! write of one whole line as each run finishes (synced to disk about once a second), and sorted
//! into `results.csv` in run order when a campaign (or shard) is complete.

use std::{
    collections::BTreeMap,
    fs::{File, OpenOptions},
    io::{Read, Seek, SeekFrom, Write},
    path::{Path, PathBuf},
    time::{Duration, Instant},
};

use crate::{
    campaign::spec::{cell, json_number, Plan, RunPoint, WINDOW_PREFIX},
    report::write_atomic,
};
use consensus_plot::error::{Error, Result};
use consensus_sim::metrics::Summary;

/// The metric columns of every row, after `run` and the axis keys.
pub const METRIC_COLUMNS: [&str; 6] = [
    "diverged",
    "divergence_time",
    "settling_time",
    "max_error_after_predefined_time",
    "max_abs_u",
    "total_u_energy",
];

/// Name of the journal in `--out`.
pub const JOURNAL: &str = "runs.journal";

/// The header of `results.csv`: `run`, axis keys, metrics, one `window.<name>` per window of
/// the base scenario, `status`, `error`, then `draw` and the sampled keys when the campaign
/// samples.
pub fn header(plan: &Plan) -> Vec<String> {
    let mut h = vec!["run".to_string()];
    h.extend(plan.axis_keys());
    h.extend(METRIC_COLUMNS.iter().map(|s| s.to_string()));
    h.extend(window_names(plan).map(|n| format!("{WINDOW_PREFIX}{n}")));
    h.extend(["status".to_string(), "error".to_string()]);
    if !plan.file.sample.is_empty() {
        h.push("draw".into());
        h.extend(plan.sample_keys());
    }
    h
}

fn window_names(plan: &Plan) -> impl Iterator<Item = &str> {
    plan.base.metrics.window.iter().map(|w| w.name.as_str())
}

fn opt(v: Option<f64>) -> String {
    v.map(json_number).unwrap_or_default()
}

/// One row (a line without its newline) for a run's outcome.
pub fn row(plan: &Plan, p: &RunPoint, outcome: &Result<Summary>) -> String {
    let mut r = vec![p.run.to_string()];
    r.extend(p.axis_values.iter().map(cell));
    match outcome {
        Ok(s) => {
            r.push(s.diverged.to_string());
            r.push(opt(s.divergence.map(|d| d.time)));
            r.push(opt(s.settling_time));
            r.push(opt(s.max_error_after_predefined_time));
            r.push(json_number(s.max_abs_u));
            r.push(json_number(s.total_u_energy));
            r.extend(window_names(plan).map(|n| opt(s.window(n))));
            r.push("ok".into());
            r.push(String::new());
        }
        Err(e) => {
            let cells = METRIC_COLUMNS.len() + window_names(plan).count();
            r.extend(std::iter::repeat_n(String::new(), cells));
            r.push("invalid".into());
            r.push(message(e));
        }
    }
    if !plan.file.sample.is_empty() {
        r.push(p.draw.to_string());
        r.extend(p.sampled.iter().map(cell));
    }
    csv_line(&r)
}

/// The reason of an invalid run, on one line.
fn message(e: &Error) -> String {
    e.message().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Fields as one CSV line (quoted where needed), without the newline.
pub fn csv_line(fields: &[String]) -> String {
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    let _ = w.write_record(fields);
    let bytes = w.into_inner().unwrap_or_default();
    let mut s = String::from_utf8_lossy(&bytes).into_owned();
    s.truncate(s.trim_end_matches('\n').len());
    s
}

/// The rows' records by run, as [`records`] reads them.
pub type Records = Vec<(u64, Option<csv::StringRecord>)>;

/// Each row's first CSV record, in run order (`None` for a row without one). One reader reads
/// them all: building a reader per row took most of a large campaign's end (0.4 s of 10,000
/// rows, on one core). Rows that do not read as one record each (an empty row, a quoted line
/// break) are read one by one, as before.
pub fn records(rows: &BTreeMap<u64, String>) -> Records {
    let mut text = String::with_capacity(rows.values().map(|l| l.len() + 1).sum());
    for line in rows.values() {
        text.push_str(line);
        text.push('\n');
    }
    let together: Option<Vec<csv::StringRecord>> = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes())
        .records()
        .collect::<std::result::Result<_, _>>()
        .ok();
    match together {
        Some(recs) if recs.len() == rows.len() && rows.values().all(|l| !l.contains('\n')) => rows
            .keys()
            .copied()
            .zip(recs.into_iter().map(Some))
            .collect(),
        _ => rows
            .iter()
            .map(|(&run, line)| {
                let mut rdr = csv::ReaderBuilder::new()
                    .has_headers(false)
                    .from_reader(line.as_bytes());
                (run, rdr.records().next().and_then(|r| r.ok()))
            })
            .collect(),
    }
}

/// The run index at the start of a row.
fn run_of(line: &str) -> Option<u64> {
    line.split(',').next()?.parse().ok()
}

/// Rows already in the journal, by run. A trailing line without its newline (the process was
/// killed while writing it) is cut off, so that it is run again.
pub fn read_journal(path: &Path) -> Result<BTreeMap<u64, String>> {
    let mut rows = BTreeMap::new();
    let mut f = match OpenOptions::new().read(true).write(true).open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(rows),
        Err(e) => return Err(Error::io(path, e)),
    };
    let mut text = String::new();
    f.read_to_string(&mut text)
        .map_err(|e| Error::io(path, e))?;
    let complete = text.rfind('\n').map_or(0, |i| i + 1);
    if complete < text.len() {
        f.set_len(complete as u64).map_err(|e| Error::io(path, e))?;
    }
    for line in text[..complete].lines() {
        let run =
            run_of(line).ok_or_else(|| Error::io(path, format!("corrupt journal line: {line}")))?;
        if rows.insert(run, line.to_string()).is_some() {
            return Err(Error::io(path, format!("run {run} twice in the journal")));
        }
    }
    Ok(rows)
}

/// Appends finished rows to the journal.
pub struct Journal {
    file: File,
    path: PathBuf,
    last_sync: Instant,
}

impl Journal {
    /// Opens (creates) the journal for appending.
    pub fn open(path: &Path) -> Result<Self> {
        let mut file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        file.seek(SeekFrom::End(0))
            .map_err(|e| Error::io(path, e))?;
        Ok(Self {
            file,
            path: path.to_path_buf(),
            last_sync: Instant::now(),
        })
    }

    /// Appends one row with a single write; syncs at most once a second.
    pub fn append(&mut self, line: &str) -> Result<()> {
        let mut buf = Vec::with_capacity(line.len() + 1);
        buf.extend_from_slice(line.as_bytes());
        buf.push(b'\n');
        self.file
            .write_all(&buf)
            .map_err(|e| Error::io(&self.path, e))?;
        if self.last_sync.elapsed() > Duration::from_secs(1) {
            self.sync()?;
        }
        Ok(())
    }

    /// Forces the rows to disk.
    pub fn sync(&mut self) -> Result<()> {
        self.last_sync = Instant::now();
        self.file.sync_data().map_err(|e| Error::io(&self.path, e))
    }
}

/// Writes `results.csv`: the header and the rows in run order.
pub fn write_results(dir: &Path, header: &[String], rows: &BTreeMap<u64, String>) -> Result<()> {
    let mut text = csv_line(header);
    text.push('\n');
    for r in rows.values() {
        text.push_str(r);
        text.push('\n');
    }
    write_atomic(&dir.join("results.csv"), text.as_bytes())
}

/// The rows of a `results.csv`, by run (the header is checked against `header`).
pub fn read_results(path: &Path, header: &[String]) -> Result<BTreeMap<u64, String>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    if lines.next() != Some(csv_line(header).as_str()) {
        return Err(Error::invalid(
            path.display(),
            "header differs from the campaign's columns",
        ));
    }
    let mut rows = BTreeMap::new();
    for line in lines {
        let run = run_of(line)
            .ok_or_else(|| Error::invalid(path.display(), format!("corrupt row: {line}")))?;
        if rows.insert(run, line.to_string()).is_some() {
            return Err(Error::invalid(path.display(), format!("run {run} twice")));
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each row alone, the way `records` must read it.
    fn one_by_one(rows: &BTreeMap<u64, String>) -> Vec<(u64, Option<Vec<String>>)> {
        rows.iter()
            .map(|(&run, line)| {
                let mut rdr = csv::ReaderBuilder::new()
                    .has_headers(false)
                    .from_reader(line.as_bytes());
                let rec = rdr.records().next().and_then(|r| r.ok());
                (run, rec.map(|r| r.iter().map(String::from).collect()))
            })
            .collect()
    }

    fn read(rows: &BTreeMap<u64, String>) -> Vec<(u64, Option<Vec<String>>)> {
        records(rows)
            .into_iter()
            .map(|(run, rec)| (run, rec.map(|r| r.iter().map(String::from).collect())))
            .collect()
    }

    #[test]
    fn records_read_together_equal_records_read_one_by_one() {
        let fields = |run: u64, extra: &str| {
            csv_line(&[run.to_string(), "0.5".into(), extra.into(), "ok".into()])
        };
        let mut rows: BTreeMap<u64, String> = (0..50)
            .map(|run| {
                (
                    run,
                    fields(
                        run,
                        if run % 7 == 0 {
                            "a, \"quoted\" field"
                        } else {
                            ""
                        },
                    ),
                )
            })
            .collect();
        // A row with fewer fields (the reader is flexible, as one per row was).
        rows.insert(50, "50,1.5".into());
        assert_eq!(read(&rows), one_by_one(&rows));
        assert!(read(&rows).iter().all(|(_, r)| r.is_some()));

        // Rows that are not one record each: read one by one, as before.
        for odd in ["", "51,\"open quote", "51,\"two\nlines\",x"] {
            let mut with = rows.clone();
            with.insert(51, odd.into());
            with.insert(52, fields(52, ""));
            assert_eq!(read(&with), one_by_one(&with), "row {odd:?}");
        }
    }
}
