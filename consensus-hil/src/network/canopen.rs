//! host-sim as the NMT master of CANopen nodes (CiA 301, docs/NETWORK.md §12), shared by
//! `kind = "socketcan"` (whose nodes are always CANopen devices; `network.canopen` makes them
//! wait for the master's NMT start) and `kind = "pil"`: the NMT start that enables a node's
//! outputs, the NMT stop that ends a bench run, and what the nodes say back — the NMT state of
//! each node's heartbeat and every emergency message (EMCY), for `summary.json`.

use agent_node::canopen::{self, CoFrame, Message, NmtCommand, NmtState};

use consensus_sim::figures::EmcyRecord;

/// EMCY cause byte of a deadline overrun (`agent_node::canopen::Fault::Overrun`).
const CAUSE_OVERRUN: u8 = 4;
/// EMCY cause byte of the host's silence (`agent_node::canopen::Fault::HostLost`).
const CAUSE_HOST_LOST: u8 = 10;

/// The master's view of nodes `1..=agents` (node-ID = agent).
#[derive(Debug, Clone)]
pub struct Master {
    /// Per agent (index `agent - 1`), the NMT state of its last heartbeat or boot-up.
    nmt: Vec<Option<NmtState>>,
    /// Every EMCY, in the order received.
    emcy: Vec<EmcyRecord>,
    /// Per agent, its host-lost EMCY came (`0x8250`, cause 10: `Fault::HostLost`).
    host_lost: Vec<bool>,
    /// Per agent, the count of its last deadline-overrun EMCY (`0x6200`, cause 4).
    overruns: Vec<u16>,
    /// Print each EMCY to standard error as it comes.
    verbose: bool,
}

impl Master {
    /// A master of `agents` nodes; `verbose`: each EMCY is printed as it comes.
    pub fn new(agents: usize, verbose: bool) -> Self {
        Self {
            nmt: vec![None; agents],
            emcy: Vec::new(),
            host_lost: vec![false; agents],
            overruns: vec![0; agents],
            verbose,
        }
    }

    /// The NMT command frame `command` to `node` (0: every node).
    pub fn command(command: NmtCommand, node: u8) -> CoFrame {
        CoFrame::new(canopen::NMT_ID, &[command.code(), node])
    }

    /// A frame a node sent, seen at run time `t` \[s\]: an EMCY is logged, a heartbeat or
    /// boot-up updates the node's NMT state. `true` when the frame is one of a node's CANopen
    /// frames (EMCY, heartbeat, boot-up, SDO answer): traffic between the node and its master,
    /// not control traffic.
    pub fn take(&mut self, id: u16, data: &[u8], t: f64) -> bool {
        match canopen::decode(id, data) {
            Some(Message::Emcy {
                node,
                code,
                register,
                info,
            }) => {
                if self.verbose {
                    eprintln!(
                        "host-sim: t = {t:.3} s: EMCY of node {node}: {code:#06x}, register {register:#04x}"
                    );
                }
                let slot = usize::from(node).checked_sub(1);
                match (code, info[0]) {
                    (0x8250, CAUSE_HOST_LOST) => {
                        if let Some(l) = slot.and_then(|i| self.host_lost.get_mut(i)) {
                            *l = true;
                        }
                    }
                    (0x6200, CAUSE_OVERRUN) => {
                        if let Some(o) = slot.and_then(|i| self.overruns.get_mut(i)) {
                            *o = u16::from_le_bytes([info[2], info[3]]);
                        }
                    }
                    _ => {}
                }
                self.emcy.push(EmcyRecord {
                    t_s: t,
                    agent: node,
                    code,
                    register,
                    cause: info[0],
                });
                true
            }
            Some(Message::Heartbeat { node, state }) => {
                if let Some(s) = usize::from(node)
                    .checked_sub(1)
                    .and_then(|i| self.nmt.get_mut(i))
                {
                    *s = state;
                }
                true
            }
            Some(Message::Sdo { request: false, .. }) => true,
            _ => false,
        }
    }

