//! `[node]` over `kind = "can"`: the safe state on a silent leader and the way back, a moved
//! identifier base, and the section's validation through the binary.

use std::path::Path;

use host_sim::{
    metrics::Summary,
    run::{run, RunOptions, RunResult},
    scenario,
};

mod common;

use common::{assert_invalid, bin, scenario_path, tmp};

const H: f64 = 1e-3;
const LEADER_TIMEOUT: f64 = 0.05;
const SILENT_FROM: f64 = 4.0;
const SILENT_UNTIL: f64 = 5.0;

fn simulate(name: &str, sets: &[&str], options: &RunOptions) -> RunResult {
    let sets: Vec<String> = sets.iter().map(|s| (*s).to_string()).collect();
    let setup = scenario::load(&scenario_path(name), &sets).expect("valid scenario");
    run(&setup, options).expect("run")
}

/// `t` and every agent's `u_{i,1}`, `u_{i,2}` of a `trajectory.csv` (four agents).
fn commands(path: &Path) -> (Vec<f64>, Vec<[[f64; 2]; 4]>) {
    let text = std::fs::read_to_string(path).expect("trajectory.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let cols: Vec<[usize; 2]> = (1..=4)
        .map(|i| [col(&format!("u{i}_1")), col(&format!("u{i}_2"))])
        .collect();
    let (mut t, mut u) = (Vec::new(), Vec::new());
    for line in lines {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.parse().expect("number"))
            .collect();
        t.push(v[0]);
        let mut row = [[0.0; 2]; 4];
        for (r, c) in row.iter_mut().zip(&cols) {
            *r = [v[c[0]], v[c[1]]];
        }
        u.push(row);
    }
    (t, u)
}

fn window(s: &Summary, name: &str) -> f64 {
    s.windows
        .iter()
        .find(|w| w.name == name)
        .and_then(|w| w.value)
        .unwrap_or(f64::NAN)
}

/// Example 1 as deployed (`[safety]` on), leader silent for 1 s, every node watching the
/// leader with the `off` policy: each follower enters its safe state within the timeout plus
/// one sample of the leader's last frame, leaves it after the leader returns, and tracks
/// again inside the band of the same run without the silence.
#[test]
fn silent_leader_puts_every_follower_in_its_safe_state_and_tracking_resumes() {
    let common = [
        "simulation.t_end=8",
        "node.heartbeat_period=0.1",
        "node.safe_state.policy=\"off\"",
        "node.safe_state.leader_timeout=0.05",
        "node.safe_state.recover_dwell=0.05",
        "metrics.window=[{name=\"before\", from=3.0, to=4.0, kind=\"max_error\"}, \
         {name=\"after\", from=6.0, to=8.0, kind=\"max_error\"}]",
    ];
    let silent = format!(
        "network.event=[{{node=0, kind=\"silent\", from={SILENT_FROM}, until={SILENT_UNTIL}}}]"
    );
    let mut sets = common.to_vec();
    sets.push(&silent);
    let dir = tmp("node-silent-leader");
    let options = RunOptions {
        out: Some(dir.clone()),
        ..RunOptions::default()
    };
    let r = simulate("example1-deploy.toml", &sets, &options);
    let nominal = simulate("example1-deploy.toml", &common, &RunOptions::default()).summary;
    let s = &r.summary;
    assert!(!s.diverged);
    let nodes = &s.network.as_ref().expect("network").nodes;
    assert_eq!(nodes.len(), 4);
    for n in nodes {
        assert_eq!(
            (n.safe_state_entries, n.state),
            (1, "operational"),
            "agent {}",
            n.agent
        );
        assert!(n.heartbeats_sent >= 79, "{n:?}");
    }
    for n in &nominal.network.as_ref().expect("network").nodes {
        assert_eq!(n.safe_state_entries, 0, "agent {}", n.agent);
    }

    // With `off`, u = q = 0 exactly while safe (a working law never gives exactly 0 twice).
    let (t, u) = commands(&dir.join("trajectory.csv"));
    let last_leader_frame = SILENT_FROM - H;
    for agent in 1..=4 {
        let safe: Vec<f64> = t
            .iter()
            .zip(&u)
            .filter(|(_, row)| row[agent - 1] == [0.0, 0.0])
            .map(|(t, _)| *t)
            .collect();
        let (Some(&entered), Some(&left)) = (safe.first(), safe.last()) else {
            panic!("agent {agent}: never in its safe state");
        };
        println!("agent {agent}: safe from {entered:.3} s to {left:.3} s");
        assert!(
            entered > last_leader_frame + LEADER_TIMEOUT
                && entered <= last_leader_frame + LEADER_TIMEOUT + H + 1e-9,
            "agent {agent}: entered at {entered} s"
        );
        assert!(
            (SILENT_UNTIL..SILENT_UNTIL + 0.06).contains(&left),
            "agent {agent}: left at {left} s"
        );
        assert_eq!(
            safe.len(),
            ((left - entered) / H).round() as usize + 1,
            "agent {agent}: one stretch"
        );
    }
    let (before, after) = (window(s, "before"), window(s, "after"));
    let band = nominal
        .max_error_after_predefined_time
        .expect("samples after 2 Ts");
    println!("max |y - y_d|: before {before:.4}, after {after:.4}, nominal run {band:.4}");
    assert!(after <= 1.1 * band, "after {after}, nominal {band}");
}

