//! The fault-matrix cells CI checks with `[safety]` on (`scenarios/example1-deploy.toml`):
//! a babbling node starving the bus for 0.5 s and a silent neighbour that returns. What they
//! must show: no divergence, `|u| ≤ u_max` in every sample, back in the band within `2 T_s`
//! after the fault ends. The whole matrix: `host-sim fault-matrix` (docs/RELIABILITY.md §4).

mod common;

use host_sim::{matrix, scenario};

#[test]
fn babbling_and_silent_neighbour_cells_recover_with_safety_on() {
    let setup = scenario::load(&common::scenario_path("example1-deploy.toml"), &[])
        .expect("shipped scenario is valid");
    let s = &setup.scenario;
    assert!(s.safety.enabled);
    let u_max = s.safety.u_max.expect("deploy scenarios set u_max");
    let two_ts = setup.predefined_time();
    let (t_f, _) = matrix::timing(s.controller.ts);
    let wanted = [
        ("babbling node", "agent 2, 0.5 s"),
        ("silent neighbour", "agent 1, 0.5 s"),
        ("silent neighbour", "agent 3, 1 s"),
    ];
    let cells: Vec<matrix::Cell> = matrix::cells(setup.agents(), t_f)
        .into_iter()
        .filter(|c| wanted.contains(&(c.fault.as_str(), c.case.as_str())))
        .collect();
    assert_eq!(cells.len(), wanted.len());
    let results = matrix::run_matrix(s, &cells, false).expect("runs");
    for r in &results {
        println!("{r:?}");
        assert!(r.safety);
        assert_eq!(r.diverged_at, None, "{r:?}");
        assert!(r.max_abs_u_run <= u_max, "{r:?}");
        assert!(r.recovered_within(two_ts), "{r:?}");
    }
}
