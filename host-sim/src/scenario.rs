//! The scenario file of docs/SCENARIO.md: serde types with the defaults of LAW §8 (Example 1),
//! `--set` overrides and validation into a [`Setup`] the simulator runs.

use std::{fmt, path::Path};

use controller_core::{
    BaselineConfig, ConfigError, Controller, ControllerConfig, GainSelection, QuantizerConfig,
    QuantizerDirection, SafetyConfig, SchemeConfig,
};
use serde::{Deserialize, Serialize};

use crate::{
    error::{Error, Result},
    faults::{FaultSchedule, FaultsSpec},
    graph::{Graph, GraphSpec, MAX_NEIGHBOURS},
    leader::Leader,
    metrics::spec::MetricsSpec,
    network::spec::{self as network, NetworkSpec},
    plant::{with_sizes, PlantModel, PlantSpec},
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
    /// `[safety]` (SCENARIO.md additions; `docs/DEVIATIONS.md` §3); left out of `check` when
    /// it is the default.
    #[serde(skip_serializing_if = "SafetySpec::is_default")]
    pub safety: SafetySpec,
    /// `[metrics]` (settling dwell, window metrics); left out of `check` when absent.
    #[serde(skip_serializing_if = "MetricsSpec::is_default")]
    pub metrics: MetricsSpec,
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
            safety: SafetySpec::default(),
            metrics: MetricsSpec::default(),
        }
    }
}

/// `[safety]`: command limits, anti-windup and recovery of `controller-core`'s
/// [`controller_core::safety`]. Off by default: the paper's law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetySpec {
    /// On: limits, conditional integration, bumpless re-entry, differentiator re-seeding.
    pub enabled: bool,
    /// Limit of `|u|` per actuator before the quantizer [command units]; absent: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_max: Option<f64>,
    /// Limit of `|du/dt|` [command units / s]; absent: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub du_max: Option<f64>,
    /// `v_r` [units of `y` / s]: a returning neighbour / leader value's jump is removed at
    /// this speed (`inf`: used at once).
    pub recovery_rate: f64,
    /// Jumps up to this size [units of `y`] re-enter at once.
    pub recovery_jump: f64,
}

impl Default for SafetySpec {
    fn default() -> Self {
        Self {
            enabled: false,
            u_max: None,
            du_max: None,
            // `SafetyConfig::default()`'s values, written as f64 so that `check` prints them
            // as written (tested in `safety_defaults_match_the_controller`).
            recovery_rate: 1.0,
            recovery_jump: 0.05,
        }
    }
}

impl SafetySpec {
    /// The default (off, nothing set).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The controller's settings, `None` when off.
    pub fn config(&self) -> Option<SafetyConfig> {
        self.enabled.then(|| SafetyConfig {
            u_max: self.u_max.map(|v| v as f32),
            du_max: self.du_max.map(|v| v as f32),
            recovery_rate: self.recovery_rate as f32,
            recovery_jump: self.recovery_jump as f32,
        })
    }
}

/// `[simulation]`: sampling, horizon and the plant integrator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Simulation {
    /// Controller sample period `h` [s] (LAW §6).
    pub h: f64,
    /// Horizon [s].
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
            h: 1e-3,
            t_end: 10.0,
            substeps: 4,
            settle_band: 0.05,
            divergence_bound: 1e6,
        }
    }
}

/// Which control law (LAW §5 or the §10 baseline).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeName {
    /// The paper's predefined-time law.
    #[default]
    PredefinedTime,
    /// The LAW §10 prescribed-time baseline.
    PrescribedTime,
}

impl fmt::Display for SchemeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::PredefinedTime => "predefined-time",
            Self::PrescribedTime => "prescribed-time",
        })
    }
}

