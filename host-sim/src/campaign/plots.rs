//! Campaign figures from `results.csv`: a heatmap over a 2-D grid (diverged and invalid cells
//! marked), a line over a 1-D grid, and for Monte Carlo a histogram of the metric beside the
//! empirical CDF of the settling time with the predefined time `2 T_s` marked.

use std::{collections::BTreeMap, ops::Range, path::Path, path::PathBuf};

use plotters::{
    coord::{ranged1d::SegmentValue, types::RangedCoordf64, Shift},
    prelude::*,
    style::colors::colormaps::ViridisRGB,
};

use crate::{
    campaign::spec::{Axis, CampaignFile},
    error::{Error, Result},
    figure::{
        self,
        chart::{axes, cartesian, legend, Frame},
        drawing_error as err, grid,
        text::{short, tick_label},
        DrawResult, Figure, FigureStyle, Format,
    },
    scenario::Scenario,
};

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
}

impl Table {
    fn new(
        metric: &str,
        base_ts: f64,
        header: &[String],
        rows: &BTreeMap<u64, String>,
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
        };
        for line in rows.values() {
            let mut rdr = csv::ReaderBuilder::new()
                .has_headers(false)
                .from_reader(line.as_bytes());
            let rec = rdr
                .records()
                .next()
                .and_then(|r| r.ok())
                .ok_or_else(|| Error::Io(format!("results.csv: bad row {line}")))?;
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
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let mut t = Table::new(&file.plot.metric, base.controller.ts, header, rows)?;
    t.units = units(base);
    let mut written = Vec::new();
    if file.draws > 1 || (file.axis.is_empty() && !file.sample.is_empty()) {
        let p = out.join("montecarlo.png");
        figure::save(
            &p,
            &FigureStyle::px(1300, 560),
            &CampaignFigure::MonteCarlo(&t),
        )?;
        written.push(p);
    }
    let t = if file.draws > 1 {
        t.per_point(file.draws as usize)
    } else {
        t
    };
    if file.axis.len() == 1 {
        let p = out.join("line.png");
        let chart = CampaignFigure::Line(&t, &file.axis[0]);
        figure::save(&p, &FigureStyle::px(1000, 600), &chart)?;
        written.push(p);
    } else if file.axis.len() == 2 {
        let p = out.join("map.png");
        written.push(map(&p, &t, &file.axis[0], &file.axis[1])?);
    } else if let [first, a, b] = &file.axis[..] {
        // One map per value of the first (slowest) axis: its cells are consecutive.
        let chunk = a.values.len() * b.values.len();
        for (n, v) in first.values.iter().enumerate() {
            let what = format!("{} = {}", first.key, axis_label(v));
            let part = t.slice(n * chunk..(n + 1) * chunk, &what);
            let p = out.join(format!("map-{}.png", n + 1));
            written.push(map(&p, &part, a, b)?);
        }
    }
    Ok(written)
}

/// The heatmap of `t` over axes `a` × `b` into `p`.
fn map(p: &Path, t: &Table, a: &Axis, b: &Axis) -> Result<PathBuf> {
    let style = FigureStyle::px(
        (300 + 100 * a.values.len()).clamp(1000, 1800) as u32,
        (200 + 60 * b.values.len()).clamp(500, 1400) as u32,
    );
    figure::save(p, &style, &CampaignFigure::Heatmap(t, a, b))?;
    Ok(p.to_path_buf())
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
    let mut chart = cartesian(
        &main,
        style,
        &format!("{metric} over {} x {}{}", a.key, b.key, t.summary),
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
        if metric == "settling_time" {
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
        &format!("{} over {}{}", t.metric, a.key, t.summary),
        Frame {
            caption: 20,
            ..FRAME
        },
        (xr, yr.clone()),
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
        .label(t.metric.as_str())
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
    if settle {
        let grey = BLACK.mix(0.55).stroke_width(2);
        let pt: Vec<(f64, f64)> = xs
            .iter()
            .zip(&t.ts)
            .map(|(&x, &ts)| (xscale.to(x), yscale.to(2.0 * ts)))
            .collect();
        c.draw_series(LineSeries::new(pt, grey))
            .map_err(err)?
            .label("predefined time 2Ts")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], grey));
    }
    legend(&mut c, style, SeriesLabelPosition::UpperRight, 13).map_err(err)
}

