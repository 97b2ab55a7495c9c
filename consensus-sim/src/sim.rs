//! The closed loop (LAW §6 on the host): at each sample `t_k = k h` check the plant state,
//! exchange outputs over the link, step every controller, let observers record, then integrate
//! each plant over `[t_k, t_k + h)` with the quantized commands held (faults applied per stage).
//!
//! With a `[clock]`, [`Sim::run_clocked`] (in `sim/clocked.rs`) runs instead: every follower
//! samples at its own instants and the plants are integrated between them.
//!
//! Who computes the commands is an [`Agents`]: host-sim's own controllers fed through a
//! [`LinkModel`] ([`Linked`]), or firmware nodes over a simulated bus
//! (`consensus_hil::network::BusAgents`).

mod clocked;

use std::sync::{Arc, Mutex, OnceLock};

use controller_core::{Controller, ControllerConfig, Gains, Link, StepOutput};
use rayon::prelude::*;
use serde::Serialize;

pub use clocked::Release;

use crate::{
    clock::Clocks,
    faults::{ActuatorEffect, FaultSchedule, SineTable, Sines},
    figures::KindReport,
    graph::Graph,
    leader::Leader,
    network::ideal::{Inbox, LinkModel},
    plant::{rk4, Example1, Lanes, Plant},
};
use consensus_plot::error::{Error, Result};

/// What the loop needs from a validated scenario besides plant and agents.
#[derive(Debug, Clone)]
pub struct World {
    /// The reference `y_d(t)`.
    pub leader: Leader,
    /// The actuator fault schedule (LAW §7).
    pub faults: FaultSchedule,
    /// Initial states, one per agent.
    pub x0: Vec<Vec<f64>>,
    /// Sample period `h` \[s\].
    pub h: f64,
    /// RK4 steps per sample.
    pub substeps: u32,
    /// `|x|` above which the run counts as diverged.
    pub divergence_bound: f64,
    /// Number of samples.
    pub samples: u64,
    /// Sensor-fault windows: (0-based agent, from, until) on which the agent reads NaN.
    pub sensor: Vec<(usize, f64, f64)>,
}

/// Neighbour capacity `K` of every controller (in-degree limit, [`crate::graph::MAX_NEIGHBOURS`]).
pub const K: usize = crate::graph::MAX_NEIGHBOURS;

/// Where and when a state first became non-finite or left the divergence bound (LAW §11).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Divergence {
    /// `t_k` \[s\].
    pub time: f64,
    /// 1-based agent.
    pub agent: usize,
}

/// One sample as observers see it: states at `t_k` and the controllers' outputs of this step.
#[derive(Debug)]
pub struct SampleView<'a, const N: usize, const M: usize> {
    /// Sample index `k`.
    pub k: u64,
    /// `t_k = k h`.
    pub t: f64,
    /// `y_d(t_k)`.
    pub yd: f64,
    /// Plant states at `t_k`.
    pub x: &'a [[f64; N]],
    /// Controller outputs of this sample.
    pub out: &'a [StepOutput<N, M>],
}

/// Something that records samples (metrics, CSV, plots).
pub trait Observer<const N: usize, const M: usize> {
    /// Called once per sample, in order.
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()>;
}

