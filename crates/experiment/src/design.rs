//! The experiment design file (RON) and its validation.
//!
//! A design names its factors and their levels, the conditions (each a
//! rendering method plus its parameters, and the factor level it realises),
//! how many runs (repetitions) each participant performs, how condition
//! orders are counterbalanced across participants, how stimuli are seeded,
//! where breaks fall, and the calibration / validation / drift-check
//! schedule. Every struct denies unknown fields, so a misspelt key is an
//! error rather than a silently ignored default.
//!
//! [`Design::validate`] checks the cross-field rules and reports the first
//! problem as a [`DesignError`] whose `field` is a path such as
//! `conditions[3].inset_deg`; the caller maps it to a file position.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The rendering methods whose parameters a condition states here (an
/// inset, kept silhouette edges): names of `pipeline::Method`
/// (`Method::name`). A condition may also name any other method the
/// renderer registers (`layers`, `simplify`, `lod`, `ulod`, a method
/// module), with the parameters it takes (a `contrast` for the CSF
/// methods, a `triangle_budget` for `simplify`); the viewer checks the
/// name against `pipeline::Method::all` when it loads the design. Kept as
/// strings so that this crate stays free of the renderer.
pub const METHODS: &[&str] = &["full", "hybrid", "image"];

/// The methods that select from the CSF sampling model, so that a
/// condition's `contrast` moves their degradation: the hybrid mask, the
/// image-based blur and the nested layers' sizes.
pub const CONTRAST_METHODS: &[&str] = &["hybrid", "image", "layers"];

/// An experiment design, as read from `config/experiments/*.ron`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// In the file the top-level struct is written `Experiment( ... )`.
#[serde(deny_unknown_fields, rename = "Experiment")]
pub struct Design {
    /// Short identifier, e.g. `"murphy2007-search"`.
    pub name: String,
    /// Free text: what the experiment is and where it comes from.
    #[serde(default)]
    pub description: String,
    /// The independent variables and their levels.
    pub factors: Vec<Factor>,
    /// The scene types a participant sees, in their canonical order; the
    /// counterbalancing permutes these indices.
    pub conditions: Vec<Condition>,
    /// Repetitions: how many times each participant performs every
    /// condition once (Murphy 2007: 4 runs of 11).
    pub runs: u32,
    /// How condition orders vary across participants.
    pub counterbalancing: Counterbalancing,
    /// How a participant's order changes from one run to the next.
    pub run_order: RunOrder,
    /// Stimulus generation.
    pub stimulus: Stimulus,
    /// Rest breaks.
    pub breaks: Breaks,
    /// How a search ends (Space; optionally a click on the found object).
    #[serde(default)]
    pub response: Response,
    /// Michelson contrast C of the CSF sampling model for every condition
    /// whose method samples by the CSF (hybrid, image, layers), unless the
    /// condition gives its own `contrast` (the renderer's knob: 1 is the
    /// worst case). The CSF's own
    /// one-ray-per-pixel disc grows with C; an inset smaller than it changes
    /// nothing (see `config/experiments/murphy2007-search.ron`).
    #[serde(default = "default_contrast")]
    pub contrast: f64,
    /// Eye-tracker calibration and validation schedule.
    pub calibration: Calibration,
    /// Optional single-point drift checks between trials.
    #[serde(default)]
    pub drift_check: Option<DriftCheck>,
    /// Optional practice trials before the first run (Murphy 2007 §7.1.5's
    /// demonstration program): shown like any trial, recorded in every file
    /// marked as practice, and never analysed.
    #[serde(default)]
    pub practice: Option<Practice>,
    /// Optional dataset metadata for the BIDS export (authors, licence,
    /// instructions, institution); `experiment export-bids` flags
    /// override it field by field.
    #[serde(default)]
    pub bids: Option<BidsMetadata>,
    /// Optional: a participant's contrast thresholds, the
    /// `thresholds-<ID>.ron` that `gazecast thresholds measure` writes
    /// (relative to the design file's folder). Every condition then renders
    /// with them: `simplify` judges its folds by the participant's table,
    /// the hybrid, image and layers methods sample by the fitted
    /// Geisler–Perry CSF. Each frame's `plan` names the file (and says
    /// SYNTHETIC when it is). Default: the Geisler–Perry model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thresholds: Option<std::path::PathBuf>,
}

/// One independent variable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Factor {
    /// Name, used as the key in [`Condition::levels`].
    pub name: String,
    /// The level labels, e.g. `["2", "5", "10"]`.
    pub levels: Vec<String>,
}

