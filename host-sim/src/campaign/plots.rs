//! Campaign figures from `results.csv`: a heatmap over a 2-D grid (diverged and invalid cells
//! marked), a line over a 1-D grid, and for Monte Carlo a histogram of the metric beside the
//! empirical CDF of the settling time with the predefined time `2 T_s` marked.

use std::{
    collections::BTreeMap,
    ops::Range,
    path::{Path, PathBuf},
};

use plotters::{
    coord::{ranged1d::SegmentValue, types::RangedCoordf64, Shift},
    prelude::*,
    style::colors::colormaps::ViridisRGB,
};

use crate::campaign::{
    results::Records,
    spec::{Axis, CampaignFile},
};
use consensus_plot::{
    error::{Error, Result},
    figure::{
        self,
        chart::{axes, cartesian, free_corner, legend, Frame},
        drawing_error as err, grid,
        text::{short, tick_label},
        DrawResult, Figure, FigureStyle, Format,
    },
};
use consensus_sim::scenario::Scenario;
use controller_core::param::Param;

/// What a row says about the plotted metric.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cell {
    Value(f64),
    /// Finished without a value (e.g. never settled).
    Missing,
    Diverged,
    Invalid,
}

/// The columns the figures read, per row in run order.
struct Table {
    metric: String,
    /// How a cell came about (per grid point of a campaign with draws: the median).
    summary: String,
    cells: Vec<Cell>,
    /// Per cell: diverged runs of all runs behind it (one run per cell without draws).
    diverged: Vec<(usize, usize)>,
    settling: Vec<Option<f64>>,
    ts: Vec<f64>,
    /// Output and input units of the plant.
    units: (String, String),
    /// The settling band `b` of the runs (the base scenario's).
    band: f64,
}

impl Table {
    fn new(
        metric: &str,
        base_ts: f64,
        header: &[String],
        rows: &BTreeMap<u64, String>,
        recs: &Records,
    ) -> Result<Self> {
        let col = |n: &str| header.iter().position(|h| h == n);
        let need = |n: &str| col(n).ok_or_else(|| Error::Io(format!("results.csv: no column {n}")));
        let (m, d, s, st) = (
            need(metric)?,
            need("diverged")?,
            need("status")?,
            need("settling_time")?,
        );
        let ts_col = col("controller.ts");
        let mut t = Self {
            metric: metric.into(),
            summary: String::new(),
            cells: Vec::new(),
            diverged: Vec::new(),
            settling: Vec::new(),
            ts: Vec::new(),
            units: ("–".into(), "–".into()),
            band: f64::NAN,
        };
        for (run, rec) in recs {
            let rec = rec.as_ref().ok_or_else(|| {
                let line = rows.get(run).map_or("", String::as_str);
                Error::Io(format!("results.csv: bad row {line}"))
            })?;
            let num = |i: usize| rec.get(i).and_then(|v| v.parse::<f64>().ok());
            t.cells.push(if rec.get(s) == Some("invalid") {
                Cell::Invalid
            } else if rec.get(d) == Some("true") {
                Cell::Diverged
            } else {
                num(m).map_or(Cell::Missing, Cell::Value)
            });
            t.settling.push(num(st));
            t.ts.push(ts_col.and_then(num).unwrap_or(base_ts));
            let div = usize::from(t.cells.last() == Some(&Cell::Diverged));
            t.diverged.push((div, 1));
        }
        Ok(t)
    }

    /// The axis text of `key` with this plant's units.
    fn label(&self, key: &str) -> String {
        label(key, (&self.units.0, &self.units.1))
    }

    /// The name of `key` in a title (no unit).
    fn name(&self, key: &str) -> String {
        named(key, (&self.units.0, &self.units.1)).0
    }

    /// The settling band as figure text, `b = 0.05 rad`.
    fn band_text(&self) -> String {
        match self.units.0.as_str() {
            "–" | "" => format!("b = {}", short(self.band)),
            u => format!("b = {} {u}", short(self.band)),
        }
    }

