//! The loop with a clock per follower ([`crate::clock`]): events in true-time order.
//!
//! * a follower's sample: its plant is integrated up to that instant with its own command
//!   held, it samples, steps and sends ([`Agents::sample_at`]); its next instant comes from
//!   its clock (`sync = "none"`) or from the next leader frame that reaches it (`"leader"`);
//! * the plant's instant `t_k = k h`: every plant is integrated up to `t_k`, the divergence
//!   check and the observers (metrics, CSV, plots) see the states at `t_k` with the command
//!   each follower holds then, and the leader sends `y_d(t_k)` ([`Agents::leader_sends`]).
//!
//! Before each event the network runs up to it ([`Agents::run_until`]); at equal times a
//! follower's sample goes before the plant's instant, lower agents first; the run ends at
//! `K h` (samples at or after it are not taken). Each plant is an
//! RK4 integration over its own intervals between events, in substeps no longer than
//! `h / substeps`.

use std::collections::VecDeque;

use controller_core::{Estimates, StepOutput, StepStatus};

use super::{Agents, Divergence, Observer, SampleView, Sim};
use crate::{
    clock::{Clocks, SyncMode},
    faults::ActuatorEffect,
    plant::{rk4, Lanes, Plant},
};
use consensus_plot::error::Result;

/// A leader frame of sample `k` that reached agent `agent` (0-based) at true time `at` \[s\]:
/// it releases the agent's sampling (`sync = "leader"`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Release {
    /// 0-based agent.
    pub agent: usize,
    /// The leader's sample.
    pub k: u64,
    /// Delivery time \[s\].
    pub at: f64,
}

/// What an agent holds before its first sample: no command.
fn idle<const N: usize, const M: usize>() -> StepOutput<N, M> {
    StepOutput {
        u: [0.0; M],
        q: [0.0; M],
        e: [0.0; N],
        alpha: [0.0; N],
        beta: [0.0; N],
        estimates: Estimates {
            mu: 0.0,
            xi: 0.0,
            lambda: 0.0,
        },
        varpi: 0.0,
        status: StepStatus::default(),
    }
}

