//! # node-linux
//!
//! One follower agent as a Linux process: `agent_node::Node` (the same application as the
//! firmware) over a SocketCAN interface, with the host that simulates the plants on the same
//! bus (`host-sim`, `[network] kind = "socketcan"`). The node hears the leader's and its
//! neighbours' value frames, reads its state from the host's sensor frames and sends its
//! commands and a heartbeat (`agent_node::plant_bus`). Configuration: [`config`]; the process
//! loop: [`run`].

pub mod config;
pub mod run;

pub use config::{ConfigError, NodeFile, NodeSection};
pub use run::{af_can_available, explain_open_error, on_wire, open, open_fd, Stop};