    /// One cell per grid point: the median of the metric over its `draws` runs (diverged if
    /// none has a value and one diverged; invalid if all are).
    fn per_point(&self, draws: usize) -> Self {
        let mut t = Self {
            metric: self.metric.clone(),
            summary: format!(", median of {draws} draws"),
            cells: Vec::new(),
            diverged: Vec::new(),
            settling: Vec::new(),
            ts: Vec::new(),
            units: self.units.clone(),
            band: self.band,
        };
        for (k, group) in self.cells.chunks(draws.max(1)).enumerate() {
            let mut v: Vec<f64> = group
                .iter()
                .filter_map(|c| match c {
                    Cell::Value(x) => Some(*x),
                    _ => None,
                })
                .collect();
            v.sort_by(f64::total_cmp);
            let div = group.iter().filter(|c| **c == Cell::Diverged).count();
            t.cells.push(if let Some(&m) = v.get(v.len() / 2) {
                Cell::Value(if v.len().is_multiple_of(2) {
                    0.5 * (v[v.len() / 2 - 1] + m)
                } else {
                    m
                })
            } else if div > 0 {
                Cell::Diverged
            } else if group.iter().all(|c| *c == Cell::Invalid) {
                Cell::Invalid
            } else {
                Cell::Missing
            });
            t.diverged.push((div, group.len()));
            t.settling.push(None);
            t.ts.push(self.ts.get(k * draws).copied().unwrap_or(f64::NAN));
        }
        t
    }

    /// The cells `range` (in run order), named `what` in the caption.
    fn slice(&self, range: Range<usize>, what: &str) -> Self {
        let take = |v: &[f64]| v.get(range.clone()).unwrap_or_default().to_vec();
        Self {
            metric: self.metric.clone(),
            summary: format!("{}, {what}", self.summary),
            cells: self.cells.get(range.clone()).unwrap_or_default().to_vec(),
            diverged: self
                .diverged
                .get(range.clone())
                .unwrap_or_default()
                .to_vec(),
            settling: self
                .settling
                .get(range.clone())
                .unwrap_or_default()
                .to_vec(),
            ts: take(&self.ts),
            units: self.units.clone(),
            band: self.band,
        }
    }

    fn values(&self) -> impl Iterator<Item = f64> + '_ {
        self.cells.iter().filter_map(|c| match c {
            Cell::Value(v) if v.is_finite() => Some(*v),
            _ => None,
        })
    }
}

/// Decimal or log10 scale for a set of values.
#[derive(Debug, Clone, Copy)]
struct Scale {
    log: bool,
}

impl Scale {
    fn for_values(v: impl Iterator<Item = f64> + Clone) -> Self {
        let lo = v.clone().fold(f64::INFINITY, f64::min);
        let hi = v.fold(f64::NEG_INFINITY, f64::max);
        Self {
            log: lo > 0.0 && hi / lo > 20.0,
        }
    }
    fn to(self, v: f64) -> f64 {
        if self.log {
            v.log10()
        } else {
            v
        }
    }
    fn from(self, v: f64) -> f64 {
        if self.log {
            10f64.powf(v)
        } else {
            v
        }
    }
    fn range(self, v: impl Iterator<Item = f64>) -> Range<f64> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for x in v.map(|x| self.to(x)).filter(|x| x.is_finite()) {
            lo = lo.min(x);
            hi = hi.max(x);
        }
        if !lo.is_finite() {
            return 0.0..1.0;
        }
        let pad = ((hi - lo) * 0.05).max(1e-9 + lo.abs().max(hi.abs()) * 1e-3);
        lo - pad..hi + pad
    }
}

