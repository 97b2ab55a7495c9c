//! The ideal link: every agent sees its neighbours' outputs sampled at the same instant as its
//! own, as in the paper's continuous-time analysis.

use super::{Inbox, Link, LinkModel};
use crate::graph::Graph;

/// No delay, no loss.
#[derive(Debug, Clone, Copy, Default)]
pub struct IdealLink;

impl LinkModel for IdealLink {
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
