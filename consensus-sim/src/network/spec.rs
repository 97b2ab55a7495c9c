//! The `[network]` section: its keys, their validation and the bus settings they give.

use agent_node::{
    bus_load::{Bitrates, FrameSet, PlantFrames, SensorFrames},
    NodeConfig,
};
use hil_mock::bus::{BusConfig, BusEvent, EventKind, Nanos};
use serde::{Deserialize, Serialize};

use crate::{
    graph::{Graph, MAX_NEIGHBOURS},
    network::node::{self, NodeSpec},
};
use consensus_plot::error::{Error, Result};

/// `network.kind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NetworkKind {
    /// Every agent sees its neighbours' outputs of the same instant.
    #[default]
    Ideal,
    /// Firmware nodes over the simulated CAN bus.
    Can,
    /// The node firmware on one emulated Cortex-M4F per agent, over the simulated CAN bus
    /// (`consensus_hil::network::pil`).
    Pil,
    /// Node processes on a Linux CAN interface, host-sim the plant and leader in real time
    /// (`consensus_hil::network::socketcan`).
    Socketcan,
}

impl NetworkKind {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Ideal => "ideal",
            Self::Can => "can",
            Self::Pil => "pil",
            Self::Socketcan => "socketcan",
        }
    }
}

/// `network.event[].kind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventName {
    /// The node's frames never reach the bus (it still receives and controls).
    Silent,
    /// The node floods frames with identifier `id` (default 0, the highest priority).
    Babbling,
    /// `kind = "pil"` only: the node firmware's control task stops at `from` (as a firmware
    /// bug would) and only its watchdog brings the node back.
    Hang,
    /// `kind = "pil"` only: on `[from, until)` each control step of the node firmware takes
    /// `periods` sample periods; its watchdog decides what follows.
    Slow,
}

impl EventName {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Silent => "silent",
            Self::Babbling => "babbling",
            Self::Hang => "hang",
            Self::Slow => "slow",
        }
    }
}

/// Largest `periods` of a `slow` event: far beyond any watchdog that resets the node, and
/// within the link's fixed point ([`agent_node::link::slow_periods`]).
pub const MAX_SLOW_PERIODS: f64 = 1000.0;

/// One `[[network.event]]`: a node silent, babbling or slow on `[from, until)`, or hanging
/// from `from` until its watchdog resets it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetworkEvent {
    /// 1-based agent (or give `node`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agent: Option<i64>,
    /// Bus node: 0 is the leader, `i` is agent `i` (or give `agent`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<i64>,
    /// `silent`, `babbling`, `hang` or `slow`.
    pub kind: EventName,
    /// Babbling only: 11-bit identifier of the flood (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<i64>,
    /// Start \[s\] (inclusive).
    #[serde(default)]
    pub from: f64,
    /// End \[s\] (exclusive); absent: until the end of the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<f64>,
    /// Slow only: sample periods each control step takes (> 0; below 1 it ends in time).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub periods: Option<f64>,
}

/// `network.nodes` (`kind = "socketcan"`): who starts the node processes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NodesMode {
    /// host-sim starts one `node-linux` per agent and stops them at the end.
    #[default]
    Spawn,
    /// The nodes run elsewhere (other processes, boards); host-sim waits for them.
    External,
}

impl NodesMode {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Spawn => "spawn",
            Self::External => "external",
        }
    }
}

