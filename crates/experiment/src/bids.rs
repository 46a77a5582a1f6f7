//! BIDS export of session folders: eye-tracking as BIDS physiological
//! recordings (`PhysioType` `"eyetrack"`, BEP020, part of BIDS since
//! 1.11.0) plus the trials as task events.
//!
//! ```text
//! OUT/
//!   dataset_description.json   Name, BIDSVersion, DatasetType, GeneratedBy, and the
//!                              dataset metadata given (Authors, License, Funding, …)
//!   README.md                  what the dataset is (and that it is synthetic, if so)
//!   participants.tsv / .json   participant_id, participant, participant_index, synthetic
//!   sub-<label>/beh/           one run per sitting (run-1, run-2, …):
//!     <run>_recording-eye<k>_physio.tsv.gz   no header, one row per sample:
//!         timestamp  x_coordinate  y_coordinate  [pupil_size]  device_timestamp  arrival_timestamp
//!     <run>_recording-eye<k>_physio.json     the sidecar (RecordedEye, calibration, task)
//!     <run>_recording-eye<k>_physioevents.tsv.gz   no header, one row per event or message:
//!         onset  duration  trial_type  trial  x/y_coordinate  end_x/end_y_coordinate  message
//!     <run>_recording-eye<k>_physioevents.json     its sidecar (OnsetSource "timestamp")
//!     <run>_events.tsv                       one row per trial
//!     <run>_events.json                      columns + StimulusPresentation
//! ```
//!
//! (`<run>` is `sub-<label>_task-<task>_run-<n>`.)
//!
//! Choices (the specification leaves them to the exporter):
//!
//! - **One run per sitting.** A session resumed after a crash or a break
//!   (`experiment run --resume`) has one sitting per process, each with
//!   its own host clock; BIDS 1.11 gives each continuous recording its own
//!   run (`run-<index>`, "if a recording was interrupted"), with times
//!   relative to that recording. So each sitting is a run, numbered by the
//!   sitting, and every time in a run is on that sitting's clock; the
//!   sittings' wall-clock anchors stay in the session folder
//!   (`session.json`). Samples of a trial that was aborted by the end of a
//!   sitting and run again later are left out (a warning counts them), as
//!   are samples with a repeated or backwards tracker timestamp.
//! - `timestamp` is the tracker's timestamp mapped onto the host clock
//!   (`samples.tsv` `mapped_us`, µs): the tracker's own sample times, on
//!   the clock the events' onsets are measured on. Within a run it
//!   increases strictly (a session file whose times go back is refused,
//!   naming the line). The extra columns keep the tracker's own timestamp
//!   as decoded (`device_timestamp`, how it is derived is in the sidecar)
//!   and the arrival time (`arrival_timestamp`). The clock model is in the
//!   sidecar (`ClockModel`).
//! - `onset` and `duration` are seconds on the host clock relative to the
//!   run's first sample (`StartTime` 0: the physio file starts the run).
//!   Without samples the reference is the run's first search onset and no
//!   physio file is written (a warning says so).
//! - `SamplingFrequency` is estimated from the median interval between
//!   consecutive tracker timestamps; the sidecar says so
//!   (`SamplingFrequencyEstimate`), with the nominal rate from
//!   `session.json` if known. If fewer than two samples have increasing
//!   timestamps the nominal rate is used, and without one the physio file
//!   is skipped with a warning.
//! - **One recording per eye** where the tracker measured each eye
//!   (`samples.tsv`'s per-eye columns): `recording-eye1` the left eye,
//!   `recording-eye2` the right (a monocular device: only its eye, as
//!   eye1), each with `pupil_size` where the tracker reported one (in the
//!   device's own units: the sidecar says gazecast does not know whether
//!   it is an area or a diameter). Otherwise (a mouse, the attention
//!   source, a session from before the per-eye columns) one recording of
//!   the combined gaze, `RecordedEye` `"cyclopean"`. Decided per run, by a
//!   first pass over the samples.
//! - **Physioevents** per recording: the session's `events.tsv`
//!   (fixations, saccades, blinks, lost track; detected on the combined
//!   gaze, so the same rows in each eye's file) and `markers.tsv` (as
//!   `message` rows), aborted trials' rows left out, sorted by onset.
//!   `onset` is on the physio file's `timestamp` clock (µs, host clock of
//!   the sitting; `OnsetSource` `"timestamp"`), `duration` in seconds.
//! - **Calibration fields** (`CalibrationCount`, `CalibrationType` `HV<n>`,
//!   `CalibrationPosition` and `CalibrationUnit` pixel,
//!   `AverageCalibrationError`, `MaximalCalibrationError`) from the
//!   sitting's `calibration-fields` markers: their count, and the last.
//!   A session without them (an earlier gazecast) has none of these.
//! - **Dataset metadata** ([`BidsMetadata`]: a design's `bids` block and
//!   `export-bids` flags): `Authors`, `License` and the other dataset
//!   fields in `dataset_description.json`; `TaskName`, `TaskDescription`,
//!   `Instructions`, `CogAtlasID`, `CogPOID` and the institution in every
//!   run's sidecars.
//! - Screen fields: REQUIRED in `_events.json` `StimulusPresentation` for
//!   `"gaze-on-screen"` recordings (in metres and pixels, origin top-left),
//!   repeated at the top level of the physio sidecar.
//! - Participant labels: the participant id with every non-alphanumeric
//!   character removed; an empty label, or two sessions with the same
//!   label, is an error.
//! - **Into an existing dataset** the export merges: the participants
//!   already there keep their rows and folders, an exported participant
//!   replaces its own row (never a second one) and the runs of its earlier
//!   export that this one does not write. A dataset it cannot merge into
//!   is refused before anything is written: not gazecast's, another
//!   design or BIDS version, other `participants.tsv` columns or
//!   `participants.json`, a `sub-*` folder without its row or a row
//!   without its folder, or a label that is another participant id's.
//!   Every file is written through a temporary file that is removed on
//!   any error (a full disk included).

use crate::analysis::{check_output_folder, OutputGuard};
pub use crate::design::BidsMetadata;
use crate::session::{
    self, read_tsv, visit_tsv, AtomicFile, CalibrationMarker, EventRow, MarkerRow, SampleRow,
    SessionFileError, SessionInfo, TrialRow, CALIBRATION_MARKER, EVENTS_TSV, MARKERS_TSV,
    SAMPLES_TSV, SESSION_JSON, TRIALS_TSV,
};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The BIDS version the export follows (eye-tracking entered the
/// specification in 1.11.0).
pub const BIDS_VERSION: &str = "1.11.1";

/// The warnings the official validator (bids-validator-deno) gives on an
/// export with its dataset metadata filled in, each as (code, the key it
/// names or `""` for any, the reason it stays): the one list the
/// validator test accepts (`tests/bids_validator.rs`) and the README
/// repeats. Every other warning, and any error, fails that test.
pub const VALIDATOR_ALLOWED_WARNINGS: &[(&str, &str, &str)] = &[
    (
        "JSON_KEY_RECOMMENDED",
        "HEDVersion",
        "the export uses no HED tags; HEDVersion is for datasets that do",
    ),
    (
        "JSON_KEY_RECOMMENDED",
        "SourceDatasets",
        "the source is gazecast session folders, not a dataset with a URL or DOI to cite",
    ),
    (
        "UNKNOWN_PUPIL_SIZE",
        "",
        "gazecast passes the tracker's pupil value on unchanged and does not know whether the device reports an area or a diameter",
    ),
];

/// What [`export_bids`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct BidsExport {
    /// Every file written.
    pub files: Vec<PathBuf>,
    /// The participant labels, in input order.
    pub labels: Vec<String>,
    /// Samples written per participant (same order).
    pub samples: Vec<usize>,
    /// Skipped lines, files not written and why.
    pub warnings: Vec<String>,
}

