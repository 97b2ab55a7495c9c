//! Host view of the cost of one `Controller::step` (ns per step on the build machine), for
//! `n = 2, m = 2` (Example 1) and `n = 3, m = 3`, 2 neighbours. The per-step math back-end is a
//! compile-time feature, so the three back-ends are three runs:
//!
//! ```sh
//! cargo bench -p controller-core --bench step                          # libm
//! cargo bench -p controller-core --bench step --features micromath     # micromath
//! cargo bench -p controller-core --bench step --features fast-math     # fast-math
//! ```
//!
//! The target view (instructions on a Cortex-M4F) is `cargo xtask bench-target`.

use controller_core::{Controller, ControllerConfig, Link};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;

/// Steps per measured batch.
const BATCH: usize = 1000;
const H: f32 = 1e-3;

const BACKEND: &str = if cfg!(feature = "micromath") {
    "micromath"
} else if cfg!(feature = "fast-math") {
    "fast-math"
} else {
    "libm"
};

/// A smooth input sequence near consensus, like agent 4 of Example 1 after the transient:
/// own state, neighbours 1 and 3, leader.
fn inputs<const N: usize>() -> Vec<([f32; N], [Link; 2], Link)> {
    (0..BATCH)
        .map(|k| {
            let t = k as f32 * H;
            let yd = 0.6 * (2.0 * t).sin();
            let mut x = [0.0; N];
            x[0] = yd + 0.05 * (7.0 * t).sin();
            for (j, v) in x.iter_mut().enumerate().skip(1) {
                *v = 1.2 * (2.0 * t + j as f32).cos() + 0.1 * (13.0 * t).sin();
            }
            let n1 = Link::Fresh(yd + 0.01 * (3.0 * t).cos());
            let n3 = Link::Fresh(yd - 0.02 * (5.0 * t).sin());
            (x, [n1, n3], Link::Fresh(yd))
        })
        .collect()
}

fn bench_order<const N: usize>(c: &mut Criterion, name: &str) {
    let cfg = ControllerConfig::<N> {
        neighbour_count: 2,
        pinned: false,
        ..ControllerConfig::default()
    };
    let Ok(start) = Controller::<N, N, 2>::new(&cfg) else {
        panic!("invalid benchmark configuration");
    };
    let seq = inputs::<N>();
    let mut group = c.benchmark_group("step");
    group.throughput(Throughput::Elements(BATCH as u64));
    group.bench_function(format!("{BACKEND}-{name}"), |b| {
        b.iter_batched_ref(
            || start,
            |ctrl| {
                for (x, n, l) in &seq {
                    black_box(ctrl.step(black_box(x), black_box(n), *l));
                }
            },
            criterion::BatchSize::SmallInput,
        );
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_order::<2>(c, "n2m2");
    bench_order::<3>(c, "n3m3");
}

criterion_group!(step, benches);
criterion_main!(step);
