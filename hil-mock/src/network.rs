//! [`CanNetwork`]: follower nodes on mocked hardware, a leader, and the [`Bus`] between them,
//! advanced one sample at a time by a host loop that owns the plant.
//!
//! Bus node `0` is the leader, bus node `i` is agent `i`; their identifiers are those of the
//! agents' identifier plan ([`agent_node::IdPlan`], `0x101` and `0x101 + i` by default).
//! Per sample at time `t` ([`CanNetwork::step`]), on the bus host loop it shares with the
//! processor-in-the-loop followers ([`BusHost`]):
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
//! With [`CanNetwork::put_plant_on_bus`] the bus also carries the frames of a bench whose plant
//! is on the bus ([`agent_node::plant_bus`]): the host's sensor frames (bus node 0, with the
//! leader's value frame; per agent or packed), each node's command frame after its tick, and
//! its state — its CANopen heartbeat (`0x700 + i`, NMT state operational) — once per state
//! period. They occupy the bus as on the bench; the nodes'
//! sensors and actuators stay mocked, and the plant frames are not handed to the nodes (a bench
//! node's value socket filters them out).
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

use crate::bus::{Bus, BusConfig, BusConfigError, BusStats, Delivery, Nanos};
use crate::host::BusHost;
use crate::mock::{MockActuator, MockCan, MockClock, MockFrame, MockNode, MockSensor};
use agent_node::bus_load::{PlantFrames, SensorFrames};
use agent_node::canopen::{self, CoFrame, NmtState};
use agent_node::plant_bus::{self, Kind, PACKED_SENSOR_AGENTS};
use agent_node::wire::IdPlan;
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
    /// The bus, the links' sample times, the leader's counter and the identifier plan.
    host: BusHost,
    nodes: Vec<MockNode<N, M, K>>,
    /// Scratch for the ages of one sample.
    ages: Vec<Nanos>,
    /// The plant's frames on the bus, and each node's last state period (`None`: none sent).
    plant: Option<(PlantFrames, Vec<Option<u64>>)>,
}

impl<const N: usize, const M: usize, const K: usize> CanNetwork<N, M, K> {
    /// Build the bus (`agents.len() + 1` nodes) and one node per agent; agent `i` must be the
    /// `i`-th entry.
    pub fn new(bus: BusConfig, agents: &[AgentSetup<N, K>]) -> Result<Self, NetworkError> {
        let ids = agents.first().map_or(IdPlan::DEFAULT, |a| a.node.ids);
        let host = BusHost::new(bus, agents.len(), ids).map_err(NetworkError::Bus)?;
        let mut nodes = Vec::with_capacity(agents.len());
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
        Ok(Self {
            host,
            nodes,
            ages: Vec::new(),
            plant: None,
        })
    }

    /// Puts the frames of a plant on the bus on the modelled bus as well (module docs).
    pub fn put_plant_on_bus(&mut self, plant: PlantFrames) {
        self.plant = Some((plant, vec![None; self.nodes.len()]));
    }

    /// The host's sensor frames of `states` (agent `i + 1` at index `i`) at `t_ns`, from bus
    /// node 0, when the plant is on the bus: one per agent, or one per 8 agents packed (timed at
    /// its CAN FD length, its first agent's state in the frame the receivers and the wire log
    /// get).
    pub fn send_sensors(&mut self, t_ns: Nanos, states: &[[f32; N]]) {
        let Some((plant, _)) = &self.plant else {
            return;
        };
        let pair = |x: &[f32; N]| {
            [
                x.first().copied().unwrap_or(0.0),
                x.get(1).copied().unwrap_or(0.0),
            ]
        };
        match plant.sensor {
            SensorFrames::PerAgent => {
                for (i, x) in states.iter().enumerate() {
                    let agent = u8::try_from(i + 1).unwrap_or(0);
                    if let Some(f) =
                        plant_bus::pair_frame::<MockFrame>(Kind::Sensor, agent, pair(x))
                    {
                        let _ = self.host.bus_mut().submit(0, t_ns, f);
                    }
                }
            }
            SensorFrames::Packed => {
                let per = usize::from(PACKED_SENSOR_AGENTS);
                for (g, group) in states.chunks(per).enumerate() {
                    let first = u8::try_from(g * per + 1).unwrap_or(0);
                    let head = group.first().map_or([0.0; 2], pair);
                    if let Some(f) = plant_bus::pair_frame::<MockFrame>(Kind::Sensor, first, head) {
                        let len = group.len() * plant_bus::PAIR_LEN;
                        let _ = self.host.bus_mut().submit_sized(0, t_ns, f, len);
                    }
                }
            }
        }
    }