/// One scene type: a rendering method with its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Condition {
    /// Label used in plans, logs and tables (e.g. `"E10"`).
    pub name: String,
    /// Rendering method: one of [`METHODS`].
    pub method: String,
    /// Diameter of the full-resolution inset in degrees of visual angle
    /// (hybrid only; `None` for the full-resolution method).
    #[serde(default)]
    pub inset_deg: Option<f64>,
    /// Whether silhouette edges are kept (refined) in the periphery
    /// (hybrid only; must be `false` for the full method, which has no
    /// periphery to degrade).
    #[serde(default)]
    pub silhouette_edges: bool,
    /// The factor level this condition realises, by factor name. A control
    /// outside the factorial (Murphy's full-resolution scene) lists none.
    #[serde(default)]
    pub levels: BTreeMap<String, String>,
    /// The CSF sampling model's Michelson contrast for this condition,
    /// overriding the design's `contrast` (`None`: the design's). Only for
    /// the methods that sample by the CSF ([`CONTRAST_METHODS`]: hybrid,
    /// image, layers), where it moves the "imperceptible" point: at 1 (the
    /// worst case) no detail of any contrast should be visibly degraded;
    /// below 1 the model assumes the scene's detail is of at most that
    /// contrast and degrades more (detail of higher contrast may then be
    /// seen degraded). In (0, 1].
    #[serde(default)]
    pub contrast: Option<f64>,
    /// Luebke & Hallen §5.3's best-effort mode for the `simplify` method:
    /// at most this many triangles a frame over the whole search display,
    /// the most perceptible fold undone first (`None`: their
    /// imperceptible mode, every fold judged invisible by their CSF
    /// model). 1 to 10⁹; `simplify` only.
    #[serde(default)]
    pub triangle_budget: Option<u64>,
}

/// Most triangles a condition's `triangle_budget` may ask for (the
/// renderer's bound, `pipeline::model_based::MAX_TRIANGLE_BUDGET`).
pub const MAX_TRIANGLE_BUDGET: u64 = 1_000_000_000;

impl Condition {
    /// The contrast the condition's sampling model uses: its own, or the
    /// design's `contrast`.
    pub fn contrast_or(&self, design_contrast: f64) -> f64 {
        self.contrast.unwrap_or(design_contrast)
    }
}

/// Counterbalancing of condition order across participants.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Counterbalancing {
    /// Cyclic Latin square: participant `p` takes row `p mod n`; each
    /// condition appears once in each position across `n` participants.
    LatinSquare,
    /// Williams (1949) balanced design: also balances first-order
    /// carry-over (each condition precedes each other equally often);
    /// `n` rows for even `n`, `2n` rows for odd `n`.
    Williams,
}

/// How a participant's condition order changes between runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RunOrder {
    /// Every run repeats the participant's row.
    Repeat,
    /// Run `r` uses the row `r` places after the participant's row, so
    /// each run on its own is counterbalanced across participants and
    /// each participant meets several orders.
    Rotate,
}

/// Stimulus generation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stimulus {
    /// Base seed; a trial's seed is derived from it, the participant and
    /// the trial index ([`crate::plan::trial_seed`]).
    pub seed: u64,
    /// Search grid as (rows, columns) — Murphy 2007: 5×5.
    pub grid: (u32, u32),
    /// How many different meshes take part (Murphy 2007: four facial
    /// expressions). Each is the target equally often within a
    /// participant's session (exactly when the trial count is a multiple
    /// of it); the other cells are filled at random from the non-targets.
    #[serde(default = "default_meshes")]
    pub meshes: u32,
    /// Width of one object in degrees of visual angle (Murphy 2007: "each
    /// target subtended approximately 3.5 degrees").
    #[serde(default = "default_object_deg")]
    pub object_deg: f64,
    /// Width of the whole grid, centre to centre of its outer cells plus
    /// one object, in degrees (Murphy 2007: "the entire scene subtended
    /// approximately 20 degrees").
    #[serde(default = "default_grid_deg")]
    pub grid_deg: f64,
    /// The reference: a copy of the target mesh at a fixed cell, which the
    /// participant may look back at during the search (Murphy 2007
    /// §7.1.4: "The target mesh was then placed both in the center of the
    /// scene and at a random location in the grid"; the appendix's
    /// instructions: "you may refer back to the target in the center of
    /// the screen"; §7.3: a search "started at the center of the screen,
    /// where the high resolution reference mesh was displayed"). The
    /// target's other cell is then drawn among the cells other than the
    /// reference's, so the reference is never the target to be found.
    ///
    /// Absent from the file: the seed's `Some((at: Centre, detail: Full))`.
    /// `None`: no reference; the target may be at any cell, the centre
    /// included (gazecast before the field existed).
    #[serde(default = "default_reference")]
    pub reference: Option<Reference>,
}

/// Where the reference stands and how it is drawn
/// ([`Stimulus::reference`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reference {
    /// The reference's cell.
    pub at: ReferenceCell,
    /// How it is rendered.
    pub detail: ReferenceDetail,
}

/// The reference's cell in the search grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReferenceCell {
    /// The grid's centre cell, `(rows / 2, columns / 2)`: the seed's (the
    /// 5×5 grid's cell (2, 2), at the screen's centre). A grid with an
    /// even number of rows or columns has no centre cell and must name
    /// one with `Cell` (or have no reference).
    Centre,
    /// The cell at (row, column), from 0, row 0 at the top: any cell of
    /// the grid.
    Cell(u32, u32),
}

/// How the reference is rendered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReferenceDetail {
    /// At full resolution whatever the condition, as the seed's "high
    /// resolution reference mesh": once per trial the target mesh alone
    /// at the reference cell is rendered at full resolution (for `Centre`
    /// that is the target preview's frame, reused), and its pixels that
    /// hit the mesh are drawn over every search frame, after the
    /// condition's method and its passes. So it looks the same under every
    /// method (full, hybrid, image, simplify, lod, ulod, layers), fixated
    /// or not; everything else on the screen is the condition's. The
    /// search scene still holds the reference object, so the method's own
    /// frame (its rays, triangles, times) is that of the whole display.
    Full,
    /// An ordinary object of the search display, rendered by the
    /// condition's method like every other: at full detail where the
    /// method gives full detail (around the gaze), degraded in the
    /// periphery (coarser rays, simplified geometry, blur, coarser layers)
    /// when the participant looks elsewhere.
    AsCondition,
}

