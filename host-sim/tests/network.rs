//! `[network]`: Example 1 over the CAN bus (agent-node nodes on hil-mock's bus), bus load by hand, validation of the
//! section through the binary, determinism.

use std::{path::Path, process::Output};

use host_sim::{
    metrics::Summary,
    network::NetworkSummary,
    run::{run, RunOptions},
    scenario,
};

mod common;

use common::{assert_invalid, bin, scenario_path, tmp};

fn simulate(name: &str, sets: &[&str]) -> Summary {
    let sets: Vec<String> = sets.iter().map(|s| (*s).to_string()).collect();
    let setup = scenario::load(&scenario_path(name), &sets).expect("valid scenario");
    run(&setup, &RunOptions::default()).expect("run").summary
}

fn network(s: &Summary) -> &NetworkSummary {
    s.network.as_ref().expect("a CAN run reports its network")
}

/// Bits of one of the project's frames, by hand: standard header 19 + 4 data bytes 32 + CRC and
/// delimiter 16 = 67 stuffed bits, worst case ⌊67/4⌋ = 16 stuff bits, then ACK slot and
/// delimiter 2, EOF 7, intermission 3.
const FRAME_BITS: f64 = (19.0 + 32.0 + 16.0) + 16.0 + 2.0 + 7.0 + 3.0;

#[test]
fn example1_over_can_is_within_10_percent_of_the_ideal_link() {
    let ideal = simulate("example1.toml", &[]);
    let can = simulate("example1-can.toml", &[]);
    assert!(
        ideal.network.is_none(),
        "no network object for the ideal link"
    );
    let (ei, ec) = (
        ideal.max_error_after_predefined_time.expect("samples"),
        can.max_error_after_predefined_time.expect("samples"),
    );
    assert!(!can.diverged);
    assert!((ec - ei).abs() <= 0.10 * ei, "ideal {ei}, can {ec}");
    let n = network(&can);
    assert_eq!(n.kind, "can");
    assert_eq!(n.bitrate, 1_000_000);
    assert_eq!(
        (n.frames_lost, n.frames_corrupted, n.deadline_misses),
        (0, 0, 0)
    );
    // One frame of delay: every value used is exactly one sample old.
    assert!((n.max_age_s - 1e-3).abs() < 1e-9, "{}", n.max_age_s);
    assert!((n.mean_age_s - 1e-3).abs() < 1e-9, "{}", n.mean_age_s);
}

#[test]
fn bus_load_at_500_kbit_matches_the_hand_computation() {
    let s = simulate(
        "example1-can.toml",
        &["network.bitrate=500000", "simulation.t_end=2"],
    );
    let h = 1e-3;
    let frames_per_sample = 4.0 + 1.0; // four agents and the leader
    let by_hand = 100.0 * frames_per_sample * FRAME_BITS / 500_000.0 / h;
    assert_eq!(FRAME_BITS, 95.0);
    assert!((by_hand - 95.0).abs() < 1e-9);
    let n = network(&s);
    assert_eq!(n.bitrate, 500_000);
    assert!(
        (n.bus_load_percent - by_hand).abs() < 0.05,
        "reported {} %, by hand {by_hand} %",
        n.bus_load_percent
    );
    assert_eq!(n.deadline_misses, 0, "95 % still fits one sample");
    // 2000 samples, 5 senders; the frames submitted at the last sample are still on the bus.
    assert_eq!(n.frames_sent, 2000 * 5 - 5);
}

#[test]
fn lossy_run_stays_bounded_and_reports_losses_and_the_silent_agent() {
    let s = simulate("example1-lossy.toml", &[]);
    assert!(!s.diverged);
    let e = s.max_error_after_predefined_time.expect("samples");
    assert!(e < 1.0, "{e}");
    let n = network(&s);
    assert!(n.frames_lost > 0);
    let lost = n.frames_lost as f64 / n.frames_sent as f64;
    assert!((lost - 0.10).abs() < 0.02, "loss rate {lost}");
    assert_eq!(n.suppressed, 2000, "agent 3 silent for 2 s at h = 1 ms");
    assert!(n.stale_samples > 2000 && n.max_age_s > 1.9);
}

#[test]
fn a_babbling_node_starves_the_others_and_the_summary_shows_it() {
    let s = simulate(
        "example1-can.toml",
        &[
            "simulation.t_end=3",
            "network.event=[{agent = 2, kind = \"babbling\", from = 1.0, until = 1.2}]",
        ],
    );
    let n = network(&s);
    assert!(n.babble_frames > 0);
    assert!(
        n.deadline_misses >= 900,
        "200 samples x 5 senders starved: {}",
        n.deadline_misses
    );
    assert!(n.malformed > 0, "receivers count the babble as unknown ids");
    assert!(n.max_age_s > 0.19);
}

fn run_to(dir: &Path, name: &str) -> Output {
    bin()
        .args(["run"])
        .arg(scenario_path(name))
        .arg("--out")
        .arg(dir)
        .args(["--no-plots", "-q", "--set", "simulation.t_end=6"])
        .output()
        .expect("run the binary")
}

