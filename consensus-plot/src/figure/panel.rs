//! Time-series panels (the run, spread, compare and firmware figures): lines told apart by
//! colour, dash pattern and marker, the band `±b`, vertical and horizontal reference lines,
//! shaded windows, a log y axis, clipped spikes with their peak written, and a legend in the
//! corner with the fewest data points.

use std::path::Path;

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

use super::{
    chart::{axes, legend, legend_corner, Drawn},
    drawing_error, grid, save_png_and_svg,
    text::{bitmap_text, secs, short_name, significant, sup, tick_label},
    DrawResult, Figure, FigureStyle, Format,
};
use crate::error::Result;

/// Markers per series, staggered between the series of a panel so that they never coincide.
const MARKERS_PER_SERIES: usize = 20;

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
    /// A clipped peak gets a note (off for a line whose peak another line's note names).
    pub note: bool,
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
            note: true,
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
            note: true,
        }
    }
}

/// A shaded time interval (an actuator fault window).
#[derive(Debug, Clone)]
pub struct Shade {
    /// Start \[s\].
    pub from: f64,
    /// End \[s\].
    pub to: f64,
    /// Fill.
    pub color: RGBAColor,
    /// Legend text (one entry per distinct text).
    pub label: String,
    /// Diagonal hatching over the fill, so that two kinds of window differ in grayscale too.
    pub hatch: bool,
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
    /// Show only `t ≤` this.
    pub x_to: Option<f64>,
    /// Logarithmic y axis (non-positive values are left out).
    pub log_y: bool,
    /// Clip isolated spikes (the y range follows the bulk of the data) and mark each clipped
    /// peak with its value.
    pub clip_spikes: bool,
    /// Draw the title's combining marks (the hat of `ξ̂`) as separate glyphs (bitmap output).
    pub marks_by_hand: bool,
    /// Where the legend goes.
    pub legend: Legend,
}

/// The legend of a panel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// In the corner with the fewest data points; when every corner has data, the y range
    /// grows so that the upper right one is free.
    #[default]
    Corner,
    /// None: another panel of the figure names the same lines (one legend per figure).
    Hidden,
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

/// Panels on a `rows` × `cols` grid, row by row; an empty panel leaves its cell blank.
#[derive(Debug, Clone, Copy)]
pub struct Panels<'a> {
    /// The panels.
    pub panels: &'a [Panel],
    /// `(rows, cols)`.
    pub layout: (usize, usize),
}

impl Figure for Panels<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        format: Format,
    ) -> DrawResult {
        let mut named: Vec<String> = Vec::new();
        for (area, p) in grid(root, self.layout).iter().zip(self.panels) {
            if p.series.is_empty() {
                continue;
            }
            let mut p = if format.is_bitmap() {
                for_bitmap(p)
            } else {
                p.clone()
            };
            // One legend per figure: a panel shows one only for lines no panel before named.
            let entries = legend_entries(&p);
            if entries.iter().all(|e| named.contains(e)) {
                p.legend = Legend::Hidden;
            }
            draw_panel(area, style, &p, &named).map_err(drawing_error)?;
            if p.legend == Legend::Corner {
                named.extend(entries);
            }
        }
        Ok(())
    }
}

/// The vertical lines of `p` inside its time window, with their index (which sets their style):
/// those outside are neither drawn nor named in the legend.
fn shown_vlines(p: &Panel) -> impl Iterator<Item = (usize, &(f64, String))> {
    let from = p.x_from.unwrap_or(f64::NEG_INFINITY);
    let to = p.x_to.unwrap_or(f64::INFINITY);
    p.vlines
        .iter()
        .enumerate()
        .filter(move |(_, (t, _))| (from..=to).contains(t))
}

/// The legend texts of `p`.
fn legend_entries(p: &Panel) -> Vec<String> {
    p.series
        .iter()
        .map(|s| s.label.clone())
        .filter(|l| !l.is_empty())
        .chain(shown_vlines(p).map(|(_, l)| l.1.clone()))
        .chain(p.hlines.iter().map(|l| l.1.clone()))
        .chain(p.band.iter().map(|b| b.1.clone()))
        .chain(p.shades.iter().map(|s| s.label.clone()))
        .collect()
}

