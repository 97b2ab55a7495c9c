//! `ptconsensus._native`: host-sim's runs and campaigns and one agent's `controller-core`
//! controller for Python. The Python package (`ptconsensus/__init__.py`) wraps these functions
//! (it checks the arguments' types, writes Python values as TOML and defines the exceptions);
//! every scenario goes through host-sim's own loading, checks and run code.
//!
//! A run or sweep goes on in a thread of its own while the calling thread waits for it and,
//! every `POLL`, lets Python handle its signals (Ctrl-C, Jupyter's "interrupt kernel"): an
//! exception from a signal handler stops the work through host-sim's [`Watch`] and is raised
//! once the work has stopped and removed its temporary files.

use std::{
    path::{Path, PathBuf},
    sync::{mpsc, Arc},
    time::Duration,
};

use consensus_plot::error::Error;
use consensus_sim::{
    agent::{AgentController, AgentStep},
    scenario::{self, Setup},
};
use host_sim::{
    campaign::{self, Shard, SweepOptions},
    report::{
        csv::Format,
        table::{Cells, Column, Results, Table},
    },
    run::{run as run_setup, summary_json, RunRequest, Watch},
};
use numpy::PyArray1;
use pyo3::{
    exceptions::PyRuntimeError,
    import_exception,
    prelude::*,
    types::{PyDict, PyList},
};

// Defined in the package itself (`ptconsensus/__init__.py`), so that pickle finds them.
import_exception!(ptconsensus, ScenarioError);
import_exception!(ptconsensus, OutputError);

/// How often the waiting thread checks for signals and reports progress.
const POLL: Duration = Duration::from_millis(20);

/// Stack of the thread a run goes on in (the size of a main thread's).
const STACK: usize = 8 << 20;

/// host-sim's error as the Python exception of its kind, with the CLI's message (the package
/// words it in Python's terms).
fn py_err(e: Error) -> PyErr {
    match e.exit_code() {
        1 => OutputError::new_err(e.to_string()),
        _ => ScenarioError::new_err(e.to_string()),
    }
}

/// The scenario `source` (`kind`: a `path` or `toml` text) with `sets` (`key=value`) applied.
fn load(kind: &str, source: &str, sets: &[String]) -> Result<Setup, Error> {
    match kind {
        "path" => scenario::load(Path::new(source), sets),
        "toml" => scenario::parse(source, sets),
        other => Err(Error::invalid(
            "scenario",
            format!("unknown source kind `{other}`"),
        )),
    }
}

/// Runs `work` on a thread of its own; this thread waits for it, and every [`POLL`] checks
/// Python's signals and calls `tick`. An exception of a signal handler or of `tick` (a
/// progress callback, in which a signal handler may run too) stops the work (`watch`) and is
/// returned once the work has ended.
fn watched<T: Send>(
    py: Python<'_>,
    watch: &Watch,
    mut tick: impl FnMut(Python<'_>) -> PyResult<()> + Send,
    work: impl FnOnce() -> Result<T, Error> + Send,
) -> PyResult<T> {
    let mut interrupt: Option<PyErr> = None;
    let outcome = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel();
            let spawned = std::thread::Builder::new()
                .name("ptconsensus".into())
                .stack_size(STACK)
                .spawn_scoped(s, move || {
                    let _ = tx.send(work());
                });
            if let Err(e) = spawned {
                return Some(Err(Error::Io(format!(
                    "cannot start the run's thread: {e}"
                ))));
            }
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(r) => return Some(r),
                    Err(mpsc::RecvTimeoutError::Disconnected) => return None,
                    Err(mpsc::RecvTimeoutError::Timeout) if interrupt.is_none() => {
                        Python::attach(|py| {
                            if let Err(e) = py.check_signals().and_then(|()| tick(py)) {
                                watch.stop();
                                interrupt = Some(e);
                            }
                        });
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                }
            }
        })
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    match outcome {
        Some(r) => r.map_err(py_err),
        None => Err(PyRuntimeError::new_err(
            "the run's thread stopped unexpectedly",
        )),
    }
}