/// Who turns the sampled states into commands, one [`StepOutput`] per agent per sample.
pub trait Agents<const N: usize, const M: usize> {
    /// Sample `k` at `t`: plant states `x` and `y_d(t)`; pushes one output per agent, in agent
    /// order, onto the (cleared) `out`. The plant holds each output's `q` over `[t, t + h)`.
    /// An error (e.g. an emulated node that stopped answering) ends the run.
    fn control(
        &mut self,
        k: u64,
        t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()>;
    /// The gains in force (agent 1's; all agents share the design values).
    fn gains(&self) -> Gains;
    /// Clocked runs: agent `i` (0-based) samples plant state `x` at true time `t` with its
    /// clock reading `now_us`, steps and sends; pushes the ages \[s\] of the neighbour and
    /// leader values its controller used onto `ages`.
    fn sample_at(
        &mut self,
        _i: usize,
        _t: f64,
        _now_us: u64,
        _x: &[f64; N],
        _ages: &mut Vec<f64>,
    ) -> Result<StepOutput<N, M>> {
        Err(unclocked())
    }
    /// Clocked runs: the leader sends `y_d` of sample `k` at `t = k h`.
    fn leader_sends(&mut self, _k: u64, _t: f64, _yd: f64) -> Result<()> {
        Err(unclocked())
    }
    /// Clocked runs: the network runs up to `until` \[s\], each node's clock from `clocks`;
    /// with `sync`, it stops at the first delivery of a leader frame and pushes the releases
    /// it gives onto `releases` (the caller plans them and calls again).
    fn run_until(
        &mut self,
        _until: f64,
        _sync: bool,
        _clocks: &Clocks,
        _releases: &mut Vec<Release>,
    ) -> Result<()> {
        Err(unclocked())
    }
    /// What these agents report for `summary.json`, one value per network kind (nothing
    /// beyond the loop's own figures for a link model).
    fn report(&self) -> KindReport {
        KindReport::Ideal
    }
    /// Figures of the agents' own (e.g. the firmware's cost per step) into `dir`, titled
    /// `title`, in the formats of `output` (`[figures]`).
    fn draw(
        &self,
        _dir: &std::path::Path,
        _h: f64,
        _title: &str,
        _output: consensus_plot::figure::Output,
    ) -> Result<()> {
        Ok(())
    }
    /// Called once after the last sample (flush a trace, stop emulators, collect figures).
    fn finish(&mut self) -> Result<()> {
        Ok(())
    }
}

fn unclocked() -> Error {
    Error::invalid("clock", "these agents cannot sample on their own clocks")
}

/// host-sim's own controllers, one per agent, hearing each other through a [`LinkModel`].
pub struct Linked<L, const N: usize, const M: usize> {
    graph: Graph,
    link: L,
    ctrls: Vec<Controller<N, M, K>>,
    y: Vec<f32>,
    inbox: Inbox,
    /// Clocked runs: each agent's last broadcast output and its sample time [s].
    sent: Vec<Option<(f32, f64)>>,
    /// Clocked runs: the leader's last `y_d`, its time [s] and sample.
    led: Option<(f32, f64, u64)>,
    /// Clocked runs: a leader broadcast not yet handed out as releases.
    unreleased: bool,
}

impl<L: LinkModel, const N: usize, const M: usize> Linked<L, N, M> {
    /// One controller per agent of `graph` (configurations in agent order), over `link`.
    pub fn new(graph: &Graph, configs: &[ControllerConfig<N>], link: L) -> Result<Self> {
        let n_agents = graph.len();
        let mut ctrls = Vec::with_capacity(n_agents);
        for (i, cfg) in configs.iter().enumerate() {
            let c = Controller::new(cfg)
                .map_err(|e| Error::invalid(format!("controller (agent {})", i + 1), e))?;
            ctrls.push(c);
        }
        let graph = graph.clone();
        Ok(Self {
            inbox: Inbox::new(&graph),
            link,
            ctrls,
            y: vec![0.0; n_agents],
            sent: vec![None; n_agents],
            led: None,
            unreleased: false,
            graph,
        })
    }
}

impl<L: LinkModel, const N: usize, const M: usize> Agents<N, M> for Linked<L, N, M> {
    fn control(
        &mut self,
        k: u64,
        t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()> {
        for (y, x) in self.y.iter_mut().zip(x) {
            *y = x[0] as f32;
        }
        self.link
            .exchange(k, t, &self.y, yd as f32, &self.graph, &mut self.inbox);
        let (graph, inbox) = (&self.graph, &self.inbox);
        let step = |i: usize, c: &mut Controller<N, M, K>| {
            let xs = x[i].map(|v| v as f32);
            c.step(&xs, inbox.of(graph, i), inbox.leader[i])
        };
        if parallel(self.ctrls.len()) {
            out.par_extend(
                self.ctrls
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(PAR_CHUNK)
                    .map(|(i, c)| step(i, c)),
            );
        } else {
            // Four agents at a time, their controllers' recursions overlapping (the same
            // outputs as one at a time, `Controller::step_side_by_side`); the rest one by one.
            let mut done = 0;
            let (groups, _) = self.ctrls.as_chunks_mut::<SIDE_BY_SIDE>();
            for (ctrls, x) in groups.iter_mut().zip(x.as_chunks::<SIDE_BY_SIDE>().0) {
                let xs = x.map(|x| x.map(|v| v as f32));
                let first = done;
                let links =
                    std::array::from_fn(|b| (inbox.of(graph, first + b), inbox.leader[first + b]));
                Controller::step_side_by_side(ctrls, &xs, links, out);
                done += SIDE_BY_SIDE;
            }
            out.extend(
                self.ctrls
                    .iter_mut()
                    .enumerate()
                    .skip(done)
                    .map(|(i, c)| step(i, c)),
            );
        }
        Ok(())
    }

    fn gains(&self) -> Gains {
        *self.ctrls[0].params().gains()
    }

    /// The ideal link without a common sample instant: agent `i` uses the latest value each
    /// neighbour broadcast (at its own last sample) and the leader's latest `y_d`.
    fn sample_at(
        &mut self,
        i: usize,
        t: f64,
        _now_us: u64,
        x: &[f64; N],
        ages: &mut Vec<f64>,
    ) -> Result<StepOutput<N, M>> {
        if !self.link.is_instant() {
            return Err(Error::invalid(
                "clock",
                "a clocked run over a link model needs the ideal link",
            ));
        }
        let o = self.graph.offset(i);
        for (slot, &j) in self.inbox.neighbours[o..]
            .iter_mut()
            .zip(self.graph.neighbours(i))
        {
            *slot = match self.sent[j] {
                Some((y, at)) => {
                    ages.push(t - at);
                    Link::Fresh(y)
                }
                None => Link::Missing,
            };
        }
        self.inbox.leader[i] = match self.led {
            Some((yd, at, _)) if self.graph.pinned(i) => {
                ages.push(t - at);
                Link::Fresh(yd)
            }
            _ => Link::Missing,
        };
        let xs = x.map(|v| v as f32);
        let out = self.ctrls[i].step(&xs, self.inbox.of(&self.graph, i), self.inbox.leader[i]);
        self.sent[i] = Some((xs[0], t));
        Ok(out)
    }

    fn leader_sends(&mut self, k: u64, t: f64, yd: f64) -> Result<()> {
        self.led = Some((yd as f32, t, k));
        self.unreleased = true;
        Ok(())
    }

    fn run_until(
        &mut self,
        until: f64,
        sync: bool,
        _clocks: &Clocks,
        releases: &mut Vec<Release>,
    ) -> Result<()> {
        if let Some((_, at, k)) = self.led.filter(|l| sync && self.unreleased && l.1 <= until) {
            self.unreleased = false;
            releases.extend((0..self.graph.len()).map(|agent| Release { agent, k, at }));
        }
        Ok(())
    }
}

/// The simulated world: plants and the agents (controllers and their network).
pub struct Sim<P: Plant<N, M>, A, const N: usize, const M: usize> {
    leader: Leader,
    faults: FaultSchedule,
    /// One agent of each fault class ([`FaultSchedule::classes`]).
    members: Vec<usize>,
    /// Time terms and fault effects of the stages of the sample being integrated.
    inputs: StageInputs<P::Time, M>,
    /// The plant's time terms at this run's stage times, computed before (by another run).
    stage_terms: Option<Arc<StageTerms<P::Time>>>,
    /// The stuck rules' `sin(ω t)` at this run's stage times, computed before (by another run).
    stuck_sines: Vec<SineTable>,
    plant: P,
    agents: A,
    /// Plant states at `t_k`, per agent.
    x: Vec<[f64; N]>,
    /// The plants, [`BATCH`] agents to a group: states and held commands.
    groups: Vec<Group<N, M>>,
    out: Vec<StepOutput<N, M>>,
    h: f64,
    substeps: u32,
    bound: f64,
    samples: u64,
    /// `[[faults.sensor]]`: (0-based agent, from, until) on which the agent reads NaN.
    sensor: Vec<(usize, f64, f64)>,
    seen: Vec<[f64; N]>,
}

impl<P: Plant<N, M> + Sync, L: LinkModel, const N: usize, const M: usize>
    Sim<P, Linked<L, N, M>, N, M>
where
    P::Time: Sync,
{
    /// Builds the controllers (over `link`) of `graph` and the plants of `world`.
    pub fn new(
        world: World,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        plant: P,
        link: L,
    ) -> Result<Self> {
        Self::with_agents(world, plant, Linked::new(graph, configs, link)?)
    }
}

impl<P: Plant<N, M> + Sync, A: Agents<N, M>, const N: usize, const M: usize> Sim<P, A, N, M>
where
    P::Time: Sync,
{
    /// Builds the plants of `world`; `agents` compute the commands.
    pub fn with_agents(world: World, plant: P, agents: A) -> Result<Self> {
        let n_agents = world.x0.len();
        let mut x = Vec::with_capacity(n_agents);
        for (i, row) in world.x0.iter().enumerate() {
            let a: [f64; N] = row.as_slice().try_into().map_err(|_| {
                Error::invalid(
                    format!("plant.x0[{}]", i + 1),
                    format!("expected {N} entries"),
                )
            })?;
            x.push(a);
        }
        let (class, members) = world.faults.classes();
        let groups = x
            .chunks(BATCH)
            .zip(class.chunks(BATCH))
            .map(|(x, c)| Group::new(x, c))
            .collect();
        Ok(Self {
            leader: world.leader,
            faults: world.faults,
            inputs: StageInputs::new(members.len(), world.substeps),
            stage_terms: None,
            stuck_sines: Vec::new(),
            members,
            groups,
            plant,
            agents,
            x,
            out: Vec::with_capacity(n_agents),
            h: world.h,
            substeps: world.substeps,
            bound: world.divergence_bound,
            samples: world.samples,
            sensor: world.sensor,
            seen: Vec::new(),
        })
    }

    /// The gains in force (agent 1's; all agents share the design values).
    pub fn gains(&self) -> Gains {
        self.agents.gains()
    }

    /// Takes the plant's time terms and the stuck rules' `sin(ω t)` from `terms` (computed
    /// before, e.g. by another run of a campaign) instead of computing them, if it holds this
    /// run's stage times.
    pub fn share_stage_terms(&mut self, terms: Arc<StageTerms<P::Time>>) {
        if terms.fits(self.h, self.substeps, self.samples) {
            self.stuck_sines = self
                .faults
                .stuck_omegas()
                .into_iter()
                .map(|w| terms.sines(w))
                .collect();
            self.stage_terms = Some(terms);
        }
    }

    /// The agents (e.g. to read network statistics after a run).
    pub fn agents(&self) -> &A {
        &self.agents
    }

    /// The agents, mutable (to finish them after a run).
    pub fn agents_mut(&mut self) -> &mut A {
        &mut self.agents
    }

    /// The first agent whose state is non-finite or above the bound.
    fn diverged_agent(&self) -> Option<usize> {
        // Within a finite bound every state is finite: one pass without early exits first.
        let within = |ok: bool, v: &f64| ok & (v.abs() <= self.bound);
        if self.bound.is_finite() && self.x.iter().flatten().fold(true, within) {
            return None;
        }
        self.x
            .iter()
            .position(|x| x.iter().any(|v| !v.is_finite() || v.abs() > self.bound))
    }

    /// Runs all samples; `progress(k)` is called every 1024 samples. Returns the divergence
    /// that stopped the run, if any.
    pub fn run(
        &mut self,
        observers: &mut [&mut dyn Observer<N, M>],
        mut progress: impl FnMut(u64),
    ) -> Result<Option<Divergence>> {
        for k in 0..self.samples {
            let t = k as f64 * self.h;
            if let Some(i) = self.diverged_agent() {
                return Ok(Some(Divergence {
                    time: t,
                    agent: i + 1,
                }));
            }
            let yd = self.control(k, t)?;
            let view = SampleView {
                k,
                t,
                yd,
                x: &self.x,
                out: &self.out,
            };
            for o in observers.iter_mut() {
                o.sample(&view)?;
            }
            self.integrate(t);
            if k.is_multiple_of(1024) {
                progress(k);
            }
        }
        progress(self.samples);
        Ok(self.diverged_agent().map(|i| Divergence {
            time: self.samples as f64 * self.h,
            agent: i + 1,
        }))
    }

    /// Every agent's step (links included); returns `y_d(t_k)`.
    fn control(&mut self, k: u64, t: f64) -> Result<f64> {
        let yd = self.leader.yd(t);
        self.out.clear();
        if self.sensor.is_empty() {
            self.agents.control(k, t, &self.x, yd, &mut self.out)?;
        } else {
            // What the controllers read: NaN for an agent inside one of its sensor windows.
            self.seen.clone_from(&self.x);
            for &(i, from, until) in &self.sensor {
                if (from..until).contains(&t) {
                    self.seen[i] = [f64::NAN; N];
                }
            }
            self.agents.control(k, t, &self.seen, yd, &mut self.out)?;
        }
        for (g, out) in self.groups.iter_mut().zip(self.out.chunks(BATCH)) {
            for (b, o) in out.iter().enumerate() {
                for (q, &v) in g.q.iter_mut().zip(&o.q) {
                    q[b] = f64::from(v);
                }
            }
        }
        Ok(yd)
    }

    /// Every plant over `[t, t + h)`: RK4 substeps, commands held, faults per stage time.
    ///
    /// The time terms and the fault effects of every stage are computed once (per fault class),
    /// then each agent takes its substeps; agents are independent, so on a large group they are
    /// integrated in parallel with the same result at any thread count.
    fn integrate(&mut self, t: f64) {
        let dt = self.h / f64::from(self.substeps);
        self.inputs.stage_times(t, self.h, self.substeps);
        let shared = self.stage_terms.as_deref();
        self.inputs.fill(
            &self.plant,
            shared,
            &self.faults,
            &self.members,
            &self.stuck_sines,
        );
        let (plant, inputs) = (&self.plant, &self.inputs);
        let step = |g: &mut Group<N, M>, x: &mut [[f64; N]]| {
            advance(plant, inputs, g, dt);
            g.scatter(x);
        };
        if parallel(self.x.len()) {
            self.groups
                .par_iter_mut()
                .zip(self.x.par_chunks_mut(BATCH))
                .with_min_len(PAR_CHUNK / BATCH)
                .for_each(|(g, x)| step(g, x));
        } else {
            for (g, x) in self.groups.iter_mut().zip(self.x.chunks_mut(BATCH)) {
                step(g, x);
            }
        }
    }
}

/// Agents integrated side by side by [`rk4`].
const BATCH: usize = 4;

/// Agents whose controllers step side by side ([`Controller::step_side_by_side`]).
const SIDE_BY_SIDE: usize = 4;

/// The inputs of one sample's RK4 stages that depend on time only: the plant's time terms and
/// every fault class's actuator effects, computed once per distinct stage time (a substep's end
/// is usually the next one's start, to the bit, and the sample's last is the next sample's first).
///
/// Fixed-size storage sized once per run (no allocation per sample): at most `3 · substeps`
/// stage times per sample plus the one carried over from the sample before.
struct StageInputs<T, const M: usize> {
    /// The distinct stage times of this sample (the first may be the previous sample's last).
    times: Vec<f64>,
    /// Per stage time, the plant's time terms.
    terms: Vec<T>,
    /// Per fault class `c` and actuator `l`, the effect at each stage time `i`:
    /// `effects[(c M + l) stride + i]`.
    effects: Vec<ActuatorEffect>,
    /// Stage times room per class and actuator in `effects`.
    stride: usize,
    /// Fault classes.
    classes: usize,
    /// Per substep the indices of its start, midpoint and end in `times`.
    at: Vec<[usize; 3]>,
    /// The first stage time of this sample whose terms and effects are still to be computed.
    fresh: usize,
    /// Distinct stage times of the run so far: the index of the next one in a [`StageTerms`].
    cursor: usize,
}

impl<T: Copy, const M: usize> StageInputs<T, M> {
    fn new(classes: usize, substeps: u32) -> Self {
        let substeps = substeps as usize;
        let stride = 3 * substeps + 1;
        Self {
            times: Vec::with_capacity(stride),
            terms: Vec::with_capacity(stride),
            effects: vec![ActuatorEffect::HEALTHY; classes * M * stride],
            stride,
            classes,
            at: Vec::with_capacity(substeps),
            fresh: 0,
            cursor: 0,
        }
    }