/// Draws `panels` on a `layout` grid into `dir/stem.<ext>` for each format of `style`. A print
/// style with a chart height stacks the panels in one column, each that high; the time window
/// of the style's output applies to every panel.
pub fn render(
    dir: &Path,
    stem: &str,
    panels: &[Panel],
    layout: (usize, usize),
    style: FigureStyle,
) -> Result<()> {
    let out = *style.output();
    let mut panels: Vec<Panel> = panels.to_vec();
    for p in &mut panels {
        if let Some(from) = out.window.0 {
            p.x_from = Some(p.x_from.map_or(from, |f| f.max(from)));
        }
        if let Some(to) = out.window.1 {
            p.x_to = Some(p.x_to.map_or(to, |t| t.min(to)));
        }
    }
    let (mut layout, mut style) = (layout, style);
    if out.print.is_some_and(|p| p.chart_mm.is_some()) {
        panels.retain(|p| !p.series.is_empty());
        layout = (panels.len().max(1), 1);
        let (w, h) = style.size();
        let chart = (w / layout.1.max(1) as u32, h / layout.0.max(1) as u32);
        style = style.stacked(chart, panels.len());
    }
    save_png_and_svg(
        dir,
        stem,
        &style,
        &Panels {
            panels: &panels,
            layout,
        },
    )
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
    /// Sizes of the sample and marker are multiplied by this (print canvases).
    zoom: f64,
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
        let (z, ink) = (self.zoom, self.zoom.sqrt());
        let k = |px: i32| (f64::from(px) * ink).round() as i32;
        let line = self
            .color
            .stroke_width(self.width.min(3) * ink.round() as u32);
        if let Some(dash) = self.dash {
            let span = (24.0 * z).round() as i32;
            let (d, g) = dash
                .pattern()
                .map_or((span, 0), |(d, g)| (k(d as i32), k(g as i32)));
            let mut s = 0;
            while s < span {
                b.draw_line((x + s, y), (x + (s + d).min(span), y), &line)?;
                s += d + g;
            }
            x += span / 2;
        }
        let thin = self.color.stroke_width(ink.round() as u32);
        let fill = self.color.filled();
        match self.marker {
            Marker::None => {}
            Marker::Circle => b.draw_circle((x, y), k(4) as u32, &thin, false)?,
            Marker::Disc => b.draw_circle((x, y), k(3) as u32, &fill, true)?,
            Marker::Triangle => b.fill_polygon(
                [(x, y - k(5)), (x - k(5), y + k(4)), (x + k(5), y + k(4))],
                &fill,
            )?,
            Marker::Cross => {
                let bold = self.color.stroke_width(k(2) as u32);
                b.draw_line((x - k(4), y - k(4)), (x + k(4), y + k(4)), &bold)?;
                b.draw_line((x - k(4), y + k(4)), (x + k(4), y - k(4)), &bold)?;
            }
        }
        Ok(())
    }
}

/// Diagonal lines 7 px apart across the rectangle between two corners (top left, bottom right).
struct Hatch<C> {
    corners: [C; 2],
    color: RGBAColor,
}

impl<'b, C: 'b> PointCollection<'b, C> for &'b Hatch<C> {
    type Point = &'b C;
    type IntoIter = std::slice::Iter<'b, C>;
    fn point_iter(self) -> Self::IntoIter {
        self.corners.iter()
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Hatch<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut pos: I,
        b: &mut DB,
        _: (u32, u32),
    ) -> std::result::Result<(), DrawingErrorKind<DB::ErrorType>> {
        let (Some((x0, y0)), Some((x1, y1))) = (pos.next(), pos.next()) else {
            return Ok(());
        };
        let (l, r, t, bt) = (x0.min(x1), x0.max(x1), y0.min(y1), y0.max(y1));
        let line = self.color.stroke_width(1);
        // Lines x - y = c, clipped to the rectangle.
        let mut c = l - bt;
        while c <= r - t {
            let (xa, ya) = if c + bt <= r {
                (c + bt, bt)
            } else {
                (r, r - c)
            };
            let (xb, yb) = if c + t >= l { (c + t, t) } else { (l, l - c) };
            if xa >= l && xb <= r {
                b.draw_line((xa, ya), (xb, yb), &line)?;
            }
            c += 7;
        }
        Ok(())
    }
}

