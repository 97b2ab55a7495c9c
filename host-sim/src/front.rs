//! The settling-time vs control-energy front of each scheme: every gain setting of a scheme
//! is one point (settling time into one band, total control energy `Σ_i Σ_l Σ_k u_{i,l}² h`),
//! and its Pareto front joins the points no other point of the same scheme beats on both.
//! Drawn by `host-sim/tests/front.rs` into `docs/figures/example2-front.png`.

use std::path::Path;

use plotters::{coord::Shift, prelude::*};
use serde::Serialize;

use consensus_plot::{
    error::Result,
    figure::{
        self,
        chart::{axes, cartesian, free_corner, legend, Frame},
        drawing_error,
        panel::color,
        text::{short, sup},
        DrawResult, Figure, FigureStyle, Format,
    },
};

/// One gain setting of a scheme.
#[derive(Debug, Clone, Serialize)]
pub struct FrontPoint {
    /// The gains in words, e.g. `Tₛ = 0.5` or `c₁ = 5, c₂ = 4.5`.
    pub gains: String,
    /// Settling time into the band \[s\]; `None` when the run never settles (or diverged).
    pub settling_time: Option<f64>,
    /// Total control energy; `None` when the run diverged.
    pub energy: Option<f64>,
}

impl FrontPoint {
    /// `(settling time, energy)` of a run that settled.
    fn settled(&self) -> Option<(f64, f64)> {
        self.settling_time.zip(self.energy)
    }
}

/// One scheme's points, named in words.
#[derive(Debug, Clone, Serialize)]
pub struct FrontScheme {
    /// The scheme's name, e.g. `predefined-time (proposed)`.
    pub name: String,
    /// What was swept, e.g. `Tₛ from 0.38 to 1 s`.
    pub swept: String,
    /// Its points.
    pub points: Vec<FrontPoint>,
}