/// `[controller]`: the design values of LAW §3–§5, shared by all agents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerSpec {
    /// Proposed law or baseline.
    pub scheme: SchemeName,
    /// `T_s` [s].
    pub ts: f64,
    /// `ζ`.
    pub zeta: f64,
    /// `ǎ_j`, one per step.
    pub a_check: Vec<f64>,
    /// `p`.
    pub p: f64,
    /// `η`.
    pub eta: f64,
    /// `τ`.
    pub tau: f64,
    /// `γ`.
    pub gamma: f64,
    /// MTN order.
    pub mtn_order: u32,
    /// `φ_low_j`.
    pub phi_low: Vec<f64>,
    /// `φ_up_j`.
    pub phi_up: Vec<f64>,
    /// `ε̄_j`.
    pub eps_bar: Vec<f64>,
    /// `ℓ_1`.
    pub diff_l1: f64,
    /// `ℓ_2`.
    pub diff_l2: f64,
    /// `ϖ_0`.
    pub varpi0: f64,
    /// `κ` of `ϖ(t)`.
    pub varpi_decay: f64,
    /// `ϖ_min`.
    pub varpi_min: f64,
    /// `μ̂(0)`.
    pub mu0: f64,
    /// `ξ̂(0)`.
    pub xi0: f64,
    /// `λ̂(0)`.
    pub lambda0: f64,
    /// Projection bound of the three estimates.
    pub estimate_max: f64,
    /// Explicit `c_1` (with `c2`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub c1: Option<f64>,
    /// Explicit `c_2` (with `c1`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub c2: Option<f64>,
    /// Baseline `κ`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kappa: Option<f64>,
    /// Baseline `μ_max`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mu_max: Option<f64>,
    /// Baseline `T` (default `T_s`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t_prescribed: Option<f64>,
}

impl Default for ControllerSpec {
    fn default() -> Self {
        Self {
            scheme: SchemeName::PredefinedTime,
            ts: 2.0,
            zeta: 0.1,
            a_check: vec![90.0, 90.0],
            p: 80.0,
            eta: 50.0,
            tau: 50.0,
            gamma: 0.1,
            mtn_order: 2,
            phi_low: vec![1.0, 1.0],
            phi_up: vec![1.0, 1.0],
            eps_bar: vec![0.0, 0.0],
            diff_l1: 1.0,
            diff_l2: 1.0,
            varpi0: 0.1,
            varpi_decay: 0.7,
            varpi_min: 1e-6,
            mu0: 0.0,
            xi0: 0.0,
            lambda0: 1.0,
            estimate_max: 1e6,
            c1: None,
            c2: None,
            kappa: None,
            mu_max: None,
            t_prescribed: None,
        }
    }
}

/// Reading of the quantizer direction (LAW §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DirectionName {
    /// `sign(u_k − u_{k−1})`.
    #[default]
    Signed,
    /// `sign(|u_k| − |u_{k−1}|)`.
    Magnitude,
}

/// `[quantizer]`: the hysteresis quantizer of eq. (2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct QuantizerSpec {
    /// Off: actuators get `u` itself.
    pub enabled: bool,
    /// `ρ`.
    pub rho: f64,
    /// `u_min`.
    pub u_min: f64,
    /// Direction reading.
    pub direction: DirectionName,
}