/// Draws `title` centred in `area`. With `marks_by_hand`, each combining mark (U+0300–U+036F)
/// is drawn as its spacing form above its letter, raised over tall letters: the bitmap font
/// renderer has no mark positioning and would bury the hat of `ξ̂` inside the `ξ`.
fn draw_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    title: &str,
    marks_by_hand: bool,
) -> Drawn<DB> {
    let (w, h) = area.dim_in_pixel();
    // A title wider than the panel (a narrow print page) is set smaller, to 60 % at least.
    let full = TextStyle::from(style.font(17));
    let wide = f64::from(area.estimate_text_size(title, &full)?.0);
    let fit = (f64::from(w) * 0.96 / wide.max(1.0)).clamp(0.6, 1.0);
    let font = if fit < 1.0 {
        TextStyle::from(style.font((17.0 * fit) as u32))
    } else {
        full
    };
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

/// `named`: the legend entries of the panels drawn before; a print legend strip leaves them out.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    page: &FigureStyle,
    p: &Panel,
    named: &[String],
) -> Drawn<DB> {
    let from = p.x_from.unwrap_or(f64::NEG_INFINITY);
    let to = p.x_to.unwrap_or(f64::INFINITY);
    let visible = |s: &Series| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .copied()
            .filter(|(x, y)| (from..=to).contains(x) && y.is_finite() && (!p.log_y || *y > 0.0))
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
    let x1 = x1.min(to);
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
        + shown_vlines(p).count()
        + p.hlines.len()
        + usize::from(p.band.is_some())
        + shade_labels.len();
    let longest = p
        .series
        .iter()
        .map(|s| &s.label)
        .chain(shown_vlines(p).map(|(_, l)| &l.1))
        .chain(p.hlines.iter().map(|l| &l.1))
        .chain(&p.band.iter().map(|b| b.1.clone()).collect::<Vec<_>>())
        .map(|l| l.chars().count())
        .chain(shade_labels.iter().map(|l| l.chars().count()))
        .max()
        .unwrap_or(0);
    let (aw, ah) = area.dim_in_pixel();
    let legend_box = (
        (longest as f64 * 6.6 + 48.0) / (f64::from(aw) - 100.0).max(1.0),
        (entries as f64 * 17.0 + 14.0) / (f64::from(ah) - 80.0).max(1.0),
    );
    // Each clipped peak gets a note in a strip above the plot, never over the data (on screen).
    let peaks = match clip {
        Some(c) => p
            .series
            .iter()
            .zip(&pts)
            .filter(|(s, _)| s.note)
            .filter(|(s, sp)| clipped_peak(s, sp, c).is_some())
            .count(),
        None => 0,
    };
    let (mut corner, covered) = legend_corner(&pts, &[], (x0, x1), (y0, y1), legend_box);
    // For print the legend is a strip above the plot, never over the data.
    let strip = page.is_print() && p.legend == Legend::Corner;
    if !strip && p.legend == Legend::Corner && covered > 0 && legend_box.1 < 0.35 && clip.is_none()
    {
        let grow = (y1 - y0) * legend_box.1 / (1.0 - legend_box.1);
        y1 += if p.log_y { grow.ceil() } else { grow };
        corner = SeriesLabelPosition::UpperRight;
    }
    let span = y1 - y0;
    let z = |px: u32| page.scaled(px);
    let (title_area, area) = area.split_vertically(z(28));
    draw_title(&title_area, page, &p.title, p.marks_by_hand)?;
    let area = if strip {
        let mut samples = legend_samples(p);
        samples.retain(|(_, label)| !named.contains(label));
        let (w, _) = area.dim_in_pixel();
        let (_, rows) = strip_layout(page, &samples, w);
        let (top, rest) = area.split_vertically(z(18) * rows as u32 + z(4));
        draw_strip(&top, page, &samples)?;
        rest
    } else {
        area
    };
    // For print, where the chart's height is fixed, the notes stay inside the plot.
    let (note_area, area) = if peaks > 0 && !page.is_print() {
        let (top, rest) = area.split_vertically(z(16) * peaks as u32 + z(4));
        (Some(top), rest)
    } else {
        (None, area)
    };
    let y_labels = if page.is_print() { 64 } else { 78 };
    let mut chart = ChartBuilder::on(&area)
        .margin(z(8))
        .margin_top(z(4))
        .x_label_area_size(z(34))
        .y_label_area_size(z(y_labels))
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
    let mut mesh = axes(&mut chart, page, ("time t [s]", &p.y_label), (13, 14));
    mesh.y_label_formatter(&y_fmt).x_label_formatter(&x_fmt);
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
        let ink = BLACK.mix(0.45);
        if !labelled.contains(&sh.label) {
            labelled.push(sh.label.clone());
            let (c, hatch) = (sh.color.mix(2.5), sh.hatch);
            anno.label(sh.label.as_str()).legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + Rectangle::new([(0, -5), (24, 5)], c.filled())
                    + Hatch {
                        corners: [(0, -5), (if hatch { 24 } else { 0 }, 5)],
                        color: ink,
                    }
            });
        }
        if sh.hatch {
            chart.draw_series([Hatch {
                corners: [(a, y1), (b, y0)],
                color: ink,
            }])?;
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
        let style = RGBColor(44, 160, 44).stroke_width(page.ink(2));
        let (d, g) = (page.ink(8), page.ink(5));
        chart
            .draw_series(DashedLineSeries::new([(x0, v), (x1, v)], d, g, style))?
            .label(label.as_str())
            .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], d, g, style));
    }
    for (k, (t, label)) in p.vlines.iter().enumerate() {
        if *t < x0 || *t > x1 {
            continue;
        }
        let style = if k == 0 {
            BLACK.mix(0.6).stroke_width(page.ink(2))
        } else {
            color(4 + k).stroke_width(page.ink(2))
        };
        let (d, g) = if k == 0 {
            (1000, 1)
        } else {
            (page.ink(6), page.ink(4))
        };
        chart
            .draw_series(DashedLineSeries::new([(*t, y0), (*t, y1)], d, g, style))?
            .label(label.as_str())
            .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], d, g, style));
    }
    let n_series = p.series.len().max(1);
    let zoom = page.zoom();
    let mut notes_drawn = 0;
    for (k, (s, pts)) in p.series.iter().zip(&pts).enumerate() {
        if pts.is_empty() {
            continue;
        }
        let shown: Vec<(f64, f64)> = match clip {
            Some(c) => pts.iter().map(|&(x, y)| (x, y.clamp(-c, c))).collect(),
            None => pts.clone(),
        };
        let style = s.color.stroke_width(page.ink(s.width));
        let anno = match s.dash.pattern() {
            None => chart.draw_series(LineSeries::new(shown.iter().copied(), style))?,
            Some((d, g)) => chart.draw_series(DashedLineSeries::new(
                shown.iter().copied(),
                page.ink(d),
                page.ink(g),
                style,
            ))?,
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
                zoom,
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
                zoom,
            }))?;
        }
        if let Some(c) = clip.filter(|_| s.note) {
            // Mark the clipped peak of this series with its value.
            if let Some((t, v)) = clipped_peak(s, pts, c) {
                let edge = v.clamp(-c, c);
                let arrow = if v > 0.0 { "▲" } else { "▼" };
                // On screen, notes stack in the strip above the plot, one row each, level with
                // their peak; for print, into the plot from its top or bottom edge.
                let rank = notes_drawn;
                notes_drawn += 1;
                let zi = |px: i32| (f64::from(px) * zoom).round() as i32;
                let name = if n_series > 1 {
                    format!("{}: ", short_name(&s.label))
                } else {
                    String::new()
                };
                let (value, at) = (significant(v), secs(t));
                let notes = [
                    format!("{arrow} {name}peak {value} at t = {at} (clipped)"),
                    format!("{arrow} {name}peak {value} at t = {at}"),
                    format!("{arrow} {name}{value} at {at}"),
                ];
                // The note runs to the right of the peak, or to its left near the right edge;
                // for print, where the text is large against the plot, the other side or a
                // shorter note when it would leave the plot.
                let mut left = note_to_the_left(t, (x0, x1));
                let mut note = notes[0].clone();
                let (px, _) = chart.backend_coord(&(t, edge));
                if page.is_print() {
                    let width = |n: &str| strip_text_width(page, n.chars().count()) as i32;
                    let (span, _) = chart.plotting_area().get_pixel_range();
                    let room = |l: bool| {
                        if l {
                            px - span.start - zi(24)
                        } else {
                            span.end - px - zi(24)
                        }
                    };
                    if width(&notes[0]) > room(left) && room(!left) > room(left) {
                        left = !left;
                    }
                    note = notes
                        .iter()
                        .find(|n| width(n) <= room(left))
                        .unwrap_or(&notes[2])
                        .clone();
                }
                // Black text (the marker has the line's colour): readable in grayscale and for
                // the lighter lines.
                let font = page.font(12).color(&BLACK);
                if let Some(strip) = &note_area {
                    // The peak keeps a marker in the line's colour at the plot's edge.
                    chart.draw_series([EmptyElement::at((t, edge))
                        + TriangleMarker::new((0, 0), zi(6) as u32, s.color.filled())])?;
                    let x = px - strip.get_base_pixel().0;
                    let (x, h) = if left {
                        (x + zi(4), HPos::Right)
                    } else {
                        (x - zi(4), HPos::Left)
                    };
                    let text = font.pos(Pos::new(h, VPos::Top));
                    strip.draw(&Text::new(note, (x, zi(2 + 16 * rank)), text))?;
                    continue;
                }
                let dy = if v > 0.0 {
                    zi(4 + 16 * rank)
                } else {
                    zi(-18 - 16 * rank)
                };
                let (dx, h) = if left {
                    (zi(-24), HPos::Right)
                } else {
                    (zi(24), HPos::Left)
                };
                let text = font.pos(Pos::new(h, VPos::Top));
                // A light backing keeps the note readable across grid and marker lines.
                let per_char = if page.is_print() { 7.0 } else { 6.4 };
                let w = (note.chars().count() as f64 * per_char * zoom) as i32 + zi(4);
                let (a, b) = if left {
                    (dx - w, dx + zi(2))
                } else {
                    (dx - zi(2), dx + w)
                };
                chart.draw_series([EmptyElement::at((t, edge))
                    + Rectangle::new(
                        [(a, dy - zi(1)), (b, dy + zi(14))],
                        WHITE.mix(0.8).filled(),
                    )
                    + TriangleMarker::new((0, 0), zi(6) as u32, s.color.filled())
                    + Text::new(note, (dx, dy), text)])?;
            }
        }
    }
    match p.legend {
        Legend::Corner if !strip => legend(&mut chart, page, corner, 12),
        _ => Ok(()),
    }
}

