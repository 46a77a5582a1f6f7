//! How numbers and cells are written in the report and the tables
//! (degrees of freedom, p-values, degrees, means ± SE), and the lines that
//! mark synthetic data.

use std::collections::BTreeSet;

use super::report::Report;
use crate::stats::Summary;

/// Degrees of freedom: integers as integers, corrected df to 2 decimals.
pub fn fmt_df(df: f64) -> String {
    if (df - df.round()).abs() < 1e-9 {
        format!("{}", df.round() as i64)
    } else {
        format!("{df:.2}")
    }
}

/// `p = 0.0123`, or `p < 0.0001`.
pub fn fmt_p(p: f64) -> String {
    if p < 1e-4 {
        "p < 0.0001".into()
    } else {
        format!("p = {p:.4}")
    }
}

/// A p-value for a table cell: `0.0123`, or `< 0.0001`.
pub(crate) fn fmt_p_cell(p: f64) -> String {
    if p < 1e-4 {
        "< 0.0001".into()
    } else {
        format!("{p:.4}")
    }
}

/// An inset in degrees: `2`, `2.5`.
pub fn fmt_deg(d: f64) -> String {
    format!("{d}")
}

pub(crate) fn md_cell(s: &str) -> String {
    s.replace('|', "\\|")
}

pub(crate) fn fmt_summary(s: &Option<Summary>) -> String {
    match s {
        Some(s) => format!("{:.2} ± {:.2} (n={})", s.mean, s.se, s.n),
        None => "n/a".into(),
    }
}

/// The seed's Table 7.1 (s), for comparison: rows No Edges, Edges; columns
/// 2, 5, 10, 15, 20 deg and pooled; control 8.69 s.
pub const SEED_TABLE_7_1: [[f64; 6]; 2] = [
    [10.22, 8.80, 7.84, 8.38, 7.97, 8.64],
    [7.47, 6.95, 8.69, 6.65, 6.27, 7.21],
];

pub(crate) fn is_seed_design(report: &Report) -> bool {
    let names: BTreeSet<&str> = report.conditions.iter().map(|c| c.name.as_str()).collect();
    let seed: BTreeSet<&str> = [
        "control", "NE2", "NE5", "NE10", "NE15", "NE20", "E2", "E5", "E10", "E15", "E20",
    ]
    .into_iter()
    .collect();
    names == seed
}

pub(crate) const SYNTHETIC_LINE: &str = "**SYNTHETIC DATA: these results come from simulated participants, not from human observers. Do not report them as human data.**";
pub(crate) const SYNTHETIC_CSV: &str = "# SYNTHETIC DATA: simulated participant(s), not human data";

pub(crate) fn data_source(report: &Report) -> &'static str {
    if report.synthetic {
        "synthetic"
    } else {
        "human"
    }
}
