//! Determinism: the same scenario and seed give byte-identical outputs, also when
//! `compare` runs its two scenarios in parallel on rayon's pool (`RAYON_NUM_THREADS=1` against
//! `4`), and over the seeded lossy CAN bus.

use std::path::Path;

use integration_tests::{host_sim_bin, scenarios_dir, scratch};

fn host_sim(args: &[&str], threads: &str, out: &Path) {
    let r = std::process::Command::new(host_sim_bin())
        .args(args)
        .arg("--out")
        .arg(out)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap_or_else(|e| panic!("host-sim: {e}"));
    assert_eq!(
        r.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

/// Every file of `a` equals the file of the same name in `b`, byte for byte.
fn same_files(a: &Path, b: &Path) -> usize {
    let mut names: Vec<_> = std::fs::read_dir(a)
        .unwrap_or_else(|e| panic!("{}: {e}", a.display()))
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .collect();
    names.sort();
    for n in &names {
        let x = std::fs::read(a.join(n)).unwrap_or_else(|e| panic!("{n:?}: {e}"));
        let y =
            std::fs::read(b.join(n)).unwrap_or_else(|e| panic!("{n:?} in {}: {e}", b.display()));
        assert!(
            x == y,
            "{n:?} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
    let count_b = std::fs::read_dir(b).map(|d| d.count()).unwrap_or(0);
    assert_eq!(names.len(), count_b, "different file sets");
    names.len()
}

#[test]
fn compare_in_parallel_is_byte_identical_to_sequential() {
    let a = scenarios_dir().join("example1.toml");
    let b = scenarios_dir().join("example1-ts1.toml");
    let (a, b) = (a.to_string_lossy(), b.to_string_lossy());
    let args = [
        "compare",
        a.as_ref(),
        b.as_ref(),
        "--quiet",
        "--set",
        "simulation.t_end=1",
    ];
    let seq = scratch("determinism-compare-1");
    let par = scratch("determinism-compare-4");
    host_sim(&args, "1", &seq);
    host_sim(&args, "4", &par);
    let n = same_files(&seq, &par);
    assert!(
        n >= 3,
        "compare.md, compare.json and the figure expected, got {n}"
    );
}

#[test]
fn seeded_runs_are_byte_identical() {
    for (name, t_end) in [("example1.toml", "1"), ("example1-lossy.toml", "0.5")] {
        let s = scenarios_dir().join(name);
        let s = s.to_string_lossy();
        let set = format!("simulation.t_end={t_end}");
        let args = ["run", s.as_ref(), "--quiet", "--no-plots", "--set", &set];
        let x = scratch(&format!("determinism-{name}-1"));
        let y = scratch(&format!("determinism-{name}-2"));
        host_sim(&args, "1", &x);
        host_sim(&args, "4", &y);
        assert_eq!(
            same_files(&x, &y),
            2,
            "{name}: summary.json and trajectory.csv"
        );
    }
}
