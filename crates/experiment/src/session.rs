//! The session folder: one folder per participant session, written by the
//! runner as the session happens and read back by the analysis
//! ([`crate::analysis`]) and the BIDS export ([`crate::bids`]).
//!
//! ```text
//! <session>/
//!   session.json          SessionInfo (who, what design, which display and tracker)
//!   design.ron            a copy of the design file (Design::load)
//!   trials.tsv            TrialRow, one per completed trial (with its plan)
//!   samples.tsv           SampleRow, every gaze sample
//!   events.tsv            EventRow, fixations / saccades / blinks
//!   markers.tsv           MarkerRow, phase starts, keys, clicks, calibration results
//!   frames.tsv            FrameRow, every frame shown (with the plan that drew it)
//!   clock.tsv             ClockRow, the tracker clock model as it was updated
//!   gaze-N.gzrec          every tracker byte of sitting N, with arrival times
//!   stimuli/trial-NNN.png the search display of trial NNN (optional, RGB)
//! ```
//!
//! # Clocks and sittings
//!
//! Every time in these files says its clock in its name and its column's
//! doc. Two clocks appear:
//!
//! - the **host clock** (`*_us` without `device`): the runner's monotonic
//!   microseconds, restarted by each process — so every row also carries
//!   its `sitting` (1, 2, … : one per run of `experiment run`, the first
//!   and each `--resume`). [`Sitting`] in `session.json` ties each
//!   sitting's host clock to the wall clock (`started_unix_us` at
//!   `host_anchor_us`), which puts all sittings on one time axis
//!   ([`SessionInfo::session_time_us`]).
//! - the **tracker clock** (`device_us`): the tracker's own timestamps as
//!   decoded (how they are derived: [`Sitting::device_clock`]).
//!
//! A gaze sample's `mapped_us` is its device time mapped onto the host
//! clock by tracker-hal's clock model (its updates: `clock.tsv`); events,
//! trial-relative times and the BIDS export use it. Its `arrival_us` is
//! when its bytes arrived (what machine load changes): kept, never used
//! for timing.
//!
//! A trial interrupted by the end of a sitting (a crash, Esc,
//! `--max-trials`) is run again in the next one: its samples in the
//! earlier sitting are *aborted* ([`aborted`]) and left out of the
//! analysis and the export.
//!
//! # Provenance: the `plan` columns
//!
//! Every frame says what drew it, so that a lab can show what each
//! condition rendered: `frames.tsv`'s `plan` is the provenance line of the
//! renderer that drew the frame (`pipeline::Renderer::provenance`: the
//! method that ran, the backend, and the passes in order with where each
//! ran), e.g. `image-based on gpu; passes: image-based foveation (gpu)` or
//! `foveated on cpu; passes: none`; `n/a` for a screen no renderer drew
//! (text, calibration targets). `trials.tsv`'s `plan` is the plan of the
//! trial's search frames (the condition's renderer). The line never holds
//! a tab or a line break, and is never empty or `n/a` itself.
//!
//! The column came after the files' first version: a file written before
//! it has a header that stops short of it ([`TsvRow::LATER_COLUMNS`]).
//! Such a file is read with `plan` missing (`None`), and a sitting resumed
//! on it first adds the column (`n/a` in the earlier rows) — see
//! [`read_tsv`] and [`TsvLog::append_to`].
//!
//! # The TSV files
//!
//! Tab-separated, one header line naming the columns ([`TsvRow::COLUMNS`],
//! in struct field order), `\n` line ends, no quoting at all (as BIDS
//! TSV): a field is the bytes between two tabs. A missing value
//! (`Option::None`) is written `n/a`, as BIDS does; on reading, `n/a` or
//! an empty field is `None`. Booleans are `true` / `false`; numbers are
//! written in the shortest form that reads back to the same bits
//! (`0.1`, `1e-300`, `1.7976931348623157e308`; NaN and infinities as `NaN`,
//! `inf`, `-inf`), so every row round-trips exactly.
//!
//! Text fields may hold anything except a tab, a carriage return or a line
//! feed: with no quoting those would split the field or the row, so
//! [`TsvLog::write`] **rejects** such a row with an error naming the
//! column, rather than escaping it (an escape would be one more private
//! convention every other TSV reader would get wrong). Quote characters,
//! spaces, `n/a` itself and any other Unicode are kept as they are.
//!
//! # Durability policy of [`TsvLog`]
//!
//! Each [`TsvLog::write`] formats the whole row in memory first and hands
//! the OS complete lines only, in one `write` call per flush. By default
//! every row is flushed at once, so a process that is killed (even with
//! `SIGKILL`) loses nothing it had written: the rows are in the OS page
//! cache. [`TsvLog::flush_every`] batches rows for high-rate files
//! (samples at 1 kHz): rows are then handed to the OS when `rows` are
//! pending or `interval` has passed since the last flush, *checked at each
//! write*, so a killed process loses at most those pending rows. Dropping
//! the log flushes. [`TsvLog::sync`] additionally asks the OS to put the
//! data on disk (`fsync`), which protects against power loss; call it at
//! trial ends, not per row.
//!
//! A process killed in the middle of the OS `write` can still leave a
//! half-written last line. [`read_tsv`] reports such a line (any last line
//! without its `\n`) as a [`ReadWarning`] and skips it; reopening the file
//! with [`TsvLog::append_to`] cuts it off before appending (and says so in
//! [`TsvLog::dropped_partial_line`]).
//!
//! `session.json` and every output of the analysis are written through
//! [`AtomicFile`]: a temporary file in the same folder, renamed over the
//! target once complete, so a reader never sees half a file.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// `session.json`: [`SessionInfo`].
pub const SESSION_JSON: &str = "session.json";
/// `design.ron`: the copy of the design file.
pub const DESIGN_RON: &str = "design.ron";
/// `trials.tsv`: [`TrialRow`].
pub const TRIALS_TSV: &str = "trials.tsv";
/// `samples.tsv`: [`SampleRow`].
pub const SAMPLES_TSV: &str = "samples.tsv";
/// `events.tsv`: [`EventRow`].
pub const EVENTS_TSV: &str = "events.tsv";
/// `markers.tsv`: [`MarkerRow`].
pub const MARKERS_TSV: &str = "markers.tsv";
/// `frames.tsv`: [`FrameRow`].
pub const FRAMES_TSV: &str = "frames.tsv";
/// `clock.tsv`: [`ClockRow`].
pub const CLOCK_TSV: &str = "clock.tsv";
/// The folder of the per-trial stimulus pictures.
pub const STIMULI_DIR: &str = "stimuli";
/// What a missing value is written as.
pub const NA: &str = "n/a";

