//! The session folder's file names and where the stimulus pictures go.

use std::path::{Path, PathBuf};

/// `session.json`: [`SessionInfo`](super::SessionInfo).
pub const SESSION_JSON: &str = "session.json";
/// `design.ron`: the copy of the design file.
pub const DESIGN_RON: &str = "design.ron";
/// `trials.tsv`: [`TrialRow`](super::TrialRow).
pub const TRIALS_TSV: &str = "trials.tsv";
/// `samples.tsv`: [`SampleRow`](super::SampleRow).
pub const SAMPLES_TSV: &str = "samples.tsv";
/// `events.tsv`: [`EventRow`](super::EventRow).
pub const EVENTS_TSV: &str = "events.tsv";
/// `markers.tsv`: [`MarkerRow`](super::MarkerRow).
pub const MARKERS_TSV: &str = "markers.tsv";
/// `frames.tsv`: [`FrameRow`](super::FrameRow).
pub const FRAMES_TSV: &str = "frames.tsv";
/// `clock.tsv`: [`ClockRow`](super::ClockRow).
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