/// Writes the figures that fit the campaign's shape; returns their paths.
pub fn draw(
    file: &CampaignFile,
    base: &Scenario,
    header: &[String],
    rows: &BTreeMap<u64, String>,
    recs: &Records,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let mut t = Table::new(&file.plot.metric, base.controller.ts, header, rows, recs)?;
    t.units = units(base);
    t.band = base.simulation.settle_band;
    // `[figures]` of the base scenario, the campaign's `set` applied: formats and print size.
    let output = base.figures.output(base.simulation.t_end)?;
    let mut written = Vec::new();
    if file.draws > 1 || (file.axis.is_empty() && !file.sample.is_empty()) {
        let style = FigureStyle::px(1300, 560).with(output);
        written.extend(save(
            out,
            "montecarlo",
            &style,
            &CampaignFigure::MonteCarlo(&t),
        )?);
    }
    let t = if file.draws > 1 {
        t.per_point(file.draws as usize)
    } else {
        t
    };
    if file.axis.len() == 1 {
        let chart = CampaignFigure::Line(&t, &file.axis[0]);
        let style = FigureStyle::px(1000, 600).with(output);
        written.extend(save(out, "line", &style, &chart)?);
    } else if file.axis.len() == 2 {
        written.extend(map(out, "map", output, &t, &file.axis[0], &file.axis[1])?);
    } else if let [first, a, b] = &file.axis[..] {
        // One map per value of the first (slowest) axis: its cells are consecutive.
        let chunk = a.values.len() * b.values.len();
        for (n, v) in first.values.iter().enumerate() {
            let what = format!("{} = {}", t.name(&first.key), axis_label(v));
            let part = t.slice(n * chunk..(n + 1) * chunk, &what);
            let stem = format!("map-{}", n + 1);
            written.extend(map(out, &stem, output, &part, a, b)?);
        }
    }
    Ok(written)
}

/// `out/stem.<ext>` in every format of the style; returns the paths written.
fn save(
    out: &Path,
    stem: &str,
    style: &FigureStyle,
    figure: &CampaignFigure<'_>,
) -> Result<Vec<PathBuf>> {
    figure::save_png_and_svg(out, stem, style, figure)?;
    Ok(style
        .output()
        .formats()
        .map(|f| out.join(format!("{stem}.{}", f.extension())))
        .collect())
}

/// The heatmap of `t` over axes `a` × `b` as `out/stem.<ext>`.
fn map(
    out: &Path,
    stem: &str,
    output: figure::Output,
    t: &Table,
    a: &Axis,
    b: &Axis,
) -> Result<Vec<PathBuf>> {
    let style = FigureStyle::px(
        (300 + 100 * a.values.len()).clamp(1000, 1800) as u32,
        (200 + 60 * b.values.len()).clamp(500, 1400) as u32,
    )
    .with(output);
    save(out, stem, &style, &CampaignFigure::Heatmap(t, a, b))
}

/// The figures of a campaign.
enum CampaignFigure<'a> {
    /// The histogram and settling-time CDF of a Monte Carlo campaign.
    MonteCarlo(&'a Table),
    /// The metric over the one axis.
    Line(&'a Table, &'a Axis),
    /// The metric over the two axes.
    Heatmap(&'a Table, &'a Axis, &'a Axis),
}

impl Figure for CampaignFigure<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        _: Format,
    ) -> DrawResult {
        match *self {
            Self::MonteCarlo(t) => monte_carlo(root, style, t),
            Self::Line(t, a) => line(root, style, t, a),
            Self::Heatmap(t, a, b) => heatmap(root, style, t, a, b),
        }
    }
}

fn axis_number(v: &toml::Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}

fn axis_label(v: &toml::Value) -> String {
    axis_number(v).map_or_else(|| crate::campaign::spec::cell(v), short)
}

