//! Commands on top of the loop: one run with its outputs, the stable-`h` search and the
//! comparison of two scenarios.

use std::{
    io::IsTerminal,
    path::PathBuf,
    sync::{
        atomic::{AtomicBool, AtomicU64, Ordering},
        Arc,
    },
};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;

use crate::report::{
    self,
    csv::{
        check_size_of, default_decimate, estimated_size_of, human_bytes, parse_agents, Format,
        Sink, TrajectoryObserver, SIZE_LIMIT,
    },
    plots::Recorder,
    spread::Spread,
    table::Table,
};
use consensus_hil::network::{
    ideal::{IdealLink, LinkModel},
    spec::NetworkKind,
    trace::Traces,
    BusAgents,
};
use consensus_plot::error::{Error, Result};
use consensus_sim::{
    clock::Clocks,
    metrics::{Metrics, Summary},
    plant::{with_sizes, Custom, Plant, PlantModel},
    scenario::{self, Scenario, Setup},
    sim::{Agents, Linked, Observer, SharedStageTerms, Sim, StageTerms, World},
};

/// What a run writes and shows.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output directory (`None`: nothing is written).
    pub out: Option<PathBuf>,
    /// Format of the trajectory file in `out`.
    pub format: Format,
    /// Keep the trajectory's columns in the result ([`RunResult::table`]).
    pub table: bool,
    /// Every `decimate`-th sample goes to `trajectory.csv`.
    pub decimate: u64,
    /// The agents (0-based, ascending) whose columns `trajectory.csv` gets (`None`: all).
    pub agents: Option<Vec<usize>>,
    /// Draw the figures.
    pub plots: bool,
    /// Keep the plot series in the result (for `compare`).
    pub record: bool,
    /// Show a progress bar (only on a terminal).
    pub progress: bool,
    /// Write every bus frame to this candump log (`kind = "can"` and `"pil"` only).
    pub trace: Option<PathBuf>,
    /// Write everything on the nodes' serial links to this candump log (`kind = "pil"` only).
    pub link_trace: Option<PathBuf>,
    /// Keep `(t, max_i |y_i − y_d|, max_{i,l} |u_{i,l}|)` of every sample in the result.
    pub worst: bool,
    /// Shared with whoever waits for the run (another thread): a stop request, checked at every
    /// sample, and the samples done.
    pub watch: Option<Arc<Watch>>,
    /// Example 1's time terms shared with other runs (a campaign's): the first run that needs
    /// them computes them.
    pub stage_terms: Option<Arc<SharedStageTerms>>,
}

/// A run watched from another thread (the Python package's `run`, which waits for signals
/// such as Ctrl-C while the run goes on): [`Watch::stop`] ends the run at its next sample with
/// [`Error::Interrupted`], before any file is moved into place; [`Watch::done`] counts samples.
#[derive(Debug, Default)]
pub struct Watch {
    stop: AtomicBool,
    done: AtomicU64,
}

impl Watch {
    /// Asks the run (or every run of a sweep) to stop.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Whether a stop was asked for.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Samples done by the run.
    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }

    /// `Err(Error::Interrupted)` once a stop was asked for.
    pub fn check(&self) -> Result<()> {
        if self.stopped() {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    }
}

impl<const N: usize, const M: usize> Observer<N, M> for &Watch {
    fn sample(&mut self, s: &consensus_sim::sim::SampleView<'_, N, M>) -> Result<()> {
        self.check()?;
        self.done.store(s.k + 1, Ordering::Relaxed);
        Ok(())
    }
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The figures of `summary.json`.
    pub summary: Summary,
    /// Plot series, when recorded.
    pub recorder: Option<Recorder>,
    /// Per sample `(t, max error, max |u|)`, when asked for (`RunOptions::worst`).
    pub worst: Option<Vec<[f64; 3]>>,
    /// The trajectory's columns, when asked for (`RunOptions::table`).
    pub table: Option<Table>,
}

