//! What `gazecast experiment run` was asked: the design, the participant,
//! the tracker and display, where the session goes and how it is shown.

use std::path::PathBuf;

use pipeline::BackendChoice;

/// What `experiment run` was asked.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The design file (RON).
    pub design: PathBuf,
    /// The participant's id.
    pub participant: String,
    /// Counterbalancing row; `None`: from the id's trailing number − 1.
    pub participant_index: Option<usize>,
    /// Tracker file (RON) the gaze comes from.
    pub tracker: Option<PathBuf>,
    /// Display file (RON).
    pub display: PathBuf,
    /// Session folders go to `out/<design name>/sub-<participant>`.
    pub out: PathBuf,
    /// Continue the session at its first unfinished trial.
    pub resume: bool,
    /// Where to render: CPU, GPU, or the GPU when there is one.
    pub backend: BackendChoice,
    /// Fullscreen on the current monitor.
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based).
    pub monitor: Option<usize>,
    /// Run the simulated participant with this seed (mouse tracker only).
    pub simulate: Option<u64>,
    /// Save each trial's search display (`stimuli/trial-NNN.png`).
    pub stimulus_pictures: bool,
    /// End this sitting after this many trials (the session stays
    /// resumable).
    pub max_trials: Option<usize>,
    /// Save the first frame shown of each kind of screen here
    /// (`<phase>.png`: instructions, calibration, preview, search, …).
    pub screenshots: Option<PathBuf>,
    /// The simulated participant searches with this observer model (it
    /// sees what is rendered; `experiment::run::observer`).
    pub participant_model: Option<PathBuf>,
    /// Run without a window on a virtual clock (with `simulate`, on the
    /// mouse tracker): the same screens, renderer and files, as fast as
    /// the machine renders.
    pub headless: bool,
    /// Show the last search frame again while the gaze stays within this
    /// many degrees of the gaze it was rendered for (`None`: render every
    /// frame).
    pub gaze_tolerance_deg: Option<f64>,
    /// `--lsl`: publish the samples, frames and markers as LSL streams.
    pub lsl: crate::args::LslArgs,
}
