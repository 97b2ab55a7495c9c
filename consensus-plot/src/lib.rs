//! # consensus-plot
//!
//! The foundation the host crates share (`consensus-sim`, `consensus-hil`, `host-sim`): the
//! error vocabulary behind host-sim's exit statuses ([`error`], docs/SCENARIO.md §1), output
//! files written under a temporary name and renamed, removed on Ctrl-C ([`files`]), and the one
//! plotting toolkit every figure is drawn and written through ([`figure`]). It imports nothing
//! of the project (docs/ARCHITECTURE.md, "Crates and dependency rules").
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod figure;
pub mod files;

pub use error::{Error, Result};
