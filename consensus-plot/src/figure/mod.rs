//! The plotting toolkit of every figure host-sim writes: the figure's size and text sizes
//! ([`FigureStyle`]), the bundled font, charts on a grid ([`grid`]), axes and legends
//! ([`chart`]), tick labels and numbers in figure text ([`text`]), the time-series panels of
//! the run and compare figures ([`panel`]), and the file writes: every PNG and SVG is drawn
//! under a temporary name and renamed into place, the temporary removed on an error or Ctrl-C
//! ([`save`]). A writer implements [`Figure`] once and gets every output format; `[figures]`
//! ([`spec`]) picks the formats and a print size in millimetres and points, for which PNG and PDF
//! are made from the figure's SVG (`resvg`, `svg2pdf` with the bundled font embedded).

pub mod chart;
pub mod panel;
pub mod spec;
pub mod text;

use std::{path::Path, sync::Once};

use plotters::{
    coord::Shift,
    prelude::{BitMapBackend, DrawingArea, DrawingBackend, IntoDrawingArea, SVGBackend, WHITE},
    style::{FontDesc, FontStyle, IntoFont},
};

use crate::{
    error::{Error, Result},
    files::{temp_path, TempFile},
};

/// What drawing into a backend returns: the backend's error as text.
pub type DrawResult = std::result::Result<(), String>;

/// Size and text of a figure. Writers give the nominal size ([`FigureStyle::px`]) and text sizes
/// in pixels of that size ([`FigureStyle::font`]); an [`Output`] with a [`Print`] size turns the
/// nominal pixels into a page in millimetres (see [`Print::canvas`]) in this one place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FigureStyle {
    width: u32,
    height: u32,
    output: Output,
}

/// The formats a figure is written in and its print size, from `[figures]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// PNG, SVG, PDF (in that order) when set.
    pub formats: [bool; 3],
    /// Page size and text size; `None`: the writers' pixel sizes.
    pub print: Option<Print>,
    /// Time window `(t_from, t_to)` of the time-series figures.
    pub window: (Option<f64>, Option<f64>),
}

impl Default for Output {
    fn default() -> Self {
        Self {
            formats: [true, true, false],
            print: None,
            window: (None, None),
        }
    }
}

impl Output {
    /// The formats to write.
    pub fn formats(&self) -> impl Iterator<Item = Format> + '_ {
        [Format::Png, Format::Svg, Format::Pdf]
            .into_iter()
            .zip(self.formats)
            .filter_map(|(f, on)| on.then_some(f))
    }
}

/// A printed figure: `width_mm` wide, each chart `chart_mm` high, tick labels of `font_pt`,
/// bitmaps at `dpi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Print {
    /// Page width \[mm\].
    pub width_mm: f64,
    /// Height of one chart \[mm\]; `None`: the writer's aspect ratio.
    pub chart_mm: Option<f64>,
    /// Tick-label size \[pt\]; titles and legends keep their proportions to it.
    pub font_pt: f64,
    /// PNG resolution [dots per inch].
    pub dpi: f64,
}

/// Tick labels are drawn at this many nominal pixels; a print style maps it to `font_pt`.
const TICK_PX: f64 = 13.0;
const PT_PER_MM: f64 = 72.0 / 25.4;
/// A printed figure's canvas is at least this wide [px]: the SVG backend rounds coordinates to
/// whole pixels, so a narrower one would draw curves as visible steps.
const MIN_CANVAS: f64 = 1000.0;

impl Print {
    /// Points per pixel of the unzoomed canvas.
    fn scale(&self) -> f64 {
        self.font_pt / TICK_PX
    }

    /// Every pixel size of the writers (text, margins, label areas) is multiplied by this.
    pub fn zoom(&self) -> f64 {
        (MIN_CANVAS / (self.width_mm * PT_PER_MM / self.scale())).max(1.0)
    }

    /// The canvas `(width, height)` \[px\] of a figure of `rows` charts stacked whose writer
    /// asked for `nominal` pixels: as wide as the page, each chart `chart_mm` high (or the
    /// writer's aspect ratio).
    pub fn canvas(&self, nominal: (u32, u32), rows: usize) -> (u32, u32) {
        let px = self.zoom() / self.scale() * PT_PER_MM;
        let w = self.width_mm * px;
        let h = match self.chart_mm {
            Some(c) => c * px * rows.max(1) as f64,
            None => w * f64::from(nominal.1) / f64::from(nominal.0.max(1)),
        };
        (w.round().max(1.0) as u32, h.round().max(1.0) as u32)
    }