/// Heatmap: first axis across, second axis up; colour = metric (log10 when it spans decades).
fn heatmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    t: &Table,
    a: &Axis,
    b: &Axis,
) -> DrawResult {
    let (nx, ny) = (a.values.len(), b.values.len());
    let scale = Scale::for_values(t.values().collect::<Vec<_>>().into_iter());
    let vals: Vec<f64> = t.values().map(|v| scale.to(v)).collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo, hi)
    } else if lo.is_finite() {
        (lo - 0.5, lo + 0.5)
    } else {
        (0.0, 1.0)
    };
    let norm = |v: f64| ((scale.to(v) - lo) / (hi - lo)).clamp(0.0, 1.0);
    let (w, _) = root.dim_in_pixel();
    let (main, bar) = root.split_horizontally(w.saturating_sub(150));
    let metric = t.metric.as_str();
    let settle = metric == "settling_time";
    let note = if settle {
        format!(" (into {}; orange frame: settled by 2Tₛ)", t.band_text())
    } else {
        String::new()
    };
    let mut chart = cartesian(
        &main,
        style,
        &format!(
            "{} over {} × {}{}{note}",
            t.name(metric),
            t.name(&a.key),
            t.name(&b.key),
            t.summary
        ),
        Frame {
            caption: 18,
            ..FRAME
        },
        (
            (0..nx as i32 - 1).into_segmented(),
            (0..ny as i32 - 1).into_segmented(),
        ),
    )
    .map_err(err)?;
    let label = |axis: &Axis, v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(i) => axis
            .values
            .get(*i as usize)
            .map(axis_label)
            .unwrap_or_default(),
        _ => String::new(),
    };
    let xl = |v: &SegmentValue<i32>| label(a, v);
    let yl = |v: &SegmentValue<i32>| label(b, v);
    axes(
        &mut chart,
        style,
        (&t.label(&a.key), &t.label(&b.key)),
        (14, 16),
    )
    .disable_mesh()
    .x_labels(nx)
    .y_labels(ny)
    .x_label_formatter(&xl)
    .y_label_formatter(&yl)
    .draw()
    .map_err(err)?;
    let font = style.font(13);
    for (run, cell) in t.cells.iter().enumerate() {
        let (i, j) = ((run / ny) as i32, (run % ny) as i32);
        let (div, of) = t.diverged[run];
        let share = if of > 1 && div > 0 {
            format!(" ({div}/{of} div.)")
        } else {
            String::new()
        };
        let cell_at = |di: i32, dj: i32| (SegmentValue::Exact(i + di), SegmentValue::Exact(j + dj));
        let (fill, text, ink) = match cell {
            Cell::Value(v) => {
                let f = norm(*v);
                let c = ViridisRGB::get_color(f as f32);
                (c, short(*v) + &share, if f > 0.6 { BLACK } else { WHITE })
            }
            Cell::Missing => (WHITE, "none".into(), BLACK),
            Cell::Diverged => (RGBColor(200, 30, 30), format!("diverged{share}"), WHITE),
            Cell::Invalid => (RGBColor(190, 190, 190), "invalid".into(), BLACK),
        };
        chart
            .draw_series([Rectangle::new(
                [cell_at(0, 0), cell_at(1, 1)],
                fill.filled(),
            )])
            .map_err(err)?;
        chart
            .draw_series([Rectangle::new(
                [cell_at(0, 0), cell_at(1, 1)],
                WHITE.stroke_width(1),
            )])
            .map_err(err)?;
        if settle {
            if let Cell::Value(v) = cell {
                if *v <= 2.0 * t.ts[run] {
                    chart
                        .draw_series([Rectangle::new(
                            [cell_at(0, 0), cell_at(1, 1)],
                            RGBColor(255, 140, 0).stroke_width(4),
                        )])
                        .map_err(err)?;
                }
            }
        }
        if nx * ny <= 400 {
            let style = font
                .clone()
                .color(&ink)
                .pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                ));
            chart
                .draw_series([Text::new(
                    text,
                    (SegmentValue::CenterOf(i), SegmentValue::CenterOf(j)),
                    style,
                )])
                .map_err(err)?;
        }
    }
    colour_bar(&bar, style, (lo, hi), scale, &t.label(metric))
}

fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    (lo, hi): (f64, f64),
    scale: Scale,
    label: &str,
) -> DrawResult {
    // Linear: decimals to the tick step, so a narrow range gets distinct labels.
    let fmt = move |v: &f64| {
        if scale.log {
            short(scale.from(*v))
        } else {
            tick_label(*v, (lo, hi))
        }
    };
    let mut c = ChartBuilder::on(area)
        .margin_top(50)
        .margin_bottom(60)
        .margin_right(10)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..1.0, lo..hi)
        .map_err(err)?;
    c.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&fmt)
        .y_desc(with_scale(label, scale))
        .label_style(style.font(12))
        .draw()
        .map_err(err)?;
    let steps = 100;
    c.draw_series((0..steps).map(|k| {
        let a = lo + (hi - lo) * k as f64 / steps as f64;
        let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
        let col = ViridisRGB::get_color(k as f32 / (steps - 1) as f32);
        Rectangle::new([(0.0, a), (1.0, b)], col.filled())
    }))
    .map_err(err)?;
    Ok(())
}

