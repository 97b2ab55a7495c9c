//! Logging macros that expand to `defmt` (firmware), `log` (host) or nothing.
//!
//! The pattern of embassy's `fmt.rs` (packaged as `defmt-or-log`): the node code calls the
//! crate-local `trace!`, `debug!`, `info!`, `warn!` and `error!` with a literal format string
//! whose placeholders are `{}` or `{:?}` (both understood by `defmt` and by `core::fmt`), so the
//! same line builds for the target and the host. Arguments must implement `defmt::Format` with
//! the `defmt` feature, and `Display`/`Debug` with `log`. Without either feature the arguments
//! are evaluated by reference and dropped, so no unused-variable warnings appear.
#![allow(unused_macros)]

#[cfg(all(feature = "defmt", feature = "log"))]
compile_error!("agent-node: the `defmt` and `log` features are mutually exclusive; enable one");

macro_rules! log_impl {
    ($level:ident, $s:literal $(, $x:expr)* $(,)?) => {{
        #[cfg(feature = "defmt")]
        ::defmt::$level!($s $(, $x)*);
        #[cfg(feature = "log")]
        ::log::$level!($s $(, $x)*);
        #[cfg(not(any(feature = "defmt", feature = "log")))]
        {
            let _ = ($(&$x),*);
        }
    }};
}

macro_rules! trace {
    ($($t:tt)*) => { log_impl!(trace, $($t)*) };
}

macro_rules! debug {
    ($($t:tt)*) => { log_impl!(debug, $($t)*) };
}

macro_rules! info {
    ($($t:tt)*) => { log_impl!(info, $($t)*) };
}

macro_rules! warn {
    ($($t:tt)*) => { log_impl!(warn, $($t)*) };
}

macro_rules! error {
    ($($t:tt)*) => { log_impl!(error, $($t)*) };
}
