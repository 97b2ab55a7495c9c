//! The spread of a large group (more than [`MAX_PLOTTED_AGENTS`] followers): percentiles across
//! agents of the tracking error `yᵢ − y_d` and of the commands `u`, and the worst agents by name,
//! where one line per agent would be unreadable (docs/SCENARIO.md §3.3, `spread`).

use std::path::Path;

use plotters::style::{Color, RGBAColor, BLACK};

use super::plots::{MAX_PLOTTED_AGENTS, TARGET_POINTS};
use consensus_plot::{
    error::Result,
    figure::{
        panel::{color, render, Panel, Series},
        text::secs,
        FigureStyle,
    },
};
use consensus_sim::{
    scenario::Setup,
    sim::{Observer, SampleView},
};

/// How many of the worst agents a figure names.
pub const NAMED: usize = 3;

/// Percentiles kept per sample: 10th, 50th (median), 90th.
const PERCENTILES: [f64; 3] = [0.10, 0.50, 0.90];

/// Spread across agents, every `stride`-th sample: minimum and maximum over the samples since
/// the last kept one (a spike between kept samples is not lost), percentiles at the kept sample.
#[derive(Debug, Clone, Default)]
pub struct Spread {
    stride: u64,
    two_ts: f64,
    /// Kept `t_k`.
    pub t: Vec<f64>,
    /// Per kept sample: min, 10th percentile, median, 90th percentile, max of `yᵢ − y_d`.
    pub err: Vec<[f64; 5]>,
    /// Likewise of `u_{i,l}` over agents and actuators.
    pub u: Vec<[f64; 5]>,
    /// Per agent: `max |yᵢ − y_d|` at `t_k ≥ 2 Tₛ`.
    pub worst_err: Vec<f64>,
    /// Per agent: `max_l |u_{i,l}|` over the run.
    pub worst_u: Vec<f64>,
    window: [[f64; 2]; 2],
    scratch: Vec<f64>,
}

/// `window`'s min, the [`PERCENTILES`] of `v` and `window`'s max (`v` is reordered; NaN
/// counts as largest). Order statistics by selection, not a full sort: this runs at every kept
/// sample over every agent.
fn quantiles(v: &mut [f64], window: [f64; 2]) -> [f64; 5] {
    if v.is_empty() {
        return [window[0], f64::NAN, f64::NAN, f64::NAN, window[1]];
    }
    let at = |p: f64| ((v.len() - 1) as f64 * p).round() as usize;
    let (lo, mid, hi) = (at(PERCENTILES[0]), at(PERCENTILES[1]), at(PERCENTILES[2]));
    let (below, &mut median, above) = v.select_nth_unstable_by(mid, f64::total_cmp);
    let p_lo = if lo < mid {
        *below.select_nth_unstable_by(lo, f64::total_cmp).1
    } else {
        median
    };
    let p_hi = if hi > mid {
        *above.select_nth_unstable_by(hi - mid - 1, f64::total_cmp).1
    } else {
        median
    };
    [window[0], p_lo, median, p_hi, window[1]]
}

const EMPTY: [f64; 2] = [f64::INFINITY, f64::NEG_INFINITY];

impl Spread {
    /// For a run of `setup`.
    pub fn new(setup: &Setup) -> Self {
        Self {
            stride: (setup.samples / TARGET_POINTS).max(1),
            two_ts: setup.predefined_time(),
            worst_err: vec![0.0; setup.agents()],
            worst_u: vec![0.0; setup.agents()],
            window: [EMPTY; 2],
            ..Self::default()
        }
    }

    /// The `NAMED` worst agents of `per_agent` (1-based, with their value), worst first.
    pub fn worst(per_agent: &[f64]) -> Vec<(usize, f64)> {
        let mut v: Vec<(usize, f64)> = per_agent
            .iter()
            .enumerate()
            .map(|(i, &e)| (i + 1, e))
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        v.truncate(NAMED);
        v
    }