/// Line over the one axis; diverged and invalid runs as markers along the top.
fn line<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    t: &Table,
    a: &Axis,
) -> DrawResult {
    let numeric = a.values.iter().all(|v| axis_number(v).is_some());
    let xs: Vec<f64> = a
        .values
        .iter()
        .enumerate()
        .map(|(i, v)| {
            if numeric {
                axis_number(v).unwrap_or(0.0)
            } else {
                i as f64
            }
        })
        .collect();
    let xscale = if numeric {
        Scale::for_values(xs.iter().copied())
    } else {
        Scale { log: false }
    };
    let yscale = Scale::for_values(t.values().collect::<Vec<_>>().into_iter());
    let mut yr = yscale.range(t.values());
    let settle = t.metric == "settling_time";
    if settle {
        let pt = t.ts.iter().map(|ts| 2.0 * ts).collect::<Vec<_>>();
        let r = yscale.range(t.values().chain(pt));
        yr = r;
    }
    let xr = xscale.range(xs.iter().copied());
    let top = yr.end - (yr.end - yr.start) * 0.03;
    let xf = move |v: &f64| {
        if numeric {
            short(xscale.from(*v))
        } else {
            a.values
                .get(v.round() as usize)
                .map(axis_label)
                .unwrap_or_default()
        }
    };
    let yf = move |v: &f64| short(yscale.from(*v));
    let mut c = cartesian(
        root,
        style,
        &format!(
            "{} over {}{}{}",
            t.name(&t.metric),
            t.name(&a.key),
            t.summary,
            if settle {
                format!(" (band {})", t.band_text())
            } else {
                String::new()
            }
        ),
        Frame {
            caption: 20,
            ..FRAME
        },
        (xr.clone(), yr.clone()),
    )
    .map_err(err)?;
    mesh(
        &mut c,
        style,
        &xf,
        &yf,
        &with_scale(&t.label(&a.key), xscale),
        &with_scale(&t.label(&t.metric), yscale),
    )?;
    let pts: Vec<(f64, f64)> = t
        .cells
        .iter()
        .zip(&xs)
        .filter_map(|(c, &x)| match c {
            Cell::Value(v) => Some((xscale.to(x), yscale.to(*v))),
            _ => None,
        })
        .collect();
    let blue = plotters::style::RGBColor(31, 119, 180);
    c.draw_series(LineSeries::new(pts.clone(), blue.stroke_width(2)))
        .map_err(err)?
        .label(t.name(&t.metric))
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], blue.stroke_width(2)));
    c.draw_series(pts.iter().map(|&p| Circle::new(p, 4, blue.filled())))
        .map_err(err)?;
    for (kind, colour, label) in [
        (Cell::Diverged, RGBColor(200, 30, 30), "diverged"),
        (Cell::Invalid, RGBColor(120, 120, 120), "invalid"),
        (
            Cell::Missing,
            RGBColor(255, 127, 14),
            "no value (e.g. never settled)",
        ),
    ] {
        let marks: Vec<(f64, f64)> = t
            .cells
            .iter()
            .zip(&xs)
            .filter(|(c, _)| **c == kind)
            .map(|(_, &x)| (xscale.to(x), top))
            .collect();
        if !marks.is_empty() {
            c.draw_series(
                marks
                    .iter()
                    .map(|&p| Cross::new(p, 7, colour.stroke_width(3))),
            )
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| Cross::new((x + 9, y), 6, colour.stroke_width(3)));
        }
    }
    // Everything drawn, for the legend's corner: the values, the markers along the top and
    // the 2Tₛ line (sampled).
    let mut drawn = pts.clone();
    drawn.extend(
        t.cells
            .iter()
            .zip(&xs)
            .filter(|(c, _)| !matches!(c, Cell::Value(_)))
            .map(|(_, &x)| (xscale.to(x), top)),
    );
    if settle {
        let grey = BLACK.mix(0.55).stroke_width(2);
        let pt: Vec<(f64, f64)> = xs
            .iter()
            .zip(&t.ts)
            .map(|(&x, &ts)| (xscale.to(x), yscale.to(2.0 * ts)))
            .collect();
        for w in pt.windows(2) {
            if let [(x0, y0), (x1, y1)] = *w {
                drawn.extend((0..=10).map(|k| {
                    let f = f64::from(k) / 10.0;
                    (x0 + f * (x1 - x0), y0 + f * (y1 - y0))
                }));
            }
        }
        c.draw_series(LineSeries::new(pt, grey))
            .map_err(err)?
            .label("predefined time 2Tₛ")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], grey));
    }
    let corner = free_corner(drawn, xr, yr);
    legend(&mut c, style, corner, 13).map_err(err)
}