/// `trial-NNN.png`: the stimulus picture's file name (trial index
/// zero-padded to 3 digits; more digits from trial 1000 on).
pub fn stimulus_file_name(trial: usize) -> String {
    format!("trial-{trial:03}.png")
}

/// `<dir>/stimuli/trial-NNN.png`.
pub fn stimulus_path(dir: &Path, trial: usize) -> PathBuf {
    dir.join(STIMULI_DIR).join(stimulus_file_name(trial))
}

/// One completed search trial (`trials.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRow {
    /// Participant id (as in `session.json`).
    pub participant: String,
    /// The sitting the trial was completed in (its times are on that
    /// sitting's host clock).
    pub sitting: u32,
    /// Run (repetition), from 0.
    pub run: usize,
    /// Position in the session, from 0 (`plan::Trial::index`).
    pub trial: usize,
    /// Position within the run, from 0.
    pub trial_in_run: usize,
    /// Condition name (`Design::conditions[..].name`).
    pub condition: String,
    /// Rendering method (`"full"` or `"hybrid"`).
    pub method: String,
    /// Inset diameter in degrees (`n/a` for the full method).
    #[serde(with = "na")]
    pub inset_deg: Option<f64>,
    /// Whether silhouette edges were kept.
    pub silhouette_edges: bool,
    /// Target mesh index.
    pub target_mesh: u32,
    /// Target cell row in the search grid.
    pub target_row: u32,
    /// Target cell column in the search grid.
    pub target_col: u32,
    /// Host clock when the search display appeared (µs): when the present
    /// call of its first frame returned.
    pub search_onset_us: u64,
    /// Host clock of the response key (µs).
    pub response_us: u64,
    /// Search time, `(response_us − search_onset_us) / 1e6` (s).
    pub rt_s: f64,
    /// Clicked grid row, when the participant confirmed by clicking.
    #[serde(with = "na")]
    pub clicked_row: Option<u32>,
    /// Clicked grid column.
    #[serde(with = "na")]
    pub clicked_col: Option<u32>,
    /// Whether the click hit the target (`n/a` without a click).
    #[serde(with = "na")]
    pub correct: Option<bool>,
    /// Frames rendered during the search.
    pub frames: u64,
    /// Of those, frames that missed their deadline.
    pub frames_late: u64,
    /// Mean rays cast per frame.
    pub mean_rays: f64,
    /// The participant was simulated.
    pub synthetic: bool,
    /// What drew the search display: the renderer's provenance line
    /// (`pipeline::Renderer::provenance`, e.g. `image-based on cpu;
    /// passes: none`) of the trial's search frames; should it have changed
    /// during the search, each plan in the order they ran, joined by
    /// ` | `. `n/a` in a file written before the column existed.
    #[serde(default, with = "na")]
    pub plan: Option<String>,
}

/// One gaze sample (`samples.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleRow {
    /// The sitting (1 = the session's first run, then one per `--resume`).
    pub sitting: u32,
    /// The tracker's timestamp mapped onto the host clock (µs, host
    /// monotonic clock of the sitting): the sample's time.
    pub mapped_us: u64,
    /// The tracker's own timestamp as decoded (µs, tracker clock); `n/a`
    /// for a tracker that sends none (then `mapped_us` is the arrival).
    #[serde(with = "na")]
    pub device_us: Option<u64>,
    /// Host clock when the sample's bytes arrived (µs): delivery, not
    /// capture — it varies with the machine's load.
    pub arrival_us: u64,
    /// How `device_us` stands against the previous sample's: `first`, `ok`,
    /// `repeated`, `backwards`, `ahead` (not believed: its capture would
    /// follow its arrival by over a second; these three have no valid
    /// interval, and `mapped_us` repeats the previous sample's), `reset` (a device clock reset: a new segment),
    /// `no-device-time`.
    pub time_order: String,
    /// The clock segment within the connection (a reset starts a new one).
    pub segment: u32,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// Runner phase (`"search"`, `"target"`, `"calibration"`, …).
    pub phase: String,
    /// Raw tracker x (tracker units), `n/a` if the tracker gave none.
    #[serde(with = "na")]
    pub raw_x: Option<f64>,
    /// Raw tracker y.
    #[serde(with = "na")]
    pub raw_y: Option<f64>,
    /// Gaze x in display pixels; `n/a` for an invalid sample (blink, lost).
    #[serde(with = "na")]
    pub x_px: Option<f64>,
    /// Gaze y in display pixels (origin top-left, y down).
    #[serde(with = "na")]
    pub y_px: Option<f64>,
}

impl SampleRow {
    /// Whether the sample has a time of its own (not a repeated, backwards
    /// or ahead device time, whose `mapped_us` is the previous one's).
    pub fn is_timed(&self) -> bool {
        !matches!(self.time_order.as_str(), "repeated" | "backwards" | "ahead")
    }
}

/// One eye-movement event (`events.tsv`), detected on the tracker's clock
/// (I-VT on device-time intervals, then the congruent-fixation merge).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventRow {
    /// The sitting.
    pub sitting: u32,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// `"fixation"`, `"saccade"`, `"blink"` or `"lost"`.
    pub kind: String,
    /// Start: the first sample's mapped time (µs, host clock).
    pub onset_us: u64,
    /// End: the last sample's mapped time (µs, host clock).
    pub end_us: u64,
    /// Start on the tracker's clock (µs, device time).
    pub onset_device_us: u64,
    /// End on the tracker's clock (µs, device time).
    pub end_device_us: u64,
    /// Fixation: centroid x; saccade: start x (display px).
    pub x_px: f64,
    /// Fixation: centroid y; saccade: start y.
    pub y_px: f64,
    /// Fixation: equal to `x_px`; saccade: end x.
    pub end_x_px: f64,
    /// Fixation: equal to `y_px`; saccade: end y.
    pub end_y_px: f64,
}