/// Why the export stopped; every variant about a file or folder names it.
#[derive(Debug, thiserror::Error)]
pub enum BidsError {
    /// No input folders.
    #[error("no session folders given")]
    NoInputs,
    /// The task label is not a BIDS label.
    #[error("task label {0:?} must be non-empty and only letters and digits")]
    BadTask(String),
    /// A session file is missing or corrupt.
    #[error(transparent)]
    File(#[from] SessionFileError),
    /// A participant id has no letters or digits.
    #[error("{}: participant {participant:?} has no letters or digits to make a BIDS label from", path.display())]
    BadLabel {
        /// The session.json.
        path: PathBuf,
        /// The id.
        participant: String,
    },
    /// Two sessions give the same label.
    #[error("{} and {} both give BIDS label sub-{label}", first.display(), second.display())]
    DuplicateLabel {
        /// The label.
        label: String,
        /// First folder.
        first: PathBuf,
        /// Second folder.
        second: PathBuf,
    },
    /// Two folders ran different designs.
    #[error("{} ran design {first_design:?} but {} ran {second_design:?}: export one design (task) at a time", first.display(), second.display())]
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
    /// The dataset metadata breaks a rule (`field` as in the design
    /// file's `bids` block).
    #[error("dataset metadata {field}: {message}")]
    Metadata {
        /// The field, e.g. `authors[1]`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The output folder is an input folder or inside one, or a file
    /// could not be written.
    #[error("{}: {message}", path.display())]
    Output {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        message: String,
    },
}

/// The BIDS label of a participant id: its ASCII letters and digits.
pub fn bids_label(participant: &str) -> Option<String> {
    let l: String = participant
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect();
    (!l.is_empty()).then_some(l)
}

fn out_err(path: &Path, e: impl std::fmt::Display) -> BidsError {
    BidsError::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn write_json(guard: &OutputGuard, path: &Path, v: &Value) -> Result<(), BidsError> {
    guard.check(path).map_err(|m| out_err(path, m))?;
    let mut text = serde_json::to_string_pretty(v).map_err(|e| out_err(path, e))?;
    text.push('\n');
    session::write_atomic(path, text.as_bytes()).map_err(|e| out_err(path, e))
}

fn write_text(guard: &OutputGuard, path: &Path, text: &str) -> Result<(), BidsError> {
    guard.check(path).map_err(|m| out_err(path, m))?;
    session::write_atomic(path, text.as_bytes()).map_err(|e| out_err(path, e))
}

/// A TSV field: no tabs or line breaks (replaced by spaces).
fn field(s: &str) -> String {
    s.replace(['\t', '\n', '\r'], " ")
}

/// The most sittings one session may have in an export.
pub const MAX_SITTINGS: usize = 1000;

/// Which gaze a recording holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Eye {
    /// The tracker's combined gaze (or the only one a source has).
    Cyclopean,
    /// The left eye.
    Left,
    /// The right eye.
    Right,
}

impl Eye {
    /// `RecordedEye`.
    fn name(self) -> &'static str {
        match self {
            Eye::Cyclopean => "cyclopean",
            Eye::Left => "left",
            Eye::Right => "right",
        }
    }

    /// The sample's x, y and pupil for this recording.
    fn values(self, s: &SampleRow) -> (Option<f64>, Option<f64>, Option<f64>) {
        match self {
            Eye::Cyclopean => (s.x_px, s.y_px, None),
            Eye::Left => (s.left_x_px, s.left_y_px, s.left_pupil),
            Eye::Right => (s.right_x_px, s.right_y_px, s.right_pupil),
        }
    }
}

/// What one sitting's samples hold per eye (a first pass over
/// `samples.tsv`): which eyes have any data, and which a pupil.
#[derive(Debug, Clone, Copy, Default)]
struct EyeScan {
    left: bool,
    right: bool,
    left_pupil: bool,
    right_pupil: bool,
}

impl EyeScan {
    fn add(&mut self, s: &SampleRow) {
        self.left |= s.left_x_px.is_some() || s.left_pupil.is_some();
        self.right |= s.right_x_px.is_some() || s.right_pupil.is_some();
        self.left_pupil |= s.left_pupil.is_some();
        self.right_pupil |= s.right_pupil.is_some();
    }

    /// The recordings of the run: one per eye with data (left first), or
    /// the combined gaze when no eye has its own; with a `pupil_size`
    /// column where the eye has one.
    fn recordings(self) -> Vec<(Eye, bool)> {
        let mut r = Vec::new();
        if self.left {
            r.push((Eye::Left, self.left_pupil));
        }
        if self.right {
            r.push((Eye::Right, self.right_pupil));
        }
        if r.is_empty() {
            r.push((Eye::Cyclopean, false));
        }
        r
    }
}

/// One recording (`recording-eyeN`) of a run while it is written.
struct Recording {
    eye: Eye,
    /// `eye1`, `eye2`.
    label: String,
    pupil: bool,
    path: PathBuf,
    gz: flate2::write::GzEncoder<AtomicFile>,
    valid: usize,
}

/// One run's physio files while they are written.
struct RunWriter {
    recordings: Vec<Recording>,
    first_us: Option<u64>,
    last_us: Option<u64>,
    last_device: Option<u64>,
    intervals: Vec<u64>,
    n: usize,
    line: String,
}

/// A run's calibration: how many calibrations the sitting had, and the
/// last one.
struct RunCalibration {
    count: usize,
    last: CalibrationMarker,
}

/// What a run's sidecars need from its session.
struct RunContext<'a> {
    info: &'a SessionInfo,
    meta: Option<&'a session::Sitting>,
    synthetic: bool,
    task: &'a str,
    guard: &'a OutputGuard,
    beh: &'a Path,
    stem: &'a str,
    samples_path: &'a Path,
    calibration: Option<&'a RunCalibration>,
    dataset: &'a BidsMetadata,
    export: &'a mut BidsExport,
}

/// A recording that was written: its label and eye.
struct Written {
    label: String,
    eye: Eye,
}

/// The physio files of `stem`'s recording `label`.
fn physio_name(stem: &str, label: &str, ext: &str) -> String {
    format!("{stem}_recording-{label}_physio.{ext}")
}

impl RunWriter {
    /// Opens one physio file per recording of `scan` (not committed
    /// until [`RunWriter::finish`]).
    fn new(
        beh: &Path,
        stem: &str,
        scan: EyeScan,
        guard: &OutputGuard,
    ) -> Result<Self, SessionFileError> {
        let mut recordings = Vec::new();
        for (k, (eye, pupil)) in scan.recordings().into_iter().enumerate() {
            let label = format!("eye{}", k + 1);
            let path = beh.join(physio_name(stem, &label, "tsv.gz"));
            guard.check(&path).map_err(|m| SessionFileError::Io {
                path: path.clone(),
                source: std::io::Error::other(m),
            })?;
            let file = AtomicFile::create(&path).map_err(|e| SessionFileError::Io {
                path: path.clone(),
                source: e,
            })?;
            recordings.push(Recording {
                eye,
                label,
                pupil,
                path,
                gz: flate2::write::GzEncoder::new(file, flate2::Compression::default()),
                valid: 0,
            });
        }
        Ok(Self {
            recordings,
            first_us: None,
            last_us: None,
            last_device: None,
            intervals: Vec::new(),
            n: 0,
            line: String::new(),
        })
    }

