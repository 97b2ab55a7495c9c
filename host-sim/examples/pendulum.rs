//! Your own plant through the library, no scenario file and no CLI: four damped pendulums,
//! each driven by two motors on its joint, follow `y_d = 0.5 sin 2t` under the paper's
//! controller (Example 2's design values), with the default faults (motor 1 at half torque,
//! motor 2 stuck on `[2,4), [6,8)` s).
//!
//! ```sh
//! cargo run --release -p host-sim --example pendulum -- out/pendulum
//! ```
//!
//! writes `summary.json`, `trajectory.csv` and the figures to the directory given (default
//! `out/pendulum`) and prints the headline figures.

use std::path::Path;

use host_sim::{
    metrics::Summary,
    plant::Plant,
    run::{run_plant, RunOptions},
    scenario::{validate_with_plant, Scenario},
};

/// `θ̇ = ω`, `ω̇ = −(g/l) sin θ − c ω + (a_1 + a_2) / (m l²)`: angle `θ` [rad] is the output.
struct Pendulum {
    /// `g / l` [1/s²].
    g_over_l: f64,
    /// Viscous damping `c` [1/s].
    damping: f64,
    /// `1 / (m l²)` [1/(kg m²)].
    inv_inertia: f64,
}

impl Plant<2, 2> for Pendulum {
    /// No term depends on time alone.
    type Time = ();

    fn at(&self, _t: f64) {}

    fn derivative(&self, _t: &(), x: &[f64; 2], a: &[f64; 2]) -> [f64; 2] {
        let [theta, omega] = *x;
        [
            omega,
            -self.g_over_l * theta.sin() - self.damping * omega + (a[0] + a[1]) * self.inv_inertia,
        ]
    }
}

fn main() -> Result<(), host_sim::Error> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "out/pendulum".into());
    let s = run(Path::new(&out), 10.0)?;
    let or_none = |v: Option<f64>, unit: &str| match v {
        Some(v) => format!("{v:.4}{unit}"),
        None => "none".into(),
    };
    println!(
        "pendulum: {}; max |y_i - y_d| after 2Ts = {}; settling time {}; max |u| = {:.2}; outputs in {out}",
        if s.diverged { "diverged" } else { "no divergence" },
        or_none(s.max_error_after_predefined_time, ""),
        or_none(s.settling_time, " s"),
        s.max_abs_u
    );
    Ok(())
}

/// `t_end` seconds of the four pendulums, outputs into `out` (host-sim/tests/example.rs runs it).
pub fn run(out: &Path, t_end: f64) -> Result<Summary, host_sim::Error> {
    // What is not set here keeps its documented default (docs/SCENARIO.md): Example 1's graph,
    // quantizer and fault schedule.
    let mut scenario = Scenario {
        name: "pendulum".into(),
        ..Scenario::default()
    };
    scenario.simulation.h = 2e-4;
    scenario.simulation.t_end = t_end;
    scenario.leader.amplitude = 0.5;
    let c = &mut scenario.controller;
    (c.ts, c.zeta, c.a_check) = (0.5, 0.6, vec![100.0, 120.0]);
    (c.p, c.eta, c.tau) = (30.0, 30.0, 30.0);
    scenario.plant.x0 = vec![
        vec![0.3, 0.0],
        vec![-0.2, 0.0],
        vec![0.1, 0.5],
        vec![0.0, -0.5],
    ];
    let setup = validate_with_plant(scenario, 2, 2)?;
    let plant = Pendulum {
        g_over_l: 9.81 / 0.8,
        damping: 0.5,
        inv_inertia: 1.0 / (1.2 * 0.8 * 0.8),
    };
    let opts = RunOptions {
        out: Some(out.to_path_buf()),
        plots: true,
        ..RunOptions::default()
    };
    Ok(run_plant(&setup, plant, &opts)?.summary)
}
