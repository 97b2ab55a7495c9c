//! What a new user runs into: one exit-code rule (bad input 2, I/O 1, interrupted 130), option
//! messages, the size limit of `trajectory.csv`, temporary files on Ctrl-C, `compare.md`
//! tables, time formatting, negative option values, empty scenario files, a closed stdout.

mod common;

use std::{
    path::Path,
    process::Output,
    time::{Duration, Instant},
};

use common::{assert_invalid, bin, scenario_path, tmp};
use host_sim::{
    report::csv::{check_size, decimate_to_fit, estimated_size, SIZE_LIMIT},
    scenario,
};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn host_sim(args: &[&str]) -> Output {
    bin().args(args).output().expect("host-sim")
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

#[test]
fn a_missing_file_and_a_directory_are_both_bad_input() {
    let dir = tmp("edges-exit");
    let missing = dir.join("missing.toml");
    let out = host_sim(&["check", path(&missing)]);
    assert_invalid(&out, "missing.toml");
    assert!(
        stderr(&out).contains("invalid scenario"),
        "{}",
        stderr(&out)
    );
    // A directory is bad input like a missing file, not an I/O error.
    let out = host_sim(&["check", path(&dir)]);
    assert_invalid(&out, "is a directory");
    // I/O errors (exit 1): cli.rs, unwritable_output_is_an_io_error.
}

#[test]
fn option_errors_say_invalid_option() {
    let e1 = scenario_path("example1.toml");
    let out_dir = tmp("edges-options");
    let cases: [(&[&str], &str); 4] = [
        (
            &["run", path(&e1), "--out", path(&out_dir), "--decimate", "0"],
            "--decimate",
        ),
        (&["stable-h", path(&e1), "--band", "-1"], "--band"),
        (&["stable-h", path(&e1), "--h-min", "-1e-3"], "--h-min"),
        (&["check", path(&e1), "--set", "controller.ts"], "--set"),
    ];
    for (args, option) in cases {
        let out = host_sim(args);
        assert_invalid(&out, option);
        assert!(
            stderr(&out).starts_with("host-sim: invalid option: "),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    // A negative value where an unsigned count is expected is clap's error, also exit 2.
    let out = host_sim(&[
        "run",
        path(&e1),
        "--out",
        path(&out_dir),
        "--decimate",
        "-3",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("-3"), "{}", stderr(&out));
}

#[test]
fn a_huge_trajectory_is_refused_with_the_decimation_that_fits() {
    let e1 = scenario_path("example1.toml");
    let dir = tmp("edges-huge");
    let start = Instant::now();
    let out = host_sim(&[
        "run",
        path(&e1),
        "--out",
        path(&dir),
        "--set",
        "simulation.t_end=1e7",
        "--no-plots",
    ]);
    assert_invalid(&out, "--decimate");
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "must refuse before running"
    );
    let setup = scenario::load(&e1, &["simulation.t_end=1e7".into()]).expect("scenario");
    let fit = decimate_to_fit(&setup, SIZE_LIMIT);
    assert!(
        stderr(&out).contains(&format!("--decimate {fit} ")),
        "{}",
        stderr(&out)
    );
    assert!(check_size(&setup, fit).is_ok());
    assert!(
        check_size(&setup, fit - 1).is_err(),
        "the smallest one that fits"
    );
    assert!(!dir.join("trajectory.csv").exists() && !dir.join(".trajectory.tmp.csv").exists());
}

#[test]
fn the_size_estimate_is_within_10_percent() {
    for (name, t_end) in [("example1.toml", "0.5"), ("example2.toml", "0.1")] {
        let dir = tmp(&format!("edges-size-{name}"));
        let e = scenario_path(name);
        let set = format!("simulation.t_end={t_end}");
        for decimate in ["1", "7"] {
            let out = host_sim(&[
                "run",
                path(&e),
                "--out",
                path(&dir),
                "--set",
                &set,
                "--decimate",
                decimate,
                "--no-plots",
                "--quiet",
            ]);
            assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
            let actual = std::fs::metadata(dir.join("trajectory.csv"))
                .expect("csv")
                .len() as f64;
            let setup = scenario::load(&e, std::slice::from_ref(&set)).expect("scenario");
            let estimate = estimated_size(&setup, decimate.parse().expect("k")) as f64;
            assert!(
                (estimate / actual - 1.0).abs() < 0.1,
                "{name} / {decimate}: estimate {estimate}, actual {actual}"
            );
        }
    }
}

#[cfg(unix)]
#[test]
fn ctrl_c_and_sigterm_remove_the_temporary_trajectory() {
    let e1 = scenario_path("example1.toml");
    for signal in ["INT", "TERM"] {
        let dir = tmp(&format!("edges-signal-{signal}"));
        let mut child = bin()
            .args(["run", path(&e1), "--out", path(&dir)])
            .args([
                "--set",
                "simulation.t_end=1e7",
                "--no-plots",
                "--quiet",
                "--force",
            ])
            .spawn()
            .expect("host-sim");
        let tmp_csv = dir.join(".trajectory.tmp.csv");
        let start = Instant::now();
        while !tmp_csv.exists() && start.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(tmp_csv.exists(), "--force must start the run");
        std::thread::sleep(Duration::from_millis(300));
        // The shell's built-in kill: no procps needed on a bare CI machine.
        let kill = std::process::Command::new("sh")
            .args(["-c", &format!("kill -{signal} {}", child.id())])
            .status()
            .expect("sh");
        assert!(kill.success());
        let status = child.wait().expect("wait");
        assert_eq!(status.code(), Some(130), "SIG{signal}");
        assert!(!tmp_csv.exists(), "SIG{signal}: temporary file left behind");
        assert!(!dir.join("trajectory.csv").exists());
    }
}

#[test]
fn compare_md_is_a_valid_table_with_consistent_times() {
    let dir = tmp("edges-compare");
    let out = host_sim(&[
        "compare",
        path(&scenario_path("example2.toml")),
        path(&scenario_path("example2-baseline.toml")),
        "--out",
        path(&dir),
        "--set",
        "simulation.t_end=0.3",
        "--set",
        "simulation.h=2e-3",
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let md = std::fs::read_to_string(dir.join("compare.md")).expect("compare.md");
    let rows: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
    assert_eq!(rows.len(), 17, "{md}");
    for row in &rows {
        let bars = row
            .match_indices('|')
            .filter(|(i, _)| !row[..*i].ends_with('\\'))
            .count();
        assert_eq!(bars, 4, "three cells per row: {row}");
    }
    assert!(md.contains("max \\|u\\|"), "{md}");
    // h = 2 ms diverges: the divergence times are printed like every other time.
    assert_times_formatted(&md);
}

/// Every `t = <number>` has four decimals and a unit.
fn assert_times_formatted(text: &str) {
    let mut seen = 0;
    for (i, _) in text.match_indices("t = ") {
        let rest = &text[i + 4..];
        let num: String = rest
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect();
        let decimals = num.split_once('.').map_or(0, |(_, d)| d.len());
        assert_eq!(decimals, 4, "time {num:?} in {text}");
        assert!(
            rest[num.len()..].starts_with(" s"),
            "unit after {num}: {text}"
        );
        seen += 1;
    }
    assert!(seen > 0, "no time printed: {text}");
}

#[test]
fn stable_h_prints_times_alike() {
    let out = host_sim(&[
        "stable-h",
        path(&scenario_path("example2.toml")),
        "--set",
        "simulation.t_end=0.3",
        "--h-min",
        "1e-4",
        "--h-max",
        "3e-3",
        "--rel-tol",
        "0.5",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("diverged at"), "{text}");
    assert_times_formatted(&text);
}

#[test]
fn an_empty_scenario_file_runs_the_defaults_with_a_note() {
    let dir = tmp("edges-empty");
    for (name, text) in [("empty.toml", ""), ("comments.toml", "# nothing here\n\n")] {
        let f = dir.join(name);
        std::fs::write(&f, text).expect("write");
        let out = host_sim(&["check", path(&f)]);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let err = stderr(&out);
        assert!(
            err.starts_with("host-sim: note: ") && err.contains("sets no keys"),
            "{err}"
        );
        assert!(String::from_utf8_lossy(&out.stdout).contains("name = \"scenario\""));
    }
    let out = host_sim(&["check", path(&scenario_path("example1.toml"))]);
    assert!(
        stderr(&out).is_empty(),
        "no note for a real scenario: {}",
        stderr(&out)
    );
}

/// `host-sim check … | head -1`: standard output closed before the first line is written. The
/// echo is dropped, the command still finishes normally, and nothing panics (a `println!` on a
/// closed pipe used to abort with "failed printing to stdout: Broken pipe", found by the
/// campaign work).
#[test]
fn a_closed_standard_output_is_not_a_panic() {
    use std::process::Stdio;
    for (scenario, sets) in [
        ("example1.toml", vec![]),
        ("example2.toml", vec!["--set", "simulation.h=2e-4"]),
    ] {
        let args = (scenario, &sets);
        let mut cmd = bin();
        cmd.arg("check")
            .arg(scenario_path(scenario))
            .args(&sets)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().expect("host-sim starts");
        drop(child.stdout.take()); // the reader goes away at once, as `head` does when done
        let out = child.wait_with_output().expect("host-sim ends");
        let err = stderr(&out);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
    }
}
