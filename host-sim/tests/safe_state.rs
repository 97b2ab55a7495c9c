//! The safe-state matrix: a leader silence, the loss of every neighbour of two agents, and a
//! sensor loss, each at instants drawn from a seed (none of them chosen by hand), on Examples 1
//! and 2, over `kind = "can"` and (four cells, both examples) `"pil"`, with the default
//! supervision policy (`hold-position`, sensor policy `hold`). Every cell asserts that the run
//! does not diverge, that the nodes the loss concerns enter their safe state and leave it, that
//! every node ends operational, and that within 3 s of the source's return the error is back
//! within 1.5× the same run's error without the loss (after `2 Ts`) and stays there to the end
//! of the run (at least 2 s more). Each cell prints how long the error took to come back.
//!
//! The instants come from `SAFE_STATE_SEED` (default below); a failure prints the seed and the
//! cell, and `SAFE_STATE_SEED=<seed> cargo test -p host-sim --release --test safe_state --
//! --ignored` replays it. CI runs the default seed and a fresh one.

mod common;

use std::path::Path;

use common::{assert_ok, bin, scenario_path, tmp};

const DEFAULT_SEED: u64 = 20_261_204;

/// The supervision every cell runs with: the timeouts, the dwell, defaults for the rest.
const SUPERVISION: [&str; 4] = [
    "node.safe_state.leader_timeout=0.1",
    "node.safe_state.neighbour_timeout=0.1",
    "node.safe_state.sensor_timeout=0.02",
    "node.safe_state.recover_dwell=0.05",
];

/// Seconds after the source returns by which the error must be back.
const BACK_AFTER: f64 = 3.0;
/// The error must then stay within this multiple of the run without the loss.
const BACK_WITHIN: f64 = 1.5;

fn seed() -> u64 {
    std::env::var("SAFE_STATE_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_SEED)
}

/// SplitMix64: the instants of a seed, the same on every machine.
struct Draw(u64);

impl Draw {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // Rounded to the millisecond so the cell prints as it runs.
        let u = (z >> 11) as f64 / (1u64 << 53) as f64;
        ((lo + (hi - lo) * u) * 1e3).round() / 1e3
    }
}

/// What is lost.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    /// The leader's frames for 1 s.
    Leader,
    /// Agent 1's frames for 1 s: agents 2 and 3 hear nobody else.
    Neighbours,
    /// Agent 4's sensor (NaN) for 0.2 s.
    Sensor,
}

impl Source {
    const ALL: [Self; 3] = [Self::Leader, Self::Neighbours, Self::Sensor];

    fn duration(self) -> f64 {
        match self {
            Self::Sensor => 0.2,
            _ => 1.0,
        }
    }

    fn event(self, from: f64) -> String {
        let until = from + self.duration();
        match self {
            Self::Leader => {
                format!("network.event=[{{node=0, kind=\"silent\", from={from}, until={until}}}]")
            }
            Self::Neighbours => {
                format!("network.event=[{{node=1, kind=\"silent\", from={from}, until={until}}}]")
            }
            Self::Sensor => format!("faults.sensor=[{{agent=4, from={from}, until={until}}}]"),
        }
    }

    /// The agents (1-based) that must enter their safe state.
    fn concerned(self) -> &'static [usize] {
        match self {
            Self::Leader => &[1, 2, 3, 4],
            Self::Neighbours => &[2, 3],
            Self::Sensor => &[4],
        }
    }
}

/// One cell: `scenario` over `kind` with `source` lost from `from`.
struct Cell<'a> {
    scenario: &'a str,
    kind: &'a str,
    source: Source,
    from: f64,
}

impl Cell<'_> {
    fn t_end(&self) -> f64 {
        (self.from + self.source.duration() + BACK_AFTER + 2.0).max(6.0)
    }

    fn name(&self) -> String {
        format!(
            "{} over {}: {:?} lost from {} s",
            self.scenario, self.kind, self.source, self.from
        )
    }

    fn run(&self, dir: &Path, with_loss: bool) {
        self.run_as(self.kind, dir, with_loss);
    }

    fn run_as(&self, kind: &str, dir: &Path, with_loss: bool) {
        let mut cmd = bin();
        cmd.args(["run", "--quiet", "--no-plots", "--out"])
            .arg(dir)
            .arg(scenario_path(self.scenario))
            .args(["--set", &format!("simulation.t_end={}", self.t_end())])
            .args(["--set", &format!("network.kind=\"{kind}\"")]);
        for s in SUPERVISION {
            cmd.args(["--set", s]);
        }
        if with_loss {
            cmd.args(["--set", &self.source.event(self.from)]);
        }
        assert_ok(&cmd.output().expect("run host-sim"));
    }
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).expect("summary"))
        .expect("json")
}

/// From `from` on, the first sample time after which `max_i |y_i − y_d|` stays within `bound`
/// to the end of the run (`from` itself if it never leaves it).
fn back_within(dir: &Path, from: f64, bound: f64) -> f64 {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).expect("trajectory.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (t, yd) = (col("t").expect("t"), col("yd").expect("yd"));
    let ys: Vec<usize> = (1..).map_while(|i| col(&format!("y{i}"))).collect();
    let mut back = from;
    for line in lines {
        let v: Vec<f64> = line
            .split(',')
            .map(|c| c.parse().expect("number"))
            .collect();
        if v[t] + 1e-9 < from {
            continue;
        }
        if ys.iter().any(|&y| (v[y] - v[yd]).abs() > bound) {
            back = v[t] + 1e-3;
        }
    }
    back
}

