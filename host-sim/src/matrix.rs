//! The fault matrix (`host-sim fault-matrix`): one scenario under network, sensor and actuator
//! faults, every cell with `[safety]` as the scenario has it and with it off.
//!
//! A cell adds one fault to the scenario (its own actuator faults stay): a silent neighbour or
//! leader, a babbling node, frame loss, corruption with bus-off, a NaN sensor burst, or all
//! actuators of one agent stuck (beyond Assumption 4). Faults with a window start at
//! `t_f = 2 T_s + 1 s` (after the predefined time); the run ends `2·2T_s + 1 s` after the window.
//!
//! Per cell: divergence (time), `max |u|` from `t_f` on, the largest error from `2 T_s` after
//! the fault's end to the end of the run, and the time from the fault's end until the error is
//! back in the band for good. The band is the same scenario's own: 1.1 × its max error after
//! `2 T_s` without the added fault (at least `settle_band`), so "back in band" means "back to
//! what this configuration achieves anyway". Loss and corruption last the whole run: their
//! recovery time is counted from 0 (a settling time).

use std::{fmt::Write as _, path::Path};

use plotters::{
    coord::{ranged1d::Ranged, Shift},
    prelude::*,
};
use rayon::prelude::*;
use serde::Serialize;

use crate::run::{run, RunOptions};
use consensus_hil::network::spec::{EventName, NetworkEvent, NetworkKind};
use consensus_plot::{
    error::Result,
    figure::{
        self,
        chart::{axes, cartesian, free_corner, legend, Frame},
        drawing_error, grid,
        text::short,
        DrawResult, Figure, FigureStyle, Format,
    },
};
use consensus_sim::{
    faults::{Agents, FaultKind, FaultRule, SensorFault},
    scenario::{self, Scenario},
};

/// One cell: a fault added to the scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// Fault family, e.g. `babbling node`.
    pub fault: String,
    /// Where and how long, e.g. `agent 2, 0.5 s`.
    pub case: String,
    /// Start of the fault \[s\] (0 for whole-run faults).
    pub from: f64,
    /// End of the fault \[s\] (0 for whole-run faults).
    pub until: f64,
    #[serde(skip)]
    apply: Fault,
}

#[derive(Debug, Clone)]
enum Fault {
    Event(NetworkEvent),
    Loss(f64),
    Corruption(f64),
    Sensor(SensorFault),
    StuckAgent(i64),
}

/// What one run of a cell gave.
#[derive(Debug, Clone, Serialize)]
pub struct CellResult {
    /// The cell.
    #[serde(flatten)]
    pub cell: Cell,
    /// `[safety]` on in this run.
    pub safety: bool,
    /// Time of divergence, if any.
    pub diverged_at: Option<f64>,
    /// `max |u|` over agents and actuators from the fault's start on (whole run for
    /// whole-run faults).
    pub max_abs_u: f64,
    /// `max |u|` over every sample of the run (`≤ u_max` with a magnitude limit).
    pub max_abs_u_run: f64,
    /// Largest error from `until + 2 T_s` to the end (null if diverged).
    pub max_error_after_recovery: Option<f64>,
    /// Seconds from `until` until the error is back in the band for good (null: not back by
    /// the end, or diverged); 0 when it never left the band.
    pub back_in_band_s: Option<f64>,
    /// The band used.
    pub band: f64,
    /// Share of actuator-samples at a limit.
    pub saturated_fraction: f64,
}

impl CellResult {
    /// The goal: no divergence, back in band within `2 T_s` after the fault ends
    /// (and, with a magnitude limit, every `|u| ≤ u_max`: checked by the caller).
    pub fn recovered_within(&self, limit: f64) -> bool {
        self.diverged_at.is_none() && self.back_in_band_s.is_some_and(|t| t <= limit)
    }
}

