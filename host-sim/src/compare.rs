//! `compare`: two scenarios side by side (the proposed scheme against the LAW §10 baseline),
//! one table with settling figures next to control effort, and overlaid figures.

use std::{fmt::Write as _, path::Path};

use plotters::style::{Color, BLACK};
use serde::Serialize;

use crate::{
    error::{Error, Result},
    figure::{
        panel::{render, Panel, Series},
        text::secs,
        FigureStyle,
    },
    metrics::Summary,
    report::{self, fmt_time, plots::Recorder},
    run::{run, RunOptions},
    scenario::Setup,
};

/// Both summaries and the effort verdict (`compare.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// First scenario.
    pub a: Summary,
    /// Second scenario.
    pub b: Summary,
    /// `total_u_energy` of b over a.
    pub energy_ratio_b_over_a: Option<f64>,
    /// `max_abs_u` of b over a.
    pub peak_u_ratio_b_over_a: Option<f64>,
    /// The two runs spent control effort within 25 % of each other.
    pub equal_effort: bool,
    /// One-line verdict on effort.
    pub note: String,
}

fn ratio(b: f64, a: f64) -> Option<f64> {
    (a > 0.0 && a.is_finite() && b.is_finite()).then(|| b / a)
}

/// A Markdown table cell: `|` escaped so that `max |u|` stays one cell.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |v| format!("{v:.4}"))
}

/// Runs both scenarios, writes `compare.md`, `compare.json` and overlaid figures into `out`;
/// returns the table.
pub fn compare(a: &Setup, b: &Setup, out: &Path, progress: bool) -> Result<String> {
    report::create_dir(out)?;
    let opts = RunOptions {
        record: true,
        progress,
        ..RunOptions::default()
    };
    // The two runs are independent: side by side on rayon's pool. Each run is sequential in
    // itself, so the outputs are byte-identical to one run after the other (tested in
    // tests/tests/determinism.rs with RAYON_NUM_THREADS=1 and 4). One progress bar only.
    let opts_b = RunOptions {
        progress: false,
        ..opts.clone()
    };
    let (ra, rb) = rayon::join(|| run(a, &opts), || run(b, &opts_b));
    let (ra, rb) = (ra?, rb?);
    let (sa, sb) = (&ra.summary, &rb.summary);
    let er = ratio(sb.total_u_energy, sa.total_u_energy);
    let pr = ratio(sb.max_abs_u, sa.max_abs_u);
    let within = |r: Option<f64>| r.is_some_and(|r| (0.8..=1.25).contains(&r));
    let equal_effort = within(er) && within(pr);
    let note = if equal_effort {
        "control effort within 25 %: the settling figures compare at similar effort".to_string()
    } else {
        format!(
            "UNEQUAL control effort ({} uses {} x the energy and {} x the peak |u| of {}): \
             the settling figures do not compare at equal effort",
            sb.scenario,
            opt(er),
            opt(pr),
            sa.scenario
        )
    };
    let mut t = String::new();
    let _ = writeln!(
        t,
        "| metric | {} | {} |",
        cell(&sa.scenario),
        cell(&sb.scenario)
    );
    let _ = writeln!(t, "|---|---|---|");
    let rows: [(&str, String, String); 10] = [
        ("scheme", sa.scheme.clone(), sb.scheme.clone()),
        (
            "c1, c2",
            format!("{:.3}, {:.3}", sa.c1, sa.c2),
            format!("{:.3}, {:.3}", sb.c1, sb.c2),
        ),
        (
            "predefined time 2Ts [s]",
            format!("{}", sa.predefined_time),
            format!("{}", sb.predefined_time),
        ),
        (
            "settling time (band) [s]",
            format!("{} ({})", opt(sa.settling_time), sa.settle_band),
            format!("{} ({})", opt(sb.settling_time), sb.settle_band),
        ),
        (
            "max error after 2Ts",
            opt(sa.max_error_after_predefined_time),
            opt(sb.max_error_after_predefined_time),
        ),
        (
            "IAE (sum over agents)",
            format!("{:.4}", sa.agents.iter().map(|x| x.iae).sum::<f64>()),
            format!("{:.4}", sb.agents.iter().map(|x| x.iae).sum::<f64>()),
        ),
        (
            "max |u|",
            format!("{:.4}", sa.max_abs_u),
            format!("{:.4}", sb.max_abs_u),
        ),
        (
            "u energy (sum over agents)",
            format!("{:.4}", sa.total_u_energy),
            format!("{:.4}", sb.total_u_energy),
        ),
        (
            "quantizer changes (sum)",
            sa.agents
                .iter()
                .map(|x| x.quantizer_changes)
                .sum::<u64>()
                .to_string(),
            sb.agents
                .iter()
                .map(|x| x.quantizer_changes)
                .sum::<u64>()
                .to_string(),
        ),
        (
            "diverged",
            sa.divergence.map_or("no".into(), |d| {
                format!("at t = {} (agent {})", fmt_time(d.time), d.agent)
            }),
            sb.divergence.map_or("no".into(), |d| {
                format!("at t = {} (agent {})", fmt_time(d.time), d.agent)
            }),
        ),
    ];
    for (k, x, y) in rows {
        let _ = writeln!(t, "| {} | {} | {} |", cell(k), cell(&x), cell(&y));
    }
    let _ = writeln!(t, "\n{note}");
    report::write_atomic(&out.join("compare.md"), t.as_bytes())?;
    let cmp = Comparison {
        a: sa.clone(),
        b: sb.clone(),
        energy_ratio_b_over_a: er,
        peak_u_ratio_b_over_a: pr,
        equal_effort,
        note,
    };
    let json = serde_json::to_string_pretty(&cmp).map_err(|e| Error::Io(e.to_string()))?;
    report::write_atomic(&out.join("compare.json"), format!("{json}\n").as_bytes())?;
    if let (Some(a_rec), Some(b_rec)) = (&ra.recorder, &rb.recorder) {
        overlay(out, a, a_rec, b, b_rec)?;
    }
    Ok(t)
}

