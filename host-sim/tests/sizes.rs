//! Every state order `n` and actuator count `m` in 1..=4 from a scenario (custom plants), sizes
//! checked against the plant, and the shipped `n = m = 3` scenario converging.

mod common;

use host_sim::{error::Error, run::simulate, scenario};

/// A damped chain `ẋ_j = x_{j+1} − 0.1 x_j`, `ẋ_n = u − 0.1 x_n` with `n` states and `m`
/// actuators, faults off, 0.2 s, Example 2's softer design values (`zeta = 0.6`,
/// `p = eta = tau = 30`: with Example 1's, orders 3 and 4 diverge within milliseconds).
fn chain(n: usize, m: usize) -> String {
    let dynamics: Vec<String> = (1..=n)
        .map(|j| {
            if j < n {
                format!("\"x{} - 0.1*x{j}\"", j + 1)
            } else {
                format!("\"u - 0.1*x{j}\"")
            }
        })
        .collect();
    let ones = |v: f64| vec![v.to_string(); n].join(", ");
    let row = format!("[{}]", ones(0.1));
    format!(
        "[simulation]\nh = 1e-4\nt_end = 0.2\n[plant]\nmodel = \"custom\"\nn = {n}\nm = {m}\n\
         dynamics = [{}]\nx0 = [{row}, {row}, {row}, {row}]\n[controller]\nts = 2.0\nzeta = 0.6\np = 30.0\neta = 30.0\ntau = 30.0\n\
         a_check = [{}]\nphi_low = [{}]\nphi_up = [{}]\neps_bar = [{}]\n[faults]\nenabled = false\n",
        dynamics.join(", "),
        ones(90.0),
        ones(1.0),
        ones(1.0),
        ones(0.0),
    )
}

#[test]
fn every_size_from_1_to_4_runs() {
    for n in 1..=4 {
        for m in 1..=4 {
            let setup = scenario::parse(&chain(n, m), &[])
                .unwrap_or_else(|e| panic!("n = {n}, m = {m}: {e}"));
            assert_eq!((setup.n(), setup.m()), (n, m));
            let s = simulate(&setup).unwrap_or_else(|e| panic!("n = {n}, m = {m}: {e}"));
            assert!(!s.diverged, "n = {n}, m = {m}: {:?}", s.divergence);
            assert_eq!(s.agents.len(), 4);
        }
    }
}

fn invalid(text: &str, sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    match scenario::parse(text, &sets) {
        Err(Error::Invalid(m)) => m,
        other => panic!("expected invalid, got {:?}", other.map(|s| s.n())),
    }
}

#[test]
fn sizes_are_checked_against_the_plant() {
    let text = chain(3, 3);
    for (sets, key) in [
        (&["plant.n=5"][..], "plant.n: must lie in 1..=4"),
        (&["plant.m=0"][..], "plant.m: must lie in 1..=4"),
        (
            &["plant.n=2"][..],
            "plant.dynamics: expected n = 2 expressions",
        ),
        (
            &["controller.a_check=[90.0, 90.0]"][..],
            "controller.a_check: `a_check` must have 3 entries",
        ),
        (
            &["plant.x0[2]=[0.1, 0.1]"][..],
            "plant.x0[2]: 2 entries, the model has n = 3",
        ),
        (
            &["network.kind=can"][..],
            "network.kind: \"can\" runs the node firmware",
        ),
        (
            &["plant.model=example1"][..],
            "plant.n: only for model = \"custom\"",
        ),
    ] {
        let m = invalid(&text, sets);
        assert!(m.contains(key), "{sets:?}: {m}");
    }
    // The default fault rules name actuators 1 and 2: with m = 1 only the first applies, and
    // a rule the user writes for an actuator the plant lacks is still rejected.
    let setup = scenario::parse(&chain(2, 1), &["faults.enabled=true".into()]).expect("valid");
    let actuators: Vec<i64> = setup
        .scenario
        .faults
        .rule
        .iter()
        .map(|r| r.actuator)
        .collect();
    assert_eq!(actuators, [1]);
    let m = invalid(
        &format!(
            "{}[[faults.rule]]\nagents = \"all\"\nactuator = 2\nkind = \"partial\"\ngain = 0.5\n",
            chain(2, 1)
        ),
        &["faults.enabled=true"],
    );
    assert!(m.contains("faults.rule[1].actuator"), "{m}");
}

#[test]
fn the_shipped_order_3_scenario_converges() {
    let setup =
        scenario::load(&common::scenario_path("custom-order3.toml"), &[]).expect("scenario");
    assert_eq!((setup.n(), setup.m()), (3, 3));
    let s = simulate(&setup).expect("run");
    assert!(!s.diverged, "{:?}", s.divergence);
    let err = s
        .max_error_after_predefined_time
        .expect("samples after 2Ts");
    assert!(err < 0.2, "max |y_i - y_d| after 2Ts = {err}");
}

#[test]
fn compare_and_fault_matrix_take_other_sizes() {
    let order3 = common::scenario_path("custom-order3.toml");
    let out = common::tmp("sizes-compare");
    let run = common::bin()
        .arg("compare")
        .arg(&order3)
        .arg(common::scenario_path("example1.toml"))
        .arg("--out")
        .arg(&out)
        .args(["--set", "simulation.t_end=0.2"])
        .output()
        .expect("host-sim");
    common::assert_ok(&run);
    assert!(out.join("compare.md").is_file() && out.join("compare.png").is_file());
    // The fault matrix acts on the CAN bus, which carries n = m = 2 only: a clear error.
    let m = common::bin()
        .arg("fault-matrix")
        .arg(&order3)
        .args(["--set", "network.kind=can", "--out"])
        .arg(common::tmp("sizes-matrix"))
        .output()
        .expect("host-sim");
    common::assert_invalid(&m, "network.kind");
}