    /// The page size `(width, height)` \[mm\] of a `canvas` \[px\].
    pub fn page_mm(&self, canvas: (u32, u32)) -> (f64, f64) {
        let mm = self.scale() / PT_PER_MM / self.zoom();
        (f64::from(canvas.0) * mm, f64::from(canvas.1) * mm)
    }
}

impl FigureStyle {
    /// A figure of `width` × `height` pixels, written as PNG and SVG.
    pub const fn px(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            output: Output {
                formats: [true, true, false],
                print: None,
                window: (None, None),
            },
        }
    }

    /// This style written as `output` says.
    pub const fn with(self, output: Output) -> Self {
        Self { output, ..self }
    }

    /// The formats, print size and time window.
    pub const fn output(&self) -> &Output {
        &self.output
    }

    /// `(width, height)` in (nominal) pixels: the canvas the writer draws on.
    pub fn size(&self) -> (u32, u32) {
        match self.output.print {
            Some(p) => p.canvas((self.width, self.height), 0),
            None => (self.width, self.height),
        }
    }

    /// The same style with a canvas of `rows` charts stacked (print) or `nominal` pixels.
    pub fn stacked(self, nominal: (u32, u32), rows: usize) -> Self {
        match self.output.print {
            Some(p) if p.chart_mm.is_some() => {
                let (width, height) = p.canvas(nominal, rows);
                Self {
                    width,
                    height,
                    output: Output {
                        print: Some(Print {
                            chart_mm: None,
                            ..p
                        }),
                        ..self.output
                    },
                }
            }
            _ => Self {
                width: nominal.0,
                height: nominal.1,
                ..self
            },
        }
    }

    /// The figures' font (the bundled DejaVu Sans) at `px` pixels.
    pub fn font(&self, px: u32) -> FontDesc<'static> {
        (FONT_FAMILY, f64::from(self.scaled(px))).into_font()
    }

    /// A writer's size of `px` pixels on this canvas (zoomed for print).
    pub fn scaled(&self, px: u32) -> u32 {
        (f64::from(px) * self.zoom()).round() as u32
    }

    /// A line width, dash or marker size of `px` on this canvas: zoomed less than text, so that
    /// lines stay fine in print.
    pub fn ink(&self, px: u32) -> u32 {
        (f64::from(px) * self.zoom().sqrt()).round() as u32
    }

    /// The zoom of a print canvas (1 without a print size).
    pub fn zoom(&self) -> f64 {
        self.output.print.map_or(1.0, |p| p.zoom())
    }

    /// Whether the figure is laid out for print (legends in a strip above the plot).
    pub fn is_print(&self) -> bool {
        self.output.print.is_some()
    }
}

/// An output format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Bitmap (`.png`).
    Png,
    /// Vector (`.svg`).
    Svg,
    /// Vector with the font embedded (`.pdf`).
    Pdf,
}

impl Format {
    /// The format of `path`, from its extension.
    pub fn of(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("png") => Ok(Self::Png),
            Some("svg") => Ok(Self::Svg),
            Some("pdf") => Ok(Self::Pdf),
            _ => Err(Error::io(path, "a figure is written as .png, .svg or .pdf")),
        }
    }

    /// The format named `name` in `[figures] format`.
    pub fn named(name: &str) -> Option<Self> {
        [Self::Png, Self::Svg, Self::Pdf]
            .into_iter()
            .find(|f| f.extension() == name)
    }

    /// The file extension.
    pub const fn extension(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Svg => "svg",
            Self::Pdf => "pdf",
        }
    }

    /// The bitmap renderer has no combining-mark positioning (see [`text::bitmap_text`]).
    pub const fn is_bitmap(self) -> bool {
        matches!(self, Self::Png)
    }
}

/// A figure: draws itself on any backend, on a white page the size of its style.
pub trait Figure {
    /// Draws on `root` for `format`.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        style: &FigureStyle,
        format: Format,
    ) -> DrawResult;
}

const FONT_FAMILY: &str = "sans-serif";
static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static FONT_ONCE: Once = Once::new();

/// Registers the bundled font as "sans-serif" (once per process): no system font lookup, so
/// figures come out the same on a bare CI machine.
fn register_font() {
    FONT_ONCE.call_once(|| {
        let _ = plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT);
    });
}