#[test]
fn a_can_run_is_deterministic() {
    let (a, b) = (tmp("net-det-a"), tmp("net-det-b"));
    for d in [&a, &b] {
        let out = run_to(d, "example1-lossy.toml");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    for f in ["summary.json", "trajectory.csv"] {
        let (x, y) = (
            std::fs::read(a.join(f)).expect("read"),
            std::fs::read(b.join(f)).expect("read"),
        );
        assert!(!x.is_empty());
        assert!(x == y, "{f} differs between two runs");
    }
    let json = std::fs::read_to_string(a.join("summary.json")).expect("read");
    assert!(json.contains("\"network\": {"), "{json}");
    assert!(json.contains("\"bus_load_percent\""));
}

fn check_network(case: usize, section: &str) -> Output {
    let d = tmp(&format!("net-bad-{case}"));
    let f = d.join("s.toml");
    std::fs::write(&f, format!("[network]\n{section}\n")).expect("write");
    bin().arg("check").arg(&f).output().expect("run the binary")
}

#[test]
fn malformed_network_keys_exit_2_naming_the_key() {
    for (case, (section, key)) in [
        ("kind = \"can\"\nloss = 1.5", "network.loss"),
        ("loss = -0.1", "network.loss"),
        ("kind = \"can\"\ncorruption = 1.0", "network.corruption"),
        ("kind = \"token-ring\"", "network.kind"),
        ("kind = \"can\"\nbitrate = 0", "network.bitrate"),
        ("bitrate = \"fast\"", "network.bitrate"),
        ("latency = -1e-3", "network.latency"),
        ("stale_timeout = 0.0", "network.stale_timeout"),
        ("seed = -1", "network.seed"),
        ("bitrat = 500000", "bitrat"),
        (
            "[[network.event]]\nagent = 9\nkind = \"silent\"\nfrom = 1.0\nuntil = 2.0",
            "network.event[1].agent",
        ),
        (
            "[[network.event]]\nagent = 3\nkind = \"silent\"\nfrom = 2.0\nuntil = 1.0",
            "network.event[1].until",
        ),
        (
            "[[network.event]]\nagent = 3\nkind = \"babbling\"\nid = 4096",
            "network.event[1].id",
        ),
        (
            "[[network.event]]\nagent = 3\nkind = \"sleepy\"",
            "network.event[1].kind",
        ),
        (
            "[[network.event]]\nagent = 3\nnode = 3\nkind = \"silent\"",
            "network.event[1]",
        ),
        (
            "[[network.event]]\nagent = 3\nkind = \"silent\"\nwhen = 1.0",
            "when",
        ),
    ]
    .iter()
    .enumerate()
    {
        assert_invalid(&check_network(case, section), key);
    }
}

#[test]
fn the_ideal_default_changes_nothing() {
    let out = bin()
        .arg("check")
        .arg(scenario_path("example1.toml"))
        .output()
        .expect("run the binary");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("[network]"), "{text}");
    let out = bin()
        .arg("check")
        .arg(scenario_path("example1-lossy.toml"))
        .output()
        .expect("run the binary");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("[network]") && text.contains("[[network.event]]"),
        "{text}"
    );
}

mod never_panics {
    use host_sim::{run::simulate, scenario, Error};
    use proptest::prelude::*;

    const ODD: &[&str] = &[
        "0",
        "-1",
        "1",
        "1e-9",
        "1.0",
        "2",
        "1e300",
        "nan",
        "inf",
        "-inf",
        "4096",
        "4294967296",
        "\"x\"",
        "[]",
    ];

    /// Mostly a value from `valid`, sometimes an odd one.
    fn mostly<S: Strategy + 'static>(valid: S) -> BoxedStrategy<String>
    where
        S::Value: ToString,
    {
        prop_oneof![
            4 => valid.prop_map(|v| v.to_string()),
            1 => prop::sample::select(ODD).prop_map(str::to_string),
        ]
        .boxed()
    }

    fn event() -> impl Strategy<Value = String> {
        (
            prop::sample::select(&["agent", "node"][..]),
            mostly(0i64..=4),
            prop::sample::select(
                &[
                    "\"silent\"",
                    "\"silent\"",
                    "\"babbling\"",
                    "\"babbling\"",
                    "\"x\"",
                ][..],
            ),
            prop::option::of(mostly(0i64..=2047)),
            mostly(0.0f64..0.05),
            prop::option::of(mostly(0.0f64..0.1)),
        )
            .prop_map(|(who, w, kind, id, from, until)| {
                let mut s = format!("{{{who} = {w}, kind = {kind}, from = {from}");
                if let Some(id) = id {
                    s.push_str(&format!(", id = {id}"));
                }
                if let Some(u) = until {
                    s.push_str(&format!(", until = {u}"));
                }
                s.push('}');
                s
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// Any `[network]` gives a scenario that runs, or an `Error::Invalid`; never a panic.
        #[test]
        fn any_network_section_is_rejected_or_runs(
            kind in prop::sample::select(&["\"ideal\"", "\"can\"", "\"can\"", "\"can\"", "\"x\""][..]),
            bitrate in mostly(20_000i64..=2_000_000),
            latency in mostly(0.0f64..0.005),
            loss in mostly(0.0f64..0.6),
            corruption in mostly(0.0f64..0.6),
            stale in mostly(1e-4f64..0.01),
            seed in mostly(0i64..1000),
            events in prop::collection::vec(event(), 0..3),
        ) {
            let sets = vec![
                "simulation.t_end=0.05".to_string(),
                format!("network.kind={kind}"),
                format!("network.bitrate={bitrate}"),
                format!("network.latency={latency}"),
                format!("network.loss={loss}"),
                format!("network.corruption={corruption}"),
                format!("network.stale_timeout={stale}"),
                format!("network.seed={seed}"),
                format!("network.event=[{}]", events.join(", ")),
            ];
            match scenario::parse("", &sets) {
                Ok(setup) => {
                    let s = simulate(&setup);
                    prop_assert!(s.is_ok(), "{:?}", s.err());
                }
                Err(Error::Invalid(_)) => {}
                Err(e) => prop_assert!(false, "unexpected error kind: {e}"),
            }
        }
    }
}
