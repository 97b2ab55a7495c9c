//! `clocks.png` / `.svg` of a clocked run: each follower's clock offset over time, as the
//! sampling-instant error `s_{i,k} − k h` of its samples.

use std::path::Path;

use consensus_plot::{
    error::Result,
    figure::{
        panel::{render, Panel, Series},
        FigureStyle, Output,
    },
};
use consensus_sim::clock::{Clocks, SyncMode};

/// Followers drawn (the first ones).
const DRAWN: usize = 6;

/// Draws the figure of `clocks` into `dir` under the title `name`, in the formats of `output`.
pub fn draw(dir: &Path, clocks: &Clocks, name: &str, output: Output) -> Result<()> {
    let series = clocks
        .series()
        .iter()
        .take(DRAWN)
        .enumerate()
        .map(|(i, s)| {
            let points = s.iter().map(|&(t, e)| (t, e * 1e3)).collect();
            Series::styled(format!("agent {}", i + 1), i, points)
        })
        .collect();
    let panel = Panel {
        title: format!(
            "{name}: sampling instant minus k h per follower ({})",
            match clocks.summary().sync {
                SyncMode::None => "free-running clocks",
                SyncMode::Leader => "clocks synchronised to the leader's",
            }
        ),
        y_label: "sample instant − k h [ms]".into(),
        series,
        ..Panel::default()
    };
    render(
        dir,
        "clocks",
        &[panel],
        (1, 1),
        FigureStyle::px(1200, 500).with(output),
    )
}
