//! The scenario file of docs/SCENARIO.md: serde types with the defaults of LAW §8 (Example 1),
//! `--set` overrides and validation into a [`Setup`] the simulator runs.

use std::path::Path;

pub use controller_core::SchemeName;
use controller_core::{
    Agent, ConfigError, ControllerConfig, ControllerSection, Param, QuantizerSection, SafetySection,
};
use serde::{Deserialize, Serialize};

use crate::{
    clock::{ClockPlan, ClockSpec},
    faults::{FaultSchedule, FaultsSpec},
    graph::{Graph, GraphSpec, MAX_NEIGHBOURS},
    leader::Leader,
    metrics::spec::MetricsSpec,
    network::{
        node::{self as node_section, NodeSpec},
        spec::{self as network, NetworkSpec},
    },
    plant::{with_sizes, PlantModel, PlantSpec},
};
use consensus_plot::{
    error::{Error, Problems, Result},
    figure::{spec::FiguresSpec, Output},
};

/// A whole scenario as written in TOML; every key is optional (docs/SCENARIO.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Name reported in `summary.json`.
    pub name: String,
    /// `[simulation]`.
    pub simulation: Simulation,
    /// `[graph]`.
    pub graph: GraphSpec,
    /// `[leader]`.
    pub leader: Leader,
    /// `[plant]`.
    pub plant: PlantSpec,
    /// `[controller]`.
    pub controller: ControllerSpec,
    /// `[quantizer]`.
    pub quantizer: QuantizerSpec,
    /// `[faults]`.
    pub faults: FaultsSpec,
    /// `[network]` (added by this project: `docs/NETWORK.md`); left out of `check` when ideal.
    #[serde(skip_serializing_if = "NetworkSpec::is_default")]
    pub network: NetworkSpec,
    /// `[node]` (the firmware nodes' identifiers, heartbeat, safe state: `docs/NETWORK.md`);
    /// left out of `check` when it is the default.
    #[serde(skip_serializing_if = "NodeSpec::is_default")]
    pub node: NodeSpec,
    /// `[safety]` (SCENARIO.md additions; `docs/DEVIATIONS.md` §3); left out of `check` when
    /// it is the default.
    #[serde(skip_serializing_if = "SafetySpec::is_default")]
    pub safety: SafetySpec,
    /// `[metrics]` (settling dwell, window metrics); left out of `check` when absent.
    #[serde(skip_serializing_if = "MetricsSpec::is_default")]
    pub metrics: MetricsSpec,
    /// `[clock]` (docs/CLOCKS.md); left out of `check` when absent.
    #[serde(skip_serializing_if = "ClockSpec::is_default")]
    pub clock: ClockSpec,
    /// `[figures]` (formats, print size, time window); left out of `check` when absent.
    #[serde(skip_serializing_if = "FiguresSpec::is_default")]
    pub figures: FiguresSpec,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            name: "scenario".into(),
            simulation: Simulation::default(),
            graph: GraphSpec::default(),
            leader: Leader::default(),
            plant: PlantSpec::default(),
            controller: ControllerSpec::default(),
            quantizer: QuantizerSpec::default(),
            faults: FaultsSpec::default(),
            network: NetworkSpec::default(),
            node: NodeSpec::default(),
            safety: SafetySpec::default(),
            metrics: MetricsSpec::default(),
            clock: ClockSpec::default(),
            figures: FiguresSpec::default(),
        }
    }
}

/// `[simulation]`: sampling, horizon and the plant integrator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Simulation {
    /// Controller sample period `h` \[s\] (LAW §6).
    pub h: f64,
    /// Horizon \[s\].
    pub t_end: f64,
    /// RK4 plant substeps per sample.
    pub substeps: u32,
    /// Band `b` of `settling_time` (LAW §11).
    pub settle_band: f64,
    /// `|x| >` this (or non-finite) is divergence.
    pub divergence_bound: f64,
}

impl Default for Simulation {
    fn default() -> Self {
        Self {
            h: Param::H.default_f64(),
            t_end: 10.0,
            substeps: 4,
            settle_band: 0.05,
            divergence_bound: 1e6,
        }
    }
}

