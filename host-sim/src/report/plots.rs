//! The paper's figures (Figs. 2–12) with `plotters`, as PNG and SVG: tracking, tracking errors
//! with the `±b` band and the `2 Tₛ` line, `u`, `q` and `u − q` with the fault windows, adaptive
//! estimates; and overlays for `compare`. Curves that may coincide (agents 2 and 3 of the
//! paper's graph hear the same neighbour) differ in colour, dash pattern and marker.

use std::{path::Path, sync::Once};

use plotters::{
    coord::Shift,
    element::{DashedPathElement, Drawable, PointCollection},
    prelude::*,
    style::RGBAColor,
};
use plotters_backend::{
    text_anchor::{HPos, Pos, VPos},
    BackendCoord, DrawingErrorKind,
};

use crate::{
    error::{Error, Result},
    report::{temp_path, TempFile},
    scenario::Setup,
    sim::{Observer, SampleView},
};

/// Most agents drawn in one figure (the first ones).
pub const MAX_PLOTTED_AGENTS: usize = 8;
/// Points per series kept for plotting.
pub(crate) const TARGET_POINTS: u64 = 4000;
/// Markers per series, staggered between the series of a panel so that they never coincide.
const MARKERS_PER_SERIES: usize = 20;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static FONT_ONCE: Once = Once::new();

/// Registers the bundled font as "sans-serif" (once per process).
pub fn register_font() {
    FONT_ONCE.call_once(|| {
        // A bundled font: no system font lookup (works on a bare CI machine).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Stroke pattern of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dash {
    /// Continuous.
    Solid,
    /// Long dashes.
    Long,
    /// Short dashes.
    Short,
    /// Dots.
    Dotted,
}

impl Dash {
    /// Dash and gap length [px], `None` for a solid line.
    fn pattern(self) -> Option<(u32, u32)> {
        match self {
            Self::Solid => None,
            Self::Long => Some((12, 6)),
            Self::Short => Some((5, 4)),
            Self::Dotted => Some((2, 4)),
        }
    }
}

/// Marker drawn at a few points of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// No marker.
    None,
    /// Open circle.
    Circle,
    /// Filled triangle.
    Triangle,
    /// Cross.
    Cross,
    /// Filled circle.
    Disc,
}

const DASHES: [Dash; 4] = [Dash::Solid, Dash::Long, Dash::Short, Dash::Dotted];
const MARKERS: [Marker; 5] = [
    Marker::None,
    Marker::Circle,
    Marker::Triangle,
    Marker::Cross,
    Marker::Disc,
];

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub color: RGBAColor,
    /// Stroke width.
    pub width: u32,
    /// Stroke pattern.
    pub dash: Dash,
    /// Marker.
    pub marker: Marker,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// The exact largest-magnitude sample `(t, value)` when the points are decimated (named in
    /// the note on a clipped peak).
    pub peak: Option<(f64, f64)>,
}

impl Series {
    /// Line number `i` of a panel: colour, dash pattern and marker all differ from line `i ± 1`.
    pub fn styled(label: String, i: usize, points: Vec<(f64, f64)>) -> Self {
        Self {
            label,
            color: color(i),
            width: 2,
            dash: DASHES[i % DASHES.len()],
            marker: MARKERS[i % MARKERS.len()],
            points,
            peak: None,
        }
    }

    /// A solid line without marker.
    pub fn plain(label: String, color: RGBAColor, width: u32, points: Vec<(f64, f64)>) -> Self {
        Self {
            label,
            color,
            width,
            dash: Dash::Solid,
            marker: Marker::None,
            points,
            peak: None,
        }
    }
}

/// A shaded time interval (an actuator fault window).
#[derive(Debug, Clone)]
pub struct Shade {
    /// Start [s].
    pub from: f64,
    /// End [s].
    pub to: f64,
    /// Fill.
    pub color: RGBAColor,
    /// Legend text (one entry per distinct text).
    pub label: String,
}

/// One chart.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Caption.
    pub title: String,
    /// Y axis label, with unit.
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
    /// Vertical markers (e.g. the predefined time `2 Tₛ`).
    pub vlines: Vec<(f64, String)>,
    /// Horizontal dashed lines (e.g. the band `b` on a log axis).
    pub hlines: Vec<(f64, String)>,
    /// The band `±b`, shaded.
    pub band: Option<(f64, String)>,
    /// Shaded intervals.
    pub shades: Vec<Shade>,
    /// Show only `t ≥` this.
    pub x_from: Option<f64>,
    /// Logarithmic y axis (non-positive values are left out).
    pub log_y: bool,
    /// Clip isolated spikes (the y range follows the bulk of the data) and mark each clipped
    /// peak with its value.
    pub clip_spikes: bool,
    /// Draw the title's combining marks (the hat of `ξ̂`) as separate glyphs (bitmap output).
    pub marks_by_hand: bool,
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

/// `n` as Unicode subscript digits (`y₁₂`).
pub fn sub(n: usize) -> String {
    n.to_string()
        .chars()
        .map(|c| char::from_u32(0x2080 + c.to_digit(10).unwrap_or(0)).unwrap_or(c))
        .collect()
}

