//! The campaign file: a base scenario, overrides for every run, grid axes and Monte Carlo
//! draws over scenario keys; checked once into a [`Plan`] that builds each run's scenario.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::campaign::sample::Sample;
use consensus_plot::error::{Error, Result};
use consensus_sim::scenario::{self, KeyPath, Scenario, Setup};

/// The campaign file as written (`docs/CAMPAIGNS.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampaignFile {
    /// Base scenario, relative to the campaign file.
    pub scenario: String,
    /// Overrides applied to every run, as `--set`.
    #[serde(default)]
    pub set: Vec<String>,
    /// Grid axes: every combination, row-major, first axis slowest.
    #[serde(default)]
    pub axis: Vec<Axis>,
    /// Monte Carlo: keys drawn afresh for every run.
    #[serde(default)]
    pub sample: Vec<Sample>,
    /// Draws per grid point (default 1).
    #[serde(default = "one")]
    pub draws: u64,
    /// Seed of the draws.
    #[serde(default)]
    pub seed: u64,
    /// Runs that also write the full `host-sim run` outputs.
    #[serde(default)]
    pub output: OutputSpec,
    /// The metric drawn in the figures.
    #[serde(default)]
    pub plot: PlotSpec,
}

fn one() -> u64 {
    1
}

/// One `[[axis]]`: a key and its values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Scenario key, dotted, with 1-based `[i]` for array entries.
    pub key: String,
    /// Values (any TOML value the key accepts).
    pub values: Vec<toml::Value>,
}

/// `[output]`: per-run outputs for chosen runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Run indices whose `summary.json`, `trajectory.csv` and plots go to `runs/<run>/`.
    #[serde(default)]
    pub runs: Vec<u64>,
    /// Every `decimate`-th sample in those trajectories.
    #[serde(default = "ten")]
    pub decimate: u64,
}

fn ten() -> u64 {
    10
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            runs: Vec::new(),
            decimate: ten(),
        }
    }
}

/// `[plot]`: what the campaign figures show.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// A metric column of `results.csv`.
    #[serde(default = "default_metric")]
    pub metric: String,
}

impl Default for PlotSpec {
    fn default() -> Self {
        Self {
            metric: default_metric(),
        }
    }
}

fn default_metric() -> String {
    "max_error_after_predefined_time".into()
}

/// Prefix of the `results.csv` column of a `[[metrics.window]]` of the base scenario.
pub const WINDOW_PREFIX: &str = "window.";

/// Metrics a figure can show (numeric columns of `results.csv`), besides window columns.
pub const PLOT_METRICS: [&str; 5] = [
    "divergence_time",
    "settling_time",
    "max_error_after_predefined_time",
    "max_abs_u",
    "total_u_energy",
];

/// The message of an error without its kind (for wrapping it in another key's message).
fn inner(e: &Error) -> String {
    e.message()
}

/// A TOML value written inline (what follows `key=` in `--set`).
fn inline(v: &toml::Value) -> String {
    v.to_string()
}

/// A value as a `results.csv` cell: strings bare, numbers as `summary.json` writes them.
pub fn cell(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(f) => json_number(*f),
        other => inline(other),
    }
}

/// A number as `serde_json` writes it (so cells equal `summary.json`).
pub fn json_number(v: f64) -> String {
    serde_json::to_string(&v).unwrap_or_default()
}

/// The checked campaign: base scenario table, keys and how to build run `i`.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The file as read (with defaults).
    pub file: CampaignFile,
    /// Base scenario (file + `set`), as resolved by the validator.
    pub base: Scenario,
    table: toml::Table,
    axes: Vec<KeyPath>,
    samples: Vec<KeyPath>,
    grid: u64,
}

/// One run's scenario before validation.
#[derive(Debug, Clone)]
pub struct RunPoint {
    /// Run index.
    pub run: u64,
    /// One value per axis.
    pub axis_values: Vec<toml::Value>,
    /// Draw index within the grid point.
    pub draw: u64,
    /// One value per `[[sample]]`.
    pub sampled: Vec<toml::Value>,
}