/// What a legend entry shows before its text.
#[derive(Debug, Clone, Copy)]
enum Sample {
    /// A line with its dash pattern and marker.
    Line(Dash, Marker, RGBAColor, u32),
    /// A dashed line of `(dash, gap)`.
    Dashed((u32, u32), RGBAColor),
    /// A filled box, hatched or not.
    Fill(RGBAColor, bool),
}

/// The legend entries of `p` in the order the corner legend lists them.
fn legend_samples(p: &Panel) -> Vec<(Sample, String)> {
    let mut out: Vec<(Sample, String)> = Vec::new();
    for sh in &p.shades {
        if !out.iter().any(|(_, l)| *l == sh.label) {
            out.push((Sample::Fill(sh.color.mix(2.5), sh.hatch), sh.label.clone()));
        }
    }
    if let Some((_, label)) = &p.band {
        out.push((
            Sample::Fill(RGBColor(44, 160, 44).mix(0.3), false),
            label.clone(),
        ));
    }
    for (_, label) in &p.hlines {
        out.push((
            Sample::Dashed((8, 5), RGBColor(44, 160, 44).to_rgba()),
            label.clone(),
        ));
    }
    for (k, (_, label)) in shown_vlines(p) {
        let sample = if k == 0 {
            Sample::Line(Dash::Solid, Marker::None, BLACK.mix(0.6), 2)
        } else {
            Sample::Dashed((6, 4), color(4 + k))
        };
        out.push((sample, label.clone()));
    }
    for s in p.series.iter().filter(|s| !s.label.is_empty()) {
        out.push((
            Sample::Line(s.dash, s.marker, s.color, s.width),
            s.label.clone(),
        ));
    }
    out
}