/// `n` as Unicode superscript (`10⁻⁵`).
fn sup(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            d => d
                .to_digit(10)
                .and_then(|d| char::from_u32(0x2070 + d))
                .unwrap_or(d),
        })
        .collect()
}

/// A time for figure text: `4 s`, `1.8636 s` (at most four decimals).
pub fn secs(t: f64) -> String {
    format!("{} s", trim_number(t))
}

/// The symbol of a legend label: `u₁` of `u₁ = u₂ (identical)`.
fn short_name(label: &str) -> &str {
    let end = [" = ", " (", ": "]
        .iter()
        .filter_map(|sep| label.find(sep))
        .min()
        .unwrap_or(label.len());
    &label[..end]
}

/// A value for figure text: whole above 100 (`−16519`), else three significant digits.
fn significant(v: f64) -> String {
    if v.abs() >= 100.0 {
        format!("{v:.0}").replace('-', "−")
    } else {
        let d = (2.0 - v.abs().log10().floor()).clamp(0.0, 8.0) as usize;
        format!("{v:.d$}").replace('-', "−")
    }
}

/// `2`, `0.5`, `0.0004` (no trailing zeros, at most 4 decimals).
fn trim_number(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.replace('-', "−")
    }
}

/// A tick label for `v` on the axis `[lo, hi]`: plain decimals
/// to the precision of the tick step, scientific `a×10ᵏ` for very small or large magnitudes,
/// never `-0`, with a real minus sign.
pub fn tick_label(v: f64, (lo, hi): (f64, f64)) -> String {
    let mag = lo.abs().max(hi.abs());
    let decimals = |scale: f64| -> usize {
        let step = tick_step((lo / scale, hi / scale), MESH_LABELS);
        if step > 0.0 && step.is_finite() {
            (-(step.log10() + 1e-9).floor()).clamp(0.0, 6.0) as usize
        } else {
            2
        }
    };
    let minus = |s: String| -> String {
        if s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            "0".into()
        } else {
            s.replace('-', "−")
        }
    };
    if mag > 0.0 && !(1e-3..1e5).contains(&mag) {
        let exp = mag.log10().floor() as i32;
        let scale = 10f64.powi(exp);
        let d = decimals(scale);
        let m = minus(format!("{:.d$}", v / scale));
        if m == "0" {
            return m;
        }
        return format!("{m}×10{}", sup(exp));
    }
    minus(format!("{v:.prec$}", prec = decimals(1.0)))
}

/// Labels per axis `plotters`' mesh asks for by default.
const MESH_LABELS: usize = 11;

/// The tick step `plotters` picks for at most `n` ticks on `[lo, hi]` (its algorithm for `f64`
/// axes): `10ᵏ`, `5·10ᵏ⁻¹` or `2·10ᵏ⁻¹`, the finest whose multiples inside the range are at most
/// `n`.
fn tick_step((lo, hi): (f64, f64), n: usize) -> f64 {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return 0.0;
    }
    let ticks = |step: f64| ((hi / step).floor() - (lo / step).ceil() + 1.0).round();
    let mut scale = 10f64.powf(span.log10().floor());
    if 1.0 + (span / scale).floor() > n as f64 {
        scale *= 10.0;
    }
    loop {
        let coarse = scale;
        for div in [2.0, 5.0, 10.0] {
            if ticks(coarse / div) > n as f64 {
                return scale;
            }
            scale = coarse / div;
        }
    }
}

