//! The node's configuration file: a `[node]` table (who the node is on which interface) and
//! the controller's tables as in a scenario file (`[simulation] h`, `[agent]`, `[controller]`,
//! `[quantizer]`, `[safety]`; `controller_core::ConfigFile`).
//!
//! ```toml
//! [node]
//! agent = 4                # this agent's number i (its frames: value, 0x300 + i, 0x700 + i)
//! neighbours = [1, 3]      # the agents it hears, in the controller's order
//! interface = "vcan0"      # SocketCAN interface
//! stale_timeout = 0.0025   # a neighbour value older than this is stale [s]
//! host_timeout = 0.5       # no sensor frame for this long: the host is gone, stop [s]
//! time_scale = 1.0         # wall seconds per simulated second (slowed real time)
//! node_id = 4              # CANopen node-ID (= agent)
//!
//! [node.canopen]           # optional: the node as a CiA 301 device (NMT, SDO, EMCY)
//! store = "agent-4.od"     # what 0x1010 "save" writes, loaded at start
//! heartbeat_ms = 100
//! exit_on_stop = true      # an NMT stop ends the process (exit 0): host-sim's bench runs
//!
//! [simulation]
//! h = 0.001
//! [agent]
//! neighbour_count = 2
//! pinned = false
//! [controller]
//! ts = 2.0
//! # …
//! ```

use std::{fmt, path::Path};

use agent_node::{IdPlan, NeighbourLoss, NodeConfig, SafePolicy, SupervisorConfig};
use controller_core::{ConfigFile, ControllerConfig};
use serde::{Deserialize, Serialize};

/// Neighbours a Linux node can hear.
pub use agent_node::wire::MAX_NEIGHBOURS;
/// State order and actuators of the built-in plants.
pub const N: usize = 2;

/// `[node]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSection {
    /// Agent number `i`, 1..=255.
    pub agent: i64,
    /// Agents heard (1-based), in the controller's order.
    #[serde(default)]
    pub neighbours: Vec<i64>,
    /// SocketCAN interface name.
    pub interface: String,
    /// A neighbour value older than this is `Stale` \[s\]; absent: `2.5 h`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stale_timeout: Option<f64>,
    /// No sensor frame for this long ends the node [s of wall time].
    #[serde(default = "default_host_timeout")]
    pub host_timeout: f64,
    /// Wall seconds per simulated second: the timer runs at `h time_scale`, the node's clock
    /// (freshness) `time_scale` times slower than the wall clock; the controller's `h` is
    /// unchanged.
    #[serde(default = "default_time_scale")]
    pub time_scale: f64,
    /// Identifier plan, heartbeat and safe state (`[node.supervision]`); absent: the default
    /// plan, no heartbeat, no supervision.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supervision: Option<Supervision>,
    /// Waiting for the host's first sensor frame longer than this ends the node (it never
    /// started) [s of wall time]; absent: 60.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_timeout: Option<f64>,
    /// CAN FD with bit-rate switching: every frame the node sends is an FD frame with BRS (the
    /// interface must be in FD mode); absent: classical CAN.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fd: Option<bool>,
    /// The host packs 8 followers' states into one CAN FD sensor frame
    /// (`agent_node::plant_bus::encode_packed`; needs `fd`); absent: one sensor frame per agent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub packed_sensors: Option<bool>,
    /// CANopen node-ID (1..=127), equal to `agent` (the value frames sit at `id_base +
    /// node-ID`); absent: `agent`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node_id: Option<i64>,
    /// The node as a CiA 301 device (`[node.canopen]`, docs/NETWORK.md §12); absent: outputs
    /// on from the first sample, no NMT, SDO or EMCY.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub canopen: Option<CanOpenSection>,
}

impl NodeSection {
    /// Whether the node sends CAN FD frames with bit-rate switching.
    pub fn fd(&self) -> bool {
        self.fd.unwrap_or(false)
    }

    /// Whether the sensor frames are packed.
    pub fn packed_sensors(&self) -> bool {
        self.packed_sensors.unwrap_or(false)
    }

    /// `start_timeout` \[s\], default 60.
    pub fn start_timeout(&self) -> f64 {
        self.start_timeout.unwrap_or(60.0)
    }
}

