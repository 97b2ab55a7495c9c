//! `ptconsensus._native`: host-sim's runs and campaigns and one agent's `controller-core`
//! controller for Python. The Python package (`ptconsensus/__init__.py`) wraps these functions;
//! every scenario goes through host-sim's own loading, checks and run code.

use std::path::{Path, PathBuf};

use host_sim::{
    agent::{AgentController, AgentStep},
    campaign::{self, Shard, SweepOptions},
    error::Error,
    report::{
        csv::Format,
        table::{Cells, Column, Results, Table},
    },
    run::{run as run_setup, summary_json, RunRequest},
    scenario::{self, Setup},
};
use numpy::PyArray1;
use pyo3::{
    create_exception,
    exceptions::{PyOSError, PyValueError},
    prelude::*,
    types::{PyDict, PyList},
};

create_exception!(
    _native,
    ScenarioError,
    PyValueError,
    "An invalid scenario, campaign or option; the message names the key."
);
create_exception!(
    _native,
    OutputError,
    PyOSError,
    "A file could not be read or written."
);

/// host-sim's error as the Python exception of its kind, with the CLI's message.
fn py_err(e: Error) -> PyErr {
    match e.exit_code() {
        1 => OutputError::new_err(e.to_string()),
        _ => ScenarioError::new_err(e.to_string()),
    }
}

/// A `set` value given as JSON, written as the TOML value of `key=value`.
fn set_line(key: &str, json: &str) -> Result<String, Error> {
    let value: toml::Value =
        serde_json::from_str(json).map_err(|e| Error::invalid(format!("--set {key}"), e))?;
    Ok(format!("{key}={value}"))
}

/// The scenario `source` (`kind`: `path`, `toml` text or a `json` object) with `sets` applied.
fn load(kind: &str, source: &str, sets: &[(String, String)]) -> Result<Setup, Error> {
    let sets = sets
        .iter()
        .map(|(k, v)| set_line(k, v))
        .collect::<Result<Vec<_>, _>>()?;
    match kind {
        "path" => scenario::load(Path::new(source), &sets),
        "toml" => scenario::parse(source, &sets),
        "json" => {
            let table: toml::Table =
                serde_json::from_str(source).map_err(|e| Error::invalid("scenario", e))?;
            let text = toml::to_string(&table).map_err(|e| Error::invalid("scenario", e))?;
            scenario::parse(&text, &sets)
        }
        other => Err(Error::invalid(
            "scenario",
            format!("unknown source kind `{other}`"),
        )),
    }
}

/// The columns of `table` as numpy arrays (moved, not copied).
fn arrays<'py>(py: Python<'py>, table: Table) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, column) in table.names.into_iter().zip(table.columns) {
        match column {
            Column::F64(v) => d.set_item(name, PyArray1::from_vec(py, v))?,
            Column::F32(v) => d.set_item(name, PyArray1::from_vec(py, v))?,
        }
    }
    Ok(d)
}

/// Runs a scenario; returns `(summary.json text, {column: array} or None)`.
#[pyfunction]
#[pyo3(signature = (kind, source, sets, out=None, format="csv", plots=false, decimate=None, agents=None, table=true))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    kind: &str,
    source: &str,
    sets: Vec<(String, String)>,
    out: Option<PathBuf>,
    format: &str,
    plots: bool,
    decimate: Option<u64>,
    agents: Option<String>,
    table: bool,
) -> PyResult<(String, Option<Bound<'py, PyDict>>)> {
    let setup = load(kind, source, &sets).map_err(py_err)?;
    let plots = plots && out.is_some();
    let opts = RunRequest {
        out,
        format: Format::from_name(format).map_err(py_err)?,
        decimate,
        agents,
        table,
        plots,
        ..RunRequest::default()
    }
    .options(&setup)
    .map_err(py_err)?;
    let r = py.detach(|| run_setup(&setup, &opts)).map_err(py_err)?;
    let summary = summary_json(&r.summary).map_err(py_err)?;
    let columns = r.table.map(|t| arrays(py, t)).transpose()?;
    Ok((summary, columns))
}

