//! # agent-node
//!
//! The application every agent node runs, whatever carries it: the PIL firmware `node-fw`, a
//! board, a Linux process, or `hil-mock`'s mocked hardware on the host. `no_std`, no
//! allocation, no `unsafe`; it depends on `controller-core` only among the project's crates.
//!
//! ## Modules
//!
//! * [`node`]: [`Node`], one follower's firmware — sample, drain received frames, freshness,
//!   `controller_core::Controller::step`, actuate, broadcast — generic over the `embedded-can`
//!   controller and small [`Clock`], [`Sensor`], [`Actuator`] traits.
//! * [`supervisor`]: the node's states (`Boot`, `Operational`, `Safe`, `Fault`), when it enters
//!   and leaves its safe state and what it commands there.
//! * [`wire`]: the bus codec — the identifier plan, the `fixed` Q7.16 payload, sequence
//!   counters, the heartbeat, decoding that rejects malformed frames without panicking.
//! * [`link`]: the serial link between a node and the host that owns its plant: SLCAN lines,
//!   the tick and report records, process-I/O frames, configuration words; and [`CanFrame`],
//!   the classical CAN frame of the link, of `hil-mock`'s mocks and of its bus model.
//! * [`plant_bus`]: the sensor and command frames between a node and a host that simulates its
//!   plant on the same CAN bus (a Linux node process on SocketCAN).
//! * [`bus_load`]: worst-case bit lengths of classical and CAN FD frames and the share of a
//!   sample period the frame set of a scenario takes.
//! * [`canopen`]: the CiA 301 (CANopen) device of every node — NMT slave, heartbeat producer
//!   and consumer, EMCY, SDO server over an object dictionary generated from
//!   `controller_core::param` — and its CiA 306 EDS.
//! * [`dbc`]: every frame kind of the bus and the link described signal by signal, and
//!   `docs/wire.dbc` written from that description ([`dbc::write_dbc`]).
//!
//! The network behaviour, the wire format and the stale-link policy are described in
//! `docs/NETWORK.md`.
//!
//! ## Features
//!
//! * `log` (default): node log lines through the `log` crate (host).
//! * `canopen` (default): `Node::enable_canopen`, the node as a CiA 301 device. Without it (the
//!   firmware builds) the node has no device and its outputs are always on.
//! * `defmt`: node log lines through `defmt` (firmware); `defmt::Format` on the node's types.
//!   Mutually exclusive with `log`. Firmware build:
//!   `cargo build -p agent-node --target thumbv7em-none-eabihf --no-default-features --features defmt`.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

#[macro_use]
mod fmt;

pub mod bus_load;
pub mod canopen;
pub mod dbc;
pub mod link;
pub mod node;
mod own;
pub mod plant_bus;
pub mod supervisor;
pub mod wire;

pub use link::CanFrame;
pub use node::{Actuator, Clock, Node, NodeConfig, NodeError, NodeStats, Sensor, Tick, TxOutcome};
pub use supervisor::{NeighbourLoss, NodeState, SafePolicy, SupervisorConfig};
pub use wire::IdPlan;

/// The crate README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