/// Samples kept for the figures: every `stride`-th, first [`MAX_PLOTTED_AGENTS`] agents.
#[derive(Debug, Clone, Default)]
pub struct Recorder {
    stride: u64,
    agents: usize,
    /// All agents of the run (the figures say when they show only the first ones).
    total: usize,
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
    /// `u_{i,l} − q_{i,l}` likewise (the quantization error).
    pub uq: Vec<Vec<f64>>,
    /// `μ̂`, `ξ̂`, `λ̂` per plotted agent.
    pub est: [Vec<Vec<f64>>; 3],
    /// The exact `(t, value)` of the largest-magnitude `u`, `q`, `u − q` of each agent and
    /// actuator over the run (interleaved like the stride peaks).
    pub extremes: Vec<(f64, f64)>,
    /// Largest-magnitude `u`, `q`, `u − q` (interleaved) and max error since the last kept
    /// sample.
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
            total: agents,
            m,
            y: vec![Vec::new(); a],
            u: vec![Vec::new(); a * m],
            q: vec![Vec::new(); a * m],
            uq: vec![Vec::new(); a * m],
            est: [
                vec![Vec::new(); a],
                vec![Vec::new(); a],
                vec![Vec::new(); a],
            ],
            peaks: vec![0.0; 3 * a * m],
            extremes: vec![(0.0, 0.0); 3 * a * m],
            ..Self::default()
        }
    }

    /// `(t, ys)` pairs.
    pub fn points(&self, ys: &[f64]) -> Vec<(f64, f64)> {
        self.t.iter().copied().zip(ys.iter().copied()).collect()
    }

    /// Writes `tracking`, `errors`, `inputs`, `estimates` (`.png`, `.svg`) into `dir`.
    pub fn draw(&self, dir: &Path, setup: &Setup, settling_time: Option<f64>) -> Result<()> {
        let name = &setup.scenario.name;
        let two_ts = setup.predefined_time();
        let band = setup.scenario.simulation.settle_band;
        let (y_unit, u_unit) = setup.plant.units();
        let vline = (two_ts, format!("2Tₛ = {}", secs(two_ts)));

        let shown = if self.total > self.agents {
            format!(
                " (agents 1–{} of {}; spread: see spread.png)",
                self.agents, self.total
            )
        } else {
            String::new()
        };
        let mut tracking = Panel {
            title: format!("{name}: outputs yᵢ and leader y_d{shown}"),
            y_label: format!("output y [{y_unit}]"),
            vlines: vec![vline.clone()],
            ..Panel::default()
        };
        tracking.series.push(Series::plain(
            "y_d (leader)".into(),
            BLACK.mix(0.35),
            5,
            self.points(&self.yd),
        ));
        for (i, y) in self.y.iter().enumerate() {
            tracking.series.push(Series::styled(
                format!("y{}", sub(i + 1)),
                i,
                self.points(y),
            ));
        }
        render(dir, "tracking", &[tracking], (1, 1), (1000, 560))?;

        let errs: Vec<Series> = self
            .y
            .iter()
            .enumerate()
            .map(|(i, y)| {
                let e: Vec<f64> = y.iter().zip(&self.yd).map(|(a, b)| a - b).collect();
                Series::styled(format!("y{} − y_d", sub(i + 1)), i, self.points(&e))
            })
            .collect();
        let full = Panel {
            title: format!("{name}: tracking errors yᵢ − y_d{shown}"),
            y_label: format!("yᵢ − y_d [{y_unit}]"),
            series: errs,
            vlines: vec![vline.clone()],
            band: Some((band, format!("±b = ±{}", trim_number(band)))),
            ..Panel::default()
        };
        let mut log_vlines = vec![vline.clone()];
        let settled = match settling_time {
            Some(t) => {
                log_vlines.push((t, format!("settled into b at {}", secs(t))));
                format!("inside b from t = {}", secs(t))
            }
            None => "never settles into b".into(),
        };
        let log = Panel {
            title: format!("largest error maxᵢ |yᵢ − y_d| (log scale; {settled})"),
            y_label: format!("maxᵢ |yᵢ − y_d| [{y_unit}]"),
            series: vec![Series::plain(
                "maxᵢ |yᵢ − y_d|".into(),
                color(3),
                2,
                self.points(&self.max_err),
            )],
            vlines: log_vlines,
            hlines: vec![(band, format!("b = {}", trim_number(band)))],
            log_y: true,
            ..Panel::default()
        };
        render(dir, "errors", &[full, log], (2, 1), (1000, 800))?;

        let mut inputs = Vec::new();
        for row in 0..self.agents.div_ceil(2) {
            let agents = (2 * row..(2 * row + 2).min(self.agents)).collect::<Vec<_>>();
            for &i in &agents {
                inputs.push(self.input_panel(setup, i, u_unit, &vline));
            }
            if agents.len() == 1 && self.agents > 1 {
                inputs.push(Panel::default());
            }
            for &i in &agents {
                inputs.push(self.quantization_panel(setup, i, u_unit));
            }
            if agents.len() == 1 && self.agents > 1 {
                inputs.push(Panel::default());
            }
        }
        let cols = if self.agents > 1 { 2 } else { 1 };
        let rows = inputs.len().div_ceil(cols).max(1);
        render(
            dir,
            "inputs",
            &inputs,
            (rows, cols),
            (1400, 270 * rows as u32),
        )?;

        let names = ["μ̂", "ξ̂", "λ̂"];
        let what = [
            "bound of the MTN approximation weights",
            "bound of the fault and disturbance terms",
            "inverse effectiveness of the actuators",
        ];
        let panels: Vec<Panel> = (0..3)
            .map(|e| Panel {
                title: format!("adaptive estimate {} ({})", names[e], what[e]),
                y_label: "estimate [–]".into(),
                series: self.est[e]
                    .iter()
                    .enumerate()
                    .map(|(i, v)| Series::styled(format!("agent {}", i + 1), i, self.points(v)))
                    .collect(),
                vlines: vec![vline.clone()],
                ..Panel::default()
            })
            .collect();
        render(dir, "estimates", &panels, (3, 1), (1000, 900))
    }

    /// The series of actuators `0..m` of agent `i` from `data`, one series when all are equal.
    /// The exact extreme of `kind` (0 `u`, 1 `q`, 2 `u − q`) of actuator `l` of agent `i`.
    pub fn extreme(&self, i: usize, l: usize, kind: usize) -> Option<(f64, f64)> {
        self.extremes.get(3 * (i * self.m + l) + kind).copied()
    }

    /// The series of `kind` (as in [`Recorder::extreme`]) of actuators `0..m` of agent `i` from
    /// `data`, one series when all are equal.
    fn actuator_series(
        &self,
        (data, kind): (&[Vec<f64>], usize),
        i: usize,
        symbol: &str,
        first: usize,
    ) -> Vec<Series> {
        let acts = &data[i * self.m..(i + 1) * self.m];
        if acts.iter().all(|a| *a == acts[0]) && self.m > 1 {
            let names: Vec<String> = (1..=self.m).map(|l| symbol.replace('#', &sub(l))).collect();
            let mut s = Series::styled(
                format!("{} (identical)", names.join(" = ")),
                first,
                self.points(&acts[0]),
            );
            s.peak = self.extreme(i, 0, kind);
            return vec![s];
        }
        acts.iter()
            .enumerate()
            .map(|(l, a)| {
                let mut s =
                    Series::styled(symbol.replace('#', &sub(l + 1)), first + l, self.points(a));
                s.peak = self.extreme(i, l, kind);
                s
            })
            .collect()
    }

    fn input_panel(&self, setup: &Setup, i: usize, u_unit: &str, vline: &(f64, String)) -> Panel {
        // Dense, noisy lines are 1 px wide: wider ones get miter spikes at sharp reversals.
        let mut series = self.actuator_series((&self.u, 0), i, "u#", 0);
        for s in &mut series {
            s.color = s.color.mix(0.5);
            s.width = 3;
        }
        for mut s in self.actuator_series((&self.q, 1), i, "q# = Q(u#)", 1) {
            s.width = 1;
            s.marker = Marker::None;
            series.push(s);
        }
        Panel {
            title: format!(
                "agent {}: command u and quantized q (shaded: fault windows)",
                i + 1
            ),
            y_label: format!("u, q [{u_unit}]"),
            series,
            vlines: vec![vline.clone()],
            shades: fault_shades(setup, i, self.m),
            clip_spikes: true,
            ..Panel::default()
        }
    }

    fn quantization_panel(&self, setup: &Setup, i: usize, u_unit: &str) -> Panel {
        Panel {
            title: format!("agent {}: quantization error u − q", i + 1),
            y_label: format!("u − q [{u_unit}]"),
            series: self
                .actuator_series((&self.uq, 2), i, "u# − q#", 0)
                .into_iter()
                .map(|s| Series { width: 1, ..s })
                .collect(),
            shades: fault_shades(setup, i, self.m),
            clip_spikes: true,
            ..Panel::default()
        }
    }
}

