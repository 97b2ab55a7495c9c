//! The velocity feed-forward of LAW §5a against the paper's law on a leader ramp: one pinned
//! double integrator (`ẋ_1 = x_2`, `ẋ_2 = u`, `φ = 1`) follows `y_d = v t`. Without the
//! feed-forward the law has nothing that knows `ẏ_d`, so `e_1` settles where the feedback
//! `β_1 ≈ (k_1 + k_2 + 1) e_1` supplies the speed `v` (LAW §9, the terms dropped between (26)
//! and (27)); with it, `α_1` carries `ẏ_d` and the lag collapses.

use controller_core::{Controller, ControllerConfig, Feedforward, Link};

/// Leader speed `v` of the ramp.
const V: f64 = 0.5;
const H: f64 = 1e-3;

/// Mean `|y − y_d|` over the last 5 s of a 20 s ramp, the plant integrated exactly under the
/// zero-order hold.
fn ramp_lag(feedforward: Feedforward) -> f64 {
    let cfg = ControllerConfig::<2> {
        quantizer: None,
        feedforward,
        ..Default::default()
    };
    let mut c = Controller::<2, 1, 0>::new(&cfg).expect("valid configuration");
    let (mut x1, mut x2) = (0.0f64, 0.0f64);
    let steps = (20.0 / H) as usize;
    let (mut sum, mut count) = (0.0, 0u32);
    for k in 0..steps {
        let t = k as f64 * H;
        let yd = V * t;
        let out = c.step(&[x1 as f32, x2 as f32], &[], Link::Fresh(yd as f32));
        assert!(out.status.fault.is_none(), "t = {t}: {:?}", out.status);
        let u = f64::from(out.q[0]);
        x1 += H * x2 + 0.5 * H * H * u;
        x2 += H * u;
        if t >= 15.0 {
            sum += (x1 - V * (t + H)).abs();
            count += 1;
        }
    }
    sum / f64::from(count)
}

#[test]
fn feedforward_removes_most_of_the_steady_lag_behind_a_leader_ramp() {
    let c = Controller::<2, 1, 0>::new(&ControllerConfig {
        quantizer: None,
        ..Default::default()
    })
    .expect("valid configuration");
    let g = c.params().gains();
    // Linearised first step: α_1 ≈ −(k_1 + k_2 + (1 + A + S)/2) e_1 with A = 1, S = 0.
    let predicted = V / f64::from(g.k1 + g.k2 + 1.0);
    let off = ramp_lag(Feedforward::Off);
    let on = ramp_lag(Feedforward::Estimated);
    println!("ramp v = {V}: lag off {off:.5} (v/gain {predicted:.5}), on {on:.6}");
    assert!(
        off > 0.3 * predicted && off < 3.0 * predicted,
        "lag without feed-forward {off}, v/gain {predicted}"
    );
    assert!(on < 0.1 * off, "lag with feed-forward {on}, without {off}");
}
