//! A node's own settings checked, and why a node could not be built: below both the node
//! ([`crate::node`]) and its CANopen device ([`crate::canopen`]), which check a row, a node-ID
//! or an identifier plan written over SDO with the same function.

use controller_core::ConfigError;

use crate::supervisor::SupervisorError;
use crate::wire::IdPlan;

/// A node's own settings as [`NodeConfig::check`] checks them, whatever its capacity: one copy
/// of the checks for every `K` (the firmware's flash).
pub(crate) struct Own<'a> {
    pub(crate) agent: u8,
    pub(crate) stale_timeout_us: u64,
    pub(crate) ids: &'a IdPlan,
    pub(crate) heartbeat_period_us: u64,
}

impl Own<'_> {
    /// [`NodeConfig::check`] with the row `neighbours` (its capacity: its length).
    #[inline(never)]
    pub(crate) fn check(&self, neighbours: &[u8], neighbour_count: usize) -> Result<(), NodeError> {
        if self.agent == 0 {
            return Err(NodeError::AgentZero);
        }
        if self.stale_timeout_us == 0 {
            return Err(NodeError::ZeroTimeout);
        }
        if self.agent > self.ids.agents() {
            return Err(NodeError::AgentOutsidePlan(self.agent));
        }
        if self.heartbeat_period_us > 0 && self.ids.heartbeat_base().is_none() {
            return Err(NodeError::NoHeartbeatIds);
        }
        let listed = neighbours
            .get(..neighbour_count)
            .ok_or(NodeError::TooManyNeighbours)?;
        for (k, &a) in listed.iter().enumerate() {
            // Not `contains`: its `u8` specialisation is a `memchr` the firmware would carry.
            let repeated = listed.iter().take(k).any(|&b| b == a);
            if a == 0 || a == self.agent || a > self.ids.agents() || repeated {
                return Err(NodeError::BadNeighbour(a));
            }
        }
        Ok(())
    }
}

/// Why a node could not be built.
///
/// ```
/// use agent_node::{CanFrame, Node, NodeConfig, NodeError};
/// use controller_core::ControllerConfig;
/// // Agent 2 listing itself as its neighbour: refused with the entry at fault.
/// let ctrl = ControllerConfig::<2> { neighbour_count: 1, ..Default::default() };
/// let e = NodeConfig::new(2, [2], 2_500);
/// # struct X;
/// # impl embedded_can::nb::Can for X {
/// #     type Frame = CanFrame; type Error = embedded_can::ErrorKind;
/// #     fn transmit(&mut self, _: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> { Ok(None) }
/// #     fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> { Err(nb::Error::WouldBlock) }
/// # }
/// # impl agent_node::Clock for X { fn now_us(&mut self) -> u64 { 0 } }
/// # impl agent_node::Sensor<2> for X { type Error = (); fn read(&mut self) -> Result<[f32; 2], ()> { Ok([0.0; 2]) } }
/// # impl agent_node::Actuator<2> for X { type Error = (); fn write(&mut self, _: &[f32; 2]) -> Result<(), ()> { Ok(()) } }
/// let r = Node::<X, X, X, X, 2, 2, 1>::new(&e, &ctrl, X, X, X, X);
/// let err = r.err().unwrap();
/// assert_eq!(err, NodeError::BadNeighbour(2));
/// assert_eq!(err.to_string(), "neighbour 2 is 0, the agent itself, or a duplicate");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum NodeError {
    /// The controller rejected its configuration.
    Config(ConfigError),
    /// Agent number 0 has no identifier.
    AgentZero,
    /// `neighbour_count` exceeds the node's capacity `K`.
    TooManyNeighbours,
    /// A neighbour entry is 0, the agent itself, or listed twice.
    BadNeighbour(u8),
    /// The stale timeout is 0.
    ZeroTimeout,
    /// The agent number is beyond the identifier plan's agents.
    AgentOutsidePlan(u8),
    /// A heartbeat period without heartbeat identifiers in the plan.
    NoHeartbeatIds,
    /// A supervision setting.
    Supervisor(SupervisorError),
    /// A graph row (neighbours, `pinned`) or an identifier plan written over SDO waits for
    /// the reset communication that applies it; the node cannot start on it before.
    PendingGraph,
}

impl From<SupervisorError> for NodeError {
    fn from(e: SupervisorError) -> Self {
        Self::Supervisor(e)
    }
}

impl From<ConfigError> for NodeError {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

impl core::fmt::Display for NodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Config(e) => write!(f, "controller configuration: {e}"),
            Self::AgentZero => f.write_str("agent number 0 has no CAN identifier"),
            Self::TooManyNeighbours => f.write_str("more neighbours than the node's capacity"),
            Self::BadNeighbour(a) => {
                write!(f, "neighbour {a} is 0, the agent itself, or a duplicate")
            }
            Self::ZeroTimeout => f.write_str("stale timeout must be > 0"),
            Self::PendingGraph => f.write_str(
                "the graph row or identifier plan written over SDO applies at the next reset communication",
            ),
            Self::AgentOutsidePlan(a) => {
                write!(f, "agent {a} has no identifier in the identifier plan")
            }
            Self::NoHeartbeatIds => {
                f.write_str("a heartbeat period needs heartbeat identifiers in the plan")
            }
            Self::Supervisor(e) => write!(f, "{e}"),
        }
    }
}

/// `Display` includes the controller's or the supervisor's message (a `no_std` log prints only
/// `Display`), so `source` stays `None`.
impl core::error::Error for NodeError {}
