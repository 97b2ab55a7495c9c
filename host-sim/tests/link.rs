//! A link model from outside the crate plugs into the loop (as the CAN bus model will).

use std::path::PathBuf;

use host_sim::{
    graph::Graph,
    network::ideal::{Inbox, Link, LinkModel},
    run::{run, run_with_link, RunOptions},
    scenario,
};

/// Every value one sample late (held as stale), the leader on time.
#[derive(Default)]
struct OneSampleLate {
    last: Vec<f32>,
}

impl LinkModel for OneSampleLate {
    fn exchange(&mut self, _k: u64, _t: f64, y: &[f32], yd: f32, graph: &Graph, inbox: &mut Inbox) {
        for i in 0..graph.len() {
            let o = graph.offset(i);
            for (slot, &k) in inbox.neighbours[o..].iter_mut().zip(graph.neighbours(i)) {
                *slot = self.last.get(k).map_or(Link::Missing, |&v| Link::Stale(v));
            }
            inbox.leader[i] = if graph.pinned(i) {
                Link::Fresh(yd)
            } else {
                Link::Missing
            };
        }
        self.last = y.to_vec();
    }
}

#[test]
fn a_custom_link_is_used_by_the_loop() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios/example1.toml");
    let setup = scenario::load(&path, &["simulation.t_end=6".into()]).expect("valid");
    let ideal = run(&setup, &RunOptions::default()).expect("run").summary;
    let late = run_with_link(&setup, &RunOptions::default(), OneSampleLate::default())
        .expect("run")
        .summary;
    assert_eq!(
        ideal.agents[0], late.agents[0],
        "agent 1 hears only the leader, on time"
    );
    assert_ne!(
        ideal.agents[3], late.agents[3],
        "agent 4 hears its neighbours late"
    );
    let e = late
        .max_error_after_predefined_time
        .expect("samples after 2Ts");
    assert!(!late.diverged && e < 0.25, "{e}");
}