/// One runner marker (`markers.tsv`): phase starts, keys, clicks,
/// calibration results.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarkerRow {
    /// The sitting.
    pub sitting: u32,
    /// Host clock (µs).
    pub host_us: u64,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// What happened (`"phase"`, `"key"`, `"click"`, `"validation"`, …).
    pub event: String,
    /// Free text (no tabs or line breaks).
    pub detail: String,
}

/// One rendered frame (`frames.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// The sitting.
    pub sitting: u32,
    /// Host clock when the present call returned (µs).
    pub host_us: u64,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// Runner phase.
    pub phase: String,
    /// Rays cast.
    pub rays: u64,
    /// Render time (ms).
    pub render_ms: f64,
    /// Time since the previous frame (ms), `n/a` for the first.
    #[serde(with = "na")]
    pub interval_ms: Option<f64>,
    /// The frame missed its deadline.
    pub late: bool,
    /// What drew the frame: the provenance line of its renderer
    /// (`pipeline::Renderer::provenance`: method, backend, passes), e.g.
    /// `foveated on cpu; passes: none`; `n/a` for a screen no renderer drew
    /// (text, calibration targets) and in a file written before the
    /// column existed.
    #[serde(default, with = "na")]
    pub plan: Option<String>,
}

/// One update of the tracker's clock model (`clock.tsv`): how the
/// tracker's clock was mapped onto the host's (tracker-hal `timing`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClockRow {
    /// The sitting.
    pub sitting: u32,
    /// Samples the model had mapped on this connection.
    pub samples: u64,
    /// The newest sample's device time (µs, tracker clock).
    pub device_us: u64,
    /// Its mapped time (µs, host clock).
    pub mapped_us: u64,
    /// Host µs per tracker µs.
    pub rate: f64,
    /// Tracker-clock drift against the host (ppm; positive: fast).
    pub drift_ppm: f64,
    /// The fitted drift lay beyond the model's bound (a wrong nominal rate).
    pub rate_clamped: bool,
    /// Mapped − device time (µs): the clock offset.
    pub offset_us: f64,
    /// Arrival − mapped time of the newest sample (µs).
    pub delay_us: f64,
    /// Steps back towards an arrival (causality corrections) so far.
    pub corrections: u64,
    /// Samples with a repeated or backwards device time so far.
    pub non_increasing: u64,
    /// Device clock resets so far.
    pub resets: u64,
}

/// A row type of one of the session's TSV files.
pub trait TsvRow: Serialize + DeserializeOwned {
    /// The file name in the session folder.
    const FILE: &'static str;
    /// The header: the serde field names, in order.
    const COLUMNS: &'static [&'static str];
    /// How many of the last [`TsvRow::COLUMNS`] were added after the
    /// file's first version (each `Option` with a serde default). A file
    /// written before has a header that stops short of them: [`read_tsv`]
    /// reads its rows with those fields `None`, and [`TsvLog::append_to`]
    /// adds them (`n/a`) to its rows before appending.
    const LATER_COLUMNS: usize = 0;

    /// The header line without its `\n`.
    fn header_line() -> String {
        Self::COLUMNS.join("\t")
    }

    /// How many columns a file with this header line has: all of
    /// [`TsvRow::COLUMNS`] for the current header, fewer for the header of
    /// a file written before the [`TsvRow::LATER_COLUMNS`]; `None` for any
    /// other header.
    fn header_columns(found: &str) -> Option<usize> {
        let all = Self::COLUMNS.len();
        let oldest = all - Self::LATER_COLUMNS.min(all);
        (oldest..=all)
            .rev()
            .find(|&n| n > 0 && found == Self::COLUMNS[..n].join("\t"))
    }
}

impl TsvRow for TrialRow {
    const FILE: &'static str = TRIALS_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "participant",
        "sitting",
        "run",
        "trial",
        "trial_in_run",
        "condition",
        "method",
        "inset_deg",
        "silhouette_edges",
        "target_mesh",
        "target_row",
        "target_col",
        "search_onset_us",
        "response_us",
        "rt_s",
        "clicked_row",
        "clicked_col",
        "correct",
        "frames",
        "frames_late",
        "mean_rays",
        "synthetic",
        "plan",
    ];
    const LATER_COLUMNS: usize = 1;
}

impl TsvRow for SampleRow {
    const FILE: &'static str = SAMPLES_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "mapped_us",
        "device_us",
        "arrival_us",
        "time_order",
        "segment",
        "trial",
        "phase",
        "raw_x",
        "raw_y",
        "x_px",
        "y_px",
    ];
}

impl TsvRow for EventRow {
    const FILE: &'static str = EVENTS_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "trial",
        "kind",
        "onset_us",
        "end_us",
        "onset_device_us",
        "end_device_us",
        "x_px",
        "y_px",
        "end_x_px",
        "end_y_px",
    ];
}

impl TsvRow for ClockRow {
    const FILE: &'static str = CLOCK_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "samples",
        "device_us",
        "mapped_us",
        "rate",
        "drift_ppm",
        "rate_clamped",
        "offset_us",
        "delay_us",
        "corrections",
        "non_increasing",
        "resets",
    ];
}

impl TsvRow for MarkerRow {
    const FILE: &'static str = MARKERS_TSV;
    const COLUMNS: &'static [&'static str] = &["sitting", "host_us", "trial", "event", "detail"];
}

impl TsvRow for FrameRow {
    const FILE: &'static str = FRAMES_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "host_us",
        "trial",
        "phase",
        "rays",
        "render_ms",
        "interval_ms",
        "late",
        "plan",
    ];
    const LATER_COLUMNS: usize = 1;
}

