//! What agents report beyond the loop, for `summary.json`: the bus figures (`network`, runs
//! over the CAN bus model or processor in the loop), the node-firmware figures
//! (`firmware[]`, processor in the loop), and the real-time figures of a run on a Linux CAN
//! interface (`socketcan`). A leaf module, so the simulation loop can name them
//! without importing the agents that produce them.

use hil_mock::bus::BusStats;
use serde::Serialize;

use crate::network::spec::NetworkKind;

/// What the agents of one network kind report after a run: one value per kind, which the
/// command writes into `summary.json` (`network`, `firmware`, `socketcan`).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum KindReport {
    /// `kind = "ideal"`: nothing beyond the loop's own figures.
    #[default]
    Ideal,
    /// `kind = "can"`: the bus (`network`).
    Can(NetworkSummary),
    /// `kind = "pil"`: the bus (`network`) and every node's firmware (`firmware[]`).
    Pil {
        /// `network`.
        network: NetworkSummary,
        /// `firmware[]`, in agent order.
        firmware: Vec<FirmwareSummary>,
    },
    /// `kind = "socketcan"`: the real-time figures of the bench (`socketcan`).
    Socketcan(SocketcanSummary),
}

/// `summary.json` `network` (runs with `kind = "can"`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetworkSummary {
    /// `"can"`.
    pub kind: String,
    /// Bit rate [bit/s].
    pub bitrate: u32,
    /// Time the bus carried frames or error frames, percent of the run.
    pub bus_load_percent: f64,
    /// Frames transmitted without error (delivered + lost).
    pub frames_sent: u64,
    /// Frames transmitted but reaching no receiver (`loss`).
    pub frames_lost: u64,
    /// Transmissions destroyed by a CRC error (`corruption`).
    pub frames_corrupted: u64,
    /// Frames replaced before they could be sent, or delivered more than `h` after submission.
    pub deadline_misses: u64,
    /// Times a node went bus-off.
    pub bus_off_events: u64,
    /// Largest age of the neighbour (and leader) data a controller used \[s\].
    pub max_age_s: f64,
    /// Mean age of the neighbour (and leader) data a controller used \[s\].
    pub mean_age_s: f64,
    /// Longest submission-to-delivery time \[s\].
    pub max_latency_s: f64,
    /// Frames rejected by the nodes' decoders (unknown id, wrong length, ...), summed.
    pub malformed: u64,
    /// Neighbour link-samples passed to a controller as `Stale`, summed over nodes.
    pub stale_samples: u64,
    /// Frames of silent nodes that never reached the bus.
    pub suppressed: u64,
    /// Frames of babbling nodes on the bus.
    pub babble_frames: u64,
    /// Per agent, the node's supervision figures (`kind = "can"` with a `[node]` section).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nodes: Vec<NodeSummary>,
    /// CAN FD data-phase bit rate [bit/s] (`network.data_bitrate`); absent: classical CAN.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub data_bitrate: Option<u32>,
}

/// `summary.json` `network.nodes[]`: one agent's node supervisor over the run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeSummary {
    /// 1-based agent.
    pub agent: usize,
    /// The node's state at the end: `"operational"`, `"boot"`, `"safe"` or `"fault"`.
    pub state: &'static str,
    /// Times the node entered its safe state.
    pub safe_state_entries: u32,
    /// Deadline overruns the node counted.
    pub overruns: u32,
    /// Heartbeats the node handed to its CAN controller.
    pub heartbeats_sent: u32,
}

impl NetworkSummary {
    /// The figures of a run over a bus with statistics `s`; `malformed` and `stale_samples`
    /// are the nodes' counts, summed.
    pub fn new(
        kind: NetworkKind,
        bitrate: u32,
        s: &BusStats,
        malformed: u64,
        stale_samples: u64,
    ) -> Self {
        Self {
            kind: kind.as_str().into(),
            bitrate,
            bus_load_percent: s.load_percent(),
            frames_sent: s.frames_sent,
            frames_lost: s.frames_lost,
            frames_corrupted: s.frames_corrupted,
            deadline_misses: s.deadline_misses,
            bus_off_events: s.bus_off_events,
            max_age_s: s.max_age_s(),
            mean_age_s: s.mean_age_s(),
            max_latency_s: s.max_latency_ns as f64 * 1e-9,
            malformed,
            stale_samples,
            suppressed: s.suppressed,
            babble_frames: s.babble_frames,
            nodes: Vec::new(),
            data_bitrate: None,
        }
    }
}

