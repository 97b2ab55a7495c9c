//! `clocks.png` / `.svg` of a clocked run: each follower's clock offset over time, as the
//! sampling-instant error `s_{i,k} − k h` of its samples.

use std::path::Path;

use crate::{
    clock::Clocks,
    error::Result,
    figure::{
        panel::{render, Panel, Series},
        FigureStyle,
    },
};

/// Followers drawn (the first ones).
const DRAWN: usize = 6;

/// Draws the figure of `clocks` into `dir` for scenario `name`.
pub fn draw(dir: &Path, clocks: &Clocks, name: &str) -> Result<()> {
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
            "{name}: sampling instant minus k h per follower (sync = \"{}\")",
            clocks.summary().sync.as_str()
        ),
        y_label: "sample instant − k h [ms]".into(),
        series,
        ..Panel::default()
    };
    render(dir, "clocks", &[panel], (1, 1), FigureStyle::px(1200, 500))
}