/// Writes `figure` to `path` (`.png`, `.svg` or `.pdf`) under a temporary name, renamed into
/// place once complete. Without a print size PNG and SVG are drawn by `plotters` in the
/// writer's pixels, a PDF from the SVG; with one, every format comes from the SVG.
pub fn save(path: &Path, style: &FigureStyle, figure: &impl Figure) -> Result<()> {
    register_font();
    let format = Format::of(path)?;
    let tmp = TempFile::new(temp_path(path));
    {
        let fail = |e: String| Error::io(path, e);
        match (format, style.output.print) {
            (Format::Png, None) => {
                let root = BitMapBackend::new(tmp.path(), style.size()).into_drawing_area();
                page(&root, style, format, figure).map_err(fail)?;
            }
            (Format::Svg, None) => {
                let root = SVGBackend::new(tmp.path(), style.size()).into_drawing_area();
                page(&root, style, format, figure).map_err(fail)?;
            }
            (_, print) => {
                let svg = svg_text(style, figure, print).map_err(fail)?;
                let bytes = match format {
                    Format::Svg => svg.into_bytes(),
                    Format::Pdf => vector::pdf(&svg).map_err(fail)?,
                    Format::Png => {
                        let dpi = print.map_or(96.0, |p| p.dpi);
                        vector::png(&svg, dpi).map_err(fail)?
                    }
                };
                std::fs::write(tmp.path(), bytes).map_err(|e| Error::io(tmp.path(), e))?;
            }
        }
    }
    tmp.persist(path)
}

/// The figure as SVG text; with a print size, the page in millimetres over the canvas.
fn svg_text(
    style: &FigureStyle,
    figure: &impl Figure,
    print: Option<Print>,
) -> std::result::Result<String, String> {
    let size = style.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        page(&root, style, Format::Svg, figure)?;
    }
    if let Some(p) = print {
        let (w, h) = p.page_mm(size);
        let nominal = format!("<svg width=\"{}\" height=\"{}\"", size.0, size.1);
        svg = svg.replacen(
            &nominal,
            &format!("<svg width=\"{w:.2}mm\" height=\"{h:.2}mm\""),
            1,
        );
    }
    Ok(svg)
}

/// Writes `dir/stem.<ext>` for every format of the style's output (PNG and SVG by default).
pub fn save_png_and_svg(
    dir: &Path,
    stem: &str,
    style: &FigureStyle,
    figure: &impl Figure,
) -> Result<()> {
    for format in style.output.formats() {
        save(
            &dir.join(format!("{stem}.{}", format.extension())),
            style,
            figure,
        )?;
    }
    Ok(())
}

/// SVG to PDF and PNG with the bundled font.
mod vector {
    use std::sync::{Arc, OnceLock};

    /// The bundled font as the only font, named for the SVG's `sans-serif`.
    fn options() -> usvg::Options<'static> {
        static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
        let db = DB.get_or_init(|| {
            let mut db = usvg::fontdb::Database::new();
            db.load_font_data(super::FONT.to_vec());
            db.set_sans_serif_family("DejaVu Sans");
            Arc::new(db)
        });
        usvg::Options {
            font_family: "DejaVu Sans".into(),
            fontdb: Arc::clone(db),
            ..usvg::Options::default()
        }
    }

    fn tree(svg: &str) -> Result<usvg::Tree, String> {
        usvg::Tree::from_str(svg, &options()).map_err(|e| format!("SVG of the figure: {e}"))
    }

    /// A PDF page of the SVG's size (96 SVG pixels per inch), the font subset and embedded.
    pub fn pdf(svg: &str) -> Result<Vec<u8>, String> {
        svg2pdf::to_pdf(
            &tree(svg)?,
            svg2pdf::ConversionOptions::default(),
            svg2pdf::PageOptions { dpi: 96.0 },
        )
        .map_err(|e| format!("PDF of the figure: {e}"))
    }

    /// A PNG of the SVG at `dpi`.
    pub fn png(svg: &str, dpi: f64) -> Result<Vec<u8>, String> {
        let tree = tree(svg)?;
        let k = (dpi / 96.0) as f32;
        let size = tree
            .size()
            .to_int_size()
            .scale_by(k)
            .ok_or("PNG of zero size")?;
        let mut pixmap =
            resvg::tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("PNG too large")?;
        resvg::render(
            &tree,
            resvg::tiny_skia::Transform::from_scale(k, k),
            &mut pixmap.as_mut(),
        );
        pixmap
            .encode_png()
            .map_err(|e| format!("PNG of the figure: {e}"))
    }
}