/// The axis text of `key` (a results.csv column or a scenario key): its name and unit,
/// `[y]` and `[u]` written as the plant's output and input units.
fn label(key: &str, units: (&str, &str)) -> String {
    let (name, unit) = named(key, units);
    format!("{name} [{unit}]")
}

/// The name and unit of `key` as figure text: the metrics and the keys outside the
/// controller's parameter table here, every parameter through [`Param::label`] and its
/// [`Param::spec`] unit (`controller.a_check[2]`: the constant of step 2). A key known to
/// neither is written as words (`network.loss`: "network loss"), never as the key.
fn named(key: &str, (y, u): (&str, &str)) -> (String, String) {
    let (base, index) = key.split_once('[').map_or((key, ""), |(b, i)| (b, i));
    let (name, unit) = match base {
        "max_error_after_predefined_time" => ("max |yᵢ − y_d| after 2Tₛ", y.to_string()),
        "settling_time" => ("settling time", "s".into()),
        "divergence_time" => ("divergence time", "s".into()),
        "max_abs_u" => ("max |u|", u.to_string()),
        "total_u_energy" => ("control energy Σ u² h", format!("({u})²·s")),
        "simulation.settle_band" => ("settling band b", y.to_string()),
        "simulation.t_end" => ("run length", "s".into()),
        "clock.drift_ppm" => ("clock drift", "ppm".into()),
        "clock.jitter_us" => ("clock jitter", "µs".into()),
        "clock.offset_us" => ("clock offset", "µs".into()),
        "clock.sync" => ("clock synchronisation", "–".into()),
        "network.loss" => ("frame loss probability", "–".into()),
        "plant.x0" => ("initial state", y.to_string()),
        "faults.rule" => return (fault_words(index), "s".into()),
        _ => match Param::ALL.iter().find(|p| p.key() == base) {
            Some(p) => {
                let unit = p
                    .spec()
                    .unit
                    .replace('`', "")
                    .replace("[y]", y)
                    .replace("[u]", u)
                    .replace("[x_n]", "state xₙ")
                    .replace(['[', ']'], "");
                let step = index
                    .trim_end_matches(']')
                    .parse::<u32>()
                    .map_or_else(|_| String::new(), |j| format!(" (step {j})"));
                return (format!("{}{step}", p.label()), unit);
            }
            None => return (words(key), "–".into()),
        },
    };
    (name.to_string(), unit)
}

/// `faults.rule[1].start` as words: "fault rule 1 start".
fn fault_words(index: &str) -> String {
    let (k, field) = index.split_once(']').unwrap_or((index, ""));
    words(&format!("fault rule {k}{field}"))
}

