//! `kind = "can"`: every agent runs as an `agent-node` [`agent_node::Node`] (its own
//! controller, freshness policy and Q7.16 frames) on `hil-mock`'s mocked hardware over its
//! CAN-like bus, via [`hil_mock::network::CanNetwork`]. The plant, faults, metrics and outputs
//! are the simulator's, unchanged; `summary.json` gains a `network` object
//! ([`NetworkSummary`]). The model and its figures: `docs/NETWORK.md`.

use controller_core::{ControllerConfig, Gains, StepOutput};
use hil_mock::{
    bus::Nanos,
    network::{AgentSetup, CanNetwork},
};

use crate::{
    clock::Clocks,
    figures::{KindReport, NetworkSummary, NodeSummary},
    graph::Graph,
    network::{
        node::NodeSpec,
        spec::{bus_config, node_config, ns, NetworkKind, NetworkSpec},
        trace::{TraceWriter, INTERFACE},
    },
    sim::{Agents, Release, K},
};
use consensus_plot::error::{Error, Result};

/// Every agent an `agent-node` node on mocked hardware over the simulated CAN bus.
pub struct CanAgents<const N: usize, const M: usize> {
    net: CanNetwork<N, M, K>,
    h_ns: Nanos,
    bitrate: u32,
    data_bitrate: Option<u32>,
    states: Vec<[f32; N]>,
    trace: Option<TraceWriter>,
    /// `summary.json` `network.nodes[]` is written (a `[node]` section was given).
    report_nodes: bool,
    h: f64,
    ages: Vec<Nanos>,
}

impl<const N: usize, const M: usize> CanAgents<N, M> {
    /// One node per agent of the validated `graph`, with its controller configuration
    /// (`configs`, in agent order) and neighbours, on the bus of `[network]` (`spec`, sample
    /// period `h`); every frame on the bus goes to `trace` (candump log) when given.
    pub fn new(
        spec: &NetworkSpec,
        node: &NodeSpec,
        h: f64,
        graph: &Graph,
        configs: &[ControllerConfig<N>],
        trace: Option<&std::path::Path>,
    ) -> Result<Self> {
        let mut agents = Vec::with_capacity(graph.len());
        for (i, controller) in configs.iter().enumerate() {
            agents.push(AgentSetup {
                node: node_config(spec, node, h, graph, i)?,
                controller: *controller,
            });
        }
        let cfg = bus_config(spec, h);
        let (bitrate, data_bitrate) = (cfg.bitrate, cfg.data_bitrate);
        let mut net = CanNetwork::new(cfg, &agents).map_err(|e| Error::invalid("network", e))?;
        if let Some(plant) = spec
            .frame_set(graph.len(), h, node.heartbeat_period)
            .and_then(|set| set.plant)
        {
            net.put_plant_on_bus(plant);
        }
        let trace = trace.map(TraceWriter::create).transpose()?;
        if trace.is_some() {
            net.bus_mut().record_wire();
        }
        Ok(Self {
            net,
            h_ns: ns(h),
            bitrate,
            data_bitrate,
            states: vec![[0.0; N]; graph.len()],
            trace,
            report_nodes: !node.is_default(),
            h,
            ages: Vec::new(),
        })
    }

    fn flush_trace(&mut self) {
        if let Some(w) = self.trace.as_mut() {
            w.write(INTERFACE, &self.net.bus_mut().take_wire_log());
        }
    }

    /// The network (nodes, bus, statistics).
    pub fn network(&self) -> &CanNetwork<N, M, K> {
        &self.net
    }

    /// The figures of `summary.json` `network`.
    pub fn summary(&self) -> NetworkSummary {
        let nodes = self.net.nodes();
        let mut summary = NetworkSummary::new(
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
        );
        summary.data_bitrate = self.data_bitrate;
        if self.report_nodes {
            summary.nodes = nodes
                .iter()
                .map(|n| NodeSummary {
                    agent: usize::from(n.agent()),
                    state: n.state().as_str(),
                    safe_state_entries: n.stats().safe_state_entries,
                    overruns: n.stats().overruns,
                    heartbeats_sent: n.stats().heartbeats_tx,
                })
                .collect();
        }
        summary
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
        self.flush_trace();
        Ok(())
    }

    fn sample_at(
        &mut self,
        i: usize,
        t: f64,
        now_us: u64,
        x: &[f64; N],
        ages: &mut Vec<f64>,
    ) -> Result<StepOutput<N, M>> {
        let t_ns = ns(t);
        let xs = x.map(|v| v as f32);
        if let Some(s) = self.states.get_mut(i) {
            *s = xs;
        }
        let tick = self.net.tick_at(i, t_ns, now_us, Some(&xs));
        self.ages.clear();
        self.net.link_ages(i, t_ns, now_us, &mut self.ages);
        ages.extend(self.ages.iter().map(|&a| a as f64 * 1e-9));
        Ok(tick.output)
    }

    fn leader_sends(&mut self, _k: u64, t: f64, yd: f64) -> Result<()> {
        self.net.send_leader(ns(t), yd as f32);
        self.net.send_sensors(ns(t), &self.states);
        Ok(())
    }

    /// With `sync`, the leader's frame is the release: every follower that receives it
    /// samples its jitter later.
    fn run_until(
        &mut self,
        until: f64,
        sync: bool,
        clocks: &Clocks,
        releases: &mut Vec<Release>,
    ) -> Result<()> {
        let until = ns(until);
        let local = |j: usize, at: Nanos| clocks.local_us(j, at as f64 * 1e-9);
        if sync {
            while let Some(at) = self.net.bus_mut().next_delivery(until) {
                for d in self.net.deliver_until(at, local) {
                    if d.from != 0 {
                        continue;
                    }
                    let k = (d.submitted_ns as f64 * 1e-9 / self.h).round() as u64;
                    for agent in 0..self.states.len() {
                        if !self.net.bus().is_bus_off(agent + 1, d.at_ns) {
                            releases.push(Release {
                                agent,
                                k,
                                at: d.at_ns as f64 * 1e-9,
                            });
                        }
                    }
                }
                if !releases.is_empty() {
                    self.flush_trace();
                    return Ok(());
                }
            }
        }
        self.net.deliver_until(until, local);
        self.flush_trace();
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

    fn report(&self) -> KindReport {
        KindReport::Can(self.summary())
    }
}
