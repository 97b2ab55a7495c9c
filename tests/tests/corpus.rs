//! The malformed-input corpus (`tests/corpus`): every scenario file through the built `host-sim`
//! binary (`check` and a short `run`), every frame through `agent_node::wire::decode_in` (the default identifier plan) and a node.
//!
//! Scenario files state their expectation on the first line, `# expect: <text>`: the one-line
//! message on stderr must contain that text (the key at fault). Optional `# run-set: k=v` lines
//! replace the default `--set simulation.t_end=0.01` of the `run` (`# run-set: none`: no
//! override, for cases about `t_end` itself). Frame files are described in
//! `tests/corpus/frames/README.md`.

use std::{path::Path, process::Output};

use agent_node::{
    wire::{self, DecodeStats, Decoded, IdPlan, WireError},
    NodeConfig, NodeStats,
};
use controller_core::ControllerConfig;
use embedded_can::{ExtendedId, Frame, Id, StandardId};
use hil_mock::mock::{MockActuator, MockCan, MockClock, MockFrame, MockNode, MockSensor};
use integration_tests::{corpus_dir, host_sim_bin, scratch};

fn files(dir: &Path, ext: &str) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    v.sort();
    v
}

/// The directives of a scenario file: expected text and the `--set`s of the run.
fn directives(path: &Path) -> (String, Vec<String>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = String::from_utf8_lossy(&bytes);
    let mut lines = text.lines();
    let expect = lines
        .next()
        .and_then(|l| l.strip_prefix("# expect:"))
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| panic!("{}: first line must be `# expect: <key>`", path.display()));
    let mut sets = Vec::new();
    let mut explicit = false;
    for l in text.lines().take_while(|l| l.starts_with('#')) {
        if let Some(s) = l.strip_prefix("# run-set:") {
            explicit = true;
            if s.trim() != "none" {
                sets.push(s.trim().to_string());
            }
        }
    }
    if !explicit {
        sets.push("simulation.t_end=0.01".into());
    }
    (expect, sets)
}

/// Exit 2, exactly one line on stderr containing `expect`, no panic, no backtrace.
fn check_rejection(what: &str, out: &Output, expect: &str) -> Result<(), String> {
    let err = String::from_utf8_lossy(&out.stderr);
    let mut problems = Vec::new();
    if out.status.code() != Some(2) {
        problems.push(format!("exit status {:?}, expected 2", out.status.code()));
    }
    if err.trim_end().lines().count() != 1 {
        problems.push("stderr is not exactly one line".into());
    }
    if !err.contains(expect) {
        problems.push(format!("message does not name `{expect}`"));
    }
    for bad in ["panicked", "backtrace", "RUST_BACKTRACE"] {
        if err.contains(bad) {
            problems.push(format!("stderr mentions `{bad}`"));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{what}: {}; stderr: {}",
            problems.join(", "),
            err.trim_end()
        ))
    }
}

#[test]
fn every_malformed_scenario_exits_2_with_one_line_naming_the_key() {
    let bin = host_sim_bin();
    let dir = corpus_dir().join("scenarios");
    let cases = files(&dir, "toml");
    assert!(cases.len() >= 40, "corpus too small: {}", cases.len());
    let mut failures = Vec::new();
    for path in &cases {
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("case")
            .to_string();
        let (expect, sets) = directives(path);
        let check = std::process::Command::new(&bin)
            .arg("check")
            .arg(path)
            .env("RUST_BACKTRACE", "1")
            .output()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", bin.display()));
        if let Err(e) = check_rejection(&format!("{name} (check)"), &check, &expect) {
            failures.push(e);
        }
        let out = scratch(&format!("corpus-{name}"));
        let mut run = std::process::Command::new(&bin);
        run.arg("run")
            .arg(path)
            .arg("--out")
            .arg(&out)
            .args(["--quiet", "--no-plots"])
            .env("RUST_BACKTRACE", "1");
        for s in &sets {
            run.args(["--set", s]);
        }
        let r = run
            .output()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", bin.display()));
        if let Err(e) = check_rejection(&format!("{name} (run)"), &r, &expect) {
            failures.push(e);
        }
        // Nothing written, not even a temporary file.
        let left: Vec<_> = std::fs::read_dir(&out)
            .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name()).collect())
            .unwrap_or_default();
        if !left.is_empty() {
            failures.push(format!("{name} (run): left files behind: {left:?}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} corpus cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// One line of a frame file.
struct FrameCase {
    line: usize,
    frame: MockFrame,
    expect: String,
}

fn hex_bytes(s: &str) -> Option<Vec<u8>> {
    if s == "-" {
        return Some(Vec::new());
    }
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}

fn parse_frames(path: &Path) -> Vec<FrameCase> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = format!("{}:{}", path.display(), n + 1);
        let field = |k: &str| -> &str {
            line.split_whitespace()
                .find_map(|f| f.strip_prefix(k).and_then(|v| v.strip_prefix('=')))
                .unwrap_or_else(|| panic!("{at}: missing `{k}=`"))
        };
        let id = u32::from_str_radix(field("id").trim_start_matches("0x"), 16)
            .unwrap_or_else(|e| panic!("{at}: id: {e}"));
        let flag = |k: &str| match field(k) {
            "0" => false,
            "1" => true,
            v => panic!("{at}: {k} must be 0 or 1, got {v}"),
        };
        let (ext, rtr) = (flag("ext"), flag("rtr"));
        let dlc: usize = field("dlc")
            .parse()
            .unwrap_or_else(|e| panic!("{at}: dlc: {e}"));
        let data = hex_bytes(field("data")).unwrap_or_else(|| panic!("{at}: data: bad hex"));
        let id: Id = if ext {
            Id::Extended(ExtendedId::new(id).unwrap_or_else(|| panic!("{at}: id > 29 bits")))
        } else {
            let raw = u16::try_from(id).ok().and_then(StandardId::new);
            Id::Standard(raw.unwrap_or_else(|| panic!("{at}: id > 11 bits")))
        };
        let frame = if rtr {
            assert!(data.is_empty(), "{at}: a remote frame carries no data");
            MockFrame::new_remote(id, dlc)
        } else {
            assert_eq!(
                dlc,
                data.len(),
                "{at}: dlc must equal the number of data bytes"
            );
            MockFrame::new(id, &data)
        }
        .unwrap_or_else(|| panic!("{at}: not a classical CAN frame (dlc <= 8)"));
        out.push(FrameCase {
            line: n + 1,
            frame,
            expect: field("expect").to_string(),
        });
    }
    out
}

fn decode_kind(e: WireError) -> &'static str {
    match e {
        WireError::ExtendedId => "extended_id",
        WireError::Remote => "remote",
        WireError::UnknownId(_) => "unknown_id",
        WireError::WrongLength(_) => "wrong_length",
        WireError::BadPayload => "bad_payload",
        // `WireError` is `#[non_exhaustive]`: a new rejection needs its corpus name here.
        _ => "unnamed",
    }
}

