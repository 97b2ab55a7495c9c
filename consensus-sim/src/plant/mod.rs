//! Plants of LAW §1 (the physical world, `f64`), integrated by RK4 with `substeps` per sample
//! and the actuator outputs under zero-order hold (faults may vary within a sample).
//!
//! Three ways to a plant: the built-in models (`plant.model = "example1"`, `"manipulator"`);
//! `plant.model = "custom"` with the dynamics as expressions in the scenario ([`Custom`]); or
//! your own type implementing [`Plant`], run through the library by
//! `host_sim::run::run_plant` (`host-sim/examples/pendulum.rs`). To make a Rust plant a
//! scenario model, add a [`PlantModel`] variant.

pub mod custom;
mod example1;
mod manipulator;

pub use custom::{Custom, MAX_ORDER};
pub use example1::Example1;
pub use manipulator::Manipulator;

use std::{collections::BTreeMap, sync::Arc};

use serde::{Deserialize, Serialize};

use consensus_plot::error::{Error, Result};

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
    /// Custom: the unit of each state `x_1..x_n` (`x_1`'s is the output's, on the figures' axes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_units: Option<Vec<String>>,
    /// Custom: the unit of the inputs `u_1..u_m`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_unit: Option<String>,
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
            state_units: None,
            input_unit: None,
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
/// in `1..=MAX_ORDER`: the one table of sizes the crates instantiate (controller, loop, outputs).
#[macro_export]
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
            (n, m) => Err($crate::Error::invalid(
                "plant.model",
                format!("n = {n}, m = {m} is not supported (supported: 1..={} each)", $crate::plant::MAX_ORDER),
            )),
        }
    };
}
pub use with_sizes;

/// One agent's dynamics `ẋ = f(t, x, a)` with `a` the actuator outputs `q^f(u_l)` (LAW §1):
/// `N` states (`x[0]` is the output `y` the agents agree on), `M` actuators.
///
/// The simulator integrates it with RK4 (`simulation.substeps` steps per sample), holding the
/// controller's commands over the sample; `a` are the commands after the quantizer and the
/// actuator faults. The time-only part of `f` (a disturbance such as `cos t`) is computed once
/// per distinct RK4 stage time for all agents by [`Plant::at`]; [`Plant::derivative`] gets it
/// back, so a plant without such a term uses `type Time = ()`.
///
/// Contract: `at` and `derivative` are pure functions of their arguments (a stage time equal to
/// the previous one reuses its `at`), `derivative` is cheap (it runs `4 · substeps` times per
/// agent and sample) and neither panics; a non-finite result is not an error here,
/// the run reports it as divergence (`summary.json` `divergence`).
///
/// A user's plant runs through `host_sim::run::run_plant` with a scenario checked by
/// [`crate::scenario::validate_with_plant`] for its `N`, `M` (an example is in its
/// documentation).
pub trait Plant<const N: usize, const M: usize> {
    /// The terms of `f` that depend on `t` only.
    type Time: Copy;
    /// Those terms at time `t`.
    fn at(&self, t: f64) -> Self::Time;
    /// `ẋ` at time terms `t`, state `x`, actuator outputs `a`.
    fn derivative(&self, t: &Self::Time, x: &[f64; N], a: &[f64; M]) -> [f64; N];

    /// [`Plant::derivative`] of `B` agents at once ([`Lanes`]: `x[j][b]`, `a[l][b]`), per agent
    /// the same operations. Provided: one agent after the other; a plant may write it lane by
    /// lane so that the compiler vectorises it (the built-in Example 1 does).
    #[inline]
    fn derivative_lanes<const B: usize>(
        &self,
        t: &Self::Time,
        x: &Lanes<N, B>,
        a: &Lanes<M, B>,
    ) -> Lanes<N, B> {
        let d: [[f64; N]; B] = std::array::from_fn(|b| {
            self.derivative(
                t,
                &std::array::from_fn(|j| x[j][b]),
                &std::array::from_fn(|l| a[l][b]),
            )
        });
        std::array::from_fn(|j| std::array::from_fn(|b| d[b][j]))
    }
}

/// `B` agents' vectors side by side, component-major: `v[j][b]` is component `j` of agent `b`
/// (so one operation on a component is the same operation on every agent, which the compiler
/// turns into vector instructions).
pub type Lanes<const J: usize, const B: usize> = [[f64; B]; J];

/// One classical RK4 step of length `dt` for each of `B` agents (`x[j][b]`): time terms and
/// actuator outputs (`act[stage][l][b]`) at `t`, `t + dt/2`, `t + dt`. Per agent exactly the
/// operations of a scalar RK4 step in the same order, whatever `B`.
#[inline]
pub fn rk4<const N: usize, const M: usize, const B: usize, P: Plant<N, M>>(
    plant: &P,
    x: &mut Lanes<N, B>,
    dt: f64,
    time: &[P::Time; 3],
    act: &[Lanes<M, B>; 3],
) {
    let add = |x: &Lanes<N, B>, k: &Lanes<N, B>, s: f64| -> Lanes<N, B> {
        std::array::from_fn(|j| std::array::from_fn(|b| x[j][b] + s * k[j][b]))
    };
    let k1 = plant.derivative_lanes(&time[0], x, &act[0]);
    let k2 = plant.derivative_lanes(&time[1], &add(x, &k1, 0.5 * dt), &act[1]);
    let k3 = plant.derivative_lanes(&time[1], &add(x, &k2, 0.5 * dt), &act[1]);
    let k4 = plant.derivative_lanes(&time[2], &add(x, &k3, dt), &act[2]);
    for j in 0..N {
        for b in 0..B {
            x[j][b] += dt / 6.0 * (k1[j][b] + 2.0 * k2[j][b] + 2.0 * k3[j][b] + k4[j][b]);
        }
    }
}

