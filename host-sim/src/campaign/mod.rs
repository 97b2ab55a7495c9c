//! Campaigns (`host-sim sweep`, `host-sim merge`): many runs of one scenario over grid axes and
//! Monte Carlo draws of its keys, in parallel, resumable, split into shards for a cluster.
//!
//! Layers: [`spec`] (the campaign file and each run's scenario) → [`sample`] (seeded draws) →
//! the runs here (rayon, summaries only) → [`results`] (journal, `results.csv`) → [`plots`].

pub mod plots;
pub mod replications;
pub mod results;
pub mod sample;
pub mod spec;

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
    sync::{mpsc, Arc},
};

use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{
    report::{self, csv::Format, parquet, table::Results, write_atomic},
    run::{run, RunOptions, Watch},
};
use consensus_plot::error::{Error, Result};
use consensus_sim::{metrics::Summary, sim::SharedStageTerms};
use spec::{CampaignFile, Plan};

/// `--shard k/N`: this process runs the runs with `run mod N == k − 1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// 1-based shard.
    pub k: u64,
    /// Number of shards.
    pub n: u64,
}

impl Shard {
    /// The whole campaign.
    pub const ALL: Self = Self { k: 1, n: 1 };

    /// Parses `k/N` with `1 ≤ k ≤ N`.
    pub fn parse(s: &str) -> Result<Self> {
        let bad = || Error::invalid("--shard", format!("`{s}`: expected k/N with 1 <= k <= N"));
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (u64, u64) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Self { k, n })
    }

    /// Whether run `run` belongs to this shard.
    pub fn has(&self, run: u64) -> bool {
        run % self.n == self.k - 1
    }

    /// Runs of this shard out of `total`.
    pub fn count(&self, total: u64) -> u64 {
        (0..total).filter(|&r| self.has(r)).count() as u64
    }
}

/// The build a campaign ran on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Build {
    /// `host-sim` crate version.
    pub host_sim_version: String,
    /// `git rev-parse HEAD` when the binary was built ("unknown" outside a git checkout).
    pub git_commit: String,
    /// Where `git_commit` comes from.
    pub git_commit_source: String,
}

impl Build {
    /// This binary.
    pub fn current() -> Self {
        Self {
            host_sim_version: env!("CARGO_PKG_VERSION").into(),
            git_commit: env!("HOST_SIM_GIT_COMMIT").into(),
            git_commit_source: "git rev-parse HEAD at build time (uncommitted changes not shown)"
                .into(),
        }
    }
}

/// `campaign.json`: identical in every shard and in the merged directory.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignJson {
    /// The campaign file with every default written out.
    pub campaign: CampaignFile,
    /// The base scenario resolved (file + `set`, defaults filled).
    pub scenario: serde_json::Value,
    /// Runs in the whole campaign.
    pub runs: u64,
    /// Columns of `results.csv`.
    pub columns: Vec<String>,
    /// The build.
    pub build: Build,
}

/// `shard.json`, only in the directory of one shard of several.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardJson {
    /// Which shard.
    pub shard: Shard,
    /// Runs in this shard.
    pub runs: u64,
}

impl CampaignJson {
    fn of(plan: &Plan) -> Result<Self> {
        Ok(Self {
            campaign: plan.file.clone(),
            scenario: serde_json::to_value(&plan.base)
                .map_err(|e| Error::invalid("scenario", e))?,
            runs: plan.runs(),
            columns: results::header(plan),
            build: Build::current(),
        })
    }

    fn text(&self) -> Result<String> {
        serde_json::to_string_pretty(self)
            .map(|s| s + "\n")
            .map_err(|e| Error::Io(format!("campaign.json: {e}")))
    }
}

/// What a sweep did.
#[derive(Debug, Clone, Default)]
pub struct SweepReport {
    /// Runs in this shard.
    pub runs: u64,
    /// Runs found done in the journal (resumed).
    pub resumed: u64,
    /// Runs done now.
    pub ran: u64,
    /// Rows with `status = invalid`.
    pub invalid: u64,
    /// Rows with `diverged = true`.
    pub diverged: u64,
    /// Figures written.
    pub figures: Vec<PathBuf>,
}