    /// One sample (timed, not aborted). Its mapped time must be later than
    /// the run's previous one: a file whose times go back is refused.
    fn write(&mut self, s: &SampleRow, line: u64, from: &Path) -> Result<(), SessionFileError> {
        if let Some(prev) = self.last_us {
            if s.mapped_us <= prev {
                return Err(SessionFileError::Parse {
                    path: from.to_path_buf(),
                    line,
                    column: Some("mapped_us".into()),
                    message: format!(
                        "{} is not later than the sitting's previous sample ({prev})",
                        s.mapped_us
                    ),
                });
            }
        }
        // The sampling interval from the tracker's own clock where it has
        // one (the mapped clock otherwise), within a clock segment.
        match (s.device_us, self.last_device, self.last_us) {
            (Some(d), Some(ld), _) if d > ld && s.time_order != "reset" => {
                self.intervals.push(d - ld)
            }
            (None, _, Some(prev)) => self.intervals.push(s.mapped_us - prev),
            _ => {}
        }
        self.first_us.get_or_insert(s.mapped_us);
        self.last_us = Some(s.mapped_us);
        self.last_device = s.device_us;
        self.n += 1;
        let value = |v: Option<f64>| match v {
            Some(x) if x.is_finite() => format!("{x}"),
            _ => "n/a".to_string(),
        };
        let device = s.device_us.map_or("n/a".into(), |d| d.to_string());
        for r in &mut self.recordings {
            let (x, y, pupil) = r.eye.values(s);
            let (x, y) = match (x, y) {
                (Some(x), Some(y)) if x.is_finite() && y.is_finite() => {
                    r.valid += 1;
                    (value(Some(x)), value(Some(y)))
                }
                _ => ("n/a".into(), "n/a".into()),
            };
            self.line.clear();
            self.line.push_str(&format!("{}\t{x}\t{y}\t", s.mapped_us));
            if r.pupil {
                self.line.push_str(&value(pupil));
                self.line.push('\t');
            }
            self.line.push_str(&format!("{device}\t{}\n", s.arrival_us));
            r.gz.write_all(self.line.as_bytes())
                .map_err(|e| SessionFileError::Io {
                    path: r.path.clone(),
                    source: e,
                })?;
        }
        Ok(())
    }

    /// Commits the physio files and writes their sidecars; the recordings
    /// written, none (and a warning) when no sampling rate is known.
    fn finish(mut self, c: &mut RunContext) -> Result<Vec<Written>, BidsError> {
        self.intervals.sort_unstable();
        let m = self.intervals.len();
        let median_us = (m > 0).then(|| {
            if m % 2 == 1 {
                self.intervals[m / 2] as f64
            } else {
                (self.intervals[m / 2 - 1] + self.intervals[m / 2]) as f64 / 2.0
            }
        });
        let info = c.info;
        let nominal = info.tracker_rate_hz.filter(|r| r.is_finite() && *r > 0.0);
        let (rate, rate_note) = match (median_us, nominal) {
            (Some(med), _) => (
                1e6 / med,
                format!(
                    "estimated from the median interval between consecutive tracker timestamps ({med} us over {m} intervals){}",
                    nominal.map(|r| format!("; nominal rate in session.json: {r} Hz")).unwrap_or_default()
                ),
            ),
            (None, Some(r)) => (
                r,
                "nominal rate from session.json (too few samples to estimate)".to_string(),
            ),
            (None, None) => {
                // AtomicFiles dropped uncommitted: nothing written.
                drop(self.recordings);
                c.export.warnings.push(format!(
                    "{}: cannot estimate the sampling frequency of {} (no increasing timestamps) and session.json has no tracker_rate_hz; no physio file",
                    c.samples_path.display(),
                    c.stem
                ));
                return Ok(Vec::new());
            }
        };
        let d = &info.display;
        let device_clock = c.meta.map_or(
            "not recorded (a session of an earlier gazecast)".to_string(),
            |m| m.device_clock.clone(),
        );
        let clock = c.meta.and_then(|m| m.clock.as_ref()).map(|k| {
            json!({
                "Description": "gazecast's clock model (tracker-hal timing) at the end of the sitting: timestamp = device_timestamp mapped onto the host clock.",
                "Rate": k.rate,
                "DriftPpm": k.drift_ppm,
                "OffsetUs": k.offset_us,
                "CausalityCorrections": k.corrections,
                "NonIncreasingTimestamps": k.non_increasing,
                "ClockResets": k.resets,
            })
        });
        let binocular = self.recordings.len() > 1;
        let mut written = Vec::new();
        for r in self.recordings {
            let file = r.gz.finish().map_err(|e| out_err(&r.path, e))?;
            file.commit().map_err(|e| out_err(&r.path, e))?;
            let (x_what, y_what) = match r.eye {
                Eye::Cyclopean => (
                    "Gaze position x-coordinate on the screen (the tracker's combined gaze: the point of regard the display followed), origin top-left, x to the right; n/a for an invalid sample (blink, lost track).",
                    "Gaze position y-coordinate on the screen (the tracker's combined gaze), origin top-left, y downwards; n/a for an invalid sample.",
                ),
                Eye::Left => (
                    "The left eye's gaze position x-coordinate on the screen, origin top-left, x to the right (its raw point through the session's calibration, fitted on the combined gaze); n/a where the tracker did not track this eye.",
                    "The left eye's gaze position y-coordinate on the screen, origin top-left, y downwards; n/a where the tracker did not track this eye.",
                ),
                Eye::Right => (
                    "The right eye's gaze position x-coordinate on the screen, origin top-left, x to the right (its raw point through the session's calibration, fitted on the combined gaze); n/a where the tracker did not track this eye.",
                    "The right eye's gaze position y-coordinate on the screen, origin top-left, y downwards; n/a where the tracker did not track this eye.",
                ),
            };
            let mut columns = vec!["timestamp", "x_coordinate", "y_coordinate"];
            if r.pupil {
                columns.push("pupil_size");
            }
            columns.extend(["device_timestamp", "arrival_timestamp"]);
            let mut sidecar = json!({
                "SamplingFrequency": rate,
                "SamplingFrequencyEstimate": rate_note,
                "StartTime": 0.0,
                "Columns": columns,
                "PhysioType": "eyetrack",
                "RecordedEye": r.eye.name(),
                "SampleCoordinateSystem": "gaze-on-screen",
                "Manufacturer": info.tracker,
                "SoftwareVersions": info.software,
                "ScreenSize": [d.width_mm / 1000.0, d.height_mm / 1000.0],
                "ScreenResolution": [d.width_px, d.height_px],
                "ScreenDistance": d.distance_mm / 1000.0,
                "ScreenOrigin": ["top", "left"],
                "timestamp": {
                    "Description": "The eye-tracker's timestamp of the sample (device_timestamp) mapped onto the host's monotonic clock by gazecast's clock model (rate fitted to the least-delayed arrivals, offset at the transport's minimum latency): the clock the events' onsets and the physioevents' onsets are on. Strictly increasing within the run; its intervals are the tracker's own.",
                    "Units": "us",
                    "Origin": "host monotonic clock of the sitting (this run)"
                },
                "x_coordinate": {
                    "LongName": "Gaze position (x)",
                    "Description": x_what,
                    "Units": "pixel"
                },
                "y_coordinate": {
                    "LongName": "Gaze position (y)",
                    "Description": y_what,
                    "Units": "pixel"
                },
                "device_timestamp": {
                    "Description": format!("The eye-tracker's own timestamp as decoded: {device_clock}. n/a where the tracker sends none."),
                    "Units": "us",
                    "Origin": "tracker clock"
                },
                "arrival_timestamp": {
                    "Description": "When the sample's bytes reached the host (delivery, not capture: it varies with the host's load; not used for timing).",
                    "Units": "us",
                    "Origin": "host monotonic clock of the sitting (this run)"
                },
                "SyntheticData": c.synthetic,
                "Notes": match (c.synthetic, binocular) {
                    (true, _) => "SYNTHETIC DATA: simulated participant, not human data.",
                    (false, true) => "Recorded data; one recording per eye (eye1 left, eye2 right).",
                    (false, false) => "Recorded data.",
                },
            });
            if let Some(obj) = sidecar.as_object_mut() {
                if r.pupil {
                    obj.insert(
                        "pupil_size".into(),
                        json!({
                            "Description": "Pupil size of this eye as the eye tracker reports it, in the tracker's own units (gazecast passes the device's value on unchanged and does not know which measure of the pupil the device reports); n/a where the tracker reports none.",
                            "Units": "n/a"
                        }),
                    );
                }
                if let Some(k) = c.calibration {
                    obj.insert("CalibrationCount".into(), json!(k.count));
                    obj.insert(
                        "CalibrationType".into(),
                        json!(format!("HV{}", k.last.targets)),
                    );
                    obj.insert("CalibrationPosition".into(), json!(k.last.positions_px));
                    obj.insert("CalibrationUnit".into(), json!("pixel"));
                    obj.insert("AverageCalibrationError".into(), json!(k.last.average_deg));
                    obj.insert("MaximalCalibrationError".into(), json!(k.last.maximal_deg));
                    obj.insert(
                        "CalibrationDescription".into(),
                        json!("The sitting's last calibration: HV<n> is a grid of n targets; CalibrationPosition lists the targets the fit used (screen pixels, origin top-left); the errors are the accuracies (degrees of visual angle) of its validation on the combined gaze: the mean over the validation points with data and the worst point."),
                    );
                }
                if let Some(clock) = clock.clone() {
                    obj.insert("ClockModel".into(), clock);
                }
                task_fields(obj, c.task, c.info, c.dataset);
            }
            let json_path = c.beh.join(physio_name(c.stem, &r.label, "json"));
            write_json(c.guard, &json_path, &sidecar)?;
            c.export.files.push(r.path.clone());
            c.export.files.push(json_path);
            if r.valid < self.n {
                c.export.warnings.push(format!(
                    "{}_recording-{} ({}): {} of {} samples invalid (n/a)",
                    c.stem,
                    r.label,
                    r.eye.name(),
                    self.n - r.valid,
                    self.n
                ));
            }
            written.push(Written {
                label: r.label,
                eye: r.eye,
            });
        }
        Ok(written)
    }
}