/// `[controller]` (controller-core's section, read in `f64`).
pub type ControllerSpec = ControllerSection<f64, Vec<f64>>;
/// `[quantizer]`.
pub type QuantizerSpec = QuantizerSection<f64>;
/// `[safety]`.
pub type SafetySpec = SafetySection<f64>;

/// A scenario checked and resolved: everything the simulator needs.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The scenario as resolved (defaults filled, overrides applied).
    pub scenario: Scenario,
    /// The validated graph.
    pub graph: Graph,
    /// The plant model.
    pub plant: PlantModel,
    /// Initial states, one per agent.
    pub x0: Vec<Vec<f64>>,
    /// The actuator fault schedule (empty when faults are off).
    pub faults: FaultSchedule,
    /// Number of samples `K = round(t_end / h)`.
    pub samples: u64,
    /// The followers' clocks; `None` when every follower samples at `k h` (no `[clock]`, or
    /// all of it zero with `sync = "none"`).
    pub clocks: Option<ClockPlan>,
}

impl Setup {
    /// Number of agents.
    pub fn agents(&self) -> usize {
        self.graph.len()
    }

    /// State order `n`.
    pub fn n(&self) -> usize {
        self.plant.n()
    }

    /// Actuators per agent `m`.
    pub fn m(&self) -> usize {
        self.plant.m()
    }

    /// How figures are written (`[figures]`, checked by [`validate`]).
    pub fn figures(&self) -> Output {
        self.scenario
            .figures
            .output(self.scenario.simulation.t_end)
            .unwrap_or_default()
    }

    /// The scheme as the paper names it, "predefined-time (proposed)" or "prescribed-time
    /// \[39\]": the words figures and tables use for a run instead of the scenario's name.
    pub fn scheme_name(&self) -> &'static str {
        match self.scenario.controller.scheme {
            SchemeName::PredefinedTime => "predefined-time (proposed)",
            SchemeName::PrescribedTime => "prescribed-time [39]",
        }
    }

    /// The title of the run's figures: the scheme and its time parameter, e.g.
    /// "predefined-time (proposed), Tₛ = 2 s" (never the scenario's name, which is a file-like
    /// identifier).
    pub fn figure_title(&self) -> String {
        let c = &self.scenario.controller;
        match c.scheme {
            SchemeName::PredefinedTime => format!("{}, Tₛ = {} s", self.scheme_name(), c.ts),
            SchemeName::PrescribedTime => format!(
                "{}, T = {} s",
                self.scheme_name(),
                c.t_prescribed.unwrap_or(c.ts)
            ),
        }
    }

    /// The predefined settling time `2 T_s`.
    pub fn predefined_time(&self) -> f64 {
        2.0 * self.scenario.controller.ts
    }

    /// Every agent's controller configuration, in agent order.
    pub fn controller_configs<const N: usize>(&self) -> Result<Vec<ControllerConfig<N>>> {
        (0..self.agents())
            .map(|i| self.controller_config::<N>(i))
            .collect()
    }

    /// Validates every agent's controller configuration (as `Controller::new` will).
    pub fn check_controllers(&self) -> Result<()> {
        with_sizes!(self.n(), self.m(), check_controllers_of(self, true))
    }

    /// The controller configuration of agent `i` (0-based), for state order `N`.
    pub fn controller_config<const N: usize>(&self, i: usize) -> Result<ControllerConfig<N>> {
        let mut problems = Problems::default();
        let cfg = self.controller_layout::<N>(i, Some(i), &mut problems);
        problems.finish(cfg)
    }

    /// Agent `i`'s configuration with the default in place of each value whose layout is
    /// wrong, those problems added to `problems` (for `agent`; `None`: every agent).
    fn controller_layout<const N: usize>(
        &self,
        i: usize,
        agent: Option<usize>,
        problems: &mut Problems,
    ) -> ControllerConfig<N> {
        let s = &self.scenario;
        let a = Agent {
            h: s.simulation.h as f32,
            neighbour_count: self.graph.neighbours(i).len(),
            pinned: self.graph.pinned(i),
        };
        let (cfg, errors) =
            ControllerConfig::from_sections_all(a, &s.controller, &s.quantizer, &s.safety);
        for e in errors {
            problems.push(Error::invalid(
                config_error_key(&e, agent.unwrap_or(0), false),
                e,
            ));
        }
        cfg
    }
}

