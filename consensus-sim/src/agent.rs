//! One agent's controller of a scenario, stepped by a caller (the Python package's
//! `Controller`): the `controller-core` law in `f32`, the same code the node firmware runs,
//! with the scenario's sizes `(n, m)` chosen at run time.

use controller_core::{Controller, Link, StepOutput};

use crate::{plant::with_sizes, scenario::Setup, sim::K};
use consensus_plot::error::{Error, Result};

/// What one step returns (LAW §6), sized at run time.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentStep {
    /// Commands `u_l` before quantization (28).
    pub u: Vec<f32>,
    /// Quantized commands `q_l` (2).
    pub q: Vec<f32>,
    /// Errors `e_j` (`e_1` is the consensus error (10)).
    pub e: Vec<f32>,
    /// `μ̂` (20).
    pub mu: f32,
    /// `ξ̂` (21).
    pub xi: f32,
    /// `λ̂` (22).
    pub lambda: f32,
    /// Why the step held its previous command, if it did.
    pub fault: Option<String>,
}

impl<const N: usize, const M: usize> From<StepOutput<N, M>> for AgentStep {
    fn from(o: StepOutput<N, M>) -> Self {
        Self {
            u: o.u.to_vec(),
            q: o.q.to_vec(),
            e: o.e.to_vec(),
            mu: o.estimates.mu,
            xi: o.estimates.xi,
            lambda: o.estimates.lambda,
            fault: o.status.fault.map(|f| format!("{f:?}")),
        }
    }
}

/// A controller of any supported `(N, M)`.
trait Stepper: Send + Sync {
    fn step(&mut self, x: &[f32], neighbours: &[Link], leader: Link) -> Option<AgentStep>;
    fn reset(&mut self);
}

impl<const N: usize, const M: usize> Stepper for Controller<N, M, K> {
    fn step(&mut self, x: &[f32], neighbours: &[Link], leader: Link) -> Option<AgentStep> {
        let x: &[f32; N] = x.try_into().ok()?;
        Some(Controller::step(self, x, neighbours, leader).into())
    }

    fn reset(&mut self) {
        Controller::reset(self);
    }
}

fn boxed<const N: usize, const M: usize>(setup: &Setup, i: usize) -> Result<Box<dyn Stepper>> {
    let c = Controller::<N, M, K>::new(&setup.controller_config::<N>(i)?)
        .map_err(|e| Error::invalid(format!("controller (agent {})", i + 1), e))?;
    Ok(Box::new(c))
}

/// Agent `i`'s controller as configured by a scenario, with its place in the graph.
pub struct AgentController {
    inner: Box<dyn Stepper>,
    n: usize,
    m: usize,
    neighbours: Vec<usize>,
    pinned: bool,
}

impl AgentController {
    /// The controller of agent `agent` (1-based) of `setup`.
    pub fn new(setup: &Setup, agent: usize) -> Result<Self> {
        let count = setup.agents();
        if agent == 0 || agent > count {
            return Err(Error::invalid(
                "agent",
                format!("{agent} out of range 1..={count} (agents are 1-based)"),
            ));
        }
        let i = agent - 1;
        let (n, m) = (setup.n(), setup.m());
        Ok(Self {
            inner: with_sizes!(n, m, boxed(setup, i))?,
            n,
            m,
            neighbours: setup.graph.neighbours(i).iter().map(|j| j + 1).collect(),
            pinned: setup.graph.pinned(i),
        })
    }

    /// States per agent `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Actuators per agent `m`.
    pub fn m(&self) -> usize {
        self.m
    }

    /// The agents (1-based) this one hears, in the order `step` takes their values.
    pub fn neighbours(&self) -> &[usize] {
        &self.neighbours
    }

    /// Whether this agent hears the leader.
    pub fn pinned(&self) -> bool {
        self.pinned
    }

    /// One sample: own state `x` (`n` values), the neighbours' outputs (one per
    /// [`Self::neighbours`], `None` when nothing was received) and the leader's `y_d` (`None`:
    /// not received; ignored unless pinned).
    pub fn step(
        &mut self,
        x: &[f32],
        neighbours: &[Option<f32>],
        leader: Option<f32>,
    ) -> Result<AgentStep> {
        if x.len() != self.n {
            return Err(Error::invalid(
                "x",
                format!("{} values given, the plant has n = {}", x.len(), self.n),
            ));
        }
        if neighbours.len() != self.neighbours.len() {
            return Err(Error::invalid(
                "neighbours",
                format!(
                    "{} values given, the agent hears {} (agents {:?})",
                    neighbours.len(),
                    self.neighbours.len(),
                    self.neighbours
                ),
            ));
        }
        let link = |v: Option<f32>| v.map_or(Link::Missing, Link::Fresh);
        let links: Vec<Link> = neighbours.iter().copied().map(link).collect();
        self.inner
            .step(x, &links, link(leader))
            .ok_or_else(|| Error::invalid("x", "wrong length"))
    }

    /// Back to the initial state (`k = 0`, estimates at their initial values).
    pub fn reset(&mut self) {
        self.inner.reset();
    }
}
