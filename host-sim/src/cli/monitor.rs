//! `host-sim monitor`: a live table of a CAN bus running the product.

use std::path::PathBuf;

use clap::Args;
use consensus_hil::monitor::{monitor, MonitorOptions};
use consensus_plot::error::Result;

/// Options of `monitor`.
#[derive(Args, Debug)]
pub struct MonitorArgs {
    /// CAN interface (e.g. vcan0, can0).
    interface: String,
    /// DBC file decoding the frames the product's codec does not know (docs/wire.dbc).
    #[arg(long)]
    dbc: Option<PathBuf>,
    /// Print one table after --duration (default 1 s) and stop.
    #[arg(long)]
    once: bool,
    /// Stop after this many seconds.
    #[arg(long)]
    duration: Option<f64>,
    /// Seconds between two tables of the live view.
    #[arg(long, default_value_t = 0.5)]
    refresh: f64,
}

/// Runs the monitor on standard output.
pub fn execute(a: MonitorArgs) -> Result<()> {
    let opts = MonitorOptions {
        interface: a.interface,
        dbc: a.dbc,
        once: a.once,
        duration: a.duration,
        refresh: a.refresh,
    };
    monitor(&opts, &mut std::io::stdout()).map(|_| ())
}
