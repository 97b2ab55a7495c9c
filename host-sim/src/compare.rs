//! `compare`: two scenarios side by side (the proposed scheme against the LAW §10 baseline),
//! one table with settling figures next to control effort, and overlaid figures. Each scheme is
//! judged after its own deadline ([`metrics::deadline`]) and both after the later of the two.

use std::{fmt::Write as _, path::Path};

use plotters::style::{Color, BLACK};
use serde::Serialize;

use crate::{
    report::{self, fmt_time, plots::Recorder},
    run::{run, RunOptions},
};
use consensus_plot::{
    error::{Error, Result},
    figure::{
        panel::{render, Panel, Series},
        text::{secs, sub},
        FigureStyle,
    },
};
use consensus_sim::{
    metrics::{self, Summary, WindowKind, WindowSpec},
    scenario::Setup,
};

/// One scheme judged after its own deadline and after the common instant.
#[derive(Debug, Clone, Serialize)]
pub struct Judgement {
    /// Which deadline the scheme promises: `2Ts` (predefined time) or `t_prescribed`.
    pub deadline_rule: &'static str,
    /// That deadline \[s\].
    pub own_deadline: f64,
    /// `max_{i, t_k ≥ own_deadline} |y_i − y_d|`; null without such samples.
    pub max_error_after_own_deadline: Option<f64>,
    /// `max_{i, t_k ≥ common_instant} |y_i − y_d|`; null without such samples.
    pub max_error_after_common_instant: Option<f64>,
    /// The dwell of the scheme's `settling_time` \[s\].
    pub settle_dwell: f64,
}

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
    /// The later of the two deadlines \[s\]: both schemes are judged after it.
    pub common_instant: f64,
    /// The first scenario after its own deadline and after the common instant.
    pub judged_a: Judgement,
    /// The second scenario after its own deadline and after the common instant.
    pub judged_b: Judgement,
}

/// Window names under which a run measures its two judgements; removed from its summary.
const AFTER_OWN: &str = "max error after own deadline";
const AFTER_COMMON: &str = "max error after common instant";

/// `setup` with the two judgement windows appended.
fn judged_setup(setup: &Setup, common: f64) -> Setup {
    let mut s = setup.clone();
    for (name, from) in [
        (AFTER_OWN, metrics::deadline(setup).0),
        (AFTER_COMMON, common),
    ] {
        s.scenario.metrics.window.push(WindowSpec {
            name: name.into(),
            from,
            to: None,
            kind: WindowKind::MaxError,
        });
    }
    s
}

/// The judgement of a run of [`judged_setup`]; its summary loses the two windows again.
fn judge(setup: &Setup, summary: &mut Summary) -> Judgement {
    let n = summary.windows.len().saturating_sub(2);
    let judged: Vec<_> = summary.windows.drain(n..).collect();
    if summary.windows.is_empty() {
        summary.units.retain(|k, _| !k.starts_with("windows."));
    }
    let value = |name: &str| judged.iter().find(|w| w.name == name).and_then(|w| w.value);
    let (own_deadline, deadline_rule) = metrics::deadline(setup);
    Judgement {
        deadline_rule,
        own_deadline,
        max_error_after_own_deadline: value(AFTER_OWN),
        max_error_after_common_instant: value(AFTER_COMMON),
        settle_dwell: metrics::settle_dwell(setup),
    }
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
    let common = metrics::deadline(a).0.max(metrics::deadline(b).0);
    let (ja, jb) = (judged_setup(a, common), judged_setup(b, common));
    let (ra, rb) = rayon::join(|| run(&ja, &opts), || run(&jb, &opts_b));
    let (mut ra, mut rb) = (ra?, rb?);
    let judged_a = judge(a, &mut ra.summary);
    let judged_b = judge(b, &mut rb.summary);
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
    let rows: [(&str, String, String); 15] = [
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
            "own deadline [s]",
            format!("{} = {}", judged_a.deadline_rule, judged_a.own_deadline),
            format!("{} = {}", judged_b.deadline_rule, judged_b.own_deadline),
        ),
        (
            "max error after own deadline",
            opt(judged_a.max_error_after_own_deadline),
            opt(judged_b.max_error_after_own_deadline),
        ),
        (
            "common instant (later deadline) [s]",
            format!("{common}"),
            format!("{common}"),
        ),
        (
            "max error after common instant",
            opt(judged_a.max_error_after_common_instant),
            opt(judged_b.max_error_after_common_instant),
        ),
        (
            "settle dwell [s]",
            format!("{}", judged_a.settle_dwell),
            format!("{}", judged_b.settle_dwell),
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
        common_instant: common,
        judged_a,
        judged_b,
    };
    let json = serde_json::to_string_pretty(&cmp).map_err(|e| Error::Io(e.to_string()))?;
    report::write_atomic(&out.join("compare.json"), format!("{json}\n").as_bytes())?;
    if let (Some(a_rec), Some(b_rec)) = (&ra.recorder, &rb.recorder) {
        overlay(out, a, a_rec, b, b_rec)?;
    }
    Ok(t)
}