/// The cells of the matrix for `n_agents` agents, windowed faults starting at `t_f`.
pub fn cells(n_agents: usize, t_f: f64) -> Vec<Cell> {
    let mut v = Vec::new();
    // A windowed fault of duration `d` (`None`: the whole run), built by `make(from, until)`.
    let mut add = |fault: &str, case: String, d: Option<f64>, make: &dyn Fn(f64, f64) -> Fault| {
        let (from, until) = d.map_or((0.0, 0.0), |d| (t_f, t_f + d));
        v.push(Cell {
            fault: fault.into(),
            case,
            from,
            until,
            apply: make(from, until),
        });
    };
    let event = |agent: Option<i64>, node: Option<i64>, kind: EventName| {
        move |from: f64, until: f64| {
            Fault::Event(NetworkEvent {
                agent,
                node,
                kind,
                id: None,
                from,
                until: Some(until),
                periods: None,
            })
        }
    };
    for agent in [1, 3] {
        for d in [0.1, 0.5, 1.0, 3.0] {
            let make = event(Some(agent), None, EventName::Silent);
            add(
                "silent neighbour",
                format!("agent {agent}, {d} s"),
                Some(d),
                &make,
            );
        }
    }
    for d in [0.1, 0.5, 1.0, 3.0] {
        let make = event(None, Some(0), EventName::Silent);
        add("silent leader", format!("{d} s"), Some(d), &make);
    }
    for agent in 1..=n_agents as i64 {
        for d in [0.2, 0.5, 1.0, 2.0] {
            let make = event(Some(agent), None, EventName::Babbling);
            add(
                "babbling node",
                format!("agent {agent}, {d} s"),
                Some(d),
                &make,
            );
        }
    }
    for p in [0.0, 0.1, 0.3, 0.6] {
        let case = format!("{:.0} %, whole run", 100.0 * p);
        add("frame loss", case, None, &|_, _| Fault::Loss(p));
    }
    for p in [0.1, 0.3] {
        let case = format!("{:.0} %, whole run", 100.0 * p);
        add("corruption, bus-off", case, None, &|_, _| {
            Fault::Corruption(p)
        });
    }
    for agent in [2, 4] {
        for d in [0.01, 0.1, 0.5] {
            let make = |from, until| Fault::Sensor(SensorFault { agent, from, until });
            add(
                "NaN sensor burst",
                format!("agent {agent}, {d} s"),
                Some(d),
                &make,
            );
        }
    }
    let stuck = |_, _| Fault::StuckAgent(2);
    add(
        "all actuators stuck",
        "agent 2, 0.5 s".into(),
        Some(0.5),
        &stuck,
    );
    v
}

/// The fault start `t_f` and the run's end for a cell ending at `until`.
pub fn timing(ts: f64) -> (f64, impl Fn(f64) -> f64) {
    let two_ts = 2.0 * ts;
    let t_f = two_ts + 1.0;
    (t_f, move |until: f64| until.max(t_f) + 2.0 * two_ts + 1.0)
}

fn with_fault(base: &Scenario, cell: &Cell, safety: bool, t_end: f64) -> Scenario {
    let mut s = base.clone();
    s.simulation.t_end = t_end;
    s.safety.enabled = safety && base.safety.enabled;
    match &cell.apply {
        Fault::Event(e) => s.network.event.push(e.clone()),
        Fault::Loss(p) => s.network.loss = *p,
        Fault::Corruption(p) => s.network.corruption = *p,
        Fault::Sensor(f) => {
            s.faults.enabled = true;
            s.faults.sensor.push(*f);
        }
        Fault::StuckAgent(agent) => {
            s.faults.enabled = true;
            s.faults.beyond_assumption4 = true;
            for actuator in 1..=2 {
                s.faults.rule.push(FaultRule {
                    agents: Agents::List(vec![*agent]),
                    actuator,
                    kind: FaultKind::Stuck,
                    gain: None,
                    bias: Some(0.0),
                    amplitude: Some(1.0),
                    omega: Some(1.0),
                    start: cell.from,
                    period: None,
                    length: Some(cell.until - cell.from),
                });
            }
        }
    }
    s
}

