//! Agent-steps per second of the whole loop (controller step + RK4 plant + ideal link +
//! metrics, no file output): Example 1 (4 agents, 10 s at h = 1 ms), the same with the plant
//! written as expressions (`[plant] model = "custom"`), and 1,000 agents on a seeded random
//! connected graph; and the cost of one plant right-hand side, built-in and custom.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use host_sim::{
    graph::Graph,
    plant::{Example1, Plant, PlantModel},
    run::simulate,
    scenario::{self, Scenario, Setup},
};

fn shipped(file: &str) -> Setup {
    let path = format!("{}/../scenarios/{file}", env!("CARGO_MANIFEST_DIR"));
    scenario::load(path.as_ref(), &[]).expect("shipped scenario")
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
        ("example1_4_agents_10s", shipped("example1.toml")),
        (
            "example1_custom_4_agents_10s",
            shipped("example1-custom.toml"),
        ),
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

/// One evaluation of Example 1's `f(t, x, a)`: the built-in model and its expressions.
fn rhs(c: &mut Criterion) {
    let PlantModel::Custom(custom) = shipped("example1-custom.toml").plant else {
        panic!("example1-custom.toml is a custom plant");
    };
    let mut g = c.benchmark_group("plant_rhs");
    let (x, a) = ([0.02, 0.8], [0.3, -0.1]);
    g.bench_function("example1_built_in", |b| {
        b.iter(|| {
            let t = Plant::<2, 2>::at(&Example1, black_box(1.5));
            Plant::<2, 2>::derivative(&Example1, &t, black_box(&x), black_box(&a))
        })
    });
    g.bench_function("example1_custom", |b| {
        b.iter(|| {
            let t = Plant::<2, 2>::at(&*custom, black_box(1.5));
            Plant::<2, 2>::derivative(&*custom, &t, black_box(&x), black_box(&a))
        })
    });
    g.finish();
}

criterion_group!(benches, bench, rhs);
criterion_main!(benches);
