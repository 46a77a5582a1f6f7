//! The visual-search analysis (`gazecast experiment analyze DIR... --out OUT`):
//! reads session folders ([`crate::session`]), computes the analyses of
//! Murphy (2007) §7.2 with [`crate::stats`], and writes the report, the
//! CSV tables and the figures.
//!
//! All on the search times `rt_s`, trials pooled across participants as
//! the seed did:
//!
//! - mean ± SE per condition, with the number of incorrect trials
//!   (`correct == Some(false)`; kept unless
//!   [`AnalyzeOptions::exclude_incorrect`], since the seed had no
//!   correctness measure);
//! - one-way ANOVA across all conditions (the seed: `F(10,473) = 3.3805`);
//! - the "significance of edges" one-way ANOVA over edges kept / edges
//!   discarded / control (`method == "full"`) with pooled-SD pairwise
//!   t-tests (the seed: `F(2,481) = 7.301`);
//! - the repeated-measures one-way ANOVA with the Greenhouse–Geisser
//!   correction on the per-participant condition means (the analysis the
//!   within-subjects design calls for, which the seed did not run);
//! - pooled-SD pairwise t-tests between all conditions with Holm-adjusted
//!   p-values, and the seed's pairs of interest;
//! - Table 7.1: rows = the distinct `silhouette_edges` values of the
//!   hybrid conditions, columns = their distinct insets ascending, plus
//!   `pooled`, with the control mean in the caption.
//!
//! Outputs (each through a temporary file and a rename; `OUT` may not be
//! one of the inputs or inside one, and no input file is ever written):
//! `report.md`, `stats.json` (every statistic at full precision), `conditions.csv`, `table-7.1.csv` (when the design has
//! hybrid conditions), `fig-conditions.png`, `fig-7.3.png`, `fig-7.4.png`,
//! and `scanpaths/<participant>-trial-NNN.png` for every trial that has a
//! `stimuli/trial-NNN.png`. Files of these names that an earlier analyze
//! left in `OUT` and this one does not write are removed (and listed in
//! the report's warnings); no other file in `OUT` is touched.
//!
//! If any session is synthetic (simulated participant), the report's first
//! line, every figure's title and the CSVs' first line and first column
//! say so.

mod compute;
mod format;
mod load;
mod markdown;
mod output;
mod report;
mod write;

pub use format::{fmt_deg, fmt_df, fmt_p, SEED_TABLE_7_1};
pub(crate) use output::{check_output_folder, OutputGuard};
pub use report::*;
pub use write::trial_fixations;

use std::path::{Path, PathBuf};

use crate::design::DesignError;
use crate::session::{SessionFileError, DESIGN_RON};
use compute::compute;
use load::{load_session, Loaded};
use output::OutputWriter;
use write::write_outputs;

/// `report.md`.
pub const REPORT_MD: &str = "report.md";
/// `stats.json`: every statistic of the report at full precision (the
/// report rounds F to 2 decimals and p to 4), with `synthetic` first.
pub const STATS_JSON: &str = "stats.json";
/// `conditions.csv`.
pub const CONDITIONS_CSV: &str = "conditions.csv";
/// `trials.csv`: every analysed session's trial table in one plain CSV
/// (a `data_source` column, then the `trials.tsv` columns), for R, SPSS or
/// a spreadsheet.
pub const TRIALS_CSV: &str = "trials.csv";
/// `table-7.1.csv`.
pub const TABLE_7_1_CSV: &str = "table-7.1.csv";
/// `fig-conditions.png`: mean search time per condition.
pub const FIG_CONDITIONS: &str = "fig-conditions.png";
/// `fig-7.3.png`: mean search time pooled, E / NE / control.
pub const FIG_7_3: &str = "fig-7.3.png";
/// `fig-7.4.png`: mean search time per inset, E and NE, control line.
pub const FIG_7_4: &str = "fig-7.4.png";
/// `scanpaths/`.
pub const SCANPATHS_DIR: &str = "scanpaths";

/// The seed's pairs of interest (§7.2.2) and what it reported for them.
pub const SEED_PAIRS: &[(&str, &str, &str)] = &[
    ("NE2", "E5", "p < 0.05"),
    ("NE2", "E15", "p < 0.01"),
    ("NE2", "E20", "p < 0.01"),
    (
        "NE2",
        "E10",
        "expected, but no significant difference observed",
    ),
];