/// Runs the reference (no added fault) and every cell, with safety as in `base` and, with
/// `compare_off`, also off. Needs `[network] kind = "can"` (the network faults act on the bus).
pub fn run_matrix(base: &Scenario, cells: &[Cell], compare_off: bool) -> Result<Vec<CellResult>> {
    if base.network.kind != NetworkKind::Can {
        return Err(consensus_plot::error::Error::invalid(
            "network.kind",
            "the fault matrix needs kind = \"can\" (its faults act on the bus)",
        ));
    }
    let ts = base.controller.ts;
    let (_, end) = timing(ts);
    let two_ts = 2.0 * ts;
    let modes: Vec<bool> = match (base.safety.enabled, compare_off) {
        (true, true) => vec![true, false],
        (on, _) => vec![on],
    };
    // Reference runs (no added fault) give each mode's band.
    let bands: Vec<(bool, f64)> = modes
        .par_iter()
        .map(|&on| {
            let mut s = base.clone();
            s.simulation.t_end = end(0.0);
            s.safety.enabled = on;
            let setup = scenario::validate(s)?;
            let r = run(&setup, &RunOptions::default())?;
            let e = r.summary.max_error_after_predefined_time.unwrap_or(0.0);
            let band = if r.summary.diverged {
                base.simulation.settle_band
            } else {
                (1.1 * e).max(base.simulation.settle_band)
            };
            Ok((on, band))
        })
        .collect::<Result<_>>()?;
    let jobs: Vec<(&Cell, bool, f64)> = cells
        .iter()
        .flat_map(|c| bands.iter().map(move |&(on, band)| (c, on, band)))
        .collect();
    jobs.par_iter()
        .map(|&(cell, on, band)| {
            let setup = scenario::validate(with_fault(base, cell, on, end(cell.until)))?;
            let opts = RunOptions {
                worst: true,
                ..RunOptions::default()
            };
            let r = run(&setup, &opts)?;
            let trace = r.worst.unwrap_or_default();
            let diverged_at = r.summary.divergence.map(|d| d.time);
            let max_abs_u = trace
                .iter()
                .filter(|p| p[0] >= cell.from)
                .map(|p| p[2])
                .fold(0.0, f64::max);
            let max_abs_u_run = trace.iter().map(|p| p[2]).fold(0.0, f64::max);
            let (max_error_after_recovery, back_in_band_s) = if diverged_at.is_some() {
                (None, None)
            } else {
                let after = trace
                    .iter()
                    .filter(|p| p[0] >= cell.until + two_ts)
                    .map(|p| p[1])
                    .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))));
                let last_out = trace
                    .iter()
                    .filter(|p| p[0] >= cell.until && p[1] > band)
                    .map(|p| p[0])
                    .next_back();
                let h = setup.scenario.simulation.h;
                let back = match (last_out, trace.last()) {
                    (None, _) => Some(0.0),
                    (Some(t), Some(last)) if t < last[0] => Some(t + h - cell.until),
                    _ => None,
                };
                (after, back)
            };
            Ok(CellResult {
                cell: cell.clone(),
                safety: on,
                diverged_at,
                max_abs_u,
                max_abs_u_run,
                max_error_after_recovery,
                back_in_band_s,
                band,
                saturated_fraction: r.summary.saturated_fraction,
            })
        })
        .collect()
}

/// 0-based cell number of each result (the modes of one cell are consecutive).
fn numbers(results: &[CellResult]) -> Vec<usize> {
    let mut out = Vec::with_capacity(results.len());
    for (j, r) in results.iter().enumerate() {
        let same = j > 0
            && results[j - 1].cell.fault == r.cell.fault
            && results[j - 1].cell.case == r.cell.case;
        let k = match out.last() {
            Some(&k) if same => k,
            Some(&k) => k + 1,
            None => 0,
        };
        out.push(k);
    }
    out
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.digits$}"))
}

/// The matrix as a Markdown table (one row per cell, safety on and off side by side).
pub fn markdown(results: &[CellResult], two_ts: f64, u_max: Option<f64>) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| # | fault | case | safety | diverged at | max \\|u\\| from fault | max error after recovery | back in band after [s] | goal (≤ 2Ts = {two_ts} s, \\|u\\| ≤ u_max) |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for (r, k) in results.iter().zip(numbers(results)) {
        let goal = if !r.safety {
            "–".to_string()
        } else {
            let u_ok = u_max.is_none_or(|m| r.max_abs_u_run <= m);
            if r.recovered_within(two_ts) && u_ok {
                "met".into()
            } else {
                "**not met**".into()
            }
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.1} | {} | {} | {} |",
            k + 1,
            r.cell.fault,
            r.cell.case,
            if r.safety { "on" } else { "off" },
            opt(r.diverged_at, 3),
            r.max_abs_u,
            opt(r.max_error_after_recovery, 3),
            opt(r.back_in_band_s, 3),
            goal
        );
    }
    out
}

/// The words of a fault-matrix or torque-limit figure: its title (the scheme as the paper
/// names it, never a scenario's name), the predefined time `2 T_s` \[s\], and the plant's output
/// and input units.
#[derive(Debug, Clone, Copy)]
pub struct FigureText<'a> {
    /// Title, e.g. `Example 2, predefined-time (proposed)`.
    pub title: &'a str,
    /// `2 T_s` \[s\].
    pub two_ts: f64,
    /// Output and input units, e.g. `("rad", "N·m")`.
    pub units: (&'a str, &'a str),
}

