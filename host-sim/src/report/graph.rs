//! The communication graph as a figure (the paper's Fig. 1): followers on a circle, an arrow
//! from each neighbour `k` to the follower `i` that hears it (`a_{i,k} = 1`), and the leader
//! `0` with a dashed arrow to each pinned follower (`r_i = 1`).

use std::path::Path;

use plotters::{coord::Shift, element::DashedPathElement, prelude::*};
use plotters_backend::text_anchor::{HPos, Pos, VPos};

use crate::report::write_atomic;
use consensus_plot::{
    error::{Error, Result},
    figure::{drawing_error, save_png_and_svg, DrawResult, Figure, FigureStyle, Format},
};
use consensus_sim::{graph::Graph, scenario::Setup};

/// Most followers drawn (the circle stays readable).
pub const MAX_DRAWN: usize = 64;

struct GraphFigure<'a> {
    graph: &'a Graph,
    title: String,
}

/// Writes `dir/graph.json` (the graph's figures: followers, links, pinned followers, largest
/// in-degree, hops from the leader) and, for at most [`MAX_DRAWN`] followers, `dir/graph.<ext>`.
pub fn draw(dir: &Path, setup: &Setup) -> Result<()> {
    let g = &setup.graph;
    let n = setup.agents();
    let path = dir.join("graph.json");
    let text = serde_json::to_string_pretty(&figures(g)).map_err(|e| Error::io(&path, e))?;
    write_atomic(&path, format!("{text}\n").as_bytes())?;
    if n > MAX_DRAWN {
        eprintln!(
            "graph: {n} followers, more than the {MAX_DRAWN} the figure draws: only graph.json written"
        );
        return Ok(());
    }
    let figure = GraphFigure {
        graph: g,
        title: format!(
            "{}: communication graph ({n} followers, {} links)",
            setup.figure_title(),
            g.links()
        ),
    };
    save_png_and_svg(
        dir,
        "graph",
        &FigureStyle::px(700, 560).with(setup.figures()),
        &figure,
    )
}

/// The content of `graph.json`.
fn figures(g: &Graph) -> serde_json::Value {
    let n = g.len();
    let hops: Vec<usize> = g.hops().into_iter().flatten().collect();
    serde_json::json!({
        "followers": n,
        "links": g.links(),
        "pinned": (0..n).filter(|&i| g.pinned(i)).count(),
        "in_degree_max": (0..n).map(|i| g.neighbours(i).len()).max().unwrap_or(0),
        "hops_max": hops.iter().max().copied().unwrap_or(0),
        "hops_mean": hops.iter().sum::<usize>() as f64 / hops.len().max(1) as f64,
    })
}

/// An arrow from `a` to `b` that stops `gap` px short of both centres.
fn arrow<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (a, b): ((f64, f64), (f64, f64)),
    gap: f64,
    dashed: bool,
    style: &FigureStyle,
) -> DrawResult {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy).max(1.0);
    let (ux, uy) = (dx / len, dy / len);
    let p = |d: f64, from: (f64, f64)| ((from.0 + ux * d) as i32, (from.1 + uy * d) as i32);
    let (s, e) = (p(gap, a), p(-gap, b));
    let line = BLACK.stroke_width(style.ink(2));
    if dashed {
        root.draw(&DashedPathElement::new(
            [s, e],
            style.ink(8),
            style.ink(5),
            line,
        ))
    } else {
        root.draw(&PathElement::new([s, e], line))
    }
    .map_err(drawing_error)?;
    let head = f64::from(style.scaled(12));
    let (bx, by) = (f64::from(e.0) - ux * head, f64::from(e.1) - uy * head);
    let side = |k: f64| {
        (
            (bx - uy * head * 0.45 * k) as i32,
            (by + ux * head * 0.45 * k) as i32,
        )
    };
    root.draw(&Polygon::new([e, side(1.0), side(-1.0)], BLACK.filled()))
        .map_err(drawing_error)
}

impl Figure for GraphFigure<'_> {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        _: Format,
    ) -> DrawResult {
        let (w, h) = root.dim_in_pixel();
        let (w, h) = (f64::from(w), f64::from(h));
        let title = TextStyle::from(style.font(17)).pos(Pos::new(HPos::Center, VPos::Top));
        root.draw(&Text::new(self.title.clone(), ((w / 2.0) as i32, 8), title))
            .map_err(drawing_error)?;
        let n = self.graph.len();
        let (cx, cy) = (w * 0.6, h * 0.55);
        let radius = (w.min(h) * 0.33).max(10.0);
        let node = f64::from(style.scaled(18));
        let at = |i: usize| {
            let phi = std::f64::consts::PI * (1.0 - 2.0 * i as f64 / n.max(1) as f64);
            (cx + radius * phi.cos(), cy - radius * phi.sin())
        };
        let leader = (w * 0.1, cy);
        for i in 0..n {
            for &k in self.graph.neighbours(i) {
                arrow(root, (at(k), at(i)), node, false, style)?;
            }
            if self.graph.pinned(i) {
                arrow(root, (leader, at(i)), node, true, style)?;
            }
        }
        let label = TextStyle::from(style.font(15)).pos(Pos::new(HPos::Center, VPos::Center));
        let ring = BLACK.stroke_width(style.ink(2));
        let points = (0..n).map(|i| (i + 1, at(i))).chain([(0, leader)]);
        for (name, (x, y)) in points {
            let c = (x as i32, y as i32);
            let fill = if name == 0 {
                BLACK.mix(0.15)
            } else {
                WHITE.mix(1.0)
            };
            root.draw(&Circle::new(c, node as i32, fill.filled()))
                .map_err(drawing_error)?;
            root.draw(&Circle::new(c, node as i32, ring))
                .map_err(drawing_error)?;
            root.draw(&Text::new(name.to_string(), c, label.clone()))
                .map_err(drawing_error)?;
        }
        let note = TextStyle::from(style.font(12)).pos(Pos::new(HPos::Left, VPos::Bottom));
        root.draw(&Text::new(
            "0: leader (dashed: pinned, rᵢ = 1);  k → i: follower i hears k",
            (8, (h - 8.0) as i32),
            note,
        ))
        .map_err(drawing_error)
    }
}