    /// Forgets the last sample's stage times but its last one (moved to the front).
    fn begin_sample(&mut self) {
        if let Some(last) = self.times.len().checked_sub(1) {
            to_front(&mut self.times, last);
            to_front(&mut self.terms, last);
            for row in self.effects.chunks_exact_mut(self.stride) {
                to_front(row, last);
            }
            self.times.truncate(1);
            self.terms.truncate(1);
        }
        self.fresh = self.times.len();
        self.at.clear();
    }

    /// The stage times of the sample at `t` (period `h`, `substeps` RK4 steps): each substep's
    /// start, midpoint and end.
    fn stage_times(&mut self, t: f64, h: f64, substeps: u32) {
        let dt = h / f64::from(substeps);
        self.begin_sample();
        for s in 0..substeps {
            let t0 = t + f64::from(s) * dt;
            // Written out rather than `[..].map(..)`: the array closure was an out-of-line call
            // per substep.
            let at = [
                self.index(t0),
                self.index(t0 + 0.5 * dt),
                self.index(t0 + dt),
            ];
            self.at.push(at);
        }
    }

    /// The index of stage time `t`: the last one if equal to it, else a new one (its terms and
    /// effects follow in [`StageInputs::fill`]).
    #[inline]
    fn index(&mut self, t: f64) -> usize {
        match self.times.last() {
            Some(l) if l.to_bits() == t.to_bits() => self.times.len() - 1,
            _ => {
                self.times.push(t);
                self.times.len() - 1
            }
        }
    }

