//! Every error type of agent-node is a `core::error::Error` whose `Display` says something.

use agent_node::canopen::od::{ParamStore, StoreError};
use agent_node::canopen::{eds::reference_device, Abort};
use agent_node::link::{decode_config, slcan_decode, CanFrame, ConfigReject, SlcanError};
use agent_node::supervisor::{Supervisor, SupervisorError};
use agent_node::wire::{decode, IdPlan, IdPlanError, WireError};
use agent_node::{NodeConfig, NodeError, SafePolicy, SupervisorConfig};
use controller_core::{ConfigError, ControllerConfig, Param, Reason};
use embedded_can::{Frame, StandardId};

/// Compiles only for a `core::error::Error`; returns its message, which must not be empty.
fn message<E: core::error::Error>(e: &E) -> String {
    let m = e.to_string();
    assert!(!m.is_empty(), "{e:?} has an empty message");
    m
}

#[test]
fn supervisor_and_node_errors() {
    let cfg = SupervisorConfig {
        policy: SafePolicy::Stop { decel: 0.0 },
        ..SupervisorConfig::OFF
    };
    let e = Supervisor::new(&cfg).expect_err("a stop deceleration of 0");
    assert_eq!(e, SupervisorError::StopDecel);
    assert!(message(&e).contains("deceleration"));

    let node = [
        NodeError::AgentZero,
        NodeError::BadNeighbour(3),
        NodeError::Supervisor(e),
        NodeError::Config(ConfigError::new(Param::Ts, Reason::NonPositive)),
    ];
    for n in &node {
        message(n);
    }
    // The inner error's words are part of the node error's message.
    assert!(message(&node[2]).contains(&e.to_string()));
    assert!(message(&node[3]).contains("`ts` must be > 0"));
}

#[test]
fn wire_and_link_errors() {
    let e = IdPlan::new(0x100, Some(0x100), 4).expect_err("overlapping blocks");
    assert_eq!(e, IdPlanError::Overlap);
    assert!(message(&e).contains("overlap"));

    let f = CanFrame::new(StandardId::new(0x600).expect("11-bit"), &[0; 4]).expect("4 bytes");
    let e = decode(&f).expect_err("not an identifier of the plan");
    assert_eq!(e, WireError::UnknownId(0x600));
    assert!(message(&e).contains("0x600"));

    let e = slcan_decode(b"?").expect_err("no SLCAN command");
    assert_eq!(e, SlcanError::UnknownCommand);
    message(&e);

    let e = decode_config::<2, 0>(&[1, 2, 3]).expect_err("three words");
    assert_eq!(e, ConfigReject::WordCount);
    message(&e);
    for r in [
        ConfigReject::BadTag,
        ConfigReject::Node,
        ConfigReject::Unexpected,
    ] {
        message(&r);
    }
}

#[test]
fn canopen_errors() {
    let mut dev = reference_device().expect("the reference device");
    let e = dev.write(0x1018, 1, &[0; 4]).expect_err("read-only"); // the identity is read-only
    assert_eq!(e, Abort::ReadOnly);
    assert_eq!(
        message(&e),
        "SDO abort 0x06010002: attempt to write a read-only object"
    );

    let r = ParamStore::new(
        NodeConfig::new(128, [], 1_000).identity(),
        &ControllerConfig::<2>::default(),
    );
    let e = r.expect_err("node-ID 128");
    assert_eq!(e, StoreError::Unrepresentable);
    assert!(message(&e).contains("1..=127"));

    // As a trait object, as `?` into `Box<dyn Error>` uses it.
    let boxed: Box<dyn core::error::Error> = Box::new(Abort::NoObject);
    assert!(boxed.to_string().contains("0x06020000"));
}
