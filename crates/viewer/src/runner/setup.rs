//! Everything fixed for one sitting of a session, from the options and the
//! checked design: what the runner's handler reads and never changes.

use std::path::PathBuf;

use experiment::design::Design;
use experiment::run::layout::Layout;
use foveation::ScreenGeometry;
use pipeline::BackendChoice;
use tracker_hal::calibration::{Model, Plan};

/// Everything fixed for the session.
pub(super) struct Setup {
    pub(super) design: Design,
    pub(super) geometry: ScreenGeometry,
    pub(super) layout: Layout,
    pub(super) backend: BackendChoice,
    pub(super) fullscreen: bool,
    pub(super) monitor: Option<usize>,
    pub(super) max_trials: Option<usize>,
    pub(super) stimulus_pictures: bool,
    pub(super) screenshots: Option<PathBuf>,
    pub(super) cal_plans: (Plan, Plan),
    pub(super) drift_plan: Option<Plan>,
    pub(super) model: Model,
    /// A search frame is shown again while the gaze stays within this many
    /// degrees of the gaze it was rendered for.
    pub(super) gaze_tolerance_deg: Option<f64>,
    /// The simulated observer's model, when it sees the rendering: each
    /// trial then renders its search display at full resolution too, and
    /// each new search frame's fidelity per object goes to it.
    pub(super) observer: Option<experiment::run::observer::ObserverModel>,
    /// The design's `thresholds` file, loaded; `None`: the default model.
    pub(super) thresholds: Option<crate::args::Thresholds>,
}