/// `[network]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkSpec {
    /// `"ideal"` or `"can"`.
    pub kind: NetworkKind,
    /// Bit rate [bit/s].
    pub bitrate: i64,
    /// From end-of-frame to delivery at the receivers \[s\].
    pub latency: f64,
    /// Probability that a frame reaches no receiver.
    pub loss: f64,
    /// Probability that a transmission is corrupted (CRC error, error frame, retransmission).
    pub corruption: f64,
    /// A neighbour value older than this is `Stale` \[s\]; absent: `2.5 h`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stale_timeout: Option<f64>,
    /// Seed of the loss and corruption random numbers.
    pub seed: i64,
    /// Silent and babbling nodes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub event: Vec<NetworkEvent>,
    /// `kind = "socketcan"`: the Linux CAN interface; absent: `"vcan0"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface: Option<String>,
    /// `kind = "socketcan"`: one interface per agent's node (e.g. each node on its own CAN
    /// controller of one bus); absent: every node on `interface`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node_interfaces: Option<Vec<String>>,
    /// `kind = "socketcan"`: wall seconds per simulated second (host-sim's loop and the nodes'
    /// timers run this much slower than real time; the controllers' `h` is unchanged);
    /// absent: 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_scale: Option<f64>,
    /// `kind = "socketcan"`: `"spawn"` (default) or `"external"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nodes: Option<NodesMode>,
    /// `kind = "socketcan"`: a node silent this long is lost; a node without sensor frames
    /// this long stops \[s\]; absent: `max(0.25, 20 h)`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node_timeout: Option<f64>,
    /// `kind = "socketcan"`: how long to wait for every node before the run starts \[s\];
    /// absent: 30.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_timeout: Option<f64>,
    /// `kind = "socketcan"`: where the node configuration files are written (kept); absent: a
    /// temporary directory, removed after the run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node_dir: Option<String>,
    /// `kind = "socketcan"`, `nodes = "spawn"`: the node program; absent: `node-linux` next to
    /// the host-sim executable, else on `PATH`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node_program: Option<String>,
    /// `kind = "socketcan"`: the command the plant applies to a lost follower (no command
    /// frame for `node_timeout`): `"zero"` (default) or `"hold"` its last command.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lost_command: Option<LostCommand>,
    /// CAN FD with bit-rate switching: the data-phase bit rate [bit/s] (`bitrate` is then the
    /// nominal, arbitration, rate); absent: classical CAN.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub data_bitrate: Option<i64>,
    /// `"per-agent"` (default: one sensor frame per follower) or `"packed"` (one CAN FD frame
    /// per 8 followers; needs `data_bitrate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_frames: Option<SensorFramesName>,
    /// `kind = "can"`: also put the plant's frames of a bench (sensor, command, state) on the
    /// modelled bus, so it carries the frame set of `kind = "socketcan"`; absent: false.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plant_frames: Option<bool>,
    /// `kind = "socketcan"`: the nodes are CANopen devices (docs/NETWORK.md §12) and host-sim
    /// their NMT master — it starts them with NMT, logs their EMCY and NMT states; absent:
    /// `false`. `kind = "pil"`, whose nodes are always CANopen devices started by host-sim:
    /// `summary.json` `firmware[]` gains each node's NMT state and EMCY.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub canopen: Option<bool>,
}

/// `network.lost_command`: what the plant applies to a lost follower.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LostCommand {
    /// Zero on every actuator from the moment the node is lost (it held the last command
    /// until then, as for any late command).
    #[default]
    Zero,
    /// The last command, for as long as the node stays silent.
    Hold,
}

impl LostCommand {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Zero => "zero",
            Self::Hold => "hold",
        }
    }
}

/// `network.sensor_frames`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SensorFramesName {
    /// One sensor frame per follower.
    #[default]
    PerAgent,
    /// One CAN FD frame per [`agent_node::plant_bus::PACKED_SENSOR_AGENTS`] followers.
    Packed,
}

impl SensorFramesName {
    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::PerAgent => "per-agent",
            Self::Packed => "packed",
        }
    }
}

impl From<SensorFramesName> for SensorFrames {
    fn from(v: SensorFramesName) -> Self {
        match v {
            SensorFramesName::PerAgent => Self::PerAgent,
            SensorFramesName::Packed => Self::Packed,
        }
    }
}

impl Default for NetworkSpec {
    fn default() -> Self {
        Self {
            kind: NetworkKind::Ideal,
            bitrate: 1_000_000,
            latency: 0.0,
            loss: 0.0,
            corruption: 0.0,
            stale_timeout: None,
            seed: 0,
            event: Vec::new(),
            interface: None,
            node_interfaces: None,
            time_scale: None,
            nodes: None,
            node_timeout: None,
            start_timeout: None,
            node_dir: None,
            node_program: None,
            lost_command: None,
            data_bitrate: None,
            sensor_frames: None,
            plant_frames: None,
            canopen: None,
        }
    }
}

impl NetworkSpec {
    /// The default (ideal) section: `check` leaves it out of the resolved scenario.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// `interface`, default `"vcan0"`.
    pub fn interface(&self) -> &str {
        self.interface.as_deref().unwrap_or("vcan0")
    }

