//! Agent-steps per second of the whole loop (controller step + RK4 plant + ideal link + faults +
//! metrics, no file output), on one thread: Example 1 (4 agents, 10 s at h = 1 ms), the same with
//! the plant written as expressions (`[plant] model = "custom"`), and Example 1's plant,
//! controller and faults on seeded random graphs of 100, 1,000 and 10,000 agents (spanning tree
//! from agent 1 plus two random links per agent, initial states drawn in Example 1's box), each
//! run about 400,000 agent-steps. Criterion's throughput is agent-steps per second; its inverse
//! is the cost per agent-step (docs/SCALING.md). Also the cost of one plant right-hand side,
//! built-in and custom, and one run of Example 1 as a campaign makes it (`campaign_run`).

use std::{hint::black_box, sync::Arc};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use host_sim::{
    generate::{self, Family, GraphRecipe},
    plant::{Example1, Plant, PlantModel},
    run::{run, simulate, RunOptions},
    scenario::{self, Setup},
    sim::SharedStageTerms,
};

fn shipped(file: &str) -> Setup {
    let path = format!("{}/../scenarios/{file}", env!("CARGO_MANIFEST_DIR"));
    scenario::load(path.as_ref(), &[]).expect("shipped scenario")
}

/// Example 1 with `n` agents on a random graph, `t_end` long.
fn random(n: usize, t_end: f64) -> Setup {
    let lists = generate::neighbours(&GraphRecipe {
        family: Family::Random,
        agents: n,
        k: 0,
        extra_edges: 2 * n,
        seed: 0x5eed,
        pinned: vec![0],
        capacity: host_sim::graph::MAX_NEIGHBOURS,
    })
    .expect("random graph");
    let mut s = shipped("example1.toml").scenario;
    s.name = format!("random-{n}");
    s.simulation.t_end = t_end;
    s.graph.neighbours = Some(
        lists
            .iter()
            .map(|row| row.iter().map(|&k| k as i64 + 1).collect())
            .collect(),
    );
    s.plant.x0 = generate::initial_states(n, &[0.0, 0.09], &[0.02, 1.0], 1).expect("x0");
    scenario::validate(s).expect("valid random scenario")
}

fn bench(c: &mut Criterion) {
    // One core: the figures are per agent-step on one thread (parallel stepping is measured
    // by the swarm run of docs/SCALING.md).
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
    let mut g = c.benchmark_group("agent_steps");
    g.sample_size(10);
    for (label, setup) in [
        ("example1_4_agents_10s", shipped("example1.toml")),
        (
            "example1_custom_4_agents_10s",
            shipped("example1-custom.toml"),
        ),
        ("random_100_agents_4s", random(100, 4.0)),
        ("random_1000_agents_0.4s", random(1000, 0.4)),
        ("random_10000_agents_0.04s", random(10_000, 0.04)),
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

/// One run of Example 1 as a campaign makes it (`host-sim sweep`, e.g.
/// `campaigns/example1-10k.toml`): no file output, the plant's time terms at the RK4 stage
/// times shared with the runs before it. Throughput in agent-steps, so criterion's inverse is
/// the cost of one agent-step of such a run.
fn campaign_run(c: &mut Criterion) {
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
    let setup = shipped("example1.toml");
    let opts = RunOptions {
        stage_terms: Some(Arc::new(SharedStageTerms::default())),
        ..RunOptions::default()
    };
    let summary = run(&setup, &opts).expect("run").summary;
    assert!(!summary.diverged, "example1 diverged");
    let mut g = c.benchmark_group("campaign_run");
    g.sample_size(10);
    g.throughput(Throughput::Elements(setup.samples * setup.agents() as u64));
    g.bench_function("example1_4_agents_10s", |b| {
        b.iter(|| run(black_box(&setup), &opts).expect("run"))
    });
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

criterion_group!(benches, bench, campaign_run, rhs);
criterion_main!(benches);
