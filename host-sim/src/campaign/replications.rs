//! `summary.csv`: per grid point, the mean of each metric over its draws (replications) with a
//! 95 % confidence interval of the mean from Student's t distribution.

use std::{collections::BTreeMap, path::Path};

use distrs::StudentsT;

use crate::{
    campaign::{
        results::csv_line,
        spec::{json_number, WINDOW_PREFIX},
    },
    report::write_atomic,
};
use consensus_plot::error::Result;

/// Columns of `results.csv` summarised (besides every `window.<name>`).
pub const SUMMARISED: [&str; 4] = [
    "settling_time",
    "max_error_after_predefined_time",
    "max_abs_u",
    "total_u_energy",
];

/// Name of the file in `--out`.
pub const FILE: &str = "summary.csv";

/// Mean, 95 % half-width and count of `values`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanCi {
    /// Values summarised.
    pub n: usize,
    /// Their mean (None without values).
    pub mean: Option<f64>,
    /// `t_{0.975, n−1} s / √n` with the sample standard deviation `s` (None below 2 values).
    pub ci95: Option<f64>,
}

/// The mean of `values` and the half-width of its two-sided 95 % Student-t interval.
pub fn mean_ci(values: &[f64]) -> MeanCi {
    let n = values.len();
    if n == 0 {
        return MeanCi {
            n,
            mean: None,
            ci95: None,
        };
    }
    let nf = n as f64;
    let mean = values.iter().sum::<f64>() / nf;
    let ci95 = (n >= 2).then(|| {
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (nf - 1.0);
        StudentsT::ppf(0.975, nf - 1.0) * (var / nf).sqrt()
    });
    MeanCi {
        n,
        mean: Some(mean),
        ci95,
    }
}

/// Writes `summary.csv` when the campaign has more than one draw per grid point: one row per
/// grid point with its axis values, `runs`, `valid` (ok and not diverged), `diverged`, then
/// `<metric>.n`, `<metric>.mean`, `<metric>.ci95` for each summarised metric over the valid
/// draws that have a value. Returns whether it was written.
pub fn write_summary(
    dir: &Path,
    axes: usize,
    draws: u64,
    header: &[String],
    recs: &super::results::Records,
) -> Result<bool> {
    if draws < 2 {
        return Ok(false);
    }
    let col = |name: &str| header.iter().position(|h| h == name);
    let metrics: Vec<(&str, usize)> = header
        .iter()
        .filter(|h| SUMMARISED.contains(&h.as_str()) || h.starts_with(WINDOW_PREFIX))
        .filter_map(|h| Some((h.as_str(), col(h)?)))
        .collect();
    let (Some(status), Some(diverged)) = (col("status"), col("diverged")) else {
        return Ok(false);
    };
    let mut out_header: Vec<String> = vec!["point".into()];
    out_header.extend(header.iter().skip(1).take(axes).cloned());
    out_header.extend(["runs", "valid", "diverged"].map(String::from));
    for (m, _) in &metrics {
        out_header.extend(["n", "mean", "ci95"].map(|s| format!("{m}.{s}")));
    }
    let mut text = csv_line(&out_header);
    text.push('\n');
    let mut points: BTreeMap<u64, Vec<&csv::StringRecord>> = BTreeMap::new();
    for (run, rec) in recs {
        if let Some(rec) = rec {
            points.entry(run / draws).or_default().push(rec);
        }
    }
    for (point, recs) in &points {
        let valid: Vec<&csv::StringRecord> = recs
            .iter()
            .copied()
            .filter(|r| r.get(status) == Some("ok") && r.get(diverged) == Some("false"))
            .collect();
        let mut cells = vec![point.to_string()];
        cells.extend((1..=axes).map(|i| recs[0].get(i).unwrap_or_default().to_string()));
        cells.push(recs.len().to_string());
        cells.push(valid.len().to_string());
        let div = recs.iter().filter(|r| r.get(diverged) == Some("true"));
        cells.push(div.count().to_string());
        for (_, c) in &metrics {
            let values: Vec<f64> = valid
                .iter()
                .filter_map(|r| r.get(*c)?.parse().ok())
                .collect();
            let s = mean_ci(&values);
            cells.push(s.n.to_string());
            cells.push(s.mean.map(json_number).unwrap_or_default());
            cells.push(s.ci95.map(json_number).unwrap_or_default());
        }
        text.push_str(&csv_line(&cells));
        text.push('\n');
    }
    write_atomic(&dir.join(FILE), text.as_bytes())?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: R `t.test(c(1, 2, 3, 4))$conf.int` = 2.5 ± 2.054 (t_{0.975,3} = 3.182446);
    /// Hill's quantile algorithm is good to about 1e-6 relative.
    #[test]
    fn confidence_interval_matches_student_t_reference() {
        let s = mean_ci(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!((s.n, s.mean), (4, Some(2.5)));
        let half = s.ci95.unwrap_or(f64::NAN);
        let want = 3.182_446_305 * (5.0f64 / 3.0 / 4.0).sqrt();
        assert!((half / want - 1.0).abs() < 1e-5, "{half} vs {want}");
    }

    #[test]
    fn one_value_has_a_mean_and_no_interval_none_has_neither() {
        assert_eq!(
            mean_ci(&[7.0]),
            MeanCi {
                n: 1,
                mean: Some(7.0),
                ci95: None
            }
        );
        assert_eq!(mean_ci(&[]).mean, None);
    }
}