    /// `node_timeout` [s of wall time], default `max(0.25, 20 h time_scale)`.
    pub fn node_timeout(&self, h: f64) -> f64 {
        self.node_timeout
            .unwrap_or((20.0 * h * self.time_scale()).max(0.25))
    }

    /// `time_scale`, default 1 (real time).
    pub fn time_scale(&self) -> f64 {
        self.time_scale.unwrap_or(1.0)
    }

    /// The bus's bit rates: `bitrate`, and `data_bitrate` for CAN FD.
    pub fn bitrates(&self) -> Bitrates {
        let rate = |r: i64| u32::try_from(r).unwrap_or(u32::MAX);
        Bitrates {
            nominal: rate(self.bitrate),
            data: self.data_bitrate.map(rate),
        }
    }

    /// `sensor_frames`, default one per follower.
    pub fn sensor_frames(&self) -> SensorFrames {
        self.sensor_frames.unwrap_or_default().into()
    }

    /// Whether the plant's frames are on the bus: always with `kind = "socketcan"` (a bench),
    /// with `plant_frames = true` on the modelled bus of `kind = "can"`.
    pub fn plant_on_bus(&self) -> bool {
        self.kind == NetworkKind::Socketcan
            || (self.kind == NetworkKind::Can && self.plant_frames.unwrap_or(false))
    }

    /// The frames this section puts on its bus for `agents` followers, sample period `h` \[s\]
    /// and node heartbeat period `heartbeat` \[s\] (0: none); `None` for the ideal kind.
    pub fn frame_set(&self, agents: usize, h: f64, heartbeat: f64) -> Option<FrameSet> {
        if self.kind == NetworkKind::Ideal {
            return None;
        }
        let us = |s: f64| (s * 1e6).round() as u64;
        Some(FrameSet {
            agents: u8::try_from(agents).unwrap_or(u8::MAX),
            rates: self.bitrates(),
            sample_period_us: us(h),
            heartbeat_period_us: us(heartbeat),
            plant: self.plant_on_bus().then_some(PlantFrames {
                sensor: self.sensor_frames(),
                state_period_us: us(STATE_PERIOD_S),
            }),
        })
    }

    /// `start_timeout` \[s\], default 30.
    pub fn start_timeout(&self) -> f64 {
        self.start_timeout.unwrap_or(30.0)
    }
}

/// Largest bit rate accepted (10 Mbit/s, beyond classical CAN's 1 Mbit/s on purpose); also
/// the largest CAN FD data bit rate.
pub const MAX_BITRATE: i64 = 10_000_000;
/// A bench node sends its state — its CANopen heartbeat (`0x1017` = 100 ms) — this often \[s\].
pub const STATE_PERIOD_S: f64 = 0.1;
/// Largest agent number a CAN identifier can carry (`0x100 + i ≤ 0x1FF`).
pub const MAX_CAN_AGENTS: usize = 255;

/// Agent `i`'s (0-based) node settings on a bus: its number, the agents it hears in `graph`
/// (1-based), the stale timeout of `[network]` (default `2.5 h`, at least 1 µs), and the
/// identifier plan, heartbeat and supervision of `[node]`.
pub fn node_config(
    spec: &NetworkSpec,
    node_spec: &NodeSpec,
    h: f64,
    graph: &Graph,
    i: usize,
) -> Result<NodeConfig<MAX_NEIGHBOURS>> {
    let agent = u8::try_from(i + 1)
        .ok()
        .filter(|_| i < MAX_CAN_AGENTS)
        .ok_or_else(|| {
            Error::invalid(
                "network.kind",
                format!(
                    "\"{}\" carries at most {MAX_CAN_AGENTS} agents (got {})",
                    spec.kind.as_str(),
                    graph.len()
                ),
            )
        })?;
    let mut neighbours = [0u8; MAX_NEIGHBOURS];
    for (d, &k) in neighbours.iter_mut().zip(graph.neighbours(i)) {
        *d = u8::try_from(k + 1).unwrap_or(0);
    }
    let stale = spec.stale_timeout.unwrap_or(2.5 * h);
    let mut cfg = NodeConfig::new(agent, neighbours, ((stale * 1e6).round() as u64).max(1));
    node::configure(node_spec, graph.len(), &mut cfg)?;
    Ok(cfg)
}