/// `summary.json` `firmware[]`: one agent's node firmware over the closed-loop run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FirmwareSummary {
    /// 1-based agent.
    pub agent: usize,
    /// Ticks measured (= samples).
    pub steps: usize,
    /// Fewest instructions of one `Node::tick`.
    pub instructions_min: u32,
    /// Median over the run.
    pub instructions_median: u32,
    /// 99th percentile (nearest rank).
    pub instructions_p99: u32,
    /// Most instructions of one tick.
    pub instructions_max: u32,
    /// Resolution of the counts (instructions per SysTick count).
    pub instructions_resolution: u32,
    /// Stack high-water mark of the whole firmware (painted), bytes.
    pub stack_bytes: u32,
    /// Releases of the sample timer that found the previous step still running.
    pub overruns: u32,
    /// Watchdog resets during the run (each one ends with the node re-joining).
    pub resets: u32,
    /// Times the node entered its safe state (from the state in its reports).
    pub safe_state_entries: u32,
    /// `network.canopen`: the node's last NMT state from its heartbeat.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nmt_state: Option<&'static str>,
    /// `network.canopen`: every EMCY the node sent, in order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub emcy: Option<Vec<EmcyRecord>>,
}

/// `summary.json` `socketcan`: one agent's commands.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AgentCommands {
    /// 1-based agent.
    pub agent: usize,
    /// Command frames received during the run.
    pub received: u64,
    /// Samples at which no new command had come since the previous sample (the plant held the
    /// previous one).
    pub late: u64,
    /// Samples minus commands received (0 when a node sent more than one per sample).
    pub missing: u64,
    /// Run time at which the node had been silent for `node_timeout`; `null`: never.
    pub lost_at_s: Option<f64>,
    /// `lost`, or the node's state from its CANopen heartbeat and EMCY (`waiting`, `running`,
    /// `host-lost`, `stopping`: docs/NETWORK.md §11), `null` when it sent no heartbeat.
    pub state: Option<&'static str>,
    /// The node's deadline overruns (samples its own timer woke more than `h/2` late), as its
    /// last EMCY `0x6200` said; 0 without one, `null` when it sent no heartbeat.
    pub node_late_ticks: Option<u16>,
    /// `network.canopen`: the node's last NMT state from its heartbeat.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nmt_state: Option<&'static str>,
}

/// `summary.json` `socketcan.emcy[]` (`network.canopen`): one emergency message of a node.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EmcyRecord {
    /// Run time it was received at \[s\] (negative: before the first sample).
    pub t_s: f64,
    /// The node (= agent).
    pub agent: u8,
    /// CiA 301 error code (`0`: error reset).
    pub code: u16,
    /// Error register.
    pub register: u8,
    /// Cause byte (docs/NETWORK.md §12).
    pub cause: u8,
}

/// `summary.json` `socketcan`: the real-time figures of a run on a Linux CAN interface.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SocketcanSummary {
    /// The interface.
    pub interface: String,
    /// `"spawn"` or `"external"`.
    pub nodes: &'static str,
    /// Samples run.
    pub samples: u64,
    /// Mean of (wake-up − deadline) over the samples \[s\].
    pub loop_lateness_mean_s: f64,
    /// 99th percentile (nearest rank) \[s\].
    pub loop_lateness_p99_s: f64,
    /// Largest \[s\].
    pub loop_lateness_max_s: f64,
    /// Samples whose wake-up was more than `h/2` late.
    pub loop_overruns: u64,
    /// Wall time from the first sample's deadline to the last's wake-up \[s\].
    pub wall_time_s: f64,
    /// Frames the host sent (leader and sensor frames).
    pub frames_sent: u64,
    /// Frames the host could not send (full queue, bus-off).
    pub send_errors: u64,
    /// Per agent.
    pub agents: Vec<AgentCommands>,
    /// `network.canopen`: every EMCY the nodes sent, in order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub emcy: Option<Vec<EmcyRecord>>,
}

/// Units of the numeric keys of [`SocketcanSummary`] for `summary.json` `units`.
pub const SOCKETCAN_UNITS: [(&str, &str); 14] = [
    ("socketcan.samples", "count"),
    ("socketcan.loop_lateness_mean_s", "s"),
    ("socketcan.loop_lateness_p99_s", "s"),
    ("socketcan.loop_lateness_max_s", "s"),
    ("socketcan.loop_overruns", "count"),
    ("socketcan.wall_time_s", "s"),
    ("socketcan.frames_sent", "count"),
    ("socketcan.send_errors", "count"),
    ("socketcan.agents.agent", "1-based index"),
    ("socketcan.agents.received", "count"),
    ("socketcan.agents.late", "count"),
    ("socketcan.agents.missing", "count"),
    ("socketcan.agents.lost_at_s", "s"),
    ("socketcan.agents.node_late_ticks", "count"),
];