/// `matrix.<ext>` in `dir` (every format of `output`): per cell (numbered as in the table),
/// `max |u|` from the fault's start (log scale) and the time back in band, safety on and off;
/// diverged runs on the top edge.
pub fn draw(
    dir: &Path,
    output: figure::Output,
    results: &[CellResult],
    u_max: Option<f64>,
    text: FigureText<'_>,
) -> Result<()> {
    let chart = MatrixFigure {
        results,
        u_max,
        text,
    };
    let style = FigureStyle::px(1400, 900).with(output);
    figure::save_png_and_svg(dir, "matrix", &style, &chart)
}

struct MatrixFigure<'a> {
    results: &'a [CellResult],
    u_max: Option<f64>,
    text: FigureText<'a>,
}

/// Captions 18 px, margin 10, room for the tick labels.
const FRAME: Frame = Frame {
    caption: 18,
    margin: 10,
    x_labels: 30,
    y_labels: 70,
};

/// The reference line of a chart (`u_max`, `2 Ts`) as a legend entry.
fn reference_line<'a, DB, X, Y>(
    c: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    (x0, x1): (f64, f64),
    y: f64,
    label: String,
) -> DrawResult
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let style = BLACK.mix(0.6).stroke_width(2);
    c.draw_series(LineSeries::new([(x0, y), (x1, y)], style))
        .map_err(drawing_error)?
        .label(label)
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
    Ok(())
}

