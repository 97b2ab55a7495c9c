//! The node's compiled-in defaults: the agent plan (which agent hears which, who is pinned),
//! the default node-ID, the controller's settings and the scales of the example wiring. One
//! image serves every agent of any graph: the node-ID, the graph row (the agents heard,
//! whether the leader is) and the identifier plan come from the stored configuration
//! ([`crate::param_page`]; the firmware builds its node and acceptance filters from what the
//! CANopen device loads of it, `agent_node::NodeConfig::graph_from`), set over the bus (CANopen SDO `0x2100`
//! `node.node_id`, the `graph.neighbours` array, `graph.pinned`, `node.id_base`, …, `0x1010`
//! store, NMT reset node); the parameters likewise. A stored node-ID without a stored row
//! takes its row from the compiled plan (Example 1). A board with nothing stored boots as
//! [`DEFAULT_AGENT`] in NMT pre-operational.
//!
//! Nothing here is trusted: [`agent_node::Node::new`] validates the node and controller
//! settings at boot (`controller_core::Controller::new` against the parameter table),
//! [`wiring_error`] the scales; a rejected value is logged by name and the board enters its
//! fault state (outputs off, no bus traffic, LD2 lit, watchdog never started).
//!
//! The values are the paper's Example 1 (`scenarios/example1-deploy.toml`: agent 1 pinned,
//! agents 2 and 3 hear agent 1, agent 4 hears agents 1 and 3, `[safety]` on), sampled at
//! `h = 1 ms`.

use agent_node::{
    supervisor::{NeighbourLoss, SafePolicy, SupervisorConfig},
    wire::IdPlan,
    NodeConfig,
};
use controller_core::{ControllerConfig, GainSelection, QuantizerConfig, SafetyConfig};

/// State order `n` (position, velocity).
pub const N: usize = 2;
/// Actuators `m`.
pub const M: usize = 2;
/// Neighbour capacity of this build (Example 1's agents hear at most 2).
pub const K: usize = 4;

/// Sample period `h` [µs]; the control timer's period and the controller's `h`.
pub const SAMPLE_PERIOD_US: u32 = 1_000;

/// One agent of the compiled plan: the agents it hears (in the controller's order) and
/// whether it is pinned (hears the leader), as `[graph]` of the scenario file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AgentPlan {
    /// The agents it hears.
    pub neighbours: &'static [u8],
    /// It hears the leader (`b_i = 1`).
    pub pinned: bool,
}

/// The plan of Example 1 (`[graph]` of `scenarios/example1-deploy.toml`): entry `i - 1` is
/// agent `i`.
pub const PLAN: [AgentPlan; 4] = [
    AgentPlan {
        neighbours: &[],
        pinned: true,
    },
    AgentPlan {
        neighbours: &[1],
        pinned: false,
    },
    AgentPlan {
        neighbours: &[1],
        pinned: false,
    },
    AgentPlan {
        neighbours: &[1, 3],
        pinned: false,
    },
];

/// The node-ID of a board with nothing stored: the highest agent of the plan. It boots NMT
/// pre-operational (outputs off) and waits to be configured; commission one such board on the
/// bus at a time (they all answer SDO `0x600 + 4`).
pub const DEFAULT_AGENT: u8 = PLAN.len() as u8;

/// Producer heartbeat time of the CANopen device (`0x1017`, ms), as the node's own heartbeat.
pub const CANOPEN_HEARTBEAT_MS: u16 = 100;

/// Agent `agent`'s entry of the plan.
pub fn plan(agent: u8) -> Option<&'static AgentPlan> {
    PLAN.get(usize::from(agent).checked_sub(1)?)
}

/// Agent `agent` is in the plan.
pub fn in_plan(agent: u8) -> bool {
    plan(agent).is_some()
}

/// The node configuration of agent `agent` of the plan: [`NODE`] with its number and
/// neighbours.
pub fn node(agent: u8) -> Option<NodeConfig<K>> {
    let p = plan(agent)?;
    let mut neighbours = [0u8; K];
    if p.neighbours.len() > K {
        return None;
    }
    for (d, s) in neighbours.iter_mut().zip(p.neighbours) {
        *d = *s;
    }
    Some(NodeConfig {
        agent,
        neighbours,
        ..NODE
    })
}

/// The controller settings of agent `agent` of the plan: [`controller`] with its neighbour
/// count and pinning.
pub fn controller_of(agent: u8) -> Option<ControllerConfig<N>> {
    let p = plan(agent)?;
    Some(ControllerConfig {
        neighbour_count: p.neighbours.len(),
        pinned: p.pinned,
        ..controller()
    })
}

