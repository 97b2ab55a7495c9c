//! `[figures]`: the formats figures are written in, a print size in millimetres with text in
//! points, and the time window of the time-series figures (docs/SCENARIO.md).

use serde::{Deserialize, Serialize};

use super::{Format, Output, Print};
use crate::error::{Error, Result};

/// `format = "pdf"` or `format = ["png", "pdf"]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Formats {
    /// One format.
    One(String),
    /// Several.
    Many(Vec<String>),
}

/// `[figures]`; every key optional. Without a size key the writers' pixel sizes stay.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FiguresSpec {
    /// `"png"`, `"svg"`, `"pdf"` or a list (default `["png", "svg"]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub format: Option<Formats>,
    /// Page width \[mm\] (default 85, a journal column, when any print key is given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// Height of one chart \[mm\]; figures of several charts stack them (default: the
    /// figure's own aspect ratio).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_mm: Option<f64>,
    /// Tick-label size \[pt\] (default 8); titles and legends keep their proportion to it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub font_pt: Option<f64>,
    /// PNG resolution of a print size \[dpi\] (default 600).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dpi: Option<f64>,
    /// Time-series figures start here \[s\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t_from: Option<f64>,
    /// Time-series figures end here \[s\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t_to: Option<f64>,
}

/// Default page width: one journal column \[mm\].
pub const COLUMN_MM: f64 = 85.0;

fn within(key: &str, v: Option<f64>, lo: f64, hi: f64) -> Result<Option<f64>> {
    match v {
        Some(x) if !(lo..=hi).contains(&x) => Err(Error::invalid(
            format!("figures.{key}"),
            format!("must lie in {lo}..={hi} (got {x})"),
        )),
        _ => Ok(v),
    }
}

impl FiguresSpec {
    /// No key given.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The checked output of a run ending at `t_end`.
    pub fn output(&self, t_end: f64) -> Result<Output> {
        let mut out = Output::default();
        if let Some(f) = &self.format {
            let names: Vec<&str> = match f {
                Formats::One(s) => vec![s.as_str()],
                Formats::Many(v) => v.iter().map(String::as_str).collect(),
            };
            if names.is_empty() {
                return Err(Error::invalid("figures.format", "names no format"));
            }
            out.formats = [false; 3];
            for name in names {
                let format = Format::named(name).ok_or_else(|| {
                    Error::invalid(
                        "figures.format",
                        format!("unknown format `{name}` (known: png, svg, pdf)"),
                    )
                })?;
                out.formats[format as usize] = true;
            }
        }
        let width = within("width_mm", self.width_mm, 20.0, 1000.0)?;
        let height = within("height_mm", self.height_mm, 10.0, 1000.0)?;
        let font = within("font_pt", self.font_pt, 4.0, 36.0)?;
        let dpi = within("dpi", self.dpi, 50.0, 2400.0)?;
        if width.is_some() || height.is_some() || font.is_some() || dpi.is_some() {
            out.print = Some(Print {
                width_mm: width.unwrap_or(COLUMN_MM),
                chart_mm: height,
                font_pt: font.unwrap_or(8.0),
                dpi: dpi.unwrap_or(600.0),
            });
        }
        let from = within("t_from", self.t_from, 0.0, t_end)?;
        let to = within("t_to", self.t_to, 0.0, t_end)?;
        if let (Some(a), Some(b)) = (from, to) {
            if a >= b {
                return Err(Error::invalid(
                    "figures.t_to",
                    format!("must be later than figures.t_from = {a} (got {b})"),
                ));
            }
        }
        out.window = (from, to);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> FiguresSpec {
        toml::from_str(text).expect("a [figures] table")
    }

    #[test]
    fn no_keys_keep_png_and_svg_at_the_writers_pixel_sizes() -> Result<()> {
        assert_eq!(FiguresSpec::default().output(10.0)?, Output::default());
        Ok(())
    }

    #[test]
    fn one_format_or_a_list() -> Result<()> {
        assert_eq!(
            spec("format = \"pdf\"").output(1.0)?.formats,
            [false, false, true]
        );
        let both = spec("format = [\"png\", \"pdf\"]").output(1.0)?;
        assert_eq!(both.formats, [true, false, true]);
        Ok(())
    }

    #[test]
    fn a_print_key_gives_a_column_wide_page() -> Result<()> {
        let p = spec("font_pt = 9").output(1.0)?.print.expect("print");
        assert_eq!(
            (p.width_mm, p.font_pt, p.dpi, p.chart_mm),
            (85.0, 9.0, 600.0, None)
        );
        let (w, _) = p.page_mm(p.canvas((1000, 560), 1));
        assert!((w - 85.0).abs() < 0.2, "{w}");
        Ok(())
    }

    #[test]
    fn bad_values_name_their_key() {
        for (text, key) in [
            ("format = \"jpg\"", "figures.format"),
            ("format = []", "figures.format"),
            ("width_mm = 2", "figures.width_mm"),
            ("font_pt = 0", "figures.font_pt"),
            ("dpi = 1e9", "figures.dpi"),
            ("t_from = 3\nt_to = 2", "figures.t_to"),
            ("t_to = 20", "figures.t_to"),
        ] {
            let e = spec(text).output(10.0).expect_err(text).to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
    }
}
