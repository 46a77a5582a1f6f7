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
//! `report.md`, `conditions.csv`, `table-7.1.csv` (when the design has
//! hybrid conditions), `fig-conditions.png`, `fig-7.3.png`, `fig-7.4.png`,
//! and `scanpaths/<participant>-trial-NNN.png` for every trial that has a
//! `stimuli/trial-NNN.png`. Files of these names that an earlier analyze
//! left in `OUT` and this one does not write are removed (and listed in
//! the report's warnings); no other file in `OUT` is touched.
//!
//! If any session is synthetic (simulated participant), the report's first
//! line, every figure's title and the CSVs' first line and first column
//! say so.

use crate::design::{Condition, Design, DesignError, MAX_SEARCH_S};
use crate::figures::{self, Bar, BarChart, BarGroup, Fixation, Reference, Scanpath};
use crate::session::{
    self, read_tsv, EventRow, SessionFileError, SessionInfo, TrialRow, DESIGN_RON, EVENTS_TSV,
    SESSION_JSON, TRIALS_TSV,
};
use crate::stats::{self, Anova, Pair, RmAnova, Summary};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// `report.md`.
pub const REPORT_MD: &str = "report.md";
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

/// A result that may have been skipped, with the reason.
#[derive(Debug, Clone, PartialEq)]
pub enum Computed<T> {
    /// Computed.
    Done(T),
    /// Not computed, and why.
    Skipped(String),
}

impl<T> Computed<T> {
    /// The value, if computed.
    pub fn done(&self) -> Option<&T> {
        match self {
            Computed::Done(t) => Some(t),
            Computed::Skipped(_) => None,
        }
    }
}

/// One input session, as the report lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionSummary {
    /// The folder.
    pub dir: PathBuf,
    /// Participant id.
    pub participant: String,
    /// Participant index.
    pub participant_index: usize,
    /// Software that ran the session.
    pub software: String,
    /// Tracker.
    pub tracker: String,
    /// Synthetic (session.json or any trial row).
    pub synthetic: bool,
    /// Trials read.
    pub trials: usize,
}

/// Search time in one condition.
#[derive(Debug, Clone, PartialEq)]
pub struct ConditionStats {
    /// Condition name.
    pub name: String,
    /// Method.
    pub method: String,
    /// Inset diameter (deg).
    pub inset_deg: Option<f64>,
    /// Silhouette edges kept.
    pub silhouette_edges: bool,
    /// Trials read (before any exclusion).
    pub n_trials: usize,
    /// Of those, `correct == Some(false)`.
    pub n_incorrect: usize,
    /// Mean ± SE of the analysed trials (`None`: no trials).
    pub summary: Option<Summary>,
}

/// Search time in a group of conditions (pooled trials).
#[derive(Debug, Clone, PartialEq)]
pub struct GroupStats {
    /// Label (`"E"`, `"NE"`, `"Control"`).
    pub label: String,
    /// The conditions pooled.
    pub conditions: Vec<String>,
    /// Mean ± SE over their trials.
    pub summary: Summary,
}

/// A one-way ANOVA with the group names.
#[derive(Debug, Clone, PartialEq)]
pub struct OneWay {
    /// Group names, in the order of the test.
    pub groups: Vec<String>,
    /// The table.
    pub anova: Anova,
}

impl OneWay {
    /// `F(10,473) = 3.38, p = 0.0003`, as the seed reports it.
    pub fn apa(&self) -> String {
        format!(
            "F({},{}) = {:.2}, {}",
            fmt_df(self.anova.df_between),
            fmt_df(self.anova.df_within),
            self.anova.f,
            fmt_p(self.anova.p)
        )
    }
}

/// One pairwise comparison, with the condition (or group) names.
#[derive(Debug, Clone, PartialEq)]
pub struct PairResult {
    /// First.
    pub a: String,
    /// Second.
    pub b: String,
    /// `stats::pairwise_t_pooled`'s result (`diff = mean(a) − mean(b)`).
    pub pair: Pair,
}

/// The seed's "significance of edges" analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgesAnalysis {
    /// E (edges kept), NE (edges discarded), Control — those present.
    pub groups: Vec<GroupStats>,
    /// One-way ANOVA over the groups.
    pub anova: OneWay,
    /// Pooled-SD t-tests between the groups (Holm over these pairs).
    pub pairs: Vec<PairResult>,
}

/// The repeated-measures ANOVA on per-participant condition means.
#[derive(Debug, Clone, PartialEq)]
pub struct RmResult {
    /// The participants included (those with every condition).
    pub participants: Vec<String>,
    /// Participants left out, with the reason.
    pub excluded: Vec<String>,
    /// The table.
    pub rm: RmAnova,
}

impl RmResult {
    /// `F(10,20) = 2.10, p = 0.07; GG ε = 0.31, F(3.10,6.20), p = 0.19`.
    pub fn apa(&self) -> String {
        let r = &self.rm;
        format!(
            "F({},{}) = {:.2}, {}; Greenhouse–Geisser ε = {:.3}: F({},{}), {}",
            fmt_df(r.df_conditions),
            fmt_df(r.df_error),
            r.f,
            fmt_p(r.p),
            r.gg_epsilon,
            fmt_df(r.gg_epsilon * r.df_conditions),
            fmt_df(r.gg_epsilon * r.df_error),
            fmt_p(r.p_gg)
        )
    }
}

/// One of the seed's pairs of interest.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedPair {
    /// First condition.
    pub a: String,
    /// Second condition.
    pub b: String,
    /// What the seed reported.
    pub seed: String,
    /// Our comparison (`None` if a condition is missing or empty).
    pub result: Option<PairResult>,
}

/// Table 7.1: mean search time by edges (rows) and inset (columns).
#[derive(Debug, Clone, PartialEq)]
pub struct Table71 {
    /// Column insets (deg), ascending.
    pub insets: Vec<f64>,
    /// Rows: `silhouette_edges` false ("No Edges") before true ("Edges").
    pub rows: Vec<Table71Row>,
    /// The control (method `full`), pooled, for the caption.
    pub control: Option<Summary>,
}

/// One row of [`Table71`].
#[derive(Debug, Clone, PartialEq)]
pub struct Table71Row {
    /// `"No Edges"` or `"Edges"`.
    pub label: String,
    /// The row's `silhouette_edges`.
    pub silhouette_edges: bool,
    /// Per inset (same order as [`Table71::insets`]); `None`: no trials.
    pub cells: Vec<Option<Summary>>,
    /// All the row's trials pooled.
    pub pooled: Option<Summary>,
}