/// `session.json`: who, which design, which display and tracker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionInfo {
    /// Participant id (free text; the BIDS label is its alphanumerics).
    pub participant: String,
    /// Participant index (the counterbalancing row).
    pub participant_index: usize,
    /// `Design::name`.
    pub design_name: String,
    /// Software and version that ran the session (e.g. `gazecast 0.1.0`).
    pub software: String,
    /// The display.
    pub display: DisplayInfo,
    /// Tracker description (make, model; `"simulated"` for a simulated one).
    pub tracker: String,
    /// Nominal sampling rate, if known.
    pub tracker_rate_hz: Option<f64>,
    /// Session start, Unix time (s).
    pub started_unix_s: f64,
    /// The participant was simulated: never present these data as human.
    pub synthetic: bool,
    /// Free notes.
    pub notes: Vec<String>,
    /// One entry per sitting, in order (the first is the session's start).
    #[serde(default)]
    pub sittings: Vec<Sitting>,
}

/// One sitting: one run of the session's process, with what ties its host
/// clock to the wall clock and to the tracker's clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sitting {
    /// 1, 2, …
    pub number: u32,
    /// The first trial it ran (index, from 0).
    pub first_trial: usize,
    /// Wall clock (Unix time, µs) at `host_anchor_us`.
    pub started_unix_us: u64,
    /// The sitting's host clock (µs) at `started_unix_us`.
    pub host_anchor_us: u64,
    /// The software that ran it.
    pub software: String,
    /// The tracker it used (name; the port may differ between sittings).
    pub tracker: String,
    /// The tracker file's settings (as JSON), to check a resumed sitting
    /// against the first.
    #[serde(default)]
    pub tracker_settings: Option<serde_json::Value>,
    /// How the tracker's device times are obtained.
    pub device_clock: String,
    /// The clock model at the sitting's end (`None` until it ends, or for
    /// a tracker without device times).
    #[serde(default)]
    pub clock: Option<ClockRow>,
}

impl SessionInfo {
    /// A sitting's host time on the session's one time axis: µs since the
    /// first sitting's start, through each sitting's wall-clock anchor.
    /// `None` for an unknown sitting.
    pub fn session_time_us(&self, sitting: u32, host_us: u64) -> Option<i64> {
        let first = self.sittings.first()?;
        let s = self.sittings.iter().find(|s| s.number == sitting)?;
        let start = s.started_unix_us as i64 - first.started_unix_us as i64;
        Some(start + (host_us as i64 - s.host_anchor_us as i64))
    }
}

/// The trials whose samples in a sitting are aborted: a sample of trial
/// `t` in sitting `s` is aborted when the trial table completed `t` in
/// another sitting (it was run again) or not at all. Returns, for each
/// trial index, the sitting that completed it.
pub fn completing_sittings(trials: &[TrialRow]) -> std::collections::HashMap<usize, u32> {
    trials.iter().map(|t| (t.trial, t.sitting)).collect()
}

/// Whether a row of `sitting` for `trial` belongs to an aborted run of the
/// trial (see [`completing_sittings`]). Rows outside trials are never
/// aborted.
pub fn aborted(
    completed: &std::collections::HashMap<usize, u32>,
    sitting: u32,
    trial: Option<usize>,
) -> bool {
    trial.is_some_and(|t| completed.get(&t) != Some(&sitting))
}

/// The display the stimuli were shown on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayInfo {
    /// Name or model.
    pub name: String,
    /// Width in pixels.
    pub width_px: u32,
    /// Height in pixels.
    pub height_px: u32,
    /// Visible width (mm).
    pub width_mm: f64,
    /// Visible height (mm).
    pub height_mm: f64,
    /// Eye-to-screen distance (mm).
    pub distance_mm: f64,
}

impl SessionInfo {
    /// Writes `path` (pretty JSON) through a temporary file and a rename.
    pub fn write(&self, path: &Path) -> Result<(), SessionFileError> {
        let mut text =
            serde_json::to_string_pretty(self).map_err(|source| SessionFileError::Json {
                path: path.to_path_buf(),
                source,
            })?;
        text.push('\n');
        write_atomic(path, text.as_bytes()).map_err(|e| SessionFileError::io(path, e))
    }

    /// Reads `path`; errors name the file (and line and column for JSON).
    pub fn read(path: &Path) -> Result<Self, SessionFileError> {
        let text = input_file::read_to_string(path, input_file::SESSION_TABLE)
            .map_err(|e| SessionFileError::io(path, e))?;
        serde_json::from_str(&text).map_err(|source| SessionFileError::Json {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// Why a session file could not be read or written. Every variant names
/// the file; parse errors also the line and, where known, the column.
#[derive(Debug, thiserror::Error)]
pub enum SessionFileError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The header line is not the expected one.
    #[error("{}: line 1: the header is not the expected one\n  expected: {expected}\n  found:    {found}", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// The expected header (tab-separated, shown with tabs as ` | `).
        expected: String,
        /// The header found.
        found: String,
    },
    /// A row could not be parsed.
    #[error("{}: line {line}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column {c}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// Column name, where known.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A row could not be written (a tab or line break in a text field).
    #[error("{}: cannot write row {row}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column {c}")).unwrap_or_default())]
    Write {
        /// The file.
        path: PathBuf,
        /// 1-based data row number within the file.
        row: u64,
        /// Column name, where known.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// `session.json` is not valid JSON of the expected shape.
    #[error("{}: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The cause (with line and column).
        source: serde_json::Error,
    },
}

impl SessionFileError {
    fn io(path: &Path, source: io::Error) -> Self {
        SessionFileError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            SessionFileError::Io { path, .. }
            | SessionFileError::Header { path, .. }
            | SessionFileError::Parse { path, .. }
            | SessionFileError::Write { path, .. }
            | SessionFileError::Json { path, .. } => path,
        }
    }
}

/// Something [`read_tsv`] skipped rather than failed on (a half-written
/// last line of a killed session).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadWarning {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number.
    pub line: u64,
    /// What was skipped and why.
    pub message: String,
}

impl fmt::Display for ReadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: line {}: {}",
            self.path.display(),
            self.line,
            self.message
        )
    }
}

/// The rows of a TSV file, with their line numbers and any warnings.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOutcome<T> {
    /// The rows, in file order.
    pub rows: Vec<T>,
    /// `lines[i]` is the 1-based line number of `rows[i]`.
    pub lines: Vec<u64>,
    /// Lines skipped (a half-written last line).
    pub warnings: Vec<ReadWarning>,
}