impl Figure for MatrixFigure<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        _: Format,
    ) -> DrawResult {
        let (results, two_ts, title) = (self.results, self.text.two_ts, self.text.title);
        let (_, u_unit) = self.text.units;
        let n = results.iter().filter(|r| r.safety).count().max(1);
        let halves = grid(root, (2, 1));
        let index = |k: usize| (k + 1) as f64;
        let cell_no = numbers(results);
        let cells = cell_no.last().map_or(n, |k| k + 1);
        let x_end = cells as f64 + 1.0;
        let u_hi = results
            .iter()
            .filter(|r| r.diverged_at.is_none())
            .map(|r| r.max_abs_u)
            .filter(|u| u.is_finite())
            .fold(1.0, f64::max)
            * 30.0;
        // Two empty decades below the smallest value: room for the legend under the data.
        let u_lo = results
            .iter()
            .map(|r| r.max_abs_u)
            .filter(|u| u.is_finite() && *u > 0.0)
            .fold(u_hi, f64::min)
            .max(1e-6)
            / 100.0;
        let caption = format!("{title}: largest command from the fault's start");
        let mut c = cartesian(
            &halves[0],
            style,
            &caption,
            FRAME,
            (0.0..x_end, (u_lo..u_hi).log_scale()),
        )
        .map_err(drawing_error)?;
        let u_label = format!("max |u| [{u_unit}] (log scale)");
        axes(
            &mut c,
            style,
            ("fault case (numbered as in the matrix table)", &u_label),
            (13, 13),
        )
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| short(*v))
        .draw()
        .map_err(drawing_error)?;
        // Everything drawn, for the legend's corner (log axis as its logarithm).
        let mut drawn: Vec<(f64, f64)> = Vec::new();
        let across = |y: f64| (0..=40).map(move |k| (x_end * f64::from(k) / 40.0, y));
        if let Some(m) = self.u_max {
            drawn.extend(across(m.log10()));
            reference_line(
                &mut c,
                (0.0, x_end),
                m,
                match u_unit {
                    "–" | "" => format!("command limit u_max = {m}"),
                    u => format!("command limit u_max = {m} {u}"),
                },
            )?;
        }
        for (on, color, name) in [(false, RED, "safety off"), (true, BLUE, "safety on")] {
            let pts: Vec<(f64, f64, bool)> = results
                .iter()
                .zip(&cell_no)
                .filter(|(r, _)| r.safety == on)
                .map(|(r, &k)| {
                    let x = index(k) + if on { 0.15 } else { -0.15 };
                    if r.diverged_at.is_some() {
                        (x, u_hi / 1.5, true)
                    } else {
                        (x, r.max_abs_u.max(u_lo), false)
                    }
                })
                .collect();
            drawn.extend(pts.iter().map(|&(x, y, _)| (x, y.log10())));
            c.draw_series(
                pts.iter()
                    .filter(|p| !p.2)
                    .map(|&(x, y, _)| Circle::new((x, y), 4, color.filled())),
            )
            .map_err(drawing_error)?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 9, y), 4, color.filled()));
            let diverged: Vec<_> = pts.iter().filter(|p| p.2).collect();
            if !diverged.is_empty() {
                c.draw_series(
                    diverged
                        .iter()
                        .map(|&&(x, y, _)| Cross::new((x, y), 6, color.stroke_width(2))),
                )
                .map_err(drawing_error)?
                .label(format!("{name}: diverged (drawn at the top)"))
                .legend(move |(x, y)| Cross::new((x + 9, y), 5, color.stroke_width(2)));
            }
        }
        let corner = free_corner(drawn, 0.0..x_end, u_lo.log10()..u_hi.log10());
        legend(&mut c, style, corner, 13).map_err(drawing_error)?;

        let t_hi = results
            .iter()
            .filter_map(|r| r.back_in_band_s)
            .fold(2.0 * two_ts, f64::max)
            * 1.15;
        let band = results.first().map_or(f64::NAN, |r| r.band);
        let caption = format!(
            "time back in band b = {} after the fault ends (whole-run faults: from 0)",
            short(band)
        );
        let mut c = cartesian(&halves[1], style, &caption, FRAME, (0.0..x_end, 0.0..t_hi))
            .map_err(drawing_error)?;
        axes(
            &mut c,
            style,
            (
                "fault case (numbered as in the matrix table)",
                "time back in band [s]",
            ),
            (13, 13),
        )
        .x_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(drawing_error)?;
        reference_line(
            &mut c,
            (0.0, x_end),
            two_ts,
            format!("predefined time 2Tₛ = {two_ts} s"),
        )?;
        let mut drawn: Vec<(f64, f64)> = across(two_ts).collect();
        for (on, color, name) in [(false, RED, "safety off"), (true, BLUE, "safety on")] {
            let pts: Vec<(f64, Option<f64>)> = results
                .iter()
                .zip(&cell_no)
                .filter(|(r, _)| r.safety == on)
                .map(|(r, &k)| {
                    (
                        index(k) + if on { 0.15 } else { -0.15 },
                        r.back_in_band_s.filter(|_| r.diverged_at.is_none()),
                    )
                })
                .collect();
            drawn.extend(pts.iter().map(|&(x, y)| (x, y.unwrap_or(t_hi / 1.08))));
            c.draw_series(
                pts.iter()
                    .filter_map(|&(x, y)| y.map(|y| Circle::new((x, y), 4, color.filled()))),
            )
            .map_err(drawing_error)?;
            let never: Vec<_> = pts.iter().filter(|p| p.1.is_none()).collect();
            if !never.is_empty() {
                c.draw_series(
                    never
                        .iter()
                        .map(|&&(x, _)| Cross::new((x, t_hi / 1.08), 6, color.stroke_width(2))),
                )
                .map_err(drawing_error)?
                .label(format!("{name}: diverged or never back (drawn at the top)"))
                .legend(move |(x, y)| Cross::new((x + 9, y), 5, color.stroke_width(2)));
            }
        }
        let corner = free_corner(drawn, 0.0..x_end, 0.0..t_hi);
        legend(&mut c, style, corner, 13).map_err(drawing_error)
    }
}

/// One run of a torque-limit sweep (`host-sim/tests/torque_limit.rs`).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LimitPoint {
    /// `u_max`.
    pub u_max: f64,
    /// `settling_time` of the run (band `settle_band`).
    pub settling_time: Option<f64>,
    /// `max_error_after_predefined_time`.
    pub max_error_after_predefined_time: Option<f64>,
    /// Share of actuator-samples at the limit.
    pub saturated_fraction: f64,
}

/// Settling time into the band `band` and max error after `2 T_s` against `u_max` (log x),
/// with the `2 T_s` line, into `path` (`.png`, `.svg` or `.pdf`).
pub fn draw_limit_sweep(
    path: &Path,
    points: &[LimitPoint],
    band: f64,
    text: FigureText<'_>,
) -> Result<()> {
    let chart = LimitSweep { points, band, text };
    figure::save(path, &FigureStyle::px(1100, 800), &chart)
}