/// `[node.canopen]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CanOpenSection {
    /// The file `0x1010` "save" writes and the node loads at start and on NMT reset node;
    /// `0x1011` "load" deletes it. Absent: nothing persists.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub store: Option<String>,
    /// Producer heartbeat time `0x1017` \[ms\] until the stored set or a master changes it.
    #[serde(default = "default_heartbeat_ms")]
    pub heartbeat_ms: u16,
    /// Operational at boot without an NMT start.
    #[serde(default)]
    pub self_starting: bool,
    /// An NMT stop ends the process (a last heartbeat `STOPPED`, exit 0): the end of a bench
    /// run, which host-sim writes for its nodes. Absent or false: a stopped node stays,
    /// answering NMT and sending its heartbeat, as CiA 301 has it.
    #[serde(default)]
    pub exit_on_stop: bool,
}

fn default_heartbeat_ms() -> u16 {
    100
}

/// `[node.supervision]`: the node supervisor's settings as resolved numbers (host-sim writes
/// them from a scenario's `[node]` section, docs/SCENARIO.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Supervision {
    /// Identifier of the leader's value frame; agent `i` sends at `id_base + i`.
    pub id_base: u16,
    /// Agent `i`'s heartbeat at `heartbeat_id_base + i`; absent: no heartbeat identifiers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heartbeat_id_base: Option<u16>,
    /// Agents of the identifier plan.
    pub agents: u8,
    /// Heartbeat period \[µs\]; 0: none.
    pub heartbeat_period_us: u64,
    /// `"hold-position"`, `"stop"` (with `stop_decel`), `"hold"`, `"ramp"` (with `ramp_rate`),
    /// `"off"`; absent: no supervision.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub policy: Option<String>,
    /// Command units per second of `"ramp"` (the policy or the sensor policy).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ramp_rate: Option<f32>,
    /// Deceleration of `"stop"`'s reference [units of y / s²].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_decel: Option<f32>,
    /// The open-loop policy while the sensor is lost: `"hold"`, `"ramp"`, `"off"`; absent:
    /// `"hold"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_policy: Option<String>,
    /// Leader silence that enters the safe state \[µs\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leader_timeout_us: Option<u64>,
    /// Neighbour silence that counts as a loss \[µs\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neighbour_timeout_us: Option<u64>,
    /// `true`: any one neighbour silent is a loss; `false`: all of them.
    #[serde(default)]
    pub any_neighbour: bool,
    /// Sensor silence that enters the safe state \[µs\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_timeout_us: Option<u64>,
    /// Time everything must be healthy again before leaving the safe state \[µs\].
    #[serde(default)]
    pub recover_dwell_us: u64,
    /// Speed of re-entry without `[safety]` [units of y / s]; absent: 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reentry_rate: Option<f32>,
}

impl Supervision {
    /// The settings of a node configuration.
    pub fn of<const K: usize>(c: &NodeConfig<K>) -> Self {
        let s = c.supervisor;
        let supervised = s != SupervisorConfig::OFF;
        let rate_of = |p: SafePolicy| match p {
            SafePolicy::Ramp { rate } => Some(rate),
            _ => None,
        };
        let policy = supervised.then_some(s.policy.as_str());
        let ramp_rate = rate_of(s.policy).or(rate_of(s.sensor_policy));
        let stop_decel = match s.policy {
            SafePolicy::Stop { decel } => Some(decel),
            _ => None,
        };
        let sensor_policy = supervised.then_some(s.sensor_policy.as_str());
        Self {
            id_base: c.ids.value_base(),
            heartbeat_id_base: c.ids.heartbeat_base(),
            agents: c.ids.agents(),
            heartbeat_period_us: c.heartbeat_period_us,
            policy: policy.map(str::to_owned),
            ramp_rate,
            stop_decel,
            sensor_policy: sensor_policy.map(str::to_owned),
            leader_timeout_us: s.leader_timeout_us,
            neighbour_timeout_us: s.neighbour_timeout_us,
            any_neighbour: s.neighbour_loss == NeighbourLoss::Any,
            sensor_timeout_us: s.sensor_timeout_us,
            recover_dwell_us: s.recover_dwell_us,
            reentry_rate: supervised.then_some(s.reentry_rate),
        }
    }

