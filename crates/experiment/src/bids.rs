//! BIDS export of session folders: eye-tracking as BIDS physiological
//! recordings (`PhysioType` `"eyetrack"`, BEP020, part of BIDS since
//! 1.11.0) plus the trials as task events.
//!
//! ```text
//! OUT/
//!   dataset_description.json   Name, BIDSVersion, DatasetType, GeneratedBy
//!   README.md                  what the dataset is (and that it is synthetic, if so)
//!   participants.tsv / .json   participant_id, participant, participant_index, synthetic
//!   sub-<label>/beh/
//!     sub-<label>_task-<task>_recording-eye1_physio.tsv.gz   no header:
//!         timestamp  x_coordinate  y_coordinate  host_timestamp
//!     sub-<label>_task-<task>_recording-eye1_physio.json     the sidecar
//!     sub-<label>_task-<task>_events.tsv                     one row per trial
//!     sub-<label>_task-<task>_events.json                    columns + StimulusPresentation
//! ```
//!
//! Choices (the specification leaves them to the exporter):
//!
//! - `timestamp` is the tracker's own clock (`samples.tsv` `sample_us`,
//!   µs), as the specification defines it; the extra column
//!   `host_timestamp` (`host_us`) is the host clock, on which the events'
//!   onsets are measured, so the two can be aligned.
//! - `onset` and `duration` are seconds on the host clock relative to the
//!   first sample (`StartTime` 0: the physio file starts the recording).
//!   Without samples the reference is the first trial's search onset and
//!   no physio file is written (a warning says so).
//! - `SamplingFrequency` is estimated from the median interval between
//!   consecutive tracker timestamps; the sidecar says so
//!   (`SamplingFrequencyEstimate`), with the nominal rate from
//!   `session.json` if known. If fewer than two samples have increasing
//!   timestamps the nominal rate is used, and without one the physio file
//!   is skipped with a warning.
//! - `RecordedEye` is `"cyclopean"`: the session files do not record which
//!   eye, and the runner uses the tracker's combined (binocular average)
//!   gaze.
//! - Screen fields: REQUIRED in `_events.json` `StimulusPresentation` for
//!   `"gaze-on-screen"` recordings (in metres and pixels, origin top-left),
//!   repeated at the top level of the physio sidecar.
//! - Participant labels: the participant id with every non-alphanumeric
//!   character removed; an empty label, or two sessions with the same
//!   label, is an error.