/// [`Setup::check_controllers`] for state order `N` and `M` actuators.
/// Messages name the agent when `per_agent`.
fn check_controllers_of<const N: usize, const M: usize>(
    setup: &Setup,
    per_agent: bool,
) -> Result<()> {
    let safety = &setup.scenario.safety;
    let mut problems = Problems::default();
    for i in 0..setup.agents() {
        let cfg = setup.controller_layout::<N>(i, per_agent.then_some(i), &mut problems);
        check_controller(setup, &cfg, per_agent.then_some(i), &mut problems);
        if cfg.safety.is_none() {
            // `[safety]` is checked whether on or off, so a typo does not wait for the day it
            // is switched on.
            let on = ControllerConfig {
                safety: Some(safety.settings()),
                ..cfg
            };
            check_controller(setup, &on, per_agent.then_some(i), &mut problems);
        }
    }
    problems.finish(())
}

/// Every problem `Controller::new` would find in agent `i`'s (0-based) configuration, each
/// named by its scenario key; `None`: the configuration stands for every agent.
fn check_controller<const N: usize>(
    setup: &Setup,
    cfg: &ControllerConfig<N>,
    agent: Option<usize>,
    problems: &mut Problems,
) {
    for e in cfg.errors(MAX_NEIGHBOURS) {
        problems.push(config_problem(setup, &e, agent));
    }
}

/// A controller-core error of agent `agent` (0-based; `None`: every agent) named by its
/// scenario key, with the value the scenario gives it.
fn config_problem(setup: &Setup, e: &ConfigError, agent: Option<usize>) -> Error {
    let auto_gains = setup.scenario.controller.c1.is_none();
    let key = config_error_key(e, agent.unwrap_or(0), auto_gains);
    let why = if key == "controller.ts" && auto_gains {
        " (the gains c1, c2 of LAW §3 computed from ts, zeta, p, eta, tau)".to_string()
    } else {
        scenario_value(&setup.scenario, e.param(), e.step())
            .filter(|_| key.starts_with(e.param().key()))
            .map_or_else(String::new, |v| format!(" (got {v})"))
    };
    let whose = agent.map_or_else(String::new, |i| format!(" (agent {})", i + 1));
    Error::invalid(key, format!("{e}{why}{whose}"))
}

/// The value the scenario gives `param` (entry `step`, 1-based, of a per-step one), as TOML.
fn scenario_value(scenario: &Scenario, param: Param, step: Option<u8>) -> Option<toml::Value> {
    let (section, name) = param.key().split_once('.')?;
    let table = toml::Value::try_from(scenario).ok()?;
    let v = table.get(section)?.get(name)?;
    match step {
        Some(j) => v.get(usize::from(j).checked_sub(1)?).cloned(),
        None => Some(v.clone()),
    }
}

/// The scenario key behind a controller-core [`ConfigError`] of agent `i` (0-based): the
/// controller names its [`Param`] (whose key is [`Param::key`]) and the step of a per-step one.
fn config_error_key(e: &ConfigError, i: usize, auto_gains: bool) -> String {
    let key = match e.param() {
        // Computed gains out of range: the user wrote ts (and zeta, p, eta, tau).
        Param::C1 | Param::C2 if auto_gains => Param::Ts.key(),
        Param::Neighbours | Param::Pinned => return format!("graph.neighbours[{}]", i + 1),
        p => p.key(),
    };
    match e.step() {
        Some(j) => format!("{key}[{j}]"),
        None => key.to_string(),
    }
}

/// Reads a scenario file, applies `--set key=value` overrides and validates it.
pub fn load(path: &Path, sets: &[String]) -> Result<Setup> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Error::invalid(
                format!("scenario file {}", path.display()),
                "not found",
            ))
        }
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => {
            return Err(Error::invalid(
                format!("scenario file {}", path.display()),
                "not UTF-8 text",
            ))
        }
        // Bad input, like a missing file (exit 2); I/O errors are reserved for files that exist.
        Err(_) if path.is_dir() => {
            return Err(Error::invalid(
                format!("scenario file {}", path.display()),
                "is a directory, not a scenario file",
            ))
        }
        Err(e) => return Err(Error::io(path, e)),
    };
    parse(&text, sets)
}