fn overlay(out: &Path, a: &Setup, ra: &Recorder, b: &Setup, rb: &Recorder) -> Result<()> {
    let (na, nb) = (&a.scenario.name, &b.scenario.name);
    let (y_unit, u_unit) = a.plant.units();
    // Each scheme's predefined time, labelled with its scenario.
    let vlines: Vec<(f64, String)> = [(a, na), (b, nb)]
        .iter()
        .map(|(s, n)| {
            let t = s.predefined_time();
            (t, format!("2Tₛ = {} ({n})", secs(t)))
        })
        .collect();
    let band = a.scenario.simulation.settle_band;
    let errs = vec![
        Series::styled(na.to_string(), 0, ra.points(&ra.max_err)),
        Series::styled(nb.to_string(), 1, rb.points(&rb.max_err)),
    ];
    let mut panels = vec![
        Panel {
            title: "largest tracking error maxᵢ |yᵢ − y_d|".into(),
            y_label: format!("maxᵢ |yᵢ − y_d| [{y_unit}]"),
            series: errs.clone(),
            vlines: vlines.clone(),
            clip_spikes: true,
            ..Panel::default()
        },
        Panel {
            title: "the same, log scale".into(),
            y_label: format!("maxᵢ |yᵢ − y_d| [{y_unit}]"),
            series: errs,
            vlines: vlines.clone(),
            hlines: vec![(band, format!("b = {band}"))],
            log_y: true,
            ..Panel::default()
        },
    ];
    let mut u = Panel {
        title: "agent 1: command u₁ (spikes clipped, peak marked)".into(),
        y_label: format!("u₁ [{u_unit}]"),
        vlines: vlines.clone(),
        clip_spikes: true,
        ..Panel::default()
    };
    if let (Some(ua), Some(ub)) = (ra.u.first(), rb.u.first()) {
        for (k, (name, r, data)) in [(na, ra, ua), (nb, rb, ub)].into_iter().enumerate() {
            let mut s = Series::styled(name.to_string(), k, r.points(data));
            s.peak = r.extreme(0, 0, 0);
            u.series.push(s);
        }
    }
    let mut tr = Panel {
        title: "agent 1: output y₁ and leader y_d".into(),
        y_label: format!("output y [{y_unit}]"),
        vlines,
        ..Panel::default()
    };
    tr.series.push(Series::plain(
        "y_d (leader)".into(),
        BLACK.mix(0.35),
        5,
        ra.points(&ra.yd),
    ));
    if let (Some(ya), Some(yb)) = (ra.y.first(), rb.y.first()) {
        tr.series
            .push(Series::styled(na.to_string(), 0, ra.points(ya)));
        tr.series
            .push(Series::styled(nb.to_string(), 1, rb.points(yb)));
    }
    panels.push(u);
    panels.push(tr);
    render(out, "compare", &panels, (2, 2), FigureStyle::px(1400, 900))
}