    /// The time terms of `plant` (from `shared` where it has them) and the effects of every
    /// fault class (class `c` as its agent `members[c]` of `faults`, stuck rules' `sin(ω t)`
    /// from `sines` where it has them) at the stage times added since
    /// [`StageInputs::begin_sample`].
    fn fill<const N: usize, P: Plant<N, M, Time = T>>(
        &mut self,
        plant: &P,
        shared: Option<&StageTerms<T>>,
        faults: &FaultSchedule,
        members: &[usize],
        sines: &[SineTable],
    ) {
        let new = self.times.get(self.fresh..).unwrap_or_default();
        let shared = shared
            .and_then(|s| s.terms.get(self.cursor..))
            .unwrap_or_default();
        // The run's `k`-th distinct stage time is the table's `k`-th (the same code makes both
        // sequences); past its end, or without one, the plant computes its terms.
        let mut from_table = shared.iter();
        self.terms.extend(
            new.iter()
                .map(|&t| from_table.next().copied().unwrap_or_else(|| plant.at(t))),
        );
        let sines = Sines::new(sines, self.cursor);
        self.cursor += new.len();
        let (from, to) = (self.fresh, self.times.len());
        for (row, (c, l)) in self
            .effects
            .chunks_exact_mut(self.stride)
            .zip((0..self.classes).flat_map(|c| (0..M).map(move |l| (c, l))))
        {
            if let (Some(&agent), Some(out)) = (members.get(c), row.get_mut(from..to)) {
                faults.effects_at(agent, l, new, sines, out);
            }
        }
        self.fresh = to;
    }