impl Plan {
    /// Reads and checks a campaign file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            Error::invalid(format!("campaign file {}", path.display()), e.to_string())
        })?;
        let what = format!("campaign file {}", path.display());
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| Error::invalid(&what, e.message()))?;
        let file: CampaignFile = serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| {
                let key = scenario::one_based(&e.path().to_string());
                Error::invalid(format!("{what}: {key}"), e.inner().message())
            })?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::new(file, &dir)
    }

    /// Checks `file`; its scenario path is relative to `dir`.
    pub fn new(file: CampaignFile, dir: &Path) -> Result<Self> {
        let spath: PathBuf = dir.join(&file.scenario);
        let text = std::fs::read_to_string(&spath)
            .map_err(|e| Error::invalid("scenario", format!("{}: {e}", spath.display())))?;
        let mut table = scenario::parse_table(&text).map_err(|e| {
            Error::invalid("scenario", format!("{}: {}", spath.display(), inner(&e)))
        })?;
        for s in &file.set {
            scenario::apply_set(&mut table, s).map_err(|e| Error::invalid("set", inner(&e)))?;
        }
        let base = scenario::from_table(table.clone())
            .map_err(|e| Error::invalid("scenario (with set)", inner(&e)))?
            .scenario;
        if file.draws == 0 {
            return Err(Error::invalid("draws", "must be >= 1"));
        }
        if file.output.decimate == 0 {
            return Err(Error::invalid("output.decimate", "must be >= 1"));
        }
        let metric = file.plot.metric.as_str();
        let window = metric
            .strip_prefix(WINDOW_PREFIX)
            .is_some_and(|n| base.metrics.window.iter().any(|w| w.name == n));
        if !PLOT_METRICS.contains(&metric) && !window {
            return Err(Error::invalid(
                "plot.metric",
                format!(
                    "`{metric}` is not one of {PLOT_METRICS:?} nor `{WINDOW_PREFIX}<name>` of a \
                     [[metrics.window]] of the scenario"
                ),
            ));
        }
        let mut grid: u64 = 1;
        let mut axes = Vec::new();
        for (i, a) in file.axis.iter().enumerate() {
            let what = format!("axis[{}].key", i + 1);
            let key = KeyPath::parse(&a.key, &what)?;
            if a.values.is_empty() {
                return Err(Error::invalid(
                    format!("axis[{}].values", i + 1),
                    "must not be empty",
                ));
            }
            for v in &a.values {
                check_key(&key, &table, v, &what)?;
            }
            grid = grid
                .checked_mul(a.values.len() as u64)
                .ok_or_else(|| Error::invalid("axis", "too many runs"))?;
            axes.push(key);
        }
        let mut samples = Vec::new();
        for (i, s) in file.sample.iter().enumerate() {
            let what = format!("sample[{}]", i + 1);
            s.check(&what)?;
            let key = KeyPath::parse(&s.key, &format!("{what}.key"))?;
            check_key(&key, &table, &s.example(), &format!("{what}.key"))?;
            samples.push(key);
        }
        let all: Vec<&str> = axes.iter().chain(&samples).map(KeyPath::as_str).collect();
        for (i, k) in all.iter().enumerate() {
            if all[..i].contains(k) {
                return Err(Error::invalid(k, "given twice in the campaign"));
            }
        }
        grid.checked_mul(file.draws)
            .ok_or_else(|| Error::invalid("draws", "too many runs"))?;
        for &r in &file.output.runs {
            if r >= grid * file.draws {
                return Err(Error::invalid(
                    "output.runs",
                    format!("run {r} does not exist ({} runs)", grid * file.draws),
                ));
            }
        }
        Ok(Self {
            file,
            base,
            table,
            axes,
            samples,
            grid,
        })
    }

    /// Total runs: grid points × draws.
    pub fn runs(&self) -> u64 {
        self.grid * self.file.draws
    }

    /// The axis keys (column names).
    pub fn axis_keys(&self) -> Vec<String> {
        self.file.axis.iter().map(|a| a.key.clone()).collect()
    }

    /// The sampled keys (column names).
    pub fn sample_keys(&self) -> Vec<String> {
        self.file.sample.iter().map(|s| s.key.clone()).collect()
    }

    /// Values of run `run`: grid position (row-major, first axis slowest), then its draws.
    pub fn point(&self, run: u64) -> RunPoint {
        let draws = self.file.draws;
        let (mut g, draw) = (run / draws, run % draws);
        let mut axis_values = vec![toml::Value::Boolean(false); self.file.axis.len()];
        for (slot, a) in axis_values.iter_mut().zip(&self.file.axis).rev() {
            let n = a.values.len() as u64;
            *slot = a.values[(g % n) as usize].clone();
            g /= n;
        }
        let mut rng = crate::campaign::sample::run_rng(self.file.seed, run);
        let sampled = self.file.sample.iter().map(|s| s.draw(&mut rng)).collect();
        RunPoint {
            run,
            axis_values,
            draw,
            sampled,
        }
    }

    /// The validated scenario of a run (an invalid combination is an `Err` for its row).
    pub fn setup(&self, p: &RunPoint) -> Result<Setup> {
        let mut t = self.table.clone();
        for (k, v) in self
            .axes
            .iter()
            .zip(&p.axis_values)
            .chain(self.samples.iter().zip(&p.sampled))
        {
            k.apply(&mut t, v)?;
        }
        scenario::from_table(t)
    }
}

/// The key exists: set to `value` on the base it deserializes without an unknown field.
fn check_key(key: &KeyPath, table: &toml::Table, value: &toml::Value, what: &str) -> Result<()> {
    let mut t = table.clone();
    key.apply(&mut t, value)
        .map_err(|e| Error::invalid(what, inner(&e)))?;
    match scenario::from_table(t) {
        Err(Error::Invalid(m)) if m.contains("unknown field") || m.contains("invalid type") => {
            Err(Error::invalid(what, format!("`{}`: {m}", key.as_str())))
        }
        _ => Ok(()),
    }
}
