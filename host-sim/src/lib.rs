//! # host-sim
//!
//! The closed-loop simulator around `controller-core`: plants (SPEC §1, §8), the graph (§2),
//! actuator faults (§7), neighbour links, metrics (§11), CSV and plots, driven by the scenario
//! files of `SCENARIO.md`. One `Controller` per agent, stepped at the sample period with its
//! outputs held between samples, exactly as firmware would run it; the plant is `f64`, the
//! controller `f32`.
//!
//! Layers: [`scenario`] (TOML, `--set`, validation) → [`graph`], [`plant`], [`faults`],
//! [`link`] or [`network`] → [`sim`] (the loop) → [`metrics`], [`report`] → [`run`] (commands).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod compare;
pub mod error;
pub mod faults;
pub mod graph;
pub mod link;
pub mod matrix;
pub mod metrics;
pub mod network;
pub mod plant;
pub mod report;
pub mod run;
pub mod scenario;
pub mod sim;

pub use error::{Error, Result};
