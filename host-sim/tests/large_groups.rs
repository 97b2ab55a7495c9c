//! Large groups (docs/SCALING.md): generated graphs and initial states from a few keys, the same
//! bytes at any thread count, the spread figure, `--agents` and the default decimation.

mod common;

use std::{path::Path, process::Output};

use common::{assert_invalid, assert_ok, bin, scenario_path, tmp};
use host_sim::{graph::MAX_NEIGHBOURS, report::csv::default_decimate, scenario};

fn host_sim(args: &[&str]) -> Output {
    bin().args(args).output().expect("host-sim")
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `run` of the swarm scenario into `dir` without figures, with `extra` options.
fn swarm_run(dir: &Path, extra: &[&str]) -> Output {
    let swarm = scenario_path("swarm-1000.toml");
    let mut args = vec!["run", path(&swarm), "--out", path(dir), "-q", "--no-plots"];
    args.extend(extra);
    host_sim(&args)
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn the_swarm_scenario_is_a_random_graph_within_the_neighbour_capacity() -> host_sim::Result<()> {
    let s = scenario::load(&scenario_path("swarm-1000.toml"), &[])?;
    assert_eq!(s.agents(), 1000);
    assert_eq!(s.x0.len(), 1000);
    assert_eq!(s.graph.links(), 999 + 2000);
    assert!((0..1000).all(|i| s.graph.neighbours(i).len() <= MAX_NEIGHBOURS));
    assert!(s
        .x0
        .iter()
        .all(|x| (0.0..=0.02).contains(&x[0]) && (0.09..=1.0).contains(&x[1])));
    let again = scenario::load(&scenario_path("swarm-1000.toml"), &[])?;
    assert_eq!(s.graph, again.graph, "seeded: the same graph every time");
    assert_eq!(s.x0, again.x0);
    let other = scenario::load(
        &scenario_path("swarm-1000.toml"),
        &["graph.seed=2".into(), "plant.x0_seed=2".into()],
    )?;
    assert_ne!(s.graph, other.graph);
    assert_ne!(s.x0, other.x0);
    Ok(())
}

#[test]
fn every_generator_gives_a_valid_group_rooted_at_the_pinned_agents() -> host_sim::Result<()> {
    for (generator, extra) in [
        ("line", ""),
        ("ring", ""),
        ("star", ""),
        ("knn", "k = 6"),
        ("random", "extra_edges = 500"),
    ] {
        // A line and a star only reach forward from agent 1; the others from any agent.
        let pins: &[&str] = if matches!(generator, "line" | "star") {
            &["[1]"]
        } else {
            &["[1]", "[7, 40]"]
        };
        for pinned in pins {
            let text = format!(
                "[graph]\ngenerator = \"{generator}\"\nagents = 60\npinned = {pinned}\n{extra}\n\
                 [plant]\nx0_min = [0.0, 0.0]\nx0_max = [0.1, 1.0]\n"
            );
            let s = scenario::parse(&text, &[])?;
            assert_eq!((s.agents(), s.x0.len()), (60, 60), "{generator}");
        }
    }
    Ok(())
}

#[test]
fn bad_generator_keys_name_the_key() {
    let dir = tmp("large-bad-keys");
    for (text, key) in [
        (
            "[graph]\ngenerator = \"tree\"\nagents = 5",
            "graph.generator",
        ),
        (
            "[graph]\ngenerator = \"knn\"\nagents = 50\nk = 17",
            "graph.k",
        ),
        (
            "[graph]\ngenerator = \"random\"\nagents = 10\nextra_edges = 1000",
            "graph.extra_edges",
        ),
        (
            "[graph]\ngenerator = \"ring\"\nagents = 4\nneighbours = [[], [1], [1], [1]]",
            "graph.generator",
        ),
        ("[graph]\ngenerator = \"ring\"", "graph.agents"),
        ("[graph]\nagents = 4", "graph.agents"),
        ("[graph]\ngenerator = \"line\"\nagents = 0", "graph.agents"),
        (
            "[graph]\ngenerator = \"line\"\nagents = 3\npinned = [3]",
            "Assumption 2",
        ),
        (
            "[graph]\ngenerator = \"line\"\nagents = 3\nk = 2",
            "graph.k",
        ),
        ("[plant]\nx0_min = [0.0, 0.0]", "plant.x0_max"),
        (
            "[plant]\nx0_min = [0.0, 0.0]\nx0_max = [1.0]",
            "plant.x0_max",
        ),
        (
            "[plant]\nx0_min = [0.0, 0.0, 0.0]\nx0_max = [1.0, 1.0, 1.0]",
            "plant.x0_min",
        ),
        (
            "[plant]\nx0_min = [0.0, 0.0]\nx0_max = [1.0, 1.0]\nx0 = [[0, 0]]",
            "plant.x0",
        ),
    ] {
        let f = dir.join("bad.toml");
        std::fs::write(&f, text).expect("write");
        assert_invalid(&host_sim(&["check", path(&f)]), key);
    }
}

/// A 300-agent group (above the parallel threshold) run on 1 and 2 threads: every output
/// byte-identical.
#[test]
fn one_or_two_threads_write_the_same_bytes() {
    let swarm = scenario_path("swarm-1000.toml");
    let sets = [
        "--set",
        "graph.agents=300",
        "--set",
        "graph.extra_edges=600",
        "--set",
        "simulation.t_end=0.3",
    ];
    let mut dirs = Vec::new();
    for threads in ["1", "2"] {
        let d = tmp(&format!("large-threads-{threads}"));
        let mut args = vec![
            "run",
            path(&swarm),
            "--out",
            path(&d),
            "-q",
            "--threads",
            threads,
        ];
        args.extend(sets);
        assert_ok(&host_sim(&args));
        dirs.push(d);
    }
    for f in ["summary.json", "trajectory.csv", "spread.svg", "errors.svg"] {
        assert!(
            read(&dirs[0].join(f)) == read(&dirs[1].join(f)),
            "{f} differs between 1 and 2 threads"
        );
    }
    let spread = String::from_utf8_lossy(&read(&dirs[0].join("spread.svg"))).into_owned();
    assert!(spread.contains("300 agents") && spread.contains("worst after 2T"));
}

#[test]
fn agents_select_the_columns_and_large_groups_are_decimated_by_default() {
    let swarm = scenario_path("swarm-1000.toml");
    let d = tmp("large-columns");
    let out = swarm_run(
        &d,
        &["--set", "simulation.t_end=0.2", "--agents", "3,10-11"],
    );
    assert_ok(&out);
    let text = String::from_utf8_lossy(&read(&d.join("trajectory.csv"))).into_owned();
    let header = text.lines().next().unwrap_or_default();
    assert!(header.starts_with("t,yd,y3,x3_1,"), "{header}");
    // 12 columns per agent, then its 2 qf columns at the end of the row.
    assert_eq!(header.split(',').count(), 2 + 3 * 14, "{header}");
    assert_eq!(text.lines().count(), 1 + 200, "every sample: 3 agents fit");

    // 1,000 agents: about 199 kB a row (qf in f64 included), 502 rows fit in 100 MB.
    let s = scenario::load(&swarm, &[]).expect("swarm");
    assert_eq!(default_decimate(&s, 1000), 20, "10,000 samples");
    assert_eq!(default_decimate(&s, 3), 1, "--agents 3,10-11 fits");
    let e1 = scenario::load(&scenario_path("example1.toml"), &[]).expect("example1");
    assert_eq!(default_decimate(&e1, 4), 1, "small groups: every sample");
    let d = tmp("large-default-decimate");
    let out = swarm_run(&d, &["--set", "simulation.t_end=0.65"]);
    assert_ok(&out);
    let note = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(note.contains("one sample in 2 (--decimate 2"), "{note}");
    let rows = String::from_utf8_lossy(&read(&d.join("trajectory.csv")))
        .lines()
        .count();
    assert_eq!(rows, 1 + 325);
    assert_invalid(
        &host_sim(&["run", path(&swarm), "--out", path(&d), "--agents", "0-3"]),
        "--agents",
    );
    assert_invalid(
        &host_sim(&["run", path(&swarm), "--out", path(&d), "--threads", "0"]),
        "--threads",
    );
}
