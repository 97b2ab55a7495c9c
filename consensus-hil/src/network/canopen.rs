//! host-sim as the NMT master of CANopen nodes (CiA 301, docs/NETWORK.md §12), shared by
//! `kind = "socketcan"` (`network.canopen`) and `kind = "pil"` (whose nodes are always CANopen
//! devices): the NMT start that enables a node's outputs, and what the nodes say back — the
//! NMT state of each node's heartbeat and every emergency message (EMCY), for `summary.json`.

use agent_node::canopen::{self, CoFrame, Message, NmtCommand, NmtState};

use consensus_sim::figures::EmcyRecord;

/// The master's view of nodes `1..=agents` (node-ID = agent).
#[derive(Debug, Clone)]
pub struct Master {
    /// Per agent (index `agent - 1`), the NMT state of its last heartbeat or boot-up.
    nmt: Vec<Option<NmtState>>,
    /// Every EMCY, in the order received.
    emcy: Vec<EmcyRecord>,
    /// Print each EMCY to standard error as it comes.
    verbose: bool,
}

impl Master {
    /// A master of `agents` nodes; `verbose`: each EMCY is printed as it comes.
    pub fn new(agents: usize, verbose: bool) -> Self {
        Self {
            nmt: vec![None; agents],
            emcy: Vec::new(),
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
            Master::command(NmtCommand::Start, 4).data(),
            &[0x01, 4],
            "NMT start of node 4"
        );
    }
}
