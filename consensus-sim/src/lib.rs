//! # consensus-sim
//!
//! The closed-loop simulation library around `controller-core`: plants (`docs/LAW.md` §1, §8),
//! graph (§2), actuator faults (§7), clocks, neighbour links, metrics (§11), driven by the
//! scenario files of `docs/SCENARIO.md`. One `Controller` per agent, stepped at the sample
//! period with its outputs held between samples, exactly as firmware would run it; the plant is
//! `f64`, the controller `f32`.
//!
//! Layers: [`scenario`] (TOML, `--set`, validation) → [`graph`], [`leader`], [`plant`],
//! [`faults`], [`clock`], [`network`] (the `ideal` and `can` kinds, the `[network]` and `[node]`
//! sections, the bus `trace`) → [`sim`] (the loop) → [`metrics`], [`agent`]. Each block owns the
//! serde type and checks of its scenario section; [`scenario`] assembles them and no block
//! imports it (docs/ARCHITECTURE.md, "host-sim modules"). The kinds with hardware in the loop
//! are in `consensus-hil`; commands, outputs and figures in `host-sim`.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod agent;
pub mod clock;
pub mod faults;
pub mod figures;
pub mod generate;
pub mod graph;
pub mod leader;
pub mod metrics;
pub mod network;
pub mod plant;
pub mod scenario;
pub mod sim;

pub use consensus_plot::error::{Error, Result};