    /// The name of agent `agent`'s (1-based) last NMT state; `None` before its first heartbeat.
    pub fn nmt_state(&self, agent: usize) -> Option<&'static str> {
        self.nmt
            .get(agent.checked_sub(1)?)
            .copied()
            .flatten()
            .map(NmtState::name)
    }

    /// Whether agent `agent` (1-based) said by EMCY that its host is gone.
    pub fn host_lost(&self, agent: usize) -> bool {
        agent
            .checked_sub(1)
            .and_then(|i| self.host_lost.get(i))
            .copied()
            .unwrap_or(false)
    }

    /// The deadline overruns agent `agent` (1-based) reported in its last EMCY `0x6200`; 0
    /// when it reported none, `None` before its first heartbeat.
    pub fn overruns(&self, agent: usize) -> Option<u16> {
        let i = agent.checked_sub(1)?;
        self.nmt.get(i).copied().flatten()?;
        self.overruns.get(i).copied()
    }

    /// The bench's name of agent `agent`'s (1-based) state (`summary.json`
    /// `socketcan.agents.state`, docs/NETWORK.md §11), from its NMT state and EMCY:
    /// `"host-lost"` once it said so by EMCY, `"stopping"` when its last heartbeat said
    /// `STOPPED`, `"running"` when operational and `commanding` (its command frames come),
    /// `"waiting"` otherwise (booting, pre-operational, or operational before its first
    /// command); `None` before its first heartbeat.
    pub fn bench_state(&self, agent: usize, commanding: bool) -> Option<&'static str> {
        let nmt = self.nmt.get(agent.checked_sub(1)?).copied().flatten()?;
        Some(if self.host_lost(agent) {
            "host-lost"
        } else {
            match nmt {
                NmtState::Stopped => "stopping",
                NmtState::Operational if commanding => "running",
                NmtState::Operational | NmtState::PreOperational | NmtState::Initialising => {
                    "waiting"
                }
            }
        })
    }

    /// Every EMCY received, in order.
    pub fn emcy(&self) -> &[EmcyRecord] {
        &self.emcy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn takes_heartbeats_emcy_and_sdo_answers_and_leaves_control_frames() {
        let mut m = Master::new(3, false);
        assert!(m.take(0x702, &[0x7F], 0.0));
        assert_eq!(m.nmt_state(2), Some("PRE-OPERATIONAL"));
        assert!(m.take(0x702, &[0x05], 0.1));
        assert_eq!(m.nmt_state(2), Some("OPERATIONAL"));
        assert_eq!(m.nmt_state(1), None);
        assert_eq!(m.nmt_state(0), None);
        assert!(m.take(0x083, &[0x00, 0x62, 0x80, 4, 1, 0, 0, 0], 0.2));
        assert_eq!(
            m.emcy(),
            [EmcyRecord {
                t_s: 0.2,
                agent: 3,
                code: 0x6200,
                register: 0x80,
                cause: 4
            }]
        );
        assert!(m.take(0x581, &[0x43, 0x18, 0x10, 1, 0, 0, 0, 0], 0.3));
        // A value frame (agent 1 of the default plan), the node's own heartbeat frame, an SDO
        // request: none of them a node's answer to its master.
        assert!(!m.take(0x102, &[0; 8], 0.3));
        assert!(!m.take(0x781, &[0; 2], 0.3));
        assert!(!m.take(0x601, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0], 0.3));
        assert_eq!(
            Master::command(NmtCommand::Stop, 0).data(),
            &[0x02, 0],
            "NMT stop of every node"
        );
        assert_eq!(
            Master::command(NmtCommand::Start, 4).data(),
            &[0x01, 4],
            "NMT start of node 4"
        );
    }

    #[test]
    fn bench_states_follow_heartbeats_and_emcy() {
        let mut m = Master::new(2, false);
        assert_eq!(m.bench_state(1, false), None, "nothing heard");
        assert_eq!(m.overruns(1), None);
        m.take(0x701, &[0x00], 0.0);
        assert_eq!(m.bench_state(1, false), Some("waiting"), "boot-up");
        m.take(0x701, &[0x7F], 0.0);
        assert_eq!(m.bench_state(1, true), Some("waiting"), "pre-operational");
        m.take(0x701, &[0x05], 0.1);
        assert_eq!(m.bench_state(1, false), Some("waiting"), "no command yet");
        assert_eq!(m.bench_state(1, true), Some("running"));
        assert_eq!(m.overruns(1), Some(0));
        // Two overrun EMCYs: the count of the last one.
        m.take(0x081, &[0x00, 0x62, 0x81, 4, 0, 3, 0, 0], 0.2);
        m.take(0x081, &[0x00, 0x62, 0x81, 4, 0, 0x2C, 1, 0], 1.2);
        assert_eq!(m.overruns(1), Some(300));
        m.take(0x701, &[0x04], 2.0);
        assert_eq!(m.bench_state(1, true), Some("stopping"));
        // Agent 2: the host's silence, by EMCY 0x8250 cause 10; a safe-state entry (0x8250
        // cause 1) is not it.
        m.take(0x702, &[0x05], 0.1);
        m.take(0x082, &[0x50, 0x82, 0x11, 1, 1, 1, 0, 0], 0.5);
        assert_eq!(m.bench_state(2, true), Some("running"));
        m.take(0x082, &[0x50, 0x82, 0x11, 10, 0, 0, 0, 0], 0.9);
        assert_eq!(m.bench_state(2, true), Some("host-lost"));
        assert!(m.host_lost(2) && !m.host_lost(1) && !m.host_lost(3));
    }
}