/// The task's fields shared by every sidecar of a run (events, physio,
/// physioevents): `TaskName`, `TaskDescription`, and the dataset
/// metadata's instructions, task ids and institution, where set.
fn task_fields(
    obj: &mut serde_json::Map<String, Value>,
    task: &str,
    info: &SessionInfo,
    dataset: &BidsMetadata,
) {
    obj.insert("TaskName".into(), json!(task));
    let description = dataset.task_description.clone().unwrap_or_else(|| {
        format!(
            "Visual search, design {:?}: find the target mesh in the search grid and press the response key.",
            info.design_name
        )
    });
    obj.insert("TaskDescription".into(), json!(description));
    for (key, value) in [
        ("Instructions", &dataset.instructions),
        ("CogAtlasID", &dataset.cog_atlas_id),
        ("CogPOID", &dataset.cog_po_id),
        ("InstitutionName", &dataset.institution_name),
        ("InstitutionAddress", &dataset.institution_address),
        (
            "InstitutionalDepartmentName",
            &dataset.institutional_department_name,
        ),
    ] {
        if let Some(v) = value {
            obj.insert(key.into(), json!(v));
        }
    }
}

/// One row of a `_physioevents.tsv.gz`.
struct PhysioEvent {
    /// On the physio file's `timestamp` clock (µs).
    onset_us: u64,
    duration_s: Option<f64>,
    trial_type: String,
    trial: Option<usize>,
    xy: Option<[f64; 4]>,
    message: Option<String>,
}

/// The columns of a `_physioevents.tsv.gz`, in order.
const PHYSIOEVENTS_COLUMNS: [&str; 9] = [
    "onset",
    "duration",
    "trial_type",
    "trial",
    "x_coordinate",
    "y_coordinate",
    "end_x_coordinate",
    "end_y_coordinate",
    "message",
];

/// Writes the physioevents of one recording: `events` (sorted by onset)
/// as `<stem>_recording-<label>_physioevents.tsv.gz` and its sidecar.
fn write_physioevents(
    c: &mut RunContext,
    w: &Written,
    events: &[PhysioEvent],
) -> Result<(), BidsError> {
    let path = c.beh.join(format!(
        "{}_recording-{}_physioevents.tsv.gz",
        c.stem, w.label
    ));
    c.guard.check(&path).map_err(|m| out_err(&path, m))?;
    let file = AtomicFile::create(&path).map_err(|e| out_err(&path, e))?;
    let mut gz = flate2::write::GzEncoder::new(file, flate2::Compression::default());
    let na = || "n/a".to_string();
    for e in events {
        let xy = |k: usize| e.xy.map_or_else(na, |v| format!("{}", v[k]));
        let line = format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\n",
            e.onset_us,
            e.duration_s.map_or_else(na, |d| format!("{d:.6}")),
            field(&e.trial_type),
            e.trial.map_or_else(na, |t| t.to_string()),
            xy(0),
            xy(1),
            xy(2),
            xy(3),
            e.message.as_deref().map_or_else(na, field),
        );
        gz.write_all(line.as_bytes())
            .map_err(|e| out_err(&path, e))?;
    }
    let file = gz.finish().map_err(|e| out_err(&path, e))?;
    file.commit().map_err(|e| out_err(&path, e))?;
    let mut sidecar = json!({
        "Columns": PHYSIOEVENTS_COLUMNS,
        "Description": format!(
            "Eye-movement events (fixations, saccades, blinks, lost track) and the runner's messages (markers.tsv) of this run. The events were detected by gazecast (I-VT on the tracker's clock, then the merge of congruent fixations) on the combined gaze of {}, not on this recording alone.",
            if w.eye == Eye::Cyclopean { "the tracker" } else { "both eyes" }
        ),
        "OnsetSource": "timestamp",
        "onset": {
            "Description": "Start of the event on the physio file's timestamp clock: the tracker's time mapped onto the host monotonic clock of the sitting (events: the event's first sample; messages: the host clock when the runner wrote the marker).",
            "Units": "us",
            "Origin": "host monotonic clock of the sitting (this run)"
        },
        "duration": {
            "Description": "From the event's first to its last sample (mapped times); n/a for a message.",
            "Units": "s"
        },
        "trial_type": {
            "Description": "What happened.",
            "Levels": {
                "fixation": "a fixation (x/y: its centroid)",
                "saccade": "a saccade (x/y: its start, end_x/end_y: its end)",
                "blink": "a blink (samples without gaze, short enough to be a blink)",
                "lost": "track lost (samples without gaze, too long for a blink)",
                "message": "a runner marker (message: its event and detail)"
            }
        },
        "trial": {"Description": "Trial index within the session, from 0; n/a outside trials."},
        "x_coordinate": {"Description": "Fixation: centroid x; saccade: start x; screen origin top-left; n/a for a blink, lost track or message.", "Units": "pixel"},
        "y_coordinate": {"Description": "Fixation: centroid y; saccade: start y; n/a as x_coordinate.", "Units": "pixel"},
        "end_x_coordinate": {"Description": "Fixation: as x_coordinate; saccade: end x.", "Units": "pixel"},
        "end_y_coordinate": {"Description": "Fixation: as y_coordinate; saccade: end y.", "Units": "pixel"},
        "message": {"Description": "For a message: the marker's event and detail as the runner wrote them (markers.tsv; times in a detail are on the host monotonic clock of the sitting, us); n/a for an eye-movement event."},
    });
    if let Some(obj) = sidecar.as_object_mut() {
        task_fields(obj, c.task, c.info, c.dataset);
    }
    let json_path = c.beh.join(format!(
        "{}_recording-{}_physioevents.json",
        c.stem, w.label
    ));
    write_json(c.guard, &json_path, &sidecar)?;
    c.export.files.push(path);
    c.export.files.push(json_path);
    Ok(())
}

