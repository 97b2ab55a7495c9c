//! [`CanNetwork`]: follower nodes on mocked hardware, a leader, and the [`Bus`] between them,
//! advanced one sample at a time by a host loop that owns the plant.
//!
//! Bus node `0` is the leader, bus node `i` is agent `i`; their identifiers are those of the
//! agents' identifier plan ([`agent_node::IdPlan`], `0x101` and `0x101 + i` by default).
//! Per sample at time `t` ([`CanNetwork::step`]):
//!
//! 1. the bus runs up to `t`; each delivered frame is pushed, at its delivery time, into the
//!    receive FIFO of every other node that is not bus-off, and the node's
//!    [`agent_node::Node::poll_rx`] runs then (the CAN receive interrupt), so values are
//!    time-stamped at arrival;
//! 2. every node gets the agent's state on its sensors and runs [`agent_node::Node::tick`] with its
//!    clock at `t`; its frames (the value frame, and a heartbeat when due) go on the bus,
//!    submitted at `t` (computation time neglected);
//! 3. the leader submits `y_d(t)` (when given) with its own sequence counter;
//! 4. the age of every neighbour (and leader) value each controller used, `t` minus the
//!    sample time at which the sender produced it, is recorded in the bus statistics.
//!
//! The commands the nodes wrote are in [`Tick::output`]`.q` (and in each node's actuator),
//! to be held by the plant over `[t, t + h)`.
//!
//! ```
//! use controller_core::ControllerConfig;
//! use hil_mock::bus::BusConfig;
//! use hil_mock::network::{AgentSetup, CanNetwork};
//! use agent_node::NodeConfig;
//!
//! // Two agents: agent 1 pinned, agent 2 hears agent 1.
//! let agent = |i: u8| AgentSetup {
//!     node: NodeConfig::new(i, [1, 0], 2_500),
//!     controller: ControllerConfig::<2> {
//!         neighbour_count: usize::from(i - 1),
//!         pinned: i == 1,
//!         ..ControllerConfig::default()
//!     },
//! };
//! let mut net = CanNetwork::<2, 2, 2>::new(BusConfig::default(), &[agent(1), agent(2)])?;
//! let mut x = [[0.1f32, 0.0], [0.2, 0.0]];
//! for k in 0..100u64 {
//!     let ticks = net.step(k * 1_000_000, &x, Some(0.0));
//!     for (xi, tick) in x.iter_mut().zip(&ticks) {
//!         xi[1] += 1e-3 * tick.output.q[0]; // a toy plant
//!         xi[0] += 1e-3 * xi[1];
//!     }
//! }
//! let s = net.stats();
//! assert_eq!(s.frames_lost, 0);
//! assert!(s.load_percent() > 28.0 && s.load_percent() < 29.0); // 3 × 95 bits per ms
//! # Ok::<(), hil_mock::network::NetworkError>(())
//! ```

use controller_core::{ControllerConfig, Link};

use crate::bus::{Bus, BusConfig, BusConfigError, BusStats, Nanos};
use crate::mock::{MockActuator, MockCan, MockClock, MockFrame, MockNode, MockSensor};
use agent_node::wire::{self, IdPlan, Source};
use agent_node::{NodeConfig, NodeError, Tick};

/// Why a network could not be built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NetworkError {
    /// The bus configuration.
    Bus(BusConfigError),
    /// Agent `agent`'s node configuration.
    Node {
        /// 1-based agent.
        agent: u8,
        /// The error.
        error: NodeError,
    },
    /// Agents must be numbered 1, 2, ... in order.
    AgentOrder(u8),
    /// Agent `0` uses another identifier plan than agent 1.
    MixedPlans(u8),
}

impl std::fmt::Display for NetworkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Bus(e) => write!(f, "{e}"),
            Self::Node { agent, error } => write!(f, "agent {agent}: {error}"),
            Self::AgentOrder(a) => write!(f, "agent {a} out of order: number agents 1, 2, ..."),
            Self::MixedPlans(a) => write!(f, "agent {a}: another identifier plan than agent 1's"),
        }
    }
}

impl std::error::Error for NetworkError {}

/// One agent's node settings and controller configuration.
#[derive(Debug, Clone, Copy)]
pub struct AgentSetup<const N: usize, const K: usize> {
    /// Node settings (agent number, neighbours, stale timeout).
    pub node: NodeConfig<K>,
    /// Controller configuration.
    pub controller: ControllerConfig<N>,
}

/// Followers, leader and bus.
pub struct CanNetwork<const N: usize, const M: usize, const K: usize> {
    bus: Bus,
    nodes: Vec<MockNode<N, M, K>>,
    /// `sample_time[receiver][sender]`: sample time of the latest frame delivered.
    sample_time: Vec<Vec<Option<Nanos>>>,
    leader_seq: u8,
    ids: IdPlan,
}

