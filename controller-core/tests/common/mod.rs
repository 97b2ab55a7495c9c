//! A minimal closed loop of the paper's Example 1 (LAW §8) for the core's own tests: four
//! agents, an f64 RK4 plant with zero-order-hold inputs, the alternating fault windows of LAW §8.
//! The full simulator is `host-sim`; this keeps the core testable on its own.

// Each test binary that includes this module uses a different subset of it.
#![allow(dead_code)]

use controller_core::{Controller, ControllerConfig, Estimates, Link};

/// Agent i (0-based) hears these agents; agent 0 is pinned.
const NEIGHBOURS: [&[usize]; 4] = [&[], &[0], &[0], &[0, 2]];
const X0: [[f64; 2]; 4] = [[0.02, 0.8], [0.01, 1.0], [0.01, 0.09], [0.0, 0.7]];
const SUBSTEPS: usize = 4;

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

/// What one sample of the loop gives: the time, the worst `|y_i − y_d|` and the estimates.
pub struct Sample {
    pub t: f64,
    pub max_error: f64,
    /// `Σ_i (y_i − y_d)²`.
    pub sum_sq_error: f64,
    pub estimates: [Estimates; 4],
    pub max_abs_u: f64,
}

/// Four Example 1 agents and their plants.
pub struct Example1 {
    ctrls: Vec<Controller<2, 2, 4>>,
    x: [[f64; 2]; 4],
    h: f64,
    k: u64,
    faults: bool,
}

impl Example1 {
    pub fn new(ts: f32, h: f64, quantizer: bool, faults: bool) -> Self {
        let ctrls = NEIGHBOURS
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let defaults = ControllerConfig::<2>::default();
                let cfg = ControllerConfig::<2> {
                    h: h as f32,
                    ts,
                    neighbour_count: n.len(),
                    pinned: i == 0,
                    quantizer: defaults.quantizer.filter(|_| quantizer),
                    ..defaults
                };
                Controller::new(&cfg).expect("valid Example 1 config")
            })
            .collect();
        Self {
            ctrls,
            x: X0,
            h,
            k: 0,
            faults,
        }
    }

    /// One sample: measure, step every controller, integrate the plants over `h`.
    pub fn step(&mut self) -> Sample {
        let t = self.k as f64 * self.h;
        let yd = 0.6 * (2.0 * t).sin();
        let max_error = self.x.iter().map(|x| (x[0] - yd).abs()).fold(0.0, f64::max);
        let sum_sq_error = self.x.iter().map(|x| (x[0] - yd).powi(2)).sum();
        let ys: Vec<f32> = self.x.iter().map(|x| x[0] as f32).collect();
        let mut qs = [[0.0f64; 2]; 4];
        let mut estimates = [Estimates {
            mu: 0.0,
            xi: 0.0,
            lambda: 0.0,
        }; 4];
        let mut max_abs_u: f64 = 0.0;
        for (i, c) in self.ctrls.iter_mut().enumerate() {
            let links: Vec<Link> = NEIGHBOURS[i].iter().map(|&k| Link::Fresh(ys[k])).collect();
            let xi = [self.x[i][0] as f32, self.x[i][1] as f32];
            let out = c.step(&xi, &links, Link::Fresh(yd as f32));
            assert!(
                out.status.fault.is_none(),
                "fault at t = {t}: {:?}",
                out.status
            );
            qs[i] = [out.q[0] as f64, out.q[1] as f64];
            estimates[i] = out.estimates;
            max_abs_u = max_abs_u.max(out.u[0].abs() as f64);
        }
        let dt = self.h / SUBSTEPS as f64;
        for (x, q) in self.x.iter_mut().zip(&qs) {
            for s in 0..SUBSTEPS {
                *x = rk4(t + s as f64 * dt, *x, *q, dt, self.faults);
            }
            assert!(
                x.iter().all(|v| v.is_finite() && v.abs() < 1e6),
                "diverged at {t}"
            );
        }
        self.k += 1;
        Sample {
            t,
            max_error,
            sum_sq_error,
            estimates,
            max_abs_u,
        }
    }
}
