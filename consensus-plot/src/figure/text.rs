//! Text in figures: tick labels that follow `plotters`' tick steps, numbers and times without
//! trailing zeros and with a real minus sign, sub- and superscript digits, and the reordering
//! of combining marks the bitmap renderer needs.

/// `n` as Unicode subscript digits (`y₁₂`).
pub fn sub(n: usize) -> String {
    n.to_string()
        .chars()
        .map(|c| char::from_u32(0x2080 + c.to_digit(10).unwrap_or(0)).unwrap_or(c))
        .collect()
}

/// `n` as Unicode superscript (`10⁻⁵`).
pub fn sup(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            d => d
                .to_digit(10)
                .and_then(|d| char::from_u32(0x2070 + d))
                .unwrap_or(d),
        })
        .collect()
}

/// A time for figure text: `4 s`, `1.8636 s` (at most four decimals).
pub fn secs(t: f64) -> String {
    format!("{} s", trim_number(t))
}

/// The symbol of a legend label: `u₁` of `u₁ = u₂ (identical)`.
pub fn short_name(label: &str) -> &str {
    let end = [" = ", " (", ": "]
        .iter()
        .filter_map(|sep| label.find(sep))
        .min()
        .unwrap_or(label.len());
    &label[..end]
}

/// A value for figure text: whole above 100 (`−16519`), else three significant digits.
pub fn significant(v: f64) -> String {
    if v.abs() >= 100.0 {
        format!("{v:.0}").replace('-', "−")
    } else {
        let d = (2.0 - v.abs().log10().floor()).clamp(0.0, 8.0) as usize;
        format!("{v:.d$}").replace('-', "−")
    }
}

/// `2`, `0.5`, `0.0004` (no trailing zeros, at most 4 decimals).
pub fn trim_number(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.replace('-', "−")
    }
}

/// A tick label for `v` on the axis `[lo, hi]`: plain decimals
/// to the precision of the tick step, scientific `a×10ᵏ` for very small or large magnitudes,
/// never `-0`, with a real minus sign.
pub fn tick_label(v: f64, (lo, hi): (f64, f64)) -> String {
    let mag = lo.abs().max(hi.abs());
    let decimals = |scale: f64| -> usize {
        let step = tick_step((lo / scale, hi / scale), MESH_LABELS);
        if step > 0.0 && step.is_finite() {
            (-(step.log10() + 1e-9).floor()).clamp(0.0, 6.0) as usize
        } else {
            2
        }
    };
    let minus = |s: String| -> String {
        if s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            "0".into()
        } else {
            s.replace('-', "−")
        }
    };
    if mag > 0.0 && !(1e-3..1e5).contains(&mag) {
        let exp = mag.log10().floor() as i32;
        let scale = 10f64.powi(exp);
        let d = decimals(scale);
        let m = minus(format!("{:.d$}", v / scale));
        if m == "0" {
            return m;
        }
        return format!("{m}×10{}", sup(exp));
    }
    minus(format!("{v:.prec$}", prec = decimals(1.0)))
}

/// Labels per axis `plotters`' mesh asks for by default.
pub const MESH_LABELS: usize = 11;

/// The tick step `plotters` picks for at most `n` ticks on `[lo, hi]` (its algorithm for `f64`
/// axes): `10ᵏ`, `5·10ᵏ⁻¹` or `2·10ᵏ⁻¹`, the finest whose multiples inside the range are at most
/// `n`.
pub fn tick_step((lo, hi): (f64, f64), n: usize) -> f64 {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return 0.0;
    }
    let ticks = |step: f64| ((hi / step).floor() - (lo / step).ceil() + 1.0).round();
    let mut scale = 10f64.powf(span.log10().floor());
    if 1.0 + (span / scale).floor() > n as f64 {
        scale *= 10.0;
    }
    loop {
        let coarse = scale;
        for div in [2.0, 5.0, 10.0] {
            if ticks(coarse / div) > n as f64 {
                return scale;
            }
            scale = coarse / div;
        }
    }
}

/// The bitmap backend draws a combining mark at the pen position after its base letter (no
/// mark positioning); put it before the letter so that `μ̂` gets its hat on the `μ`. SVG keeps
/// the Unicode order, which SVG viewers position correctly.
pub fn bitmap_text(text: &str) -> String {
    let mut out: Vec<char> = Vec::with_capacity(text.len());
    for c in text.chars() {
        match (c, out.pop()) {
            ('\u{300}'..='\u{36f}', Some(base)) => out.extend([c, base]),
            (c, prev) => out.extend(prev.into_iter().chain([c])),
        }
    }
    out.into_iter().collect()
}

/// Three significant digits.
pub fn short(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-4..1e4).contains(&v.abs()) {
        let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_have_no_negative_zero_and_use_scientific_notation_when_small() {
        let r = (-0.19, 0.18);
        assert_eq!(tick_label(-0.0, r), "0");
        assert_eq!(tick_label(-1e-17, r), "0");
        assert_eq!(tick_label(-0.05, r), "−0.05");
        assert_eq!(tick_label(0.15, r), "0.15");
        assert_eq!(tick_step(r, MESH_LABELS), 0.05);
        // plotters puts ticks every 0.5 on [-2.2, 2.2]: one decimal, no repeated "2".
        assert_eq!(tick_step((-1.71, 3.6), MESH_LABELS), 0.5);
        assert_eq!(tick_step((-2.2, 2.2), MESH_LABELS), 0.5);
        assert_eq!(tick_label(1.5, (-2.2, 2.2)), "1.5");
        assert_eq!(tick_label(2.0, (-2.2, 2.2)), "2.0");
        assert_eq!(tick_label(2.0e-5, (-2e-6, 9.4e-5)), "2×10⁻⁵");
        assert_eq!(tick_label(2.5e-5, (-2e-6, 3.1e-5)), "2.5×10⁻⁵");
        assert_eq!(tick_label(20000.0, (-30000.0, 1000.0)), "20000");
        assert_eq!(tick_label(-2.0e5, (-3e5, 1e5)), "−2.0×10⁵");
        assert_eq!(sub(12), "₁₂");
        assert_eq!(bitmap_text("μ̂ and ŷ, x̂₁"), "\u{302}μ and ŷ, \u{302}x₁");
        assert_eq!(trim_number(4.0), "4");
        assert_eq!(trim_number(0.0004), "0.0004");
        assert_eq!(significant(-16519.07), "−16519");
        assert_eq!(significant(2.1234), "2.12");
        assert_eq!(short_name("u₁ = u₂ (identical)"), "u₁");
        assert_eq!(short_name("agent 1"), "agent 1");
        assert_eq!(short_name("example2-baseline"), "example2-baseline");
    }

    #[test]
    fn short_keeps_three_significant_digits() {
        assert_eq!(short(0.001), "0.001");
        assert_eq!(short(0.1703), "0.17");
        assert_eq!(short(47.21), "47.2");
        assert_eq!(short(2.0), "2");
        assert_eq!(short(0.0), "0");
        assert_eq!(short(16519.0), "1.65e4");
    }
}