fn tsv_reader<R: Read>(r: R) -> csv::Reader<R> {
    csv::ReaderBuilder::new()
        .delimiter(b'\t')
        .has_headers(true)
        .quoting(false)
        .flexible(false)
        .from_reader(r)
}

fn tsv_writer<W: Write>(w: W) -> csv::Writer<W> {
    csv::WriterBuilder::new()
        .delimiter(b'\t')
        .has_headers(false)
        .quote_style(csv::QuoteStyle::Never)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(w)
}

/// Length of the file up to and including its last `\n` (0 if none).
fn complete_len(file: &mut File, len: u64) -> io::Result<u64> {
    let mut end = len;
    let mut buf = vec![0u8; 64 * 1024];
    while end > 0 {
        let start = end.saturating_sub(buf.len() as u64);
        let chunk = &mut buf[..(end - start) as usize];
        file.seek(SeekFrom::Start(start))?;
        file.read_exact(chunk)?;
        if let Some(i) = chunk.iter().rposition(|&b| b == b'\n') {
            return Ok(start + i as u64 + 1);
        }
        end = start;
    }
    Ok(0)
}

fn shown(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let text = text.replace('\t', " | ");
    if text.chars().count() > 80 {
        format!("{}…", text.chars().take(80).collect::<String>())
    } else {
        text
    }
}

/// Reads every row of a session TSV file.
///
/// The header must be exactly [`TsvRow::COLUMNS`], or the header of a file
/// written before the [`TsvRow::LATER_COLUMNS`] (those columns left off
/// the end: their fields read as `None`). A last line without its
/// `\n` (a killed writer) is skipped with a warning, whatever it holds;
/// every other problem is an error naming the file, the line and, where
/// known, the column.
pub fn read_tsv<T: TsvRow>(path: &Path) -> Result<ReadOutcome<T>, SessionFileError> {
    let mut out = ReadOutcome {
        rows: Vec::new(),
        lines: Vec::new(),
        warnings: Vec::new(),
    };
    visit_tsv::<T>(path, |row, line| {
        out.rows.push(row);
        out.lines.push(line);
        Ok(())
    })
    .map(|w| {
        out.warnings = w;
    })?;
    Ok(out)
}

/// Streams the rows of a session TSV file to `each(row, line)` (for files
/// too large to hold, such as a long session's samples). Same rules as
/// [`read_tsv`]; returns the warnings.
pub fn visit_tsv<T: TsvRow>(
    path: &Path,
    mut each: impl FnMut(T, u64) -> Result<(), SessionFileError>,
) -> Result<Vec<ReadWarning>, SessionFileError> {
    let io_err = |e| SessionFileError::io(path, e);
    let (mut file, len) = input_file::open(path, input_file::SESSION_STREAM).map_err(io_err)?;
    let good = complete_len(&mut file, len).map_err(io_err)?;
    let mut warnings = Vec::new();
    if len == 0 {
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line: 1,
            message: "the file is empty (no header): no rows".into(),
        });
        return Ok(warnings);
    }
    let mut partial = None;
    if good < len {
        let mut tail = Vec::new();
        file.seek(SeekFrom::Start(good)).map_err(io_err)?;
        file.read_to_end(&mut tail).map_err(io_err)?;
        partial = Some(tail);
    }
    file.seek(SeekFrom::Start(0)).map_err(io_err)?;
    if good == 0 {
        // Only a partial header line.
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line: 1,
            message: format!(
                "incomplete header line (no line end; the writer was stopped?) skipped: {:?}",
                shown(partial.as_deref().unwrap_or_default())
            ),
        });
        return Ok(warnings);
    }
    let mut rdr = tsv_reader(BufReader::new(file.take(good)));
    let expected = T::header_line();
    let header = rdr.headers().map_err(|e| csv_error(path, e, T::COLUMNS))?;
    let found = header.iter().collect::<Vec<_>>().join("\t");
    // An older file without the later columns: its rows have fewer fields
    // (csv holds every record to the header's length), and the missing
    // ones take their serde default.
    if T::header_columns(&found).is_none() {
        return Err(SessionFileError::Header {
            path: path.to_path_buf(),
            expected: expected.replace('\t', " | "),
            found: found.replace('\t', " | "),
        });
    }
    let mut record = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, e, T::COLUMNS)),
        }
        let line = record.position().map_or(0, |p| p.line());
        let row: T =
            row_de::from_fields(&record).map_err(|(i, message)| SessionFileError::Parse {
                path: path.to_path_buf(),
                line,
                column: Some(
                    T::COLUMNS
                        .get(i)
                        .map_or_else(|| format!("#{}", i + 1), |c| c.to_string()),
                ),
                message,
            })?;
        each(row, line)?;
    }
    if let Some(tail) = partial {
        let line = rdr.position().line();
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line,
            message: format!(
                "incomplete last line (no line end; the writer was stopped?) skipped: {:?}",
                shown(&tail)
            ),
        });
    }
    Ok(warnings)
}

fn csv_error(path: &Path, e: csv::Error, columns: &[&str]) -> SessionFileError {
    let column_name = |i: u64| {
        columns
            .get(i as usize)
            .map(|c| c.to_string())
            .unwrap_or_else(|| format!("#{}", i + 1))
    };
    match e.into_kind() {
        csv::ErrorKind::Io(source) => SessionFileError::io(path, source),
        csv::ErrorKind::Utf8 { pos, err } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: Some(column_name(err.field() as u64)),
            message: format!("not UTF-8 text ({err})"),
        },
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: None,
            message: format!("{len} fields, expected {expected_len} (a tab too many or too few?)"),
        },
        csv::ErrorKind::Deserialize { pos, err } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: err.field().map(column_name),
            message: match err.kind() {
                csv::DeserializeErrorKind::Message(m) => m.clone(),
                other => other.to_string(),
            },
        },
        other => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: 0,
            column: None,
            message: format!("{other:?}"),
        },
    }
}

