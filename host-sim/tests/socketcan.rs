//! `kind = "socketcan"` where no CAN interface is needed: its errors and keys. The runs on a
//! bus are in `.ci/socketcan-vm-checks.sh`, inside the test VM (`.ci/socketcan.sh`).

mod common;

use common::{assert_invalid, bin, scenario_path, tmp};

#[test]
fn a_missing_can_interface_is_exit_2_naming_network_interface_and_what_to_do() {
    let out = bin()
        .arg("run")
        .arg(scenario_path("example1-socketcan.toml"))
        .arg("--out")
        .arg(tmp("socketcan-no-interface"))
        .args(["--set", "network.interface=\"nosuchcan9\""])
        .output()
        .expect("host-sim runs");
    assert_invalid(&out, "network.interface");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("AF_CAN") || err.contains("ip link add dev nosuchcan9 type vcan"),
        "the message says what to do: {err}"
    );
}

#[test]
fn socketcan_keys_with_another_kind_are_exit_2_naming_the_key() {
    let out = bin()
        .arg("check")
        .arg(scenario_path("example1-can.toml"))
        .args(["--set", "network.nodes=\"external\""])
        .output()
        .expect("host-sim runs");
    assert_invalid(&out, "network.nodes");
}

#[test]
fn simulated_bus_faults_on_a_real_bus_are_exit_2() {
    let out = bin()
        .arg("check")
        .arg(scenario_path("example1-socketcan.toml"))
        .args(["--set", "network.loss=0.1"])
        .output()
        .expect("host-sim runs");
    assert_invalid(&out, "network.kind");
}

#[test]
fn node_interfaces_need_one_entry_per_agent() {
    let out = bin()
        .arg("check")
        .arg(scenario_path("example1-socketcan.toml"))
        .args(["--set", "network.node_interfaces=[\"can1\"]"])
        .output()
        .expect("host-sim runs");
    assert_invalid(&out, "network.node_interfaces");
}

#[test]
fn monitor_without_the_interface_fails_with_a_message_not_a_panic() {
    let out = bin()
        .args(["monitor", "nosuchcan9", "--once", "--duration", "0.1"])
        .output()
        .expect("host-sim runs");
    let err = String::from_utf8_lossy(&out.stderr);
    // Bad input, as a missing network.interface is for `run`.
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("invalid option: <interface>: ")
            && err.contains("nosuchcan9")
            && !err.contains("panicked"),
        "{err}"
    );
}
