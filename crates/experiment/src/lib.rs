//! `experiment`: the pure logic of a gaze-contingent experiment — no
//! window, no GPU, no tracker device (tracker-hal's calibration, event
//! and search maths are used; raycast only for scene files).
//!
//! - [`design`]: the experiment design file (RON), parsed with serde
//!   (`deny_unknown_fields`) and validated with errors that name the field
//!   (`conditions[3].inset_deg`).
//! - [`counterbalance`]: condition orders — the cyclic Latin square and the
//!   balanced Williams design.
//! - [`plan`](mod@plan): one participant's session as a list of trials (run, trial,
//!   condition, stimulus seed, target cell) with the breaks, calibration,
//!   validation and drift checks marked before the trials they precede.
//! - [`run`]: what running a session decides apart from the window: the
//!   order of screens, the stimuli and their checks on the display, the
//!   simulated participant's behaviour, a trial's events and score.
//! - [`stats`]: the analysis — means ± SE, one-way ANOVA, repeated-measures
//!   one-way ANOVA with the Greenhouse–Geisser correction, and pairwise
//!   t-tests with a pooled SD and Holm-adjusted p-values.
//!
//! The reference design is Murphy (2007), *Hybrid Image-/Model-Based
//! Gaze-Contingent Rendering*, ch. 7: `config/experiments/murphy2007-search.ron`.

#![warn(missing_docs)]

pub mod analysis;
pub mod bids;
pub mod counterbalance;
pub mod design;
pub mod figures;
pub mod plan;
pub mod run;
pub mod session;
pub mod stats;

pub use analysis::{analyze, AnalysisError, AnalyzeOptions, Report};
pub use bids::{export_bids, BidsError, BidsExport};
pub use counterbalance::{index_from_id, latin_square, williams};
pub use design::{Design, DesignError};
pub use plan::{plan, Step, Trial};
pub use session::{read_tsv, ReadOutcome, SessionFileError, SessionInfo, TsvLog, TsvRow};
pub use stats::StatsError;

/// The README's examples, compiled and run as doc-tests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
