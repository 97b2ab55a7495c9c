//! `[network]`: how the agents talk, one module per kind, and what the kinds share.
//!
//! * [`ideal`] (`kind = "ideal"`, the default): host-sim's own controllers (`sim::Linked`)
//!   hear each other through a [`LinkModel`]; [`IdealLink`] is the paper's instantaneous one.
//! * [`can`] (`kind = "can"`): every agent an `agent-node` node on `hil-mock`'s mocked
//!   hardware over its simulated CAN bus ([`CanAgents`]).
//! * [`pil`] (`kind = "pil"`): every agent the node firmware on its own emulated Cortex-M4F,
//!   the bus model on the host ([`PilAgents`]).
//! * [`socketcan`] (`kind = "socketcan"`): every agent a node process on a Linux CAN
//!   interface, host-sim the plant and leader in real time ([`SocketcanAgents`]).
//! * [`trace`]: the candump log of every frame on the bus (`--trace`), for both bus kinds.
//! * [`spec`]: the `[network]` section, its checks, the bus settings and node settings it
//!   gives.
//!
//! [`BusAgents`] picks the agents of a bus kind, so the run loop is built once for all of
//! them; a new kind is one more module and one more variant. The model and its figures: `docs/NETWORK.md`.

pub mod canopen;
pub mod pil;
pub mod socketcan;

// The library's kinds and network blocks, under the paths they had before the split.
pub use consensus_sim::network::{can, ideal, node, spec, trace};

use std::path::Path;

use controller_core::{ControllerConfig, Gains, StepOutput};

pub use crate::network::{pil::PilAgents, socketcan::SocketcanAgents};
use consensus_plot::error::{Error, Result};
use consensus_sim::{
    clock::Clocks,
    figures::KindReport,
    graph::Graph,
    sim::{Agents, Release},
};
pub use consensus_sim::{
    figures::NetworkSummary,
    network::{
        can::CanAgents,
        ideal::{IdealLink, Inbox, Link, LinkModel},
        node::NodeSpec,
        spec::{
            bus_config, validate, EventName, NetworkEvent, NetworkKind, NetworkSpec,
            SensorFramesName, MAX_BITRATE, MAX_CAN_AGENTS, STATE_PERIOD_S,
        },
        trace::Traces,
    },
};

/// The output of a node that reports only some of it (filled in by the caller): commands and
/// errors 0, the estimates 0, the rest NaN (no output uses `alpha`, `beta`, `varpi`).
pub(crate) fn unreported_output<const N: usize, const M: usize>() -> StepOutput<N, M> {
    StepOutput {
        u: [0.0; M],
        q: [0.0; M],
        e: [0.0; N],
        alpha: [f32::NAN; N],
        beta: [f32::NAN; N],
        estimates: controller_core::Estimates {
            mu: 0.0,
            xi: 0.0,
            lambda: 0.0,
        },
        varpi: f32::NAN,
        status: controller_core::StepStatus::default(),
    }
}

/// The agents of a bus network kind: node firmware over the simulated CAN bus, host-compiled
/// or emulated.
pub enum BusAgents<const N: usize, const M: usize> {
    /// `kind = "can"`.
    Can(Box<CanAgents<N, M>>),
    /// `kind = "pil"`.
    Pil(Box<PilAgents<N, M>>),
    /// `kind = "socketcan"`.
    Socketcan(Box<SocketcanAgents<N, M>>),
}

impl<const N: usize, const M: usize> BusAgents<N, M> {
    /// The agents of `spec.kind` for the validated `graph`, with their controller
    /// configurations (`configs`, in agent order), sample period `h` and `samples` samples;
    /// the frames on the bus, and on the serial links of `"pil"`, go to the candump logs of
    /// `traces` when given. The ideal kind has no bus: an error naming `network.kind`.
    pub fn new(
        spec: &NetworkSpec,
        node: &NodeSpec,
        h: f64,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        samples: u64,
        traces: Traces<'_>,
    ) -> Result<Self> {
        traces.check(spec.kind)?;
        match spec.kind {
            NetworkKind::Ideal => Err(Error::invalid(
                "network.kind",
                "\"ideal\" has no bus: host-sim's controllers run over a link model",
            )),
            NetworkKind::Can => CanAgents::new(spec, node, h, graph, configs, traces.bus)
                .map(|a| Self::Can(Box::new(a))),
            NetworkKind::Pil => PilAgents::new(spec, node, h, graph, configs, samples, traces)
                .map(|a| Self::Pil(Box::new(a))),
            NetworkKind::Socketcan => {
                SocketcanAgents::new(spec, node, h, graph, configs, traces.bus)
                    .map(|a| Self::Socketcan(Box::new(a)))
            }
        }
    }

    fn agents(&self) -> &dyn Agents<N, M> {
        match self {
            Self::Can(a) => a.as_ref(),
            Self::Pil(a) => a.as_ref(),
            Self::Socketcan(a) => a.as_ref(),
        }
    }

    fn agents_mut(&mut self) -> &mut dyn Agents<N, M> {
        match self {
            Self::Can(a) => a.as_mut(),
            Self::Pil(a) => a.as_mut(),
            Self::Socketcan(a) => a.as_mut(),
        }
    }
}

impl<const N: usize, const M: usize> Agents<N, M> for BusAgents<N, M> {
    fn control(
        &mut self,
        k: u64,
        t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()> {
        self.agents_mut().control(k, t, x, yd, out)
    }

    fn gains(&self) -> Gains {
        self.agents().gains()
    }

    fn sample_at(
        &mut self,
        i: usize,
        t: f64,
        now_us: u64,
        x: &[f64; N],
        ages: &mut Vec<f64>,
    ) -> Result<StepOutput<N, M>> {
        self.agents_mut().sample_at(i, t, now_us, x, ages)
    }

    fn leader_sends(&mut self, k: u64, t: f64, yd: f64) -> Result<()> {
        self.agents_mut().leader_sends(k, t, yd)
    }

    fn run_until(
        &mut self,
        until: f64,
        sync: bool,
        clocks: &Clocks,
        releases: &mut Vec<Release>,
    ) -> Result<()> {
        self.agents_mut().run_until(until, sync, clocks, releases)
    }

    fn report(&self) -> KindReport {
        self.agents().report()
    }

    fn draw(
        &self,
        dir: &Path,
        h: f64,
        title: &str,
        output: consensus_plot::figure::Output,
    ) -> Result<()> {
        self.agents().draw(dir, h, title, output)
    }

    fn finish(&mut self) -> Result<()> {
        self.agents_mut().finish()
    }
}
