//! One chart: its frame (caption, margins, label areas), its axes and its legend, in the
//! figures' font and sizes.

use plotters::{
    chart::{ChartBuilder, ChartContext, MeshStyle, SeriesLabelPosition},
    coord::{
        ranged1d::{AsRangedCoord, Ranged, ValueFormatter},
        CoordTranslate, Shift,
    },
    prelude::{
        Cartesian2d, DrawingArea, DrawingAreaErrorKind, DrawingBackend, BLACK, TRANSPARENT, WHITE,
    },
    style::Color,
};

use super::FigureStyle;

/// Result of a drawing call on backend `DB`.
pub type Drawn<DB, T = ()> =
    std::result::Result<T, DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A chart over the coordinates `X` × `Y` (as given to [`cartesian`]).
pub type Chart<'c, DB, X, Y> = ChartContext<
    'c,
    DB,
    Cartesian2d<<X as AsRangedCoord>::CoordDescType, <Y as AsRangedCoord>::CoordDescType>,
>;

/// The frame of a captioned chart, in pixels.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Caption text size.
    pub caption: u32,
    /// Margin on every side.
    pub margin: u32,
    /// Height kept below the plot for the x tick labels and description.
    pub x_labels: u32,
    /// Width kept left of the plot for the y tick labels and description.
    pub y_labels: u32,
}

/// A chart with `caption` over `x` × `y` on `area`.
pub fn cartesian<'c, DB: DrawingBackend, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    caption: &str,
    frame: Frame,
    (x, y): (X, Y),
) -> Drawn<DB, Chart<'c, DB, X, Y>> {
    ChartBuilder::on(area)
        .caption(caption, style.font(frame.caption))
        .margin(frame.margin)
        .x_label_area_size(frame.x_labels)
        .y_label_area_size(frame.y_labels)
        .build_cartesian_2d(x, y)
}

/// The grid and axes of `chart`, described `x_desc` and `y_desc`, tick labels of `label` px
/// and descriptions of `desc` px; the caller adds formatters and draws.
pub fn axes<'a, 'b, DB, XT, YT, X, Y>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    style: &FigureStyle,
    (x_desc, y_desc): (&str, &str),
    (label, desc): (u32, u32),
) -> MeshStyle<'a, 'b, X, Y, DB>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = XT> + ValueFormatter<XT>,
    Y: Ranged<ValueType = YT> + ValueFormatter<YT>,
{
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(style.font(label))
        .axis_desc_style(style.font(desc))
        .bold_line_style(BLACK.mix(0.14))
        .light_line_style(TRANSPARENT);
    mesh
}

/// The legend of `chart` (every labelled series) at `at`, text of `px` px, on a light box.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    style: &FigureStyle,
    at: SeriesLabelPosition,
    px: u32,
) -> Drawn<DB> {
    chart
        .configure_series_labels()
        .position(at)
        .label_font(style.font(px))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

/// The corner of a chart over `x` × `y` where a legend covers the fewest of `points` (in the
/// chart's coordinates, log axes already as their logarithm): [`legend_corner`] with a box of
/// about 45 % of the width and 30 % of the height. Ties go to the upper right.
pub fn free_corner(
    points: impl IntoIterator<Item = (f64, f64)>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
) -> SeriesLabelPosition {
    let pts = [points.into_iter().collect::<Vec<_>>()];
    legend_corner(&pts, &[], (x.start, x.end), (y.start, y.end), (0.45, 0.3)).0
}

/// The corner of the plot where a legend box of `w` × `h` (fractions of the plot) covers the
/// fewest data points (a point of a note counts 100), and how many it covers.
pub fn legend_corner(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_goes_where_the_data_is_not() {
        let rising = (0..20).map(|k| (f64::from(k), f64::from(k)));
        assert!(matches!(
            free_corner(rising, 0.0..19.0, 0.0..19.0),
            SeriesLabelPosition::LowerRight
        ));
        let bottom_and_right = (0..20)
            .map(|k| (f64::from(k), 0.5))
            .chain((0..20).map(|k| (18.5, f64::from(k))));
        assert!(matches!(
            free_corner(bottom_and_right, 0.0..19.0, 0.0..19.0),
            SeriesLabelPosition::UpperLeft
        ));
        assert!(matches!(
            free_corner([], 0.0..1.0, 0.0..1.0),
            SeriesLabelPosition::UpperRight
        ));
    }
}