struct LimitSweep<'a> {
    points: &'a [LimitPoint],
    band: f64,
    text: FigureText<'a>,
}

impl Figure for LimitSweep<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        _: Format,
    ) -> DrawResult {
        let (points, two_ts) = (self.points, self.text.two_ts);
        let (y_unit, u_unit) = self.text.units;
        let (lo, hi) = points.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p.u_max), hi.max(p.u_max))
        });
        let t_hi = points
            .iter()
            .filter_map(|p| p.settling_time)
            .fold(2.0 * two_ts, f64::max)
            * 1.1;
        let e_hi = points
            .iter()
            .filter_map(|p| p.max_error_after_predefined_time)
            .fold(0.1, f64::max)
            * 1.1;
        let halves = grid(root, (2, 1));
        let settling: fn(&LimitPoint) -> Option<f64> = |p| p.settling_time;
        let error: fn(&LimitPoint) -> Option<f64> = |p| p.max_error_after_predefined_time;
        let band = format!("b = {} {y_unit}", short(self.band));
        let panels = [
            (format!("settling time into {band} [s]"), t_hi, settling),
            (format!("max |yᵢ − y_d| after 2Tₛ [{y_unit}]"), e_hi, error),
        ];
        let x_label = format!("command limit u_max per actuator [{u_unit}] (log scale)");
        for (k, ((label, y_hi, value), area)) in panels.into_iter().zip(&halves).enumerate() {
            let caption = if k == 0 {
                format!("{}: settling time under a command limit", self.text.title)
            } else {
                "tracking error after the predefined time 2Tₛ".to_string()
            };
            let frame = Frame {
                x_labels: 34,
                ..FRAME
            };
            // Ticks at 1, 2, 5 × 10ᵏ across the range: the log axis alone labels only decades.
            let ticks: Vec<f64> = (-3..=6)
                .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
                .filter(|v| (lo / 1.2..=hi * 1.2).contains(v))
                .collect();
            let x_range = (lo / 1.2..hi * 1.2).log_scale().with_key_points(ticks);
            let mut c = cartesian(area, style, &caption, frame, (x_range, 0.0..y_hi))
                .map_err(drawing_error)?;
            axes(&mut c, style, (&x_label, &label), (13, 13))
                .x_label_formatter(&|v| short(*v))
                .draw()
                .map_err(drawing_error)?;
            if k == 0 {
                reference_line(
                    &mut c,
                    (lo / 1.2, hi * 1.2),
                    two_ts,
                    format!("predefined time 2Tₛ = {two_ts} s"),
                )?;
            }
            let pts: Vec<(f64, f64)> = points
                .iter()
                .filter_map(|p| value(p).map(|v| (p.u_max, v)))
                .collect();
            // Everything drawn, for the legend's corner (log axis as its logarithm).
            let (x0, x1) = ((lo / 1.2).log10(), (hi * 1.2).log10());
            let mut drawn: Vec<(f64, f64)> = points
                .iter()
                .map(|p| (p.u_max.log10(), value(p).unwrap_or(y_hi / 1.1)))
                .collect();
            if k == 0 {
                drawn.extend((0..=40).map(|j| (x0 + (x1 - x0) * f64::from(j) / 40.0, two_ts)));
            }
            c.draw_series(LineSeries::new(pts.clone(), BLUE.stroke_width(2)))
                .map_err(drawing_error)?;
            c.draw_series(pts.iter().map(|&p| Circle::new(p, 4, BLUE.filled())))
                .map_err(drawing_error)?
                .label("one run per command limit")
                .legend(|(x, y)| Circle::new((x + 9, y), 4, BLUE.filled()));
            let never: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| value(p).is_none())
                .map(|p| (p.u_max, y_hi / 1.1))
                .collect();
            if !never.is_empty() {
                let what = if k == 0 {
                    "never settled (drawn at the top)"
                } else {
                    "no value (drawn at the top)"
                };
                c.draw_series(never.iter().map(|&p| Cross::new(p, 6, RED.stroke_width(2))))
                    .map_err(drawing_error)?
                    .label(what)
                    .legend(|(x, y)| Cross::new((x + 9, y), 5, RED.stroke_width(2)));
            }
            let corner = free_corner(drawn, x0..x1, 0.0..y_hi);
            legend(&mut c, style, corner, 13).map_err(drawing_error)?;
        }
        Ok(())
    }
}
