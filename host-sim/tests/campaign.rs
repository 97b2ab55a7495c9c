//! `host-sim sweep` / `merge`: rows equal `host-sim run` summaries, thread count and sharding
//! do not change the bytes, a killed campaign resumes without running anything twice, and a
//! bad campaign file exits 2 naming the key.

mod common;

use std::{
    collections::BTreeSet,
    path::{Path, PathBuf},
    process::Stdio,
    time::{Duration, Instant},
};

use common::{assert_invalid, bin, tmp};

fn campaign(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/campaigns")
        .join(name)
}

fn sweep(file: &Path, out: &Path, extra: &[&str], threads: &str) {
    let o = bin()
        .arg("sweep")
        .arg(file)
        .arg("--out")
        .arg(out)
        .args(extra)
        .arg("--quiet")
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .expect("spawn host-sim");
    assert!(
        o.status.success(),
        "sweep failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `results.csv` as header + rows of fields.
fn table(dir: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r = csv::Reader::from_path(dir.join("results.csv")).expect("results.csv");
    let h = r
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    let rows = r
        .records()
        .map(|x| x.expect("row").iter().map(String::from).collect())
        .collect();
    (h, rows)
}

/// Every metric cell of `row` equals `summary.json` of `host-sim run` with `sets`.
fn assert_row_is_run(header: &[String], row: &[String], scenario: &Path, sets: &[String]) {
    let out = tmp(&format!("campaign-run-{}", row[0]));
    let mut cmd = bin();
    cmd.arg("run").arg(scenario).arg("--out").arg(&out);
    for s in sets {
        cmd.arg("--set").arg(s);
    }
    let o = cmd.args(["--no-plots", "--quiet"]).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = read(&out.join("summary.json"));
    // The number as summary.json writes it (top-level keys are indented by two spaces).
    let raw = |key: &str| -> String {
        let tag = format!("\n  \"{key}\": ");
        let at = json
            .find(&tag)
            .unwrap_or_else(|| panic!("{key} in summary.json"))
            + tag.len();
        let v = json[at..].split([',', '\n']).next().unwrap_or_default();
        if v == "null" {
            String::new()
        } else {
            v.to_string()
        }
    };
    let col = |n: &str| &row[header.iter().position(|h| h == n).expect(n)];
    assert_eq!(col("diverged"), &raw("diverged"));
    let time = json
        .split("\"time\": ")
        .nth(1)
        .and_then(|t| t.split([',', '\n']).next())
        .unwrap_or_default();
    assert_eq!(col("divergence_time"), time);
    for k in [
        "settling_time",
        "max_error_after_predefined_time",
        "max_abs_u",
        "total_u_energy",
    ] {
        assert_eq!(col(k), &raw(k), "run {} column {k}", row[0]);
    }
}

#[test]
fn grid_rows_equal_run_summaries_and_invalid_runs_are_recorded() {
    let out = tmp("campaign-grid");
    sweep(&campaign("grid.toml"), &out, &[], "2");
    let (h, rows) = table(&out);
    assert_eq!(
        h,
        [
            "run",
            "controller.ts",
            "simulation.h",
            "diverged",
            "divergence_time",
            "settling_time",
            "max_error_after_predefined_time",
            "max_abs_u",
            "total_u_energy",
            "status",
            "error"
        ]
    );
    assert_eq!(rows.len(), 6);
    // Row-major, first axis slowest.
    let axes: Vec<(&str, &str)> = rows.iter().map(|r| (&*r[1], &*r[2])).collect();
    assert_eq!(axes[1], ("0.5", "0.002"));
    assert_eq!(axes[3], ("1.0", "0.0"));
    let invalid = &rows[3];
    assert_eq!(invalid[9], "invalid");
    assert!(invalid[10].contains("simulation.h"), "{invalid:?}");
    assert!(invalid[3..9].iter().all(String::is_empty));
    let scenario = common::scenario_path("example1.toml");
    // A diverged run and a stable one.
    for r in [&rows[1], &rows[4]] {
        let sets = vec![
            "simulation.t_end=3".to_string(),
            format!("controller.ts={}", r[1]),
            format!("simulation.h={}", r[2]),
        ];
        assert_row_is_run(&h, r, &scenario, &sets);
    }
    assert_eq!(rows[1][3], "true");
    assert_eq!(rows[4][3], "false");
    assert!(out.join("map.png").exists());
    let meta: serde_json::Value =
        serde_json::from_str(&read(&out.join("campaign.json"))).expect("json");
    assert_eq!(meta["runs"], 6);
    assert!(meta["build"]["host_sim_version"].is_string());
    assert!(meta["build"]["git_commit"].is_string());
}

#[test]
fn sampled_array_entries_equal_runs_and_threads_do_not_change_bytes() {
    let file = campaign("monte-carlo.toml");
    let (one, two) = (tmp("campaign-mc-1"), tmp("campaign-mc-2"));
    sweep(&file, &one, &[], "1");
    sweep(&file, &two, &[], "2");
    for f in ["results.csv", "campaign.json"] {
        assert_eq!(read(&one.join(f)), read(&two.join(f)), "{f} differs");
    }
    let (h, rows) = table(&one);
    let col = |n: &str| h.iter().position(|x| x == n).expect(n);
    let (x, start) = (col("plant.x0[2][1]"), col("faults.rule[1].start"));
    let draws: BTreeSet<&str> = rows.iter().map(|r| &*r[x]).collect();
    assert_eq!(draws.len(), rows.len(), "a fresh draw per run");
    let scenario = common::scenario_path("example1.toml");
    for r in &rows[..2] {
        let sets = vec![
            "simulation.t_end=3".to_string(),
            "simulation.h=0.002".to_string(),
            format!(
                "plant.x0=[[0.02, 0.8], [{}, 1.0], [0.01, 0.09], [0.0, 0.7]]",
                r[x]
            ),
            // The indexed key through --set itself (the x0 above spells the whole array).
            format!("faults.rule[1].start={}", r[start]),
        ];
        assert_row_is_run(&h, r, &scenario, &sets);
    }
    assert!(one.join("montecarlo.png").exists());
}

#[test]
fn killed_campaign_resumes_without_running_twice() {
    let file = campaign("resume.toml");
    let reference = tmp("campaign-resume-ref");
    sweep(&file, &reference, &[], "2");
    let out = tmp("campaign-resume");
    let journal = out.join("runs.journal");
    let mut child = bin()
        .arg("sweep")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .env("RAYON_NUM_THREADS", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    let started = Instant::now();
    let lines = |p: &Path| std::fs::read_to_string(p).map_or(0, |t| t.lines().count());
    while lines(&journal) < 3 && started.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().expect("kill");
    let _ = child.wait();
    let done = lines(&journal);
    assert!(
        (3..24).contains(&done),
        "killed after {done} of 24 runs: the test needs a campaign cut short"
    );
    assert!(!out.join("results.csv").exists());
    // A row cut off mid-write (as by a kill during the write) is dropped and run again.
    let mut text = read(&journal);
    text.push_str("23,false,0.1");
    std::fs::write(&journal, text).expect("write");
    sweep(&file, &out, &[], "2");
    assert_eq!(
        read(&out.join("results.csv")),
        read(&reference.join("results.csv"))
    );
    let runs: Vec<String> = read(&journal)
        .lines()
        .map(|l| l.split(',').next().unwrap_or_default().to_string())
        .collect();
    let unique: BTreeSet<&String> = runs.iter().collect();
    assert_eq!(runs.len(), 24, "each run once in the journal: {runs:?}");
    // A grid with draws: the Monte Carlo figure and the map of per-point medians.
    assert!(out.join("montecarlo.png").exists() && out.join("map.png").exists());
    assert_eq!(unique.len(), 24);
}

#[test]
fn two_shards_merge_to_the_unsharded_bytes() {
    let file = campaign("grid.toml");
    let whole = tmp("campaign-shard-whole");
    sweep(&file, &whole, &[], "2");
    let (s1, s2) = (tmp("campaign-shard-1"), tmp("campaign-shard-2"));
    sweep(&file, &s1, &["--shard", "1/2"], "1");
    let merged = tmp("campaign-merged");
    let missing = bin()
        .arg("merge")
        .arg(&s1)
        .arg("--out")
        .arg(&merged)
        .output()
        .expect("merge");
    assert_invalid(&missing, "2/2");
    sweep(&file, &s2, &["--shard", "2/2"], "2");
    let (_, rows) = table(&s2);
    assert!(rows
        .iter()
        .all(|r| r[0].parse::<u64>().is_ok_and(|k| k % 2 == 1)));
    let o = bin()
        .arg("merge")
        .arg(&s2)
        .arg(&s1)
        .arg("--out")
        .arg(&merged)
        .output()
        .expect("merge");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["results.csv", "campaign.json"] {
        assert_eq!(read(&merged.join(f)), read(&whole.join(f)), "{f}");
    }
    assert!(merged.join("map.png").exists());
    let wrong = bin()
        .arg("sweep")
        .arg(&file)
        .arg("--out")
        .arg(&s1)
        .args(["--shard", "2/2", "--quiet"])
        .output()
        .expect("sweep");
    assert_invalid(&wrong, "--shard");
    let other = bin()
        .arg("sweep")
        .arg(campaign("monte-carlo.toml"))
        .arg("--out")
        .arg(&s1)
        .args(["--shard", "1/2", "--quiet"])
        .output()
        .expect("sweep");
    assert_invalid(&other, "--out");
}

#[test]
fn invalid_campaign_files_exit_2_naming_the_key() {
    let dir = tmp("campaign-invalid");
    let scenario = common::scenario_path("example1.toml");
    let cases = [
        (
            "[[axis]]\nkey = \"controller.tss\"\nvalues = [1.0]",
            "axis[1].key",
        ),
        (
            "[[axis]]\nkey = \"controller.ts\"\nvalues = []",
            "axis[1].values",
        ),
        (
            "[[axis]]\nkey = \"plant.x0[5][1]\"\nvalues = [1.0]",
            "axis[1].key",
        ),
        (
            "[[sample]]\nkey = \"controller.ts\"\ndist = \"uniform\"\nlow = 2.0\nhigh = 1.0",
            "sample[1].high",
        ),
        (
            "[[sample]]\nkey = \"controller.ts\"\ndist = \"gamma\"",
            "dist",
        ),
        ("draws = 0", "draws"),
        ("colour = 1", "colour"),
        ("[plot]\nmetric = \"speed\"", "plot.metric"),
        ("[plot]\nmetric = \"window.none\"", "plot.metric"),
        ("[output]\nruns = [5]", "output.runs"),
        ("set = [\"controller.zeta=2\"]", "controller.zeta"),
    ];
    for (i, (body, key)) in cases.iter().enumerate() {
        let f = dir.join(format!("c{i}.toml"));
        let text = format!("scenario = {:?}\n{body}\n", scenario.display().to_string());
        std::fs::write(&f, text).expect("write");
        let o = bin()
            .arg("sweep")
            .arg(&f)
            .arg("--out")
            .arg(dir.join(format!("out{i}")))
            .output()
            .expect("sweep");
        assert_invalid(&o, key);
    }
    let f = dir.join("missing-scenario.toml");
    std::fs::write(&f, "scenario = \"nowhere.toml\"\n").expect("write");
    let o = bin()
        .arg("sweep")
        .arg(&f)
        .arg("--out")
        .arg(dir.join("out-missing"))
        .output()
        .expect("sweep");
    assert_invalid(&o, "scenario");
    let o = bin()
        .args(["sweep", "x.toml", "--out", "o", "--shard", "3/2"])
        .output()
        .expect("sweep");
    assert_invalid(&o, "--shard");
}

#[test]
fn set_takes_one_based_array_entries() {
    let scenario = common::scenario_path("example1.toml");
    let o = bin()
        .arg("check")
        .arg(&scenario)
        .args([
            "--set",
            "plant.x0[2][1]=0.5",
            "--set",
            "faults.rule[2].start=1.5",
        ])
        .output()
        .expect("check");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("[0.5, 1.0]"), "{text}");
    assert!(text.contains("start = 1.5"), "{text}");
    let o = bin()
        .arg("check")
        .arg(&scenario)
        .args(["--set", "plant.x0[9][1]=0"])
        .output()
        .expect("check");
    assert_invalid(&o, "plant.x0[9][1]");
}

#[test]
fn one_axis_draws_a_line() {
    let out = tmp("campaign-line");
    sweep(&campaign("line.toml"), &out, &[], "2");
    let (h, rows) = table(&out);
    assert_eq!(h[1], "controller.ts");
    assert_eq!(rows.len(), 3);
    assert!(out.join("line.png").exists());
    assert!(!out.join("map.png").exists());
}

/// Window metrics become `window.<name>` columns equal to `summary.json`; with draws,
/// `summary.csv` holds per grid point the mean and 95 % Student-t half-width of each metric
/// over the valid draws (t_{0.975,3} = 3.182446 for four draws).
#[test]
fn window_columns_and_replication_means_with_student_t_intervals() {
    let dir = tmp("campaign-replications");
    let example =
        read(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios/example1.toml"));
    let scenario = dir.join("scenario.toml");
    std::fs::write(
        &scenario,
        format!(
            "{example}\n[metrics]\nsettle_dwell = 0.2\n\
             [[metrics.window]]\nname = \"early peak\"\nto = 0.5\nkind = \"max_error\"\n\
             [[metrics.window]]\nname = \"late iae\"\nfrom = 0.5\nkind = \"iae\"\n"
        ),
    )
    .expect("scenario");
    let file = dir.join("campaign.toml");
    std::fs::write(
        &file,
        "scenario = \"scenario.toml\"\nset = [\"simulation.t_end=1\"]\n\
         draws = 4\nseed = 5\n[plot]\nmetric = \"window.late iae\"\n[[axis]]\nkey = \"controller.ts\"\nvalues = [1.0, 2.0]\n\
         [[sample]]\nkey = \"faults.rule[1].start\"\ndist = \"uniform\"\nlow = 0.0\nhigh = 1.0\n",
    )
    .expect("campaign");
    let out = dir.join("out");
    sweep(&file, &out, &[], "2");
    let (h, rows) = table(&out);
    let col = |n: &str| h.iter().position(|x| x == n).expect(n);
    let (early, late) = (col("window.early peak"), col("window.late iae"));
    let run0 = tmp("campaign-replications-run0");
    let o = bin()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(&run0)
        .args(["--set", "simulation.t_end=1"])
        .args(["--set", "controller.ts=1", "--set"])
        .arg(format!(
            "faults.rule[1].start={}",
            rows[0][col("faults.rule[1].start")]
        ))
        .args(["--no-plots", "--quiet"])
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The cells as summary.json writes them (serde_json's parser can be one ulp off).
    let json = read(&run0.join("summary.json"));
    let values: Vec<&str> = json
        .split("\"value\": ")
        .skip(1)
        .filter_map(|v| v.split([',', '\n']).next())
        .collect();
    assert_eq!(values.len(), 2, "{json}");
    for (v, c) in values.iter().zip([early, late]) {
        assert_eq!(&rows[0][c], v, "{}", h[c]);
    }
    let mut r = csv::Reader::from_path(out.join("summary.csv")).expect("summary.csv");
    let sh: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    let points: Vec<csv::StringRecord> = r.records().map(|x| x.expect("row")).collect();
    assert_eq!(points.len(), 2, "one row per grid point");
    assert!(
        out.join("line.png").exists(),
        "the window metric over the axis"
    );
    let scol = |n: &str| sh.iter().position(|x| x == n).expect(n);
    for (p, rec) in points.iter().enumerate() {
        assert_eq!(&rec[scol("runs")], "4");
        let values: Vec<f64> = rows[p * 4..p * 4 + 4]
            .iter()
            .filter(|r| r[col("diverged")] == "false")
            .map(|r| r[late].parse().expect("late iae"))
            .collect();
        assert_eq!(values.len(), 4, "Example 1 does not diverge in 1 s");
        let mean = values.iter().sum::<f64>() / 4.0;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 3.0;
        let half = 3.182_446_305 * (var / 4.0).sqrt();
        let got = |k: &str| {
            rec[scol(&format!("window.late iae.{k}"))]
                .parse::<f64>()
                .expect(k)
        };
        assert!((got("mean") / mean - 1.0).abs() < 1e-12);
        assert!(
            (got("ci95") / half - 1.0).abs() < 1e-5,
            "{} vs {half}",
            got("ci95")
        );
        assert_eq!(&rec[scol("window.late iae.n")], "4");
    }
}

#[test]
fn three_axes_draw_one_map_per_value_of_the_first() {
    let out = tmp("campaign-three-axes");
    sweep(&campaign("three-axes.toml"), &out, &[], "2");
    let (h, rows) = table(&out);
    assert_eq!(
        h[1..4],
        ["clock.sync", "clock.drift_ppm", "clock.jitter_us"]
    );
    assert_eq!(rows.len(), 8);
    // The first axis is the slowest: runs 0-3 are sync none, 4-7 leader.
    assert!(rows[..4].iter().all(|r| r[1] == "none"), "{rows:?}");
    assert!(rows[4..].iter().all(|r| r[1] == "leader"), "{rows:?}");
    assert!(out.join("map-1.png").exists() && out.join("map-2.png").exists());
    assert!(!out.join("map-3.png").exists() && !out.join("map.png").exists());
}