    fn named(per_agent: &[f64]) -> String {
        Self::worst(per_agent)
            .iter()
            .map(|(i, v)| format!("{i} ({v:.3})"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn series(&self, data: &[[f64; 5]], what: &str) -> Vec<Series> {
        let pts = |k: usize| self.t.iter().zip(data).map(|(&t, q)| (t, q[k])).collect();
        let grey = |a: f64| -> RGBAColor { BLACK.mix(a) };
        vec![
            Series::plain(format!("min / max of {what}"), grey(0.35), 1, pts(0)),
            Series::plain(String::new(), grey(0.35), 1, pts(4)),
            Series::plain("10th / 90th percentile".into(), color(0), 2, pts(1)),
            Series::plain(String::new(), color(0), 2, pts(3)),
            Series::plain("median".into(), color(3), 3, pts(2)),
        ]
    }

    /// Writes `spread.png` and `spread.svg` into `dir`.
    pub fn draw(&self, dir: &Path, setup: &Setup) -> Result<()> {
        let name = &setup.figure_title();
        let band = setup.scenario.simulation.settle_band;
        let (y_unit, u_unit) = setup.plant.units();
        let vline = (self.two_ts, format!("2Tₛ = {}", secs(self.two_ts)));
        let agents = self.worst_err.len();
        let errors = Panel {
            title: format!(
                "{name}: yᵢ − y_d across {agents} agents; worst after 2Tₛ (max |yᵢ − y_d|): {}",
                Self::named(&self.worst_err)
            ),
            y_label: format!("yᵢ − y_d [{y_unit}]"),
            series: self.series(&self.err, "yᵢ − y_d"),
            vlines: vec![vline.clone()],
            band: Some((band, format!("±b = ±{band}"))),
            ..Panel::default()
        };
        let inputs = Panel {
            title: format!(
                "commands u over all agents and actuators; largest (max |u|): {}",
                Self::named(&self.worst_u)
            ),
            y_label: format!("u [{u_unit}]"),
            series: self.series(&self.u, "u"),
            vlines: vec![vline],
            clip_spikes: true,
            ..Panel::default()
        };
        render(
            dir,
            "spread",
            &[errors, inputs],
            (2, 1),
            FigureStyle::px(1200, 800).with(setup.figures()),
        )
    }
}

impl<const N: usize, const M: usize> Observer<N, M> for Spread {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        let after = s.t >= self.two_ts;
        let [we, wu] = &mut self.window;
        for (i, (x, o)) in s.x.iter().zip(s.out).enumerate() {
            let e = x[0] - s.yd;
            *we = [we[0].min(e), we[1].max(e)];
            if after {
                self.worst_err[i] = self.worst_err[i].max(e.abs());
            }
            for &u in &o.u {
                let u = f64::from(u);
                *wu = [wu[0].min(u), wu[1].max(u)];
                self.worst_u[i] = self.worst_u[i].max(u.abs());
            }
        }
        if !s.k.is_multiple_of(self.stride) {
            return Ok(());
        }
        self.t.push(s.t);
        self.scratch.clear();
        self.scratch.extend(s.x.iter().map(|x| x[0] - s.yd));
        self.err.push(quantiles(&mut self.scratch, self.window[0]));
        self.scratch.clear();
        self.scratch
            .extend(s.out.iter().flat_map(|o| o.u.iter().map(|&u| f64::from(u))));
        self.u.push(quantiles(&mut self.scratch, self.window[1]));
        self.window = [EMPTY; 2];
        Ok(())
    }
}

/// Whether a group is large enough for the spread figure.
pub fn wanted(agents: usize) -> bool {
    agents > MAX_PLOTTED_AGENTS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_known_sample() {
        let mut v: Vec<f64> = (0..=100).rev().map(f64::from).collect();
        let q = quantiles(&mut v, [-1.0, 200.0]);
        assert_eq!(q, [-1.0, 10.0, 50.0, 90.0, 200.0]);
        for n in [1, 2, 3, 7, 1000] {
            let mut v: Vec<f64> = (0..n).map(|i| f64::from((i * 7919) % n)).collect();
            let mut sorted = v.clone();
            sorted.sort_unstable_by(f64::total_cmp);
            let at = |p: f64| sorted[((n - 1) as f64 * p).round() as usize];
            let q = quantiles(&mut v, [0.0, 0.0]);
            assert_eq!(q[1..4], [at(0.1), at(0.5), at(0.9)], "n = {n}");
        }
    }

    #[test]
    fn the_worst_agents_are_named_worst_first() {
        let w = Spread::worst(&[0.1, 0.5, 0.2, 0.5, 0.0]);
        assert_eq!(w, vec![(2, 0.5), (4, 0.5), (3, 0.2)]);
    }
}