/// Calls a Python `progress(done, total)`.
fn call_progress(py: Python<'_>, f: Option<&Py<PyAny>>, done: u64, total: u64) -> PyResult<()> {
    match f {
        Some(cb) => cb.call1(py, (done, total)).map(drop),
        None => Ok(()),
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

/// Runs a scenario; returns `(summary.json text, {column: array} or None)`. `progress(done,
/// total)` is called with the samples done while the run goes on.
#[pyfunction]
#[pyo3(signature = (kind, source, sets, out=None, format="csv", plots=false, decimate=None, agents=None, table=true, force=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    kind: &str,
    source: &str,
    sets: Vec<String>,
    out: Option<PathBuf>,
    format: &str,
    plots: bool,
    decimate: Option<u64>,
    agents: Option<String>,
    table: bool,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Option<Bound<'py, PyDict>>)> {
    let setup = load(kind, source, &sets).map_err(py_err)?;
    let plots = plots && out.is_some();
    let mut opts = RunRequest {
        out,
        format: Format::from_name(format).map_err(py_err)?,
        decimate,
        agents,
        table,
        plots,
        force,
        ..RunRequest::default()
    }
    .options(&setup)
    .map_err(py_err)?;
    let watch = Arc::new(Watch::default());
    opts.watch = Some(Arc::clone(&watch));
    let total = setup.samples;
    let mut last = None;
    let tick = |py: Python<'_>| {
        let done = watch.done();
        if last == Some(done) {
            return Ok(());
        }
        last = Some(done);
        call_progress(py, progress.as_ref(), done, total)
    };
    let r = watched(py, &watch, tick, || run_setup(&setup, &opts))?;
    call_progress(py, progress.as_ref(), total, total)?;
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
    // Called from the sweep's journal thread (not this one): an exception is printed.
    let report = |done: u64, total: u64| {
        if progress.is_some() {
            Python::attach(|py| {
                if let Err(e) = call_progress(py, progress.as_ref(), done, total) {
                    e.print(py);
                }
            });
        }
    };
    let watch = Arc::new(Watch::default());
    let opts = SweepOptions {
        progress: false,
        on_run: Some(&report),
        format,
        watch: Some(&watch),
    };
    watched(
        py,
        &watch,
        |_| Ok(()),
        || campaign::sweep_with(&campaign, &out, shard, &opts),
    )?;
    results_of(py, &out.join("results.csv"))
}

/// One agent's controller of a scenario: `controller-core`'s law in `f32`, the code the node
/// firmware runs.
#[pyclass(module = "ptconsensus._native")]
struct Controller {
    inner: AgentController,
    /// Sample period `h` [s] of the scenario.
    h: f64,
    /// Samples stepped since the start or the last reset.
    k: u64,
}

/// One step as `(u, q, e, mu, xi, lambda, fault)`, the vectors as `float32` arrays.
type StepTuple<'py> = (
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    Bound<'py, PyArray1<f32>>,
    f32,
    f32,
    f32,
    Option<String>,
);

fn step_tuple<'py>(py: Python<'py>, s: AgentStep) -> StepTuple<'py> {
    (
        PyArray1::from_vec(py, s.u),
        PyArray1::from_vec(py, s.q),
        PyArray1::from_vec(py, s.e),
        s.mu,
        s.xi,
        s.lambda,
        s.fault,
    )
}

#[pymethods]
impl Controller {
    #[new]
    fn new(kind: &str, source: &str, sets: Vec<String>, agent: i64) -> PyResult<Self> {
        let setup = load(kind, source, &sets).map_err(py_err)?;
        let count = setup.agents();
        let index = usize::try_from(agent)
            .ok()
            .filter(|&a| (1..=count).contains(&a))
            .ok_or_else(|| {
                py_err(Error::invalid(
                    "agent",
                    format!("{agent} out of range 1..={count} (agents are 1-based)"),
                ))
            })?;
        let inner = AgentController::new(&setup, index).map_err(py_err)?;
        Ok(Self {
            inner,
            h: setup.scenario.simulation.h,
            k: 0,
        })
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
    fn h(&self) -> f64 {
        self.h
    }

    #[getter]
    fn k(&self) -> u64 {
        self.k
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
    ) -> PyResult<StepTuple<'py>> {
        let s = self.inner.step(&x, &neighbours, leader).map_err(py_err)?;
        self.k += 1;
        Ok(step_tuple(py, s))
    }

    fn reset(&mut self) {
        self.inner.reset();
        self.k = 0;
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_class::<Controller>()?;
    Ok(())
}