/// Runs `cell` and its nominal twin; `Err` names what failed.
fn check(cell: &Cell, id: &str) -> Result<String, String> {
    let (lossy, nominal) = (
        tmp(&format!("safe-{id}")),
        tmp(&format!("safe-{id}-nominal")),
    );
    cell.run(&lossy, true);
    // The nominal twin over the host-compiled nodes: over `pil` the same run is bit-identical
    // to them, which the lossy run checks on the way.
    cell.run_as("can", &nominal, false);
    let host = tmp(&format!("safe-{id}-can"));
    if cell.kind == "pil" {
        cell.run_as("can", &host, true);
        let same = |d: &Path| std::fs::read(d.join("trajectory.csv")).expect("trajectory.csv");
        if same(&lossy) != same(&host) {
            return Err("the emulated nodes' trajectory.csv differs from the host nodes'".into());
        }
    }
    let s = summary(&lossy);
    if s["diverged"] != false {
        return Err(format!("diverged: {}", s["divergence"]));
    }
    let nodes = match cell.kind {
        "pil" => s["firmware"].as_array(),
        _ => s["network"]["nodes"].as_array(),
    }
    .ok_or("no per-node report")?
    .clone();
    for (i, n) in nodes.iter().enumerate() {
        let entries = n["safe_state_entries"].as_u64().unwrap_or(0);
        if cell.source.concerned().contains(&(i + 1)) && entries == 0 {
            return Err(format!("agent {} never entered its safe state: {n}", i + 1));
        }
        if cell.kind != "pil" && n["state"] != "operational" {
            return Err(format!(
                "agent {} ended {}, not operational",
                i + 1,
                n["state"]
            ));
        }
    }
    if cell.kind == "pil" {
        // The emulated nodes report no final state; their host-compiled twins, which command
        // the same samples bit for bit, do.
        let host = summary(&host);
        let twins = host["network"]["nodes"].as_array().ok_or("no host nodes")?;
        for (i, n) in twins.iter().enumerate() {
            if n["state"] != "operational" {
                return Err(format!(
                    "agent {} ended {}, not operational",
                    i + 1,
                    n["state"]
                ));
            }
        }
    }
    let nominal_error = summary(&nominal)["max_error_after_predefined_time"]
        .as_f64()
        .ok_or("nominal run without an error after 2 Ts")?;
    let returned = cell.from + cell.source.duration();
    let bound = BACK_WITHIN * nominal_error;
    let took = back_within(&lossy, returned, bound) - returned;
    if took > BACK_AFTER {
        return Err(format!(
            "the error came back within {bound:.4} ({BACK_WITHIN}× the {nominal_error:.4} \
             without the loss) {took:.3} s after the source returned (at most {BACK_AFTER} s)"
        ));
    }
    Ok(format!(
        "ok: within {bound:.4} ({BACK_WITHIN}× nominal) {took:.3} s after the return"
    ))
}

/// Every cell of `cells`, reporting all of them before failing with the seed.
fn run_matrix(cells: &[Cell], tag: &str) {
    let seed = seed();
    let mut failed = Vec::new();
    for (k, cell) in cells.iter().enumerate() {
        match check(cell, &format!("{tag}-{k}")) {
            Ok(line) => println!("{}: {line}", cell.name()),
            Err(why) => {
                println!("{}: FAILED: {why}", cell.name());
                failed.push(format!("{}: {why}", cell.name()));
            }
        }
    }
    assert!(
        failed.is_empty(),
        "{} of {} cells failed (replay: SAFE_STATE_SEED={seed} cargo test -p host-sim --release \
         --test safe_state -- --ignored):\n{}",
        failed.len(),
        cells.len(),
        failed.join("\n")
    );
}

/// Two instants per source and example: one before `2 Ts`, one after.
fn cells<'a>(scenarios: &[(&'a str, f64)], kind: &'a str, per_source: usize) -> Vec<Cell<'a>> {
    let mut draw = Draw(seed());
    let mut out = Vec::new();
    for &(scenario, two_ts) in scenarios {
        for source in Source::ALL {
            for k in 0..per_source {
                let (lo, hi) = if k % 2 == 0 {
                    (0.2, two_ts)
                } else {
                    (two_ts, two_ts + 3.0)
                };
                out.push(Cell {
                    scenario,
                    kind,
                    source,
                    from: draw.uniform(lo, hi),
                });
            }
        }
    }
    out
}

#[test]
#[ignore = "the safe-state matrix: 24 runs, release build; run with --ignored"]
fn no_loss_at_drawn_instants_diverges_and_every_node_comes_back() {
    run_matrix(
        &cells(
            &[("example1-can.toml", 4.0), ("example2-deploy.toml", 1.0)],
            "can",
            2,
        ),
        "can",
    );
}

#[test]
#[ignore = "needs qemu-system-arm and the node-fw build; run with --ignored"]
fn the_emulated_nodes_keep_the_loop_closed_too() {
    // Both examples over `pil`, each source on one of them (the `can` matrix has every
    // combination, and each cell here is checked bit-identical to its `can` twin).
    let mut all = cells(
        &[("example1-can.toml", 4.0), ("example2-deploy.toml", 1.0)],
        "pil",
        1,
    );
    all.retain(|c| match c.source {
        Source::Leader => true,
        Source::Sensor => c.scenario.starts_with("example1"),
        Source::Neighbours => c.scenario.starts_with("example2"),
    });
    run_matrix(&all, "pil");
}

#[test]
fn the_drawn_instants_are_the_seed_s() {
    let a: Vec<f64> = (0..4).map(|_| Draw(7).uniform(0.2, 4.0)).collect();
    assert!(a.windows(2).all(|w| w[0] == w[1]));
    let mut d = Draw(7);
    let b: Vec<f64> = (0..100).map(|_| d.uniform(0.2, 4.0)).collect();
    assert!(b.iter().all(|t| (0.2..=4.0).contains(t)));
    assert!(b.windows(2).any(|w| w[0] != w[1]));
}