/// A run as a user asks for it (the options of `host-sim run`, the arguments of the Python
/// package's `run`), before it is checked against its scenario by [`RunRequest::options`].
#[derive(Debug, Clone, Default)]
pub struct RunRequest {
    /// Output directory (`None`: nothing is written).
    pub out: Option<PathBuf>,
    /// Format of the trajectory file.
    pub format: Format,
    /// `--decimate` (`None`: 1, or for a large group what keeps the file within 100 MB).
    pub decimate: Option<u64>,
    /// `--agents`: 1-based numbers and ranges (`None`: all).
    pub agents: Option<String>,
    /// Keep the trajectory in memory.
    pub table: bool,
    /// Draw the figures.
    pub plots: bool,
    /// Show a progress bar.
    pub progress: bool,
    /// Write (or keep in memory) a trajectory estimated above the size limit.
    pub force: bool,
    /// `--trace`.
    pub trace: Option<PathBuf>,
    /// `--link-trace`.
    pub link_trace: Option<PathBuf>,
}

impl RunRequest {
    /// The run options for `setup`: `--decimate` and `--agents` checked, the default
    /// decimation of a large group chosen (with a note on standard error) and, unless `force`,
    /// the size of the trajectory checked where it goes: the file in `out`, else the columns
    /// kept in memory (`table`); a run that keeps no trajectory has no limit.
    pub fn options(self, setup: &Setup) -> Result<RunOptions> {
        if self.decimate == Some(0) {
            return Err(Error::invalid("--decimate", "must be >= 1"));
        }
        let agents = self
            .agents
            .map(|list| parse_agents(&list, setup.agents()))
            .transpose()?;
        let columns = agents.as_ref().map_or(setup.agents(), Vec::len);
        let decimate = match self.decimate {
            Some(k) => k,
            None => {
                let k = default_decimate(setup, columns);
                if k > 1 {
                    eprintln!(
                        "host-sim: note: {} agents: trajectory.csv keeps one sample in {k} \
                         (--decimate {k}, about {}); --decimate 1 keeps every sample, \
                         --agents a subset of the columns",
                        setup.agents(),
                        human_bytes(estimated_size_of(setup, k, columns)),
                    );
                }
                k
            }
        };
        if !self.force {
            if self.out.is_some() {
                check_size_of(setup, decimate, columns)?;
            } else if self.table {
                check_memory_of(setup, decimate, columns)?;
            }
        }
        Ok(RunOptions {
            out: self.out,
            format: self.format,
            table: self.table,
            decimate,
            agents,
            plots: self.plots,
            record: false,
            progress: self.progress,
            trace: self.trace,
            link_trace: self.link_trace,
            worst: false,
            watch: None,
            stage_terms: None,
        })
    }
}

/// Estimated bytes of the trajectory's columns in memory ([`Table`]): 8 per `f64` value, 4 per
/// `f32` value (the columns of [`crate::report::csv`]).
pub fn estimated_memory_of(setup: &Setup, decimate: u64, columns: usize) -> u64 {
    let (n, m) = (setup.n(), setup.m());
    let row = 8 * (2 + columns * (1 + n + m)) + 4 * columns * (n + 2 * m + 3);
    setup
        .samples
        .div_ceil(decimate.max(1))
        .saturating_mul(row as u64)
}

/// `Err` (an invalid `--decimate`, naming the one that fits) when the trajectory kept in memory
/// would exceed [`SIZE_LIMIT`].
fn check_memory_of(setup: &Setup, decimate: u64, columns: usize) -> Result<()> {
    let size = estimated_memory_of(setup, decimate, columns);
    if size <= SIZE_LIMIT {
        return Ok(());
    }
    let fit = size.div_ceil(SIZE_LIMIT).saturating_mul(decimate.max(1));
    Err(Error::invalid(
        "--decimate",
        format!(
            "the trajectory kept in memory would take about {} ({} samples, every {decimate}), \
             above the limit of {}: use --decimate {fit}, keep no trajectory, or --force to keep \
             it anyway",
            human_bytes(size),
            setup.samples,
            human_bytes(SIZE_LIMIT),
        ),
    ))
}

/// The text of `summary.json`.
pub fn summary_json(summary: &Summary) -> Result<String> {
    serde_json::to_string_pretty(summary)
        .map(|json| json + "\n")
        .map_err(|e| Error::Io(format!("summary.json: {e}")))
}

