//! How neighbour and leader values reach each agent's controller (LAW §2: `y_k` is the latest
//! value agent `i` has received). A CAN bus model plugs in here by implementing [`LinkModel`].

mod ideal;

pub use controller_core::Link;
pub use ideal::IdealLink;

use crate::graph::Graph;

/// What each agent receives in one sample: its neighbours' values in configured order (flat,
/// indexed by [`Graph::offset`]) and the leader's value.
#[derive(Debug, Clone, PartialEq)]
pub struct Inbox {
    /// Per link, agent `i`'s slots at `graph.offset(i)..`.
    pub neighbours: Vec<Link>,
    /// Per agent: the leader's `y_d` (ignored by unpinned agents).
    pub leader: Vec<Link>,
}

impl Inbox {
    /// All links missing.
    pub fn new(graph: &Graph) -> Self {
        Self {
            neighbours: vec![Link::Missing; graph.links()],
            leader: vec![Link::Missing; graph.len()],
        }
    }

    /// Agent `i`'s neighbour values.
    #[inline]
    pub fn of(&self, graph: &Graph, i: usize) -> &[Link] {
        let o = graph.offset(i);
        &self.neighbours[o..o + graph.neighbours(i).len()]
    }
}

/// A network between the agents: given every agent's output at sample `k`, fill the inbox.
pub trait LinkModel {
    /// Delivers the values agents see at sample `k` (time `t`): outputs `y` (one per agent,
    /// as broadcast) and the leader's `y_d`.
    fn exchange(&mut self, k: u64, t: f64, y: &[f32], yd: f32, graph: &Graph, inbox: &mut Inbox);
}