/// The points of `points` that settled and that no other settled point beats on both settling
/// time and energy (ties kept once), by increasing settling time.
pub fn pareto(points: &[FrontPoint]) -> Vec<(f64, f64)> {
    let mut settled: Vec<(f64, f64)> = points.iter().filter_map(FrontPoint::settled).collect();
    settled.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in settled {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

/// Words of the figure.
#[derive(Debug, Clone, Copy)]
pub struct FrontText<'a> {
    /// Title, e.g. `Example 2: settling time against control energy`.
    pub title: &'a str,
    /// Band `b` and its unit.
    pub band: (f64, &'a str),
    /// Unit of the control energy, e.g. `N²·m²·s`.
    pub energy_unit: &'a str,
}

/// Settling time (x) against control energy (y, log scale), each scheme's points and Pareto
/// front, the runs that never settle drawn at the right edge, into `path`.
pub fn draw_front(path: &Path, schemes: &[FrontScheme], text: FrontText<'_>) -> Result<()> {
    figure::save(path, &FigureStyle::px(1100, 700), &Front { schemes, text })
}

struct Front<'a> {
    schemes: &'a [FrontScheme],
    text: FrontText<'a>,
}

impl Figure for Front<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        _: Format,
    ) -> DrawResult {
        let all = || self.schemes.iter().flat_map(|s| &s.points);
        let t_hi = all().filter_map(|p| p.settling_time).fold(1.0, f64::max) * 1.15;
        let (e_lo, e_hi) = all()
            .filter_map(|p| p.energy)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), e| {
                (lo.min(e), hi.max(e))
            });
        let (e_lo, e_hi) = if e_lo.is_finite() && e_hi > 0.0 {
            (e_lo / 2.0, e_hi * 2.0)
        } else {
            (1.0, 10.0)
        };
        // The never-settled runs stand at the right edge, beyond the settled ones.
        let never_x = t_hi / 1.15 * 1.08;
        let (band, unit) = self.text.band;
        let ticks: Vec<f64> = (-2..=12)
            .flat_map(|k| [1.0, 3.0].map(|m| m * 10f64.powi(k)))
            .filter(|v| (e_lo..=e_hi).contains(v))
            .collect();
        let frame = Frame {
            caption: 18,
            margin: 10,
            x_labels: 45,
            y_labels: 80,
        };
        let caption = format!("{} (band b = {} {unit})", self.text.title, short(band));
        let mut c = cartesian(
            root,
            style,
            &caption,
            frame,
            (0.0..t_hi, (e_lo..e_hi).log_scale().with_key_points(ticks)),
        )
        .map_err(drawing_error)?;
        let x_label = format!("settling time into the band b = {} {unit} [s]", short(band));
        let y_label = format!("control energy [{}] (log scale)", self.text.energy_unit);
        axes(&mut c, style, (&x_label, &y_label), (14, 15))
            .x_label_formatter(&|v| format!("{v:.1}"))
            .y_label_formatter(&|v| power_of_ten(*v))
            .draw()
            .map_err(drawing_error)?;
        let mut drawn: Vec<(f64, f64)> = Vec::new();
        for (k, s) in self.schemes.iter().enumerate() {
            let col = color(k);
            let settled: Vec<(f64, f64)> =
                s.points.iter().filter_map(FrontPoint::settled).collect();
            let front = pareto(&s.points);
            drawn.extend(settled.iter().map(|&(t, e)| (t, e.log10())));
            c.draw_series(
                settled
                    .iter()
                    .map(|&p| Circle::new(p, 4, col.stroke_width(2))),
            )
            .map_err(drawing_error)?
            .label(format!(
                "{}: one run per gain setting ({})",
                s.name, s.swept
            ))
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, col.stroke_width(2)));
            c.draw_series(LineSeries::new(front.clone(), col.stroke_width(3)))
                .map_err(drawing_error)?
                .label(format!("{}: Pareto front", s.name))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], col.stroke_width(3)));
            c.draw_series(front.iter().map(|&p| Circle::new(p, 4, col.filled())))
                .map_err(drawing_error)?;
            // Runs that never settle stand at the right edge at their energy; diverged runs
            // (no energy) at the bottom right.
            let edge = |p: &FrontPoint| (never_x, p.energy.unwrap_or(e_lo * 1.3));
            let never: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| p.settling_time.is_none() && p.energy.is_some())
                .map(edge)
                .collect();
            let diverged: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| p.energy.is_none())
                .map(edge)
                .collect();
            for (pts, what) in [(never, "never settles in the band"), (diverged, "diverged")] {
                if pts.is_empty() {
                    continue;
                }
                drawn.extend(pts.iter().map(|&(t, e)| (t, e.log10())));
                let size = if what == "diverged" { 8 } else { 6 };
                c.draw_series(
                    pts.iter()
                        .map(|&p| Cross::new(p, size, col.stroke_width(2))),
                )
                .map_err(drawing_error)?
                .label(format!(
                    "{}: {what} ({} {}, drawn at the right edge)",
                    s.name,
                    pts.len(),
                    if pts.len() == 1 { "run" } else { "runs" }
                ))
                .legend(move |(x, y)| Cross::new((x + 9, y), size - 1, col.stroke_width(2)));
            }
        }
        let corner = free_corner(drawn, 0.0..t_hi, e_lo.log10()..e_hi.log10());
        legend(&mut c, style, corner, 13).map_err(drawing_error)
    }
}

/// `10⁶`, `3·10⁵`: a tick of the log energy axis.
fn power_of_ten(v: f64) -> String {
    if v <= 0.0 || !v.is_finite() {
        return short(v);
    }
    let k = v.log10().floor();
    let m = (v / 10f64.powf(k)).round();
    let k = k as i32;
    if m == 1.0 {
        format!("10{}", sup(k))
    } else {
        format!("{m}·10{}", sup(k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(t: Option<f64>, e: f64) -> FrontPoint {
        FrontPoint {
            gains: String::new(),
            settling_time: t,
            energy: Some(e),
        }
    }

    #[test]
    fn the_front_keeps_only_points_nothing_beats_on_both() {
        let pts = [
            p(Some(1.0), 10.0),
            p(Some(2.0), 5.0),
            p(Some(2.5), 6.0), // beaten by (2, 5)
            p(Some(3.0), 1.0),
            p(None, 0.1), // never settles: not on the front
            p(Some(1.0), 12.0),
        ];
        assert_eq!(pareto(&pts), vec![(1.0, 10.0), (2.0, 5.0), (3.0, 1.0)]);
        assert!(pareto(&[]).is_empty());
    }

    #[test]
    fn energy_ticks_read_as_powers_of_ten() {
        assert_eq!(power_of_ten(1e6), "10⁶");
        assert_eq!(power_of_ten(3e4), "3·10⁴");
    }
}