/// How a sweep reports and what it writes besides `results.csv`.
#[derive(Clone, Copy, Default)]
pub struct SweepOptions<'a> {
    /// Show a progress bar (only on a terminal).
    pub progress: bool,
    /// Called with (runs done, runs in the shard) as each run finishes (and once at the start).
    pub on_run: Option<&'a (dyn Fn(u64, u64) + Sync)>,
    /// [`Format::Parquet`]: also `results.parquet` (`results.csv` stays: resuming and `merge`
    /// read it).
    pub format: Format,
    /// A stop request from another thread: once set, every run ends at its next sample, runs
    /// not started are skipped and the sweep returns [`Error::Interrupted`]; the journal keeps
    /// the runs finished before (resumable).
    pub watch: Option<&'a Arc<Watch>>,
}

/// Runs the campaign `path` (this shard of it) into `out`; resumes from `out`'s journal.
pub fn sweep(path: &Path, out: &Path, shard: Shard, progress: bool) -> Result<SweepReport> {
    let opts = SweepOptions {
        progress,
        ..SweepOptions::default()
    };
    sweep_with(path, out, shard, &opts)
}

/// [`sweep`] with the reporting and outputs of `opts`.
pub fn sweep_with(
    path: &Path,
    out: &Path,
    shard: Shard,
    opts: &SweepOptions<'_>,
) -> Result<SweepReport> {
    let plan = Plan::load(path)?;
    let meta = CampaignJson::of(&plan)?.text()?;
    report::create_dir(out)?;
    let cj = out.join("campaign.json");
    match std::fs::read_to_string(&cj) {
        Ok(old) if old != meta => {
            return Err(Error::invalid(
                "--out",
                format!(
                    "{} holds another campaign or a run of another build (campaign.json \
                     differs); use a new directory",
                    out.display()
                ),
            ))
        }
        Ok(_) => {}
        Err(_) => write_atomic(&cj, meta.as_bytes())?,
    }
    check_shard_file(out, shard, &plan)?;
    let journal_path = out.join(results::JOURNAL);
    let done = results::read_journal(&journal_path)?;
    if let Some(r) = done.keys().find(|&&r| r >= plan.runs() || !shard.has(r)) {
        return Err(Error::invalid(
            "--out",
            format!("the journal holds run {r}, which is not in this shard"),
        ));
    }
    let todo: Vec<u64> = (0..plan.runs())
        .filter(|&r| shard.has(r) && !done.contains_key(&r))
        .collect();
    let mut rep = SweepReport {
        runs: shard.count(plan.runs()),
        resumed: done.len() as u64,
        ran: todo.len() as u64,
        ..SweepReport::default()
    };
    let pb = progress_bar(rep.runs, rep.resumed, opts.progress);
    let report = |done| {
        if let Some(f) = opts.on_run {
            f(done, rep.runs);
        }
    };
    report(rep.resumed);
    let mut journal = results::Journal::open(&journal_path)?;
    let (tx, rx) = mpsc::channel::<Result<String>>();
    let writer = std::thread::scope(|s| {
        let handle = s.spawn(|| -> Result<()> {
            let mut done = rep.resumed;
            for line in rx {
                journal.append(&line?)?;
                pb.inc(1);
                done += 1;
                report(done);
            }
            journal.sync()
        });
        let terms = Arc::new(SharedStageTerms::default());
        todo.par_iter().for_each_with(tx, |tx, &r| {
            let _ = tx.send(run_row(&plan, out, r, opts.watch, &terms));
        });
        handle
            .join()
            .unwrap_or_else(|_| Err(Error::Io("journal writer stopped".into())))
    });
    pb.finish_and_clear();
    writer?;
    let rows = results::read_journal(&journal_path)?;
    let header = results::header(&plan);
    results::write_results(out, &header, &rows)?;
    write_other(opts.format, out, &header, &rows)?;
    let recs = results::records(&rows);
    count(&header, &recs, &mut rep);
    if shard == Shard::ALL {
        let (axes, draws) = (plan.file.axis.len(), plan.file.draws);
        replications::write_summary(out, axes, draws, &header, &recs)?;
        rep.figures = plots::draw(&plan.file, &plan.base, &header, &rows, &recs, out)?;
    }
    Ok(rep)
}