/// Parses scenario text with overrides and validates it.
pub fn parse(text: &str, sets: &[String]) -> Result<Setup> {
    let mut table = parse_table(text)?;
    let mut problems = Problems::default();
    for s in sets {
        problems.take(apply_set(&mut table, s));
    }
    problems.finish(())?;
    from_table(table)
}

/// Scenario text as a TOML table, before overrides (a syntax error names line and column).
pub fn parse_table(text: &str) -> Result<toml::Table> {
    text.parse().map_err(|e: toml::de::Error| {
        let at = e
            .span()
            .map(|s| {
                let (line, col) = line_col(text, s.start);
                format!(" at line {line}, column {col}")
            })
            .unwrap_or_default();
        Error::Invalid(format!("TOML syntax{at}: {}", e.message()))
    })
}

/// A scenario table (overrides applied) deserialized and validated.
///
/// A section that does not deserialize is reported with the problems of the others, which are
/// validated with it at its default; the agent-, plant- and time-dependent checks need
/// `[graph]`, `[plant]` and `[simulation]`, so a problem there is reported alone.
pub fn from_table(table: toml::Table) -> Result<Setup> {
    let written = Written::Table(written_steps(&table));
    let whole = match deserialize(toml::Value::Table(table.clone())) {
        Ok(s) => return validate_plant(s, None, &written),
        Err(e) => e,
    };
    let mut problems = Problems::default();
    let mut good = toml::Table::new();
    let mut failed = Vec::new();
    for (k, v) in table {
        let one = toml::Table::from_iter([(k.clone(), v.clone())]);
        match deserialize(toml::Value::Table(one)) {
            Ok(_) => {
                good.insert(k, v);
            }
            Err(e) => {
                problems.push(e);
                failed.push(k);
            }
        }
    }
    let basic = ["graph", "plant", "simulation"];
    if problems.is_empty() {
        return Err(whole);
    }
    if !failed.iter().any(|k| basic.contains(&k.as_str())) {
        let rest =
            deserialize(toml::Value::Table(good)).and_then(|s| validate_plant(s, None, &written));
        if let Err(e) = rest {
            for p in e.problems() {
                let m = p.message();
                if !failed
                    .iter()
                    .any(|k| m.starts_with(&format!("{k}.")) || m.starts_with(&format!("{k}:")))
                {
                    problems.push(p.clone());
                }
            }
        }
    }
    Err(problems.into_error().unwrap_or(whole))
}

/// A scenario table deserialized; the error names the key (1-based indices).
fn deserialize(value: toml::Value) -> Result<Scenario> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = one_based(&e.path().to_string());
        let msg = e.inner().message().to_string();
        if path == "." {
            Error::Invalid(msg)
        } else {
            Error::invalid(path, msg)
        }
    })
}

/// Rewrites serde's 0-based `[k]` indices as 1-based, like every other message.
pub fn one_based(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    let mut rest = path;
    while let Some(open) = rest.find('[') {
        out.push_str(&rest[..=open]);
        rest = &rest[open + 1..];
        let close = rest.find(']').unwrap_or(rest.len());
        match rest[..close].parse::<usize>() {
            Ok(k) => out.push_str(&(k + 1).to_string()),
            Err(_) => out.push_str(&rest[..close]),
        }
        rest = &rest[close..];
    }
    out.push_str(rest);
    out
}

/// 1-based line and column of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Applies one `key=value` override: a dotted key (array entries with 1-based `[i]`, e.g.
/// `plant.x0[2][1]`) and a TOML value (a bare word is a string).
pub fn apply_set(table: &mut toml::Table, set: &str) -> Result<()> {
    let Some((key, raw)) = set.split_once('=') else {
        return Err(Error::invalid(format!("--set {set}"), "expected key=value"));
    };
    let key = key.trim();
    let raw = raw.trim();
    let value = match format!("v = {raw}").parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_)
            if !raw.is_empty() && raw.chars().all(|c| c.is_alphanumeric() || "-_".contains(c)) =>
        {
            toml::Value::String(raw.into())
        }
        Err(e) => {
            return Err(Error::invalid(
                format!("--set {key}"),
                format!("not a TOML value: {}", e.message()),
            ))
        }
    };
    if key.contains('[') {
        return set_indexed(table, key, value);
    }
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(Error::invalid(format!("--set {key}"), "empty key segment"));
    }
    let mut cur = table;
    for (i, p) in parts.iter().enumerate() {
        if i + 1 == parts.len() {
            cur.insert((*p).to_string(), value);
            return Ok(());
        }
        let entry = cur
            .entry((*p).to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = match entry {
            toml::Value::Table(t) => t,
            _ => {
                return Err(Error::invalid(
                    format!("--set {key}"),
                    format!("`{}` is not a table", parts[..=i].join(".")),
                ))
            }
        };
    }
    Ok(())
}