impl<P: Plant<N, M> + Sync, A: Agents<N, M>, const N: usize, const M: usize> Sim<P, A, N, M>
where
    P::Time: Sync,
{
    /// Runs all samples with the followers on `clocks` (module docs); `progress(k)` is called
    /// every 1024 plant instants. Returns the divergence that stopped the run, if any.
    pub fn run_clocked(
        &mut self,
        clocks: &mut Clocks,
        observers: &mut [&mut dyn Observer<N, M>],
        mut progress: impl FnMut(u64),
    ) -> Result<Option<Divergence>> {
        let n = self.x.len();
        let sync = clocks.sync() == SyncMode::Leader;
        let mut edges = vec![
            Edge {
                t: 0.0,
                stage: None
            };
            n
        ];
        let mut held = vec![[0.0; M]; n];
        self.out.clear();
        self.out.resize(n, idle());
        // Per agent, its coming samples `(s, k)` in time order.
        let mut coming: Vec<VecDeque<(f64, u64)>> = vec![VecDeque::new(); n];
        if !sync {
            for (i, c) in coming.iter_mut().enumerate() {
                c.push_back(clocks.next_own(i));
            }
        }
        let mut releases = Vec::new();
        let mut ages = Vec::new();
        let mut k = 0;
        loop {
            let t_k = k as f64 * self.h;
            let first = coming
                .iter()
                .enumerate()
                .filter_map(|(i, c)| c.front().map(|&(s, _)| (s, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .filter(|&(s, _)| s < t_k || (s == t_k && k < self.samples));
            let e = first.map_or(t_k, |(s, _)| s);
            releases.clear();
            self.agents.run_until(e, sync, clocks, &mut releases)?;
            if !releases.is_empty() {
                for r in &releases {
                    let s = r.at + clocks.jitter(r.agent);
                    let c = &mut coming[r.agent];
                    let at = c.partition_point(|&(t, _)| t <= s);
                    c.insert(at, (s, r.k));
                }
                continue;
            }
            if let Some((s, i)) = first {
                let Some((_, ks)) = coming[i].pop_front() else {
                    continue;
                };
                let mut x = self.x[i];
                self.advance_agent(i, &mut x, &mut edges[i], s, &held[i]);
                self.x[i] = x;
                if self
                    .sensor
                    .iter()
                    .any(|&(a, from, until)| a == i && (from..until).contains(&s))
                {
                    x = [f64::NAN; N];
                }
                ages.clear();
                let out = self
                    .agents
                    .sample_at(i, s, clocks.local_us(i, s), &x, &mut ages)?;
                for &a in &ages {
                    clocks.age(a);
                }
                clocks.sampled(i, ks, s);
                held[i] = out.q.map(f64::from);
                self.out[i] = out;
                if !sync {
                    coming[i].push_back(clocks.next_own(i));
                }
                continue;
            }
            for (i, edge) in edges.iter_mut().enumerate() {
                let mut x = self.x[i];
                self.advance_agent(i, &mut x, edge, t_k, &held[i]);
                self.x[i] = x;
            }
            if let Some(i) = self.diverged_agent() {
                return Ok(Some(Divergence {
                    time: t_k,
                    agent: i + 1,
                }));
            }
            if k == self.samples {
                progress(self.samples);
                return Ok(None);
            }
            let yd = self.leader.yd(t_k);
            let view = SampleView {
                k,
                t: t_k,
                yd,
                x: &self.x,
                out: &self.out,
            };
            for o in observers.iter_mut() {
                o.sample(&view)?;
            }
            self.agents.leader_sends(k, t_k, yd)?;
            if k.is_multiple_of(1024) {
                progress(k);
            }
            k += 1;
        }
    }

    /// Agent `i`'s plant from `edge.t` to `to` with its actuators' command `q` held (faults per
    /// stage time): RK4 in equal substeps no longer than `h / substeps`. The time terms and
    /// fault effects at a substep's end are its successor's start, also across calls.
    fn advance_agent(
        &self,
        i: usize,
        x: &mut [f64; N],
        edge: &mut Edge<P::Time, M>,
        to: f64,
        q: &[f64; M],
    ) {
        let span = to - edge.t;
        if span <= 0.0 {
            return;
        }
        let longest = self.h / f64::from(self.substeps);
        // A span that is a whole number of substeps up to rounding takes that number.
        let steps = (span / longest * (1.0 - 1e-9)).ceil().max(1.0);
        let dt = span / steps;
        let stage = |t: f64| Stage {
            time: self.plant.at(t),
            effects: std::array::from_fn(|l| self.faults.effect(i, l, t)),
        };
        let act = |s: &Stage<P::Time, M>| -> Lanes<M, 1> {
            std::array::from_fn(|l| [s.effects[l].on(q[l])])
        };
        let from = edge.t;
        let mut lanes: Lanes<N, 1> = std::array::from_fn(|j| [x[j]]);
        let mut start = edge.stage.take().unwrap_or_else(|| stage(from));
        let last = steps as u64 - 1;
        for s in 0..=last {
            let t0 = from + s as f64 * dt;
            let t1 = if s == last {
                to
            } else {
                from + (s + 1) as f64 * dt
            };
            let (mid, end) = (stage(t0 + 0.5 * dt), stage(t1));
            rk4(
                &self.plant,
                &mut lanes,
                dt,
                &[start.time, mid.time, end.time],
                &[act(&start), act(&mid), act(&end)],
            );
            start = end;
        }
        *x = std::array::from_fn(|j| lanes[j][0]);
        *edge = Edge {
            t: to,
            stage: Some(start),
        };
    }
}

/// The time terms and fault effects of one stage time.
#[derive(Debug, Clone, Copy)]
struct Stage<T, const M: usize> {
    time: T,
    effects: [ActuatorEffect; M],
}

/// Where an agent's plant integration has got to, with that instant's stage inputs.
#[derive(Debug, Clone, Copy)]
struct Edge<T, const M: usize> {
    t: f64,
    stage: Option<Stage<T, M>>,
}