impl Default for QuantizerSpec {
    fn default() -> Self {
        Self {
            enabled: true,
            rho: 0.9,
            u_min: 0.01,
            direction: DirectionName::Signed,
        }
    }
}

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
        with_sizes!(self.n(), self.m(), check_controllers_of(self))
    }

    /// The controller configuration of agent `i` (0-based), for state order `N`.
    pub fn controller_config<const N: usize>(&self, i: usize) -> Result<ControllerConfig<N>> {
        let c = &self.scenario.controller;
        let q = &self.scenario.quantizer;
        let arr = |v: &[f64], key: &str| -> Result<[f32; N]> {
            let mut a = [0.0f32; N];
            if v.len() != N {
                return Err(Error::invalid(
                    format!("controller.{key}"),
                    format!(
                        "expected {N} entries (one per step j = 1..n), got {}",
                        v.len()
                    ),
                ));
            }
            for (d, s) in a.iter_mut().zip(v) {
                *d = *s as f32;
            }
            Ok(a)
        };
        let gains = match (c.c1, c.c2) {
            (None, None) => GainSelection::Auto,
            (Some(c1), Some(c2)) => GainSelection::Explicit {
                c1: c1 as f32,
                c2: c2 as f32,
            },
            (Some(_), None) => {
                return Err(Error::invalid("controller.c2", "required when c1 is given"))
            }
            (None, Some(_)) => {
                return Err(Error::invalid("controller.c1", "required when c2 is given"))
            }
        };
        let scheme = match c.scheme {
            SchemeName::PredefinedTime => {
                for (k, v) in [
                    ("kappa", c.kappa),
                    ("mu_max", c.mu_max),
                    ("t_prescribed", c.t_prescribed),
                ] {
                    if v.is_some() {
                        return Err(Error::invalid(
                            format!("controller.{k}"),
                            "only for scheme = \"prescribed-time\"",
                        ));
                    }
                }
                SchemeConfig::PredefinedTime
            }
            SchemeName::PrescribedTime => {
                let d = BaselineConfig::default();
                SchemeConfig::PrescribedTime(BaselineConfig {
                    kappa: c.kappa.map_or(d.kappa, |v| v as f32),
                    mu_max: c.mu_max.map_or(d.mu_max, |v| v as f32),
                    t_prescribed: c.t_prescribed.map(|v| v as f32),
                })
            }
        };
        let graph = &self.graph;
        Ok(ControllerConfig {
            h: self.scenario.simulation.h as f32,
            neighbour_count: graph.neighbours(i).len(),
            pinned: graph.pinned(i),
            ts: c.ts as f32,
            zeta: c.zeta as f32,
            gains,
            a_check: arr(&c.a_check, "a_check")?,
            p: c.p as f32,
            eta: c.eta as f32,
            tau: c.tau as f32,
            gamma: c.gamma as f32,
            mtn_order: c.mtn_order as usize,
            phi_low: arr(&c.phi_low, "phi_low")?,
            phi_up: arr(&c.phi_up, "phi_up")?,
            eps_bar: arr(&c.eps_bar, "eps_bar")?,
            diff_l1: c.diff_l1 as f32,
            diff_l2: c.diff_l2 as f32,
            varpi0: c.varpi0 as f32,
            varpi_decay: c.varpi_decay as f32,
            varpi_min: c.varpi_min as f32,
            mu0: c.mu0 as f32,
            xi0: c.xi0 as f32,
            lambda0: c.lambda0 as f32,
            estimate_max: c.estimate_max as f32,
            quantizer: q.enabled.then_some(QuantizerConfig {
                rho: q.rho as f32,
                u_min: q.u_min as f32,
                direction: match q.direction {
                    DirectionName::Signed => QuantizerDirection::Signed,
                    DirectionName::Magnitude => QuantizerDirection::Magnitude,
                },
            }),
            scheme,
            safety: self.scenario.safety.config(),
        })
    }
}

/// [`Setup::check_controllers`] for state order `N` and `M` actuators.
fn check_controllers_of<const N: usize, const M: usize>(setup: &Setup) -> Result<()> {
    for i in 0..setup.agents() {
        let cfg = setup.controller_config::<N>(i)?;
        Controller::<N, M, MAX_NEIGHBOURS>::new(&cfg).map_err(|e| {
            let auto_gains = setup.scenario.controller.c1.is_none();
            let key = config_error_key(&e, i, auto_gains);
            let why = if key == "controller.ts" && auto_gains {
                " (the gains c1, c2 of LAW §3 computed from ts, zeta, p, eta, tau)"
            } else {
                ""
            };
            Error::invalid(key, format!("{e}{why} (agent {})", i + 1))
        })?;
    }
    Ok(())
}

