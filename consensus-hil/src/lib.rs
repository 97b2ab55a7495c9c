//! # consensus-hil
//!
//! host-sim's hardware in the loop, on top of the simulation library `consensus-sim`: the
//! `pil` kind (the node firmware on one emulated Cortex-M4F per agent, `network::pil`), the
//! `socketcan` kind (node processes on a Linux CAN interface, `network::socketcan`), host-sim
//! as CANopen NMT master (`network::canopen`), the agents of every bus kind
//! (`network::BusAgents`) and the live-bus decoding of `host-sim monitor` ([`monitor`]).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod monitor;
pub mod network;
