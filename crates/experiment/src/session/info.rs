//! `session.json`: who, which design, which display and tracker, and the
//! sittings with their clocks; which sitting completed each trial and
//! which rows are aborted.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::atomic::write_atomic;
use super::error::SessionFileError;
use super::rows::{ClockRow, TrialRow};

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
