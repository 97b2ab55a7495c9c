//! The paper's figures (Figs. 2–12) with `plotters`, as PNG and SVG: tracking, tracking errors
//! with the `2 T_s` line, `u` and `q`, adaptive estimates; and overlays for `compare`.

use std::{path::Path, sync::Once};

use plotters::{coord::Shift, prelude::*, style::RGBAColor};

use crate::{
    error::{Error, Result},
    report::temp_path,
    sim::{Observer, SampleView},
};

/// Most agents drawn in one figure (the first ones).
pub const MAX_PLOTTED_AGENTS: usize = 8;
/// Points per series kept for plotting.
const TARGET_POINTS: u64 = 4000;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static FONT_ONCE: Once = Once::new();

pub(crate) fn register_font() {
    FONT_ONCE.call_once(|| {
        // A bundled font: no system font lookup (works on a bare CI machine).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub color: RGBAColor,
    /// Stroke width.
    pub width: u32,
    /// Points.
    pub points: Vec<(f64, f64)>,
}

/// One chart.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Caption.
    pub title: String,
    /// Y axis label.
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
    /// A vertical marker (the predefined time `2 T_s`).
    pub vline: Option<(f64, String)>,
    /// Show only `t ≥` this.
    pub x_from: Option<f64>,
}

/// Colour of line `i` (the tab10 palette: distinct, readable on white).
pub fn color(i: usize) -> RGBAColor {
    const TAB10: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    let (r, g, b) = TAB10[i % TAB10.len()];
    RGBColor(r, g, b).to_rgba()
}

/// Samples kept for the figures: every `stride`-th, first [`MAX_PLOTTED_AGENTS`] agents.
#[derive(Debug, Clone, Default)]
pub struct Recorder {
    stride: u64,
    agents: usize,
    m: usize,
    /// `t_k`.
    pub t: Vec<f64>,
    /// `y_d`.
    pub yd: Vec<f64>,
    /// `y_i` per plotted agent.
    pub y: Vec<Vec<f64>>,
    /// `max_i |y_i − y_d|` over all agents.
    pub max_err: Vec<f64>,
    /// `u_{i,l}` per plotted agent and actuator (`i * m + l`).
    pub u: Vec<Vec<f64>>,
    /// `q_{i,l}` likewise.
    pub q: Vec<Vec<f64>>,
    /// `μ̂`, `ξ̂`, `λ̂` per plotted agent.
    pub est: [Vec<Vec<f64>>; 3],
    /// Largest-magnitude `u`, `q` (interleaved) and max error since the last kept sample.
    peaks: Vec<f64>,
    peak_err: f64,
}

/// Keeps the larger-magnitude value.
fn peak(acc: &mut f64, v: f64) {
    if v.abs() > acc.abs() || !v.is_finite() {
        *acc = v;
    }
}

impl Recorder {
    /// For `samples` samples of `agents` agents with `m` actuators.
    pub fn new(samples: u64, agents: usize, m: usize) -> Self {
        let a = agents.min(MAX_PLOTTED_AGENTS);
        Self {
            stride: (samples / TARGET_POINTS).max(1),
            agents: a,
            m,
            y: vec![Vec::new(); a],
            u: vec![Vec::new(); a * m],
            q: vec![Vec::new(); a * m],
            est: [
                vec![Vec::new(); a],
                vec![Vec::new(); a],
                vec![Vec::new(); a],
            ],
            peaks: vec![0.0; 2 * a * m],
            ..Self::default()
        }
    }

    fn line(&self, label: String, c: RGBAColor, ys: &[f64]) -> Series {
        Series {
            label,
            color: c,
            width: 2,
            points: self.t.iter().copied().zip(ys.iter().copied()).collect(),
        }
    }

    /// Writes `tracking`, `errors`, `inputs`, `estimates` (`.png`, `.svg`) into `dir`.
    pub fn draw(&self, dir: &Path, predefined_time: f64, name: &str) -> Result<()> {
        let vline = Some((predefined_time, format!("2Ts = {predefined_time}")));
        let mut tracking = Panel {
            title: format!("{name}: outputs y_i and leader y_d"),
            y_label: "y".into(),
            ..Panel::default()
        };
        tracking
            .series
            .push(self.line("y_d".into(), BLACK.to_rgba(), &self.yd));
        for (i, y) in self.y.iter().enumerate() {
            let mut s = self.line(format!("y_{}", i + 1), color(i), y);
            s.width = 1;
            tracking.series.push(s);
        }
        render(dir, "tracking", &[tracking], (1, 1), (1000, 560))?;

        let errs: Vec<Series> = self
            .y
            .iter()
            .enumerate()
            .map(|(i, y)| {
                let e: Vec<f64> = y.iter().zip(&self.yd).map(|(a, b)| a - b).collect();
                self.line(format!("y_{} - y_d", i + 1), color(i), &e)
            })
            .collect();
        let full = Panel {
            title: format!("{name}: tracking errors y_i - y_d"),
            y_label: "y_i - y_d".into(),
            series: errs.clone(),
            vline: vline.clone(),
            x_from: None,
        };
        let zoom = Panel {
            title: "after the predefined time 2Ts".into(),
            y_label: "y_i - y_d".into(),
            series: errs,
            vline: vline.clone(),
            x_from: Some(predefined_time),
        };
        render(dir, "errors", &[full, zoom], (2, 1), (1000, 800))?;

        let mut inputs = Vec::new();
        for i in 0..self.agents {
            // Every actuator of an agent gets the same command (SPEC §5), so u_1, q_1 show all.
            let mut p = Panel {
                title: format!(
                    "agent {}: command u (every actuator) and quantized q",
                    i + 1
                ),
                y_label: "u, q".into(),
                vline: vline.clone(),
                ..Panel::default()
            };
            let mut s = self.line("u".into(), color(1).mix(0.6), &self.u[i * self.m]);
            s.width = 3;
            p.series.push(s);
            let mut s = self.line("q = Q(u)".into(), color(0), &self.q[i * self.m]);
            s.width = 1;
            p.series.push(s);
            inputs.push(p);
        }
        let rows = self.agents.div_ceil(2).max(1);
        let cols = if self.agents > 1 { 2 } else { 1 };
        render(
            dir,
            "inputs",
            &inputs,
            (rows, cols),
            (1200, 300 * rows as u32),
        )?;

        let names = ["mu_hat", "xi_hat", "lambda_hat"];
        let panels: Vec<Panel> = (0..3)
            .map(|e| Panel {
                title: format!("adaptive estimate {}", names[e]),
                y_label: names[e].into(),
                series: self.est[e]
                    .iter()
                    .enumerate()
                    .map(|(i, v)| self.line(format!("agent {}", i + 1), color(i), v))
                    .collect(),
                vline: vline.clone(),
                x_from: None,
            })
            .collect();
        render(dir, "estimates", &panels, (3, 1), (1000, 900))
    }
}

impl<const N: usize, const M: usize> Observer<N, M> for Recorder {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        // u, q and the error keep the peak of each stride (no spike is lost by decimation).
        for i in 0..self.agents {
            let o = &s.out[i];
            for l in 0..M.min(self.m) {
                let j = 2 * (i * self.m + l);
                peak(&mut self.peaks[j], f64::from(o.u[l]));
                peak(&mut self.peaks[j + 1], f64::from(o.q[l]));
            }
        }
        let worst = s.x.iter().map(|x| (x[0] - s.yd).abs()).fold(0.0, f64::max);
        self.peak_err = self.peak_err.max(worst);
        if !s.k.is_multiple_of(self.stride) {
            return Ok(());
        }
        self.t.push(s.t);
        self.yd.push(s.yd);
        self.max_err.push(std::mem::take(&mut self.peak_err));
        for i in 0..self.agents {
            self.y[i].push(s.x[i][0]);
            let o = &s.out[i];
            for l in 0..self.m {
                let j = i * self.m + l;
                self.u[j].push(std::mem::take(&mut self.peaks[2 * j]));
                self.q[j].push(std::mem::take(&mut self.peaks[2 * j + 1]));
            }
            self.est[0][i].push(f64::from(o.estimates.mu));
            self.est[1][i].push(f64::from(o.estimates.xi));
            self.est[2][i].push(f64::from(o.estimates.lambda));
        }
        Ok(())
    }
}