/// The scenario key behind a controller-core [`ConfigError`] of agent `i` (0-based): the
/// controller names its own parameter, the user wrote a dotted key.
fn config_error_key(e: &ConfigError, i: usize, auto_gains: bool) -> String {
    let param = |p: &str| match p {
        "h" => "simulation.h".to_string(),
        // Computed gains out of range: the user wrote ts (and zeta, p, eta, tau).
        "c1" | "c2" if auto_gains => "controller.ts".to_string(),
        "rho" | "u_min" => format!("quantizer.{p}"),
        "u_max" | "du_max" | "recovery_rate" | "recovery_jump" => format!("safety.{p}"),
        p => format!("controller.{p}"),
    };
    match *e {
        ConfigError::NonFinite(p)
        | ConfigError::NonPositive(p)
        | ConfigError::Negative(p)
        | ConfigError::GainTooLarge(p)
        | ConfigError::DerivedOverflow(p) => param(p),
        ConfigError::ZetaOutOfRange => param("zeta"),
        ConfigError::NonPositiveTs => param("ts"),
        ConfigError::NonPositiveSamplePeriod => param("h"),
        ConfigError::RhoOutOfRange => param("rho"),
        ConfigError::NonPositiveUMin => param("u_min"),
        ConfigError::NonPositivePhiLow { step } | ConfigError::PhiLowAbovePhiUp { step } => {
            format!("controller.phi_low[{step}]")
        }
        ConfigError::ZeroACheck { step } => format!("controller.a_check[{step}]"),
        ConfigError::ZeroMtnOrder | ConfigError::MtnOrderTooLarge => param("mtn_order"),
        ConfigError::TooManyNeighbours | ConfigError::Isolated => {
            format!("graph.neighbours[{}]", i + 1)
        }
        ConfigError::VarpiMinOutOfRange => param("varpi_min"),
        ConfigError::InitialEstimateAboveMax => param("estimate_max"),
        ConfigError::MuMaxBelowOne => param("mu_max"),
        ConfigError::ZeroStateOrder => "plant.model".into(),
        ConfigError::UMaxNotAboveUMin => "safety.u_max".into(),
        _ => "controller".into(),
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
    for s in sets {
        apply_set(&mut table, s)?;
    }
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
pub fn from_table(table: toml::Table) -> Result<Setup> {
    let scenario: Scenario =
        serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
            let path = one_based(&e.path().to_string());
            let msg = e.inner().message().to_string();
            if path == "." {
                Error::Invalid(msg)
            } else {
                Error::invalid(path, msg)
            }
        })?;
    validate(scenario)
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

fn finite(v: f64, key: &str) -> Result<()> {
    if !v.is_finite() {
        return Err(Error::invalid(key, format!("must be finite (got {v})")));
    }
    Ok(())
}

/// Checks the scenario and resolves graph, plant, initial states and faults.
pub fn validate(scenario: Scenario) -> Result<Setup> {
    validate_plant(scenario, None)
}

/// [`validate`] for a plant given in Rust of `n` states and `m` actuators (run it with
/// [`crate::run::run_plant`]); of `[plant]` only `x0` is read.
pub fn validate_with_plant(scenario: Scenario, n: usize, m: usize) -> Result<Setup> {
    validate_plant(scenario, Some(PlantModel::Library { n, m }))
}

fn validate_plant(mut scenario: Scenario, plant: Option<PlantModel>) -> Result<Setup> {
    scenario.graph = scenario.graph.or_example();
    let sim = &scenario.simulation;
    positive(sim.h, "simulation.h")?;
    positive(sim.t_end, "simulation.t_end")?;
    if sim.substeps == 0 || sim.substeps > 10_000 {
        return Err(Error::invalid(
            "simulation.substeps",
            format!("must lie in 1..=10000 (got {})", sim.substeps),
        ));
    }
    positive(sim.settle_band, "simulation.settle_band")?;
    positive(sim.divergence_bound, "simulation.divergence_bound")?;
    if sim.divergence_bound > f64::from(f32::MAX) {
        // Above it the controllers (f32) would see an infinite state and hold their commands
        // while the run still counted as not diverged.
        return Err(Error::invalid(
            "simulation.divergence_bound",
            format!(
                "must not exceed f32::MAX = {:e}, the controller's range (got {:e})",
                f32::MAX,
                sim.divergence_bound
            ),
        ));
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
    let samples = samples_f as u64;
    scenario.leader.check(sim.t_end)?;
    let c = &scenario.controller;
    positive(c.ts, "controller.ts")?;
    if !(c.zeta > 0.0 && c.zeta < 1.0) {
        return Err(Error::invalid(
            "controller.zeta",
            format!("must lie in (0, 1) (got {})", c.zeta),
        ));
    }
    for (k, v) in [
        ("controller.p", c.p),
        ("controller.eta", c.eta),
        ("controller.tau", c.tau),
        ("controller.gamma", c.gamma),
        ("controller.diff_l1", c.diff_l1),
        ("controller.diff_l2", c.diff_l2),
        ("controller.varpi0", c.varpi0),
        ("controller.varpi_min", c.varpi_min),
        ("controller.estimate_max", c.estimate_max),
    ] {
        positive(v, k)?;
    }
    for (k, v) in [
        ("controller.varpi_decay", c.varpi_decay),
        ("controller.mu0", c.mu0),
        ("controller.xi0", c.xi0),
        ("controller.lambda0", c.lambda0),
    ] {
        if !v.is_finite() || v < 0.0 {
            return Err(Error::invalid(
                k,
                format!("must be a finite number >= 0 (got {v})"),
            ));
        }
    }
    if c.mtn_order == 0 {
        return Err(Error::invalid("controller.mtn_order", "must be >= 1"));
    }
    for (k, v) in [("controller.c1", c.c1), ("controller.c2", c.c2)] {
        if let Some(v) = v {
            positive(v, k)?;
        }
    }
    let q = &scenario.quantizer;
    if q.enabled {
        if !(q.rho > 0.0 && q.rho < 1.0) {
            return Err(Error::invalid(
                "quantizer.rho",
                format!("must lie in (0, 1) (got {})", q.rho),
            ));
        }
        positive(q.u_min, "quantizer.u_min")?;
    }

    // Checked whether on or off, so a typo does not wait for the day it is switched on.
    let sf = &scenario.safety;
    for (k, v) in [("safety.u_max", sf.u_max), ("safety.du_max", sf.du_max)] {
        if let Some(v) = v {
            positive(v, k)?;
            if v > f64::from(f32::MAX) {
                return Err(Error::invalid(k, format!("must fit f32 (got {v:e})")));
            }
        }
    }
    if sf.recovery_rate.is_nan() || sf.recovery_rate <= 0.0 {
        return Err(Error::invalid(
            "safety.recovery_rate",
            format!(
                "must be > 0 (units of y per second; inf: no blending) (got {})",
                sf.recovery_rate
            ),
        ));
    }
    if !sf.recovery_jump.is_finite() || sf.recovery_jump < 0.0 {
        return Err(Error::invalid(
            "safety.recovery_jump",
            format!("must be a finite number >= 0 (got {})", sf.recovery_jump),
        ));
    }
    if let (Some(u_max), true) = (sf.u_max, q.enabled) {
        if u_max <= q.u_min {
            return Err(Error::invalid(
                "safety.u_max",
                format!(
                    "must be above quantizer.u_min = {} (got {u_max}): every command would quantize to 0",
                    q.u_min
                ),
            ));
        }
    }

    let graph = Graph::from_spec(&scenario.graph)?;
    let plant = match plant {
        Some(p) => p,
        None => PlantModel::from_spec(&scenario.plant)?,
    };
    let (n, m) = (plant.n(), plant.m());
    for (k, v) in [
        ("a_check", &c.a_check),
        ("phi_low", &c.phi_low),
        ("phi_up", &c.phi_up),
        ("eps_bar", &c.eps_bar),
    ] {
        if v.len() != n {
            return Err(Error::invalid(
                format!("controller.{k}"),
                format!(
                    "expected {n} entries (one per step j = 1..n), got {}",
                    v.len()
                ),
            ));
        }
        for (j, x) in v.iter().enumerate() {
            finite(*x, &format!("controller.{k}[{}]", j + 1))?;
        }
    }
    let x0 = scenario
        .plant
        .initial_states(graph.len(), n, sim.divergence_bound)?;
    network::validate(&scenario.network, graph.len(), sim.h, sim.t_end)?;
    if scenario.network.kind != network::NetworkKind::Ideal && (n, m) != (2, 2) {
        return Err(Error::invalid(
            "network.kind",
            format!(
                "\"{}\" runs the node firmware, built for n = 2, m = 2 (this plant: n = {n}, m = {m})",
                scenario.network.kind.as_str()
            ),
        ));
    }
    let faults = scenario.faults.schedule(graph.len(), m, sim.t_end)?;
    scenario.metrics.check()?;
    if scenario.plant.x0_drawn() {
        // Drawn from the box: the resolved scenario shows the box, not Example 1's rows.
        scenario.plant.x0.clear();
    }
    let setup = Setup {
        scenario,
        graph,
        plant,
        x0,
        faults,
        samples,
    };
    setup.check_controllers()?;
    Ok(setup)
}

/// The resolved scenario as TOML (what `check` prints).
pub fn to_toml(s: &Scenario) -> String {
    toml::to_string(s).unwrap_or_else(|e| format!("# cannot print the scenario: {e}\n"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn safety_defaults_match_the_controller() {
        let (spec, core) = (
            super::SafetySpec::default(),
            controller_core::SafetyConfig::default(),
        );
        assert_eq!(spec.recovery_rate as f32, core.recovery_rate);
        assert_eq!(spec.recovery_jump as f32, core.recovery_jump);
        assert_eq!((spec.u_max, spec.du_max), (None, None));
        assert!(core.u_max.is_none() && core.du_max.is_none());
    }

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