/// One step of a key path: a table key, then 0-based array indices.
#[derive(Debug, Clone, PartialEq)]
struct Segment {
    name: String,
    index: Vec<usize>,
}

/// A scenario key: `controller.ts`, or with 1-based array entries `plant.x0[2][1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyPath {
    text: String,
    segments: Vec<Segment>,
}

impl KeyPath {
    /// Parses a key; `what` names it in messages (e.g. `axis[1].key`).
    pub fn parse(text: &str, what: &str) -> Result<Self> {
        let bad = |why: &str| Error::invalid(what, format!("`{text}`: {why}"));
        let mut segments = Vec::new();
        for part in text.split('.') {
            let (name, mut rest) = match part.find('[') {
                Some(i) => (&part[..i], &part[i..]),
                None => (part, ""),
            };
            if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
                return Err(bad("expected dotted names with optional [i] indices"));
            }
            let mut index = Vec::new();
            while !rest.is_empty() {
                let close = rest
                    .find(']')
                    .filter(|_| rest.starts_with('['))
                    .ok_or_else(|| bad("unbalanced [ ]"))?;
                let i: usize = rest[1..close]
                    .parse()
                    .ok()
                    .filter(|&i| i >= 1)
                    .ok_or_else(|| bad("indices are integers from 1"))?;
                index.push(i - 1);
                rest = &rest[close + 1..];
            }
            segments.push(Segment {
                name: name.into(),
                index,
            });
        }
        Ok(Self {
            text: text.into(),
            segments,
        })
    }

    /// The key as written.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    fn indexed(&self) -> bool {
        self.segments.iter().any(|s| !s.index.is_empty())
    }

    /// Sets the key in a scenario table, exactly as `--set key=value` does.
    pub fn apply(&self, table: &mut toml::Table, value: &toml::Value) -> Result<()> {
        if self.indexed() {
            self.set_entry(table, &default_table()?, value)
        } else {
            apply_set(table, &format!("{}={value}", self.text))
        }
    }

    /// Sets an array entry in place; an array the table leaves out is first copied from
    /// `defaults`.
    fn set_entry(
        &self,
        table: &mut toml::Table,
        defaults: &toml::Table,
        value: &toml::Value,
    ) -> Result<()> {
        let missing = || Error::invalid(&self.text, "no such entry in the scenario");
        let mut cur = table;
        let mut def = Some(defaults);
        for (i, seg) in self.segments.iter().enumerate() {
            let last = i + 1 == self.segments.len();
            let dflt = def.and_then(|d| d.get(&seg.name));
            if !cur.contains_key(&seg.name) {
                let v = match dflt {
                    Some(v) if !seg.index.is_empty() => v.clone(),
                    _ if seg.index.is_empty() && !last => toml::Value::Table(toml::Table::new()),
                    _ => return Err(missing()),
                };
                cur.insert(seg.name.clone(), v);
            }
            let mut slot = cur.get_mut(&seg.name).ok_or_else(missing)?;
            let mut dslot = dflt;
            for &k in &seg.index {
                let len = slot.as_array().map(Vec::len);
                slot = match slot {
                    toml::Value::Array(a) => a.get_mut(k).ok_or_else(|| {
                        Error::invalid(
                            &self.text,
                            format!(
                                "index {} out of range ({} entries)",
                                k + 1,
                                len.unwrap_or(0)
                            ),
                        )
                    })?,
                    _ => return Err(Error::invalid(&self.text, "not an array")),
                };
                dslot = dslot.and_then(|d| d.as_array()).and_then(|a| a.get(k));
            }
            if last {
                *slot = value.clone();
                return Ok(());
            }
            cur = slot
                .as_table_mut()
                .ok_or_else(|| Error::invalid(&self.text, "not a table"))?;
            def = dslot.and_then(toml::Value::as_table);
        }
        Ok(())
    }
}