/// Seconds to nanoseconds (validated, finite and small enough, input).
pub fn ns(s: f64) -> Nanos {
    (s * 1e9).round() as Nanos
}

fn probability(v: f64, key: &str) -> Result<()> {
    if !(0.0..1.0).contains(&v) {
        return Err(Error::invalid(key, format!("must be in [0, 1) (got {v})")));
    }
    Ok(())
}

/// Checks `[network]` for `agents` agents, sample period `h` and horizon `t_end` (every key,
/// whatever the kind, so a typo in an `ideal` section is still reported).
pub fn validate(spec: &NetworkSpec, agents: usize, h: f64, t_end: f64) -> Result<()> {
    if !(1..=MAX_BITRATE).contains(&spec.bitrate) {
        return Err(Error::invalid(
            "network.bitrate",
            format!("must lie in 1..={MAX_BITRATE} bit/s (got {})", spec.bitrate),
        ));
    }
    if !(spec.latency.is_finite() && (0.0..=1.0).contains(&spec.latency)) {
        return Err(Error::invalid(
            "network.latency",
            format!("must be in [0, 1] s (got {})", spec.latency),
        ));
    }
    check_frame_set(spec)?;
    probability(spec.loss, "network.loss")?;
    probability(spec.corruption, "network.corruption")?;
    if let Some(s) = spec.stale_timeout {
        if !(1e-6..=1e6).contains(&s) {
            return Err(Error::invalid(
                "network.stale_timeout",
                format!("must be in [1e-6, 1e6] s (got {s})"),
            ));
        }
    }
    if spec.seed < 0 {
        return Err(Error::invalid(
            "network.seed",
            format!("must be >= 0 (got {})", spec.seed),
        ));
    }
    check_socketcan(spec, h)?;
    if let Some(list) = spec.node_interfaces.as_ref().filter(|l| l.len() != agents) {
        return Err(Error::invalid(
            "network.node_interfaces",
            format!("needs one entry per agent ({agents}), got {}", list.len()),
        ));
    }
    if matches!(
        spec.kind,
        NetworkKind::Can | NetworkKind::Pil | NetworkKind::Socketcan
    ) {
        if agents > MAX_CAN_AGENTS {
            return Err(Error::invalid(
                "network.kind",
                format!(
                    "\"{}\" carries at most {MAX_CAN_AGENTS} agents (got {agents})",
                    spec.kind.as_str()
                ),
            ));
        }
        if h < 1e-6 {
            return Err(Error::invalid(
                "simulation.h",
                format!(
                    "must be >= 1e-6 s with network.kind = \"{}\" (got {h})",
                    spec.kind.as_str()
                ),
            ));
        }
        if t_end > 1e9 {
            return Err(Error::invalid(
                "simulation.t_end",
                format!(
                    "must be <= 1e9 s with network.kind = \"{}\" (got {t_end})",
                    spec.kind.as_str()
                ),
            ));
        }
    }
    for (j, e) in spec.event.iter().enumerate() {
        let key = |k: &str| format!("network.event[{}].{k}", j + 1);
        match (e.agent, e.node) {
            (Some(a), None) => {
                if a < 1 || a as u64 > agents as u64 {
                    return Err(Error::invalid(
                        key("agent"),
                        format!("must lie in 1..={agents} (got {a})"),
                    ));
                }
            }
            (None, Some(n)) => {
                if n < 0 || n as u64 > agents as u64 {
                    return Err(Error::invalid(
                        key("node"),
                        format!("must lie in 0..={agents} (0 is the leader; got {n})"),
                    ));
                }
            }
            _ => {
                return Err(Error::invalid(
                    format!("network.event[{}]", j + 1),
                    "give exactly one of `agent` (1-based) or `node` (0 = leader)",
                ))
            }
        }
        if matches!(e.kind, EventName::Hang | EventName::Slow) {
            let what = if e.kind == EventName::Hang {
                "stops a node firmware's control task"
            } else {
                "slows a node firmware's control steps"
            };
            if spec.kind != NetworkKind::Pil {
                return Err(Error::invalid(
                    key("kind"),
                    format!(
                        "\"{}\" {what} and needs network.kind = \"pil\" (got \"{}\")",
                        e.kind.as_str(),
                        spec.kind.as_str()
                    ),
                ));
            }
            if e.agent.is_none() {
                return Err(Error::invalid(
                    key("agent"),
                    format!(
                        "kind = \"{}\" names a follower by `agent` (the leader has no firmware)",
                        e.kind.as_str()
                    ),
                ));
            }
        }
        match (e.kind, e.periods) {
            (EventName::Slow, None) => {
                return Err(Error::invalid(
                    key("periods"),
                    "needed with kind = \"slow\": sample periods each control step takes",
                ))
            }
            (EventName::Slow, Some(p)) if !(p.is_finite() && p > 0.0 && p <= MAX_SLOW_PERIODS) => {
                return Err(Error::invalid(
                    key("periods"),
                    format!("must be > 0 and <= {MAX_SLOW_PERIODS} sample periods (got {p})"),
                ))
            }
            (EventName::Slow, Some(_)) | (_, None) => {}
            (_, Some(_)) => return Err(Error::invalid(key("periods"), "only for kind = \"slow\"")),
        }
        if e.kind == EventName::Hang && e.until.is_some() {
            return Err(Error::invalid(
                key("until"),
                "not for kind = \"hang\": only the node's watchdog ends a hang",
            ));
        }
        match (e.kind, e.id) {
            (EventName::Silent | EventName::Hang | EventName::Slow, Some(_)) => {
                return Err(Error::invalid(key("id"), "only for kind = \"babbling\""))
            }
            (EventName::Babbling, Some(id)) if !(0..=0x7FF).contains(&id) => {
                return Err(Error::invalid(
                    key("id"),
                    format!("must be an 11-bit identifier in 0..=2047 (got {id})"),
                ))
            }
            _ => {}
        }
        if !(e.from.is_finite() && (0.0..=1e9).contains(&e.from)) {
            return Err(Error::invalid(
                key("from"),
                format!("must be in [0, 1e9] s (got {})", e.from),
            ));
        }
        if let Some(u) = e.until {
            if !(u.is_finite() && u > e.from && u <= 1e9) {
                return Err(Error::invalid(
                    key("until"),
                    format!("must be > from and <= 1e9 s (got {u})"),
                ));
            }
            if ns(u) <= ns(e.from) {
                return Err(Error::invalid(
                    key("until"),
                    "must be at least 1 ns after from",
                ));
            }
        }
    }
    Ok(())
}

