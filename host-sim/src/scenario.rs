//! The scenario file of docs/SCENARIO.md: serde types with the defaults of LAW §8 (Example 1),
//! `--set` overrides and validation into a [`Setup`] the simulator runs.

use std::{fmt, path::Path};

use controller_core::{
    BaselineConfig, ConfigError, Controller, ControllerConfig, GainSelection, QuantizerConfig,
    QuantizerDirection, SafetyConfig, SchemeConfig,
};
use serde::{de, Deserialize, Deserializer, Serialize, Serializer};

use crate::{
    error::{Error, Result},
    faults::FaultSchedule,
    graph::{Graph, MAX_NEIGHBOURS},
    network::NetworkSpec,
    plant::PlantModel,
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

/// `[graph]`: who hears whom (LAW §2), as neighbour lists or an adjacency matrix.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GraphSpec {
    /// Agent `i` (1-based) hears these agents.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neighbours: Option<Vec<Vec<i64>>>,
    /// Alternative: `a_{i,k}` as a square 0/1 matrix.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adjacency: Option<Vec<Vec<i64>>>,
    /// Agents that hear the leader (`r_i = 1`).
    pub pinned: Vec<i64>,
}

impl Default for GraphSpec {
    fn default() -> Self {
        Self {
            neighbours: None,
            adjacency: None,
            pinned: vec![1],
        }
    }
}

/// `[leader]`: `y_d = amplitude sin(omega t + phase) + offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Leader {
    /// Amplitude.
    pub amplitude: f64,
    /// Angular frequency [rad/s].
    pub omega: f64,
    /// Phase [rad].
    pub phase: f64,
    /// Offset.
    pub offset: f64,
}

impl Default for Leader {
    fn default() -> Self {
        Self {
            amplitude: 0.6,
            omega: 2.0,
            phase: 0.0,
            offset: 0.0,
        }
    }
}

impl Leader {
    /// `y_d(t)`.
    pub fn yd(&self, t: f64) -> f64 {
        self.amplitude * (self.omega * t + self.phase).sin() + self.offset
    }
}

/// `[plant]`: the model, its parameters and initial states.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantSpec {
    /// `"example1"` or `"manipulator"`.
    pub model: String,
    /// One initial state per agent.
    pub x0: Vec<Vec<f64>>,
    /// Manipulator inertia `M`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia: Option<f64>,
    /// Manipulator mass `m`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// Manipulator `g`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity: Option<f64>,
    /// Manipulator link length `l`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
}

impl Default for PlantSpec {
    fn default() -> Self {
        Self {
            model: "example1".into(),
            x0: vec![
                vec![0.02, 0.8],
                vec![0.01, 1.0],
                vec![0.01, 0.09],
                vec![0.0, 0.7],
            ],
            inertia: None,
            mass: None,
            gravity: None,
            length: None,
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

/// `[faults]`: actuator fault rules (LAW §7); the default is LAW §8's schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaultsSpec {
    /// Off: every actuator healthy.
    pub enabled: bool,
    /// The rules (`[[faults.rule]]`).
    #[serde(default = "default_rules")]
    pub rule: Vec<FaultRule>,
    /// Sensor faults (`[[faults.sensor]]`): an agent's controller reads a NaN state on
    /// `[from, until)` (the plant is not affected).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sensor: Vec<SensorFault>,
    /// Run schedules with all `m` actuators of an agent in total loss at once (beyond
    /// Assumption 4; for fault campaigns). Default false: such a schedule is rejected.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub beyond_assumption4: bool,
}

impl Default for FaultsSpec {
    fn default() -> Self {
        Self {
            enabled: true,
            rule: default_rules(),
            sensor: Vec::new(),
            beyond_assumption4: false,
        }
    }
}

/// One `[[faults.sensor]]` window: agent `agent` (1-based) reads NaN on `[from, until)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorFault {
    /// 1-based agent.
    pub agent: i64,
    /// Start [s].
    pub from: f64,
    /// End [s], exclusive.
    pub until: f64,
}

fn default_rules() -> Vec<FaultRule> {
    vec![
        FaultRule {
            kind: FaultKind::Partial,
            gain: Some(0.5),
            ..FaultRule::window(1)
        },
        FaultRule {
            kind: FaultKind::Stuck,
            bias: Some(0.0),
            amplitude: Some(1.0),
            omega: Some(1.0),
            ..FaultRule::window(2)
        },
    ]
}

/// Which agents a rule applies to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Agents {
    /// Every agent.
    All,
    /// These agents (1-based).
    List(Vec<i64>),
}

