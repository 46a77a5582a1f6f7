//! What the analysis reports: per-session and per-condition summaries,
//! the ANOVAs, the pairwise tests and Table 7.1, each value computed or
//! the reason it could not be.

use std::path::PathBuf;

use serde::Serialize;

use super::format::{fmt_df, fmt_p};
use crate::stats::{Anova, Pair, RmAnova, Summary};

/// A result that may have been skipped, with the reason.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupStats {
    /// Label (`"E"`, `"NE"`, `"Control"`).
    pub label: String,
    /// The conditions pooled.
    pub conditions: Vec<String>,
    /// Mean ± SE over their trials.
    pub summary: Summary,
}

/// A one-way ANOVA with the group names.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairResult {
    /// First.
    pub a: String,
    /// Second.
    pub b: String,
    /// `stats::pairwise_t_pooled`'s result (`diff = mean(a) − mean(b)`).
    pub pair: Pair,
}

/// The seed's "significance of edges" analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EdgesAnalysis {
    /// E (edges kept), NE (edges discarded), Control — those present.
    pub groups: Vec<GroupStats>,
    /// One-way ANOVA over the groups.
    pub anova: OneWay,
    /// Pooled-SD t-tests between the groups (Holm over these pairs).
    pub pairs: Vec<PairResult>,
}

/// The repeated-measures ANOVA on per-participant condition means.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
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
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table71 {
    /// Column insets (deg), ascending.
    pub insets: Vec<f64>,
    /// Rows: `silhouette_edges` false ("No Edges") before true ("Edges").
    pub rows: Vec<Table71Row>,
    /// The control (method `full`), pooled, for the caption.
    pub control: Option<Summary>,
}

/// One row of [`Table71`].
#[derive(Debug, Clone, PartialEq, Serialize)]
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

/// Everything [`analyze`](super::analyze) computed and wrote.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Any session synthetic.
    pub synthetic: bool,
    /// The design's name.
    pub design_name: String,
    /// The inputs, in the order given.
    pub sessions: Vec<SessionSummary>,
    /// Trials read (practice trials not counted).
    pub n_trials_read: usize,
    /// Practice trials read and left out: never analysed.
    pub n_practice: usize,
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