/// Exports the session folders `dirs` as a BIDS dataset in `out` with task
/// label `task`. See the module documentation for the layout and choices.
/// The `method` column's levels describe full, hybrid and image; see
/// [`export_bids_described`] for the other methods a design may name.
pub fn export_bids(dirs: &[PathBuf], out: &Path, task: &str) -> Result<BidsExport, BidsError> {
    export_bids_described(dirs, out, task, &[])
}

/// [`export_bids`] with the `method` column's levels described for every
/// method in `methods` (name, one line of help: the renderer's list, e.g.
/// a registered method module), besides full, hybrid and image.
pub fn export_bids_described(
    dirs: &[PathBuf],
    out: &Path,
    task: &str,
    methods: &[(&str, &str)],
) -> Result<BidsExport, BidsError> {
    export_bids_with(dirs, out, task, methods, &BidsMetadata::default())
}

/// [`export_bids_described`] with the dataset metadata `dataset`
/// (authors, licence, instructions, institution: from the design file's
/// `bids` block and the command line) in `dataset_description.json` and
/// every run's sidecars.
pub fn export_bids_with(
    dirs: &[PathBuf],
    out: &Path,
    task: &str,
    methods: &[(&str, &str)],
    dataset: &BidsMetadata,
) -> Result<BidsExport, BidsError> {
    dataset
        .validate()
        .map_err(|(field, message)| BidsError::Metadata { field, message })?;
    if dirs.is_empty() {
        return Err(BidsError::NoInputs);
    }
    if task.is_empty() || !task.chars().all(|c| c.is_ascii_alphanumeric()) {
        return Err(BidsError::BadTask(task.into()));
    }
    let guard = check_output_folder(dirs, out).map_err(|(input, message)| BidsError::Output {
        path: out.to_path_buf(),
        message: format!("{message} ({})", input.display()),
    })?;
    // Read every session.json first: labels and designs are checked before
    // anything is written.
    let mut infos: Vec<(PathBuf, SessionInfo, String)> = Vec::new();
    for dir in dirs {
        let path = dir.join(SESSION_JSON);
        let info = SessionInfo::read(&path)?;
        let label = bids_label(&info.participant).ok_or_else(|| BidsError::BadLabel {
            path: path.clone(),
            participant: info.participant.clone(),
        })?;
        if let Some((first, _, _)) = infos.iter().find(|(_, _, l)| *l == label) {
            return Err(BidsError::DuplicateLabel {
                label,
                first: first.clone(),
                second: dir.clone(),
            });
        }
        if let Some((first, other, _)) = infos.first() {
            if other.design_name != info.design_name {
                return Err(BidsError::DesignMismatch {
                    first: first.clone(),
                    first_design: other.design_name.clone(),
                    second: dir.clone(),
                    second_design: info.design_name.clone(),
                });
            }
        }
        infos.push((dir.clone(), info, label));
    }
    // An existing dataset is merged into (or refused) before anything is
    // written: its participants stay, the exported ones are added or
    // replace their own rows.
    let design_name = infos[0].1.design_name.clone();
    let labels: Vec<&str> = infos.iter().map(|(_, _, l)| l.as_str()).collect();
    let existing = read_dataset(out, &design_name)?;
    check_merge(out, &existing, &infos, &labels)?;
    std::fs::create_dir_all(out).map_err(|e| out_err(out, e))?;
    let synthetic_any = infos.iter().any(|(_, i, _)| i.synthetic);
    let mut export = BidsExport {
        files: Vec::new(),
        labels: Vec::new(),
        samples: Vec::new(),
        warnings: Vec::new(),
    };
    let version = env!("CARGO_PKG_VERSION");

    let mut synthetic_trials_any = false;
    let mut participants_rows = Vec::new();
    for (dir, info, label) in &infos {
        let trials = read_tsv::<TrialRow>(&dir.join(TRIALS_TSV))?;
        export
            .warnings
            .extend(trials.warnings.iter().map(|w| w.to_string()));
        let synthetic = info.synthetic || trials.rows.iter().any(|t| t.synthetic);
        synthetic_trials_any |= synthetic;
        let beh = out.join(format!("sub-{label}")).join("beh");
        guard.check(&beh).map_err(|m| out_err(&beh, m))?;
        std::fs::create_dir_all(&beh).map_err(|e| out_err(&beh, e))?;
        let completed = session::completing_sittings(&trials.rows);

        // Samples → one physio.tsv.gz per sitting (a BIDS run) and eye,
        // streamed; a first pass finds which eyes each sitting has.
        let samples_path = dir.join(SAMPLES_TSV);
        let mut scans: BTreeMap<u32, EyeScan> = BTreeMap::new();
        visit_tsv::<SampleRow>(&samples_path, |s, _| {
            if !session::aborted(&completed, s.sitting, s.trial) && s.is_timed() {
                scans.entry(s.sitting).or_default().add(&s);
            }
            Ok(())
        })?;
        let mut runs: BTreeMap<u32, RunWriter> = BTreeMap::new();
        let mut aborted = 0usize;
        let mut untimed = 0usize;
        let warnings = visit_tsv::<SampleRow>(&samples_path, |s, line| {
            if session::aborted(&completed, s.sitting, s.trial) {
                aborted += 1;
                return Ok(());
            }
            if !s.is_timed() {
                untimed += 1;
                return Ok(());
            }
            if !runs.contains_key(&s.sitting) {
                if runs.len() >= MAX_SITTINGS {
                    return Err(SessionFileError::Parse {
                        path: samples_path.clone(),
                        line,
                        column: Some("sitting".into()),
                        message: format!("more than {MAX_SITTINGS} sittings"),
                    });
                }
                let stem = format!("sub-{label}_task-{task}_run-{}", s.sitting);
                let scan = scans.get(&s.sitting).copied().unwrap_or_default();
                runs.insert(s.sitting, RunWriter::new(&beh, &stem, scan, &guard)?);
            }
            let Some(run) = runs.get_mut(&s.sitting) else {
                return Ok(());
            };
            run.write(&s, line, &samples_path)
        })?;
        export
            .warnings
            .extend(warnings.iter().map(|w| w.to_string()));
        if aborted > 0 {
            export.warnings.push(format!(
                "sub-{label}: {aborted} samples of aborted trials (run again in a later sitting) left out"
            ));
        }
        if untimed > 0 {
            export.warnings.push(format!(
                "sub-{label}: {untimed} samples with a repeated or backwards tracker timestamp left out"
            ));
        }
        let (physio_events, calibrations) =
            read_physio_events(dir, &completed, &mut export.warnings)?;
        let mut sittings: Vec<u32> = runs.keys().copied().collect();
        sittings.extend(trials.rows.iter().map(|t| t.sitting));
        sittings.sort_unstable();
        sittings.dedup();
        let mut written = 0usize;
        for sitting in sittings {
            let stem = format!("sub-{label}_task-{task}_run-{sitting}");
            let meta = info.sittings.iter().find(|m| m.number == sitting);
            let run_trials: Vec<&TrialRow> = trials
                .rows
                .iter()
                .filter(|t| t.sitting == sitting)
                .collect();
            let first_sample = runs.get(&sitting).and_then(|r| r.first_us);
            let t0 = match first_sample {
                Some(t) => t,
                None => {
                    export.warnings.push(format!(
                        "{}: no samples in sitting {sitting}; no physio file for its run, event onsets are relative to its first search onset",
                        samples_path.display()
                    ));
                    run_trials
                        .iter()
                        .map(|t| t.search_onset_us)
                        .min()
                        .unwrap_or(0)
                }
            };
            if let Some(run) = runs.remove(&sitting) {
                written += run.n;
                let mut c = RunContext {
                    info,
                    meta,
                    synthetic,
                    task,
                    guard: &guard,
                    beh: &beh,
                    stem: &stem,
                    samples_path: &samples_path,
                    calibration: calibrations.get(&sitting),
                    dataset,
                    export: &mut export,
                };
                let recordings = run.finish(&mut c)?;
                let none = Vec::new();
                let events = physio_events.get(&sitting).unwrap_or(&none);
                // A run without events or messages (a session from before
                // events.tsv and markers.tsv) has no physioevents file.
                if !events.is_empty() {
                    for w in &recordings {
                        write_physioevents(&mut c, w, events)?;
                    }
                }
            }
            // Trials → events.tsv.
            let mut ev = String::from(
                "onset\tduration\ttrial_type\ttrial\trun\tmethod\tinset_deg\tsilhouette_edges\ttarget_row\ttarget_col\tresponse_time\tcorrect\tplan\tpractice\n",
            );
            for t in &run_trials {
                let onset = (t.search_onset_us as f64 - t0 as f64) / 1e6;
                let duration = t.response_us.saturating_sub(t.search_onset_us) as f64 / 1e6;
                ev.push_str(&format!(
                    "{onset:.6}\t{duration:.6}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\n",
                    field(&t.condition),
                    t.trial,
                    t.run,
                    field(&t.method),
                    t.inset_deg.map_or("n/a".into(), |d| format!("{d}")),
                    if t.silhouette_edges { 1 } else { 0 },
                    t.target_row,
                    t.target_col,
                    if t.rt_s.is_finite() {
                        format!("{}", t.rt_s)
                    } else {
                        "n/a".into()
                    },
                    match t.correct {
                        Some(true) => "1",
                        Some(false) => "0",
                        None => "n/a",
                    },
                    t.plan.as_deref().map_or("n/a".into(), field),
                    if t.practice { 1 } else { 0 },
                ));
            }
            let events_path = beh.join(format!("{stem}_events.tsv"));
            write_text(&guard, &events_path, &ev)?;
            export.files.push(events_path);
            let d = &info.display;
            let mut method_levels = json!({"full": "full-resolution ray casting (control)", "hybrid": "hybrid gaze-contingent rendering", "image": "image-based foveation: every pixel cast, then blurred by a Gaussian pyramid at the ray mask's level per pixel"});
            if let Some(levels) = method_levels.as_object_mut() {
                for (name, help) in methods {
                    levels
                        .entry(name.to_string())
                        .or_insert_with(|| json!(help));
                }
            }
            let mut events_json = json!({
                "StimulusPresentation": {
                    "ScreenDistance": d.distance_mm / 1000.0,
                    "ScreenOrigin": ["top", "left"],
                    "ScreenResolution": [d.width_px, d.height_px],
                    "ScreenSize": [d.width_mm / 1000.0, d.height_mm / 1000.0],
                    "SoftwareName": "gazecast",
                    "SoftwareVersion": info.software,
                },
                "onset": {"Description": "Search display onset, seconds since the run's first eye-tracking sample (the physio file's timestamp column: the tracker's time mapped onto the host clock; the onset itself is when the display's first frame was presented, host clock).", "Units": "s"},
                "duration": {"Description": "Search time: search display onset to the response key.", "Units": "s"},
                "trial_type": {"Description": "Condition (scene type) name from the design file."},
                "trial": {"Description": "Trial index within the session, from 0."},
                "run": {"Description": "Run (repetition of all conditions) of the design, from 0; the file's run- entity is the sitting instead."},
                "method": {"Description": "Rendering method (the condition's method in the design file; the plan column says what ran).", "Levels": method_levels},
                "inset_deg": {"Description": "Diameter of the full-resolution inset around the point of regard; n/a for the full method.", "Units": "deg"},
                "silhouette_edges": {"Description": "Whether silhouette edges were kept in the periphery.", "Levels": {"1": "edges kept", "0": "edges discarded"}},
                "target_row": {"Description": "Row of the target cell in the search grid, from 0."},
                "target_col": {"Description": "Column of the target cell in the search grid, from 0."},
                "response_time": {"Description": "Search time as recorded by the runner.", "Units": "s"},
                "correct": {"Description": "Whether the clicked cell was the target.", "Levels": {"1": "correct", "0": "incorrect", "n/a": "no click recorded"}},
                "plan": {"Description": "What rendered the search display: gazecast's provenance line of the trial's renderer (trials.tsv plan): the method that ran, the backend, and the passes in order with where each ran, e.g. \"image on gpu; passes: image-based foveation (gpu)\" or \"hybrid on cpu; passes: none\" (sessions recorded before gazecast gave each method one name say \"image-based\" and \"foveated\" for image and hybrid). Plans that changed during the search are joined by \" | \". n/a for a session recorded before gazecast wrote it."},
                "practice": {"Description": "Whether the trial was a practice trial (the design's practice block before the first run: shown like any trial, never analysed).", "Levels": {"1": "practice trial", "0": "experimental trial"}},
            });
            if let Some(obj) = events_json.as_object_mut() {
                task_fields(obj, task, info, dataset);
            }
            let events_json_path = beh.join(format!("{stem}_events.json"));
            write_json(&guard, &events_json_path, &events_json)?;
            export.files.push(events_json_path);
        }

        remove_stale_runs(&beh, label, task, &export.files)?;
        participants_rows.push(ParticipantRow {
            id: format!("sub-{label}"),
            participant: field(&info.participant),
            index: info.participant_index.to_string(),
            synthetic,
        });
        export.labels.push(label.clone());
        export.samples.push(written);
    }
    // The dataset's rows: the existing ones in their order, each exported
    // participant replacing its own row or appended.
    let mut rows = existing.rows;
    for r in participants_rows {
        match rows.iter_mut().find(|e| e.id == r.id) {
            Some(e) => *e = r,
            None => rows.push(r),
        }
    }
    let synthetic = synthetic_any || synthetic_trials_any || rows.iter().any(|r| r.synthetic);

    let participants_path = out.join(PARTICIPANTS_TSV);
    let mut p = PARTICIPANTS_COLUMNS.join("\t");
    p.push('\n');
    for r in &rows {
        p.push_str(&format!(
            "{}\t{}\t{}\t{}\n",
            r.id, r.participant, r.index, r.synthetic
        ));
    }
    write_text(&guard, &participants_path, &p)?;
    export.files.push(participants_path);
    let pj = out.join(PARTICIPANTS_JSON);
    write_json(&guard, &pj, &participants_json())?;
    export.files.push(pj);

    let name = if synthetic {
        format!("{SYNTHETIC_NAME}{design_name}{NAME_SUFFIX}")
    } else {
        format!("{design_name}{NAME_SUFFIX}")
    };
    let dd = out.join(DATASET_DESCRIPTION);
    let mut description = json!({
            "Name": name,
            "BIDSVersion": BIDS_VERSION,
            "DatasetType": "raw",
            "GeneratedBy": [{
                "Name": "gazecast",
                "Version": version,
                "Description": if synthetic {
                    "Exported from gazecast session folders. Contains SYNTHETIC data from simulated participants: not human data."
                } else {
                    "Exported from gazecast session folders."
                },
            }],
    });
    if let Some(obj) = description.as_object_mut() {
        let lists = [
            ("Authors", &dataset.authors),
            ("Funding", &dataset.funding),
            ("EthicsApprovals", &dataset.ethics_approvals),
            ("ReferencesAndLinks", &dataset.references_and_links),
        ];
        for (key, values) in lists {
            if !values.is_empty() {
                obj.insert(key.into(), json!(values));
            }
        }
        let texts = [
            ("License", &dataset.license),
            ("Acknowledgements", &dataset.acknowledgements),
            ("HowToAcknowledge", &dataset.how_to_acknowledge),
            ("DatasetDOI", &dataset.dataset_doi),
        ];
        for (key, value) in texts {
            if let Some(v) = value {
                obj.insert(key.into(), json!(v));
            }
        }
    }
    write_json(&guard, &dd, &description)?;
    export.files.push(dd);
    let readme = out.join("README.md");
    let mut text = String::new();
    if synthetic {
        text.push_str("**SYNTHETIC DATA: simulated participants, not human data.**\n\n");
    }
    text.push_str(&format!(
        "# {design_name}\n\nVisual search with gaze-contingent rendering (gazecast), exported to BIDS {BIDS_VERSION}.\n\n\
Per participant, `beh/` holds one run per sitting (a session resumed later has several): the eye-tracking recordings \
(`_run-N_recording-eyeK_physio.tsv.gz`, PhysioType eyetrack: one per eye where the tracker measured each eye (eye1 left, eye2 right; RecordedEye in the sidecar), \
else one of the combined gaze (cyclopean); columns timestamp (the tracker's timestamp mapped onto the host clock of the sitting, us), \
x_coordinate and y_coordinate (screen pixels, origin top-left, n/a for invalid samples), pupil_size where the tracker reports it (its own units), \
device_timestamp (the tracker's own clock, us), arrival_timestamp (host arrival, us)), their eye-movement events and the runner's messages \
(`_run-N_recording-eyeK_physioevents.tsv.gz`: onsets on the timestamp clock, us) and one event per search trial \
(`_run-N_events.tsv`: onset and duration in s since the run's first sample).\n"
    ));
    write_text(&guard, &readme, &text)?;
    export.files.push(readme);
    Ok(export)
}

