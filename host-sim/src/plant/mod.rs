//! Plants of LAW §1 (the physical world, `f64`), integrated by RK4 with `substeps` per sample
//! and the actuator outputs under zero-order hold (faults may vary within a sample).
//!
//! Three ways to a plant: the built-in models (`plant.model = "example1"`, `"manipulator"`);
//! `plant.model = "custom"` with the dynamics as expressions in the scenario ([`Custom`]); or
//! your own type implementing [`Plant`], run through the library by
//! [`crate::run::run_plant`] (`host-sim/examples/pendulum.rs`). To make a Rust plant a
//! scenario model, add a [`PlantModel`] variant.

mod custom;
mod example1;
mod manipulator;

pub use custom::{Custom, MAX_ORDER};
pub use example1::Example1;
pub use manipulator::Manipulator;

use std::{collections::BTreeMap, sync::Arc};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// `[plant]`: the model, its parameters and initial states.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantSpec {
    /// `"example1"`, `"manipulator"` or `"custom"`.
    pub model: String,
    /// One initial state per agent (left out when drawn from `x0_min`..`x0_max`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub x0: Vec<Vec<f64>>,
    /// Lower corner of the box initial states are drawn from, instead of `x0`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x0_min: Option<Vec<f64>>,
    /// Upper corner of that box.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x0_max: Option<Vec<f64>>,
    /// Seed of the draw (default 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub x0_seed: Option<u64>,
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
    /// Custom: states per agent `n`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub n: Option<i64>,
    /// Custom: actuators per agent `m`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub m: Option<i64>,
    /// Custom: `dx_j/dt` as expressions, `j = 1..n`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dynamics: Option<Vec<String>>,
    /// Custom: named constants of the expressions (`[plant.params]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub params: Option<BTreeMap<String, f64>>,
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
            x0_min: None,
            x0_max: None,
            x0_seed: None,
            inertia: None,
            mass: None,
            gravity: None,
            length: None,
            n: None,
            m: None,
            dynamics: None,
            params: None,
        }
    }
}

impl PlantSpec {
    /// Whether the initial states are drawn in a box (`x0_min`, `x0_max`).
    pub fn x0_drawn(&self) -> bool {
        self.x0_min.is_some() || self.x0_max.is_some()
    }

    /// The initial states of `agents` agents: `x0` as written, or drawn uniformly in the box
    /// `x0_min`..`x0_max` (then `x0` must be left out or be the default); checked as in
    /// [`PlantSpec::check_x0`].
    pub fn initial_states(&self, agents: usize, n: usize, bound: f64) -> Result<Vec<Vec<f64>>> {
        let (lo, hi) = match (&self.x0_min, &self.x0_max) {
            (None, None) => {
                if self.x0_seed.is_some() {
                    return Err(Error::invalid(
                        "plant.x0_seed",
                        "only with plant.x0_min and plant.x0_max",
                    ));
                }
                self.check_x0(agents, n, bound)?;
                return Ok(self.x0.clone());
            }
            (Some(_), None) => {
                return Err(Error::invalid(
                    "plant.x0_max",
                    "missing: give both corners of the box, plant.x0_min and plant.x0_max",
                ))
            }
            (None, Some(_)) => {
                return Err(Error::invalid(
                    "plant.x0_min",
                    "missing: give both corners of the box, plant.x0_min and plant.x0_max",
                ))
            }
            (Some(lo), Some(hi)) => (lo, hi),
        };
        if !self.x0.is_empty() && self.x0 != Self::default().x0 {
            return Err(Error::invalid(
                "plant.x0",
                "give either plant.x0 or the box plant.x0_min / plant.x0_max, not both",
            ));
        }
        if lo.len() != n {
            return Err(Error::invalid(
                "plant.x0_min",
                format!("{} entries, the model has n = {n} states", lo.len()),
            ));
        }
        let drawn = Self {
            x0: crate::generate::initial_states(agents, lo, hi, self.x0_seed.unwrap_or(1))?,
            ..Self::default()
        };
        drawn.check_x0(agents, n, bound)?;
        Ok(drawn.x0)
    }

