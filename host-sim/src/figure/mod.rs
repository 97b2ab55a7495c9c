//! The plotting toolkit of every figure host-sim writes: the figure's size and text sizes
//! ([`FigureStyle`]), the bundled font, charts on a grid ([`grid`]), axes and legends
//! ([`chart`]), tick labels and numbers in figure text ([`text`]), the time-series panels of
//! the run and compare figures ([`panel`]), and the file writes: every PNG and SVG is drawn
//! under a temporary name and renamed into place, the temporary removed on an error or Ctrl-C
//! ([`save`]). A writer implements [`Figure`] once and gets every output format.

pub mod chart;
pub mod panel;
pub mod text;

use std::{path::Path, sync::Once};

use plotters::{
    coord::Shift,
    prelude::{BitMapBackend, DrawingArea, DrawingBackend, IntoDrawingArea, SVGBackend, WHITE},
    style::{FontDesc, FontStyle, IntoFont},
};

use crate::{
    error::{Error, Result},
    report::{temp_path, TempFile},
};

/// What drawing into a backend returns: the backend's error as text.
pub type DrawResult = std::result::Result<(), String>;

/// Size and text of a figure. Writers give the nominal size ([`FigureStyle::px`]) and text sizes
/// in pixels of that size ([`FigureStyle::font`]); the fields stay private so that a style in
/// millimetres and points, or a print style, changes what [`FigureStyle::size`] and
/// [`FigureStyle::font`] return here and in no writer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FigureStyle {
    width: u32,
    height: u32,
}

impl FigureStyle {
    /// A figure of `width` × `height` pixels.
    pub const fn px(width: u32, height: u32) -> Self {
        Self { width, height }
    }

    /// `(width, height)` in pixels.
    pub const fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The figures' font (the bundled DejaVu Sans) at `px` pixels.
    pub fn font(&self, px: u32) -> FontDesc<'static> {
        (FONT_FAMILY, px).into_font()
    }
}

/// An output format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Bitmap (`.png`).
    Png,
    /// Vector (`.svg`).
    Svg,
}

impl Format {
    /// The format of `path`, from its extension.
    pub fn of(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("png") => Ok(Self::Png),
            Some("svg") => Ok(Self::Svg),
            _ => Err(Error::io(path, "a figure is written as .png or .svg")),
        }
    }

    /// The file extension.
    pub const fn extension(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Svg => "svg",
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

/// Writes `figure` to `path` (`.png` or `.svg`) under a temporary name, renamed into place
/// once complete.
pub fn save(path: &Path, style: &FigureStyle, figure: &impl Figure) -> Result<()> {
    register_font();
    let format = Format::of(path)?;
    let tmp = TempFile::new(temp_path(path));
    {
        let fail = |e: String| Error::io(path, e);
        match format {
            Format::Png => {
                let root = BitMapBackend::new(tmp.path(), style.size()).into_drawing_area();
                page(&root, style, format, figure).map_err(fail)?;
            }
            Format::Svg => {
                let root = SVGBackend::new(tmp.path(), style.size()).into_drawing_area();
                page(&root, style, format, figure).map_err(fail)?;
            }
        }
    }
    tmp.persist(path)
}

/// Writes `dir/stem.png` and `dir/stem.svg`.
pub fn save_png_and_svg(
    dir: &Path,
    stem: &str,
    style: &FigureStyle,
    figure: &impl Figure,
) -> Result<()> {
    for format in [Format::Png, Format::Svg] {
        save(
            &dir.join(format!("{stem}.{}", format.extension())),
            style,
            figure,
        )?;
    }
    Ok(())
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
    fn only_png_and_svg_are_figure_formats() {
        assert_eq!(Format::of(Path::new("a/b.png")).ok(), Some(Format::Png));
        assert_eq!(Format::of(Path::new("b.svg")).ok(), Some(Format::Svg));
        assert!(Format::of(Path::new("b.pdf")).is_err());
        assert!(Format::of(Path::new("b")).is_err());
    }
}