/// Collects the per-sample worst error and command (for fault campaigns).
struct WorstPerSample(Vec<[f64; 3]>);

impl<const N: usize, const M: usize> Observer<N, M> for WorstPerSample {
    fn sample(&mut self, s: &consensus_sim::sim::SampleView<'_, N, M>) -> Result<()> {
        let err = s.x.iter().map(|x| (x[0] - s.yd).abs()).fold(0.0, f64::max);
        let u = s
            .out
            .iter()
            .flat_map(|o| o.u.iter())
            .map(|u| f64::from(u.abs()))
            .fold(0.0, f64::max);
        self.0.push([s.t, err, u]);
        Ok(())
    }
}

/// Runs `setup` without writing anything: the summary only.
pub fn simulate(setup: &Setup) -> Result<Summary> {
    run(setup, &RunOptions::default()).map(|r| r.summary)
}

/// Runs `setup` with the outputs of `opts` over the network of its `[network]` section: the
/// ideal link, or firmware nodes over the CAN bus.
pub fn run(setup: &Setup, opts: &RunOptions) -> Result<RunResult> {
    let trace = Traces {
        bus: opts.trace.as_deref(),
        link: opts.link_trace.as_deref(),
    };
    trace.check(setup.scenario.network.kind)?;
    match setup.scenario.network.kind {
        NetworkKind::Ideal => run_with_link(setup, opts, IdealLink),
        NetworkKind::Can | NetworkKind::Pil | NetworkKind::Socketcan => match &setup.plant {
            PlantModel::Example1(p) => {
                run_with::<_, _, 2, 2>(setup, *p, bus_agents(setup, trace)?, opts, None)
            }
            PlantModel::Manipulator(p) => {
                run_with::<_, _, 2, 2>(setup, *p, bus_agents(setup, trace)?, opts, None)
            }
            PlantModel::Custom(p) => {
                run_with::<_, _, 2, 2>(setup, (**p).clone(), bus_agents(setup, trace)?, opts, None)
            }
            PlantModel::Library { .. } => Err(library()),
        },
    }
}

/// Runs `setup` with the outputs of `opts`, host-sim's controllers over `link` (e.g. a bus
/// model; `[network]` is not consulted); dispatches on the plant model (and so its `(n, m)`).
pub fn run_with_link<L: LinkModel>(setup: &Setup, opts: &RunOptions, link: L) -> Result<RunResult> {
    match &setup.plant {
        PlantModel::Example1(p) => {
            let terms = opts.stage_terms.as_ref().map(|shared| {
                let sim = &setup.scenario.simulation;
                shared.example1(sim.h, sim.substeps, setup.samples)
            });
            run_with::<_, _, 2, 2>(setup, *p, linked(setup, link)?, opts, terms)
        }
        PlantModel::Manipulator(p) => {
            run_with::<_, _, 2, 2>(setup, *p, linked(setup, link)?, opts, None)
        }
        PlantModel::Custom(p) => {
            with_sizes!(p.n(), p.m(), run_custom(setup, opts, (**p).clone(), link))
        }
        PlantModel::Library { .. } => Err(library()),
    }
}

fn library() -> Error {
    Error::invalid(
        "plant.model",
        "a plant given in Rust runs through host_sim::run::run_plant",
    )
}

