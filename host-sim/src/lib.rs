//! # host-sim
//!
//! The closed-loop simulator around `controller-core`: plants (`docs/LAW.md` §1, §8), graph (§2),
//! actuator faults (§7), neighbour links, metrics (§11), CSV and plots, driven by the scenario
//! files of `docs/SCENARIO.md`. One `Controller` per agent, stepped at the sample period with its
//! outputs held between samples, exactly as firmware would run it; the plant is `f64`, the
//! controller `f32`.
//!
//! Layers: [`scenario`] (TOML, `--set`, validation) → [`graph`], [`leader`], [`plant`],
//! [`faults`], [`clock`], [`network`] (every kind: `ideal`, `can`, `pil`, `socketcan`, and the bus `trace`) → [`sim`]
//! (the loop) → [`metrics`], [`report`] → [`run`], [`monitor`] (commands) → [`campaign`] (many runs: grids,
//! Monte Carlo, shards). Every figure is drawn and written through [`figure`]. Each block owns
//! the serde type and checks of its scenario section; [`scenario`] assembles them and no block
//! imports it (docs/ARCHITECTURE.md, "host-sim modules").
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod agent;
pub mod campaign;
pub mod clock;
pub mod compare;
pub mod error;
pub mod faults;
pub mod figure;
pub mod figures;
pub mod front;
pub mod generate;
pub mod graph;
pub mod leader;
pub mod matrix;
pub mod metrics;
pub mod monitor;
pub mod network;
pub mod plant;
pub mod report;
pub mod run;
pub mod scenario;
pub mod sim;

pub use error::{Error, Result};