/// The default scenario as a table (the arrays an indexed key falls back to).
fn default_table() -> Result<toml::Table> {
    match toml::Value::try_from(Scenario::default()) {
        Ok(toml::Value::Table(t)) => Ok(t),
        _ => Err(Error::Invalid(
            "the default scenario cannot be written as TOML".into(),
        )),
    }
}

/// `--set` of a key with 1-based array indices (`plant.x0[2][1]=0.5`).
pub fn set_indexed(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
    KeyPath::parse(key, &format!("--set {key}"))?.set_entry(table, &default_table()?, &value)
}

fn positive(v: f64, key: &str) -> Result<()> {
    if !v.is_finite() || v <= 0.0 {
        return Err(Error::invalid(
            key,
            format!("must be a finite number > 0 (got {v})"),
        ));
    }
    Ok(())
}

/// Checks the scenario and resolves graph, plant, initial states and faults.
pub fn validate(scenario: Scenario) -> Result<Setup> {
    validate_plant(scenario, None, &Written::Unknown)
}

/// [`validate`] for a plant given in Rust of `n` states and `m` actuators (run it with
/// `host_sim::run::run_plant`); of `[plant]` only `x0` is read.
pub fn validate_with_plant(scenario: Scenario, n: usize, m: usize) -> Result<Setup> {
    validate_plant(
        scenario,
        Some(PlantModel::Library { n, m }),
        &Written::Unknown,
    )
}

/// Which per-step controller arrays the user wrote (the others take their default per step).
enum Written {
    /// Those of this list, read from the scenario table.
    Table(Vec<Param>),
    /// Not known (a [`Scenario`] built in code): an array equal to the default is taken as
    /// left out.
    Unknown,
}

/// The per-step controller parameters, whose defaults are written for n = 2.
const PER_STEP: [Param; 4] = [Param::ACheck, Param::PhiLow, Param::PhiUp, Param::EpsBar];

/// The per-step parameters the scenario table sets.
fn written_steps(table: &toml::Table) -> Vec<Param> {
    let controller = table.get("controller").and_then(toml::Value::as_table);
    PER_STEP
        .into_iter()
        .filter(|p| controller.is_some_and(|c| c.contains_key(p.name())))
        .collect()
}

