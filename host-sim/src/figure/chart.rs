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
/// chart's coordinates, log axes already as their logarithm): a legend box is about 45 % of the
/// width and 30 % of the height. Ties go to the upper right, upper left, lower right, lower left.
pub fn free_corner(
    points: impl IntoIterator<Item = (f64, f64)>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
) -> SeriesLabelPosition {
    let (w, h) = (x.end - x.start, y.end - y.start);
    let mut count = [0usize; 4];
    for (px, py) in points {
        let (u, v) = ((px - x.start) / w, (py - y.start) / h);
        if !(u.is_finite() && v.is_finite()) {
            continue;
        }
        let (right, left, top, bottom) = (u >= 0.55, u <= 0.45, v >= 0.7, v <= 0.3);
        for (k, inside) in [top && right, top && left, bottom && right, bottom && left]
            .into_iter()
            .enumerate()
        {
            if let Some(c) = count.get_mut(k).filter(|_| inside) {
                *c += 1;
            }
        }
    }
    let best = (0..4).min_by_key(|&k| count.get(k).copied().unwrap_or(0));
    match best {
        Some(1) => SeriesLabelPosition::UpperLeft,
        Some(2) => SeriesLabelPosition::LowerRight,
        Some(3) => SeriesLabelPosition::LowerLeft,
        _ => SeriesLabelPosition::UpperRight,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_goes_where_the_data_is_not() {
        let rising = (0..20).map(|k| (f64::from(k), f64::from(k)));
        assert!(matches!(
            free_corner(rising, 0.0..19.0, 0.0..19.0),
            SeriesLabelPosition::UpperLeft
        ));
        let top = (0..20).map(|k| (f64::from(k), 18.5));
        assert!(matches!(
            free_corner(top, 0.0..19.0, 0.0..19.0),
            SeriesLabelPosition::LowerRight
        ));
        assert!(matches!(
            free_corner([], 0.0..1.0, 0.0..1.0),
            SeriesLabelPosition::UpperRight
        ));
    }
}