use crate::analysis::{check_output_folder, OutputGuard};
use crate::session::{
    self, read_tsv, visit_tsv, AtomicFile, SampleRow, SessionFileError, SessionInfo, TrialRow,
    SAMPLES_TSV, SESSION_JSON, TRIALS_TSV,
};
use serde_json::{json, Value};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The BIDS version the export follows (eye-tracking entered the
/// specification in 1.11.0).
pub const BIDS_VERSION: &str = "1.11.1";

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

/// Exports the session folders `dirs` as a BIDS dataset in `out` with task
/// label `task`. See the module documentation for the layout and choices.
pub fn export_bids(dirs: &[PathBuf], out: &Path, task: &str) -> Result<BidsExport, BidsError> {
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
    std::fs::create_dir_all(out).map_err(|e| out_err(out, e))?;
    let synthetic_any = infos.iter().any(|(_, i, _)| i.synthetic);
    let mut export = BidsExport {
        files: Vec::new(),
        labels: Vec::new(),
        samples: Vec::new(),
        warnings: Vec::new(),
    };
    let design_name = infos[0].1.design_name.clone();
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
        let stem = format!("sub-{label}_task-{task}");

        // Samples → physio.tsv.gz, streamed.
        let samples_path = dir.join(SAMPLES_TSV);
        let gz_path = beh.join(format!("{stem}_recording-eye1_physio.tsv.gz"));
        guard.check(&gz_path).map_err(|m| out_err(&gz_path, m))?;
        let file = AtomicFile::create(&gz_path).map_err(|e| out_err(&gz_path, e))?;
        let mut gz = flate2::write::GzEncoder::new(file, flate2::Compression::default());
        let mut first_host: Option<u64> = None;
        let mut last_sample: Option<u64> = None;
        let mut intervals: Vec<u64> = Vec::new();
        let mut n = 0usize;
        let mut valid = 0usize;
        let mut line = String::new();
        let warnings = visit_tsv::<SampleRow>(&samples_path, |s, _| {
            first_host = Some(first_host.map_or(s.host_us, |f| f.min(s.host_us)));
            if let Some(prev) = last_sample {
                if s.sample_us > prev {
                    intervals.push(s.sample_us - prev);
                }
            }
            last_sample = Some(s.sample_us);
            line.clear();
            let coord = |v: Option<f64>| match v {
                Some(x) if x.is_finite() => format!("{x}"),
                _ => "n/a".to_string(),
            };
            let (x, y) = match (s.x_px, s.y_px) {
                (Some(x), Some(y)) if x.is_finite() && y.is_finite() => {
                    valid += 1;
                    (coord(Some(x)), coord(Some(y)))
                }
                _ => ("n/a".into(), "n/a".into()),
            };
            line.push_str(&format!("{}\t{x}\t{y}\t{}\n", s.sample_us, s.host_us));
            n += 1;
            gz.write_all(line.as_bytes())
                .map_err(|e| SessionFileError::Io {
                    path: gz_path.clone(),
                    source: e,
                })
        })?;
        export
            .warnings
            .extend(warnings.iter().map(|w| w.to_string()));
        intervals.sort_unstable();
        let median_us = (!intervals.is_empty()).then(|| {
            let m = intervals.len();
            if m % 2 == 1 {
                intervals[m / 2] as f64
            } else {
                (intervals[m / 2 - 1] + intervals[m / 2]) as f64 / 2.0
            }
        });
        let nominal = info.tracker_rate_hz.filter(|r| r.is_finite() && *r > 0.0);
        let (rate, rate_note) = match (median_us, nominal) {
            (Some(m), _) => (
                Some(1e6 / m),
                format!(
                    "estimated from the median interval between consecutive tracker timestamps ({m} us over {} intervals){}",
                    intervals.len(),
                    nominal.map(|r| format!("; nominal rate in session.json: {r} Hz")).unwrap_or_default()
                ),
            ),
            (None, Some(r)) => (
                Some(r),
                "nominal rate from session.json (too few samples to estimate)".to_string(),
            ),
            (None, None) => (None, String::new()),
        };
        let t0 = match first_host {
            Some(t) => t,
            None => {
                let t = trials
                    .rows
                    .iter()
                    .map(|t| t.search_onset_us)
                    .min()
                    .unwrap_or(0);
                export.warnings.push(format!(
                    "{}: no samples; no physio file for sub-{label}, event onsets are relative to the first search onset",
                    samples_path.display()
                ));
                t
            }
        };
        match (first_host, rate) {
            (Some(_), Some(rate)) => {
                let file = gz.finish().map_err(|e| out_err(&gz_path, e))?;
                file.commit().map_err(|e| out_err(&gz_path, e))?;
                export.files.push(gz_path.clone());
                let d = &info.display;
                let sidecar = json!({
                    "SamplingFrequency": rate,
                    "SamplingFrequencyEstimate": rate_note,
                    "StartTime": 0.0,
                    "Columns": ["timestamp", "x_coordinate", "y_coordinate", "host_timestamp"],
                    "PhysioType": "eyetrack",
                    "RecordedEye": "cyclopean",
                    "SampleCoordinateSystem": "gaze-on-screen",
                    "Manufacturer": info.tracker,
                    "SoftwareVersions": info.software,
                    "ScreenSize": [d.width_mm / 1000.0, d.height_mm / 1000.0],
                    "ScreenResolution": [d.width_px, d.height_px],
                    "ScreenDistance": d.distance_mm / 1000.0,
                    "ScreenOrigin": ["top", "left"],
                    "timestamp": {
                        "Description": "Timestamp issued by the eye-tracker (its own clock).",
                        "Units": "us",
                        "Origin": "tracker clock"
                    },
                    "x_coordinate": {
                        "LongName": "Gaze position (x)",
                        "Description": "Gaze position x-coordinate on the screen (the tracker's combined gaze), origin top-left, x to the right; n/a for an invalid sample (blink, lost track).",
                        "Units": "pixel"
                    },
                    "y_coordinate": {
                        "LongName": "Gaze position (y)",
                        "Description": "Gaze position y-coordinate on the screen, origin top-left, y downwards; n/a for an invalid sample.",
                        "Units": "pixel"
                    },
                    "host_timestamp": {
                        "Description": "Host clock when the sample arrived; the events' onsets are seconds on this clock since the first sample.",
                        "Units": "us",
                        "Origin": "host clock"
                    },
                    "SyntheticData": synthetic,
                    "Notes": if synthetic {
                        "SYNTHETIC DATA: simulated participant, not human data."
                    } else {
                        "Recorded data."
                    },
                });
                let json_path = beh.join(format!("{stem}_recording-eye1_physio.json"));
                write_json(&guard, &json_path, &sidecar)?;
                export.files.push(json_path);
                if valid < n {
                    export.warnings.push(format!(
                        "sub-{label}: {} of {n} samples invalid (n/a)",
                        n - valid
                    ));
                }
            }
            (Some(_), None) => {
                drop(gz); // AtomicFile dropped uncommitted: nothing written.
                export.warnings.push(format!(
                    "{}: cannot estimate the sampling frequency (no increasing timestamps) and session.json has no tracker_rate_hz; no physio file for sub-{label}",
                    samples_path.display()
                ));
            }
            (None, _) => drop(gz),
        }

        // Trials → events.tsv.
        let mut ev = String::from(
            "onset\tduration\ttrial_type\ttrial\trun\tmethod\tinset_deg\tsilhouette_edges\ttarget_row\ttarget_col\tresponse_time\tcorrect\n",
        );
        for t in &trials.rows {
            let onset = (t.search_onset_us as f64 - t0 as f64) / 1e6;
            let duration = t.response_us.saturating_sub(t.search_onset_us) as f64 / 1e6;
            ev.push_str(&format!(
                "{onset:.6}\t{duration:.6}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\n",
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
            ));
        }
        let events_path = beh.join(format!("{stem}_events.tsv"));
        write_text(&guard, &events_path, &ev)?;
        export.files.push(events_path);
        let d = &info.display;
        let events_json = json!({
            "TaskName": task,
            "TaskDescription": format!("Visual search, design {:?}: find the target mesh in the search grid and press the response key.", info.design_name),
            "StimulusPresentation": {
                "ScreenDistance": d.distance_mm / 1000.0,
                "ScreenOrigin": ["top", "left"],
                "ScreenResolution": [d.width_px, d.height_px],
                "ScreenSize": [d.width_mm / 1000.0, d.height_mm / 1000.0],
                "SoftwareName": "gazecast",
                "SoftwareVersion": info.software,
            },
            "onset": {"Description": "Search display onset, seconds since the first eye-tracking sample (host clock).", "Units": "s"},
            "duration": {"Description": "Search time: search display onset to the response key.", "Units": "s"},
            "trial_type": {"Description": "Condition (scene type) name from the design file."},
            "trial": {"Description": "Trial index within the session, from 0."},
            "run": {"Description": "Run (repetition of all conditions), from 0."},
            "method": {"Description": "Rendering method.", "Levels": {"full": "full-resolution ray casting (control)", "hybrid": "hybrid gaze-contingent rendering"}},
            "inset_deg": {"Description": "Diameter of the full-resolution inset around the point of regard; n/a for the full method.", "Units": "deg"},
            "silhouette_edges": {"Description": "Whether silhouette edges were kept in the periphery.", "Levels": {"1": "edges kept", "0": "edges discarded"}},
            "target_row": {"Description": "Row of the target cell in the search grid, from 0."},
            "target_col": {"Description": "Column of the target cell in the search grid, from 0."},
            "response_time": {"Description": "Search time as recorded by the runner.", "Units": "s"},
            "correct": {"Description": "Whether the clicked cell was the target.", "Levels": {"1": "correct", "0": "incorrect", "n/a": "no click recorded"}},
        });
        let events_json_path = beh.join(format!("{stem}_events.json"));
        write_json(&guard, &events_json_path, &events_json)?;
        export.files.push(events_json_path);

        participants_rows.push(format!(
            "sub-{label}\t{}\t{}\t{}\n",
            field(&info.participant),
            info.participant_index,
            synthetic
        ));
        export.labels.push(label.clone());
        export
            .samples
            .push(if first_host.is_some() { n } else { 0 });
    }
    let synthetic = synthetic_any || synthetic_trials_any;

    let participants_path = out.join("participants.tsv");
    let mut p = String::from("participant_id\tparticipant\tparticipant_index\tsynthetic\n");
    for r in &participants_rows {
        p.push_str(r);
    }
    write_text(&guard, &participants_path, &p)?;
    export.files.push(participants_path);
    let pj = out.join("participants.json");
    write_json(
        &guard,
        &pj,
        &json!({
            "participant": {"Description": "Participant id as recorded in session.json."},
            "participant_index": {"Description": "Participant index (counterbalancing row)."},
            "synthetic": {"Description": "Whether the participant was simulated.", "Levels": {"true": "simulated participant (not human data)", "false": "human participant"}},
        }),
    )?;
    export.files.push(pj);

    let name = if synthetic {
        format!("SYNTHETIC DATA (simulated participants): {design_name} visual search with eye tracking")
    } else {
        format!("{design_name} visual search with eye tracking")
    };
    let dd = out.join("dataset_description.json");
    write_json(
        &guard,
        &dd,
        &json!({
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
        }),
    )?;
    export.files.push(dd);
    let readme = out.join("README.md");
    let mut text = String::new();
    if synthetic {
        text.push_str("**SYNTHETIC DATA: simulated participants, not human data.**\n\n");
    }
    text.push_str(&format!(
        "# {design_name}\n\nVisual search with gaze-contingent rendering (gazecast), exported to BIDS {BIDS_VERSION}.\n\n\
Per participant, `beh/` holds the eye-tracking recording (`_recording-eye1_physio.tsv.gz`, PhysioType eyetrack: \
timestamp (tracker clock, us), x_coordinate and y_coordinate (screen pixels, origin top-left, n/a for invalid samples), \
host_timestamp (host clock, us)) and one event per search trial (`_events.tsv`: onset and duration in s since the first sample).\n"
    ));
    write_text(&guard, &readme, &text)?;
    export.files.push(readme);
    Ok(export)
}