/// Everything [`analyze`] computed and wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Any session synthetic.
    pub synthetic: bool,
    /// The design's name.
    pub design_name: String,
    /// The inputs, in the order given.
    pub sessions: Vec<SessionSummary>,
    /// Trials read.
    pub n_trials_read: usize,
    /// Trials analysed (after exclusion).
    pub n_trials: usize,
    /// Incorrect trials excluded (0 unless `exclude_incorrect`).
    pub n_excluded: usize,
    /// Whether incorrect trials were excluded.
    pub exclude_incorrect: bool,
    /// Per condition, in design order.
    pub conditions: Vec<ConditionStats>,
    /// One-way ANOVA across the conditions with trials.
    pub anova: Computed<OneWay>,
    /// Edges kept / discarded / control.
    pub edges: Computed<EdgesAnalysis>,
    /// Repeated-measures ANOVA with Greenhouse–Geisser.
    pub rm_anova: Computed<RmResult>,
    /// Pooled-SD t-tests between all conditions with trials.
    pub pairwise: Computed<Vec<PairResult>>,
    /// The pairs with Holm-adjusted p < 0.05.
    pub significant: Vec<PairResult>,
    /// The seed's pairs of interest (those whose conditions the design has).
    pub seed_pairs: Vec<SeedPair>,
    /// Table 7.1 (`None`: the design has no hybrid conditions).
    pub table71: Option<Table71>,
    /// Skipped lines, left-out participants, scanpaths not drawn.
    pub warnings: Vec<String>,
    /// Files written.
    pub outputs: Vec<PathBuf>,
}

struct Loaded {
    dir: PathBuf,
    info: SessionInfo,
    design: Design,
    trials: Vec<TrialRow>,
    /// `events.tsv`, read when a trial has a stimulus picture (scanpaths).
    events: Vec<EventRow>,
    synthetic: bool,
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

/// Absolute, normalised form of `p` (symlinks resolved for the part that
/// exists).
fn absolute(p: &Path) -> PathBuf {
    let mut existing = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            existing = c;
            break;
        }
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name.to_os_string());
                existing = parent.to_path_buf();
            }
            _ => break,
        }
    }
    for name in rest.into_iter().rev() {
        existing.push(name);
    }
    // Lexically resolve what canonicalize could not (a `..` after a missing part).
    let mut norm = PathBuf::new();
    for c in existing.components() {
        match c {
            Component::ParentDir => {
                norm.pop();
            }
            Component::CurDir => {}
            other => norm.push(other),
        }
    }
    norm
}

/// Which paths the outputs may not touch: the input folders.
pub(crate) struct OutputGuard {
    inputs: Vec<PathBuf>,
}

impl OutputGuard {
    /// Refuses a path inside an input folder (an input folder can sit
    /// inside the output folder), so no input file is ever replaced.
    pub(crate) fn check(&self, path: &Path) -> Result<(), String> {
        let abs = absolute(path);
        match self.inputs.iter().find(|i| abs.starts_with(i)) {
            Some(input) => Err(format!(
                "it is inside input folder {}; refusing to write there",
                input.display()
            )),
            None => Ok(()),
        }
    }
}

/// Refuses an output folder that is one of the inputs or inside one;
/// `Err((input, message))`.
pub(crate) fn check_output_folder(
    dirs: &[PathBuf],
    out: &Path,
) -> Result<OutputGuard, (PathBuf, String)> {
    let out_abs = absolute(out);
    let mut inputs = Vec::new();
    for d in dirs {
        let d_abs = absolute(d);
        if out_abs.starts_with(&d_abs) {
            return Err((
                d.clone(),
                "the output folder is an input folder or inside one".into(),
            ));
        }
        inputs.push(d_abs);
    }
    Ok(OutputGuard { inputs })
}

struct OutputWriter {
    out: PathBuf,
    guard: OutputGuard,
}

impl OutputWriter {
    fn path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    fn guard(&self, path: &Path) -> Result<(), AnalysisError> {
        self.guard
            .check(path)
            .map_err(|message| AnalysisError::Output {
                path: path.to_path_buf(),
                message,
            })
    }