/// `participants.tsv`.
pub const PARTICIPANTS_TSV: &str = "participants.tsv";
/// `participants.json`.
pub const PARTICIPANTS_JSON: &str = "participants.json";
/// `dataset_description.json`.
pub const DATASET_DESCRIPTION: &str = "dataset_description.json";
/// The columns of `participants.tsv`, in order.
pub const PARTICIPANTS_COLUMNS: [&str; 4] = [
    "participant_id",
    "participant",
    "participant_index",
    "synthetic",
];
const SYNTHETIC_NAME: &str = "SYNTHETIC DATA (simulated participants): ";
const NAME_SUFFIX: &str = " visual search with eye tracking";

fn participants_json() -> Value {
    json!({
        "participant": {"Description": "Participant id as recorded in session.json."},
        "participant_index": {"Description": "Participant index (counterbalancing row)."},
        "synthetic": {"Description": "Whether the participant was simulated.", "Levels": {"true": "simulated participant (not human data)", "false": "human participant"}},
    })
}

/// One row of `participants.tsv`.
#[derive(Debug, Clone, PartialEq)]
struct ParticipantRow {
    /// `sub-<label>`.
    id: String,
    participant: String,
    index: String,
    synthetic: bool,
}

/// The dataset already in the output folder (empty when there is none).
#[derive(Debug, Default)]
struct Dataset {
    rows: Vec<ParticipantRow>,
    /// The `sub-*` folders there.
    folders: Vec<String>,
}