/// One run to its row; per-run outputs when the campaign asks for them. An interrupted run
/// (`watch`) is no row.
fn run_row(
    plan: &Plan,
    out: &Path,
    r: u64,
    watch: Option<&Arc<Watch>>,
    terms: &Arc<SharedStageTerms>,
) -> Result<String> {
    if let Some(w) = watch {
        w.check()?;
    }
    let watch = watch.cloned();
    let p = plan.point(r);
    let outcome: Result<Summary> = plan.setup(&p).and_then(|setup| {
        if plan.file.output.runs.contains(&r) {
            let opts = RunOptions {
                agents: None,
                out: Some(out.join("runs").join(r.to_string())),
                decimate: plan.file.output.decimate,
                plots: true,
                record: false,
                progress: false,
                trace: None,
                link_trace: None,
                worst: false,
                watch,
                stage_terms: Some(Arc::clone(terms)),
                ..RunOptions::default()
            };
            run(&setup, &opts).map(|x| x.summary)
        } else {
            let opts = RunOptions {
                watch,
                stage_terms: Some(Arc::clone(terms)),
                ..RunOptions::default()
            };
            run(&setup, &opts).map(|x| x.summary)
        }
    });
    match &outcome {
        Err(Error::Io(m)) => return Err(Error::Io(m.clone())),
        Err(Error::Interrupted) => return Err(Error::Interrupted),
        _ => {}
    }
    Ok(results::row(plan, &p, &outcome))
}

fn check_shard_file(out: &Path, shard: Shard, plan: &Plan) -> Result<()> {
    let path = out.join("shard.json");
    let existing: Option<ShardJson> = std::fs::read_to_string(&path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let found = existing.as_ref().map_or(Shard::ALL, |s| s.shard);
    let has_journal = out.join(results::JOURNAL).exists();
    if has_journal && found != shard {
        return Err(Error::invalid(
            "--shard",
            format!(
                "{} holds shard {}/{}; resume it with that --shard",
                out.display(),
                found.k,
                found.n
            ),
        ));
    }
    if shard != Shard::ALL {
        let j = ShardJson {
            shard,
            runs: shard.count(plan.runs()),
        };
        let text =
            serde_json::to_string_pretty(&j).map_err(|e| Error::Io(format!("shard.json: {e}")))?;
        write_atomic(&path, format!("{text}\n").as_bytes())?;
    }
    Ok(())
}

fn count(header: &[String], recs: &results::Records, rep: &mut SweepReport) {
    let col = |name: &str| header.iter().position(|h| h == name);
    let (Some(d), Some(s)) = (col("diverged"), col("status")) else {
        return;
    };
    for (_, rec) in recs {
        if let Some(rec) = rec {
            if rec.get(d) == Some("true") {
                rep.diverged += 1;
            }
            if rec.get(s) == Some("invalid") {
                rep.invalid += 1;
            }
        }
    }
}

fn progress_bar(len: u64, done: u64, show: bool) -> ProgressBar {
    let pb = crate::run::progress_bar(
        len,
        show,
        "{bar:40} {pos}/{len} runs  {per_sec}  {elapsed} (eta {eta})",
    );
    pb.set_position(done);
    pb.reset_eta();
    pb
}

/// `results.parquet` beside `results.csv` when `format` asks for it.
fn write_other(
    format: Format,
    out: &Path,
    header: &[String],
    rows: &BTreeMap<u64, String>,
) -> Result<()> {
    match format {
        Format::Csv => Ok(()),
        Format::Parquet => parquet::write_results(out, &Results::from_csv(header, rows.values())?),
    }
}

/// Merges complete shard directories (or one complete campaign) into `out`: the same
/// `results.csv`, `campaign.json` and figures as one unsharded sweep.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<SweepReport> {
    merge_with(dirs, out, Format::Csv)
}