    fn bytes(&self, path: &Path, bytes: &[u8]) -> Result<(), AnalysisError> {
        self.guard(path)?;
        session::write_atomic(path, bytes).map_err(|e| AnalysisError::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }
}

fn load_session(
    dir: &Path,
    opts: &AnalyzeOptions,
    warnings: &mut Vec<String>,
) -> Result<Loaded, AnalysisError> {
    let info_path = dir.join(SESSION_JSON);
    let info = SessionInfo::read(&info_path)?;
    let design_path = dir.join(DESIGN_RON);
    let design = Design::load(&design_path).map_err(|source| AnalysisError::Design {
        path: design_path.clone(),
        source,
    })?;
    if info.design_name != design.name {
        return Err(AnalysisError::Invalid {
            path: info_path,
            line: None,
            message: format!(
                "design_name {:?} is not the name of the design in {} ({:?})",
                info.design_name,
                design_path.display(),
                design.name
            ),
        });
    }
    let trials_path = dir.join(TRIALS_TSV);
    let read = read_tsv::<TrialRow>(&trials_path)?;
    warnings.extend(read.warnings.iter().map(|w| w.to_string()));
    let mut seen: BTreeMap<usize, u64> = BTreeMap::new();
    let mut synthetic = info.synthetic;
    for (row, &line) in read.rows.iter().zip(&read.lines) {
        let bad = |message: String| AnalysisError::Invalid {
            path: trials_path.clone(),
            line: Some(line),
            message,
        };
        if row.participant != info.participant {
            return Err(bad(format!(
                "participant {:?}, but {} says {:?}",
                row.participant,
                info_path.display(),
                info.participant
            )));
        }
        let Some(c) = design.conditions.iter().find(|c| c.name == row.condition) else {
            return Err(bad(format!(
                "condition {:?} is not in {} ({})",
                row.condition,
                design_path.display(),
                design
                    .conditions
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        if c.method != row.method
            || c.inset_deg != row.inset_deg
            || c.silhouette_edges != row.silhouette_edges
        {
            return Err(bad(format!(
                "condition {:?} is {} in {} but the row says {}",
                c.name,
                describe(&c.method, c.inset_deg, c.silhouette_edges),
                design_path.display(),
                describe(&row.method, row.inset_deg, row.silhouette_edges)
            )));
        }
        if !(row.rt_s.is_finite() && (0.0..=MAX_SEARCH_S).contains(&row.rt_s)) {
            return Err(bad(format!(
                "rt_s {}: a search time must be 0 to {MAX_SEARCH_S} s",
                screen_geometry::fmt_f64(row.rt_s)
            )));
        }
        if let Some(first) = seen.insert(row.trial, line) {
            return Err(bad(format!(
                "trial {} already appears on line {first}",
                row.trial
            )));
        }
        synthetic |= row.synthetic;
    }
    // Scanpaths need events.tsv: read (and check) it before anything is written.
    let mut events = Vec::new();
    if opts.scanpaths
        && read
            .rows
            .iter()
            .any(|t| session::stimulus_path(dir, t.trial).is_file())
    {
        let e = read_tsv::<EventRow>(&dir.join(EVENTS_TSV))?;
        warnings.extend(e.warnings.iter().map(|w| w.to_string()));
        events = e.rows;
    }
    Ok(Loaded {
        dir: dir.to_path_buf(),
        info,
        design,
        trials: read.rows,
        events,
        synthetic,
    })
}

fn describe(method: &str, inset: Option<f64>, edges: bool) -> String {
    match inset {
        Some(d) => format!(
            "{method}, {}° inset, {}",
            fmt_deg(d),
            if edges { "edges kept" } else { "no edges" }
        ),
        None => format!("{method}{}", if edges { ", edges kept" } else { "" }),
    }
}

fn is_control(c: &Condition) -> bool {
    c.method == "full"
}

fn used(t: &TrialRow, opts: &AnalyzeOptions) -> bool {
    !(opts.exclude_incorrect && t.correct == Some(false))
}

fn compute(sessions: &[Loaded], opts: &AnalyzeOptions, mut warnings: Vec<String>) -> Report {
    let design = &sessions[0].design;
    let conds = &design.conditions;
    let k = conds.len();
    let index: BTreeMap<&str, usize> = conds
        .iter()
        .enumerate()
        .map(|(i, c)| (c.name.as_str(), i))
        .collect();
    // rts[c]: pooled; per[s][c]: per participant.
    let mut rts: Vec<Vec<f64>> = vec![Vec::new(); k];
    let mut per: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); k]; sessions.len()];
    let mut n_trials = vec![0usize; k];
    let mut n_incorrect = vec![0usize; k];
    let mut n_read = 0;
    let mut n_excluded = 0;
    for (s, sess) in sessions.iter().enumerate() {
        for t in &sess.trials {
            let c = index[t.condition.as_str()];
            n_read += 1;
            n_trials[c] += 1;
            if t.correct == Some(false) {
                n_incorrect[c] += 1;
            }
            if used(t, opts) {
                rts[c].push(t.rt_s);
                per[s][c].push(t.rt_s);
            } else {
                n_excluded += 1;
            }
        }
    }
    let summary = |xs: &[f64]| stats::summarize(xs).ok();
    let conditions: Vec<ConditionStats> = conds
        .iter()
        .enumerate()
        .map(|(i, c)| ConditionStats {
            name: c.name.clone(),
            method: c.method.clone(),
            inset_deg: c.inset_deg,
            silhouette_edges: c.silhouette_edges,
            n_trials: n_trials[i],
            n_incorrect: n_incorrect[i],
            summary: summary(&rts[i]),
        })
        .collect();

    // One-way ANOVA and pairwise tests across the conditions with trials.
    let present: Vec<usize> = (0..k).filter(|&i| !rts[i].is_empty()).collect();
    for i in (0..k).filter(|i| rts[*i].is_empty()) {
        warnings.push(format!(
            "condition {} has no analysed trials: left out of the tests",
            conds[i].name
        ));
    }
    let groups: Vec<&[f64]> = present.iter().map(|&i| rts[i].as_slice()).collect();
    let names: Vec<String> = present.iter().map(|&i| conds[i].name.clone()).collect();
    let anova = match stats::one_way_anova(&groups) {
        Ok(a) => Computed::Done(OneWay {
            groups: names.clone(),
            anova: a,
        }),
        Err(e) => Computed::Skipped(format!("one-way ANOVA across conditions: {e}")),
    };
    let pairwise = match stats::pairwise_t_pooled(&groups) {
        Ok(ps) => Computed::Done(
            ps.into_iter()
                .map(|p| PairResult {
                    a: names[p.a].clone(),
                    b: names[p.b].clone(),
                    pair: p,
                })
                .collect::<Vec<_>>(),
        ),
        Err(e) => Computed::Skipped(format!("pairwise t-tests: {e}")),
    };
    let significant = pairwise
        .done()
        .map(|ps| {
            ps.iter()
                .filter(|p| p.pair.p_holm < 0.05)
                .cloned()
                .collect()
        })
        .unwrap_or_default();
    let seed_pairs = SEED_PAIRS
        .iter()
        .filter(|(a, b, _)| index.contains_key(a) && index.contains_key(b))
        .map(|&(a, b, seed)| SeedPair {
            a: a.into(),
            b: b.into(),
            seed: seed.into(),
            result: pairwise.done().and_then(|ps| find_pair(ps, a, b)),
        })
        .collect();

    // Edges kept / discarded / control.
    let pool = |pick: &dyn Fn(&Condition) -> bool| -> (Vec<String>, Vec<f64>) {
        let mut names = Vec::new();
        let mut xs = Vec::new();
        for (i, c) in conds.iter().enumerate() {
            if pick(c) {
                names.push(c.name.clone());
                xs.extend_from_slice(&rts[i]);
            }
        }
        (names, xs)
    };
    let edge_groups = [
        ("E", pool(&|c| !is_control(c) && c.silhouette_edges)),
        ("NE", pool(&|c| !is_control(c) && !c.silhouette_edges)),
        ("Control", pool(&is_control)),
    ];
    let edges = {
        let present: Vec<_> = edge_groups
            .iter()
            .filter(|(_, (_, xs))| !xs.is_empty())
            .collect();
        let has_e = present.iter().any(|(l, _)| *l == "E");
        let has_ne = present.iter().any(|(l, _)| *l == "NE");
        if !(has_e && has_ne) {
            Computed::Skipped(
                "the design has no hybrid conditions with both edges kept and edges discarded (with trials)"
                    .into(),
            )
        } else {
            let gs: Vec<&[f64]> = present.iter().map(|(_, (_, xs))| xs.as_slice()).collect();
            let labels: Vec<String> = present.iter().map(|(l, _)| l.to_string()).collect();
            let summaries: Result<Vec<GroupStats>, stats::StatsError> = present
                .iter()
                .map(|(l, (names, xs))| {
                    Ok(GroupStats {
                        label: l.to_string(),
                        conditions: names.clone(),
                        summary: stats::summarize(xs)?,
                    })
                })
                .collect();
            match (
                summaries,
                stats::one_way_anova(&gs),
                stats::pairwise_t_pooled(&gs),
            ) {
                (Ok(groups), Ok(a), Ok(ps)) => Computed::Done(EdgesAnalysis {
                    groups,
                    anova: OneWay {
                        groups: labels.clone(),
                        anova: a,
                    },
                    pairs: ps
                        .into_iter()
                        .map(|p| PairResult {
                            a: labels[p.a].clone(),
                            b: labels[p.b].clone(),
                            pair: p,
                        })
                        .collect(),
                }),
                (Err(e), _, _) | (_, Err(e), _) | (_, _, Err(e)) => {
                    Computed::Skipped(format!("edges ANOVA: {e}"))
                }
            }
        }
    };

    // Repeated measures on per-participant condition means.
    let rm_anova = {
        let mut rows: Vec<Vec<f64>> = Vec::new();
        let mut included = Vec::new();
        let mut excluded = Vec::new();
        for (s, sess) in sessions.iter().enumerate() {
            let missing: Vec<&str> = (0..k)
                .filter(|&c| per[s][c].is_empty())
                .map(|c| conds[c].name.as_str())
                .collect();
            if missing.is_empty() {
                rows.push(
                    per[s]
                        .iter()
                        .map(|xs| xs.iter().sum::<f64>() / xs.len() as f64)
                        .collect(),
                );
                included.push(sess.info.participant.clone());
            } else {
                excluded.push(format!(
                    "{} (no analysed trials in {})",
                    sess.info.participant,
                    missing.join(", ")
                ));
            }
        }
        if rows.len() < 2 {
            Computed::Skipped(format!(
                "needs at least 2 participants with trials in every condition; {} {}{}",
                rows.len(),
                if rows.len() == 1 { "has" } else { "have" },
                if excluded.is_empty() {
                    String::new()
                } else {
                    format!(" (left out: {})", excluded.join("; "))
                }
            ))
        } else {
            let data: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
            match stats::rm_anova(&data) {
                Ok(rm) => {
                    for e in &excluded {
                        warnings.push(format!("repeated-measures ANOVA leaves out {e}"));
                    }
                    Computed::Done(RmResult {
                        participants: included,
                        excluded,
                        rm,
                    })
                }
                Err(e) => Computed::Skipped(format!("repeated-measures ANOVA: {e}")),
            }
        }
    };

    // Table 7.1.
    let table71 = {
        let hybrid: Vec<(usize, &Condition)> = conds
            .iter()
            .enumerate()
            .filter(|(_, c)| !is_control(c) && c.inset_deg.is_some())
            .collect();
        if hybrid.is_empty() {
            None
        } else {
            let edge_values: BTreeSet<bool> =
                hybrid.iter().map(|(_, c)| c.silhouette_edges).collect();
            let mut insets: Vec<f64> = Vec::new();
            for d in hybrid.iter().filter_map(|(_, c)| c.inset_deg) {
                if !insets.contains(&d) {
                    insets.push(d);
                }
            }
            insets.sort_by(f64::total_cmp);
            let rows = edge_values
                .iter()
                .map(|&e| {
                    let cells = insets
                        .iter()
                        .map(|&d| {
                            let xs: Vec<f64> = hybrid
                                .iter()
                                .filter(|(_, c)| c.silhouette_edges == e && c.inset_deg == Some(d))
                                .flat_map(|(i, _)| rts[*i].iter().copied())
                                .collect();
                            summary(&xs)
                        })
                        .collect();
                    let all: Vec<f64> = hybrid
                        .iter()
                        .filter(|(_, c)| c.silhouette_edges == e)
                        .flat_map(|(i, _)| rts[*i].iter().copied())
                        .collect();
                    Table71Row {
                        label: if e { "Edges" } else { "No Edges" }.into(),
                        silhouette_edges: e,
                        cells,
                        pooled: summary(&all),
                    }
                })
                .collect();
            let control = summary(&edge_groups[2].1 .1);
            Some(Table71 {
                insets,
                rows,
                control,
            })
        }
    };

    Report {
        synthetic: sessions.iter().any(|s| s.synthetic),
        design_name: design.name.clone(),
        sessions: sessions
            .iter()
            .map(|s| SessionSummary {
                dir: s.dir.clone(),
                participant: s.info.participant.clone(),
                participant_index: s.info.participant_index,
                software: s.info.software.clone(),
                tracker: s.info.tracker.clone(),
                synthetic: s.synthetic,
                trials: s.trials.len(),
            })
            .collect(),
        n_trials_read: n_read,
        n_trials: n_read - n_excluded,
        n_excluded,
        exclude_incorrect: opts.exclude_incorrect,
        conditions,
        anova,
        edges,
        rm_anova,
        pairwise,
        significant,
        seed_pairs,
        table71,
        warnings,
        outputs: Vec::new(),
    }
}

fn find_pair(ps: &[PairResult], a: &str, b: &str) -> Option<PairResult> {
    ps.iter().find_map(|p| {
        if p.a == a && p.b == b {
            Some(p.clone())
        } else if p.a == b && p.b == a {
            // Report it in the asked-for direction.
            let mut q = p.clone();
            q.a = a.into();
            q.b = b.into();
            q.pair.diff = -q.pair.diff;
            q.pair.t = -q.pair.t;
            Some(q)
        } else {
            None
        }
    })
}

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
fn fmt_p_cell(p: f64) -> String {
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

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|")
}

fn fmt_summary(s: &Option<Summary>) -> String {
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

fn is_seed_design(report: &Report) -> bool {
    let names: BTreeSet<&str> = report.conditions.iter().map(|c| c.name.as_str()).collect();
    let seed: BTreeSet<&str> = [
        "control", "NE2", "NE5", "NE10", "NE15", "NE20", "E2", "E5", "E10", "E15", "E20",
    ]
    .into_iter()
    .collect();
    names == seed
}

const SYNTHETIC_LINE: &str = "**SYNTHETIC DATA: these results come from simulated participants, not from human observers. Do not report them as human data.**";
const SYNTHETIC_CSV: &str = "# SYNTHETIC DATA: simulated participant(s), not human data";

fn data_source(report: &Report) -> &'static str {
    if report.synthetic {
        "synthetic"
    } else {
        "human"
    }
}

fn write_outputs(
    w: &OutputWriter,
    sessions: &[Loaded],
    opts: &AnalyzeOptions,
    report: &mut Report,
) -> Result<(), AnalysisError> {
    let mut outputs = Vec::new();
    // conditions.csv
    {
        let path = w.path(CONDITIONS_CSV);
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        let mut csv = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        csv.write_record([
            "data_source",
            "condition",
            "method",
            "inset_deg",
            "silhouette_edges",
            "n_trials",
            "n_incorrect",
            "n",
            "mean_s",
            "sd_s",
            "se_s",
        ])
        .map_err(io)?;
        for c in &report.conditions {
            let (n, mean, sd, se) = match &c.summary {
                Some(s) => (
                    s.n.to_string(),
                    s.mean.to_string(),
                    s.sd.to_string(),
                    s.se.to_string(),
                ),
                None => ("0".into(), "n/a".into(), "n/a".into(), "n/a".into()),
            };
            csv.write_record([
                data_source(report).to_string(),
                c.name.clone(),
                c.method.clone(),
                c.inset_deg.map_or("n/a".into(), fmt_deg),
                c.silhouette_edges.to_string(),
                c.n_trials.to_string(),
                c.n_incorrect.to_string(),
                n,
                mean,
                sd,
                se,
            ])
            .map_err(io)?;
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        text.push_str(&String::from_utf8_lossy(&bytes));
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // trials.csv: every trial read, in input order.
    {
        let path = w.path(TRIALS_CSV);
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        text.push_str("data_source,");
        text.push_str(&<TrialRow as crate::session::TsvRow>::COLUMNS.join(","));
        text.push('\n');
        let mut csv = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(Vec::new());
        for l in sessions {
            for t in &l.trials {
                csv.serialize(t).map_err(io)?;
            }
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        for line in String::from_utf8_lossy(&bytes).lines() {
            text.push_str(data_source(report));
            text.push(',');
            text.push_str(line);
            text.push('\n');
        }
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // table-7.1.csv
    if let Some(t) = &report.table71 {
        let path = w.path(TABLE_7_1_CSV);
        let mut text = String::new();
        if report.synthetic {
            text.push_str(SYNTHETIC_CSV);
            text.push('\n');
        }
        let mut csv = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        };
        let mut header = vec!["data_source".to_string(), "edges".to_string()];
        header.extend(t.insets.iter().map(|&d| fmt_deg(d)));
        header.push("pooled".into());
        csv.write_record(&header).map_err(io)?;
        let mean = |s: &Option<Summary>| s.map_or("n/a".into(), |s| s.mean.to_string());
        for r in &t.rows {
            let mut rec = vec![data_source(report).to_string(), r.label.clone()];
            rec.extend(r.cells.iter().map(mean));
            rec.push(mean(&r.pooled));
            csv.write_record(&rec).map_err(io)?;
        }
        if t.control.is_some() {
            let mut rec = vec![data_source(report).to_string(), "Control".to_string()];
            rec.extend(t.insets.iter().map(|_| "n/a".to_string()));
            rec.push(mean(&t.control));
            csv.write_record(&rec).map_err(io)?;
        }
        let bytes = csv.into_inner().map_err(|e| AnalysisError::Output {
            path: path.clone(),
            message: e.to_string(),
        })?;
        text.push_str(&String::from_utf8_lossy(&bytes));
        w.bytes(&path, text.as_bytes())?;
        outputs.push(path);
    }
    // Figures.
    let n_part = report.sessions.len();
    let synthetic_tag = if report.synthetic {
        " (SYNTHETIC DATA)"
    } else {
        ""
    };
    let subtitle_base = format!(
        "{} participant{}, {} trials; error bars ±1 SE{}",
        n_part,
        if n_part == 1 { "" } else { "s" },
        report.n_trials,
        if report.synthetic {
            "; simulated participants"
        } else {
            ""
        }
    );
    let mut figure =
        |name: &str, chart: &BarChart, size: (u32, u32)| -> Result<(), AnalysisError> {
            let path = w.path(name);
            w.guard(&path)?;
            figures::bar_chart(&path, chart, size).map_err(|e| AnalysisError::Output {
                path: path.clone(),
                message: e.to_string(),
            })?;
            outputs.push(path);
            Ok(())
        };
    {
        let groups = report
            .conditions
            .iter()
            .filter_map(|c| {
                c.summary.map(|s| BarGroup {
                    label: c.name.clone(),
                    bars: vec![Bar {
                        series: c.name.clone(),
                        mean: s.mean,
                        se: s.se,
                        n: s.n,
                        color: if c.method == "full" {
                            figures::CONTROL
                        } else if c.silhouette_edges {
                            figures::EDGES
                        } else {
                            figures::NO_EDGES
                        },
                    }],
                })
            })
            .collect();
        let chart = BarChart {
            title: format!("Mean search time per condition{synthetic_tag}"),
            subtitle: format!("{}: {subtitle_base}", report.design_name),
            x_label: "Condition".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: None,
            legend: false,
            synthetic: report.synthetic,
        };
        figure(FIG_CONDITIONS, &chart, (1100, 700))?;
    }
    if let Computed::Done(e) = &report.edges {
        let groups = e
            .groups
            .iter()
            .map(|g| {
                let (label, color) = match g.label.as_str() {
                    "E" => ("E (edges kept)", figures::EDGES),
                    "NE" => ("NE (no edges)", figures::NO_EDGES),
                    _ => ("Control (full)", figures::CONTROL),
                };
                BarGroup {
                    label: label.into(),
                    bars: vec![Bar {
                        series: g.label.clone(),
                        mean: g.summary.mean,
                        se: g.summary.se,
                        n: g.summary.n,
                        color,
                    }],
                }
            })
            .collect();
        let chart = BarChart {
            title: format!("Fig. 7.3: Mean search time, pooled{synthetic_tag}"),
            subtitle: format!("{}; {}", subtitle_base, e.anova.apa()),
            x_label: "Scene type (E = silhouette edges kept, NE = no edges)".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: None,
            legend: false,
            synthetic: report.synthetic,
        };
        figure(FIG_7_3, &chart, (900, 700))?;
    }
    if let Some(t) = &report.table71 {
        let groups = t
            .insets
            .iter()
            .enumerate()
            .map(|(j, &d)| BarGroup {
                label: format!("{}°", fmt_deg(d)),
                // E before NE, as the seed's figure.
                bars: t
                    .rows
                    .iter()
                    .rev()
                    .filter_map(|r| {
                        r.cells[j].map(|s| Bar {
                            series: if r.silhouette_edges {
                                "E (edges kept)".into()
                            } else {
                                "NE (no edges)".into()
                            },
                            mean: s.mean,
                            se: s.se,
                            n: s.n,
                            color: if r.silhouette_edges {
                                figures::EDGES
                            } else {
                                figures::NO_EDGES
                            },
                        })
                    })
                    .collect(),
            })
            .collect();
        let chart = BarChart {
            title: format!("Fig. 7.4: Mean search time per window size{synthetic_tag}"),
            subtitle: subtitle_base.clone(),
            x_label: "High-resolution inset diameter (deg of visual angle)".into(),
            y_label: "Mean search time (s)".into(),
            groups,
            reference: t.control.map(|c| Reference {
                label: format!("Control (full res.) {:.2} s ± SE", c.mean),
                mean: c.mean,
                se: c.se,
            }),
            legend: true,
            synthetic: report.synthetic,
        };
        figure(FIG_7_4, &chart, (1100, 700))?;
    }
    // Scanpaths.
    if opts.scanpaths {
        let dir = w.path(SCANPATHS_DIR);
        for s in sessions {
            let with_stimulus: Vec<&TrialRow> = s
                .trials
                .iter()
                .filter(|t| session::stimulus_path(&s.dir, t.trial).is_file())
                .collect();
            if with_stimulus.is_empty() {
                continue;
            }
            w.guard(&dir)?;
            std::fs::create_dir_all(&dir).map_err(|e| AnalysisError::Output {
                path: dir.clone(),
                message: e.to_string(),
            })?;
            for t in with_stimulus {
                let fixations = trial_fixations(&s.events, t);
                let cond = report.conditions.iter().find(|c| c.name == t.condition);
                let what = cond
                    .map(|c| describe(&c.method, c.inset_deg, c.silhouette_edges))
                    .unwrap_or_default();
                let sp = Scanpath {
                    fixations,
                    display_px: (s.info.display.width_px, s.info.display.height_px),
                    caption: vec![
                        format!(
                            "participant {}{} | trial {} (run {}, #{} in run) | condition {} ({})",
                            s.info.participant,
                            if s.synthetic { " (SYNTHETIC)" } else { "" },
                            t.trial,
                            t.run,
                            t.trial_in_run,
                            t.condition,
                            what
                        ),
                        format!(
                            "search time {:.2} s | {} fixations from search onset to response | circle size grows with duration",
                            t.rt_s,
                            trial_fixations(&s.events, t).len()
                        ),
                    ],
                    synthetic: s.synthetic,
                };
                let path = dir.join(format!(
                    "{}-trial-{:03}.png",
                    file_safe(&s.info.participant),
                    t.trial
                ));
                w.guard(&path)?;
                let stimulus = session::stimulus_path(&s.dir, t.trial);
                match figures::scanpath(&path, &stimulus, &sp) {
                    Ok(()) => outputs.push(path),
                    Err(e) => report
                        .warnings
                        .push(format!("{}: scanpath not drawn: {e}", stimulus.display())),
                }
            }
        }
    }
    let report_path = w.path(REPORT_MD);
    outputs.push(report_path.clone());
    remove_stale(w, &outputs, &mut report.warnings)?;
    report.outputs = outputs;
    let md = markdown(report);
    w.bytes(&report_path, md.as_bytes())?;
    Ok(())
}

/// Whether `name` (a file in `OUT/`, or in `OUT/scanpaths/` when
/// `scanpath`) is one that analyze writes: its fixed outputs, and
/// `<participant>-trial-NNN.png` scanpaths.
fn analyze_output_name(name: &str, scanpath: bool) -> bool {
    if !scanpath {
        return [
            REPORT_MD,
            CONDITIONS_CSV,
            TRIALS_CSV,
            TABLE_7_1_CSV,
            FIG_CONDITIONS,
            FIG_7_3,
            FIG_7_4,
        ]
        .contains(&name);
    }
    let Some((who, trial)) = name
        .strip_suffix(".png")
        .and_then(|stem| stem.rsplit_once("-trial-"))
    else {
        return false;
    };
    !who.is_empty()
        && who
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        && trial.len() >= 3
        && trial.chars().all(|c| c.is_ascii_digit())
}

/// Removes what an earlier analyze wrote into `OUT` and this one did not
/// (a figure this design has no data for, another participant's
/// scanpaths): they would sit beside a report that does not list them.
/// Only files named as analyze names its outputs are touched, never
/// another file; each removal is noted in the report's warnings.
fn remove_stale(
    w: &OutputWriter,
    outputs: &[PathBuf],
    warnings: &mut Vec<String>,
) -> Result<(), AnalysisError> {
    let err = |path: &Path, e: std::io::Error| AnalysisError::Output {
        path: path.to_path_buf(),
        message: format!("cannot remove this output of an earlier analyze: {e}"),
    };
    let scanpaths = w.path(SCANPATHS_DIR);
    for (dir, scanpath) in [(w.out.clone(), false), (scanpaths.clone(), true)] {
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(err(&dir, e)),
        };
        let mut stale = Vec::new();
        for e in entries {
            let e = e.map_err(|e| err(&dir, e))?;
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            let is_file = e.file_type().map(|t| t.is_file()).unwrap_or(false);
            if is_file && analyze_output_name(&name, scanpath) && !outputs.contains(&path) {
                stale.push(path);
            }
        }
        stale.sort();
        for path in stale {
            w.guard(&path)?;
            std::fs::remove_file(&path).map_err(|e| err(&path, e))?;
            warnings.push(format!(
                "removed {} (written by an earlier analyze, not by this one)",
                path.display()
            ));
        }
    }
    // An emptied scanpaths folder goes too (a folder with other files stays).
    if !outputs.iter().any(|o| o.starts_with(&scanpaths)) {
        let _ = std::fs::remove_dir(&scanpaths);
    }
    Ok(())
}

/// The trial's fixations between search onset and response (the sitting's
/// host clock), clipped to that window, in order. Only events of the
/// sitting that completed the trial count (an aborted run of it left none
/// on the same clock).
pub fn trial_fixations(events: &[EventRow], t: &TrialRow) -> Vec<Fixation> {
    let (t0, t1) = (t.search_onset_us, t.response_us);
    let mut fx: Vec<&EventRow> = events
        .iter()
        .filter(|e| e.kind == "fixation" && e.sitting == t.sitting)
        .filter(|e| e.trial.is_none_or(|i| i == t.trial))
        .filter(|e| e.onset_us < t1 && e.end_us > t0)
        .collect();
    fx.sort_by_key(|e| e.onset_us);
    fx.into_iter()
        .map(|e| Fixation {
            x: e.x_px,
            y: e.y_px,
            duration_ms: (e.end_us.min(t1) - e.onset_us.max(t0)) as f64 / 1000.0,
        })
        .collect()
}

fn file_safe(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if t.is_empty() {
        "participant".into()
    } else {
        t
    }
}

fn markdown(r: &Report) -> String {
    let mut m = String::new();
    if r.synthetic {
        let _ = writeln!(m, "{SYNTHETIC_LINE}\n");
    }
    let _ = writeln!(
        m,
        "# Visual search analysis: {}{}\n",
        r.design_name,
        if r.synthetic { " (SYNTHETIC DATA)" } else { "" }
    );
    let _ = writeln!(
        m,
        "{} participant{}, {} trials analysed ({} read{}). Generated by experiment {} (gazecast).\n",
        r.sessions.len(),
        if r.sessions.len() == 1 { "" } else { "s" },
        r.n_trials,
        r.n_trials_read,
        if r.exclude_incorrect {
            format!(", {} incorrect excluded", r.n_excluded)
        } else {
            ", incorrect trials kept".into()
        },
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        m,
        "Dependent variable: search time `rt_s` (search display onset to response). \
Trials are pooled across participants for the one-way ANOVAs and the pairwise t-tests, as in Murphy (2007) §7.2.\n"
    );
    let _ = writeln!(m, "## Inputs\n");
    let _ = writeln!(
        m,
        "| folder | participant | index | software | tracker | data | trials |\n|---|---|---|---|---|---|---|"
    );
    for s in &r.sessions {
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {} | {} |",
            md_cell(&s.dir.display().to_string()),
            md_cell(&s.participant),
            s.participant_index,
            md_cell(&s.software),
            md_cell(&s.tracker),
            if s.synthetic {
                "**synthetic**"
            } else {
                "human"
            },
            s.trials
        );
    }
    let software: BTreeSet<&str> = r.sessions.iter().map(|s| s.software.as_str()).collect();
    let _ = writeln!(
        m,
        "\nSoftware versions recorded: {}.\n",
        software.into_iter().collect::<Vec<_>>().join(", ")
    );

    let _ = writeln!(m, "## Search time per condition\n");
    let _ = writeln!(
        m,
        "| condition | method | inset (°) | edges | trials | incorrect | mean (s) | SD (s) | SE (s) |\n|---|---|---|---|---|---|---|---|---|"
    );
    for c in &r.conditions {
        let (mean, sd, se) = c
            .summary
            .map_or(("n/a".into(), "n/a".into(), "n/a".into()), |s| {
                (
                    format!("{:.2}", s.mean),
                    format!("{:.2}", s.sd),
                    format!("{:.2}", s.se),
                )
            });
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            md_cell(&c.name),
            md_cell(&c.method),
            c.inset_deg.map_or("–".into(), fmt_deg),
            if c.method == "full" {
                "–"
            } else if c.silhouette_edges {
                "kept"
            } else {
                "discarded"
            },
            c.n_trials,
            c.n_incorrect,
            mean,
            sd,
            se
        );
    }
    let seed = is_seed_design(r);
    let _ = writeln!(m, "\n## One-way ANOVA across conditions\n");
    match &r.anova {
        Computed::Done(a) => {
            let _ = writeln!(
                m,
                "{} ({} conditions, {} trials).",
                a.apa(),
                a.groups.len(),
                r.n_trials
            );
        }
        Computed::Skipped(why) => {
            let _ = writeln!(m, "Skipped: {why}.");
        }
    }
    if seed {
        let _ = writeln!(
            m,
            "\nMurphy (2007) §7.2.2 reported F(10,473) = 3.3805, p < 0.01 (11 participants, 484 trials)."
        );
    }
    let _ = writeln!(m, "\n## Significance of edges\n");
    match &r.edges {
        Computed::Done(e) => {
            let _ = writeln!(
                m,
                "One-way ANOVA over {}: {}.\n",
                e.anova.groups.join(" / "),
                e.anova.apa()
            );
            let _ = writeln!(m, "| group | conditions | mean (s) |\n|---|---|---|");
            for g in &e.groups {
                let _ = writeln!(
                    m,
                    "| {} | {} | {} |",
                    g.label,
                    md_cell(&g.conditions.join(", ")),
                    fmt_summary(&Some(g.summary))
                );
            }
            let _ = writeln!(
                m,
                "\nPairwise t-tests with pooled SD (Holm over these {} pairs):\n",
                e.pairs.len()
            );
            pair_table(&mut m, &e.pairs);
            if seed {
                let _ = writeln!(
                    m,
                    "\nMurphy (2007) §7.2.1 reported F(2,481) = 7.301, p < 0.01, and E vs NE p < 0.01."
                );
            }
        }
        Computed::Skipped(why) => {
            let _ = writeln!(m, "Skipped: {why}.");
        }
    }
    let _ = writeln!(
        m,
        "\n## Repeated-measures ANOVA (Greenhouse–Geisser)\n\nOn each participant's mean search time per condition (not in the seed, which pooled trials).\n"
    );
    match &r.rm_anova {
        Computed::Done(rm) => {
            let _ = writeln!(
                m,
                "{} ({} participants: {}).",
                rm.apa(),
                rm.participants.len(),
                md_cell(&rm.participants.join(", "))
            );
            if !rm.excluded.is_empty() {
                let _ = writeln!(m, "\nLeft out: {}.", md_cell(&rm.excluded.join("; ")));
            }
        }
        Computed::Skipped(why) => {
            let _ = writeln!(m, "Skipped: {why}.");
        }
    }
    let _ = writeln!(
        m,
        "\n## Pairwise t-tests between conditions (pooled SD, Holm)\n"
    );
    match &r.pairwise {
        Computed::Done(ps) => {
            let _ = writeln!(
                m,
                "{} pairs; with Holm-adjusted p < 0.05: {}.\n",
                ps.len(),
                r.significant.len()
            );
            if !r.significant.is_empty() {
                pair_table(&mut m, &r.significant);
            }
            if !r.seed_pairs.is_empty() {
                let _ = writeln!(m, "\nThe seed's pairs of interest (§7.2.2):\n");
                let _ = writeln!(
                    m,
                    "| pair | diff (s) | t | df | p | p (Holm) | seed |\n|---|---|---|---|---|---|---|"
                );
                for sp in &r.seed_pairs {
                    match &sp.result {
                        Some(p) => {
                            let _ = writeln!(
                                m,
                                "| {} vs {} | {:.2} | {:.2} | {} | {} | {} | {} |",
                                sp.a,
                                sp.b,
                                p.pair.diff,
                                p.pair.t,
                                fmt_df(p.pair.df),
                                fmt_p_cell(p.pair.p),
                                fmt_p_cell(p.pair.p_holm),
                                sp.seed
                            );
                        }
                        None => {
                            let _ = writeln!(
                                m,
                                "| {} vs {} | n/a | n/a | n/a | n/a | n/a | {} |",
                                sp.a, sp.b, sp.seed
                            );
                        }
                    }
                }
            }
        }
        Computed::Skipped(why) => {
            let _ = writeln!(m, "Skipped: {why}.");
        }
    }
    let _ = writeln!(m, "\n## Table 7.1\n");
    match &r.table71 {
        Some(t) => {
            let _ = write!(m, "| |");
            for d in &t.insets {
                let _ = write!(m, " {}° |", fmt_deg(*d));
            }
            let _ = writeln!(m, " pooled |");
            let _ = writeln!(m, "|---|{}---|", "---|".repeat(t.insets.len()));
            for row in &t.rows {
                let _ = write!(m, "| {} |", row.label);
                for c in &row.cells {
                    let _ = write!(
                        m,
                        " {} |",
                        c.map_or("n/a".into(), |s| format!("{:.2}", s.mean))
                    );
                }
                let _ = writeln!(
                    m,
                    " {} |",
                    row.pooled
                        .map_or("n/a".into(), |s| format!("{:.2}", s.mean))
                );
            }
            let _ = writeln!(
                m,
                "\nTable 7.1: Mean search times (in s{}){}\n",
                t.control
                    .map(|c| format!("; Control = {:.2} s", c.mean))
                    .unwrap_or_default(),
                if r.synthetic { ". SYNTHETIC DATA." } else { "" }
            );
            let _ = writeln!(m, "With ±SE and n:\n");
            let _ = write!(m, "| |");
            for d in &t.insets {
                let _ = write!(m, " {}° |", fmt_deg(*d));
            }
            let _ = writeln!(m, " pooled |");
            let _ = writeln!(m, "|---|{}---|", "---|".repeat(t.insets.len()));
            for row in &t.rows {
                let _ = write!(m, "| {} |", row.label);
                for c in &row.cells {
                    let _ = write!(m, " {} |", fmt_summary(c));
                }
                let _ = writeln!(m, " {} |", fmt_summary(&row.pooled));
            }
            if let Some(c) = t.control {
                let _ = writeln!(m, "\nControl: {}.", fmt_summary(&Some(c)));
            }
            if seed {
                let _ = writeln!(
                    m,
                    "\nThe seed's Table 7.1 (11 participants, Control = 8.69 s):\n\n| | 2° | 5° | 10° | 15° | 20° | pooled |\n|---|---|---|---|---|---|---|"
                );
                for (label, row) in ["No Edges", "Edges"].iter().zip(SEED_TABLE_7_1) {
                    let cells: Vec<String> = row.iter().map(|v| format!("{v:.2}")).collect();
                    let _ = writeln!(m, "| {label} | {} |", cells.join(" | "));
                }
            }
        }
        None => {
            let _ = writeln!(
                m,
                "Not applicable: the design has no hybrid conditions with an inset (see the per-condition table)."
            );
        }
    }
    let _ = writeln!(m, "\n## Figures\n");
    let mut scanpaths = 0;
    for o in &r.outputs {
        let name = o
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if o.parent()
            .and_then(|p| p.file_name())
            .is_some_and(|p| p == SCANPATHS_DIR)
        {
            scanpaths += 1;
            continue;
        }
        if name.ends_with(".png") {
            let _ = writeln!(m, "![{name}]({name})\n");
        }
    }
    if scanpaths > 0 {
        let _ = writeln!(
            m,
            "Scanpaths (Fig. 7.5 style): {scanpaths} pictures in `{SCANPATHS_DIR}/`."
        );
    }
    if !r.warnings.is_empty() {
        let _ = writeln!(m, "\n## Warnings\n");
        for w in &r.warnings {
            let _ = writeln!(m, "- {}", md_cell(w));
        }
    }
    if r.synthetic {
        let _ = writeln!(m, "\n{SYNTHETIC_LINE}");
    }
    m
}

fn pair_table(m: &mut String, ps: &[PairResult]) {
    let _ = writeln!(
        m,
        "| pair | diff (s) | t | df | p | p (Holm) |\n|---|---|---|---|---|---|"
    );
    for p in ps {
        let _ = writeln!(
            m,
            "| {} vs {} | {:.2} | {:.2} | {} | {} | {} |",
            md_cell(&p.a),
            md_cell(&p.b),
            p.pair.diff,
            p.pair.t,
            fmt_df(p.pair.df),
            fmt_p_cell(p.pair.p),
            fmt_p_cell(p.pair.p_holm)
        );
    }
}