    /// Node `j`'s command frame of `q` and, once per state period, its CANopen heartbeat, at
    /// `t_ns`, when the plant is on the bus.
    fn send_plant_frames(&mut self, j: usize, t_ns: Nanos, q: &[f32; M]) {
        let Some((plant, last)) = self.plant.as_mut() else {
            return;
        };
        let agent = u8::try_from(j + 1).unwrap_or(0);
        let pair = [
            q.first().copied().unwrap_or(0.0),
            q.get(1).copied().unwrap_or(0.0),
        ];
        if let Some(f) = plant_bus::pair_frame::<MockFrame>(Kind::Command, agent, pair) {
            let _ = self.host.bus_mut().submit(j + 1, t_ns, f);
        }
        let period = (t_ns / 1000).checked_div(plant.state_period_us);
        if let (Some(p), Some(slot)) = (period, last.get_mut(j)) {
            if *slot != Some(p) {
                *slot = Some(p);
                let beat = CoFrame::new(
                    canopen::heartbeat_id(agent),
                    &[NmtState::Operational.code()],
                );
                if let Some(f) = beat.to_frame::<MockFrame>() {
                    let _ = self.host.bus_mut().submit(j + 1, t_ns, f);
                }
            }
        }
    }

    /// The bus.
    pub fn bus(&self) -> &Bus {
        self.host.bus()
    }

    /// The bus (e.g. to record a trace: [`Bus::record_wire`]).
    pub fn bus_mut(&mut self) -> &mut Bus {
        self.host.bus_mut()
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
        self.host.bus().stats()
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
        self.deliver_until(t_ns, |_, at| at / 1000);
        let mut ticks = Vec::with_capacity(self.nodes.len());
        let t_us = t_ns / 1000;
        for j in 0..self.nodes.len() {
            ticks.push(self.tick_at(j, t_ns, t_us, states.get(j)));
        }
        self.record_ages(t_ns);
        if let Some(yd) = leader {
            self.send_leader(t_ns, yd);
        }
        self.send_sensors(t_ns, states);
        ticks
    }

    /// Runs the bus up to `t_ns` and hands every frame delivered by then to the nodes that
    /// receive it, each node's clock reading `clock(j, at)` µs at the delivery (`j`: 0-based
    /// agent). Returns the deliveries, in order.
    pub fn deliver_until(
        &mut self,
        t_ns: Nanos,
        clock: impl Fn(usize, Nanos) -> u64,
    ) -> Vec<Delivery> {
        let plant = self.plant.is_some();
        let nodes = &mut self.nodes;
        self.host.deliver_until(t_ns, |j, d| {
            // A bench node's value socket filters the plant's frames out.
            if plant && plant_bus::decode(&d.frame).is_some() {
                return false;
            }
            let Some(node) = nodes.get_mut(j) else {
                return false;
            };
            node.clock_mut().set(clock(j, d.at_ns));
            node.can_mut().push_rx(d.frame);
            node.poll_rx();
            true
        })
    }

    /// Agent `j + 1` (0-based `j`) samples at `t_ns` with its clock at `now_us`: its sensors
    /// read `state` (unchanged when `None`), it ticks, and its frame is submitted at `t_ns`.
    pub fn tick_at(
        &mut self,
        j: usize,
        t_ns: Nanos,
        now_us: u64,
        state: Option<&[f32; N]>,
    ) -> Tick<N, M> {
        let bus_node = j + 1;
        let bus_off = self.host.bus().is_bus_off(bus_node, t_ns);
        let node = &mut self.nodes[j];
        node.clock_mut().set(now_us);
        if let Some(x) = state {
            node.sensor_mut().x = *x;
        }
        node.can_mut().set_bus_off(bus_off);
        let tick = node.tick();
        while let Some(f) = node.can_mut().take_tx() {
            // Refusals (silent, bus-off) are counted by the bus.
            let _ = self.host.bus_mut().submit(bus_node, t_ns, f);
        }
        self.send_plant_frames(j, t_ns, &tick.output.q);
        tick
    }

    /// The leader submits `y_d` at `t_ns` with its own sequence counter.
    pub fn send_leader(&mut self, t_ns: Nanos, yd: f32) {
        self.host.send_leader(t_ns, yd);
    }

    /// Agent `j + 1`'s ages at `t_ns` (its clock at `now_us`) of the neighbour and leader values
    /// its controller uses: `t_ns` minus the sender's sample time. Also recorded in the bus
    /// statistics.
    pub fn link_ages(&mut self, j: usize, t_ns: Nanos, now_us: u64, ages: &mut Vec<Nanos>) {
        let Some(node) = self.nodes.get(j) else {
            return;
        };
        // The senders of the neighbour values in use, then the leader when pinned.
        let mut k = 0;
        let neighbours = std::iter::from_fn(|| {
            while let Some(link) = node.neighbour_link(k, now_us) {
                let sender = node.neighbour_agent(k);
                k += 1;
                if let (false, Some(sender)) = (matches!(link, Link::Missing), sender) {
                    return Some(usize::from(sender));
                }
            }
            None
        });
        let leader = node.is_pinned().then_some(0);
        self.host.link_ages(j, t_ns, neighbours.chain(leader), ages);
    }

    fn record_ages(&mut self, t_ns: Nanos) {
        let mut ages = std::mem::take(&mut self.ages);
        for j in 0..self.nodes.len() {
            ages.clear();
            self.link_ages(j, t_ns, t_ns / 1000, &mut ages);
        }
        self.ages = ages;
    }
}