/// [`merge`], also writing `results.parquet` for [`Format::Parquet`].
pub fn merge_with(dirs: &[PathBuf], out: &Path, format: Format) -> Result<SweepReport> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::invalid("merge", "give at least one directory"))?;
    let read = |d: &Path, name: &str| {
        std::fs::read_to_string(d.join(name)).map_err(|e| Error::io(&d.join(name), e))
    };
    let meta_text = read(first, "campaign.json")?;
    let meta: CampaignJson = serde_json::from_str(&meta_text)
        .map_err(|e| Error::invalid(first.join("campaign.json").display(), e))?;
    let mut rows = BTreeMap::new();
    let mut seen: Vec<Shard> = Vec::new();
    for d in dirs {
        if read(d, "campaign.json")? != meta_text {
            return Err(Error::invalid(
                d.display(),
                "campaign.json differs from the first directory's (another campaign or build)",
            ));
        }
        let shard = match std::fs::read_to_string(d.join("shard.json")) {
            Ok(t) => {
                serde_json::from_str::<ShardJson>(&t)
                    .map_err(|e| Error::invalid(d.join("shard.json").display(), e))?
                    .shard
            }
            Err(_) => Shard::ALL,
        };
        if seen.contains(&shard) {
            return Err(Error::invalid(
                d.display(),
                format!("shard {}/{} given twice", shard.k, shard.n),
            ));
        }
        let part = results::read_results(&d.join("results.csv"), &meta.columns)?;
        let expected = shard.count(meta.runs);
        if part.len() as u64 != expected || part.keys().any(|&r| !shard.has(r)) {
            return Err(Error::invalid(
                d.display(),
                format!(
                    "shard {}/{} is incomplete: {} of {expected} runs (finish it with sweep)",
                    shard.k,
                    shard.n,
                    part.len()
                ),
            ));
        }
        seen.push(shard);
        rows.extend(part);
    }
    if rows.len() as u64 != meta.runs {
        let n = seen.first().map_or(1, |s| s.n);
        let missing: Vec<String> = (1..=n)
            .filter(|k| !seen.iter().any(|s| s.k == *k && s.n == n))
            .map(|k| format!("{k}/{n}"))
            .collect();
        return Err(Error::invalid(
            "merge",
            format!(
                "{} of {} runs; missing shards: {}",
                rows.len(),
                meta.runs,
                missing.join(", ")
            ),
        ));
    }
    report::create_dir(out)?;
    write_atomic(&out.join("campaign.json"), meta_text.as_bytes())?;
    results::write_results(out, &meta.columns, &rows)?;
    write_other(format, out, &meta.columns, &rows)?;
    let base: consensus_sim::scenario::Scenario = serde_json::from_value(meta.scenario.clone())
        .map_err(|e| Error::invalid("campaign.json scenario", e))?;
    let mut rep = SweepReport {
        runs: meta.runs,
        ..SweepReport::default()
    };
    let recs = results::records(&rows);
    count(&meta.columns, &recs, &mut rep);
    let (axes, draws) = (meta.campaign.axis.len(), meta.campaign.draws);
    replications::write_summary(out, axes, draws, &meta.columns, &recs)?;
    rep.figures = plots::draw(&meta.campaign, &base, &meta.columns, &rows, &recs, out)?;
    Ok(rep)
}

#[cfg(test)]
mod tests {
    use super::Shard;

    #[test]
    fn shards_partition_the_runs() -> crate::Result<()> {
        let shards = [
            Shard::parse("1/3")?,
            Shard::parse(" 2 / 3 ")?,
            Shard::parse("3/3")?,
        ];
        for run in 0..100 {
            assert_eq!(shards.iter().filter(|s| s.has(run)).count(), 1);
        }
        assert_eq!(shards.iter().map(|s| s.count(100)).sum::<u64>(), 100);
        for bad in ["0/2", "3/2", "1", "a/b", "1/0", "-1/2"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        Ok(())
    }
}
