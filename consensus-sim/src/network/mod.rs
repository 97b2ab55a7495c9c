//! `[network]`: the kinds the library runs itself and what every kind shares.
//!
//! * [`ideal`] (`kind = "ideal"`, the default): host-sim's own controllers (`sim::Linked`)
//!   hear each other through a [`ideal::LinkModel`]; [`ideal::IdealLink`] is the paper's
//!   instantaneous one.
//! * [`can`] (`kind = "can"`): every agent an `agent-node` node on `hil-mock`'s mocked
//!   hardware over its simulated CAN bus ([`can::CanAgents`]).
//! * [`spec`]: the `[network]` section, its checks, the bus settings and node settings it
//!   gives; [`node`]: the `[node]` section.
//! * [`trace`]: the candump logs of the bus (`--trace`) and of the serial links
//!   (`--link-trace`).
//!
//! The kinds with hardware in the loop (`pil`, `socketcan`) are `consensus-hil`'s.

pub mod can;
pub mod ideal;
pub mod node;
pub mod spec;
pub mod trace;