/// The axis text of `key` (a results.csv column or a scenario key): a name and its unit,
/// `[y]` and `[u]` written as the plant's output and input units.
fn label(key: &str, (y, u): (&str, &str)) -> String {
    let (name, unit) = match key {
        "max_error_after_predefined_time" => ("max |yᵢ − y_d| after 2Tₛ", y.to_string()),
        "settling_time" => ("settling time", "s".into()),
        "divergence_time" => ("divergence time", "s".into()),
        "max_abs_u" => ("max |u|", u.to_string()),
        "total_u_energy" => ("control energy Σ u² h", format!("({u})²·s")),
        "controller.ts" => ("Tₛ", "s".into()),
        "simulation.h" => ("sample period h", "s".into()),
        "controller.t_prescribed" => ("t_prescribed", "s".into()),
        "controller.c1" => ("c₁", "–".into()),
        "controller.c2" => ("c₂", "–".into()),
        "quantizer.rho" => ("quantizer ρ", "–".into()),
        "quantizer.u_min" => ("quantizer u_min", u.to_string()),
        "simulation.settle_band" => ("band b", y.to_string()),
        "clock.drift_ppm" => ("clock drift", "ppm".into()),
        "clock.jitter_us" => ("clock jitter", "µs".into()),
        "clock.offset_us" => ("clock offset", "µs".into()),
        _ => return param_label(key, (y, u)),
    };
    format!("{name} [{unit}]")
}

/// The axis text of a key of the controller's parameter table (`controller.zeta`,
/// `controller.a_check[2]`): the key and its unit; any other key as it is.
fn param_label(key: &str, (y, u): (&str, &str)) -> String {
    let base = key.split_once('[').map_or(key, |(b, _)| b);
    let Some(p) = controller_core::param::Param::ALL
        .iter()
        .find(|p| p.key() == base)
    else {
        return key.to_string();
    };
    let unit = p
        .spec()
        .unit
        .replace('`', "")
        .replace("[y]", y)
        .replace("[u]", u)
        .replace(['[', ']'], "");
    format!("{key} [{unit}]")
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
/// over all finished runs (never settled or diverged count as not settled), with `2 T_s`.
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
        t.metric,
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
        .filter(|(c, _)| **c != Cell::Invalid)
        .filter_map(|(_, s)| *s)
        .collect();
    settled.sort_by(f64::total_cmp);
    let finished = n - invalid;
    let by_predefined = t
        .settling
        .iter()
        .zip(&t.ts)
        .filter(|(s, ts)| s.is_some_and(|s| s <= 2.0 * **ts))
        .count();
    let share = |k: usize| k as f64 / finished.max(1) as f64;
    let tmax = settled
        .last()
        .copied()
        .unwrap_or(0.0)
        .max(predefined)
        .max(1e-9)
        * 1.05;
    let caption = format!(
        "settling time: {:.1} % settle, {:.1} % by 2Ts",
        100.0 * share(settled.len()),
        100.0 * share(by_predefined)
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
        &t.label("settling_time"),
        "share of runs settled (empirical CDF)",
    )?;
    let mut step = vec![(0.0, 0.0)];
    for (k, &s) in settled.iter().enumerate() {
        step.push((s, share(k)));
        step.push((s, share(k + 1)));
    }
    step.push((tmax, share(settled.len())));
    c.draw_series(LineSeries::new(step, blue.stroke_width(2)))
        .map_err(err)?
        .label("empirical CDF")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], blue.stroke_width(2)));
    let grey = BLACK.mix(0.55).stroke_width(2);
    c.draw_series(LineSeries::new(
        [(predefined, 0.0), (predefined, 1.02)],
        grey,
    ))
    .map_err(err)?
    .label(format!("predefined time 2Ts = {}", short(predefined)))
    .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], grey));
    legend(&mut c, style, SeriesLabelPosition::LowerRight, 13).map_err(err)
}

#[cfg(test)]
mod tests {
    use super::label;

    #[test]
    fn axis_labels_carry_units() {
        let units = ("rad", "N·m");
        assert_eq!(label("clock.drift_ppm", units), "clock drift [ppm]");
        assert_eq!(label("clock.jitter_us", units), "clock jitter [µs]");
        assert_eq!(label("controller.ts", units), "Tₛ [s]");
        assert_eq!(label("controller.zeta", units), "controller.zeta [–]");
        assert_eq!(label("safety.du_max", units), "safety.du_max [N·m/s]");
        assert_eq!(label("controller.gamma", units), "controller.gamma [x_n]");
        assert_eq!(
            label("controller.a_check[2]", units),
            "controller.a_check[2] [–]"
        );
        assert_eq!(label("network.loss", units), "network.loss");
    }
}