/// Width of `chars` characters of legend text [px] (the bundled font at the legend's size).
fn strip_text_width(page: &FigureStyle, chars: usize) -> u32 {
    (chars as f64 * 7.0 * page.zoom()) as u32
}

/// One entry of the legend strip: where it goes and its text, broken into lines.
struct StripEntry {
    x: u32,
    row: usize,
    lines: Vec<String>,
}

/// The legend strip of `samples` over `width` px: entries side by side, wrapping onto new rows;
/// a label wider than a row is broken at spaces onto lines of its own, so no text leaves the
/// figure. Returns the entries and the number of rows.
fn strip_layout(
    page: &FigureStyle,
    samples: &[(Sample, String)],
    width: u32,
) -> (Vec<StripEntry>, usize) {
    let (left, sample, gap) = (page.scaled(8), page.scaled(34), page.scaled(14));
    let room = width.saturating_sub(left + sample + gap);
    let (mut entries, mut row, mut x) = (Vec::with_capacity(samples.len()), 0, left);
    for (_, label) in samples {
        let lines = wrap(label, page, room);
        let text = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0);
        let w = sample + strip_text_width(page, text) + gap;
        if x + w > width && x > left {
            row += 1;
            x = left;
        }
        let extra = lines.len().saturating_sub(1);
        entries.push(StripEntry { x, row, lines });
        x += w;
        if extra > 0 {
            row += extra + 1;
            x = left;
        }
    }
    let rows = if x > left { row + 1 } else { row.max(1) };
    (entries, rows)
}