fn trace_lines(path: &Path) -> Vec<(String, u32, String)> {
    std::fs::read_to_string(path)
        .expect("trace")
        .lines()
        .map(|l| {
            let (time, rest) = l.split_once(" can0 ").expect("candump line");
            let (id, data) = rest.split_once('#').expect("id#data");
            (
                time.to_string(),
                u32::from_str_radix(id, 16).expect("hex id"),
                data.to_string(),
            )
        })
        .collect()
}

/// Moving the identifier base keeps the arbitration order (leader, agent 1, 2, ...), so the
/// run is the same: identical `trajectory.csv`, and a bus trace that differs only in the
/// identifiers, shifted by the base.
#[test]
fn a_moved_identifier_base_gives_the_same_trajectory_and_shifted_identifiers() {
    let dir = tmp("node-moved-base");
    let run_to = |sub: &str, sets: &[&str]| {
        let out = dir.join(sub);
        let options = RunOptions {
            out: Some(out.clone()),
            trace: Some(out.join("bus.log")),
            ..RunOptions::default()
        };
        simulate("example1-can.toml", sets, &options);
        out
    };
    let a = run_to("default", &["simulation.t_end=0.5"]);
    let b = run_to("moved", &["simulation.t_end=0.5", "node.id_base=0x020"]);
    let csv = |d: &Path| std::fs::read(d.join("trajectory.csv")).expect("trajectory");
    assert!(csv(&a) == csv(&b), "trajectories differ");
    let (ta, tb) = (
        trace_lines(&a.join("bus.log")),
        trace_lines(&b.join("bus.log")),
    );
    assert_eq!(ta.len(), tb.len());
    for (x, y) in ta.iter().zip(&tb) {
        assert_eq!((&x.0, &x.2), (&y.0, &y.2));
        assert_eq!(x.1 - 0x101, y.1 - 0x020, "{x:?} {y:?}");
    }
    assert_eq!(ta[0].1, 0x101);
    assert_eq!(tb[0].1, 0x020);
}

#[test]
fn bad_node_keys_are_named_by_the_binary() {
    for (set, key) in [
        ("node.id_base=0x7FD", "node.id_base"),
        ("node.heartbeat_period=-1", "node.heartbeat_period"),
        (
            "node.safe_state.policy=\"ramp\"",
            "node.safe_state.ramp_rate",
        ),
        (
            "node.safe_state.sensor_timeout=0",
            "node.safe_state.sensor_timeout",
        ),
        (
            "node.safe_state.neighbour_loss=\"some\"",
            "node.safe_state.neighbour_loss",
        ),
    ] {
        let out = bin()
            .args(["check"])
            .arg(scenario_path("example1-can.toml"))
            .args(["--set", set])
            .output()
            .expect("run host-sim");
        assert_invalid(&out, key);
    }
}