fn validate_plant(
    mut scenario: Scenario,
    plant: Option<PlantModel>,
    written: &Written,
) -> Result<Setup> {
    scenario.graph = scenario.graph.or_example();
    let mut problems = Problems::default();
    let sim = &scenario.simulation;
    let samples = problems.take(check_simulation(sim));
    // The leader is checked over [0, t_end], the network and the faults also in steps of h.
    let horizon = positive(sim.t_end, "").is_ok();
    let timed = horizon && positive(sim.h, "").is_ok();
    if horizon {
        problems.take(scenario.leader.check(sim.t_end));
        problems.take(scenario.figures.output(sim.t_end));
    }
    // [controller], [quantizer] and [safety] are checked by `Controller::new` (check_controllers).
    let graph = problems.take(Graph::from_spec(&scenario.graph));
    let plant = match plant {
        Some(p) => Some(p),
        None => problems.take(PlantModel::from_spec(&scenario.plant)),
    };
    if let Some(plant) = &plant {
        fit_defaults(&mut scenario, plant.n(), plant.m(), written);
    }
    let sim = &scenario.simulation;
    let x0_default = scenario.plant.x0 == PlantSpec::default().x0
        && scenario.plant.x0_min.is_none()
        && scenario.plant.x0_max.is_none();
    let x0 = match (&graph, &plant) {
        (Some(_), Some(p)) if x0_default && p.n() != DEFAULT_X0_ORDER => {
            problems.push(Error::invalid(
                "plant.x0",
                format!(
                    "not given, and the default (Example 1's initial states, n = \
                     {DEFAULT_X0_ORDER}) does not fit this plant's n = {}: write plant.x0 (one \
                     row of n values per agent) or plant.x0_min and plant.x0_max",
                    p.n()
                ),
            ));
            None
        }
        (Some(g), Some(p)) => problems.take(scenario.plant.initial_states(
            g.len(),
            p.n(),
            sim.divergence_bound,
        )),
        _ => None,
    };
    if let (Some(g), true) = (&graph, timed) {
        problems.take(network::validate(
            &scenario.network,
            g.len(),
            sim.h,
            sim.t_end,
        ));
        problems.take(node_section::check_watchdog_timeout(&scenario.node, sim.h));
    }
    if let Some(g) = &graph {
        problems.take(node_section::validate(&scenario.node, g.len()));
    }
    if let Some(p) = &plant {
        let (n, m) = (p.n(), p.m());
        if scenario.network.kind != network::NetworkKind::Ideal && (n, m) != (2, 2) {
            problems.push(Error::invalid(
                "network.kind",
                format!(
                    "\"{}\" runs the node firmware, built for n = 2, m = 2 (this plant: n = {n}, m = {m})",
                    scenario.network.kind.as_str()
                ),
            ));
        }
    }
    let faults = match (&graph, &plant) {
        (Some(g), Some(p)) if timed => {
            problems.take(scenario.faults.schedule(g.len(), p.m(), sim.t_end))
        }
        _ => None,
    };
    problems.take(scenario.metrics.check());
    let clocks = match &graph {
        Some(g) if timed && scenario.clock.is_active() => {
            if scenario.network.kind == network::NetworkKind::Pil {
                problems.push(Error::invalid(
                    "clock",
                    "network.kind = \"pil\" paces every emulated node by the host's sample grid, \
                     so a node cannot sample on its own clock: leave [clock] out (or all zero with \
                     sync = \"none\"), or use kind = \"can\"",
                ));
                None
            } else {
                problems.take(scenario.clock.plan(g.len(), sim.h))
            }
        }
        _ => None,
    };
    if scenario.plant.x0_drawn() {
        // Drawn from the box: the resolved scenario shows the box, not Example 1's rows.
        scenario.plant.x0.clear();
    }
    let Some(plant) = plant else {
        // The controller checks need the state order n.
        return Err(problems
            .into_error()
            .unwrap_or_else(|| Error::Invalid("the plant is invalid".into())));
    };
    // Without a usable graph the controller sections are still checked, for one agent that
    // hears the leader: the problems that do not depend on the topology.
    let per_agent = graph.is_some();
    let graph = match graph {
        Some(g) => g,
        None => Graph::from_spec(&GraphSpec {
            neighbours: Some(vec![Vec::new()]),
            pinned: vec![1],
            ..GraphSpec::default()
        })?,
    };
    let faults = faults.unwrap_or_else(|| FaultSchedule::healthy(graph.len(), plant.m()));
    let setup = Setup {
        scenario,
        graph,
        plant,
        x0: x0.unwrap_or_default(),
        faults,
        samples: samples.unwrap_or(1),
        clocks,
    };
    problems.take(with_sizes!(
        setup.n(),
        setup.m(),
        check_controllers_of(&setup, per_agent)
    ));
    problems.finish(setup)
}

/// State order of the default `plant.x0` (Example 1).
const DEFAULT_X0_ORDER: usize = 2;

/// `[simulation]`: every key in its range; the number of samples `K`.
fn check_simulation(sim: &Simulation) -> Result<u64> {
    let mut problems = Problems::default();
    problems.take(positive(sim.h, "simulation.h"));
    problems.take(positive(sim.t_end, "simulation.t_end"));
    if sim.substeps == 0 || sim.substeps > 10_000 {
        problems.push(Error::invalid(
            "simulation.substeps",
            format!("must lie in 1..=10000 (got {})", sim.substeps),
        ));
    }
    problems.take(positive(sim.settle_band, "simulation.settle_band"));
    problems.take(positive(
        sim.divergence_bound,
        "simulation.divergence_bound",
    ));
    if sim.divergence_bound > f64::from(f32::MAX) {
        // Above it the controllers (f32) would see an infinite state and hold their commands
        // while the run still counted as not diverged.
        problems.push(Error::invalid(
            "simulation.divergence_bound",
            format!(
                "must not exceed f32::MAX = {:e}, the controller's range (got {:e})",
                f32::MAX,
                sim.divergence_bound
            ),
        ));
    }
    if !problems.is_empty() {
        return problems.finish(0);
    }
    let samples_f = (sim.t_end / sim.h).round();
    if samples_f < 1.0 {
        return Err(Error::invalid(
            "simulation.t_end",
            "shorter than one sample period h",
        ));
    }
    if samples_f > 1e10 {
        return Err(Error::invalid(
            "simulation.h",
            format!("t_end / h = {samples_f:e} samples is too many"),
        ));
    }
    if (sim.h as f32) <= 0.0 {
        return Err(Error::invalid(
            "simulation.h",
            "underflows f32 (the controller's type)",
        ));
    }
    Ok(samples_f as u64)
}