/// An append-only TSV log of `T` rows: see the module documentation for
/// the durability policy.
pub struct TsvLog<T: TsvRow> {
    path: PathBuf,
    file: File,
    pending: Vec<u8>,
    pending_rows: usize,
    rows: u64,
    flush_rows: usize,
    flush_interval: Duration,
    last_flush: Instant,
    dropped: Option<String>,
    added: &'static [&'static str],
    _row: PhantomData<fn(&T)>,
}

impl<T: TsvRow> TsvLog<T> {
    /// Opens `path` for appending rows: creates it with the header line,
    /// or opens an existing file after checking that its header line is
    /// [`TsvRow::COLUMNS`] (a mismatch is [`SessionFileError::Header`]
    /// naming the file). A half-written last line left by a killed writer
    /// is cut off first (see [`TsvLog::dropped_partial_line`]); an
    /// incomplete header line is rewritten.
    ///
    /// A file written before the [`TsvRow::LATER_COLUMNS`] (its header
    /// stops short of them) gets them first: the file is rewritten whole
    /// (through a temporary file and a rename) with the current header and
    /// `n/a` for those columns at the end of every row, every other byte
    /// kept ([`TsvLog::added_columns`] names them). A row whose field count
    /// is not its header's is an error, and the file is left untouched.
    pub fn append_to(path: impl AsRef<Path>) -> Result<Self, SessionFileError> {
        let path = path.as_ref();
        let io_err = |e| SessionFileError::io(path, e);
        let expected = T::header_line();
        let (added, upgrade_dropped) = add_later_columns::<T>(path)?;
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io_err)?;
        let len = file.metadata().map_err(io_err)?.len();
        let mut rows = 0;
        let mut dropped = None;
        let good = complete_len(&mut file, len).map_err(io_err)?;
        if good == 0 {
            // New, empty, or only part of the header line.
            let mut have = Vec::new();
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            file.read_to_end(&mut have).map_err(io_err)?;
            if !expected.as_bytes().starts_with(&have) {
                return Err(SessionFileError::Header {
                    path: path.to_path_buf(),
                    expected: expected.replace('\t', " | "),
                    found: shown(&have),
                });
            }
            file.set_len(0).map_err(io_err)?;
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            file.write_all(format!("{expected}\n").as_bytes())
                .map_err(io_err)?;
        } else {
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            let mut reader = BufReader::new(&mut file);
            let mut first = Vec::new();
            reader.read_until(b'\n', &mut first).map_err(io_err)?;
            let found = String::from_utf8_lossy(&first);
            let found = found.trim_end_matches('\n').trim_end_matches('\r');
            if found != expected {
                return Err(SessionFileError::Header {
                    path: path.to_path_buf(),
                    expected: expected.replace('\t', " | "),
                    found: found.replace('\t', " | "),
                });
            }
            // Count the data lines (for row numbers in errors).
            let mut line = Vec::new();
            let mut read = first.len() as u64;
            while read < good {
                line.clear();
                let n = reader.read_until(b'\n', &mut line).map_err(io_err)?;
                if n == 0 {
                    break;
                }
                read += n as u64;
                rows += 1;
            }
            drop(reader);
            if good < len {
                let mut tail = Vec::new();
                file.seek(SeekFrom::Start(good)).map_err(io_err)?;
                file.read_to_end(&mut tail).map_err(io_err)?;
                dropped = Some(String::from_utf8_lossy(&tail).into_owned());
                file.set_len(good).map_err(io_err)?;
            }
        }
        file.seek(SeekFrom::End(0)).map_err(io_err)?;
        Ok(TsvLog {
            path: path.to_path_buf(),
            file,
            pending: Vec::new(),
            pending_rows: 0,
            rows,
            flush_rows: 1,
            flush_interval: Duration::ZERO,
            last_flush: Instant::now(),
            dropped: dropped.or(upgrade_dropped),
            added,
            _row: PhantomData,
        })
    }

    /// The columns [`TsvLog::append_to`] added to an older file's rows
    /// (`n/a` in each), or none.
    pub fn added_columns(&self) -> &'static [&'static str] {
        self.added
    }

    /// Batches rows: hand them to the OS when `rows` rows are pending or
    /// `interval` has passed since the last flush (checked at each write).
    /// `rows = 1` (the default) flushes every row.
    pub fn flush_every(mut self, rows: usize, interval: Duration) -> Self {
        self.flush_rows = rows.max(1);
        self.flush_interval = interval;
        self
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Data rows in the file so far (including those still pending).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The half-written last line [`TsvLog::append_to`] cut off, if any.
    pub fn dropped_partial_line(&self) -> Option<&str> {
        self.dropped.as_deref()
    }

    /// Appends one row. A text field holding a tab, carriage return or
    /// line feed is refused ([`SessionFileError::Write`] naming the
    /// column) and nothing is written.
    pub fn write(&mut self, row: &T) -> Result<(), SessionFileError> {
        let line = format_row(row).map_err(|(column, message)| SessionFileError::Write {
            path: self.path.clone(),
            row: self.rows + 1,
            column,
            message,
        })?;
        self.pending.extend_from_slice(&line);
        self.pending_rows += 1;
        self.rows += 1;
        if self.pending_rows >= self.flush_rows
            || (self.flush_interval > Duration::ZERO
                && self.last_flush.elapsed() >= self.flush_interval)
        {
            self.flush()?;
        }
        Ok(())
    }

    /// Hands every pending row to the OS (one `write` of whole lines).
    pub fn flush(&mut self) -> Result<(), SessionFileError> {
        if !self.pending.is_empty() {
            self.file
                .write_all(&self.pending)
                .map_err(|e| SessionFileError::io(&self.path, e))?;
            self.pending.clear();
            self.pending_rows = 0;
        }
        self.last_flush = Instant::now();
        Ok(())
    }

    /// Flushes and asks the OS to put the data on disk (`fsync`).
    pub fn sync(&mut self) -> Result<(), SessionFileError> {
        self.flush()?;
        self.file
            .sync_data()
            .map_err(|e| SessionFileError::io(&self.path, e))
    }
}

