//! # host-sim
//!
//! The command-line crate of the simulator: the commands of `docs/SCENARIO.md` ([`run`],
//! [`compare`], [`matrix`], [`front`]), campaigns ([`campaign`]: grids, Monte Carlo, shards) and
//! the outputs of a run ([`report`]: `trajectory.csv`, Parquet, the figures). The simulation
//! itself is `consensus-sim`, the kinds with hardware in the loop `consensus-hil`, errors, output
//! files and the figure toolkit `consensus-plot` (docs/ARCHITECTURE.md, "Crates and dependency
//! rules").
//!
//! The modules of those crates are re-exported here under the names they had when they were
//! all host-sim's (`host_sim::scenario`, `host_sim::network`, ...), so the integration tests,
//! the examples and the benchmarks reach them as before. host-sim's own modules import them
//! from their crates, never through these re-exports.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod campaign;
pub mod compare;
pub mod front;
pub mod matrix;
pub mod report;
pub mod run;

pub use consensus_hil::{monitor, network};
pub use consensus_plot::{error, figure};
pub use consensus_sim::{
    agent, clock, faults, figures, generate, graph, leader, metrics, plant, scenario, sim,
};

pub use error::{Error, Result};
