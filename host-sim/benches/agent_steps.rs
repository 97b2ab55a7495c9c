//! Agent-steps per second of the whole loop (controller step + RK4 plant + ideal link +
//! metrics, no file output): Example 1 (4 agents, 10 s at h = 1 ms) and 1,000 agents on a
//! seeded random connected graph.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use host_sim::{
    graph::Graph,
    run::simulate,
    scenario::{self, Scenario, Setup},
};

fn example1() -> Setup {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/example1.toml");
    scenario::load(path.as_ref(), &[]).expect("example1.toml")
}

fn random(n: usize, t_end: f64) -> Setup {
    let g = Graph::random_connected(n, 2, 0x5eed).expect("connected");
    let mut s = Scenario {
        name: format!("random-{n}"),
        ..Scenario::default()
    };
    s.simulation.t_end = t_end;
    s.graph.neighbours = Some(
        (0..n)
            .map(|i| g.neighbours(i).iter().map(|&k| k as i64 + 1).collect())
            .collect(),
    );
    s.graph.pinned = vec![1];
    s.plant.x0 = vec![vec![0.01, 0.5]; n];
    scenario::validate(s).expect("valid random scenario")
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("agent_steps");
    g.sample_size(10);
    for (label, setup) in [
        ("example1_4_agents_10s", example1()),
        ("random_1000_agents_0.5s", random(1000, 0.5)),
    ] {
        let summary = simulate(&setup).expect("run");
        assert!(
            !summary.diverged,
            "{label} diverged: {:?}",
            summary.divergence
        );
        g.throughput(Throughput::Elements(setup.samples * setup.agents() as u64));
        g.bench_function(label, |b| {
            b.iter(|| simulate(black_box(&setup)).expect("run"))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