impl<T: TsvRow> Drop for TsvLog<T> {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

/// [`TsvLog::append_to`]'s first step: when `path` exists with the header
/// of a file written before the [`TsvRow::LATER_COLUMNS`], rewrites it
/// with the current header and `\tn/a` for each missing column at the end
/// of every complete row. Returns the columns added and the half-written
/// last line cut off, if any; nothing for any other file (a new one, the
/// current header, a header `append_to` refuses).
fn add_later_columns<T: TsvRow>(
    path: &Path,
) -> Result<(&'static [&'static str], Option<String>), SessionFileError> {
    let io_err = |e| SessionFileError::io(path, e);
    let mut file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok((&[], None)),
        Err(e) => return Err(io_err(e)),
    };
    let len = file.metadata().map_err(io_err)?.len();
    let good = complete_len(&mut file, len).map_err(io_err)?;
    if good == 0 {
        return Ok((&[], None));
    }
    file.seek(SeekFrom::Start(0)).map_err(io_err)?;
    let mut reader = BufReader::new((&mut file).take(good));
    let mut line = Vec::new();
    reader.read_until(b'\n', &mut line).map_err(io_err)?;
    let found = String::from_utf8_lossy(&line);
    let found = found.trim_end_matches('\n').trim_end_matches('\r');
    let all = T::COLUMNS.len();
    let n = match T::header_columns(found) {
        Some(n) if n < all => n,
        _ => return Ok((&[], None)),
    };
    let added = &T::COLUMNS[n..];
    let fill: String = added.iter().map(|_| format!("\t{NA}")).collect();
    let mut out = AtomicFile::create(path).map_err(io_err)?;
    writeln!(out, "{}", T::header_line()).map_err(io_err)?;
    let mut number = 1u64;
    loop {
        line.clear();
        if reader.read_until(b'\n', &mut line).map_err(io_err)? == 0 {
            break;
        }
        number += 1;
        let body = line.strip_suffix(b"\n").unwrap_or(&line);
        // A `\r\n` line end stays one, after the added fields.
        let (body, cr) = match body.strip_suffix(b"\r") {
            Some(b) => (b, &b"\r"[..]),
            None => (body, &b""[..]),
        };
        let fields = 1 + body.iter().filter(|&&b| b == b'\t').count();
        if fields != n {
            return Err(SessionFileError::Parse {
                path: path.to_path_buf(),
                line: number,
                column: None,
                message: format!(
                    "{fields} fields, expected {n} (its header's); the file is left as it is, without the added column{} {}",
                    if added.len() == 1 { "" } else { "s" },
                    added.join(", ")
                ),
            });
        }
        out.write_all(body).map_err(io_err)?;
        out.write_all(fill.as_bytes()).map_err(io_err)?;
        out.write_all(cr).map_err(io_err)?;
        out.write_all(b"\n").map_err(io_err)?;
    }
    drop(reader);
    let dropped = if good < len {
        let mut tail = Vec::new();
        file.seek(SeekFrom::Start(good)).map_err(io_err)?;
        file.read_to_end(&mut tail).map_err(io_err)?;
        Some(String::from_utf8_lossy(&tail).into_owned())
    } else {
        None
    };
    drop(file);
    out.commit().map_err(io_err)?;
    Ok((added, dropped))
}

/// The row as one TSV line with its `\n`, or the offending column and why.
fn format_row<T: TsvRow>(row: &T) -> Result<Vec<u8>, (Option<String>, String)> {
    let mut w = tsv_writer(Vec::new());
    w.serialize(row)
        .map_err(|e| (None, format!("cannot serialize: {e}")))?;
    let line = w
        .into_inner()
        .map_err(|e| (None, format!("cannot serialize: {}", e.error())))?;
    let tabs = line.iter().filter(|&&b| b == b'\t').count();
    let breaks = line.iter().filter(|&&b| b == b'\n' || b == b'\r').count();
    if tabs + 1 == T::COLUMNS.len() && breaks == 1 && line.last() == Some(&b'\n') {
        return Ok(line);
    }
    // Find the culprit: serialize again with quoting, which keeps fields whole.
    let mut q = csv::WriterBuilder::new()
        .delimiter(b'\t')
        .has_headers(false)
        .from_writer(Vec::new());
    let column = q.serialize(row).ok().and_then(|_| {
        let bytes = q.into_inner().ok()?;
        let mut r = csv::ReaderBuilder::new()
            .delimiter(b'\t')
            .has_headers(false)
            .from_reader(bytes.as_slice());
        let rec = r.records().next()?.ok()?;
        let i = rec.iter().position(|f| f.contains(['\t', '\n', '\r']))?;
        T::COLUMNS.get(i).map(|c| c.to_string())
    });
    Err((
        column,
        "a text field contains a tab or a line break, which TSV cannot hold (not written)".into(),
    ))
}

/// Deserializes one row from its text fields, knowing which field fails
/// (csv's own deserializer loses the position of errors raised by custom
/// field parsers such as [`na`]): `Err((field index, message))`.
mod row_de {
    use serde::de::{self, DeserializeSeed, IntoDeserializer, SeqAccess, Visitor};
    use std::fmt;

    #[derive(Debug)]
    pub struct Error(pub String);