    /// The policy called `name` under key `field`, with its rate.
    fn policy_named(&self, name: &str, field: &str) -> Result<SafePolicy, ConfigError> {
        let key = |k: &str| format!("node.supervision.{k}");
        let needed = |k: &str, v: Option<f32>| {
            v.ok_or_else(|| ConfigError::new(key(k), format!("needed by \"{name}\"")))
        };
        Ok(match name {
            "hold-position" => SafePolicy::HoldPosition,
            "stop" => SafePolicy::Stop {
                decel: needed("stop_decel", self.stop_decel)?,
            },
            "hold" => SafePolicy::Hold,
            "off" => SafePolicy::Off,
            "ramp" => SafePolicy::Ramp {
                rate: needed("ramp_rate", self.ramp_rate)?,
            },
            other => {
                return Err(ConfigError::new(
                    key(field),
                    format!(
                    "\"{other}\" is not \"hold-position\", \"stop\", \"hold\", \"ramp\" or \"off\""
                ),
                ))
            }
        })
    }

    /// Writes these settings into `cfg`.
    fn apply<const K: usize>(&self, cfg: &mut NodeConfig<K>) -> Result<(), ConfigError> {
        let key = |k: &str| format!("node.supervision.{k}");
        cfg.ids = IdPlan::new(self.id_base, self.heartbeat_id_base, self.agents)
            .map_err(|e| ConfigError::new(key("id_base"), e))?;
        cfg.heartbeat_period_us = self.heartbeat_period_us;
        let Some(name) = self.policy.as_deref() else {
            return Ok(());
        };
        let policy = self.policy_named(name, "policy")?;
        let sensor_policy = self.policy_named(
            self.sensor_policy.as_deref().unwrap_or("hold"),
            "sensor_policy",
        )?;
        cfg.supervisor = SupervisorConfig {
            policy,
            leader_timeout_us: self.leader_timeout_us,
            neighbour_timeout_us: self.neighbour_timeout_us,
            neighbour_loss: if self.any_neighbour {
                NeighbourLoss::Any
            } else {
                NeighbourLoss::All
            },
            sensor_timeout_us: self.sensor_timeout_us,
            recover_dwell_us: self.recover_dwell_us,
            sensor_policy,
            reentry_rate: self
                .reentry_rate
                .unwrap_or(SupervisorConfig::OFF.reentry_rate),
        };
        cfg.supervisor
            .validate()
            .map_err(|e| ConfigError::new(key("policy"), format!("{e:?}")))
    }
}

fn default_time_scale() -> f64 {
    1.0
}

fn default_host_timeout() -> f64 {
    0.5
}

#[derive(Deserialize)]
struct NodeOnly {
    node: NodeSection,
}

/// A rejected configuration: the key and the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    /// Dotted key, e.g. `node.agent`.
    pub key: String,
    /// Why.
    pub reason: String,
}

impl ConfigError {
    fn new(key: impl Into<String>, reason: impl fmt::Display) -> Self {
        Self {
            key: key.into(),
            reason: reason.to_string(),
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.reason)
    }
}

impl std::error::Error for ConfigError {}

/// A validated node configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeFile {
    /// `[node]` as written.
    pub node: NodeSection,
    /// The node settings for `agent_node::Node`.
    pub node_config: NodeConfig<MAX_NEIGHBOURS>,
    /// The controller settings.
    pub controller: ControllerConfig<N>,
}

