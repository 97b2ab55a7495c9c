//! `kind = "ideal"`: host-sim's own controllers hearing each other through a [`LinkModel`]
//! (LAW §2: `y_k` is the latest value agent `i` has received). [`IdealLink`] is the paper's:
//! every agent sees its neighbours' outputs sampled at the same instant as its own, as in the
//! continuous-time analysis. Another link model (delay, loss) plugs in by implementing
//! [`LinkModel`].

pub use controller_core::Link;

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
    /// Every value reaches its receivers at once (a clocked run can then use the latest
    /// broadcast values without the model).
    fn is_instant(&self) -> bool {
        false
    }
}

/// No delay, no loss.
#[derive(Debug, Clone, Copy, Default)]
pub struct IdealLink;

impl LinkModel for IdealLink {
    fn is_instant(&self) -> bool {
        true
    }

    #[inline]
    fn exchange(&mut self, _k: u64, _t: f64, y: &[f32], yd: f32, graph: &Graph, inbox: &mut Inbox) {
        for i in 0..graph.len() {
            let o = graph.offset(i);
            for (slot, &k) in inbox.neighbours[o..].iter_mut().zip(graph.neighbours(i)) {
                *slot = Link::Fresh(y[k]);
            }
            inbox.leader[i] = if graph.pinned(i) {
                Link::Fresh(yd)
            } else {
                Link::Missing
            };
        }
    }
}