impl Stimulus {
    /// The reference's cell (row, column), `None` without a reference.
    /// For `Centre`, `(rows / 2, columns / 2)` (the centre of an odd
    /// grid; validation refuses an even one).
    pub fn reference_cell(&self) -> Option<(u32, u32)> {
        self.reference.map(|r| match r.at {
            ReferenceCell::Centre => (self.grid.0 / 2, self.grid.1 / 2),
            ReferenceCell::Cell(row, col) => (row, col),
        })
    }

    /// Checks the reference against the grid (which must already be at
    /// least 1×1).
    fn validate_reference(&self) -> Result<(), DesignError> {
        let Some(reference) = self.reference else {
            return Ok(());
        };
        let (rows, cols) = self.grid;
        if u64::from(rows) * u64::from(cols) < 2 {
            return Err(DesignError::invalid(
                "stimulus.reference",
                format!(
                    "a reference needs at least 2 cells (its own and the target's other), the \
                     grid has {rows}x{cols}; give None"
                ),
            ));
        }
        match reference.at {
            ReferenceCell::Centre => {
                if rows % 2 == 0 || cols % 2 == 0 {
                    return Err(DesignError::invalid(
                        "stimulus.reference.at",
                        format!(
                            "a {rows}x{cols} grid has no centre cell (an even number of rows or \
                             columns); give the reference's cell as Cell(row, column), or None \
                             for no reference"
                        ),
                    ));
                }
            }
            ReferenceCell::Cell(r, c) => {
                if r >= rows || c >= cols {
                    return Err(DesignError::invalid(
                        "stimulus.reference.at",
                        format!(
                            "Cell({r}, {c}) is outside the {rows}x{cols} grid (rows 0 to {}, \
                             columns 0 to {})",
                            rows - 1,
                            cols - 1
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Longest condition name, factor name or factor level (characters).
pub const MAX_LABEL_CHARS: usize = 32;

/// Checks a condition name, factor name or factor level, which end up as
/// TSV and CSV cells, BIDS `trial_type` values, Markdown table cells and
/// figure labels: 1 to [`MAX_LABEL_CHARS`] ASCII letters, digits, `-`,
/// `_`, `.` and `+`, starting with a letter or a digit. So no tab or
/// newline (they split TSV rows and cells), no `/` or `\` and no `.` or
/// `..` (a name must never act as a path), no quote, comma or `|` (CSV and
/// Markdown), and never BIDS's missing value `n/a`.
pub fn check_label(field: &str, value: &str) -> Result<(), DesignError> {
    let bad = |why: String| Err(DesignError::invalid(field, format!("{value:?}: {why}")));
    if value.eq_ignore_ascii_case("n/a") {
        return bad("is BIDS's marker of a missing value; choose another name".into());
    }
    let n = value.chars().count();
    if n == 0 || n > MAX_LABEL_CHARS {
        return bad(format!(
            "must be 1 to {MAX_LABEL_CHARS} characters, got {n}"
        ));
    }
    if let Some(c) = value
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | '+')))
    {
        return bad(format!(
            "{c:?} is not allowed (ASCII letters, digits, '-', '_', '.' and '+' only: the name is \
             written into TSV, CSV and BIDS files)"
        ));
    }
    if !value.starts_with(|c: char| c.is_ascii_alphanumeric()) {
        return bad("must start with a letter or a digit".into());
    }
    Ok(())
}

/// Longest id that names a folder (characters): a participant id, a
/// design's `name`.
pub const MAX_ID_CHARS: usize = 64;

/// The rule for every string that becomes a path component (a design's
/// `name` names the folder `OUT/<name>`, a participant id the folder
/// `sub-<id>`): 1 to [`MAX_ID_CHARS`] ASCII letters, digits, `-` and `_`.
/// So never `.`, `..`, a separator or an absolute path: the component
/// stays one folder inside the output folder. `Err` is the reason.
pub fn check_id(value: &str) -> Result<(), String> {
    let n = value.chars().count();
    if n == 0 || n > MAX_ID_CHARS {
        return Err(format!(
            "{value:?}: must be 1 to {MAX_ID_CHARS} characters, got {n}"
        ));
    }
    if let Some(c) = value
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_'))
    {
        return Err(format!(
            "{value:?}: {c:?} is not allowed (ASCII letters, digits, '-' and '_' only: it names a folder)"
        ));
    }
    Ok(())
}

/// Most calibration targets a design may ask for: the 5×5 grid (the
/// grids are 5 or a square number; Murphy 2007 used 9, a 3×3 grid).
pub const MAX_CALIBRATION_POINTS: u32 = 25;
/// Most validation targets a design may ask for (5×5).
pub const MAX_VALIDATION_POINTS: u32 = 25;

/// Whether `n` targets make one of the runner's grids: 5 (the centre and
/// the corners) or a square number from 4 up to `max`.
fn grid_points_ok(n: u32, max: u32) -> bool {
    let k = (f64::from(n)).sqrt().round() as u32;
    n <= max && (n == 5 || (n >= 4 && k * k == n))
}

/// Checks a calibration or validation target count; `Err` is the reason.
pub fn check_points(n: u32, max: u32) -> Result<(), String> {
    if grid_points_ok(n, max) {
        return Ok(());
    }
    let grids: Vec<String> = (1..=max)
        .filter(|&m| grid_points_ok(m, max))
        .map(|m| m.to_string())
        .collect();
    Err(format!(
        "{n} targets: must be one of {} (5 = the centre and the corners, a square number = a \
         square grid; at most {max})",
        grids.join(", ")
    ))
}

/// Longest search a trial may record, seconds (an hour): the bound of a
/// design's `response.max_search_s`, and of every `rt_s` that `analyze`
/// reads (a longer one is invalid input, named by file and line).
pub const MAX_SEARCH_S: f64 = 3600.0;

/// Most trials a participant's plan may hold (a day of 1-s trials).
pub const MAX_TRIALS: usize = 100_000;

fn default_contrast() -> f64 {
    1.0
}
fn default_meshes() -> u32 {
    4
}
fn default_object_deg() -> f64 {
    3.5
}
fn default_grid_deg() -> f64 {
    20.0
}
fn default_reference() -> Option<Reference> {
    Some(Reference {
        at: ReferenceCell::Centre,
        detail: ReferenceDetail::Full,
    })
}

/// How a search ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Response {
    /// After `Space`, the participant clicks the object they found; the
    /// trial records the cell and whether it is the target (Murphy 2007
    /// had no such step: `false`).
    #[serde(default)]
    pub confirm_click: bool,
    /// End a search that has had no response after this many seconds
    /// (recorded as a time-out); `None`: wait as long as it takes, as in
    /// Murphy 2007.
    #[serde(default)]
    pub max_search_s: Option<f64>,
}

/// Rest breaks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Breaks {
    /// A break after this many trials within a run (Murphy 2007: 6, "a
    /// break to check the calibration or stretch was allowed after 6
    /// search tasks"); `None` for none within a run.
    #[serde(default)]
    pub break_after_trials: Option<u32>,
    /// A break between consecutive runs (Murphy 2007: "upon completion of
    /// all 11 search tasks, users were encouraged to stand and stretch").
    #[serde(default)]
    pub between_runs: bool,
}

/// Calibration and validation schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Calibration targets (Murphy 2007: 9, a 3×3 grid): 5 or a square
    /// number, at most [`MAX_CALIBRATION_POINTS`].
    pub points: u32,
    /// Validation (accuracy confirmation) targets (Murphy 2007: 5): 5 or a
    /// square number, at most [`MAX_VALIDATION_POINTS`].
    pub validation_points: u32,
    /// Mean validation error above which the runner recalibrates, in
    /// degrees of visual angle.
    pub accuracy_threshold_deg: f64,
    /// Calibrate (and validate) before the first trial.
    pub at_start: bool,
    /// Validate before the first trial of the session's second half.
    pub validate_at_midpoint: bool,
}

/// Single-point drift check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftCheck {
    /// Check before every `every_trials`-th trial (not before the first):
    /// 1 to trials per participant − 1. The check is one target at the
    /// screen's centre (there is no point count to choose).
    pub every_trials: u32,
    /// Error above which the runner recalibrates, in degrees.
    pub threshold_deg: f64,
}

/// Practice trials (Murphy 2007 §7.1.5: a demonstration program that
/// "functioned in exactly the same manner as the experimental program,
/// with only the control group being displayed", where "time was not a
/// factor"). They come before the first run, after the session's first
/// calibration; a screen then says that practice is over (the seed's
/// pause for questions) before the first experimental trial.
///
/// A practice trial is planned like an experimental one (a target, a
/// reference, distractors) from a seed of its own, so adding or removing
/// practice leaves every experimental trial's stimulus unchanged. Its rows
/// are marked in every file (`trials.tsv` and `events.tsv`: `practice`;
/// samples, frames and markers: the phases `practice-preview`,
/// `practice-search`, `practice-confirm`; the BIDS events: `practice`)
/// and the analysis leaves them out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Practice {
    /// How many practice trials: 1 to [`MAX_PRACTICE_TRIALS`].
    pub trials: u32,
    /// The condition every practice trial shows, by name (the seed showed
    /// only its control, the full-resolution scene).
    pub condition: String,
}