/// Options of [`analyze`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AnalyzeOptions {
    /// Leave out trials with `correct == Some(false)` (default `false`:
    /// the seed had no correctness measure and kept every trial).
    pub exclude_incorrect: bool,
    /// Draw the scanpath pictures (default `true`).
    pub scanpaths: bool,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        AnalyzeOptions {
            exclude_incorrect: false,
            scanpaths: true,
        }
    }
}

/// Why the analysis stopped. Every variant that is about a file or folder
/// names it.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// No input folders.
    #[error("no session folders given")]
    NoInputs,
    /// A session file is missing or corrupt.
    #[error(transparent)]
    File(#[from] SessionFileError),
    /// `design.ron` is missing or invalid.
    #[error("{}: {source}", path.display())]
    Design {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: DesignError,
    },
    /// A file parsed but its content is inconsistent.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(": line {l}")).unwrap_or_default())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// 1-based line, where it is about one row.
        line: Option<u64>,
        /// What is wrong.
        message: String,
    },
    /// Two folders ran different designs.
    #[error("{} ran design {first_design:?} but {} ran {second_design:?}: analyse one design at a time", first.display(), second.display())]
    DesignMismatch {
        /// First folder.
        first: PathBuf,
        /// Its design.
        first_design: String,
        /// Second folder.
        second: PathBuf,
        /// Its design.
        second_design: String,
    },
    /// Two folders of the same participant.
    #[error("{} and {} are both sessions of participant {participant:?}: analyse one session per participant", first.display(), second.display())]
    DuplicateParticipant {
        /// The participant.
        participant: String,
        /// First folder.
        first: PathBuf,
        /// Second folder.
        second: PathBuf,
    },
    /// The output folder is an input folder or inside one.
    #[error("output folder {} is input folder {} or inside it: choose an output folder outside the session folders", out.display(), input.display())]
    OutputInsideInput {
        /// The output folder.
        out: PathBuf,
        /// The input folder.
        input: PathBuf,
    },
    /// An output file could not be written.
    #[error("cannot write {}: {message}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// The cause.
        message: String,
    },
}

/// Reads the session folders, computes the analyses and writes the
/// outputs into `out` (created if needed). See the module documentation.
pub fn analyze(
    dirs: &[PathBuf],
    out: &Path,
    opts: &AnalyzeOptions,
) -> Result<Report, AnalysisError> {
    if dirs.is_empty() {
        return Err(AnalysisError::NoInputs);
    }
    let guard =
        check_output_folder(dirs, out).map_err(|(input, _)| AnalysisError::OutputInsideInput {
            out: out.to_path_buf(),
            input,
        })?;
    let mut warnings = Vec::new();
    let mut sessions: Vec<Loaded> = Vec::new();
    for dir in dirs {
        let s = load_session(dir, opts, &mut warnings)?;
        if let Some(first) = sessions.first() {
            if first.design.name != s.design.name {
                return Err(AnalysisError::DesignMismatch {
                    first: first.dir.clone(),
                    first_design: first.design.name.clone(),
                    second: s.dir.clone(),
                    second_design: s.design.name.clone(),
                });
            }
            // Same name is not enough: sessions whose stimuli differ
            // (`meshes: 4` and `64`, another grid, other conditions) are
            // never pooled.
            let differences = first.design.differences(&s.design);
            if !differences.is_empty() {
                let shown: Vec<&str> = differences.iter().take(8).map(String::as_str).collect();
                return Err(AnalysisError::Invalid {
                    path: s.dir.join(DESIGN_RON),
                    line: None,
                    message: format!(
                        "design {:?} differs from {} in {} field{} ({}{}): sessions that ran \
                         different stimuli are not pooled; analyse each version of the design \
                         separately",
                        s.design.name,
                        first.dir.join(DESIGN_RON).display(),
                        differences.len(),
                        if differences.len() == 1 { "" } else { "s" },
                        shown.join("; "),
                        if differences.len() > shown.len() {
                            "; …"
                        } else {
                            ""
                        }
                    ),
                });
            }
        }
        if let Some(other) = sessions
            .iter()
            .find(|o| o.info.participant == s.info.participant)
        {
            return Err(AnalysisError::DuplicateParticipant {
                participant: s.info.participant.clone(),
                first: other.dir.clone(),
                second: s.dir.clone(),
            });
        }
        sessions.push(s);
    }
    let mut report = compute(&sessions, opts, warnings);
    std::fs::create_dir_all(out).map_err(|e| AnalysisError::Output {
        path: out.to_path_buf(),
        message: e.to_string(),
    })?;
    let writer = OutputWriter {
        out: out.to_path_buf(),
        guard,
    };
    write_outputs(&writer, &sessions, opts, &mut report)?;
    Ok(report)
}