/// The settling band's label, with its unit unless the output has none.
fn band_label(band: f64, y_unit: &str) -> String {
    match y_unit {
        "–" | "" => format!("settling band b = {band}"),
        u => format!("settling band b = {band} {u}"),
    }
}

/// The scheme of a run as the paper names it, for figure text: "predefined-time (proposed)",
/// "prescribed-time [39]"; when both runs have the same scheme, "(a)"/"(b)" tells them apart.
fn scheme_label(s: &Setup, other: &Setup, tag: &str) -> String {
    let name = Setup::scheme_name;
    if name(s) == name(other) {
        format!("{} {tag}", name(s))
    } else {
        name(s).to_owned()
    }
}

/// Each scheme's own deadline labelled with its rule and scheme; the later one is also the
/// common instant (one line when both deadlines coincide).
fn deadline_lines(a: &Setup, b: &Setup) -> Vec<(f64, String)> {
    let rule = |s: &Setup, other: &Setup, tag: &str| {
        let (t, r) = metrics::deadline(s);
        let r = if r == "2Ts" { "2Tₛ" } else { "T" };
        (t, format!("{r} of {}", scheme_label(s, other, tag)))
    };
    let ((ta, la), (tb, lb)) = (rule(a, b, "(b)"), rule(b, a, "(a)"));
    if ta == tb {
        return vec![(ta, format!("{la} = {lb} = {}: common instant", secs(ta)))];
    }
    let common = ta.max(tb);
    [(ta, la), (tb, lb)]
        .into_iter()
        .map(|(t, l)| {
            let tag = if t == common { ": common instant" } else { "" };
            (t, format!("{l} = {}{tag}", secs(t)))
        })
        .collect()
}

fn overlay(out: &Path, a: &Setup, ra: &Recorder, b: &Setup, rb: &Recorder) -> Result<()> {
    let (na, nb) = (&scheme_label(a, b, "(b)"), &scheme_label(b, a, "(a)"));
    let (y_unit, u_unit) = a.plant.units();
    let vlines = deadline_lines(a, b);
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
            hlines: vec![(band, band_label(band, y_unit))],
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
    render(
        out,
        "compare",
        &panels,
        (2, 2),
        FigureStyle::px(1400, 900).with(a.figures()),
    )?;
    outputs(out, (a, ra), (b, rb))
}

/// `compare-outputs`, laid out like the paper's Fig. 8: every follower's output and `y_d`, one
/// panel per scheme, (a) the second scenario (the baseline) above (b) the first, both deadlines
/// marked in each.
fn outputs(out: &Path, (a, ra): (&Setup, &Recorder), (b, rb): (&Setup, &Recorder)) -> Result<()> {
    let (y_unit, _) = a.plant.units();
    let vlines = deadline_lines(a, b);
    let panel = |tag: &str, s: &Setup, other: &Setup, r: &Recorder| {
        let mut p = Panel {
            title: format!(
                "({tag}) {}: outputs yᵢ and leader y_d",
                scheme_label(s, other, &format!("({tag})"))
            ),
            y_label: format!("output y [{y_unit}]"),
            vlines: vlines.clone(),
            ..Panel::default()
        };
        p.series.push(Series::plain(
            "y_d (leader)".into(),
            BLACK.mix(0.35),
            5,
            r.points(&r.yd),
        ));
        for (i, y) in r.y.iter().enumerate() {
            p.series
                .push(Series::styled(format!("y{}", sub(i + 1)), i, r.points(y)));
        }
        p
    };
    render(
        out,
        "compare-outputs",
        &[panel("a", b, a, rb), panel("b", a, b, ra)],
        (2, 1),
        FigureStyle::px(1000, 900).with(a.figures()),
    )
}