    /// Substep `s`'s time terms at its start, midpoint and end.
    #[inline]
    fn time(&self, s: usize) -> [T; 3] {
        let [t0, t1, t2] = self.at[s];
        [self.terms[t0], self.terms[t1], self.terms[t2]]
    }

    /// Substep `s`'s actuator outputs of group `g` at its start, midpoint and end.
    #[inline(always)]
    fn act<const N: usize>(&self, s: usize, g: &Group<N, M>) -> [Lanes<M, BATCH>; 3] {
        let [t0, t1, t2] = self.at[s];
        let effect = |i: usize, c: usize, l: usize| self.effects[(c * M + l) * self.stride + i];
        match g.class {
            Classes::Healthy => [g.q; 3],
            Classes::One(c) => {
                let at = |i: usize| -> Lanes<M, BATCH> {
                    std::array::from_fn(|l| {
                        let e = effect(i, c, l);
                        std::array::from_fn(|b| e.on(g.q[l][b]))
                    })
                };
                [at(t0), at(t1), at(t2)]
            }
            Classes::Mixed(class) => {
                let at = |i: usize| -> Lanes<M, BATCH> {
                    std::array::from_fn(|l| {
                        std::array::from_fn(|b| match class[b] {
                            Some(c) => effect(i, c, l).on(g.q[l][b]),
                            None => g.q[l][b],
                        })
                    })
                };
                [at(t0), at(t1), at(t2)]
            }
        }
    }
}

/// Moves entry `i` of `v` to the front (if there is one).
fn to_front<X>(v: &mut [X], i: usize) {
    if i < v.len() {
        v.swap(0, i);
    }
}

/// The plant's time terms (`Plant::at`) at every distinct RK4 stage time of a run, in order:
/// they depend on the sample period, the substeps and the number of samples only, so the runs
/// of a campaign that share these (and the plant) share one table instead of each computing
/// them (Example 1: `cos t` at nine stage times per sample).
#[derive(Debug)]
pub struct StageTerms<T> {
    h: f64,
    substeps: u32,
    samples: u64,
    /// The distinct stage times.
    times: Vec<f64>,
    terms: Vec<T>,
    /// `sin(ω t)` at `times` for the stuck rules' `ω` asked for so far.
    sines: Mutex<Vec<SineTable>>,
}

impl<T: Copy> StageTerms<T> {
    /// The terms of `plant` at the stage times of `samples` samples of period `h`, `substeps`
    /// RK4 steps each: the times of [`Sim::run`], found by the same code.
    pub fn new<const N: usize, const M: usize, P: Plant<N, M, Time = T>>(
        plant: &P,
        h: f64,
        substeps: u32,
        samples: u64,
    ) -> Self {
        let mut inputs = StageInputs::<T, M>::new(0, substeps);
        let (mut times, mut terms) = (Vec::new(), Vec::new());
        let faults = FaultSchedule::healthy(0, M);
        for k in 0..samples {
            inputs.stage_times(k as f64 * h, h, substeps);
            inputs.fill(plant, None, &faults, &[], &[]);
            let skip = usize::from(k > 0);
            times.extend(inputs.times.iter().skip(skip));
            terms.extend(inputs.terms.iter().skip(skip));
        }
        Self {
            h,
            substeps,
            samples,
            times,
            terms,
            sines: Mutex::new(Vec::new()),
        }
    }