/// Most practice trials a design may ask for.
pub const MAX_PRACTICE_TRIALS: u32 = 1000;

/// Why a design file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// RON syntax or a type/field mismatch (unknown field, wrong type).
    #[error("{0}")]
    Parse(#[from] ron::error::SpannedError),
    /// The file parsed but breaks a rule; `field` is a path such as
    /// `conditions[3].inset_deg`.
    #[error("{field}: {message}")]
    Invalid {
        /// Path of the offending field.
        field: String,
        /// What is wrong with it.
        message: String,
    },
}

impl DesignError {
    fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        DesignError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }

    /// The field path of a validation error (`None` for I/O and parse
    /// errors, which carry their own position).
    pub fn field(&self) -> Option<&str> {
        match self {
            DesignError::Invalid { field, .. } => Some(field),
            _ => None,
        }
    }
}

impl Design {
    /// Parses and validates a design from RON text.
    pub fn from_ron_str(text: &str) -> Result<Self, DesignError> {
        let design: Design = ron::from_str(text)?;
        design.validate()?;
        Ok(design)
    }

    /// Reads, parses and validates a design file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, DesignError> {
        let path = path.as_ref();
        let text = input_file::read_to_string(path, input_file::DESIGN).map_err(|source| {
            DesignError::Io {
                path: path.display().to_string(),
                source,
            }
        })?;
        Self::from_ron_str(&text)
    }

    /// Every field in which `other` differs from `self`, as
    /// `path: this → that` (e.g. `stimulus.meshes: 4 → 64`), in field
    /// order; empty when the two designs produce the same stimuli and
    /// data. Only `description` (free text) is ignored: every other field
    /// changes what a participant sees, in which order, or what a trial
    /// records, so sessions of designs that differ must not be pooled.
    pub fn differences(&self, other: &Design) -> Vec<String> {
        let value = |d: &Design| {
            let mut v = serde_json::to_value(d).unwrap_or(serde_json::Value::Null);
            if let Some(map) = v.as_object_mut() {
                map.remove("description");
                map.remove("bids");
            }
            v
        };
        let mut out = Vec::new();
        diff_values("", &value(self), &value(other), &mut out);
        out
    }

    /// Trials per run (one per condition).
    pub fn trials_per_run(&self) -> usize {
        self.conditions.len()
    }

    /// Practice trials before the first run (0 without `practice`).
    pub fn practice_trials(&self) -> usize {
        self.practice.as_ref().map_or(0, |p| p.trials as usize)
    }

    /// Index into `conditions` of the practice trials' condition (`None`
    /// without practice or when the name is not a condition's).
    pub fn practice_condition(&self) -> Option<usize> {
        let p = self.practice.as_ref()?;
        self.conditions.iter().position(|c| c.name == p.condition)
    }

    /// Trials per participant, practice not included.
    pub fn total_trials(&self) -> usize {
        self.conditions.len().saturating_mul(self.runs as usize)
    }

    /// Checks the rules serde cannot express; returns the first violation.
    pub fn validate(&self) -> Result<(), DesignError> {
        // The name names the session folder OUT/<name>: the id rule, so
        // it can never reach outside OUT.
        check_id(&self.name).map_err(|m| {
            DesignError::invalid(
                "name",
                format!("{m}; the name is the session folder OUT/<name>"),
            )
        })?;
        self.validate_factors()?;
        self.validate_conditions()?;
        if self.runs == 0 {
            return Err(DesignError::invalid("runs", "must be at least 1"));
        }
        // The plan holds every trial: bound it before anything allocates.
        if self.total_trials() > MAX_TRIALS {
            return Err(DesignError::invalid(
                "runs",
                format!(
                    "{} runs of {} conditions is {} trials; at most {MAX_TRIALS} per participant",
                    self.runs,
                    self.conditions.len(),
                    self.total_trials()
                ),
            ));
        }
        let (rows, cols) = self.stimulus.grid;
        if rows == 0 || cols == 0 {
            return Err(DesignError::invalid(
                "stimulus.grid",
                format!("must be at least 1x1, got {rows}x{cols}"),
            ));
        }
        if !(self.contrast.is_finite() && self.contrast > 0.0 && self.contrast <= 1.0) {
            return Err(DesignError::invalid(
                "contrast",
                format!(
                    "must be a Michelson contrast in (0, 1], got {}",
                    self.contrast
                ),
            ));
        }
        let st = &self.stimulus;
        if st.meshes < 2 || st.meshes > 64 {
            return Err(DesignError::invalid(
                "stimulus.meshes",
                format!(
                    "must be between 2 and 64 (a target and at least one distractor), got {}",
                    st.meshes
                ),
            ));
        }
        if u64::from(rows) * u64::from(cols) > 1024 {
            return Err(DesignError::invalid(
                "stimulus.grid",
                format!("at most 1024 cells, got {rows}x{cols}"),
            ));
        }
        st.validate_reference()?;
        positive_finite(st.object_deg, "stimulus.object_deg")?;
        positive_finite(st.grid_deg, "stimulus.grid_deg")?;
        if st.object_deg >= 170.0 || st.grid_deg >= 170.0 {
            return Err(DesignError::invalid(
                "stimulus.grid_deg",
                "object and grid must each subtend less than 170 degrees",
            ));
        }
        if st.object_deg > st.grid_deg {
            return Err(DesignError::invalid(
                "stimulus.object_deg",
                format!(
                    "an object ({} deg) cannot be wider than the grid ({} deg)",
                    st.object_deg, st.grid_deg
                ),
            ));
        }
        if let Some(t) = self.response.max_search_s {
            if !(t.is_finite() && t > 0.0 && t <= MAX_SEARCH_S) {
                return Err(DesignError::invalid(
                    "response.max_search_s",
                    format!("must be in (0, {MAX_SEARCH_S}] seconds, got {t}"),
                ));
            }
        }
        if let Some(k) = self.breaks.break_after_trials {
            let per_run = self.trials_per_run();
            if k == 0 || k as usize >= per_run {
                return Err(DesignError::invalid(
                    "breaks.break_after_trials",
                    format!(
                        "must be between 1 and {} (trials per run - 1), got {k}",
                        per_run - 1
                    ),
                ));
            }
        }
        let c = &self.calibration;
        check_points(c.points, MAX_CALIBRATION_POINTS)
            .map_err(|m| DesignError::invalid("calibration.points", m))?;
        check_points(c.validation_points, MAX_VALIDATION_POINTS)
            .map_err(|m| DesignError::invalid("calibration.validation_points", m))?;
        positive_finite(
            c.accuracy_threshold_deg,
            "calibration.accuracy_threshold_deg",
        )?;
        if c.validate_at_midpoint && self.total_trials() < 2 {
            return Err(DesignError::invalid(
                "calibration.validate_at_midpoint",
                "needs at least 2 trials per participant",
            ));
        }
        if let Some(d) = &self.drift_check {
            // A drift check is one target at the centre; it comes before
            // trial k·every_trials (k ≥ 1), so it must fall within the session.
            let total = self.total_trials();
            if d.every_trials == 0 || d.every_trials as usize >= total {
                return Err(DesignError::invalid(
                    "drift_check.every_trials",
                    format!(
                        "must be between 1 and {} (trials per participant - 1: a larger value \
                         never checks), got {}",
                        total.saturating_sub(1),
                        d.every_trials
                    ),
                ));
            }
            positive_finite(d.threshold_deg, "drift_check.threshold_deg")?;
        }
        if let Some(p) = &self.practice {
            if p.trials == 0 || p.trials > MAX_PRACTICE_TRIALS {
                return Err(DesignError::invalid(
                    "practice.trials",
                    format!(
                        "must be between 1 and {MAX_PRACTICE_TRIALS} (leave `practice` out for none), got {}",
                        p.trials
                    ),
                ));
            }
            if self.practice_condition().is_none() {
                return Err(DesignError::invalid(
                    "practice.condition",
                    format!(
                        "{:?} is not a condition of this design ({})",
                        p.condition,
                        self.conditions
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        if let Some(b) = &self.bids {
            b.validate().map_err(|(field, message)| {
                DesignError::invalid(format!("bids.{field}"), message)
            })?;
        }
        Ok(())
    }

    fn validate_factors(&self) -> Result<(), DesignError> {
        for (i, f) in self.factors.iter().enumerate() {
            check_label(&format!("factors[{i}].name"), &f.name)?;
            if let Some(j) = self.factors[..i].iter().position(|g| g.name == f.name) {
                return Err(DesignError::invalid(
                    format!("factors[{i}].name"),
                    format!("duplicates factors[{j}].name {:?}", f.name),
                ));
            }
            if f.levels.len() < 2 {
                return Err(DesignError::invalid(
                    format!("factors[{i}].levels"),
                    format!("a factor needs at least 2 levels, got {}", f.levels.len()),
                ));
            }
            for (l, level) in f.levels.iter().enumerate() {
                check_label(&format!("factors[{i}].levels[{l}]"), level)?;
                if let Some(m) = f.levels[..l].iter().position(|x| x == level) {
                    return Err(DesignError::invalid(
                        format!("factors[{i}].levels[{l}]"),
                        format!("duplicates levels[{m}] {level:?}"),
                    ));
                }
            }
        }
        Ok(())
    }

    fn validate_conditions(&self) -> Result<(), DesignError> {
        if self.conditions.len() < 2 {
            return Err(DesignError::invalid(
                "conditions",
                format!("needs at least 2 conditions, got {}", self.conditions.len()),
            ));
        }
        for (i, c) in self.conditions.iter().enumerate() {
            let at = |field: &str| format!("conditions[{i}].{field}");
            check_label(&at("name"), &c.name)?;
            if let Some(j) = self.conditions[..i].iter().position(|d| d.name == c.name) {
                return Err(DesignError::invalid(
                    at("name"),
                    format!("duplicates conditions[{j}].name {:?}", c.name),
                ));
            }
            match c.method.as_str() {
                "full" => {
                    if c.inset_deg.is_some() {
                        return Err(DesignError::invalid(
                            at("inset_deg"),
                            "the full method renders every pixel at full resolution and takes no inset",
                        ));
                    }
                    if c.silhouette_edges {
                        return Err(DesignError::invalid(
                            at("silhouette_edges"),
                            "the full method has no degraded periphery whose edges could be kept",
                        ));
                    }
                }
                "hybrid" => match c.inset_deg {
                    None => {
                        return Err(DesignError::invalid(
                            at("inset_deg"),
                            "the hybrid method needs an inset diameter in degrees",
                        ))
                    }
                    Some(d) => {
                        if !(d.is_finite() && d > 0.0 && d <= 180.0) {
                            return Err(DesignError::invalid(
                                at("inset_deg"),
                                format!("must be in (0, 180] degrees, got {d}"),
                            ));
                        }
                    }
                },
                "image" => {
                    if let Some(d) = c.inset_deg {
                        if !(d.is_finite() && d > 0.0 && d <= 180.0) {
                            return Err(DesignError::invalid(
                                at("inset_deg"),
                                format!("must be in (0, 180] degrees, got {d}"),
                            ));
                        }
                    }
                    if c.silhouette_edges {
                        return Err(DesignError::invalid(
                            at("silhouette_edges"),
                            "the image method casts every pixel: its silhouettes are always exact",
                        ));
                    }
                }
                other => {
                    // Another method the renderer registers (a method
                    // module): a name, no parameters of the three above.
                    // Whether the renderer knows it is checked where the
                    // design is run (`gazecast experiment plan/run`).
                    check_id(other).map_err(|m| DesignError::invalid(at("method"), m))?;
                    if c.inset_deg.is_some() {
                        return Err(DesignError::invalid(
                            at("inset_deg"),
                            format!(
                                "only the hybrid and image methods take an inset; {other:?} has \
                                 none"
                            ),
                        ));
                    }
                    if c.silhouette_edges {
                        return Err(DesignError::invalid(
                            at("silhouette_edges"),
                            format!(
                                "only the hybrid method keeps silhouette edges; {other:?} does not"
                            ),
                        ));
                    }
                }
            }
            if let Some(k) = c.contrast {
                if !CONTRAST_METHODS.contains(&c.method.as_str()) {
                    return Err(DesignError::invalid(
                        at("contrast"),
                        format!(
                            "only the methods that sample by the CSF ({}) take a contrast; {:?} \
                             does not read it",
                            CONTRAST_METHODS.join(", "),
                            c.method
                        ),
                    ));
                }
                if !(k.is_finite() && k > 0.0 && k <= 1.0) {
                    return Err(DesignError::invalid(
                        at("contrast"),
                        format!("must be a Michelson contrast in (0, 1], got {k}"),
                    ));
                }
            }
            if let Some(b) = c.triangle_budget {
                if c.method != "simplify" {
                    return Err(DesignError::invalid(
                        at("triangle_budget"),
                        format!(
                            "the triangle budget is Luebke & Hallen's best-effort mode, for the \
                             simplify method only (not {:?})",
                            c.method
                        ),
                    ));
                }
                if !(1..=MAX_TRIANGLE_BUDGET).contains(&b) {
                    return Err(DesignError::invalid(
                        at("triangle_budget"),
                        format!("must be 1 to {MAX_TRIANGLE_BUDGET} triangles, got {b}"),
                    ));
                }
            }
            for (factor, level) in &c.levels {
                let Some(f) = self.factors.iter().find(|f| &f.name == factor) else {
                    return Err(DesignError::invalid(
                        format!("conditions[{i}].levels.{factor}"),
                        format!("no factor named {factor:?}"),
                    ));
                };
                if !f.levels.contains(level) {
                    return Err(DesignError::invalid(
                        format!("conditions[{i}].levels.{factor}"),
                        format!(
                            "{level:?} is not a level of {factor:?} ({})",
                            f.levels.join(", ")
                        ),
                    ));
                }
            }
            if !c.levels.is_empty() {
                if let Some(j) = self.conditions[..i]
                    .iter()
                    .position(|d| !d.levels.is_empty() && d.levels == c.levels)
                {
                    return Err(DesignError::invalid(
                        at("levels"),
                        format!("same factor levels as conditions[{j}]"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Appends the paths where `a` and `b` differ (objects key by key, arrays
/// element by element when of equal length, anything else as a whole).
fn diff_values(path: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
    use serde_json::Value;
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let null = Value::Null;
                diff_values(
                    &join(k),
                    x.get(k).unwrap_or(&null),
                    y.get(k).unwrap_or(&null),
                    out,
                );
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                diff_values(&format!("{path}[{i}]"), p, q, out);
            }
        }
        _ if a != b => {
            let show = |v: &Value| {
                let s = v.to_string();
                if s.chars().count() > 60 {
                    format!("{}…", s.chars().take(60).collect::<String>())
                } else {
                    s
                }
            };
            out.push(format!("{path}: {} → {}", show(a), show(b)));
        }
        _ => {}
    }
}

fn positive_finite(x: f64, field: &str) -> Result<(), DesignError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(DesignError::invalid(
            field,
            format!("must be a positive finite number of degrees, got {x}"),
        ))
    }
}

/// Dataset metadata for the BIDS export: who made the data, under which
/// licence, what the participants were told, and where. Every field is
/// optional (`experiment export-bids` flags set or override each); none
/// changes what a participant sees, so designs that differ only here
/// pool ([`Design::differences`] ignores it). In a design file:
///
/// ```text
/// bids: Some((
///     authors: ["A. Person", "B. Person"],
///     license: Some("CC-BY-4.0"),
///     instructions: Some("Find the object that matches the target …"),
///     institution_name: Some("Some University"),
/// )),
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BidsMetadata {
    /// `Authors` of `dataset_description.json`: one person per entry.
    #[serde(default)]
    pub authors: Vec<String>,
    /// `License`: the data's licence, an SPDX identifier where there is
    /// one (`"CC0-1.0"`, `"CC-BY-4.0"`, `"PDDL-1.0"`).
    #[serde(default)]
    pub license: Option<String>,
    /// `Acknowledgements`: who else contributed.
    #[serde(default)]
    pub acknowledgements: Option<String>,
    /// `HowToAcknowledge`: how to cite the data.
    #[serde(default)]
    pub how_to_acknowledge: Option<String>,
    /// `Funding`: one source per entry.
    #[serde(default)]
    pub funding: Vec<String>,
    /// `EthicsApprovals`: one approval per entry (board, number).
    #[serde(default)]
    pub ethics_approvals: Vec<String>,
    /// `ReferencesAndLinks`: papers and pages about the data.
    #[serde(default)]
    pub references_and_links: Vec<String>,
    /// `DatasetDOI`: the dataset's DOI as a URI (`"doi:10.…"`).
    #[serde(default)]
    pub dataset_doi: Option<String>,
    /// `Instructions`: the text given to the participants before the
    /// recording (in every run's sidecars).
    #[serde(default)]
    pub instructions: Option<String>,
    /// `TaskDescription`: replaces gazecast's one-line description of the
    /// visual search.
    #[serde(default)]
    pub task_description: Option<String>,
    /// `CogAtlasID`: the Cognitive Atlas task's URI.
    #[serde(default)]
    pub cog_atlas_id: Option<String>,
    /// `CogPOID`: the CogPO term's URI.
    #[serde(default)]
    pub cog_po_id: Option<String>,
    /// `InstitutionName`: the institution in charge of the equipment.
    #[serde(default)]
    pub institution_name: Option<String>,
    /// `InstitutionAddress`: its address.
    #[serde(default)]
    pub institution_address: Option<String>,
    /// `InstitutionalDepartmentName`: the department.
    #[serde(default)]
    pub institutional_department_name: Option<String>,
}

impl BidsMetadata {
    /// `self` with every field that `over` sets replaced by `over`'s (a
    /// list replaces the whole list).
    pub fn overlay(&self, over: &BidsMetadata) -> BidsMetadata {
        let text = |a: &Option<String>, b: &Option<String>| b.clone().or_else(|| a.clone());
        let list =
            |a: &Vec<String>, b: &Vec<String>| if b.is_empty() { a.clone() } else { b.clone() };
        BidsMetadata {
            authors: list(&self.authors, &over.authors),
            license: text(&self.license, &over.license),
            acknowledgements: text(&self.acknowledgements, &over.acknowledgements),
            how_to_acknowledge: text(&self.how_to_acknowledge, &over.how_to_acknowledge),
            funding: list(&self.funding, &over.funding),
            ethics_approvals: list(&self.ethics_approvals, &over.ethics_approvals),
            references_and_links: list(&self.references_and_links, &over.references_and_links),
            dataset_doi: text(&self.dataset_doi, &over.dataset_doi),
            instructions: text(&self.instructions, &over.instructions),
            task_description: text(&self.task_description, &over.task_description),
            cog_atlas_id: text(&self.cog_atlas_id, &over.cog_atlas_id),
            cog_po_id: text(&self.cog_po_id, &over.cog_po_id),
            institution_name: text(&self.institution_name, &over.institution_name),
            institution_address: text(&self.institution_address, &over.institution_address),
            institutional_department_name: text(
                &self.institutional_department_name,
                &over.institutional_department_name,
            ),
        }
    }

    /// Checks every value: no empty text (a field left out is the way to
    /// say nothing), the DOI a `doi:` URI, the two task ids web
    /// addresses. `Err((field, message))`, the field as named in the
    /// design file (`authors[1]`).
    pub fn validate(&self) -> Result<(), (String, String)> {
        let lists: [(&str, &Vec<String>); 4] = [
            ("authors", &self.authors),
            ("funding", &self.funding),
            ("ethics_approvals", &self.ethics_approvals),
            ("references_and_links", &self.references_and_links),
        ];
        for (name, values) in lists {
            for (i, v) in values.iter().enumerate() {
                if v.trim().is_empty() {
                    return Err((
                        format!("{name}[{i}]"),
                        "is empty: leave it out instead".into(),
                    ));
                }
            }
        }
        let texts: [(&str, &Option<String>); 11] = [
            ("license", &self.license),
            ("acknowledgements", &self.acknowledgements),
            ("how_to_acknowledge", &self.how_to_acknowledge),
            ("dataset_doi", &self.dataset_doi),
            ("instructions", &self.instructions),
            ("task_description", &self.task_description),
            ("cog_atlas_id", &self.cog_atlas_id),
            ("cog_po_id", &self.cog_po_id),
            ("institution_name", &self.institution_name),
            ("institution_address", &self.institution_address),
            (
                "institutional_department_name",
                &self.institutional_department_name,
            ),
        ];
        for (name, value) in texts {
            if value.as_deref().is_some_and(|v| v.trim().is_empty()) {
                return Err((name.into(), "is empty: leave it out (None) instead".into()));
            }
        }
        if let Some(d) = &self.dataset_doi {
            if !d.starts_with("doi:") {
                return Err((
                    "dataset_doi".into(),
                    format!(
                        "{d:?}: must be a URI such as \"doi:10.18112/openneuro.ds000001.v1.0.0\""
                    ),
                ));
            }
        }
        for (name, value) in [
            ("cog_atlas_id", &self.cog_atlas_id),
            ("cog_po_id", &self.cog_po_id),
        ] {
            if let Some(v) = value {
                if !(v.starts_with("https://") || v.starts_with("http://")) {
                    return Err((
                        name.into(),
                        format!("{v:?}: must be a web address (https://…)"),
                    ));
                }
            }
        }
        Ok(())
    }
}
