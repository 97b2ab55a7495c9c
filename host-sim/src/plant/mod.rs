//! Plants of LAW §1 (the physical world, `f64`), integrated by RK4 with `substeps` per sample
//! and the actuator outputs under zero-order hold (faults may vary within a sample).
//!
//! To add a model: implement [`Plant`] in a new file and add a [`PlantModel`] variant.

mod example1;
mod manipulator;

pub use example1::Example1;
pub use manipulator::Manipulator;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// `[plant]`: the model, its parameters and initial states.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantSpec {
    /// `"example1"` or `"manipulator"`.
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

/// One agent's dynamics `ẋ = f(t, x, a)` with `a` the actuator outputs `q^f(u_l)` (LAW §1).
///
/// The time-only part of `f` (a disturbance such as `cos t`) is computed once per RK4 stage for
/// all agents by [`Plant::at`]; [`Plant::derivative`] gets it back.
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PlantModel {
    /// LAW §8 Example 1.
    Example1(Example1),
    /// LAW §8 Example 2: single-link manipulator.
    Manipulator(Manipulator),
}

impl PlantModel {
    /// From `[plant]`; manipulator parameters are rejected for other models.
    pub fn from_spec(spec: &PlantSpec) -> Result<Self> {
        let params = [
            ("inertia", spec.inertia),
            ("mass", spec.mass),
            ("gravity", spec.gravity),
            ("length", spec.length),
        ];
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
            other => Err(Error::invalid(
                "plant.model",
                format!("unknown model \"{other}\" (expected \"example1\" or \"manipulator\")"),
            )),
        }
    }

    /// State order `n`.
    pub fn n(&self) -> usize {
        2
    }

    /// Actuators per agent `m`.
    pub fn m(&self) -> usize {
        2
    }

    /// Units of the output `y` and of the actuator commands `u` (for the figures).
    pub fn units(&self) -> (&'static str, &'static str) {
        match self {
            Self::Example1(_) => ("–", "–"),
            Self::Manipulator(_) => ("rad", "N·m"),
        }
    }

    /// The scenario name of the model.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Example1(_) => "example1",
            Self::Manipulator(_) => "manipulator",
        }
    }
}