/// A key as words: dots, underscores and brackets become spaces.
fn words(key: &str) -> String {
    key.replace(['.', '_', '[', ']'], " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The output and input units of the campaign's plant (as on the run figures).
fn units(base: &Scenario) -> (String, String) {
    let p = &base.plant;
    match p.model.as_str() {
        "manipulator" => ("rad".into(), "N·m".into()),
        "custom" => (
            p.state_units
                .as_ref()
                .and_then(|s| s.first().cloned())
                .unwrap_or_else(|| "–".into()),
            p.input_unit.clone().unwrap_or_else(|| "–".into()),
        ),
        _ => ("–".into(), "–".into()),
    }
}

fn with_scale(name: &str, s: Scale) -> String {
    if s.log {
        format!("{name} (log scale)")
    } else {
        name.to_string()
    }
}

/// Captions, margins and label areas of the line and Monte Carlo charts (the caption size is
/// each chart's own).
const FRAME: Frame = Frame {
    caption: 17,
    margin: 12,
    x_labels: 48,
    y_labels: 80,
};

/// The grid and axes of a line or Monte Carlo chart: value formatters and descriptions.
fn mesh<DB: DrawingBackend>(
    c: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    style: &FigureStyle,
    xf: &dyn Fn(&f64) -> String,
    yf: &dyn Fn(&f64) -> String,
    xd: &str,
    yd: &str,
) -> DrawResult {
    axes(c, style, (xd, yd), (13, 15))
        .x_label_formatter(xf)
        .y_label_formatter(yf)
        .draw()
        .map_err(err)
}

/// Histogram of the metric (runs with a value) and the empirical CDF of the settling time
/// into the band over all valid runs, with `2 T_s`; the runs that never settle and the
/// diverged runs are stacked above the CDF's end, each in its own colour and legend entry.
fn monte_carlo<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    t: &Table,
) -> DrawResult {
    let panels = grid(root, (1, 2));
    let frame = Frame {
        y_labels: 64,
        ..FRAME
    };
    let n = t.cells.len();
    let diverged = t.cells.iter().filter(|c| **c == Cell::Diverged).count();
    let invalid = t.cells.iter().filter(|c| **c == Cell::Invalid).count();
    let vals: Vec<f64> = t.values().collect();
    let scale = Scale::for_values(vals.iter().copied());
    let tv: Vec<f64> = vals.iter().map(|&v| scale.to(v)).collect();
    let xr = scale.range(vals.iter().copied());
    let bins = 40usize;
    let width = (xr.end - xr.start) / bins as f64;
    let mut counts = vec![0u32; bins];
    for v in &tv {
        let b = (((v - xr.start) / width) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let ymax = f64::from(counts.iter().copied().max().unwrap_or(1)).max(1.0) * 1.1;
    let xf = move |v: &f64| short(scale.from(*v));
    // Counts are whole: a tick between two whole numbers stays unlabelled.
    let yf = |v: &f64| {
        if (v - v.round()).abs() < 1e-9 {
            format!("{v:.0}")
        } else {
            String::new()
        }
    };
    let caption = format!(
        "{}: {} of {n} runs ({diverged} diverged, {invalid} invalid)",
        t.name(&t.metric),
        vals.len()
    );
    let mut c =
        cartesian(&panels[0], style, &caption, frame, (xr.clone(), 0.0..ymax)).map_err(err)?;
    mesh(
        &mut c,
        style,
        &xf,
        &yf,
        &with_scale(&t.label(&t.metric), scale),
        "runs",
    )?;
    let blue = RGBColor(31, 119, 180);
    c.draw_series(counts.iter().enumerate().map(|(b, &k)| {
        let x0 = xr.start + b as f64 * width;
        Rectangle::new(
            [(x0, 0.0), (x0 + width, f64::from(k))],
            blue.mix(0.75).filled(),
        )
    }))
    .map_err(err)?;
    let predefined = t.ts.iter().copied().fold(f64::NEG_INFINITY, f64::max) * 2.0;
    let mut settled: Vec<f64> = t
        .cells
        .iter()
        .zip(&t.settling)
        .filter(|(c, _)| !matches!(c, Cell::Invalid | Cell::Diverged))
        .filter_map(|(_, s)| *s)
        .collect();
    settled.sort_by(f64::total_cmp);
    let finished = n - invalid;
    let by_predefined = t
        .settling
        .iter()
        .zip(&t.ts)
        .zip(&t.cells)
        .filter(|((s, ts), c)| **c != Cell::Diverged && s.is_some_and(|s| s <= 2.0 * **ts))
        .count();
    let never = finished - diverged - settled.len();
    let share = |k: usize| k as f64 / finished.max(1) as f64;
    let tmax = settled
        .last()
        .copied()
        .unwrap_or(0.0)
        .max(predefined)
        .max(1e-9)
        * 1.05;
    let caption = format!(
        "settling into {}: {:.1} % settle ({:.1} % by 2Tₛ), {:.1} % never, {:.1} % diverge",
        t.band_text(),
        100.0 * share(settled.len()),
        100.0 * share(by_predefined),
        100.0 * share(never),
        100.0 * share(diverged)
    );
    let mut c =
        cartesian(&panels[1], style, &caption, frame, (0.0..tmax, 0.0..1.02)).map_err(err)?;
    let xf = |v: &f64| short(*v);
    let yf = |v: &f64| tick_label(*v, (0.0, 1.02));
    mesh(
        &mut c,
        style,
        &xf,
        &yf,
        &format!("settling time into {} [s]", t.band_text()),
        "share of runs settled (empirical CDF)",
    )?;
    let mut step = vec![(0.0, 0.0)];
    for (k, &s) in settled.iter().enumerate() {
        step.push((s, share(k)));
        step.push((s, share(k + 1)));
    }
    step.push((tmax, share(settled.len())));
    // Everything drawn, for the legend's corner: the CDF's corners, the 2Tₛ line and the
    // stacked shares at the right edge (sampled).
    let mut drawn = step.clone();
    drawn.extend((0..=20).map(|k| (predefined, 1.02 * f64::from(k) / 20.0)));
    drawn.extend((0..=20).map(|k| {
        (
            tmax,
            share(settled.len()) + (1.0 - share(settled.len())) * f64::from(k) / 20.0,
        )
    }));
    c.draw_series(LineSeries::new(step, blue.stroke_width(2)))
        .map_err(err)?
        .label("empirical CDF")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], blue.stroke_width(2)));
    // The runs without a settling time, stacked above the CDF's end at the right edge.
    let x0 = tmax * 0.985;
    let mut from = share(settled.len());
    for (k, colour, what) in [
        (never, RGBColor(255, 127, 14), "never settled"),
        (diverged, RGBColor(200, 30, 30), "diverged"),
    ] {
        if k == 0 {
            continue;
        }
        let to = from + share(k);
        c.draw_series([Rectangle::new([(x0, from), (tmax, to)], colour.filled())])
            .map_err(err)?
            .label(format!("{what} ({:.1} %)", 100.0 * share(k)))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], colour.filled()));
        from = to;
    }
    let grey = BLACK.mix(0.55).stroke_width(2);
    c.draw_series(LineSeries::new(
        [(predefined, 0.0), (predefined, 1.02)],
        grey,
    ))
    .map_err(err)?
    .label(format!("predefined time 2Tₛ = {} s", short(predefined)))
    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], grey));
    let corner = free_corner(drawn, 0.0..tmax, 0.0..1.02);
    legend(&mut c, style, corner, 13).map_err(err)
}

#[cfg(test)]
mod tests {
    use super::label;

    #[test]
    fn axis_labels_are_words_with_units() {
        let units = ("rad", "N·m");
        assert_eq!(label("clock.drift_ppm", units), "clock drift [ppm]");
        assert_eq!(label("clock.jitter_us", units), "clock jitter [µs]");
        assert_eq!(label("controller.ts", units), "predefined time Tₛ [s]");
        assert_eq!(label("controller.zeta", units), "gain constant ζ [–]");
        assert_eq!(label("controller.c1", units), "gain c₁ [1/s]");
        assert_eq!(label("safety.du_max", units), "command rate limit [N·m/s]");
        assert_eq!(
            label("controller.gamma", units),
            "smoothing width γ [state xₙ]"
        );
        assert_eq!(
            label("controller.a_check[2]", units),
            "MTN design constant ǎ (step 2) [–]"
        );
        assert_eq!(label("network.loss", units), "frame loss probability [–]");
        assert_eq!(
            label("faults.rule[1].start", units),
            "fault rule 1 start [s]"
        );
        assert_eq!(label("network.bit_rate", units), "network bit rate [–]");
    }
}