    impl fmt::Display for Error {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(&self.0)
        }
    }

    impl std::error::Error for Error {}

    impl de::Error for Error {
        fn custom<T: fmt::Display>(msg: T) -> Self {
            Error(msg.to_string())
        }
    }

    pub fn from_fields<T: de::DeserializeOwned>(
        record: &csv::StringRecord,
    ) -> Result<T, (usize, String)> {
        let fields: Vec<&str> = record.iter().collect();
        let mut row = Row {
            fields: &fields,
            next: 0,
            failed: None,
        };
        match T::deserialize(&mut row) {
            Ok(t) => Ok(t),
            Err(e) => Err((row.failed.unwrap_or(row.next.saturating_sub(1)), e.0)),
        }
    }

    struct Row<'r, 'a> {
        fields: &'r [&'a str],
        next: usize,
        failed: Option<usize>,
    }

    impl<'de> de::Deserializer<'de> for &mut Row<'_, '_> {
        type Error = Error;

        fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_seq(self)
        }

        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map struct enum identifier ignored_any
        }
    }

    impl<'de> SeqAccess<'de> for &mut Row<'_, '_> {
        type Error = Error;

        fn next_element_seed<S: DeserializeSeed<'de>>(
            &mut self,
            seed: S,
        ) -> Result<Option<S::Value>, Error> {
            let Some(&text) = self.fields.get(self.next) else {
                return Ok(None);
            };
            let i = self.next;
            self.next += 1;
            seed.deserialize(Field(text)).map(Some).inspect_err(|_| {
                self.failed = Some(i);
            })
        }
    }

    struct Field<'a>(&'a str);

    impl Field<'_> {
        fn parse<T: std::str::FromStr>(&self, what: &str) -> Result<T, Error> {
            self.0
                .parse()
                .map_err(|_| Error(format!("{:?} is not {what}", self.0)))
        }
    }

    macro_rules! parse_int {
        ($($m:ident $v:ident $t:ty),*) => {$(
            fn $m<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
                visitor.$v(self.parse::<$t>("an integer of the column's range")?)
            }
        )*};
    }

    impl<'de> de::Deserializer<'de> for Field<'_> {
        type Error = Error;

        fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_str(self.0)
        }
        fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_bool(self.parse("true or false")?)
        }
        parse_int!(
            deserialize_u8 visit_u8 u8, deserialize_u16 visit_u16 u16,
            deserialize_u32 visit_u32 u32, deserialize_u64 visit_u64 u64,
            deserialize_i8 visit_i8 i8, deserialize_i16 visit_i16 i16,
            deserialize_i32 visit_i32 i32, deserialize_i64 visit_i64 i64
        );
        fn deserialize_f32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_f32(self.parse("a number")?)
        }
        fn deserialize_f64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.visit_f64(self.parse("a number")?)
        }
        fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            if self.0.is_empty() || self.0 == super::NA {
                visitor.visit_none()
            } else {
                visitor.visit_some(self)
            }
        }
        fn deserialize_enum<V: Visitor<'de>>(
            self,
            _name: &'static str,
            _variants: &'static [&'static str],
            visitor: V,
        ) -> Result<V::Value, Error> {
            visitor.visit_enum(self.0.into_deserializer())
        }

        serde::forward_to_deserialize_any! {
            i128 u128 char str string bytes byte_buf unit unit_struct
            newtype_struct seq tuple tuple_struct map struct identifier ignored_any
        }
    }
}

/// Serde helpers for `Option` fields written `n/a` when missing (BIDS).
pub mod na {
    use serde::{Deserialize, Deserializer, Serializer};

    /// A value that can stand in an `n/a`-able TSV field.
    pub trait NaValue: Sized {
        /// The field text.
        fn to_field(&self) -> String;
        /// Parses the field text.
        fn from_field(s: &str) -> Result<Self, String>;
    }

    impl NaValue for f64 {
        fn to_field(&self) -> String {
            // Debug: shortest round-trip form, exponent for tiny/huge values.
            format!("{self:?}")
        }
        fn from_field(s: &str) -> Result<Self, String> {
            s.parse()
                .map_err(|_| format!("{s:?} is not a number or {}", super::NA))
        }
    }

    impl NaValue for bool {
        fn to_field(&self) -> String {
            self.to_string()
        }
        fn from_field(s: &str) -> Result<Self, String> {
            s.parse()
                .map_err(|_| format!("{s:?} is not true, false or {}", super::NA))
        }
    }

    macro_rules! na_int {
        ($($t:ty),*) => {$(
            impl NaValue for $t {
                fn to_field(&self) -> String {
                    self.to_string()
                }
                fn from_field(s: &str) -> Result<Self, String> {
                    s.parse().map_err(|_| {
                        format!("{s:?} is not a non-negative integer or {}", super::NA)
                    })
                }
            }
        )*};
    }
    na_int!(u32, u64, usize);

    /// Text (a field written `n/a` or left empty reads back as `None`, so
    /// a `Some` of either does not round-trip).
    impl NaValue for String {
        fn to_field(&self) -> String {
            self.clone()
        }
        fn from_field(s: &str) -> Result<Self, String> {
            Ok(s.to_string())
        }
    }

    /// `None` → `n/a`.
    pub fn serialize<T: NaValue, S: Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(x) => s.serialize_str(&x.to_field()),
            None => s.serialize_str(super::NA),
        }
    }

    /// `n/a` or an empty field → `None`.
    pub fn deserialize<'de, T: NaValue, D: Deserializer<'de>>(d: D) -> Result<Option<T>, D::Error> {
        let s = String::deserialize(d)?;
        if s == super::NA || s.is_empty() {
            Ok(None)
        } else {
            T::from_field(&s)
                .map(Some)
                .map_err(serde::de::Error::custom)
        }
    }
}

/// A file written whole or not at all: the bytes go to a temporary file
/// in the same folder, which [`AtomicFile::commit`] renames over the
/// target. Dropped without a commit, the temporary file is removed and the
/// target is untouched.
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    file: Option<io::BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target`.
    pub fn create(target: &Path) -> io::Result<Self> {
        use std::sync::atomic::{AtomicU64, Ordering};
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "no file name"))?
            .to_string_lossy();
        let temp = target.with_file_name(format!(
            ".{name}.tmp-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let file = File::create(&temp)?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            temp,
            file: Some(io::BufWriter::new(file)),
        })
    }

    /// Flushes, syncs and renames the temporary file over the target. On
    /// any error (a full disk when the last bytes are flushed, a failed
    /// sync or rename) the temporary file is removed and the target is
    /// untouched.
    pub fn commit(mut self) -> io::Result<()> {
        let result = self.finish();
        if result.is_err() {
            let _ = std::fs::remove_file(&self.temp);
        }
        result
    }

    fn finish(&mut self) -> io::Result<()> {
        let file = self.file.take().ok_or_else(committed)?;
        let file = file.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&self.temp, &self.target)
    }
}

fn committed() -> io::Error {
    io::Error::other("the file was already committed")
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.as_mut().ok_or_else(committed)?.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.file.as_mut().ok_or_else(committed)?.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            // Unflushed bytes are discarded, not written (they may be
            // what failed): the BufWriter is taken apart before the drop.
            let _ = file.into_parts();
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` whole or not at all ([`AtomicFile`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}