/// The typed columns of a `results.csv`.
fn results_of<'py>(py: Python<'py>, path: &Path) -> PyResult<Bound<'py, PyDict>> {
    let text = std::fs::read_to_string(path).map_err(|e| py_err(Error::io(path, e)))?;
    let mut lines = text.lines().map(str::to_string);
    let header_line = lines.next().unwrap_or_default();
    let header: Vec<String> = csv_fields(&header_line);
    let rows: Vec<String> = lines.collect();
    let results = Results::from_csv(&header, rows.iter()).map_err(py_err)?;
    let d = PyDict::new(py);
    for (name, cells) in results.names.into_iter().zip(results.columns) {
        let list = match cells {
            Cells::Bool(v) => PyList::new(py, v)?,
            Cells::Int(v) => PyList::new(py, v)?,
            Cells::Float(v) => PyList::new(py, v)?,
            Cells::Text(v) => PyList::new(py, v)?,
        };
        d.set_item(name, list)?;
    }
    Ok(d)
}

/// The fields of one CSV header line (names with commas are quoted).
fn csv_fields(line: &str) -> Vec<String> {
    line.split(',')
        .map(|f| f.trim_matches('"').to_string())
        .collect()
}

/// Runs a campaign (or one shard) into `out`; returns `results.csv` as typed columns.
#[pyfunction]
#[pyo3(signature = (campaign, out, shard=None, format="csv", progress=None))]
fn sweep<'py>(
    py: Python<'py>,
    campaign: PathBuf,
    out: PathBuf,
    shard: Option<&str>,
    format: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let shard = shard.map_or(Ok(Shard::ALL), Shard::parse).map_err(py_err)?;
    let format = Format::from_name(format).map_err(py_err)?;
    let report = |done: u64, total: u64| {
        if let Some(cb) = &progress {
            Python::attach(|py| {
                if let Err(e) = cb.call1(py, (done, total)) {
                    e.print(py);
                }
            });
        }
    };
    let opts = SweepOptions {
        progress: false,
        on_run: Some(&report),
        format,
    };
    py.detach(|| campaign::sweep_with(&campaign, &out, shard, &opts))
        .map_err(py_err)?;
    results_of(py, &out.join("results.csv"))
}

/// One agent's controller of a scenario: `controller-core`'s law in `f32`, the code the node
/// firmware runs.
#[pyclass(module = "ptconsensus._native")]
struct Controller {
    inner: AgentController,
}

fn step_dict<'py>(py: Python<'py>, s: AgentStep) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("u", s.u)?;
    d.set_item("q", s.q)?;
    d.set_item("e", s.e)?;
    d.set_item("mu", s.mu)?;
    d.set_item("xi", s.xi)?;
    d.set_item("lambda", s.lambda)?;
    d.set_item("fault", s.fault)?;
    Ok(d)
}

#[pymethods]
impl Controller {
    #[new]
    fn new(kind: &str, source: &str, sets: Vec<(String, String)>, agent: usize) -> PyResult<Self> {
        let setup = load(kind, source, &sets).map_err(py_err)?;
        let inner = AgentController::new(&setup, agent).map_err(py_err)?;
        Ok(Self { inner })
    }

    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }

    #[getter]
    fn m(&self) -> usize {
        self.inner.m()
    }

    #[getter]
    fn neighbours(&self) -> Vec<usize> {
        self.inner.neighbours().to_vec()
    }

    #[getter]
    fn pinned(&self) -> bool {
        self.inner.pinned()
    }

    #[pyo3(signature = (x, neighbours, leader=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        x: Vec<f32>,
        neighbours: Vec<Option<f32>>,
        leader: Option<f32>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let s = self.inner.step(&x, &neighbours, leader).map_err(py_err)?;
        step_dict(py, s)
    }

    fn reset(&mut self) {
        self.inner.reset();
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_class::<Controller>()?;
    m.add("ScenarioError", m.py().get_type::<ScenarioError>())?;
    m.add("OutputError", m.py().get_type::<OutputError>())?;
    Ok(())
}