impl<const N: usize, const M: usize, const K: usize> CanNetwork<N, M, K> {
    /// Build the bus (`agents.len() + 1` nodes) and one node per agent; agent `i` must be the
    /// `i`-th entry.
    pub fn new(bus: BusConfig, agents: &[AgentSetup<N, K>]) -> Result<Self, NetworkError> {
        let bus = Bus::new(bus, agents.len() + 1).map_err(NetworkError::Bus)?;
        let mut nodes = Vec::with_capacity(agents.len());
        let ids = agents.first().map_or(IdPlan::DEFAULT, |a| a.node.ids);
        for (i, a) in agents.iter().enumerate() {
            if usize::from(a.node.agent) != i + 1 {
                return Err(NetworkError::AgentOrder(a.node.agent));
            }
            if a.node.ids != ids {
                return Err(NetworkError::MixedPlans(a.node.agent));
            }
            let node = MockNode::new(
                &a.node,
                &a.controller,
                MockCan::default(),
                MockClock::default(),
                MockSensor::default(),
                MockActuator::default(),
            )
            .map_err(|error| NetworkError::Node {
                agent: a.node.agent,
                error,
            })?;
            nodes.push(node);
        }
        let n = agents.len() + 1;
        Ok(Self {
            bus,
            nodes,
            sample_time: vec![vec![None; n]; n],
            leader_seq: 0,
            ids,
        })
    }

    /// The bus.
    pub fn bus(&self) -> &Bus {
        &self.bus
    }

    /// The bus (e.g. to record a trace: [`Bus::record_wire`]).
    pub fn bus_mut(&mut self) -> &mut Bus {
        &mut self.bus
    }

    /// The nodes; agent `i` is at index `i − 1`.
    pub fn nodes(&self) -> &[MockNode<N, M, K>] {
        &self.nodes
    }

    /// Mutable nodes (inject sensor or actuator failures).
    pub fn nodes_mut(&mut self) -> &mut [MockNode<N, M, K>] {
        &mut self.nodes
    }

    /// Bus statistics, with the ages of neighbour data used.
    pub fn stats(&self) -> BusStats {
        self.bus.stats()
    }

    /// One sample at `t_ns` (see the module docs): `states[i]` is agent `i + 1`'s state,
    /// `leader` the leader's `y_d(t)` (`None`: the leader sends nothing this sample).
    /// Returns each node's tick, agent order.
    pub fn step(
        &mut self,
        t_ns: Nanos,
        states: &[[f32; N]],
        leader: Option<f32>,
    ) -> Vec<Tick<N, M>> {
        for d in self.bus.advance_to(t_ns) {
            for (j, node) in self.nodes.iter_mut().enumerate() {
                let bus_node = j + 1;
                if bus_node == d.from || self.bus.is_bus_off(bus_node, d.at_ns) {
                    continue;
                }
                node.clock_mut().set(d.at_ns / 1000);
                node.can_mut().push_rx(d.frame);
                node.poll_rx();
                self.sample_time[bus_node][d.from] = Some(d.submitted_ns);
            }
        }

        let mut ticks = Vec::with_capacity(self.nodes.len());
        let t_us = t_ns / 1000;
        for (j, node) in self.nodes.iter_mut().enumerate() {
            let bus_node = j + 1;
            node.clock_mut().set(t_us);
            if let Some(x) = states.get(j) {
                node.sensor_mut().x = *x;
            }
            node.can_mut()
                .set_bus_off(self.bus.is_bus_off(bus_node, t_ns));
            let tick = node.tick();
            while let Some(f) = node.can_mut().take_tx() {
                // Refusals (silent, bus-off) are counted by the bus.
                let _ = self.bus.submit(bus_node, t_ns, f);
            }
            ticks.push(tick);
        }
        self.record_ages(t_ns);

        if let Some(yd) = leader {
            if let Some((f, _)) =
                wire::encode_in::<MockFrame>(&self.ids, Source::Leader, yd, self.leader_seq)
            {
                let _ = self.bus.submit(0, t_ns, f);
            }
            self.leader_seq = (self.leader_seq + 1) % wire::SEQ_MODULUS;
        }
        ticks
    }

    fn record_ages(&mut self, t_ns: Nanos) {
        for (j, node) in self.nodes.iter().enumerate() {
            let receiver = j + 1;
            let mut k = 0;
            while let Some(link) = node.neighbour_link(k, t_ns / 1000) {
                if !matches!(link, Link::Missing) {
                    if let Some(sender) = node.neighbour_agent(k) {
                        if let Some(ts) = self.sample_time[receiver][usize::from(sender)] {
                            self.bus.record_age(t_ns.saturating_sub(ts));
                        }
                    }
                }
                k += 1;
            }
            if node.is_pinned() {
                if let Some(ts) = self.sample_time[receiver][0] {
                    self.bus.record_age(t_ns.saturating_sub(ts));
                }
            }
        }
    }
}