/// `data_bitrate`, `sensor_frames`, `plant_frames`: in range and consistent.
fn check_frame_set(spec: &NetworkSpec) -> Result<()> {
    if let Some(d) = spec.data_bitrate {
        if !(spec.bitrate..=MAX_BITRATE).contains(&d) {
            return Err(Error::invalid(
                "network.data_bitrate",
                format!(
                    "must lie in network.bitrate..={MAX_BITRATE} = {}..={MAX_BITRATE} bit/s (got {d})",
                    spec.bitrate
                ),
            ));
        }
        if spec.kind == NetworkKind::Pil {
            return Err(Error::invalid(
                "network.data_bitrate",
                "not for network.kind = \"pil\": the node firmware's serial link carries \
                 classical frames only",
            ));
        }
    }
    if spec.sensor_frames == Some(SensorFramesName::Packed) && spec.data_bitrate.is_none() {
        return Err(Error::invalid(
            "network.sensor_frames",
            "\"packed\" sends CAN FD frames of up to 64 bytes: give network.data_bitrate",
        ));
    }
    if spec.sensor_frames.is_some() && !spec.plant_on_bus() {
        return Err(Error::invalid(
            "network.sensor_frames",
            "only when the plant's frames are on the bus: network.kind = \"socketcan\", or \
             \"can\" with plant_frames = true",
        ));
    }
    if spec.plant_frames.is_some() && spec.kind != NetworkKind::Can {
        return Err(Error::invalid(
            "network.plant_frames",
            "only for network.kind = \"can\" (\"socketcan\" always has them)",
        ));
    }
    Ok(())
}

