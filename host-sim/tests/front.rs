//! The settling-time vs control-energy front of Example 2's two schemes: the proposed scheme
//! over its predefined time `Tₛ`, the prescribed-time baseline over its gains `c₁ × c₂`, every
//! run judged at one band, 1.5× the proposed scheme's final residual (max error over the run's
//! last `2 Tₛ`), with a dwell of 1 s — the band of the same-settling check of
//! docs/REPRODUCTION.md. Release only (about 50 runs of 10 s at h = 0.2 ms):
//!
//! ```sh
//! FRONT_OUT=target/front cargo test -p host-sim --release --test front -- --ignored --nocapture
//! ```
//! prints each run and writes `front.png` and `front.json` into `FRONT_OUT` (relative to the
//! workspace root; default: cargo's temporary directory). `cargo xtask docs` copies the figure
//! to `docs/figures/example2-front.png`.

mod common;

use host_sim::{
    front::{draw_front, pareto, FrontPoint, FrontScheme, FrontText},
    run::simulate,
    scenario,
};
use rayon::prelude::*;

/// Band of the front, × the proposed scheme's final residual.
const BAND_FACTOR: f64 = 1.5;
/// How long the error must stay inside the band [s] (both schemes' deadline in Example 2).
const DWELL: f64 = 1.0;
/// `Tₛ` of the proposed scheme (it diverges within 1 ms at `Tₛ ≤ 0.35` and this `h`).
const TS: [f64; 11] = [0.38, 0.4, 0.42, 0.45, 0.48, 0.5, 0.55, 0.6, 0.7, 0.8, 1.0];
/// The baseline's `c₁` and `c₂` (its shipped gains are `c₁ = 10`, `c₂ = 9`).
const C1: [f64; 7] = [1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 14.0];
const C2: [f64; 5] = [3.0, 4.5, 6.0, 9.0, 12.0];

/// One run of `scenario` with `sets`, judged at `band`.
fn point(scenario: &str, gains: String, sets: &[String], band: f64) -> FrontPoint {
    let mut all = vec![
        format!("simulation.settle_band={band}"),
        format!("metrics.settle_dwell={DWELL}"),
    ];
    all.extend(sets.iter().cloned());
    let setup = scenario::load(&common::scenario_path(scenario), &all).expect("valid");
    let s = simulate(&setup).expect("runs");
    FrontPoint {
        gains,
        settling_time: s.settling_time.filter(|_| !s.diverged),
        energy: (!s.diverged).then_some(s.total_u_energy),
    }
}

#[test]
#[ignore = "release sweep: see the module docs"]
fn example2_settling_time_against_control_energy() {
    // The band: the proposed scheme's max error over the last 2Tₛ = 1 s of its shipped run
    // (from the last sample's time minus 2Tₛ, as docs/REPRODUCTION.md's final residual).
    let window = "metrics.window=[{name = \"final\", kind = \"max_error\", from = 8.9998}]";
    let shipped = scenario::load(
        &common::scenario_path("example2.toml"),
        &[window.to_owned()],
    )
    .expect("valid");
    let residual = simulate(&shipped)
        .expect("runs")
        .windows
        .first()
        .and_then(|w| w.value)
        .expect("the final window has samples");
    let band = BAND_FACTOR * residual;
    let proposed: Vec<FrontPoint> = TS
        .par_iter()
        .map(|&ts| {
            point(
                "example2.toml",
                format!("Tₛ = {ts}"),
                &[format!("controller.ts={ts}")],
                band,
            )
        })
        .collect();
    let grid: Vec<(f64, f64)> = C1
        .iter()
        .flat_map(|&c1| C2.iter().map(move |&c2| (c1, c2)))
        .collect();
    let baseline: Vec<FrontPoint> = grid
        .par_iter()
        .map(|&(c1, c2)| {
            point(
                "example2-baseline.toml",
                format!("c₁ = {c1}, c₂ = {c2}"),
                &[format!("controller.c1={c1}"), format!("controller.c2={c2}")],
                band,
            )
        })
        .collect();
    let schemes = [
        FrontScheme {
            name: "predefined-time (proposed)".to_owned(),
            swept: format!("Tₛ from {} to {} s", TS[0], TS[TS.len() - 1]),
            points: proposed,
        },
        FrontScheme {
            name: "prescribed-time [39]".to_owned(),
            swept: "c₁ from 1 to 14, c₂ from 3 to 12".to_owned(),
            points: baseline,
        },
    ];
    println!("band {band:.4} rad (residual {residual:.4})");
    for s in &schemes {
        for p in &s.points {
            println!(
                "{}, {}: settling {:?} s, energy {:?}",
                s.name, p.gains, p.settling_time, p.energy
            );
        }
        println!("{} Pareto front: {:?}", s.name, pareto(&s.points));
    }
    // The sweep reaches both sides of the proposed scheme's settling time, and each scheme has
    // a front to draw.
    for s in &schemes {
        assert!(
            pareto(&s.points).len() >= 2,
            "{}: fewer than two settled runs",
            s.name
        );
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = std::env::var_os("FRONT_OUT").map_or_else(|| common::tmp("front"), |d| root.join(d));
    std::fs::create_dir_all(&dir).expect("output directory");
    let text = FrontText {
        title: "Example 2: settling time against control energy, each scheme over its gains",
        band: (band, "rad"),
        energy_unit: "N²·m²·s",
    };
    draw_front(&dir.join("front.png"), &schemes, text).expect("figure");
    let json = serde_json::json!({
        "band": band,
        "residual": residual,
        "dwell": DWELL,
        "schemes": schemes,
        "fronts": schemes.iter().map(|s| pareto(&s.points)).collect::<Vec<_>>(),
    });
    std::fs::write(
        dir.join("front.json"),
        serde_json::to_string_pretty(&json).expect("json"),
    )
    .expect("front.json");
}
