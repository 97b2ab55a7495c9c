//! Closed-loop check of the paper's Example 1 (SPEC §8) with a minimal RK4 plant: four agents,
//! faults and quantizer on, h = 1 ms. The full simulator lives in `host-sim`; this test keeps the
//! core honest on its own.

use controller_core::{Controller, ControllerConfig, Link};

const H: f64 = 1e-3;
const SUBSTEPS: usize = 4;
/// Agent i (0-based) hears these agents; agent 0 is pinned.
const NEIGHBOURS: [&[usize]; 4] = [&[], &[0], &[0], &[0, 2]];
const X0: [[f64; 2]; 4] = [[0.02, 0.8], [0.01, 1.0], [0.01, 0.09], [0.0, 0.7]];

fn faults_active(t: f64) -> bool {
    t >= 2.0 && (t - 2.0).rem_euclid(4.0) < 2.0
}

fn plant(t: f64, x: [f64; 2], q: [f64; 2], faults: bool) -> [f64; 2] {
    let (a1, a2) = if faults && faults_active(t) {
        (0.5 * q[0], t.sin())
    } else {
        (q[0], q[1])
    };
    [
        x[1] + 0.8 * x[0].powi(3),
        a1 + a2 - 2.0 * x[0] * x[0] + x[1].powi(3) + t.cos(),
    ]
}

fn rk4(t: f64, x: [f64; 2], q: [f64; 2], dt: f64, faults: bool) -> [f64; 2] {
    let add = |x: [f64; 2], k: [f64; 2], s: f64| [x[0] + s * k[0], x[1] + s * k[1]];
    let k1 = plant(t, x, q, faults);
    let k2 = plant(t + dt / 2.0, add(x, k1, dt / 2.0), q, faults);
    let k3 = plant(t + dt / 2.0, add(x, k2, dt / 2.0), q, faults);
    let k4 = plant(t + dt, add(x, k3, dt), q, faults);
    [
        x[0] + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
        x[1] + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
    ]
}

/// Max |y_i − y_d| over samples with t ≥ t_from.
fn run(ts: f32, t_end: f64, t_from: f64, quantizer: bool, faults: bool) -> f64 {
    let mut ctrls: Vec<Controller<2, 2, 4>> = NEIGHBOURS
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let defaults = ControllerConfig::<2>::default();
            let cfg = ControllerConfig::<2> {
                ts,
                neighbour_count: n.len(),
                pinned: i == 0,
                quantizer: defaults.quantizer.filter(|_| quantizer),
                ..defaults
            };
            Controller::new(&cfg).expect("valid Example 1 config")
        })
        .collect();
    let mut x = X0;
    let steps = (t_end / H).round() as usize;
    let mut worst: f64 = 0.0;
    for k in 0..steps {
        let t = k as f64 * H;
        let yd = 0.6 * (2.0 * t).sin();
        if t >= t_from {
            for xi in &x {
                worst = worst.max((xi[0] - yd).abs());
            }
        }
        let ys: Vec<f32> = x.iter().map(|xi| xi[0] as f32).collect();
        let mut qs = [[0.0f64; 2]; 4];
        for (i, c) in ctrls.iter_mut().enumerate() {
            let links: Vec<Link> = NEIGHBOURS[i].iter().map(|&k| Link::Fresh(ys[k])).collect();
            let xi = [x[i][0] as f32, x[i][1] as f32];
            let out = c.step(&xi, &links, Link::Fresh(yd as f32));
            assert!(
                out.status.fault.is_none(),
                "fault at t = {t}: {:?}",
                out.status
            );
            qs[i] = [out.q[0] as f64, out.q[1] as f64];
        }
        let dt = H / SUBSTEPS as f64;
        for (xi, q) in x.iter_mut().zip(&qs) {
            for s in 0..SUBSTEPS {
                *xi = rk4(t + s as f64 * dt, *xi, *q, dt, faults);
            }
            assert!(
                xi.iter().all(|v| v.is_finite() && v.abs() < 1e6),
                "diverged at {t}"
            );
        }
    }
    worst
}

#[test]
fn example1_tracks_after_predefined_time_with_faults_and_quantizer() {
    let e2 = run(2.0, 10.0, 4.0, true, true);
    println!("Example 1, Ts = 2: max |y_i - y_d| after 4 s = {e2:.4}");
    assert!(e2 < 0.25, "max error after 2 Ts = {e2}");
    let e1 = run(1.0, 10.0, 2.0, true, true);
    println!("Example 1, Ts = 1: max |y_i - y_d| after 2 s = {e1:.4}");
    assert!(
        e1 < e2,
        "Ts = 1 ({e1}) should track tighter than Ts = 2 ({e2})"
    );
}