    /// Checks `x0`: one row of `n` finite entries within `bound` per agent.
    pub fn check_x0(&self, agents: usize, n: usize, bound: f64) -> Result<()> {
        let x0 = &self.x0;
        if x0.len() != agents {
            return Err(Error::invalid(
                "plant.x0",
                format!(
                    "{} initial states but the graph has {agents} agents",
                    x0.len()
                ),
            ));
        }
        for (i, row) in x0.iter().enumerate() {
            let key = || format!("plant.x0[{}]", i + 1);
            if row.len() != n {
                return Err(Error::invalid(
                    key(),
                    format!("{} entries, the model has n = {n} states", row.len()),
                ));
            }
            for v in row {
                if !v.is_finite() {
                    return Err(Error::invalid(key(), format!("must be finite (got {v})")));
                }
                if v.abs() > bound {
                    return Err(Error::invalid(
                        key(),
                        format!("|{v:e}| is above simulation.divergence_bound = {bound:e}"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Calls `$f::<N, M>(args…)` with the const sizes `N`, `M` equal to the runtime `($n, $m)`, both
/// in `1..=MAX_ORDER`: the one table of sizes the crate instantiates (controller, loop, outputs).
macro_rules! with_sizes {
    ($n:expr, $m:expr, $f:ident($($arg:expr),* $(,)?)) => {
        match ($n, $m) {
            (1, 1) => $f::<1, 1>($($arg),*),
            (1, 2) => $f::<1, 2>($($arg),*),
            (1, 3) => $f::<1, 3>($($arg),*),
            (1, 4) => $f::<1, 4>($($arg),*),
            (2, 1) => $f::<2, 1>($($arg),*),
            (2, 2) => $f::<2, 2>($($arg),*),
            (2, 3) => $f::<2, 3>($($arg),*),
            (2, 4) => $f::<2, 4>($($arg),*),
            (3, 1) => $f::<3, 1>($($arg),*),
            (3, 2) => $f::<3, 2>($($arg),*),
            (3, 3) => $f::<3, 3>($($arg),*),
            (3, 4) => $f::<3, 4>($($arg),*),
            (4, 1) => $f::<4, 1>($($arg),*),
            (4, 2) => $f::<4, 2>($($arg),*),
            (4, 3) => $f::<4, 3>($($arg),*),
            (4, 4) => $f::<4, 4>($($arg),*),
            (n, m) => Err($crate::error::Error::invalid(
                "plant.model",
                format!("n = {n}, m = {m} is not supported (supported: 1..={} each)", $crate::plant::MAX_ORDER),
            )),
        }
    };
}
pub(crate) use with_sizes;

/// One agent's dynamics `ẋ = f(t, x, a)` with `a` the actuator outputs `q^f(u_l)` (LAW §1):
/// `N` states (`x[0]` is the output `y` the agents agree on), `M` actuators.
///
/// The simulator integrates it with RK4 (`simulation.substeps` steps per sample), holding the
/// controller's commands over the sample; `a` are the commands after the quantizer and the
/// actuator faults. The time-only part of `f` (a disturbance such as `cos t`) is computed once
/// per RK4 stage for all agents by [`Plant::at`]; [`Plant::derivative`] gets it back, so a
/// plant without such a term uses `type Time = ()`.
///
/// Contract: `derivative` is a pure function of its arguments, cheap (it runs `4 · substeps`
/// times per agent and sample) and does not panic; a non-finite result is not an error here,
/// the run reports it as divergence (`summary.json` `divergence`).
///
/// A user's plant runs through [`crate::run::run_plant`] with a scenario checked by
/// [`crate::scenario::validate_with_plant`] for its `N`, `M`:
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
pub trait Plant<const N: usize, const M: usize> {
    /// The terms of `f` that depend on `t` only.
    type Time: Copy;
    /// Those terms at time `t`.
    fn at(&self, t: f64) -> Self::Time;
    /// `ẋ` at time terms `t`, state `x`, actuator outputs `a`.
    fn derivative(&self, t: &Self::Time, x: &[f64; N], a: &[f64; M]) -> [f64; N];
}

/// Stage inputs of one RK4 step: time terms and actuator outputs at `t`, `t + dt/2`, `t + dt`.
#[derive(Debug, Clone, Copy)]
pub struct Stages<T, const M: usize> {
    /// Time terms at the start, midpoint and end.
    pub time: [T; 3],
    /// Actuator outputs at the start, midpoint and end.
    pub act: [[f64; M]; 3],
}

/// One classical RK4 step of length `dt`.
#[inline]
pub fn rk4<const N: usize, const M: usize, P: Plant<N, M>>(
    plant: &P,
    x: &mut [f64; N],
    dt: f64,
    st: &Stages<P::Time, M>,
) {
    rk4_batch(plant, std::array::from_mut(x), dt, std::array::from_ref(st));
}

/// One classical RK4 step of length `dt` for each of `B` agents: per agent exactly the
/// operations of [`rk4`], the agents' independent chains interleaved so that a core overlaps
/// them (one agent's step is a chain of dependent operations).
#[inline]
pub fn rk4_batch<const N: usize, const M: usize, const B: usize, P: Plant<N, M>>(
    plant: &P,
    x: &mut [[f64; N]; B],
    dt: f64,
    st: &[Stages<P::Time, M>; B],
) {
    let add = |x: &[f64; N], k: &[f64; N], s: f64| -> [f64; N] {
        let mut y = *x;
        for (y, k) in y.iter_mut().zip(k) {
            *y += s * k;
        }
        y
    };
    let f = |b: usize, stage: usize, x: &[f64; N]| {
        plant.derivative(&st[b].time[stage], x, &st[b].act[stage])
    };
    let k1: [[f64; N]; B] = std::array::from_fn(|b| f(b, 0, &x[b]));
    let k2: [[f64; N]; B] = std::array::from_fn(|b| f(b, 1, &add(&x[b], &k1[b], 0.5 * dt)));
    let k3: [[f64; N]; B] = std::array::from_fn(|b| f(b, 1, &add(&x[b], &k2[b], 0.5 * dt)));
    let k4: [[f64; N]; B] = std::array::from_fn(|b| f(b, 2, &add(&x[b], &k3[b], dt)));
    for (b, x) in x.iter_mut().enumerate() {
        for j in 0..N {
            x[j] += dt / 6.0 * (k1[b][j] + 2.0 * k2[b][j] + 2.0 * k3[b][j] + k4[b][j]);
        }
    }
}

/// The models a scenario can name (`plant.model`).
#[derive(Debug, Clone, PartialEq)]
pub enum PlantModel {
    /// LAW §8 Example 1.
    Example1(Example1),
    /// LAW §8 Example 2: single-link manipulator.
    Manipulator(Manipulator),
    /// Dynamics written in the scenario (shared by every run of a campaign).
    Custom(Arc<Custom>),
    /// A [`Plant`] given in Rust, of `n` states and `m` actuators: the scenario was checked by
    /// [`crate::scenario::validate_with_plant`] and runs by [`crate::run::run_plant`].
    Library {
        /// State order.
        n: usize,
        /// Actuators.
        m: usize,
    },
}

impl PlantModel {
    /// From `[plant]`; manipulator and custom keys are rejected for other models.
    pub fn from_spec(spec: &PlantSpec) -> Result<Self> {
        let params = [
            ("inertia", spec.inertia),
            ("mass", spec.mass),
            ("gravity", spec.gravity),
            ("length", spec.length),
        ];
        let custom = [
            ("n", spec.n.is_some()),
            ("m", spec.m.is_some()),
            ("dynamics", spec.dynamics.is_some()),
            ("params", spec.params.is_some()),
        ];
        if spec.model != "custom" {
            if let Some((k, _)) = custom.iter().find(|(_, set)| *set) {
                return Err(Error::invalid(
                    format!("plant.{k}"),
                    "only for model = \"custom\"",
                ));
            }
        }
        match spec.model.as_str() {
            "example1" => {
                if let Some((k, _)) = params.iter().find(|(_, v)| v.is_some()) {
                    return Err(Error::invalid(
                        format!("plant.{k}"),
                        "only for model = \"manipulator\"",
                    ));
                }
                Ok(Self::Example1(Example1))
            }
            "manipulator" => {
                let d = Manipulator::default();
                let m = Manipulator {
                    inertia: spec.inertia.unwrap_or(d.inertia),
                    mass: spec.mass.unwrap_or(d.mass),
                    gravity: spec.gravity.unwrap_or(d.gravity),
                    length: spec.length.unwrap_or(d.length),
                };
                for (k, v) in [
                    ("inertia", m.inertia),
                    ("mass", m.mass),
                    ("gravity", m.gravity),
                    ("length", m.length),
                ] {
                    if !v.is_finite() {
                        return Err(Error::invalid(format!("plant.{k}"), "must be finite"));
                    }
                }
                if m.inertia <= 0.0 {
                    return Err(Error::invalid("plant.inertia", "must be > 0"));
                }
                Ok(Self::Manipulator(m))
            }
            "custom" => {
                if let Some((k, _)) = params.iter().find(|(_, v)| v.is_some()) {
                    return Err(Error::invalid(
                        format!("plant.{k}"),
                        "only for model = \"manipulator\"",
                    ));
                }
                let size = |key: &str, v: Option<i64>| {
                    let v = v.ok_or_else(|| {
                        Error::invalid(format!("plant.{key}"), "required for model = \"custom\"")
                    })?;
                    usize::try_from(v).map_err(|_| {
                        Error::invalid(
                            format!("plant.{key}"),
                            format!("must lie in 1..={MAX_ORDER} (got {v})"),
                        )
                    })
                };
                let (n, m) = (size("n", spec.n)?, size("m", spec.m)?);
                let dynamics = spec.dynamics.as_deref().ok_or_else(|| {
                    Error::invalid("plant.dynamics", "required for model = \"custom\"")
                })?;
                let params = spec.params.clone().unwrap_or_default();
                Ok(Self::Custom(Arc::new(Custom::new(n, m, dynamics, &params)?)))
            }
            other => Err(Error::invalid(
                "plant.model",
                format!(
                    "unknown model \"{other}\" (expected \"example1\", \"manipulator\" or \"custom\")"
                ),
            )),
        }
    }

    /// State order `n`.
    pub fn n(&self) -> usize {
        match self {
            Self::Custom(c) => c.n(),
            Self::Library { n, .. } => *n,
            _ => 2,
        }
    }

    /// Actuators per agent `m`.
    pub fn m(&self) -> usize {
        match self {
            Self::Custom(c) => c.m(),
            Self::Library { m, .. } => *m,
            _ => 2,
        }
    }

    /// Units of the output `y` and of the actuator commands `u` (for the figures).
    pub fn units(&self) -> (&'static str, &'static str) {
        match self {
            Self::Example1(_) | Self::Custom(_) | Self::Library { .. } => ("–", "–"),
            Self::Manipulator(_) => ("rad", "N·m"),
        }
    }

    /// The scenario name of the model.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Example1(_) => "example1",
            Self::Manipulator(_) => "manipulator",
            Self::Custom(_) => "custom",
            Self::Library { .. } => "library",
        }
    }
}