    /// `sin(ω t)` at the stage times: the table computed before for this `ω`, or a new one.
    pub fn sines(&self, omega: f64) -> SineTable {
        // A poisoned lock only means another run panicked while computing a table: the
        // tables already in it are complete.
        let mut tables = self
            .sines
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(t) = tables.iter().find(|t| t.omega.to_bits() == omega.to_bits()) {
            return t.clone();
        }
        let t = SineTable::new(omega, &self.times);
        tables.push(t.clone());
        t
    }

    /// Whether this table holds the stage times of a run of `samples` samples of period `h`,
    /// `substeps` RK4 steps each (a shorter run uses its beginning).
    pub fn fits(&self, h: f64, substeps: u32, samples: u64) -> bool {
        self.h.to_bits() == h.to_bits() && self.substeps == substeps && self.samples >= samples
    }
}

/// Example 1's time terms ([`StageTerms`] of `cos t`), computed by the first run that asks
/// for them and shared by the runs after it (the runs of a campaign).
#[derive(Debug, Default)]
pub struct SharedStageTerms(OnceLock<Arc<StageTerms<f64>>>);

impl SharedStageTerms {
    /// The table of Example 1 for `samples` samples of period `h`, `substeps` RK4 steps each:
    /// the one computed before, or a new one. A run whose timing differs from the first run's
    /// gets the first one's, which [`Sim::share_stage_terms`] then declines.
    pub fn example1(&self, h: f64, substeps: u32, samples: u64) -> Arc<StageTerms<f64>> {
        Arc::clone(
            self.0.get_or_init(|| {
                Arc::new(StageTerms::new::<2, 2, _>(&Example1, h, substeps, samples))
            }),
        )
    }
}

/// The fault classes of a group's agents.
#[derive(Debug, Clone, Copy)]
enum Classes {
    /// No faults.
    Healthy,
    /// All of one class.
    One(usize),
    /// Per agent (`None`: healthy).
    Mixed([Option<usize>; BATCH]),
}

/// [`BATCH`] agents' plants side by side ([`Lanes`]), integrated together: the vector units
/// take several agents' same operation at once and their dependent chains overlap. The last
/// group is padded with agents that restart at rest every sample (their results are unused).
#[derive(Debug, Clone)]
struct Group<const N: usize, const M: usize> {
    /// States.
    x: Lanes<N, BATCH>,
    /// Commands held over the sample.
    q: Lanes<M, BATCH>,
    class: Classes,
}

impl<const N: usize, const M: usize> Group<N, M> {
    /// The agents of states `x` and fault classes `class` (up to [`BATCH`] of them).
    fn new(x: &[[f64; N]], class: &[Option<usize>]) -> Self {
        let mut g = Self {
            x: [[0.0; BATCH]; N],
            q: [[0.0; BATCH]; M],
            // A padding agent takes the first one's class.
            class: if class.iter().all(|&c| c == class[0]) {
                class[0].map_or(Classes::Healthy, Classes::One)
            } else {
                Classes::Mixed(std::array::from_fn(|b| class.get(b).copied().flatten()))
            },
        };
        g.load(x);
        g
    }