/// Draws `panels` on a `layout` grid into `dir/stem.png` and `dir/stem.svg`.
pub fn render(
    dir: &Path,
    stem: &str,
    panels: &[Panel],
    layout: (usize, usize),
    size: (u32, u32),
) -> Result<()> {
    register_font();
    let png = dir.join(format!("{stem}.png"));
    let tmp = temp_path(&png);
    {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        draw_panels(&root, panels, layout).map_err(|e| Error::io(&png, e))?;
        root.present().map_err(|e| Error::io(&png, e))?;
    }
    std::fs::rename(&tmp, &png).map_err(|e| Error::io(&png, e))?;
    let svg = dir.join(format!("{stem}.svg"));
    let tmp = temp_path(&svg);
    {
        let root = SVGBackend::new(&tmp, size).into_drawing_area();
        draw_panels(&root, panels, layout).map_err(|e| Error::io(&svg, e))?;
        root.present().map_err(|e| Error::io(&svg, e))?;
    }
    std::fs::rename(&tmp, &svg).map_err(|e| Error::io(&svg, e))
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel],
    layout: (usize, usize),
) -> std::result::Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly(layout);
    for (area, p) in areas.iter().zip(panels) {
        draw_panel(area, p).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// `(lo, hi)` of the finite values, padded; a unit range around a constant.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9 + lo.abs().max(hi.abs()) * 1e-6);
    (lo - pad, hi + pad)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let from = p.x_from.unwrap_or(f64::NEG_INFINITY);
    let visible = |s: &Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|(x, y)| *x >= from && y.is_finite())
            .collect()
    };
    let pts: Vec<Vec<(f64, f64)>> = p.series.iter().map(visible).collect();
    let (x0, x1) = range(pts.iter().flatten().map(|p| p.0));
    let (y0, y1) = range(pts.iter().flatten().map(|p| p.1));
    let x0 = if p.x_from.is_some() {
        x0.max(from)
    } else {
        x0.max(0.0)
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(p.y_label.as_str())
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    if let Some((t, label)) = &p.vline {
        if *t >= x0 && *t <= x1 {
            let style = BLACK.mix(0.55).stroke_width(2);
            chart
                .draw_series(LineSeries::new([(*t, y0), (*t, y1)], style))?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
        }
    }
    for (s, pts) in p.series.iter().zip(pts) {
        let style = s.color.stroke_width(s.width);
        chart
            .draw_series(LineSeries::new(pts, style))?
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
