//! # hil-mock
//!
//! The agent node firmware application of the project, and the host-side hardware it runs
//! against in tests.
//!
//! ## Layers
//!
//! * [`node`] (`no_std`, no allocation): [`node::Node`], one follower's firmware — sample,
//!   drain received frames, freshness, `controller_core::Controller::step`, actuate,
//!   broadcast — generic over the `embedded-can` controller and small [`node::Clock`],
//!   [`node::Sensor`], [`node::Actuator`] traits. Builds for `thumbv7em-none-eabihf`.
//! * [`wire`] (`no_std`): the frame codec — identifiers, the `fixed` Q7.16 payload, sequence
//!   counters, decoding that rejects malformed frames without panicking.
//! * `mock` (feature `std`): in-memory CAN controller, clock, sensors and actuators.
//! * `bus` (feature `std`): the CAN-like bus simulator — bit timing with worst-case stuffing,
//!   arbitration, latency, seeded loss and corruption, silent and babbling nodes, error
//!   counters and bus-off.
//! * `network` (feature `std`): `network::CanNetwork`, nodes on mocked hardware, a leader and
//!   the bus, stepped one sample at a time by a host loop that owns the plant.
//!
//! The network behaviour, the wire format and the stale-link policy are described in
//! `docs/NETWORK.md`.
//!
//! ## Features
//!
//! * `std` (default): the `mock` and `bus` modules.
//! * `log` (default): node log lines through the `log` crate (host).
//! * `defmt`: node log lines through `defmt` (firmware); `defmt::Format` on the node's types.
//!   Mutually exclusive with `log`. Firmware build:
//!   `cargo build -p hil-mock --target thumbv7em-none-eabihf --no-default-features --features defmt`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[macro_use]
mod fmt;

#[cfg(feature = "std")]
pub mod bus;
#[cfg(feature = "std")]
pub mod mock;
#[cfg(feature = "std")]
pub mod network;
pub mod node;
pub mod pil;
pub mod wire;

pub use node::{Actuator, Clock, Node, NodeConfig, NodeError, NodeStats, Sensor, Tick, TxOutcome};
