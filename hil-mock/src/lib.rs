//! # hil-mock
//!
//! The host-side hardware an [`agent_node::Node`] runs against in simulations and tests: mocked
//! peripherals and a CAN-like bus simulator (`std`).
//!
//! ## Modules
//!
//! * [`mock`]: in-memory CAN controller, clock, sensors and actuators.
//! * [`bus`]: the CAN-like bus simulator — bit timing with worst-case stuffing, arbitration,
//!   latency, seeded loss and corruption, silent and babbling nodes, error counters and
//!   bus-off.
//! * [`host`]: [`host::BusHost`], the host's side of the bus shared by every kind of follower:
//!   delivery to the receivers, the links' sample times and ages, the leader's frame.
//! * [`network`]: [`network::CanNetwork`], nodes on mocked hardware, a leader and the bus,
//!   stepped one sample at a time by a host loop that owns the plant.
//!
//! The node application itself (the `Node`, the wire codec, the serial link protocol) is the
//! `no_std` crate `agent-node`. The network behaviour, the wire format and the stale-link
//! policy are described in `docs/NETWORK.md`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bus;
pub mod host;
pub mod mock;
pub mod network;
