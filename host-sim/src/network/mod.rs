//! `[network]`: how the agents talk. `kind = "ideal"` (the default) is host-sim's
//! [`crate::link::IdealLink`]; `kind = "can"` runs every agent as a `hil-mock` firmware
//! [`hil_mock::Node`] (its own controller, freshness policy and Q7.16 frames) on mocked hardware
//! over `hil-mock`'s CAN-like bus, via [`hil_mock::network::CanNetwork`]. The plant, faults,
//! metrics and outputs are the simulator's, unchanged; `summary.json` gains a `network` object
//! ([`NetworkSummary`]). The model and its figures: `docs/NETWORK.md`.

pub mod spec;

pub use crate::figures::NetworkSummary;

pub use spec::{
    bus_config, validate, EventName, NetworkEvent, NetworkKind, NetworkSpec, MAX_BITRATE,
    MAX_CAN_AGENTS,
};

use controller_core::{ControllerConfig, Gains, StepOutput};
use hil_mock::{
    bus::Nanos,
    network::{AgentSetup, CanNetwork},
    NodeConfig,
};

use crate::{
    error::{Error, Result},
    graph::Graph,
    report::trace::{TraceWriter, INTERFACE},
    sim::{Agents, K},
};
use spec::ns;

/// Every agent a `hil-mock` node over the simulated CAN bus (`kind = "can"`).
pub struct CanAgents<const N: usize, const M: usize> {
    net: CanNetwork<N, M, K>,
    h_ns: Nanos,
    bitrate: u32,
    states: Vec<[f32; N]>,
    trace: Option<TraceWriter>,
}

impl<const N: usize, const M: usize> CanAgents<N, M> {
    /// One node per agent of the validated `graph`, with its controller configuration
    /// (`configs`, in agent order) and neighbours, on the bus of `[network]` (`spec`, sample
    /// period `h`); every frame on the bus goes to `trace` (candump log) when given.
    pub fn new(
        spec: &NetworkSpec,
        h: f64,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        trace: Option<&std::path::Path>,
    ) -> Result<Self> {
        let stale = spec.stale_timeout.unwrap_or(2.5 * h);
        let stale_timeout_us = ((stale * 1e6).round() as u64).max(1);
        let mut agents = Vec::with_capacity(graph.len());
        for (i, controller) in configs.iter().enumerate() {
            let agent = u8::try_from(i + 1).map_err(|_| {
                Error::invalid(
                    "network.kind",
                    format!("\"can\" carries at most {MAX_CAN_AGENTS} agents"),
                )
            })?;
            let mut neighbours = [0u8; K];
            for (d, &k) in neighbours.iter_mut().zip(graph.neighbours(i)) {
                *d = u8::try_from(k + 1).unwrap_or(0);
            }
            agents.push(AgentSetup {
                node: NodeConfig {
                    agent,
                    neighbours,
                    stale_timeout_us,
                },
                controller: *controller,
            });
        }
        let cfg = bus_config(spec, h);
        let bitrate = cfg.bitrate;
        let mut net = CanNetwork::new(cfg, &agents).map_err(|e| Error::invalid("network", e))?;
        let trace = trace.map(TraceWriter::create).transpose()?;
        if trace.is_some() {
            net.bus_mut().record_wire();
        }
        Ok(Self {
            net,
            h_ns: ns(h),
            bitrate,
            states: vec![[0.0; N]; graph.len()],
            trace,
        })
    }

    /// The network (nodes, bus, statistics).
    pub fn network(&self) -> &CanNetwork<N, M, K> {
        &self.net
    }

    /// The figures of `summary.json` `network`.
    pub fn summary(&self) -> NetworkSummary {
        let nodes = self.net.nodes();
        NetworkSummary::new(
            NetworkKind::Can,
            self.bitrate,
            &self.net.stats(),
            nodes
                .iter()
                .map(|n| u64::from(n.stats().malformed.total()))
                .sum(),
            nodes
                .iter()
                .map(|n| u64::from(n.stats().stale_samples))
                .sum(),
        )
    }
}

impl<const N: usize, const M: usize> Agents<N, M> for CanAgents<N, M> {
    fn control(
        &mut self,
        k: u64,
        _t: f64,
        x: &[[f64; N]],
        yd: f64,
        out: &mut Vec<StepOutput<N, M>>,
    ) -> Result<()> {
        for (s, x) in self.states.iter_mut().zip(x) {
            for (d, v) in s.iter_mut().zip(x) {
                *d = *v as f32;
            }
        }
        let t_ns = k.saturating_mul(self.h_ns);
        let ticks = self.net.step(t_ns, &self.states, Some(yd as f32));
        out.extend(ticks.iter().map(|t| t.output));
        if let Some(w) = self.trace.as_mut() {
            w.write(INTERFACE, &self.net.bus_mut().take_wire_log());
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<()> {
        self.trace.as_mut().map_or(Ok(()), TraceWriter::finish)
    }

    fn gains(&self) -> Gains {
        // Validation rejects an empty graph, so node 1 exists.
        match self.net.nodes().first() {
            Some(n) => *n.controller().params().gains(),
            None => Gains {
                c1: f32::NAN,
                c2: f32::NAN,
                k1: f32::NAN,
                k2: f32::NAN,
            },
        }
    }

    fn network(&self) -> Option<NetworkSummary> {
        Some(self.summary())
    }
}