impl NodeFile {
    /// Reads and validates `path`.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::new(path.display().to_string(), e))?;
        Self::parse(&text)
    }

    /// Parses and validates a configuration text.
    pub fn parse(text: &str) -> Result<Self, ConfigError> {
        let node = toml::from_str::<NodeOnly>(text)
            .map_err(|e| ConfigError::new("node", e.message()))?
            .node;
        let file: ConfigFile<heapless::Vec<f32, N>> =
            toml::from_str(text).map_err(|e| ConfigError::new("controller", e.message()))?;
        Self::new(node, file)
    }

    /// Checks `[node]` against the controller's tables.
    pub fn new(
        node: NodeSection,
        file: ConfigFile<heapless::Vec<f32, N>>,
    ) -> Result<Self, ConfigError> {
        let agent = u8::try_from(node.agent)
            .ok()
            .filter(|&a| a > 0)
            .ok_or_else(|| ConfigError::new("node.agent", "must lie in 1..=255"))?;
        if node.neighbours.len() > MAX_NEIGHBOURS {
            return Err(ConfigError::new(
                "node.neighbours",
                format!("at most {MAX_NEIGHBOURS} entries"),
            ));
        }
        let mut neighbours = [0u8; MAX_NEIGHBOURS];
        for (k, (d, &a)) in neighbours.iter_mut().zip(&node.neighbours).enumerate() {
            *d = u8::try_from(a)
                .ok()
                .filter(|&a| a > 0 && a != agent && !node.neighbours[..k].contains(&i64::from(a)))
                .ok_or_else(|| {
                    ConfigError::new(
                        format!("node.neighbours[{}]", k + 1),
                        format!("{a} is not an agent in 1..=255 other than {agent} and not listed before"),
                    )
                })?;
        }
        if file.agent.neighbour_count != node.neighbours.len() {
            return Err(ConfigError::new(
                "agent.neighbour_count",
                format!(
                    "is {} but node.neighbours lists {}",
                    file.agent.neighbour_count,
                    node.neighbours.len()
                ),
            ));
        }
        if let Some(id) = node.node_id {
            if id != i64::from(agent) || !(1..=127).contains(&id) {
                return Err(ConfigError::new(
                    "node.node_id",
                    format!("must equal node.agent ({agent}) and lie in 1..=127 (got {id})"),
                ));
            }
        }
        if node.canopen.is_some() && agent > 127 {
            return Err(ConfigError::new(
                "node.canopen",
                format!("a CANopen node-ID lies in 1..=127 (node.agent is {agent})"),
            ));
        }
        if node.interface.is_empty() || node.interface.len() > 15 {
            return Err(ConfigError::new(
                "node.interface",
                "must be a Linux interface name of 1 to 15 bytes",
            ));
        }
        let h = f64::from(file.simulation.h);
        let stale = node.stale_timeout.unwrap_or(2.5 * h);
        if !(1e-6..=1e6).contains(&stale) {
            return Err(ConfigError::new(
                "node.stale_timeout",
                format!("must be in [1e-6, 1e6] s (got {stale})"),
            ));
        }
        if !(node.time_scale.is_finite() && (1.0..=1000.0).contains(&node.time_scale)) {
            return Err(ConfigError::new("node.time_scale", "must be in [1, 1000]"));
        }
        let least = 2.0 * h * node.time_scale;
        if !(node.host_timeout.is_finite() && node.host_timeout >= least) {
            return Err(ConfigError::new(
                "node.host_timeout",
                format!("must be at least 2 h time_scale = {least} s"),
            ));
        }
        let st = node.start_timeout();
        if !(st.is_finite() && st > 0.0 && st <= 86_400.0) {
            return Err(ConfigError::new(
                "node.start_timeout",
                format!("must be in (0, 86400] s (got {st})"),
            ));
        }
        if node.packed_sensors() && !node.fd() {
            return Err(ConfigError::new(
                "node.packed_sensors",
                "packed sensor frames are CAN FD frames: needs node.fd = true",
            ));
        }
        let controller = ControllerConfig::<N>::try_from(file)
            .map_err(|e| ConfigError::new(e.param().key(), e))?;
        if let Some(e) = controller.errors(MAX_NEIGHBOURS).first() {
            return Err(ConfigError::new(e.param().key(), e));
        }
        let mut node_config =
            NodeConfig::new(agent, neighbours, ((stale * 1e6).round() as u64).max(1));
        if let Some(s) = &node.supervision {
            s.apply(&mut node_config)?;
        }
        // What `Node::new` would refuse, named by key before any socket is opened.
        let plan = node_config.ids.agents();
        if agent > plan {
            return Err(ConfigError::new(
                "node.agent",
                format!("{agent} is beyond the identifier plan's {plan} agents (node.supervision.agents)"),
            ));
        }
        if let Some(k) = node.neighbours.iter().position(|&a| a > i64::from(plan)) {
            return Err(ConfigError::new(
                format!("node.neighbours[{}]", k + 1),
                format!("beyond the identifier plan's {plan} agents (node.supervision.agents)"),
            ));
        }
        if node_config.heartbeat_period_us > 0 && node_config.ids.heartbeat_base().is_none() {
            return Err(ConfigError::new(
                "node.supervision.heartbeat_id_base",
                "a heartbeat period needs heartbeat identifiers",
            ));
        }
        Ok(Self {
            node_config,
            node,
            controller,
        })
    }

    /// The file text of a configuration: `[node]`, then the controller's tables.
    pub fn to_toml<const S: usize>(
        node: &NodeSection,
        controller: ControllerConfig<S>,
    ) -> Result<String, toml::ser::Error> {
        #[derive(Serialize)]
        struct Head<'a> {
            node: &'a NodeSection,
        }
        let mut s = toml::to_string(&Head { node })?;
        s.push('\n');
        s += &toml::to_string(&ConfigFile::from(controller))?;
        Ok(s)
    }

    /// The sample period of the node's timer: `h time_scale` [s of wall time].
    pub fn wall_h(&self) -> f64 {
        f64::from(self.controller.h) * self.node.time_scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section() -> NodeSection {
        NodeSection {
            agent: 4,
            neighbours: vec![1, 3],
            interface: "vcan0".into(),
            stale_timeout: Some(0.0025),
            host_timeout: 0.25,
            time_scale: 1.0,
            supervision: None,
            start_timeout: None,
            fd: None,
            packed_sensors: None,
            node_id: Some(4),
            canopen: None,
        }
    }

    fn controller() -> ControllerConfig<N> {
        ControllerConfig {
            neighbour_count: 2,
            pinned: false,
            h: 0.001,
            ..ControllerConfig::default()
        }
    }

    #[test]
    fn a_written_file_reads_back_to_the_same_configuration() {
        let text = NodeFile::to_toml(&section(), controller()).expect("serializes");
        let f = NodeFile::parse(&text).expect("valid");
        assert_eq!(f.controller, controller());
        assert_eq!(f.node, section());
        assert_eq!(f.node_config.agent, 4);
        assert_eq!(&f.node_config.neighbours[..2], &[1, 3]);
        assert_eq!(f.node_config.stale_timeout_us, 2500);
    }

    #[test]
    fn bad_values_name_their_key() {
        type Case = (fn(&mut NodeSection), &'static str);
        fn plan(agents: u8) -> Option<Supervision> {
            let mut c = NodeConfig::<MAX_NEIGHBOURS>::new(4, [0; MAX_NEIGHBOURS], 2500);
            c.ids = IdPlan::new(0x101, None, agents).expect("plan");
            Some(Supervision::of(&c))
        }
        let cases: [Case; 9] = [
            (|s| s.agent = 0, "node.agent"),
            (|s| s.node_id = Some(5), "node.node_id"),
            (|s| s.neighbours = vec![1, 4], "node.neighbours[2]"),
            (|s| s.interface = String::new(), "node.interface"),
            (|s| s.host_timeout = 0.0, "node.host_timeout"),
            (|s| s.start_timeout = Some(-1.0), "node.start_timeout"),
            (|s| s.packed_sensors = Some(true), "node.packed_sensors"),
            // Agent 4 in a plan of 3 agents: refused before any socket is opened.
            (|s| s.supervision = plan(3), "node.agent"),
            (
                |s| {
                    s.agent = 2;
                    s.node_id = Some(2);
                    s.neighbours = vec![1, 3];
                    s.supervision = plan(2);
                },
                "node.neighbours[2]",
            ),
        ];
        for (change, key) in cases {
            let mut s = section();
            change(&mut s);
            let text = NodeFile::to_toml(&s, controller()).expect("serializes");
            let e = NodeFile::parse(&text).expect_err(key);
            assert_eq!(e.key, key, "{e}");
        }
        let mut c = controller();
        c.neighbour_count = 1;
        let e = NodeFile::parse(&NodeFile::to_toml(&section(), c).expect("serializes"))
            .expect_err("count");
        assert_eq!(e.key, "agent.neighbour_count");
        let mut c = controller();
        c.ts = -1.0;
        let e = NodeFile::parse(&NodeFile::to_toml(&section(), c).expect("serializes"))
            .expect_err("ts");
        assert_eq!(e.key, "controller.ts", "{e}");
    }
}