/// The fault windows of agent `i`'s actuators as shaded intervals.
fn fault_shades(setup: &Setup, i: usize, m: usize) -> Vec<Shade> {
    let t_end = setup.scenario.simulation.t_end;
    let mut shades = Vec::new();
    for l in 0..m {
        for (from, to, total) in setup.faults.windows(i, l, t_end) {
            let (c, kind) = if total {
                (RGBColor(214, 39, 40).mix(0.10), "total loss")
            } else {
                (RGBColor(255, 127, 14).mix(0.12), "partial loss")
            };
            shades.push(Shade {
                from,
                to,
                color: c,
                label: format!("actuator {} fault: {kind}", l + 1),
            });
        }
    }
    shades
}

impl<const N: usize, const M: usize> Observer<N, M> for Recorder {
    fn sample(&mut self, s: &SampleView<'_, N, M>) -> Result<()> {
        // u, q, u − q and the error keep the peak of each stride (decimation loses no spike).
        for i in 0..self.agents {
            let o = &s.out[i];
            for l in 0..M.min(self.m) {
                let j = 3 * (i * self.m + l);
                let (u, q) = (f64::from(o.u[l]), f64::from(o.q[l]));
                for (d, v) in [u, q, u - q].into_iter().enumerate() {
                    peak(&mut self.peaks[j + d], v);
                    if v.abs() > self.extremes[j + d].1.abs() {
                        self.extremes[j + d] = (s.t, v);
                    }
                }
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
                self.u[j].push(std::mem::take(&mut self.peaks[3 * j]));
                self.q[j].push(std::mem::take(&mut self.peaks[3 * j + 1]));
                self.uq[j].push(std::mem::take(&mut self.peaks[3 * j + 2]));
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
    let tmp = TempFile::new(temp_path(&png));
    {
        let root = BitMapBackend::new(tmp.path(), size).into_drawing_area();
        let panels: Vec<Panel> = panels.iter().map(for_bitmap).collect();
        draw_panels(&root, &panels, layout).map_err(|e| Error::io(&png, e))?;
        root.present().map_err(|e| Error::io(&png, e))?;
    }
    tmp.persist(&png)?;
    let svg = dir.join(format!("{stem}.svg"));
    let tmp = TempFile::new(temp_path(&svg));
    {
        let root = SVGBackend::new(tmp.path(), size).into_drawing_area();
        draw_panels(&root, panels, layout).map_err(|e| Error::io(&svg, e))?;
        root.present().map_err(|e| Error::io(&svg, e))?;
    }
    tmp.persist(&svg)
}

/// The bitmap backend draws a combining mark at the pen position after its base letter (no
/// mark positioning); put it before the letter so that `μ̂` gets its hat on the `μ`. SVG keeps
/// the Unicode order, which SVG viewers position correctly.
fn bitmap_text(text: &str) -> String {
    let mut out: Vec<char> = Vec::with_capacity(text.len());
    for c in text.chars() {
        match (c, out.pop()) {
            ('\u{300}'..='\u{36f}', Some(base)) => out.extend([c, base]),
            (c, prev) => out.extend(prev.into_iter().chain([c])),
        }
    }
    out.into_iter().collect()
}

fn for_bitmap(p: &Panel) -> Panel {
    let mut p = p.clone();
    p.marks_by_hand = true;
    p.y_label = bitmap_text(&p.y_label);
    for s in &mut p.series {
        s.label = bitmap_text(&s.label);
    }
    for (_, l) in p.vlines.iter_mut().chain(p.hlines.iter_mut()) {
        *l = bitmap_text(l);
    }
    p
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[Panel],
    layout: (usize, usize),
) -> std::result::Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly(layout);
    for (area, p) in areas.iter().zip(panels) {
        if p.series.is_empty() {
            continue;
        }
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

/// The y limit beyond which isolated spikes are clipped: `None` when nothing stands out.
/// The bulk is the 99th percentile of `|y|`; a peak more than 4× above it is a spike.
fn spike_limit(values: &[f64]) -> Option<f64> {
    let mut mags: Vec<f64> = values.iter().map(|v| v.abs()).collect();
    if mags.len() < 20 {
        return None;
    }
    mags.sort_by(f64::total_cmp);
    let bulk = mags[(mags.len() - 1) * 99 / 100];
    let max = mags[mags.len() - 1];
    (bulk > 0.0 && max > 4.0 * bulk).then_some(1.5 * bulk)
}

/// A marker, or a legend sample (line with its dash pattern and marker), drawn with the
/// backend's primitives so that one element type serves every kind.
struct Glyph<C> {
    at: C,
    marker: Marker,
    /// `Some`: a legend sample, 24 px of line with this pattern before the marker.
    dash: Option<Dash>,
    color: RGBAColor,
    width: u32,
}

impl<'b, C: 'b> PointCollection<'b, C> for &'b Glyph<C> {
    type Point = &'b C;
    type IntoIter = std::iter::Once<&'b C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Glyph<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut pos: I,
        b: &mut DB,
        _: (u32, u32),
    ) -> std::result::Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((mut x, y)) = pos.next() else {
            return Ok(());
        };
        let line = self.color.stroke_width(self.width.min(3));
        if let Some(dash) = self.dash {
            let (d, g) = dash.pattern().unwrap_or((24, 0));
            let mut s = 0;
            while s < 24 {
                b.draw_line((x + s, y), (x + (s + d as i32).min(24), y), &line)?;
                s += (d + g) as i32;
            }
            x += 12;
        }
        let thin = self.color.stroke_width(1);
        let fill = self.color.filled();
        match self.marker {
            Marker::None => {}
            Marker::Circle => b.draw_circle((x, y), 4, &thin, false)?,
            Marker::Disc => b.draw_circle((x, y), 3, &fill, true)?,
            Marker::Triangle => {
                b.fill_polygon([(x, y - 5), (x - 5, y + 4), (x + 5, y + 4)], &fill)?
            }
            Marker::Cross => {
                let bold = self.color.stroke_width(2);
                b.draw_line((x - 4, y - 4), (x + 4, y + 4), &bold)?;
                b.draw_line((x - 4, y + 4), (x + 4, y - 4), &bold)?;
            }
        }
        Ok(())
    }
}

/// Draws `title` centred in `area`. With `marks_by_hand`, each combining mark (U+0300–U+036F)
/// is drawn as its spacing form above its letter, raised over tall letters: the bitmap font
/// renderer has no mark positioning and would bury the hat of `ξ̂` inside the `ξ`.
fn draw_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    marks_by_hand: bool,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = TextStyle::from(("sans-serif", 17).into_font());
    let (w, h) = area.dim_in_pixel();
    let plain: String = title
        .chars()
        .filter(|c| !(marks_by_hand && ('\u{300}'..='\u{36f}').contains(c)))
        .collect();
    let width = |t: &str| area.estimate_text_size(t, &font).map(|s| s.0 as i32);
    let left = w as i32 / 2 - width(&plain)? / 2;
    let top = h as i32 / 2 + 2;
    area.draw(&Text::new(
        plain.clone(),
        (left, top),
        font.pos(Pos::new(HPos::Left, VPos::Center)),
    ))?;
    if !marks_by_hand {
        return Ok(());
    }
    let mut prefix = String::new();
    for c in title.chars() {
        if !('\u{300}'..='\u{36f}').contains(&c) {
            prefix.push(c);
            continue;
        }
        let Some(base) = prefix.pop() else { continue };
        let x = left + width(&prefix)? + width(&base.to_string())? / 2;
        prefix.push(base);
        let spacing = match c {
            '\u{302}' => 'ˆ',
            '\u{303}' => '˜',
            '\u{304}' => '¯',
            '\u{307}' => '˙',
            _ => continue,
        };
        let tall = base.is_uppercase() || "bdfhklλξδζθβ".contains(base);
        let y = top - if tall { 5 } else { 1 };
        area.draw(&Text::new(
            spacing.to_string(),
            (x, y),
            font.pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
    }
    Ok(())
}

/// The largest-magnitude point of a series beyond the clip limit `c`: its exact peak when
/// known, else the largest of `pts`.
fn clipped_peak(s: &Series, pts: &[(f64, f64)], c: f64) -> Option<(f64, f64)> {
    s.peak.filter(|p| p.1.abs() > c).or_else(|| {
        pts.iter()
            .copied()
            .filter(|(_, y)| y.abs() > c)
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    })
}

/// A note at `t` is written to the left of its peak in the right 45 % of the plot.
fn note_to_the_left(t: f64, (x0, x1): (f64, f64)) -> bool {
    (t - x0) / (x1 - x0) > 0.55
}

/// The corner of the plot where a legend box of `w` × `h` (fractions of the plot) covers the
/// fewest data points (a point of a note counts 100), and how many it covers.
fn legend_corner(
    pts: &[Vec<(f64, f64)>],
    notes: &[(f64, f64)],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (w, h): (f64, f64),
) -> (SeriesLabelPosition, usize) {
    let fx = |x: f64| (x - x0) / (x1 - x0);
    let fy = |y: f64| (y.clamp(y0, y1) - y0) / (y1 - y0);
    let corners = [
        (SeriesLabelPosition::UpperRight, 1.0 - w, 1.0, 1.0 - h, 1.0),
        (SeriesLabelPosition::LowerRight, 1.0 - w, 1.0, 0.0, h),
        (SeriesLabelPosition::UpperLeft, 0.0, w, 1.0 - h, 1.0),
        (SeriesLabelPosition::LowerLeft, 0.0, w, 0.0, h),
    ];
    let mut best = (SeriesLabelPosition::UpperRight, usize::MAX);
    for (pos, ax, bx, ay, by) in corners {
        let within =
            |&&(x, y): &&(f64, f64)| (ax..=bx).contains(&fx(x)) && (ay..=by).contains(&fy(y));
        let inside =
            pts.iter().flatten().filter(within).count() + 100 * notes.iter().filter(within).count();
        if inside < best.1 {
            best = (pos, inside);
        }
    }
    best
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
            .filter(|(x, y)| *x >= from && y.is_finite() && (!p.log_y || *y > 0.0))
            .map(|(x, y)| if p.log_y { (x, y.log10()) } else { (x, y) })
            .collect()
    };
    let pts: Vec<Vec<(f64, f64)>> = p.series.iter().map(visible).collect();
    let (x0, x1) = range(pts.iter().flatten().map(|p| p.0));
    let x0 = if p.x_from.is_some() {
        x0.max(from)
    } else {
        x0.max(0.0)
    };
    let all_y: Vec<f64> = pts.iter().flatten().map(|p| p.1).collect();
    let clip = if p.clip_spikes {
        spike_limit(&all_y)
    } else {
        None
    };
    let extra: Vec<f64> = p
        .band
        .iter()
        .flat_map(|(b, _)| [-b * 1.3, b * 1.3])
        .chain(
            p.hlines
                .iter()
                .map(|(v, _)| if p.log_y { v.log10() } else { *v }),
        )
        .collect();
    let (mut y0, mut y1) = range(
        all_y
            .iter()
            .map(|v| clip.map_or(*v, |c| v.clamp(-c, c)))
            .chain(extra.iter().copied()),
    );
    if p.log_y {
        // Whole decades around the data, without the linear padding.
        let (lo, hi) = all_y
            .iter()
            .chain(&extra)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if lo.is_finite() {
            (y0, y1) = (
                (lo + 1e-9).floor(),
                (hi - 1e-9).ceil().max(lo.floor() + 1.0),
            );
        }
    }
    // The legend goes into a free corner; when every corner has data, the y range grows so
    // that the upper right one is free.
    let mut shade_labels: Vec<&str> = p.shades.iter().map(|s| s.label.as_str()).collect();
    shade_labels.sort_unstable();
    shade_labels.dedup();
    let entries = p.series.len()
        + p.vlines.len()
        + p.hlines.len()
        + usize::from(p.band.is_some())
        + shade_labels.len();
    let longest = p
        .series
        .iter()
        .map(|s| &s.label)
        .chain(p.vlines.iter().chain(&p.hlines).map(|l| &l.1))
        .chain(&p.band.iter().map(|b| b.1.clone()).collect::<Vec<_>>())
        .map(|l| l.chars().count())
        .chain(shade_labels.iter().map(|l| l.chars().count()))
        .max()
        .unwrap_or(0);
    let (aw, ah) = area.dim_in_pixel();
    let legend = (
        (longest as f64 * 6.6 + 48.0) / (f64::from(aw) - 100.0).max(1.0),
        (entries as f64 * 17.0 + 14.0) / (f64::from(ah) - 80.0).max(1.0),
    );
    // The notes on clipped peaks occupy a strip beside the peak; the legend must not hide them.
    let mut notes = Vec::new();
    if let Some(c) = clip {
        for (s, sp) in p.series.iter().zip(&pts) {
            if let Some((t, v)) = clipped_peak(s, sp, c) {
                let edge = v.clamp(-c, c);
                let dir = if note_to_the_left(t, (x0, x1)) {
                    -1.0
                } else {
                    1.0
                };
                notes.extend(
                    (0..40).map(|k| (t + dir * (x1 - x0) * 0.5 * f64::from(k) / 40.0, edge)),
                );
            }
        }
    }
    let (mut corner, covered) = legend_corner(&pts, &notes, (x0, x1), (y0, y1), legend);
    if covered > 0 && legend.1 < 0.35 && clip.is_none() {
        let grow = (y1 - y0) * legend.1 / (1.0 - legend.1);
        y1 += if p.log_y { grow.ceil() } else { grow };
        corner = SeriesLabelPosition::UpperRight;
    }
    let span = y1 - y0;
    let (title_area, area) = area.split_vertically(28);
    draw_title(&title_area, &p.title, p.marks_by_hand)?;
    let mut chart = ChartBuilder::on(&area)
        .margin(8)
        .margin_top(4)
        .x_label_area_size(34)
        .y_label_area_size(78)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let log = p.log_y;
    let y_fmt = move |v: &f64| -> String {
        if log {
            let k = v.round();
            if (v - k).abs() < 1e-6 {
                format!("10{}", sup(k as i32))
            } else {
                String::new()
            }
        } else {
            tick_label(*v, (y0, y1))
        }
    };
    let x_fmt = move |v: &f64| tick_label(*v, (x0, x1));
    let mut mesh = chart.configure_mesh();
    mesh.x_desc("time t [s]")
        .y_desc(p.y_label.as_str())
        .y_label_formatter(&y_fmt)
        .x_label_formatter(&x_fmt)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14));
    if log {
        mesh.y_labels((span as usize + 1).min(12))
            .y_max_light_lines(0);
    }
    mesh.draw()?;
    if log {
        // Minor grid at 2…9 × 10ᵏ.
        let faint = BLACK.mix(0.08).stroke_width(1);
        let minor = (y0 as i32..y1 as i32)
            .flat_map(|k| (2..10).map(move |m| f64::from(k) + f64::from(m).log10()));
        chart.draw_series(minor.map(|v| PathElement::new(vec![(x0, v), (x1, v)], faint)))?;
    }