/// The default node ([`DEFAULT_AGENT`]), its neighbours, the stale timeout (2.5 `h`, as host-sim's `[network]`
/// default), the default identifier plan (leader `0x101`, agent `i` at `0x101 + i`, its
/// heartbeat at `0x780 + i`), a heartbeat every 100 ms, and the safe state: when both
/// neighbours or the leader fall silent for 50 ms the joint holds position in closed loop on
/// the last valid values (`hold-position`, CiA 402 halt); a lost sensor switches the outputs
/// off; 200 ms of every source healthy again and the returning values re-enter at `[safety]`'s
/// recovery rate.
pub const NODE: NodeConfig<K> = NodeConfig {
    agent: DEFAULT_AGENT,
    neighbours: [1, 3, 0, 0],
    stale_timeout_us: 2_500,
    ids: IdPlan::DEFAULT,
    heartbeat_period_us: 100_000,
    supervisor: SupervisorConfig {
        policy: SafePolicy::HoldPosition,
        leader_timeout_us: Some(50_000),
        neighbour_timeout_us: Some(50_000),
        neighbour_loss: NeighbourLoss::All,
        sensor_timeout_us: None,
        recover_dwell_us: 200_000,
        sensor_policy: SafePolicy::Off,
        reentry_rate: 1.0,
    },
};

/// Position of the encoder shaft per count (x1 units; 4,096 counts per unit).
pub const POSITION_PER_COUNT: f32 = 1.0 / 4_096.0;
/// The command that drives an output to 100 % duty (and its negative to 0 %): the quantizer's
/// largest level `(1 + δ) u_max = 42.1` for `u_max = 40`, `ρ = 0.9`.
pub const COMMAND_FULL_SCALE: f32 = 42.1;
/// PWM carrier frequency [Hz] of the actuator outputs.
pub const PWM_HZ: u32 = 20_000;
/// Independent watchdog timeout [µs]: five missed samples reset the board.
pub const WATCHDOG_US: u32 = 5 * SAMPLE_PERIOD_US;

/// The controller's settings of the default agent (Example 1, `[safety]` of
/// `example1-deploy.toml`; [`controller_of`] for another agent).
pub fn controller() -> ControllerConfig<N> {
    ControllerConfig {
        h: SAMPLE_PERIOD_US as f32 * 1e-6,
        neighbour_count: 2,
        pinned: false,
        ts: 2.0,
        zeta: 0.1,
        gains: GainSelection::Auto,
        a_check: [90.0, 90.0],
        p: 80.0,
        eta: 50.0,
        tau: 50.0,
        gamma: 0.1,
        mtn_order: 2,
        phi_low: [1.0, 1.0],
        phi_up: [1.0, 1.0],
        eps_bar: [0.0, 0.0],
        diff_l1: 1.0,
        diff_l2: 1.0,
        varpi0: 0.1,
        varpi_decay: 0.7,
        varpi_min: 1e-6,
        mu0: 0.0,
        xi0: 0.0,
        lambda0: 1.0,
        quantizer: Some(QuantizerConfig {
            rho: 0.9,
            u_min: 0.01,
            ..QuantizerConfig::default()
        }),
        safety: Some(SafetyConfig {
            u_max: Some(40.0),
            du_max: Some(2000.0),
            recovery_rate: 1.0,
            recovery_jump: 0.05,
        }),
        ..ControllerConfig::default()
    }
}

/// A wiring scale that cannot work, named by its constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum WiringError {
    /// `SAMPLE_PERIOD_US` is 0.
    SamplePeriod,
    /// `POSITION_PER_COUNT` is not finite or is 0.
    PositionPerCount,
    /// `COMMAND_FULL_SCALE` is not finite and > 0.
    CommandFullScale,
    /// `PWM_HZ` is 0 or above 1 MHz.
    PwmHz,
    /// `WATCHDOG_US` is below two samples or above the IWDG's 32.7 s.
    Watchdog,
}

/// The first wiring scale of this file that cannot work, if any.
pub fn wiring_error() -> Option<WiringError> {
    let checks = [
        (SAMPLE_PERIOD_US > 0, WiringError::SamplePeriod),
        (
            POSITION_PER_COUNT.is_finite() && POSITION_PER_COUNT != 0.0,
            WiringError::PositionPerCount,
        ),
        (
            COMMAND_FULL_SCALE.is_finite() && COMMAND_FULL_SCALE > 0.0,
            WiringError::CommandFullScale,
        ),
        ((1..=1_000_000).contains(&PWM_HZ), WiringError::PwmHz),
        (
            WATCHDOG_US >= 2 * SAMPLE_PERIOD_US && WATCHDOG_US <= 32_000_000,
            WiringError::Watchdog,
        ),
    ];
    checks.iter().find(|(ok, _)| !ok).map(|&(_, e)| e)
}
