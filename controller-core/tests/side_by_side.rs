//! `Controller::step_side_by_side` (several agents' recursions interleaved, LAW §5) against
//! `Controller::step` one agent at a time: the same outputs and the same committed states, to
//! the bit, over random configurations, states and links — held steps (a non-finite state, an
//! overflow), returning links with safety on, the feed-forward of LAW §5a, more link values than
//! slots included.
//!
//! Each case prints its seed; `SIDE_BY_SIDE_SEED=<u64>` replays one.

use controller_core::{
    Controller, ControllerConfig, Feedforward, Link, QuantizerConfig, SafetyConfig, StepOutput,
};

const M: usize = 2;
const K: usize = 3;
/// Samples per case: long enough for the differentiators, estimates and quantizers to move.
const STEPS: usize = 400;

/// SplitMix64: a small generator whose whole state is its seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    fn chance(&mut self, p: f32) -> bool {
        self.unit() < p
    }

    /// A state or link value: mostly in the examples' box, sometimes far out, rarely
    /// non-finite or so large that the step overflows.
    fn value(&mut self, scale: f32) -> f32 {
        match self.below(200) {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => 1e30,
            3..=12 => (self.unit() - 0.5) * 200.0,
            _ => (self.unit() - 0.5) * 2.0 * scale,
        }
    }
}

fn config<const N: usize>(rng: &mut Rng) -> ControllerConfig<N> {
    // An agent hears someone: the leader, a neighbour or both.
    let pinned = rng.chance(0.5);
    let least = u64::from(!pinned);
    ControllerConfig {
        neighbour_count: (least + rng.below(K as u64 + 1 - least)) as usize,
        pinned,
        quantizer: rng.chance(0.8).then(QuantizerConfig::default),
        safety: rng.chance(0.5).then(|| SafetyConfig {
            u_max: rng.chance(0.5).then_some(5.0),
            du_max: rng.chance(0.5).then_some(500.0),
            ..SafetyConfig::default()
        }),
        feedforward: if rng.chance(0.3) {
            Feedforward::Estimated
        } else {
            Feedforward::Off
        },
        ..ControllerConfig::default()
    }
}

fn links(rng: &mut Rng, count: usize) -> Vec<Link> {
    // Now and then one more value than configured (a wiring error the law counts).
    let count = count + usize::from(rng.chance(0.02));
    (0..count)
        .map(|_| {
            if rng.chance(0.1) {
                Link::Missing
            } else {
                Link::Fresh(rng.value(1.0))
            }
        })
        .collect()
}

/// `Debug` writes every `f32` so that it reads back to the same bits (`-0.0` apart from
/// `0.0`), so equal texts are equal values to the bit.
fn text<T: core::fmt::Debug>(v: &T) -> String {
    format!("{v:?}")
}

/// One case of `L` agents: returns how many of the steps were held (to show the held paths ran).
fn case<const N: usize, const L: usize>(seed: u64) -> usize {
    let mut rng = Rng(seed);
    let configs: [ControllerConfig<N>; L] = core::array::from_fn(|_| config(&mut rng));
    let ctrls: [Controller<N, M, K>; L] =
        configs.map(|cfg| Controller::new(&cfg).expect("a valid configuration"));
    let (mut together, mut alone) = (ctrls, ctrls);
    let mut held = 0;
    for k in 0..STEPS {
        let x: [[f32; N]; L] = core::array::from_fn(|_| {
            core::array::from_fn(|j| rng.value(if j == 0 { 1.0 } else { 3.0 }))
        });
        let values: [Vec<Link>; L] =
            core::array::from_fn(|i| links(&mut rng, configs[i].neighbour_count));
        let leaders: [Link; L] = core::array::from_fn(|_| {
            if rng.chance(0.1) {
                Link::Missing
            } else {
                Link::Fresh(rng.value(1.0))
            }
        });
        let mut out = Vec::new();
        Controller::step_side_by_side(
            &mut together,
            &x,
            core::array::from_fn(|i| (values[i].as_slice(), leaders[i])),
            &mut out,
        );
        assert_eq!(out.len(), L);
        for i in 0..L {
            let one: StepOutput<N, M> = alone[i].step(&x[i], &values[i], leaders[i]);
            assert_eq!(
                text(&out[i]),
                text(&one),
                "seed {seed}, n = {N}, L = {L}, sample {k}, agent {i}: outputs differ"
            );
            assert_eq!(
                text(&together[i]),
                text(&alone[i]),
                "seed {seed}, n = {N}, L = {L}, sample {k}, agent {i}: states differ"
            );
            held += usize::from(one.status.fault.is_some());
        }
    }
    held
}

#[test]
fn side_by_side_steps_equal_single_steps_to_the_bit() {
    let seeds: Vec<u64> = match std::env::var("SIDE_BY_SIDE_SEED") {
        Ok(s) => vec![s.parse().expect("SIDE_BY_SIDE_SEED is a u64")],
        Err(_) => (0..24).map(|i| 20_261_205 + i).collect(),
    };
    let mut held = 0;
    for &seed in &seeds {
        eprintln!("side by side: seed {seed} (replay: SIDE_BY_SIDE_SEED={seed})");
        held += case::<2, 4>(seed) + case::<2, 3>(seed) + case::<2, 1>(seed) + case::<3, 4>(seed);
    }
    // The held paths ran (a non-finite state, an overflow): their lanes are compared too.
    assert!(held > 0, "no held step in {} seeds", seeds.len());
}
