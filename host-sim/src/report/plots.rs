//! The paper's figures (Figs. 2–12) of a run, as PNG and SVG: tracking, tracking errors with
//! the `±b` band and the `2 Tₛ` line, `u`, `q` and `u − q` with the fault windows, adaptive
//! estimates; drawn as [`consensus_plot::figure::panel`]s. Curves that may coincide (agents 2 and 3 of the
//! paper's graph hear the same neighbour) differ in colour, dash pattern and marker.

use std::path::Path;

use plotters::style::{Color, BLACK};

use consensus_plot::{
    error::Result,
    figure::{
        panel::{color, render, Marker, Panel, Series, Shade},
        text::{secs, sub, trim_number},
        FigureStyle,
    },
};
use consensus_sim::{
    faults::FaultSchedule,
    scenario::Setup,
    sim::{Observer, SampleView},
};

/// Most agents drawn in one figure (the first ones).
pub const MAX_PLOTTED_AGENTS: usize = 8;
/// Points per series kept for plotting.
pub(crate) const TARGET_POINTS: u64 = 4000;

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
    /// `q^f(u_{i,l})`, the actuator output after the faults (eq. (3)), likewise.
    pub qf: Vec<Vec<f64>>,
    /// The fault schedule `q^f` is computed with.
    faults: Option<FaultSchedule>,
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
            qf: vec![Vec::new(); a * m],
            est: [
                vec![Vec::new(); a],
                vec![Vec::new(); a],
                vec![Vec::new(); a],
            ],
            peaks: vec![0.0; 4 * a * m],
            extremes: vec![(0.0, 0.0); 4 * a * m],
            ..Self::default()
        }
    }

    /// `q^f` through `faults` (without it, `q^f = q`).
    pub fn with_faults(self, faults: FaultSchedule) -> Self {
        Self {
            faults: Some(faults),
            ..self
        }
    }

    /// `(t, ys)` pairs.
    pub fn points(&self, ys: &[f64]) -> Vec<(f64, f64)> {
        self.t.iter().copied().zip(ys.iter().copied()).collect()
    }

    /// Writes `tracking`, `errors`, `inputs`, `estimates` (`.png`, `.svg`) into `dir`.
    pub fn draw(&self, dir: &Path, setup: &Setup, settling_time: Option<f64>) -> Result<()> {
        let name = &setup.figure_title();
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
        render(
            dir,
            "tracking",
            &[tracking],
            (1, 1),
            FigureStyle::px(1000, 560).with(setup.figures()),
        )?;

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
        render(
            dir,
            "errors",
            &[full, log],
            (2, 1),
            FigureStyle::px(1000, 800).with(setup.figures()),
        )?;

        // For print, one column read agent by agent and a figure per agent (Figs. 3–6); on
        // screen, two agents side by side.
        let print = setup.figures().print.is_some();
        let mut inputs = Vec::new();
        if print {
            for i in 0..self.agents {
                let pair = [
                    self.input_panel(setup, i, u_unit, &vline),
                    self.quantization_panel(setup, i, u_unit),
                ];
                render(
                    dir,
                    &format!("inputs-{}", i + 1),
                    &pair,
                    (2, 1),
                    FigureStyle::px(1400, 540).with(setup.figures()),
                )?;
                inputs.extend(pair);
            }
        } else {
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
        }
        let cols = if self.agents > 1 && !print { 2 } else { 1 };
        let rows = inputs.len().div_ceil(cols).max(1);
        render(
            dir,
            "inputs",
            &inputs,
            (rows, cols),
            FigureStyle::px(1400, 270 * rows as u32).with(setup.figures()),
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
        render(
            dir,
            "estimates",
            &panels,
            (3, 1),
            FigureStyle::px(1000, 900).with(setup.figures()),
        )
    }

    /// Whether `peak` of `q^f` is the extreme of `q` of some actuator of agent `i`.
    fn peak_equals_q(&self, i: usize, peak: &(f64, f64)) -> bool {
        (0..self.m).any(|l| self.extreme(i, l, 1) == Some(*peak))
    }

    /// The exact extreme of `kind` (0 `u`, 1 `q`, 2 `u − q`, 3 `q^f`) of actuator `l` of
    /// agent `i`.
    pub fn extreme(&self, i: usize, l: usize, kind: usize) -> Option<(f64, f64)> {
        self.extremes.get(4 * (i * self.m + l) + kind).copied()
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
        let first = series.len();
        for mut s in self.actuator_series((&self.qf, 3), i, "qᶠ(u#)", first) {
            s.color = BLACK.to_rgba();
            s.width = 1;
            // A peak where no fault acts is q's: q's note names it.
            s.note = !s.peak.is_some_and(|p| self.peak_equals_q(i, &p));
            series.push(s);
        }
        Panel {
            title: format!(
                "agent {}: command u, quantized q, actuator output qᶠ (shaded: faults)",
                i + 1
            ),
            y_label: format!("u, q, qᶠ [{u_unit}]"),
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
            // Gray levels and hatching tell the kinds apart in grayscale print.
            let (c, kind) = if total {
                (BLACK.mix(0.16), "total loss")
            } else {
                (BLACK.mix(0.05), "partial loss")
            };
            shades.push(Shade {
                from,
                to,
                color: c,
                label: format!("actuator {} fault: {kind}", l + 1),
                hatch: !total,
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
                let j = 4 * (i * self.m + l);
                let (u, q) = (f64::from(o.u[l]), f64::from(o.q[l]));
                let qf = self.faults.as_ref().map_or(q, |f| f.apply(i, l, s.t, q));
                for (d, v) in [u, q, u - q, qf].into_iter().enumerate() {
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
                self.u[j].push(std::mem::take(&mut self.peaks[4 * j]));
                self.q[j].push(std::mem::take(&mut self.peaks[4 * j + 1]));
                self.uq[j].push(std::mem::take(&mut self.peaks[4 * j + 2]));
                self.qf[j].push(std::mem::take(&mut self.peaks[4 * j + 3]));
            }
            self.est[0][i].push(f64::from(o.estimates.mu));
            self.est[1][i].push(f64::from(o.estimates.xi));
            self.est[2][i].push(f64::from(o.estimates.lambda));
        }
        Ok(())
    }
}