/// `label` broken at spaces into lines of at most `room` px (a word longer than that stays
/// whole on its line).
fn wrap(label: &str, page: &FigureStyle, room: u32) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in label.split(' ') {
        let n = line.chars().count() + 1 + word.chars().count();
        if !line.is_empty() && strip_text_width(page, n) > room {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    lines.push(line);
    lines
}

/// The legend as rows of entries across `area`, laid out by [`strip_layout`].
fn draw_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    page: &FigureStyle,
    samples: &[(Sample, String)],
) -> Drawn<DB> {
    let (w, _) = area.dim_in_pixel();
    let z = |px: u32| page.scaled(px) as i32;
    let font = page.font(12);
    let (entries, _) = strip_layout(page, samples, w);
    for ((sample, _), entry) in samples.iter().zip(&entries) {
        let (x, y) = (entry.x as i32, z(11) + z(18) * entry.row as i32);
        let line = z(24);
        match *sample {
            Sample::Line(dash, marker, color, width) => area.draw(&Glyph {
                at: (x, y),
                marker,
                dash: Some(dash),
                color,
                width,
                zoom: page.zoom(),
            })?,
            Sample::Dashed((d, g), color) => area.draw(&DashedPathElement::new(
                vec![(x, y), (x + line, y)],
                page.ink(d),
                page.ink(g),
                color.stroke_width(page.ink(2)),
            ))?,
            Sample::Fill(color, hatch) => {
                area.draw(&Rectangle::new(
                    [(x, y - z(5)), (x + line, y + z(5))],
                    color.filled(),
                ))?;
                if hatch {
                    area.draw(&Hatch {
                        corners: [(x, y - z(5)), (x + line, y + z(5))],
                        color: BLACK.mix(0.45),
                    })?;
                }
            }
        }
        for (k, text) in entry.lines.iter().enumerate() {
            area.draw(&Text::new(
                text.clone(),
                (x + z(30), y + z(18) * k as i32),
                TextStyle::from(font.clone()).pos(Pos::new(HPos::Left, VPos::Center)),
            ))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_names_each_line_in_one_legend() {
        let dir = std::env::temp_dir().join(format!("host-sim-legend-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let line = |legend| Panel {
            series: vec![Series::styled(
                "agent 7".into(),
                0,
                vec![(0.0, 0.0), (1.0, 1.0)],
            )],
            legend,
            ..Panel::default()
        };
        let style = FigureStyle::px(400, 400);
        let legends = |panels: &[Panel]| {
            render(&dir, "legend", panels, (2, 1), style).expect("figure");
            let svg = std::fs::read_to_string(dir.join("legend.svg")).expect("svg");
            svg.matches("agent 7").count()
        };
        // Panels naming the same lines share the first one's legend.
        assert_eq!(legends(&[line(Legend::Corner), line(Legend::Corner)]), 1);
        assert_eq!(legends(&[line(Legend::Corner), line(Legend::Hidden)]), 1);
        let mut other = line(Legend::Corner);
        other.series[0].label = "agent 8".into();
        render(
            &dir,
            "legend",
            &[line(Legend::Corner), other],
            (2, 1),
            style,
        )
        .expect("figure");
        let svg = std::fs::read_to_string(dir.join("legend.svg")).expect("svg");
        assert_eq!(
            svg.matches("agent 8").count(),
            1,
            "a new line gets its legend"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_print_figure_names_each_legend_entry_once() {
        let dir = std::env::temp_dir().join(format!("host-sim-strip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let panel = |label: &str| Panel {
            series: vec![Series::styled(
                label.into(),
                0,
                vec![(0.0, 0.0), (2.0, 1.0)],
            )],
            vlines: vec![(1.0, "deadline 1 s".into())],
            ..Panel::default()
        };
        let output = crate::figure::Output {
            formats: [false, true, false],
            print: Some(crate::figure::Print {
                width_mm: 85.0,
                chart_mm: Some(40.0),
                font_pt: 8.0,
                dpi: 100.0,
            }),
            window: (None, None),
        };
        let style = FigureStyle::px(1000, 560).with(output);
        render(
            &dir,
            "strip",
            &[panel("agent 1"), panel("agent 2")],
            (2, 1),
            style,
        )
        .expect("figure");
        let svg = std::fs::read_to_string(dir.join("strip.svg")).expect("svg");
        assert_eq!(
            svg.matches("deadline 1 s").count(),
            1,
            "the shared line once"
        );
        assert_eq!(
            svg.matches("agent 2").count(),
            1,
            "the new line in its panel"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_legend_label_wider_than_the_strip_is_broken_onto_lines_that_fit() {
        let style = FigureStyle::px(400, 400);
        let sample = || Sample::Fill(BLACK.mix(0.2), false);
        let long = "2Tₛ (example2) = t_prescribed (example2-baseline) = 1 s: common instant";
        let samples = [
            (sample(), "y_d".to_string()),
            (sample(), long.to_string()),
            (sample(), "y₁".to_string()),
        ];
        let (entries, rows) = strip_layout(&style, &samples, 400);
        let room = 400 - style.scaled(8) - style.scaled(34) - style.scaled(14);
        assert!(entries[1].lines.len() > 1, "{:?}", entries[1].lines);
        assert_eq!(entries[1].lines.join(" "), long);
        for line in &entries[1].lines {
            assert!(
                strip_text_width(&style, line.chars().count()) <= room,
                "{line}"
            );
        }
        assert_eq!((entries[0].row, entries[1].row), (0, 1));
        assert_eq!(entries[2].row, 1 + entries[1].lines.len());
        assert_eq!(rows, entries[2].row + 1);
    }

    #[test]
    fn a_vertical_line_outside_the_time_window_is_not_in_the_legend() {
        let p = Panel {
            series: vec![Series::styled(
                "agent 1".into(),
                0,
                vec![(0.0, 0.0), (10.0, 1.0)],
            )],
            vlines: vec![(4.0, "2Tₛ = 4 s".into()), (7.5, "settled".into())],
            x_from: Some(5.0),
            ..Panel::default()
        };
        let labels: Vec<String> = legend_samples(&p).into_iter().map(|(_, l)| l).collect();
        assert_eq!(labels, ["settled", "agent 1"]);
        assert_eq!(legend_entries(&p), ["agent 1", "settled"]);
        // The line inside keeps the style of its place in the list.
        assert_eq!(shown_vlines(&p).map(|(k, _)| k).collect::<Vec<_>>(), [1]);
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