/// How a plant behaves without feedback: what an open-loop safe policy (`hold`, `ramp`,
/// `off` of `[node.safe_state]`) can expect of it.
#[derive(Debug, Clone, PartialEq)]
pub enum WithoutFeedback {
    /// It escapes under any input the node could hold: no open-loop policy is safe.
    Unstable(&'static str),
    /// Bounded at zero input (`off`, the end of a `ramp`); a held input may not be.
    BoundedAtZero(String),
    /// Dynamics host-sim cannot judge (custom or library plants).
    Unknown,
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
    /// [`crate::scenario::validate_with_plant`] and runs by `host_sim::run::run_plant`.
    Library {
        /// State order.
        n: usize,
        /// Actuators.
        m: usize,
    },
}

impl PlantModel {
    /// How the plant behaves without feedback (for `host-sim check`).
    pub fn without_feedback(&self) -> WithoutFeedback {
        match self {
            Self::Example1(_) => WithoutFeedback::Unstable(
                "Example 1 (ẋ₂ = u − 2x₁² + x₂³ + …) escapes in finite time without feedback",
            ),
            Self::Manipulator(m) => WithoutFeedback::BoundedAtZero(format!(
                "the manipulator is an undamped pendulum: it swings within bounds at zero \
                 torque, but a held torque above ½ m g l = {} spins it up without bound",
                0.5 * m.mass * m.gravity * m.length
            )),
            Self::Custom(_) | Self::Library { .. } => WithoutFeedback::Unknown,
        }
    }

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
            ("state_units", spec.state_units.is_some()),
            ("input_unit", spec.input_unit.is_some()),
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
                let custom = Custom::new(n, m, dynamics, &params)?
                    .with_units(spec.state_units.as_deref(), spec.input_unit.as_deref())?;
                Ok(Self::Custom(Arc::new(custom)))
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
    pub fn units(&self) -> (&str, &str) {
        match self {
            Self::Custom(c) => c.units(),
            Self::Example1(_) | Self::Library { .. } => ("–", "–"),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Example 1 through the provided [`Plant::derivative_lanes`] (one agent after the other).
    struct OneByOne;

    impl Plant<2, 2> for OneByOne {
        type Time = f64;
        fn at(&self, t: f64) -> f64 {
            Plant::<2, 2>::at(&Example1, t)
        }
        fn derivative(&self, t: &f64, x: &[f64; 2], a: &[f64; 2]) -> [f64; 2] {
            Example1.derivative(t, x, a)
        }
    }

    /// Seeded values for the lane tests (fixed seeds: a failure replays as it is).
    pub(super) struct Draw(pub(super) u64);

    impl Draw {
        /// Uniform in `[-scale/2, scale/2)`.
        pub(super) fn value(&mut self, scale: f64) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (((self.0 >> 11) as f64) / (1u64 << 53) as f64 - 0.5) * scale
        }

        /// Four agents' vectors of `J` components.
        pub(super) fn lanes<const J: usize>(&mut self, scale: f64) -> Lanes<J, 4> {
            std::array::from_fn(|_| std::array::from_fn(|_| self.value(scale)))
        }
    }

    /// One agent's classical RK4 step, written out.
    fn scalar_rk4(x: [f64; 2], dt: f64, time: &[f64; 3], act: &[[f64; 2]; 3]) -> [f64; 2] {
        let f = |s: usize, x: [f64; 2]| Example1.derivative(&time[s], &x, &act[s]);
        let add = |k: [f64; 2], s: f64| [x[0] + s * k[0], x[1] + s * k[1]];
        let k1 = f(0, x);
        let k2 = f(1, add(k1, 0.5 * dt));
        let k3 = f(1, add(k2, 0.5 * dt));
        let k4 = f(2, add(k3, dt));
        std::array::from_fn(|j| x[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]))
    }

    /// Example 1's lane-wise RK4 step of four agents gives each agent's single-agent result to
    /// the bit, as does the provided lane form (seeded values, printed on failure).
    #[test]
    fn four_lanes_equal_four_single_steps() {
        let mut draw = Draw(0x9e37_79b9_7f4a_7c15);
        for trial in 0..1000 {
            let x = draw.lanes(4.0);
            let act: [Lanes<2, 4>; 3] = std::array::from_fn(|_| draw.lanes(60.0));
            let (t, dt) = (draw.value(20.0).abs(), 2.5e-4);
            let time = [t, t + 0.5 * dt, t + dt].map(|t| Plant::<2, 2>::at(&Example1, t));
            let (mut lanes, mut provided) = (x, x);
            rk4(&Example1, &mut lanes, dt, &time, &act);
            rk4(&OneByOne, &mut provided, dt, &time, &act);
            for b in 0..4 {
                let one = scalar_rk4(
                    [x[0][b], x[1][b]],
                    dt,
                    &time,
                    &act.map(|a| [a[0][b], a[1][b]]),
                );
                for j in 0..2 {
                    let bits = [lanes[j][b], provided[j][b], one[j]].map(f64::to_bits);
                    assert!(
                        bits[0] == bits[2] && bits[1] == bits[2],
                        "trial {trial}, agent {b}, state {j}: {bits:x?} (x = {x:?})"
                    );
                }
            }
        }
    }
}