/// The keys of `kind = "socketcan"`: only with that kind, and in range.
fn check_socketcan(spec: &NetworkSpec, h: f64) -> Result<()> {
    let given = [
        ("network.interface", spec.interface.is_some()),
        ("network.node_interfaces", spec.node_interfaces.is_some()),
        ("network.time_scale", spec.time_scale.is_some()),
        ("network.nodes", spec.nodes.is_some()),
        ("network.node_timeout", spec.node_timeout.is_some()),
        ("network.start_timeout", spec.start_timeout.is_some()),
        ("network.node_dir", spec.node_dir.is_some()),
        ("network.node_program", spec.node_program.is_some()),
        ("network.lost_command", spec.lost_command.is_some()),
        (
            "network.canopen",
            spec.canopen.is_some() && spec.kind != NetworkKind::Pil,
        ),
    ];
    if spec.kind != NetworkKind::Socketcan {
        if let Some((key, _)) = given.iter().find(|(_, g)| *g) {
            return Err(Error::invalid(
                *key,
                if *key == "network.canopen" {
                    "only for network.kind = \"socketcan\" or \"pil\""
                } else {
                    "only for network.kind = \"socketcan\""
                },
            ));
        }
        return Ok(());
    }
    let bad_name = |n: &str| n.is_empty() || n.len() > 15 || n.contains(['/', ' ']);
    let iface = spec.interface();
    if bad_name(iface) {
        return Err(Error::invalid(
            "network.interface",
            format!("must be a Linux interface name of 1 to 15 bytes (got \"{iface}\")"),
        ));
    }
    for (j, n) in spec.node_interfaces.iter().flatten().enumerate() {
        if bad_name(n) {
            return Err(Error::invalid(
                format!("network.node_interfaces[{}]", j + 1),
                format!("must be a Linux interface name of 1 to 15 bytes (got \"{n}\")"),
            ));
        }
    }
    let t = spec.node_timeout(h);
    let least = 2.0 * h * spec.time_scale.unwrap_or(1.0);
    if !(t.is_finite() && t >= least && t <= 3600.0) {
        return Err(Error::invalid(
            "network.node_timeout",
            format!("must be in [2 h time_scale, 3600] s = [{least}, 3600] s (got {t})"),
        ));
    }
    let ts = spec.time_scale();
    if !(ts.is_finite() && (1.0..=1000.0).contains(&ts)) {
        return Err(Error::invalid(
            "network.time_scale",
            format!("must be in [1, 1000] (got {ts})"),
        ));
    }
    let t = spec.start_timeout();
    if !(t.is_finite() && t > 0.0 && t <= 3600.0) {
        return Err(Error::invalid(
            "network.start_timeout",
            format!("must be in (0, 3600] s (got {t})"),
        ));
    }
    if spec.loss != 0.0 || spec.corruption != 0.0 || spec.latency != 0.0 || !spec.event.is_empty() {
        return Err(Error::invalid(
            "network.kind",
            "\"socketcan\" is a real bus: latency, loss, corruption and event are the bus's own, \
             not simulated",
        ));
    }
    Ok(())
}

/// The bus settings of a validated `[network]` with sample period `h` (the deadline of every
/// frame is one sample).
pub fn bus_config(spec: &NetworkSpec, h: f64) -> BusConfig {
    BusConfig {
        bitrate: spec.bitrates().nominal,
        data_bitrate: spec.bitrates().data,
        latency_ns: ns(spec.latency),
        loss: spec.loss,
        corruption: spec.corruption,
        seed: u64::try_from(spec.seed).unwrap_or(0),
        auto_retransmit: true,
        deadline_ns: ns(h),
        events: spec
            .event
            .iter()
            .filter_map(|e| {
                let kind = match e.kind {
                    EventName::Silent => EventKind::Silent,
                    EventName::Babbling => EventKind::Babbling {
                        id: u16::try_from(e.id.unwrap_or(0)).unwrap_or(0),
                    },
                    EventName::Hang | EventName::Slow => return None,
                };
                Some(BusEvent {
                    node: usize::try_from(e.agent.or(e.node).unwrap_or(0)).unwrap_or(0),
                    kind,
                    from_ns: ns(e.from),
                    until_ns: e.until.map_or(Nanos::MAX, ns),
                })
            })
            .collect(),
    }
}