fn page<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    style: &FigureStyle,
    format: Format,
    figure: &impl Figure,
) -> DrawResult {
    root.fill(&WHITE).map_err(drawing_error)?;
    figure.draw(root, style, format)?;
    root.present().map_err(drawing_error)
}

/// `root` split into `rows` × `cols` equal charts, row by row.
pub fn grid<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    (rows, cols): (usize, usize),
) -> Vec<DrawingArea<DB, Shift>> {
    root.split_evenly((rows, cols))
}

/// A backend's error as the text of a [`DrawResult`].
pub fn drawing_error(e: impl std::fmt::Display) -> String {
    e.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A figure that draws nothing, or fails with the given message.
    struct Stub(Option<&'static str>);

    impl Figure for Stub {
        fn draw<DB: DrawingBackend>(
            &self,
            _: &DrawingArea<DB, Shift>,
            _: &FigureStyle,
            _: Format,
        ) -> DrawResult {
            self.0.map_or(Ok(()), |e| Err(e.into()))
        }
    }

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir =
            std::env::temp_dir().join(format!("host-sim-figure-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    #[test]
    fn a_failed_figure_leaves_neither_the_file_nor_its_temporary() {
        let dir = scratch("failed");
        let style = FigureStyle::px(200, 100);
        for ext in ["png", "svg"] {
            let path = dir.join(format!("f.{ext}"));
            let e = save(&path, &style, &Stub(Some("no data"))).expect_err("drawing fails");
            assert!(e.to_string().contains("no data"), "{e}");
        }
        let left: Vec<_> = std::fs::read_dir(&dir).expect("dir").collect();
        assert!(left.is_empty(), "{left:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn png_and_svg_are_written_under_their_names_only() {
        let dir = scratch("written");
        save_png_and_svg(&dir, "f", &FigureStyle::px(200, 100), &Stub(None)).expect("written");
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["f.png", "f.svg"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn only_png_svg_and_pdf_are_figure_formats() {
        assert_eq!(Format::of(Path::new("a/b.png")).ok(), Some(Format::Png));
        assert_eq!(Format::of(Path::new("b.svg")).ok(), Some(Format::Svg));
        assert_eq!(Format::of(Path::new("b.pdf")).ok(), Some(Format::Pdf));
        assert!(Format::of(Path::new("b.jpg")).is_err());
        assert!(Format::of(Path::new("b")).is_err());
    }

    /// A print page is as wide as asked, its tick labels `font_pt` high, and the PDF carries
    /// the bundled font (as a subset: the name has a `+` tag).
    #[test]
    fn a_print_pdf_has_the_page_size_and_embeds_the_font() {
        let dir = scratch("print");
        let print = Print {
            width_mm: 85.0,
            chart_mm: None,
            font_pt: 8.0,
            dpi: 150.0,
        };
        let output = Output {
            formats: [true, true, true],
            print: Some(print),
            window: (None, None),
        };
        let style = FigureStyle::px(1000, 560).with(output);
        let (w, _) = print.page_mm(style.size());
        assert!((w - 85.0).abs() < 0.1, "{w} mm");
        assert!(
            (f64::from(style.scaled(13)) / print.zoom() * print.scale() - 8.0).abs() < 0.2,
            "tick labels at font_pt"
        );
        save_png_and_svg(&dir, "f", &style, &Text).expect("written");
        let pdf = std::fs::read(dir.join("f.pdf")).expect("pdf");
        let text = String::from_utf8_lossy(&pdf);
        assert!(
            text.contains("/FontFile2") || text.contains("/FontFile3"),
            "no embedded font"
        );
        assert!(text.contains("DejaVuSans"), "not the bundled font");
        let svg = std::fs::read_to_string(dir.join("f.svg")).expect("svg");
        assert!(svg.contains("width=\"85.00mm\""), "{}", &svg[..200]);
        let png = std::fs::read(dir.join("f.png")).expect("png");
        let px = u32::from_be_bytes([png[16], png[17], png[18], png[19]]);
        assert_eq!(px, (85.0 / 25.4 * 150.0_f64).round() as u32);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A figure with one line of text.
    struct Text;

    impl Figure for Text {
        fn draw<DB: DrawingBackend>(
            &self,
            root: &DrawingArea<DB, Shift>,
            style: &FigureStyle,
            _: Format,
        ) -> DrawResult {
            root.draw_text("u₁ [N·m]", &style.font(13).into(), (20, 20))
                .map_err(drawing_error)
        }
    }
}