    let mut labelled = Vec::new();
    for sh in &p.shades {
        let (a, b) = (sh.from.max(x0), sh.to.min(x1));
        if a >= b {
            continue;
        }
        let anno = chart.draw_series([Rectangle::new([(a, y0), (b, y1)], sh.color.filled())])?;
        if !labelled.contains(&sh.label) {
            labelled.push(sh.label.clone());
            let c = sh.color.mix(2.5);
            anno.label(sh.label.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 24, y + 5)], c.filled()));
        }
    }
    if let Some((b, label)) = &p.band {
        let fill = RGBColor(44, 160, 44).mix(0.12);
        let edge = RGBColor(44, 160, 44).mix(0.8).stroke_width(1);
        chart
            .draw_series([Rectangle::new([(x0, -b), (x1, *b)], fill.filled())])?
            .label(label.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 24, y + 5)], fill.filled()));
        for v in [-b, *b] {
            chart.draw_series(DashedLineSeries::new([(x0, v), (x1, v)], 6, 4, edge))?;
        }
    }
    for (v, label) in &p.hlines {
        let v = if log { v.log10() } else { *v };
        let style = RGBColor(44, 160, 44).stroke_width(2);
        chart
            .draw_series(DashedLineSeries::new([(x0, v), (x1, v)], 8, 5, style))?
            .label(label.as_str())
            .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], 8, 5, style));
    }
    for (k, (t, label)) in p.vlines.iter().enumerate() {
        if *t < x0 || *t > x1 {
            continue;
        }
        let style = if k == 0 {
            BLACK.mix(0.6).stroke_width(2)
        } else {
            color(4 + k).stroke_width(2)
        };
        let (d, g) = if k == 0 { (1000, 1) } else { (6, 4) };
        chart
            .draw_series(DashedLineSeries::new([(*t, y0), (*t, y1)], d, g, style))?
            .label(label.as_str())
            .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], d, g, style));
    }
    let n_series = p.series.len().max(1);
    let mut notes_drawn = 0;
    for (k, (s, pts)) in p.series.iter().zip(&pts).enumerate() {
        if pts.is_empty() {
            continue;
        }
        let shown: Vec<(f64, f64)> = match clip {
            Some(c) => pts.iter().map(|&(x, y)| (x, y.clamp(-c, c))).collect(),
            None => pts.clone(),
        };
        let style = s.color.stroke_width(s.width);
        let anno = match s.dash.pattern() {
            None => chart.draw_series(LineSeries::new(shown.iter().copied(), style))?,
            Some((d, g)) => {
                chart.draw_series(DashedLineSeries::new(shown.iter().copied(), d, g, style))?
            }
        };
        let (marker, dash, color, width) = (s.marker, s.dash, s.color, s.width);
        if !s.label.is_empty() {
            // An unlabelled series (the second edge of a band) has no legend entry.
            anno.label(s.label.as_str()).legend(move |at| Glyph {
                at,
                marker,
                dash: Some(dash),
                color,
                width,
            });
        }
        let step = (shown.len() / MARKERS_PER_SERIES).max(1);
        let offset = k * step / n_series;
        if s.marker != Marker::None {
            chart.draw_series(shown.iter().skip(offset).step_by(step).map(|&at| Glyph {
                at,
                marker: s.marker,
                dash: None,
                color: s.color,
                width: s.width,
            }))?;
        }
        if let Some(c) = clip {
            // Mark the clipped peak of this series with its value.
            if let Some((t, v)) = clipped_peak(s, pts, c) {
                let edge = v.clamp(-c, c);
                let arrow = if v > 0.0 { "▲" } else { "▼" };
                // Notes stack into the plot: downwards from the top edge, upwards from the bottom.
                let rank = notes_drawn;
                notes_drawn += 1;
                let dy = if v > 0.0 {
                    4 + 16 * rank
                } else {
                    -18 - 16 * rank
                };
                // The note runs to the right of the peak, or to its left near the right edge.
                let left = note_to_the_left(t, (x0, x1));
                let (dx, h) = if left {
                    (-24, HPos::Right)
                } else {
                    (24, HPos::Left)
                };
                let style = ("sans-serif", 12)
                    .into_font()
                    .color(&s.color)
                    .pos(Pos::new(h, VPos::Top));
                let note = format!(
                    "{arrow} {}peak {} at t = {} (clipped)",
                    if n_series > 1 {
                        format!("{}: ", short_name(&s.label))
                    } else {
                        String::new()
                    },
                    significant(v),
                    secs(t)
                );
                // A light backing keeps the note readable across grid and marker lines.
                let w = (note.chars().count() as f64 * 6.4) as i32 + 4;
                let (a, b) = if left {
                    (dx - w, dx + 2)
                } else {
                    (dx - 2, dx + w)
                };
                chart.draw_series([EmptyElement::at((t, edge))
                    + Rectangle::new([(a, dy - 1), (b, dy + 14)], WHITE.mix(0.8).filled())
                    + TriangleMarker::new((0, 0), 6, s.color.filled())
                    + Text::new(note, (dx, dy), style)])?;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(corner)
        .label_font(("sans-serif", 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_no_negative_zero_and_use_scientific_notation_when_small() {
        let r = (-0.19, 0.18);
        assert_eq!(tick_label(-0.0, r), "0");
        assert_eq!(tick_label(-1e-17, r), "0");
        assert_eq!(tick_label(-0.05, r), "−0.05");
        assert_eq!(tick_label(0.15, r), "0.15");
        assert_eq!(tick_step(r, MESH_LABELS), 0.05);
        // plotters puts ticks every 0.5 on [-2.2, 2.2]: one decimal, no repeated "2".
        assert_eq!(tick_step((-1.71, 3.6), MESH_LABELS), 0.5);
        assert_eq!(tick_step((-2.2, 2.2), MESH_LABELS), 0.5);
        assert_eq!(tick_label(1.5, (-2.2, 2.2)), "1.5");
        assert_eq!(tick_label(2.0, (-2.2, 2.2)), "2.0");
        assert_eq!(tick_label(2.0e-5, (-2e-6, 9.4e-5)), "2×10⁻⁵");
        assert_eq!(tick_label(2.5e-5, (-2e-6, 3.1e-5)), "2.5×10⁻⁵");
        assert_eq!(tick_label(20000.0, (-30000.0, 1000.0)), "20000");
        assert_eq!(tick_label(-2.0e5, (-3e5, 1e5)), "−2.0×10⁵");
        assert_eq!(sub(12), "₁₂");
        assert_eq!(bitmap_text("μ̂ and ŷ, x̂₁"), "\u{302}μ and ŷ, \u{302}x₁");
        assert_eq!(trim_number(4.0), "4");
        assert_eq!(trim_number(0.0004), "0.0004");
        assert_eq!(significant(-16519.07), "−16519");
        assert_eq!(significant(2.1234), "2.12");
        assert_eq!(short_name("u₁ = u₂ (identical)"), "u₁");
        assert_eq!(short_name("agent 1"), "agent 1");
        assert_eq!(short_name("example2-baseline"), "example2-baseline");
    }

    #[test]
    fn spikes_are_found_only_when_they_stand_out() {
        let mut v: Vec<f64> = (0..1000).map(|k| (k as f64 * 0.1).sin()).collect();
        assert_eq!(spike_limit(&v), None);
        v[3] = -27_000.0;
        let c = spike_limit(&v).expect("a spike");
        assert!(c > 1.0 && c < 2.0, "{c}");
    }
}
