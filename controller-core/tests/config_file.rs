//! With the `serde` feature a scenario file's `[simulation]` `h`, `[controller]`, `[quantizer]`
//! and `[safety]` load into a `ControllerConfig` (docs/SCENARIO.md; its other tables ignored).
#![cfg(feature = "serde")]

use controller_core::{
    Controller, ControllerConfig, GainSelection, Param, QuantizerConfig, SafetyConfig, SchemeConfig,
};

fn shipped(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenarios")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn load(text: &str) -> Result<ControllerConfig<2>, toml::de::Error> {
    toml::from_str(text)
}

#[test]
fn a_shipped_scenario_with_safety_loads_into_the_configuration() {
    let cfg = load(&shipped("example1-deploy.toml")).expect("example1-deploy.toml loads");
    assert_eq!(cfg.h, 1e-3);
    assert_eq!((cfg.ts, cfg.zeta, cfg.a_check), (2.0, 0.1, [90.0, 90.0]));
    assert_eq!(cfg.gains, GainSelection::Auto);
    assert_eq!(cfg.quantizer, Some(QuantizerConfig::default()));
    let safety = cfg.safety.expect("[safety] enabled = true");
    assert_eq!(safety.u_max, Some(40.0));
    // Agent 1 of the examples unless an [agent] table says otherwise.
    assert_eq!((cfg.neighbour_count, cfg.pinned), (0, true));
    assert!(Controller::<2, 2, 4>::new(&cfg).is_ok());
}

#[test]
fn the_baseline_scenario_loads_explicit_gains_and_the_prescribed_time_scheme() {
    let cfg = load(&shipped("example2-baseline.toml")).expect("example2-baseline.toml loads");
    assert_eq!(cfg.h, 2e-4);
    assert_eq!(cfg.gains, GainSelection::Explicit { c1: 10.0, c2: 9.0 });
    assert!(matches!(cfg.scheme, SchemeConfig::PrescribedTime(_)));
    assert_eq!(cfg.safety, None);
    assert!(Controller::<2, 2, 4>::new(&cfg).is_ok());
}

#[test]
fn an_empty_file_is_the_default_configuration_and_a_written_one_reads_back() {
    assert_eq!(load("").expect("empty"), ControllerConfig::default());
    let cfg = ControllerConfig::<2> {
        neighbour_count: 2,
        quantizer: None,
        safety: Some(SafetyConfig {
            du_max: Some(100.0),
            ..SafetyConfig::default()
        }),
        ..ControllerConfig::default()
    };
    let text = toml::to_string(&cfg).expect("writes");
    assert!(
        text.contains("[agent]") && text.contains("neighbour_count = 2"),
        "{text}"
    );
    assert_eq!(load(&text).expect("reads back"), cfg);
}

#[test]
fn a_bad_layout_is_an_error_naming_the_key() {
    let err = |text: &str| load(text).expect_err(text).to_string();
    assert!(err("[controller]\nc1 = 10.0\n").contains("`c2`"));
    assert!(err("[controller]\na_check = [1.0]\n").contains("`a_check` must have 2 entries"));
    assert!(err("[controller]\nkappa = 2.0\n").contains("prescribed-time"));
    assert!(err("[controller]\nts_typo = 2.0\n").contains("ts_typo"));
    assert!(err("[quantizer]\ndirection = \"up\"\n").contains("up"));
    // Values are checked by the constructor, as for every other configuration.
    let cfg = load("[controller]\nzeta = 1.5\n").expect("layout is fine");
    let e = Controller::<2, 2, 4>::new(&cfg).expect_err("zeta outside (0, 1)");
    assert_eq!(e.param(), Param::Zeta);
}
