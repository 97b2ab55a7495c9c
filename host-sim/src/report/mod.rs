//! Outputs of a run: the trajectory's columns and writers, the figures of a run, tables in
//! memory; the output files themselves (temporary names, atomic writes, interrupts) are
//! `consensus-plot`'s `files`, re-exported here under the path they had before the split.

pub mod clocks;
pub mod csv;
pub mod graph;
pub mod parquet;
pub mod plots;
pub mod spread;
pub mod table;

pub use consensus_plot::files::*;
