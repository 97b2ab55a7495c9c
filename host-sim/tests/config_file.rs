//! Firmware and host read the same file: every shipped scenario of `n = 2` gives the same
//! controller configuration through controller-core's `ControllerConfig` deserializer as through
//! host-sim's scenario parser.

mod common;

use controller_core::ControllerConfig;
use host_sim::scenario;

#[test]
fn every_shipped_scenario_loads_the_same_configuration_in_controller_core_and_host_sim() {
    let dir = common::scenario_path("example1.toml")
        .parent()
        .expect("scenarios/")
        .to_path_buf();
    let mut compared = 0;
    for entry in std::fs::read_dir(&dir).expect("scenarios/") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let setup = scenario::load(&path, &[]).expect("a shipped scenario is valid");
        if setup.n() != 2 {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("read");
        let mut file: ControllerConfig<2> =
            toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let host = setup.controller_config::<2>(0).expect("agent 1");
        // The topology comes from [graph]; the file's default is agent 1 of the examples.
        file.neighbour_count = host.neighbour_count;
        file.pinned = host.pinned;
        assert_eq!(file, host, "{}", path.display());
        compared += 1;
    }
    assert!(compared >= 10, "only {compared} scenarios compared");
}