/// Runs `setup` (from [`consensus_sim::scenario::validate_with_plant`] with `N`, `M`) with a plant
/// given in Rust, host-sim's controllers over the ideal link, the outputs of `opts`. The plant
/// is shared by the threads that integrate a large group (`Sync`).
///
/// ```
/// use host_sim::{plant::Plant, run::{run_plant, RunOptions}, scenario};
///
/// /// `ẋ_1 = x_2`, `ẋ_2 = −x_1 + a_1 + a_2`: an undamped oscillator with two motors.
/// struct Oscillator;
///
/// impl Plant<2, 2> for Oscillator {
///     type Time = ();
///     fn at(&self, _t: f64) {}
///     fn derivative(&self, _t: &(), x: &[f64; 2], a: &[f64; 2]) -> [f64; 2] {
///         [x[1], -x[0] + a[0] + a[1]]
///     }
/// }
///
/// let mut s = scenario::Scenario::default();
/// s.simulation.t_end = 0.5;
/// let setup = scenario::validate_with_plant(s, 2, 2)?;
/// let summary = run_plant(&setup, Oscillator, &RunOptions::default())?.summary;
/// assert!(!summary.diverged);
/// # Ok::<(), host_sim::Error>(())
/// ```
pub fn run_plant<P: Plant<N, M> + Sync, const N: usize, const M: usize>(
    setup: &Setup,
    plant: P,
    opts: &RunOptions,
) -> Result<RunResult>
where
    P::Time: Sync,
{
    if (setup.n(), setup.m()) != (N, M) {
        return Err(Error::invalid(
            "plant.model",
            format!(
                "the scenario was checked for n = {}, m = {}, the plant has n = {N}, m = {M}",
                setup.n(),
                setup.m()
            ),
        ));
    }
    if setup.scenario.network.kind != NetworkKind::Ideal {
        return Err(Error::invalid(
            "network.kind",
            "a plant given in Rust runs over the ideal link",
        ));
    }
    run_with::<_, _, N, M>(setup, plant, linked(setup, IdealLink)?, opts, None)
}

/// A custom plant of `N` states and `M` actuators under host-sim's controllers over `link`.
fn run_custom<const N: usize, const M: usize>(
    setup: &Setup,
    opts: &RunOptions,
    plant: Custom,
    link: impl LinkModel,
) -> Result<RunResult> {
    run_with::<_, _, N, M>(setup, plant, linked(setup, link)?, opts, None)
}

/// What the simulation loop needs of `setup`: leader, faults, initial states and timing.
pub fn world(setup: &Setup) -> World {
    let sim = &setup.scenario.simulation;
    World {
        leader: setup.scenario.leader.clone(),
        faults: setup.faults.clone(),
        x0: setup.x0.clone(),
        h: sim.h,
        substeps: sim.substeps,
        divergence_bound: sim.divergence_bound,
        samples: setup.samples,
        sensor: setup.scenario.faults.sensor_windows(),
    }
}

/// host-sim's controllers of `setup` over `link`.
fn linked<L: LinkModel, const N: usize, const M: usize>(
    setup: &Setup,
    link: L,
) -> Result<Linked<L, N, M>> {
    Linked::new(&setup.graph, &setup.controller_configs::<N>()?, link)
}

/// The node firmware of `setup`'s agents on the bus of its `[network]` (`kind = "can"` or
/// `"pil"`).
fn bus_agents<const N: usize, const M: usize>(
    setup: &Setup,
    trace: Traces<'_>,
) -> Result<BusAgents<N, M>> {
    let s = &setup.scenario;
    BusAgents::new(
        &s.network,
        &s.node,
        s.simulation.h,
        &setup.graph,
        &setup.controller_configs::<N>()?,
        setup.samples,
        trace,
    )
}

/// A progress bar of `len` steps drawn with `template` on stderr; hidden unless `show` and
/// stderr is a terminal.
pub(crate) fn progress_bar(len: u64, show: bool, template: &str) -> ProgressBar {
    if !show || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style);
    }
    pb
}