impl Serialize for Agents {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            Self::All => s.serialize_str("all"),
            Self::List(v) => v.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Agents {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> de::Visitor<'de> for V {
            type Value = Agents;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("\"all\" or a list of agent numbers")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Agents, E> {
                if v == "all" {
                    Ok(Agents::All)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
            fn visit_seq<A: de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Agents, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<i64>()? {
                    v.push(x);
                }
                Ok(Agents::List(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// Fault kinds of LAW §7.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultKind {
    /// `gain · q(u)`, `0 ≤ gain < 1` (`gain = 0` is a total loss).
    Partial,
    /// `bias + amplitude sin(omega t)`, `q(u)` ignored: total loss.
    Stuck,
}

/// One `[[faults.rule]]`: one actuator of some agents on repeating windows
/// `[start + k period, start + k period + length)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultRule {
    /// `"all"` or a list of 1-based agents.
    pub agents: Agents,
    /// 1-based actuator `l`.
    pub actuator: i64,
    /// `partial` or `stuck`.
    pub kind: FaultKind,
    /// Partial: effectiveness `ϱ`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain: Option<f64>,
    /// Stuck: `bias`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<f64>,
    /// Stuck: sine amplitude.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Stuck: sine angular frequency [rad/s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
    /// First window start [s].
    #[serde(default)]
    pub start: f64,
    /// Repeat period [s]; absent: one window.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    /// Window length [s]; absent: until the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
}

impl FaultRule {
    /// LAW §8's window `[2,4), [6,8), …` on `actuator`, for all agents, partial with no gain.
    fn window(actuator: i64) -> Self {
        Self {
            agents: Agents::All,
            actuator,
            kind: FaultKind::Partial,
            gain: None,
            bias: None,
            amplitude: None,
            omega: None,
            start: 2.0,
            period: Some(4.0),
            length: Some(2.0),
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

    /// Validates every agent's controller configuration (as `Controller::new` will).
    pub fn check_controllers(&self) -> Result<()> {
        match (self.n(), self.m()) {
            (2, 2) => self.check_controllers_of::<2, 2>(),
            (n, m) => Err(Error::invalid(
                "plant.model",
                format!("n = {n}, m = {m} is not supported (supported: n = 2, m = 2)"),
            )),
        }
    }

    fn check_controllers_of<const N: usize, const M: usize>(&self) -> Result<()> {
        for i in 0..self.agents() {
            let cfg = self.controller_config::<N>(i)?;
            Controller::<N, M, MAX_NEIGHBOURS>::new(&cfg).map_err(|e| {
                let auto_gains = self.scenario.controller.c1.is_none();
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
        return crate::campaign::spec::set_indexed(table, key, value);
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

/// LAW §8's graph: agent 2 hears 1, agent 3 hears 1, agent 4 hears 1 and 3.
fn example_neighbours() -> Vec<Vec<i64>> {
    vec![vec![], vec![1], vec![1], vec![1, 3]]
}

/// Checks the scenario and resolves graph, plant, initial states and faults.
pub fn validate(mut scenario: Scenario) -> Result<Setup> {
    if scenario.graph.neighbours.is_none() && scenario.graph.adjacency.is_none() {
        scenario.graph.neighbours = Some(example_neighbours());
    }
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
    let l = &scenario.leader;
    for (k, v) in [
        ("leader.amplitude", l.amplitude),
        ("leader.omega", l.omega),
        ("leader.phase", l.phase),
        ("leader.offset", l.offset),
    ] {
        finite(v, k)?;
    }
    // y_d goes to the controllers as f32 and into the CSV: it must stay finite over the run.
    let peak = l.amplitude.abs() + l.offset.abs();
    if peak > f64::from(f32::MAX) {
        return Err(Error::invalid(
            "leader.amplitude",
            format!("|amplitude| + |offset| = {peak:e} does not fit the controller's f32"),
        ));
    }
    if !(l.omega.abs() * sim.t_end + l.phase.abs()).is_finite() {
        return Err(Error::invalid(
            "leader.omega",
            "omega * t_end overflows (y_d would be NaN)",
        ));
    }
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
    let plant = PlantModel::from_spec(&scenario.plant)?;
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
    let x0 = &scenario.plant.x0;
    if x0.len() != graph.len() {
        return Err(Error::invalid(
            "plant.x0",
            format!(
                "{} initial states but the graph has {} agents",
                x0.len(),
                graph.len()
            ),
        ));
    }
    for (i, row) in x0.iter().enumerate() {
        if row.len() != n {
            return Err(Error::invalid(
                format!("plant.x0[{}]", i + 1),
                format!("{} entries, the model has n = {n} states", row.len()),
            ));
        }
        for v in row {
            finite(*v, &format!("plant.x0[{}]", i + 1))?;
            if v.abs() > sim.divergence_bound {
                return Err(Error::invalid(
                    format!("plant.x0[{}]", i + 1),
                    format!(
                        "|{v:e}| is above simulation.divergence_bound = {:e}",
                        sim.divergence_bound
                    ),
                ));
            }
        }
    }
    crate::network::validate(&scenario.network, graph.len(), sim.h, sim.t_end)?;
    let faults = if !scenario.faults.enabled {
        FaultSchedule::healthy(graph.len(), m)
    } else if scenario.faults.beyond_assumption4 {
        FaultSchedule::compile(&scenario.faults.rule, graph.len(), m)?
    } else {
        FaultSchedule::from_rules(&scenario.faults.rule, graph.len(), m, sim.t_end)?
    };
    for (j, f) in scenario.faults.sensor.iter().enumerate() {
        let key = |k: &str| format!("faults.sensor[{}].{k}", j + 1);
        if f.agent < 1 || f.agent as usize > graph.len() {
            return Err(Error::invalid(
                key("agent"),
                format!("agent {} out of range 1..={}", f.agent, graph.len()),
            ));
        }
        if !(f.from.is_finite() && f.until.is_finite() && f.from < f.until) {
            return Err(Error::invalid(
                key("until"),
                format!("need finite from < until (got {} .. {})", f.from, f.until),
            ));
        }
    }
    let x0 = x0.clone();
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
}