fn refuse(path: &Path, message: String) -> BidsError {
    BidsError::Output {
        path: path.to_path_buf(),
        message: format!("{message}; cannot merge this export into it (export into a new folder)"),
    }
}

/// Reads the dataset in `out`, if any, and checks that this export can
/// merge into it: a gazecast export of design `design_name` in this BIDS
/// version whose `participants.tsv` has this export's columns and whose
/// `participants.json` describes them.
fn read_dataset(out: &Path, design_name: &str) -> Result<Dataset, BidsError> {
    let mut folders = Vec::new();
    match std::fs::read_dir(out) {
        Ok(entries) => {
            for e in entries {
                let e = e.map_err(|e| out_err(out, e))?;
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with("sub-") && e.path().is_dir() {
                    folders.push(name);
                }
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Dataset::default()),
        Err(e) => return Err(out_err(out, e)),
    }
    folders.sort();
    let dd = out.join(DATASET_DESCRIPTION);
    let pt = out.join(PARTICIPANTS_TSV);
    let pj = out.join(PARTICIPANTS_JSON);
    if !dd.exists() && !pt.exists() && !pj.exists() {
        // No dataset yet (or one whose first export failed part-way: its
        // folders must be exported again, [`check_merge`]).
        return Ok(Dataset {
            rows: Vec::new(),
            folders,
        });
    }
    // dataset_description.json: gazecast's, same design, same BIDS version.
    let text = input_file::read_to_string(&dd, input_file::SESSION_TABLE)
        .map_err(|e| refuse(&dd, e.to_string()))?;
    let v: Value = serde_json::from_str(&text).map_err(|e| refuse(&dd, e.to_string()))?;
    let generated = v
        .get("GeneratedBy")
        .and_then(|g| g.get(0))
        .and_then(|g| g.get("Name"))
        .and_then(Value::as_str);
    if generated != Some("gazecast") {
        return Err(refuse(
            &dd,
            format!("GeneratedBy {generated:?}: the dataset was not written by gazecast"),
        ));
    }
    let version = v.get("BIDSVersion").and_then(Value::as_str);
    if version != Some(BIDS_VERSION) {
        return Err(refuse(
            &dd,
            format!("BIDSVersion {version:?}, this export writes {BIDS_VERSION:?}"),
        ));
    }
    let name = v.get("Name").and_then(Value::as_str).unwrap_or("");
    let theirs = name
        .strip_prefix(SYNTHETIC_NAME)
        .unwrap_or(name)
        .strip_suffix(NAME_SUFFIX);
    if theirs != Some(design_name) {
        return Err(refuse(
            &dd,
            format!("the dataset is {name:?}, not an export of design {design_name:?}"),
        ));
    }
    // participants.json: the columns this export describes.
    let text = input_file::read_to_string(&pj, input_file::SESSION_TABLE)
        .map_err(|e| refuse(&pj, e.to_string()))?;
    let v: Value = serde_json::from_str(&text).map_err(|e| refuse(&pj, e.to_string()))?;
    if v != participants_json() {
        return Err(refuse(
            &pj,
            "it describes other columns than this export's (participant, participant_index, synthetic)".into(),
        ));
    }
    // participants.tsv: these columns, one row per participant.
    let text = input_file::read_to_string(&pt, input_file::SESSION_TABLE)
        .map_err(|e| refuse(&pt, e.to_string()))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    if header.split('\t').collect::<Vec<_>>() != PARTICIPANTS_COLUMNS {
        return Err(refuse(
            &pt,
            format!(
                "line 1: columns {:?}, this export writes {:?}",
                header.split('\t').collect::<Vec<_>>(),
                PARTICIPANTS_COLUMNS
            ),
        ));
    }
    let mut rows: Vec<ParticipantRow> = Vec::new();
    for (k, line) in lines.enumerate() {
        let at = |m: String| refuse(&pt, format!("line {}: {m}", k + 2));
        let cells: Vec<&str> = line.split('\t').collect();
        let [id, participant, index, synthetic] = cells[..] else {
            return Err(at(format!(
                "{} cells, expected {}",
                cells.len(),
                PARTICIPANTS_COLUMNS.len()
            )));
        };
        let label_ok = id
            .strip_prefix("sub-")
            .is_some_and(|l| !l.is_empty() && l.chars().all(|c| c.is_ascii_alphanumeric()));
        if !label_ok {
            return Err(at(format!("participant_id {id:?} is not sub-<label>")));
        }
        let synthetic = match synthetic {
            "true" => true,
            "false" => false,
            other => return Err(at(format!("synthetic {other:?} is not true or false"))),
        };
        if rows.iter().any(|r| r.id == id) {
            return Err(at(format!("{id} appears twice")));
        }
        rows.push(ParticipantRow {
            id: id.to_string(),
            participant: participant.to_string(),
            index: index.to_string(),
            synthetic,
        });
    }
    Ok(Dataset { rows, folders })
}

/// The merge keeps the dataset consistent: every `sub-*` folder has its
/// row and every row its folder once this export is in, and an exported
/// label that is already there belongs to the same participant id.
fn check_merge(
    out: &Path,
    existing: &Dataset,
    infos: &[(PathBuf, SessionInfo, String)],
    labels: &[&str],
) -> Result<(), BidsError> {
    let pt = out.join(PARTICIPANTS_TSV);
    let exported = |id: &str| labels.iter().any(|l| id == format!("sub-{l}"));
    for f in &existing.folders {
        if !exported(f) && !existing.rows.iter().any(|r| &r.id == f) {
            return Err(refuse(
                &pt,
                format!("{f} has no row (export its session folder together with these to repair the dataset)"),
            ));
        }
    }
    for r in &existing.rows {
        if !exported(&r.id) && !existing.folders.contains(&r.id) {
            return Err(refuse(
                &pt,
                format!("{} is listed but its folder is missing", r.id),
            ));
        }
    }
    for (dir, info, label) in infos {
        let id = format!("sub-{label}");
        if let Some(r) = existing.rows.iter().find(|r| r.id == id) {
            if r.participant != field(&info.participant) {
                return Err(refuse(
                    &pt,
                    format!(
                        "{id} is participant {:?} there, but {} is participant {:?}",
                        r.participant,
                        dir.display(),
                        info.participant
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Removes the files an earlier export of this participant and task wrote
/// in `beh` that this one did not (a run that has no file now): only
/// names of the export's own scheme, `sub-<label>_task-<task>_run-<n>_…`.
fn remove_stale_runs(
    beh: &Path,
    label: &str,
    task: &str,
    written: &[PathBuf],
) -> Result<(), BidsError> {
    let prefix = format!("sub-{label}_task-{task}_run-");
    let entries = std::fs::read_dir(beh).map_err(|e| out_err(beh, e))?;
    for e in entries {
        let e = e.map_err(|e| out_err(beh, e))?;
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(&prefix) else {
            continue;
        };
        let (run, suffix) = rest.split_once('_').unwrap_or((rest, ""));
        let ours = !run.is_empty()
            && run.chars().all(|c| c.is_ascii_digit())
            && (["events.tsv", "events.json"].contains(&suffix)
                || ["eye1", "eye2"].iter().any(|eye| {
                    suffix
                        .strip_prefix("recording-")
                        .and_then(|r| r.strip_prefix(eye))
                        .is_some_and(|r| {
                            [
                                "_physio.tsv.gz",
                                "_physio.json",
                                "_physioevents.tsv.gz",
                                "_physioevents.json",
                            ]
                            .contains(&r)
                        })
                }));
        let path = e.path();
        if ours && !written.contains(&path) {
            std::fs::remove_file(&path).map_err(|e| out_err(&path, e))?;
        }
    }
    Ok(())
}

/// A session's physioevents per sitting (its `events.tsv` and
/// `markers.tsv`, rows of aborted trials left out, sorted by onset) and
/// each sitting's calibrations (its `calibration-fields` markers). A
/// missing file gives none, with a warning; a marker whose detail is not
/// a calibration's is an error naming the file and line.
#[allow(clippy::type_complexity)]
fn read_physio_events(
    dir: &Path,
    completed: &std::collections::HashMap<usize, u32>,
    warnings: &mut Vec<String>,
) -> Result<
    (
        BTreeMap<u32, Vec<PhysioEvent>>,
        BTreeMap<u32, RunCalibration>,
    ),
    BidsError,
> {
    let mut events: BTreeMap<u32, Vec<PhysioEvent>> = BTreeMap::new();
    let mut calibrations: BTreeMap<u32, RunCalibration> = BTreeMap::new();
    let path = dir.join(EVENTS_TSV);
    if path.exists() {
        let read = read_tsv::<EventRow>(&path)?;
        warnings.extend(read.warnings.iter().map(|w| w.to_string()));
        for e in read.rows {
            if session::aborted(completed, e.sitting, e.trial) {
                continue;
            }
            let xy = [e.x_px, e.y_px, e.end_x_px, e.end_y_px];
            events.entry(e.sitting).or_default().push(PhysioEvent {
                onset_us: e.onset_us,
                duration_s: Some(e.end_us.saturating_sub(e.onset_us) as f64 / 1e6),
                xy: (matches!(e.kind.as_str(), "fixation" | "saccade")
                    && xy.iter().all(|v| v.is_finite()))
                .then_some(xy),
                trial_type: e.kind,
                trial: e.trial,
                message: None,
            });
        }
    } else {
        warnings.push(format!(
            "{}: not found; the physioevents hold no eye-movement events",
            path.display()
        ));
    }
    let path = dir.join(MARKERS_TSV);
    if path.exists() {
        let read = read_tsv::<MarkerRow>(&path)?;
        warnings.extend(read.warnings.iter().map(|w| w.to_string()));
        for (m, line) in read.rows.into_iter().zip(read.lines) {
            if m.event == CALIBRATION_MARKER {
                let last = CalibrationMarker::from_detail(&m.detail).map_err(|message| {
                    SessionFileError::Parse {
                        path: path.clone(),
                        line,
                        column: Some("detail".into()),
                        message: format!("not a calibration's fields: {message}"),
                    }
                })?;
                let k = calibrations.entry(m.sitting).or_insert(RunCalibration {
                    count: 0,
                    last: last.clone(),
                });
                k.count += 1;
                k.last = last;
            }
            if session::aborted(completed, m.sitting, m.trial) {
                continue;
            }
            let message = if m.detail.is_empty() {
                m.event.clone()
            } else {
                format!("{}: {}", m.event, m.detail)
            };
            events.entry(m.sitting).or_default().push(PhysioEvent {
                onset_us: m.host_us,
                duration_s: None,
                trial_type: "message".into(),
                trial: m.trial,
                xy: None,
                message: Some(message),
            });
        }
    } else {
        warnings.push(format!(
            "{}: not found; the physioevents hold no messages and the sidecars no calibration",
            path.display()
        ));
    }
    for list in events.values_mut() {
        list.sort_by_key(|e| e.onset_us);
    }
    Ok((events, calibrations))
}
