//! `[metrics]` and `[[metrics.window]]` of docs/SCENARIO.md: the settling dwell and the
//! user-defined window metrics, with their checks.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use consensus_plot::error::{Error, Result};

/// `[metrics]`: the settling dwell and user-defined window metrics (docs/SCENARIO.md).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricsSpec {
    /// How long the error must stay inside the band for `settling_time` \[s\]; default: the
    /// scheme's own deadline (`metrics::deadline`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub settle_dwell: Option<f64>,
    /// `[[metrics.window]]`, reported in `summary.json` `windows` in this order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub window: Vec<WindowSpec>,
}

/// One `[[metrics.window]]`: a figure over the samples with `from ≤ t_k ≤ to`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowSpec {
    /// Unique name: the `summary.json` entry and the `window.<name>` column of campaigns.
    pub name: String,
    /// Start \[s\] (default 0).
    #[serde(default)]
    pub from: f64,
    /// End \[s\] (default: the end of the run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<f64>,
    /// What is measured.
    pub kind: WindowKind,
}

/// The figure of a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowKind {
    /// `max_{i,k} |y_i − y_d|` \[y\].
    MaxError,
    /// `Σ_i Σ_k |y_i − y_d| h` [y s].
    Iae,
    /// `Σ_i Σ_k Σ_l u_{i,l}² h` [u² s].
    Energy,
}

impl WindowKind {
    /// The unit of the figure.
    pub fn unit(self) -> &'static str {
        match self {
            Self::MaxError => "[y]",
            Self::Iae => "[y] s",
            Self::Energy => "[u]^2 s",
        }
    }
}

impl MetricsSpec {
    /// No `[metrics]` section (left out of `check`).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Checks the dwell and the windows.
    pub fn check(&self) -> Result<()> {
        if let Some(d) = self.settle_dwell {
            if !d.is_finite() || d <= 0.0 {
                return Err(Error::invalid(
                    "metrics.settle_dwell",
                    format!("must be a finite number > 0 [s] (got {d})"),
                ));
            }
        }
        let mut names = BTreeSet::new();
        for (i, w) in self.window.iter().enumerate() {
            let key = |k: &str| format!("metrics.window[{}].{k}", i + 1);
            if w.name.trim().is_empty() {
                return Err(Error::invalid(key("name"), "must not be empty"));
            }
            if !names.insert(w.name.as_str()) {
                return Err(Error::invalid(
                    key("name"),
                    format!("\"{}\" names two windows", w.name),
                ));
            }
            if !w.from.is_finite() || w.from < 0.0 {
                return Err(Error::invalid(
                    key("from"),
                    format!("must be a finite number >= 0 [s] (got {})", w.from),
                ));
            }
            if let Some(to) = w.to {
                if !to.is_finite() || to <= w.from {
                    return Err(Error::invalid(
                        key("to"),
                        format!("must be a finite number > from = {} [s] (got {to})", w.from),
                    ));
                }
            }
        }
        Ok(())
    }
}