/// Defaults written for Example 1 (n = 2, m = 2) fitted to a plant of `n` states and `m`
/// actuators: per-step arrays left out get one default entry per step, and the default fault
/// rules keep only the rules whose actuator the plant has.
fn fit_defaults(scenario: &mut Scenario, n: usize, m: usize, written: &Written) {
    let c = &mut scenario.controller;
    for (param, steps) in [
        (Param::ACheck, &mut c.a_check),
        (Param::PhiLow, &mut c.phi_low),
        (Param::PhiUp, &mut c.phi_up),
        (Param::EpsBar, &mut c.eps_bar),
    ] {
        let d = param.default_f64();
        let left_out = match written {
            Written::Table(w) => !w.contains(&param),
            Written::Unknown => {
                steps.len() == ControllerSpec::default().a_check.len()
                    && steps.iter().all(|&v| v == d)
            }
        };
        if left_out && steps.len() != n {
            *steps = vec![d; n];
        }
    }
    scenario.faults.fit_default_rules(m);
}

/// The resolved scenario as TOML (what `check` prints).
pub fn to_toml(s: &Scenario) -> String {
    toml::to_string(s).unwrap_or_else(|e| format!("# cannot print the scenario: {e}\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_indices_become_one_based() {
        assert_eq!(one_based("faults.rule[0].agents"), "faults.rule[1].agents");
        assert_eq!(one_based("plant.x0[3][0]"), "plant.x0[4][1]");
        assert_eq!(one_based("simulation.h"), "simulation.h");
    }

    #[test]
    fn set_takes_dotted_keys_and_toml_values() -> Result<()> {
        let mut t = toml::Table::new();
        apply_set(&mut t, "controller.ts=1")?;
        apply_set(&mut t, "plant.model=manipulator")?;
        apply_set(&mut t, "plant.x0=[[0,0],[1,1]]")?;
        assert_eq!(t["controller"]["ts"].as_integer(), Some(1));
        assert_eq!(t["plant"]["model"].as_str(), Some("manipulator"));
        assert_eq!(t["plant"]["x0"].as_array().map(Vec::len), Some(2));
        assert!(apply_set(&mut t, "controller.ts.x=1").is_err());
        assert!(apply_set(&mut t, "novalue").is_err());
        Ok(())
    }

    #[test]
    fn defaults_are_example1() -> Result<()> {
        let s = parse("", &[])?;
        assert_eq!(s.agents(), 4);
        assert_eq!(s.samples, 10_000);
        assert_eq!(s.predefined_time(), 4.0);
        assert_eq!(s.graph.neighbours(3), &[0, 2]);
        Ok(())
    }

    fn table(s: &str) -> toml::Table {
        s.parse().unwrap_or_default()
    }

    #[test]
    fn indexed_keys_are_one_based_and_fill_from_defaults() -> Result<()> {
        let defaults = table("[plant]\nx0 = [[1.0, 2.0], [3.0, 4.0]]");
        let mut t = table("[plant]\nmodel = \"example1\"");
        KeyPath::parse("plant.x0[2][1]", "k")?.set_entry(
            &mut t,
            &defaults,
            &toml::Value::Float(9.0),
        )?;
        assert_eq!(t["plant"]["x0"][1][0].as_float(), Some(9.0));
        assert_eq!(t["plant"]["x0"][0][1].as_float(), Some(2.0));
        let out = KeyPath::parse("plant.x0[3][1]", "k")?.set_entry(
            &mut t,
            &defaults,
            &toml::Value::Float(0.0),
        );
        assert!(out.is_err_and(|e| e.to_string().contains("index 3 out of range")));
        assert!(KeyPath::parse("plant.x0[0]", "k").is_err());
        assert!(KeyPath::parse("plant..x0", "k").is_err());
        assert!(KeyPath::parse("plant.x0[1", "k").is_err());
        Ok(())
    }
}