    /// Sets the states of the group's agents; padding ones at rest.
    fn load(&mut self, x: &[[f64; N]]) {
        for (j, lane) in self.x.iter_mut().enumerate() {
            *lane = std::array::from_fn(|b| x.get(b).map_or(0.0, |x| x[j]));
        }
    }

    /// Copies the states out to the group's agents (and puts padding ones back at rest).
    fn scatter(&mut self, x: &mut [[f64; N]]) {
        for (b, x) in x.iter_mut().enumerate() {
            *x = std::array::from_fn(|j| self.x[j][b]);
        }
        for lane in &mut self.x {
            lane[x.len()..].fill(0.0);
        }
    }
}

/// Group `g`'s plants over one sample's RK4 substeps. Not inlined into the loop: its lanes are
/// loaded and stored whole, which is what makes the compiler vectorise across agents.
#[inline(never)]
fn advance<P: Plant<N, M>, const N: usize, const M: usize>(
    plant: &P,
    inputs: &StageInputs<P::Time, M>,
    g: &mut Group<N, M>,
    dt: f64,
) {
    let mut x = g.x;
    for s in 0..inputs.at.len() {
        rk4(plant, &mut x, dt, &inputs.time(s), &inputs.act(s, g));
    }
    g.x = x;
}

/// Smallest group stepped in parallel (below it a thread hand-off costs more than it saves).
pub const PAR_MIN_AGENTS: usize = 256;

/// Agents per parallel work item (a multiple of [`BATCH`]).
const PAR_CHUNK: usize = 64;

/// Whether a group of `agents` is stepped on several threads (rayon's pool has more than one).
fn parallel(agents: usize) -> bool {
    agents >= PAR_MIN_AGENTS && rayon::current_num_threads() > 1
}