fn malformed(d: &DecodeStats, kind: &str) -> Option<u32> {
    Some(match kind {
        "extended_id" => d.extended_id,
        "remote" => d.remote,
        "unknown_id" => d.unknown_id,
        "wrong_length" => d.wrong_length,
        "bad_payload" => d.bad_payload,
        _ => return None,
    })
}

fn counter(s: &NodeStats, kind: &str) -> u32 {
    malformed(&s.malformed, kind).unwrap_or_else(|| match kind {
        "accepted" => s.accepted,
        "saturated" => s.saturated_rx,
        "no_value" => s.no_value,
        "ignored" => s.ignored,
        "own_id" => s.own_id,
        "repeated" => s.repeated,
        "out_of_order" => s.out_of_order,
        "heartbeat" => s.heartbeats_rx,
        k => panic!("unknown expected kind `{k}`"),
    })
}

/// Agent 4 of Example 1: hears 1 and 3, pinned here so that leader frames are taken too.
fn agent4() -> MockNode<2, 2, 4> {
    let cfg = ControllerConfig::<2> {
        neighbour_count: 2,
        pinned: true,
        ..Default::default()
    };
    let r = MockNode::new(
        &NodeConfig::new(4, [1, 3, 0, 0], 2_500),
        &cfg,
        MockCan::new(64),
        MockClock::default(),
        MockSensor::default(),
        MockActuator::default(),
    );
    r.unwrap_or_else(|e| panic!("agent 4: {e:?}"))
}

#[test]
fn every_malformed_frame_is_rejected_and_counted_by_kind() {
    let dir = corpus_dir().join("frames");
    let paths = files(&dir, "frames");
    assert!(
        paths.len() >= 2,
        "frame corpus missing in {}",
        dir.display()
    );
    let mut total = 0;
    for path in &paths {
        let mut node = agent4();
        for (k, c) in parse_frames(path).iter().enumerate() {
            let at = format!("{}:{}", path.display(), c.line);
            let decoded = wire::decode_in(&IdPlan::DEFAULT, &c.frame);
            match (decoded, malformed(&DecodeStats::default(), &c.expect)) {
                (Err(e), Some(_)) => assert_eq!(decode_kind(e), c.expect, "{at}"),
                (Err(e), None) => panic!("{at}: rejected as {e:?}, expected {}", c.expect),
                (Ok(m), Some(_)) => panic!("{at}: decoded as {m:?}, expected {}", c.expect),
                (Ok(Decoded::Value(m)), None) => {
                    assert!(m
                        .y
                        .is_none_or(|y| y.is_finite() && (-128.0..128.0).contains(&y)))
                }
                (Ok(Decoded::Heartbeat { .. }), None) => assert_eq!(c.expect, "heartbeat", "{at}"),
            }
            let before = *node.stats();
            node.clock_mut().set(500 * (k as u64 + 1));
            assert!(node.can_mut().push_rx(c.frame), "{at}: receive FIFO full");
            node.poll_rx();
            let after = *node.stats();
            assert_eq!(after.frames_rx, before.frames_rx + 1, "{at}");
            assert_eq!(
                counter(&after, &c.expect),
                counter(&before, &c.expect) + 1,
                "{at}: `{}` not counted",
                c.expect
            );
            let is_malformed = malformed(&after.malformed, &c.expect).is_some();
            assert_eq!(
                after.malformed.total() - before.malformed.total(),
                u32::from(is_malformed),
                "{at}: malformed total"
            );
            if is_malformed {
                assert_eq!(
                    after.accepted, before.accepted,
                    "{at}: a malformed frame was used"
                );
            }
            // A tick after each frame: the controller gets finite commands out.
            let tick = node.tick();
            assert!(tick.output.q.iter().all(|q| q.is_finite()), "{at}");
            total += 1;
        }
    }
    assert!(total >= 30, "frame corpus too small: {total}");
}