fn run_with<P: Plant<N, M> + Sync, A: Agents<N, M>, const N: usize, const M: usize>(
    setup: &Setup,
    plant: P,
    agents: A,
    opts: &RunOptions,
    terms: Option<Arc<StageTerms<P::Time>>>,
) -> Result<RunResult>
where
    P::Time: Sync,
{
    let mut sim = Sim::<_, _, N, M>::with_agents(world(setup), plant, agents)?;
    if let Some(terms) = terms {
        sim.share_stage_terms(terms);
    }
    let mut metrics = Metrics::new(setup);
    let mut recorder = (opts.plots || opts.record).then(|| {
        Recorder::new(setup.samples, setup.agents(), setup.m()).with_faults(setup.faults.clone())
    });
    let columns = opts
        .agents
        .clone()
        .unwrap_or_else(|| (0..setup.agents()).collect());
    let trajectory = |sink| {
        let h = setup.scenario.simulation.h;
        TrajectoryObserver::create_for(sink, columns.clone(), (N, M), opts.decimate.max(1), h)
            .map(|t| t.with_faults(setup.faults.clone()))
    };
    let mut file = match &opts.out {
        Some(dir) => {
            report::create_dir(dir)?;
            let name = format!("trajectory.{}", opts.format.extension());
            Some(trajectory(Sink::File(opts.format, dir.join(name)))?)
        }
        None => None,
    };
    let mut table = opts.table.then(|| trajectory(Sink::Table)).transpose()?;
    let pb = progress_bar(
        setup.samples,
        opts.progress,
        "{bar:40} {pos}/{len} samples  {elapsed} (eta {eta})",
    );
    let mut worst = opts.worst.then(|| WorstPerSample(Vec::new()));
    let mut spread =
        (opts.plots && report::spread::wanted(setup.agents())).then(|| Spread::new(setup));
    let mut clocks = setup
        .clocks
        .as_ref()
        .map(|plan| Clocks::new(plan, setup.samples));
    let mut watch = opts.watch.as_deref();
    let divergence = {
        let mut obs: Vec<&mut dyn Observer<N, M>> = vec![&mut metrics];
        if let Some(w) = watch.as_mut() {
            obs.push(w);
        }
        if let Some(w) = worst.as_mut() {
            obs.push(w);
        }
        if let Some(r) = recorder.as_mut() {
            obs.push(r);
        }
        if let Some(s) = spread.as_mut() {
            obs.push(s);
        }
        if let Some(c) = file.as_mut() {
            obs.push(c);
        }
        if let Some(c) = table.as_mut() {
            obs.push(c);
        }
        match clocks.as_mut() {
            Some(c) => sim.run_clocked(c, &mut obs, |k| pb.set_position(k))?,
            None => sim.run(&mut obs, |k| pb.set_position(k))?,
        }
    };
    pb.finish_and_clear();
    sim.agents_mut().finish()?;
    let mut summary = metrics.summary(setup, &sim.gains(), divergence);
    summary.set_report(sim.agents().report());
    summary.set_clock(clocks.as_ref().map(Clocks::summary));
    let table = table.map(TrajectoryObserver::finish).transpose()?.flatten();
    if let Some(dir) = &opts.out {
        if let Some(c) = file {
            c.finish()?;
        }
        report::write_atomic(
            &dir.join("summary.json"),
            summary_json(&summary)?.as_bytes(),
        )?;
        if opts.plots {
            if let Some(r) = &recorder {
                r.draw(dir, setup, summary.settling_time)?;
            }
            if let Some(s) = &spread {
                s.draw(dir, setup)?;
            }
            sim.agents().draw(
                dir,
                setup.scenario.simulation.h,
                &setup.figure_title(),
                setup.figures(),
            )?;
            if let Some(c) = &clocks {
                report::clocks::draw(dir, c, &setup.figure_title(), setup.figures())?;
            }
        }
    }
    Ok(RunResult {
        summary,
        recorder,
        worst: worst.map(|w| w.0),
        table,
    })
}

/// One trial of the stable-`h` search.
#[derive(Debug, Clone, Serialize)]
pub struct Trial {
    /// Sample period \[s\].
    pub h: f64,
    /// Stable: no divergence and error after `2 T_s` within the band.
    pub stable: bool,
    /// `max_error_after_predefined_time`.
    pub max_error_after_predefined_time: Option<f64>,
    /// Divergence time, if any.
    pub diverged_at: Option<f64>,
}

/// Result of `stable-h`.
#[derive(Debug, Clone, Serialize)]
pub struct StableH {
    /// Largest stable `h` found (null if even `h_min` is unstable).
    pub largest_stable_h: Option<f64>,
    /// Smallest unstable `h` found (null if `h_max` is stable).
    pub smallest_unstable_h: Option<f64>,
    /// Error band used.
    pub band: f64,
    /// Every run, in order.
    pub trials: Vec<Trial>,
}

