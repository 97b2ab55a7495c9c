//! # controller-core
//!
//! The predefined-time adaptive consensus controller of Lu, Zhu, Wang and Han (2024),
//! *Predefined-time adaptive consensus control for nonlinear multi-agent systems with input
//! quantization and actuator faults*, for one follower agent, as it runs on the agent's
//! microcontroller: `no_std`, no allocation, no `unsafe`, `f32`, fixed size.
//!
//! The law as implemented is described in the repository's `docs/LAW.md` (cited as "LAW §k");
//! where it departs from the paper's printed text is listed in `docs/DEVIATIONS.md`.
//!
//! ## Block diagram (one sample, LAW §6)
//!
//! ```text
//!  neighbours' y_k ─┐
//!  leader y_d ──────┼─► consensus ─► e_1 ─► backstepping steps j = 1..n ─► u ─► quantizer ─► q
//!  own state x ─────┘   (§2, (10))        β_j, α_j, e_{j+1} (15)–(19), (28)   (2), Lemma 3
//!                                           ▲      │ α_j               │ e_j, β_n
//!                          Levant differentiators ◄┘     adaptive laws μ̂, ξ̂, λ̂ ◄┘
//!                          χ_2 ≈ α̇_j (Lemma 5)           (20)–(22)
//! ```
//!
//! Each block is a type with its settings apart from its state: [`consensus::Consensus`],
//! [`backstepping::Backstepping`] with [`MtnRegressor`], [`powers::Powers`] and
//! [`smoothing::smooth`], [`LevantDifferentiator`], [`HysteresisQuantizer`],
//! [`adaptive::AdaptiveLaws`], the `ϖ(t)` schedule [`smoothing::VarpiSchedule`]. The proposed
//! predefined-time scheme and the prescribed-time baseline of LAW §10 differ only in
//! [`scheme::Scheme`]. [`Controller`] validates a [`ControllerConfig`] once and runs the steps.
//!
//! ## Bad input
//!
//! [`Controller::step`] never panics. A NaN or infinite own state, or an `f32` overflow inside the
//! law, holds the previous command and commits no state ([`StepFault`]); the controller resumes
//! as soon as valid inputs return. Stale, missing or invalid neighbour and leader values follow
//! the policy of [`consensus`].
//!
//! ## Safety (off by default)
//!
//! [`ControllerConfig::safety`] adds what the paper's law lacks for real actuators
//! ([`safety`]): magnitude and rate limits of the command before the quantizer, conditional
//! integration of the adaptive laws while a limit is active, rate-limited re-entry of neighbour
//! and leader values returning after an outage, and re-seeded differentiators after a held step.
//! `None` is the law as printed.
//!
//! ## Features
//!
//! * `libm` (default): accurate math. Configuration-time `powf`, `expf`, `logf` from `libm`;
//!   the per-step `x^ζ`, `√x`, `tanh` are this crate's own kernels ([`math`]), within a few ulp
//!   of f64, because `libm`'s `powf` and software `sqrtf` dominated the step on a Cortex-M4F.
//! * `micromath`: the `micromath` crate's `F32Ext` for the per-step functions (`math::micro`, with the feature:
//!   `e^(y ln x)` with the crate's degree-4 `ln` and `exp`, its bit-level `√`), and the accurate
//!   kernels at configuration time, so no `libm` is linked. Relative errors against f64 of
//!   8e-4 for `x^ζ` at `x ≥ 1` but up to 1.2 % (`ζ = 0.1`) below 1, where the crate's `ln` goes
//!   through an 8 % reciprocal; 6 % for `√`. The closed loop of both paper examples against
//!   the default build: `docs/REPRODUCTION.md`, "Math back-ends".
//! * `fast-math`: this crate's fast approximations for the per-step functions (`math::fast`, with the feature:
//!   relative errors of a few 1e-6, no division in the powers and the smoothing function), and
//!   the accurate kernels at configuration time, so no `libm` is linked.
//! * `safety` (default): [`ControllerConfig::safety`] can be set. Without it a configuration
//!   with safety is rejected (a [`ConfigError`] with [`Reason::NotBuilt`]) and neither the step nor the
//!   configuration links any of [`safety`]'s code: a firmware that never limits its command
//!   builds with `default-features = false, features = ["libm"]` (Example 1's step and
//!   configuration then fit 16 KiB of flash; `cargo xtask bench-gate` holds them to it).
//! * `defmt`: `defmt::Format` for the configuration, errors, state and outputs.
//! * `serde`: `Serialize`/`Deserialize` of [`ControllerConfig`] and its parts (`serde` without
//!   its default features): a node reads the same scenario file as `host-sim`
//!   ([`sections`]: `[simulation]` `h`, `[controller]`, `[quantizer]`, `[safety]`).
//! * `alloc`: `Vec` as the per-step values of [`ControllerSection`] (host tools).
//!
//! `micromath` and `fast-math` each take precedence over `libm` (on by default); enabling both
//! is a compile error.
//!
//! ## Parameters
//!
//! [`Param::spec`] is the one table of every parameter's scenario key, unit, default and range:
//! the defaults of [`ControllerConfig`] and of the scenario sections come from it, the
//! constructors check against it, and a [`ConfigError`] names the [`Param`] at fault.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

// The shared Example 1 test loop (`tests/common`) names the crate `controller_core`, also when a
// unit test includes it.
#[cfg(test)]
extern crate self as controller_core;

pub mod adaptive;
pub mod backstepping;
pub mod config;
#[cfg(test)]
mod config_tests;
pub mod consensus;
pub mod controller;
pub mod differentiator;
mod error;
pub mod gains;
pub mod math;
pub mod mtn;
pub mod param;
pub mod powers;
pub mod quantizer;
pub mod safety;
pub mod scheme;
pub mod sections;
pub mod smoothing;

pub use adaptive::Estimates;
pub use backstepping::Feedforward;
pub use config::{ControllerConfig, Params};
pub use consensus::{Link, LinkReport};
pub use controller::{Controller, State, StepFault, StepOutput, StepStatus};
pub use differentiator::LevantDifferentiator;
pub use error::ConfigError;
pub use gains::{GainSelection, Gains};
pub use mtn::MtnRegressor;
pub use param::{Param, Reason};
pub use quantizer::{HysteresisQuantizer, QuantizerConfig, QuantizerDirection};
pub use safety::SafetyConfig;
pub use scheme::{BaselineConfig, SchemeConfig};
#[cfg(feature = "serde")]
pub use sections::ConfigFile;
pub use sections::{
    Agent, ControllerSection, GainReading, QuantizerSection, SafetySection, SchemeName, Sections,
};

/// The crate README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