/// Bisection (geometric) over `h ∈ [h_min, h_max]` for the largest stable sample period;
/// assumes stability is monotone in `h` (each trial is listed so a user can check).
pub fn stable_h(
    base: &Scenario,
    band: f64,
    h_min: f64,
    h_max: f64,
    rel_tol: f64,
    mut report: impl FnMut(&Trial),
) -> Result<StableH> {
    if !(band.is_finite() && band > 0.0) {
        return Err(Error::invalid("--band", "must be > 0"));
    }
    if !(h_min > 0.0 && h_max > h_min && h_max.is_finite()) {
        return Err(Error::invalid("--h-min/--h-max", "need 0 < h_min < h_max"));
    }
    if !(rel_tol > 0.0 && rel_tol.is_finite()) {
        return Err(Error::invalid("--rel-tol", "must be > 0"));
    }
    let mut trials = Vec::new();
    let mut trial = |h: f64| -> Result<bool> {
        let mut s = base.clone();
        s.simulation.h = h;
        let setup = scenario::validate(s)?;
        let sum = simulate(&setup)?;
        let stable = !sum.diverged
            && sum
                .max_error_after_predefined_time
                .is_some_and(|e| e <= band);
        let t = Trial {
            h,
            stable,
            max_error_after_predefined_time: sum.max_error_after_predefined_time,
            diverged_at: sum.divergence.map(|d| d.time),
        };
        report(&t);
        trials.push(t);
        Ok(stable)
    };
    let result = if trial(h_max)? {
        (Some(h_max), None)
    } else if !trial(h_min)? {
        (None, Some(h_min))
    } else {
        let (mut lo, mut hi) = (h_min, h_max);
        while hi / lo > 1.0 + rel_tol {
            let mid = (lo * hi).sqrt();
            if trial(mid)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (Some(lo), Some(hi))
    };
    Ok(StableH {
        largest_stable_h: result.0,
        smallest_unstable_h: result.1,
        band,
        trials,
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::{run, RunRequest, Watch};
    use crate::Result;
    use consensus_plot::error::Error;
    use consensus_sim::scenario;

    fn example1(t_end: f64) -> Result<scenario::Setup> {
        scenario::parse(
            include_str!("../../scenarios/example1.toml"),
            &[format!("simulation.t_end={t_end}")],
        )
    }

    #[test]
    fn a_stopped_watch_ends_the_run_before_any_file_is_in_place() -> Result<()> {
        let setup = example1(1.0)?;
        let dir = std::env::temp_dir().join(format!("host-sim-watch-{}", std::process::id()));
        let mut opts = RunRequest {
            out: Some(dir.clone()),
            ..RunRequest::default()
        }
        .options(&setup)?;
        let watch = Arc::new(Watch::default());
        opts.watch = Some(Arc::clone(&watch));
        watch.stop();
        assert_eq!(run(&setup, &opts).err(), Some(Error::Interrupted));
        let left: Vec<_> = std::fs::read_dir(&dir)
            .map_err(|e| Error::io(&dir, e))?
            .collect();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(left.is_empty(), "{left:?}");
        Ok(())
    }

    #[test]
    fn a_watch_counts_the_samples_of_a_run() -> Result<()> {
        let setup = example1(0.5)?;
        let mut opts = RunRequest::default().options(&setup)?;
        let watch = Arc::new(Watch::default());
        opts.watch = Some(Arc::clone(&watch));
        run(&setup, &opts)?;
        assert_eq!(watch.done(), 500);
        Ok(())
    }

    #[test]
    fn the_size_limit_applies_where_the_trajectory_goes() -> Result<()> {
        // 7,000 s of Example 1: trajectory.csv about 5.85 GB, the columns about 2.24 GB.
        let setup = example1(7000.0)?;
        let file = RunRequest {
            out: Some("unused".into()),
            ..RunRequest::default()
        };
        let memory = RunRequest {
            table: true,
            ..RunRequest::default()
        };
        let message = |r: RunRequest| r.options(&setup).err().map(|e| e.to_string());
        assert!(message(file.clone()).is_some_and(|m| m.contains("trajectory.csv would take")));
        assert!(message(memory.clone()).is_some_and(|m| m.contains("kept in memory")));
        assert_eq!(message(RunRequest::default()), None);
        for forced in [file, memory] {
            let forced = RunRequest {
                force: true,
                ..forced
            };
            assert_eq!(message(forced), None);
        }
        Ok(())
    }
}
