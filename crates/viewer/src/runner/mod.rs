//! The experiment runner (`gazecast experiment run`): a design's session for one participant in a
//! window, written as it happens to a session folder
//! (`experiment::session`), resumable after a crash.
//!
//! The screens come from [`flow::Flow`]; each frame the runner takes every
//! tracker sample (all of them, not only the newest: each goes to
//! `samples.tsv`, to the calibration in progress and to the trial's
//! eye-movement events), handles keys and clicks (the window's, or the
//! simulated participant's — [`participant`]) with their host times, and
//! draws the screen: text, a calibration target, the target preview (full
//! resolution) or the search display through the frame pipeline with the
//! trial condition's method (`stimulus`).
//!
//! Timing, on the host's monotonic clock of this sitting (the clock the
//! gaze samples' device times are mapped onto, `mapped_us`): the search
//! starts when the present call of the search display's first frame
//! returns (`search_onset_us`), and ends at the Space key's event
//! (`response_us`, taken when the event reaches the runner; winit gives
//! key events no timestamp of their own; the simulated participant's keys
//! carry the time it planned them for). A trial's eye-movement events are
//! detected on the tracker's clock (tracker-hal `events`) over its samples
//! captured up to the response: its end waits for the tracker to deliver
//! them. Every frame is logged (`frames.tsv`), late when its interval
//! exceeds 1.5 periods of the nominal refresh rate, with the plan that
//! drew it (`pipeline::Renderer::provenance`: the search renderer's for the
//! search and confirm screens, the full-resolution renderer's for the
//! preview, `n/a` for text and targets); a trial's row has its search
//! frames' plan.
//!
//! Keys: `Space` go on (instructions, breaks, the preview) and "found"
//! (the search); a left click confirms the object found (designs with
//! `confirm_click`); in a failed validation `R` calibrates again and
//! `Space` continues; `Esc` ends the session (what was written stays;
//! `--resume` continues at the first unfinished trial).

pub mod flow;
pub mod participant;
pub mod stimulus;

mod session_dir;
mod trial;

use std::io::Write;
use std::path::PathBuf;

use experiment::design::Design;
use experiment::session::{FrameRow, MarkerRow, SampleRow};
use foveation::ScreenGeometry;
use pipeline::BackendChoice;
use tracker_hal::calibration::{
    validate, Calibration, Model, Order, Plan, Procedure, Session, SessionPlan, SessionRequest,
    TimedPoint,
};
use tracker_hal::clock::monotonic_us;
use tracker_hal::events::TimedGaze;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::WindowId;

use crate::gaze_feed::{GazeFeed, GazeSetup, TrackerMsg};
use crate::screen::Screen;
use flow::{Flow, Phase};
use participant::{Action, Participant};
use session_dir::SessionDir;
use stimulus::Layout;
use trial::TrialState;

/// Calibration target timing (ms): as `gazecast calibrate`'s defaults.
const SETTLE_MS: u32 = 400;
const COLLECT_MS: u32 = 800;
/// Failed validations before the runner asks the experimenter.
const MAX_CALIBRATION_ATTEMPTS: u32 = 3;
/// The longest a trial's end waits for the tracker's samples captured up
/// to its response (a delivery stall; the events are computed on them).
const RESPONSE_SAMPLES_WAIT: std::time::Duration = std::time::Duration::from_millis(500);
/// Refresh rate assumed when the monitor reports none (Hz).
const NOMINAL_REFRESH_HZ: f64 = 60.0;

/// What `experiment run` was asked.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub design: PathBuf,
    pub participant: String,
    /// Counterbalancing row; `None`: from the id's trailing number − 1.
    pub participant_index: Option<usize>,
    pub tracker: Option<PathBuf>,
    pub display: PathBuf,
    /// Session folders go to `out/<design name>/sub-<participant>`.
    pub out: PathBuf,
    pub resume: bool,
    pub backend: BackendChoice,
    pub fullscreen: bool,
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
    /// `--lsl`: publish the samples, frames and markers as LSL streams.
    pub lsl: crate::args::LslArgs,
}

/// The counterbalancing index from a participant id: its trailing number
/// minus one (`P01` → 0, `sub-12` → 11).
pub fn index_from_id(id: &str) -> Option<usize> {
    let digits: String = id
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    let n: usize = digits.parse().ok()?;
    n.checked_sub(1)
}

/// What [`check_design`] derives from a design on a display: all that
/// `experiment run` needs from it before any folder or window exists.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The participant's trials.
    pub trials: Vec<experiment::Trial>,
    /// The search grid on the screen.
    pub layout: Layout,
    /// The calibration fit: a second-order polynomial follows an eye's
    /// bow where there are points enough (9: the seed's); fewer points
    /// fit a homography.
    pub model: Model,
    /// (calibration, validation) targets and timing.
    pub cal_plans: (Plan, Plan),
    /// The drift check's single target at the centre (designs with one).
    pub drift_plan: Option<Plan>,
}

/// The one check of a design that `experiment plan` and `experiment run`
/// share, so that they cannot disagree: the design's own rules
/// ([`Design::validate`]), the trials on this display
/// ([`stimulus::plan_on_display`]), the calibration and validation grids
/// and the fit they feed, and the drift check's target. `Err((field,
/// message))` names the design field (the caller adds the file and line).
pub fn check_design(
    design: &Design,
    index: usize,
    geometry: &ScreenGeometry,
) -> Result<Checked, (String, String)> {
    design.validate().map_err(|e| match e {
        experiment::DesignError::Invalid { field, message } => (field, message),
        other => ("name".to_string(), other.to_string()),
    })?;
    let (trials, layout) = stimulus::plan_on_display(design, index, geometry)?;
    let size = (geometry.width_px, geometry.height_px);
    let c = &design.calibration;
    let plan = SessionPlan {
        points: c.points as usize,
        validation_points: c.validation_points as usize,
        settle_ms: SETTLE_MS,
        collect_ms: COLLECT_MS,
        order: Order::RowMajor,
    };
    let cal_plans = plan.plans(size).map_err(|e| match e {
        tracker_hal::calibration::PlanError::Validation(m) => {
            ("calibration.validation_points".to_string(), m)
        }
        other => ("calibration.points".to_string(), other.to_string()),
    })?;
    let model = if c.points >= 9 {
        Model::Polynomial2
    } else {
        Model::Homography
    };
    if cal_plans.0.targets_px.len() < model.min_points() {
        return Err((
            "calibration.points".into(),
            format!(
                "{} targets: the {model:?} fit needs at least {}",
                cal_plans.0.targets_px.len(),
                model.min_points()
            ),
        ));
    }
    let drift_plan = design.drift_check.as_ref().map(|_| drift_plan(geometry));
    Ok(Checked {
        trials,
        layout,
        model,
        cal_plans,
        drift_plan,
    })
}

/// The drift check: one target at the screen's centre, timed as the
/// calibration targets. (The calibration grids start at 4 points; a drift
/// check is a single one.)
fn drift_plan(geometry: &ScreenGeometry) -> Plan {
    Plan {
        targets_px: vec![geometry.centre_px()],
        settle_ms: SETTLE_MS,
        collect_ms: COLLECT_MS,
        window_ms: 200.min(COLLECT_MS / 2),
        min_samples: 5,
        max_dispersion: f64::INFINITY,
    }
}

/// Everything fixed for the session.
struct Setup {
    design: Design,
    geometry: ScreenGeometry,
    layout: Layout,
    backend: BackendChoice,
    fullscreen: bool,
    monitor: Option<usize>,
    max_trials: Option<usize>,
    stimulus_pictures: bool,
    screenshots: Option<PathBuf>,
    cal_plans: (Plan, Plan),
    drift_plan: Option<Plan>,
    model: Model,
}

/// A calibration or validation in progress.
enum Checking {
    /// Full calibration (the unattended session policy of tracker-hal).
    Calibrating(Box<Session>),
    /// Validation or drift check of the calibration in use.
    Validating { procedure: Procedure, drift: bool },
    /// Failed too often: the experimenter decides (Space / R).
    Decide(String),
}

struct Runner<'a> {
    setup: &'a Setup,
    out: &'a mut dyn Write,
    dir: SessionDir,
    feed: GazeFeed,
    screen: Option<Screen>,
    flow: Flow,
    phase_since_us: u64,
    /// Raw tracker units → screen px, once calibrated.
    calibration: Option<Calibration>,
    attempts: u32,
    checking: Option<Checking>,
    gaze: [f64; 2],
    cursor: [f64; 2],
    trial: Option<TrialState>,
    canvas: Vec<u8>,
    last_submit_us: Option<u64>,
    late_after_ms: f64,
    participant: Option<Participant>,
    trials_this_sitting: usize,
    error: Option<String>,
    finished: bool,
    /// The event loop was asked to end: no more frames.
    quitting: bool,
    /// Screens saved by `--screenshots` (one per kind).
    shot: std::collections::HashSet<&'static str>,
    /// A calibration (with its own validation) just succeeded: the plan's
    /// validation straight after it is that one.
    just_calibrated: bool,
}

impl Runner<'_> {
    fn say(&mut self, line: &str) {
        let _ = writeln!(self.out, "{line}");
    }

    fn marker(&mut self, event: &str, detail: String) {
        let row = MarkerRow {
            sitting: self.dir.sitting(),
            host_us: monotonic_us(),
            trial: self.flow.trial().map(|t| t.index),
            event: event.to_string(),
            detail,
        };
        self.dir.marker(&row);
    }

    fn size(&self) -> (u32, u32) {
        (self.setup.geometry.width_px, self.setup.geometry.height_px)
    }

    /// Every queued sample: logged, fed to the check in progress and to
    /// the trial; the newest valid one is the gaze.
    fn drain(&mut self) {
        let phase = self.flow.phase();
        let trial = self
            .flow
            .trial()
            .map(|t| t.index)
            .filter(|_| phase.in_trial());
        let msgs: Vec<TrackerMsg> = self.feed.rx.try_iter().collect();
        for m in msgs {
            match m {
                TrackerMsg::Gaze {
                    device_us,
                    arrival_us,
                    mapped_us,
                    time_order,
                    segment,
                    raw,
                    gaze_px,
                    ..
                } => {
                    let mapped = match (&self.calibration, raw) {
                        (Some(c), Some(r)) => c.map(r),
                        _ => gaze_px,
                    }
                    .filter(|g| {
                        tracker_hal::plausibility::plausible(
                            *g,
                            Some(self.setup.geometry.size_px()),
                        )
                    });
                    self.dir.sample(&SampleRow {
                        sitting: self.dir.sitting(),
                        mapped_us,
                        device_us,
                        arrival_us,
                        time_order: time_order.name().into(),
                        segment,
                        trial,
                        phase: phase.name().into(),
                        raw_x: raw.map(|r| r[0]),
                        raw_y: raw.map(|r| r[1]),
                        x_px: mapped.map(|g| g[0]),
                        y_px: mapped.map(|g| g[1]),
                    });
                    if let Some(g) = mapped {
                        self.gaze = g;
                    }
                    if let Some(t) = &mut self.trial {
                        t.sample(TimedGaze {
                            device_us: device_us.unwrap_or(mapped_us),
                            mapped_us,
                            order: time_order,
                            segment,
                            gaze: mapped,
                        });
                    }
                    match &mut self.checking {
                        Some(Checking::Calibrating(s)) => s.feed(TimedPoint {
                            t_us: mapped_us,
                            raw,
                        }),
                        Some(Checking::Validating { procedure, .. }) => {
                            procedure.feed(TimedPoint {
                                t_us: mapped_us,
                                raw,
                            })
                        }
                        _ => {}
                    }
                }
                TrackerMsg::Status(s) => {
                    if !s.is_empty() {
                        self.say(&format!("tracker: {s}"));
                        self.marker("tracker-status", s);
                    }
                }
                TrackerMsg::Clock(c, d) => {
                    self.dir.clock(&c, &d);
                }
            }
        }
    }

    /// The screen changed: log it, tell the participant, set it up.
    fn entered(&mut self) {
        let now = monotonic_us();
        self.phase_since_us = now;
        let phase = self.flow.phase();
        let detail = self
            .flow
            .trial()
            .map(|t| format!("trial {} ({})", t.index + 1, t.condition_name))
            .unwrap_or_default();
        self.marker(&format!("start:{}", phase.name()), detail);
        if !matches!(phase, Phase::Validation { midpoint: false }) {
            self.just_calibrated = false;
        }
        match phase {
            Phase::Calibration => {
                let (cal, val) = self.setup.cal_plans.clone();
                let s = Session::new(
                    self.setup.model,
                    cal,
                    val,
                    self.setup.geometry,
                    self.setup.design.calibration.accuracy_threshold_deg,
                    true,
                );
                self.checking = Some(Checking::Calibrating(Box::new(s)));
            }
            Phase::Validation { midpoint: false } if self.just_calibrated => {
                // The calibration session validated on its own targets.
                self.just_calibrated = false;
                self.marker("validation", "done by the calibration just before".into());
                return self.advance();
            }
            Phase::Validation { .. } | Phase::DriftCheck => {
                let drift = phase == Phase::DriftCheck;
                let plan = if drift {
                    self.setup.drift_plan.clone()
                } else {
                    Some(self.setup.cal_plans.1.clone())
                };
                if self.calibration.is_none() || plan.is_none() {
                    // Nothing to validate yet: calibrate first.
                    self.flow.recalibrate();
                    return self.entered();
                }
                if let Some(plan) = plan {
                    self.checking = Some(Checking::Validating {
                        procedure: Procedure::new(plan),
                        drift,
                    });
                }
            }
            Phase::Preview => {
                if let Some(t) = self.flow.trial().cloned() {
                    match TrialState::new(self.setup, &t) {
                        Ok(s) => self.trial = Some(s),
                        Err(e) => self.error = Some(e),
                    }
                }
            }
            _ => {}
        }
        if let Some(p) = &self.participant {
            let (objects, target) = match (&self.trial, self.flow.trial()) {
                (Some(_), Some(t)) => (
                    self.setup.layout.centres_px.clone(),
                    Some(self.setup.layout.centre_px(t.target_cell)),
                ),
                _ => (Vec::new(), None),
            };
            // The screen's set-up (the trial's scenes) took time: it starts now.
            p.show(phase, monotonic_us(), &objects, target);
        }
    }

    fn advance(&mut self) {
        self.checking = None;
        self.flow.advance();
        self.entered();
    }

    fn act(&mut self, action: Action, el: &ActiveEventLoop) {
        let phase = self.flow.phase();
        match action {
            Action::Space { host_us } => {
                self.marker("key", format!("space {host_us}"));
                match phase {
                    Phase::Instructions | Phase::Rest { .. } | Phase::Preview => self.advance(),
                    Phase::Search => {
                        let responded = self.trial.as_mut().is_some_and(|t| t.respond(host_us));
                        if responded {
                            if self.setup.design.response.confirm_click {
                                self.advance();
                            } else {
                                self.end_trial(None, el);
                            }
                        }
                    }
                    Phase::Validation { .. } | Phase::DriftCheck | Phase::Calibration => {
                        if matches!(self.checking, Some(Checking::Decide(_))) {
                            self.marker("calibration", "accepted by the experimenter".into());
                            self.advance();
                        }
                    }
                    _ => {}
                }
            }
            Action::Click { host_us, px } => {
                self.marker("click", format!("{host_us} {:.1} {:.1}", px[0], px[1]));
                if phase == Phase::Confirm {
                    let cell = self.setup.layout.cell_at(px);
                    self.end_trial(Some(cell), el);
                }
            }
        }
    }

    /// The trial's response is complete: write it, then the next screen.
    fn end_trial(&mut self, click: Option<Option<(u32, u32)>>, el: &ActiveEventLoop) {
        // Its eye-movement events are computed on the tracker's clock: wait
        // (at most RESPONSE_SAMPLES_WAIT) until the tracker has delivered
        // the samples captured up to the response, however late delivery is.
        let waited = std::time::Instant::now();
        while self.trial.as_ref().is_some_and(TrialState::awaits_samples)
            && waited.elapsed() < RESPONSE_SAMPLES_WAIT
        {
            std::thread::sleep(std::time::Duration::from_millis(5));
            self.drain();
        }
        let (Some(state), Some(t)) = (self.trial.take(), self.flow.trial().cloned()) else {
            return;
        };
        let participant = self.dir.participant().to_string();
        let synthetic = self.participant.is_some();
        match state.finish(
            self.setup,
            &t,
            &participant,
            click,
            synthetic,
            &mut self.dir,
        ) {
            Ok(line) => self.say(&line),
            Err(e) => {
                self.error = Some(e);
                return self.quit(el);
            }
        }
        self.trials_this_sitting += 1;
        if self
            .setup
            .max_trials
            .is_some_and(|n| self.trials_this_sitting >= n)
        {
            self.say(&format!(
                "stopping after {} trials as asked; --resume continues",
                self.trials_this_sitting
            ));
            return self.quit(el);
        }
        self.advance();
    }

    fn quit(&mut self, el: &ActiveEventLoop) {
        self.quitting = true;
        el.exit();
    }

    /// Calibration and validation bookkeeping once per frame.
    fn check(&mut self) {
        let mut outcome: Option<Result<String, String>> = None;
        let mut target = None;
        match &mut self.checking {
            Some(Checking::Calibrating(s)) => {
                let log = s.take_log();
                let requests = s.take_requests();
                for l in log {
                    self.dir.marker(&MarkerRow {
                        sitting: self.dir.sitting(),
                        host_us: monotonic_us(),
                        trial: self.flow.trial().map(|t| t.index),
                        event: "calibration".into(),
                        detail: l,
                    });
                }
                for r in requests {
                    match r {
                        SessionRequest::Save => {
                            let summary = s.summary();
                            self.calibration = s.calibration().cloned();
                            let threshold = self.setup.design.calibration.accuracy_threshold_deg;
                            outcome = Some(match summary {
                                Some(v) if v.accuracy_deg <= threshold => Ok(format!(
                                    "calibrated: validation accuracy {:.2} deg (precision RMS {:.2} deg), threshold {threshold} deg",
                                    v.accuracy_deg, v.precision_rms_deg
                                )),
                                Some(v) => Err(format!(
                                    "calibration validated at {:.2} deg, above the threshold {threshold} deg",
                                    v.accuracy_deg
                                )),
                                None => Err("calibration: no validation point had data".into()),
                            });
                        }
                        SessionRequest::Abort(e) => {
                            outcome = Some(Err(format!("calibration failed: {e}")))
                        }
                    }
                }
                target = match s.phase() {
                    tracker_hal::calibration::SessionPhase::Calibrating => {
                        s.calibration_run().target().map(|t| t.1)
                    }
                    tracker_hal::calibration::SessionPhase::Validating => {
                        s.validation_run().target().map(|t| t.1)
                    }
                    _ => None,
                };
            }
            Some(Checking::Validating { procedure, drift }) => {
                target = procedure.target().map(|t| t.1);
                if procedure.done() {
                    let runs: Vec<([f64; 2], Vec<TimedPoint>)> = procedure
                        .results()
                        .map(|r| (r.target_px, r.samples.clone()))
                        .collect();
                    let threshold = match (*drift, &self.setup.design.drift_check) {
                        (true, Some(d)) => d.threshold_deg,
                        _ => self.setup.design.calibration.accuracy_threshold_deg,
                    };
                    let what = if *drift { "drift check" } else { "validation" };
                    outcome = Some(match &self.calibration {
                        Some(c) => match validate(c, &self.setup.geometry, &runs) {
                            Ok(v) if v.accuracy_deg <= threshold => Ok(format!(
                                "{what}: accuracy {:.2} deg (threshold {threshold} deg)",
                                v.accuracy_deg
                            )),
                            Ok(v) => Err(format!(
                                "{what}: accuracy {:.2} deg, above the threshold {threshold} deg",
                                v.accuracy_deg
                            )),
                            Err(e) => Err(format!("{what}: {e}")),
                        },
                        None => Err(format!("{what}: no calibration to validate")),
                    });
                }
            }
            _ => {}
        }
        if let Some(p) = &self.participant {
            p.show_target(target);
        }
        match outcome {
            Some(Ok(line)) => {
                self.say(&line);
                self.marker("calibration-result", line);
                self.attempts = 0;
                self.just_calibrated = self.flow.phase() == Phase::Calibration;
                self.advance();
            }
            Some(Err(line)) => {
                self.say(&line);
                self.marker("calibration-result", line.clone());
                self.attempts += 1;
                if self.attempts >= MAX_CALIBRATION_ATTEMPTS {
                    self.checking = Some(Checking::Decide(line));
                } else {
                    self.checking = None;
                    self.flow.recalibrate();
                    self.entered();
                }
            }
            None => {}
        }
        self.canvas_target(target);
    }

    fn canvas_target(&mut self, target: Option<[f64; 2]>) {
        if !matches!(
            self.flow.phase(),
            Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck
        ) {
            return;
        }
        let size = self.size();
        let lines = match &self.checking {
            Some(Checking::Decide(why)) => vec![
                why.clone(),
                "R: calibrate again    Space: continue with this calibration".to_string(),
            ],
            _ => Vec::new(),
        };
        trial::target_screen(&mut self.canvas, size, target, &lines);
    }

    fn text(&mut self, lines: &[String]) {
        let size = self.size();
        trial::text_screen(&mut self.canvas, size, lines);
    }

    fn frame(&mut self, el: &ActiveEventLoop) -> Result<(), String> {
        if let Some(e) = self.dir.error() {
            return Err(format!("the session folder cannot be written: {e}"));
        }
        let tex = self.screen.as_ref().and_then(Screen::acquire);
        self.drain();
        if let Some(p) = &self.participant {
            for a in p.take_actions() {
                self.act(a, el);
            }
        }
        if self.quitting {
            return Ok(());
        }
        self.check();
        let phase = self.flow.phase();
        let design = &self.setup.design;
        let mut rays = 0;
        let mut render_ms = 0.0;
        match phase {
            Phase::Instructions => {
                let mut lines = vec![
                    format!("Visual search: {}", design.name),
                    String::new(),
                    "First look at each dot as it appears (calibration).".into(),
                    "Each trial shows the target face at the centre: study it, then press Space."
                        .into(),
                    "Find the same face in the grid and press Space as soon as you have found it."
                        .into(),
                ];
                if design.response.confirm_click {
                    lines.push("Then click on the face you found.".into());
                }
                lines.push(String::new());
                lines.push("Press Space to begin.".into());
                self.text(&lines);
            }
            Phase::Rest { between_runs } => {
                let t = self
                    .flow
                    .trial()
                    .map(|t| (t.run, t.trial_in_run))
                    .unwrap_or((0, 0));
                let lines = if between_runs {
                    vec![
                        format!("End of run {} of {}.", t.0, design.runs),
                        "Please stand up and stretch.".into(),
                        "Press Space to go on.".into(),
                    ]
                } else {
                    vec![
                        "A short break: rest your eyes.".into(),
                        "Press Space to go on.".into(),
                    ]
                };
                self.text(&lines);
            }
            Phase::Done => {
                self.text(&["The session is complete. Thank you!".into()]);
                if !self.finished {
                    self.finished = true;
                    self.say("session complete");
                }
                if monotonic_us().saturating_sub(self.phase_since_us) > 1_000_000 {
                    self.quit(el);
                }
            }
            Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck => {}
            Phase::Preview | Phase::Search | Phase::Confirm => {
                let Some(t) = &mut self.trial else {
                    return Err("no trial state for the trial's screen".into());
                };
                if phase == Phase::Search {
                    let (r, ms) = t.render_search(self.gaze)?;
                    rays = r;
                    render_ms = ms;
                } else if phase == Phase::Confirm {
                    t.confirm_overlay();
                }
            }
        }
        if let Some(limit) = design.response.max_search_s {
            let now = monotonic_us();
            let timed_out = phase == Phase::Search
                && self
                    .trial
                    .as_mut()
                    .is_some_and(|t| t.timed_out(limit) && t.respond(now));
            if timed_out {
                self.marker("timeout", format!("no response within {limit} s"));
                self.end_trial(None, el);
                return Ok(());
            }
        }
        let rgb: &[u8] = match (&self.trial, phase) {
            (Some(t), Phase::Preview | Phase::Search | Phase::Confirm) => t.rgb(phase),
            _ => &self.canvas,
        };
        // What drew the picture: a renderer for the trial's screens; the
        // text and target screens are drawn without one (`n/a`).
        let plan = match (&self.trial, phase) {
            (Some(t), Phase::Preview | Phase::Search | Phase::Confirm) => {
                Some(t.plan(phase).to_string())
            }
            _ => None,
        };
        let size = self.size();
        if let Some(dir) = &self.setup.screenshots {
            if self.shot.insert(phase.name()) {
                let path = dir.join(format!("{}.png", phase.name()));
                if let Err(e) = crate::picture::save_png(&path, size, rgb) {
                    return Err(format!("{}: {e}", path.display()));
                }
            }
        }
        let submit_us = match (&mut self.screen, tex) {
            (Some(s), Some(tex)) => s.present(tex, rgb, size),
            _ => monotonic_us(),
        };
        let present_us = monotonic_us();
        let interval_ms = self
            .last_submit_us
            .map(|t| submit_us.saturating_sub(t) as f64 / 1e3);
        self.last_submit_us = Some(submit_us);
        let late = interval_ms.is_some_and(|i| i > self.late_after_ms);
        if phase == Phase::Search {
            if let Some(t) = &mut self.trial {
                let first = t.presented(present_us, rays, late);
                if first {
                    self.dir.marker(&MarkerRow {
                        sitting: self.dir.sitting(),
                        host_us: present_us,
                        trial: self.flow.trial().map(|t| t.index),
                        event: "search-onset".into(),
                        detail: "first frame of the search display presented".into(),
                    });
                    if let Some(p) = &self.participant {
                        let target = self
                            .flow
                            .trial()
                            .map(|t| self.setup.layout.centre_px(t.target_cell));
                        p.show(
                            Phase::Search,
                            present_us,
                            &self.setup.layout.centres_px,
                            target,
                        );
                    }
                }
            }
        }
        self.dir.frame(&FrameRow {
            sitting: self.dir.sitting(),
            host_us: present_us,
            trial: self
                .flow
                .trial()
                .map(|t| t.index)
                .filter(|_| phase.in_trial()),
            phase: phase.name().into(),
            rays,
            render_ms,
            interval_ms,
            late,
            plan,
        });
        Ok(())
    }
}

impl ApplicationHandler for Runner<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.screen.is_none() {
            let size = self.size();
            let title = format!("gazecast experiment — {}", self.setup.design.name);
            match Screen::open(el, &title, size, self.setup.fullscreen, self.setup.monitor) {
                Ok(s) => {
                    if let Some(hz) = s
                        .window
                        .current_monitor()
                        .and_then(|m| m.refresh_rate_millihertz())
                        .filter(|&mhz| mhz >= 10_000)
                    {
                        self.late_after_ms = 1.5 * 1e6 / f64::from(hz);
                    }
                    self.screen = Some(s);
                }
                Err(e) => {
                    self.error = Some(e);
                    el.exit();
                }
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let now = monotonic_us();
        match event {
            WindowEvent::CloseRequested => {
                self.say("window closed: ending the session (--resume continues it)");
                self.quit(el)
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = [position.x, position.y];
                self.feed.cursor_moved(position.x, position.y);
            }
            WindowEvent::MouseInput {
                state: ElementState::Pressed,
                button: MouseButton::Left,
                ..
            } => {
                let px = self.cursor;
                self.act(Action::Click { host_us: now, px }, el);
            }
            WindowEvent::KeyboardInput { event, .. }
                if event.state == ElementState::Pressed && !event.repeat =>
            {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Escape) => {
                        self.say("Esc: ending the session (--resume continues it)");
                        self.marker("key", "escape".into());
                        self.quit(el)
                    }
                    Key::Named(NamedKey::Space) => self.act(Action::Space { host_us: now }, el),
                    Key::Character("r") | Key::Character("R") => {
                        if matches!(self.checking, Some(Checking::Decide(_))) {
                            self.attempts = 0;
                            self.checking = None;
                            self.flow.recalibrate();
                            self.entered();
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::RedrawRequested => {
                if crate::gaze_feed::interrupted() {
                    self.say("interrupted (Ctrl-C or SIGTERM): ending the session");
                    return self.quit(el);
                }
                if let Err(e) = self.frame(el) {
                    // Keep the first error: it is the cause.
                    self.error.get_or_insert(e);
                    return self.quit(el);
                }
                if let Some(e) = &self.error {
                    let e = e.clone();
                    self.say(&format!("error: {e}"));
                    return self.quit(el);
                }
                if let Some(s) = &self.screen {
                    s.window.request_redraw();
                }
            }
            _ => {}
        }
    }
}

/// Runs (or resumes) a session to its end or until it is stopped.
pub fn run(opts: &RunOptions, out: &mut dyn Write) -> Result<(), String> {
    let display = crate::config::load_display(&opts.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let index = match opts.participant_index {
        Some(i) => i,
        None => index_from_id(&opts.participant).ok_or_else(|| {
            format!(
                "--participant {:?} ends in no number ≥ 1 to take the counterbalancing row from; give --participant-index N",
                opts.participant
            )
        })?,
    };
    // The design on this display, before any folder or window exists.
    let (design, checked) =
        crate::config::load_design_checked(&opts.design, |d| check_design(d, index, &geometry))
            .map_err(|e| e.to_string())?;
    let Checked {
        trials,
        layout,
        model,
        cal_plans,
        drift_plan,
    } = checked;
    let mut setup_gaze = GazeSetup::resolve(opts.tracker.as_deref(), None)?;
    // The simulated participant's ISCAN: a pseudo-terminal whose slave the
    // tracker opens in place of the file's port.
    let mut iscan_master = None;
    if opts.simulate.is_some() {
        match &mut setup_gaze.tracker.driver {
            tracker_hal::Driver::Mouse(_) => {}
            tracker_hal::Driver::Iscan(c) => {
                use serialport::SerialPort;
                let (master, slave) =
                    serialport::TTYPort::pair().map_err(|e| format!("a pseudo-terminal for the simulated ISCAN: {e}"))?;
                let name = slave
                    .name()
                    .ok_or("the simulated ISCAN's pseudo-terminal has no name")?;
                drop(slave); // the port is opened exclusively, by path
                c.port = Some(name);
                iscan_master = Some((master, c.clone()));
            }
            _ => {
                return Err("--simulate-participant drives a Mouse or an ISCAN tracker file (config/trackers/mouse.ron, iscan-binary.ron)".into())
            }
        }
    }
    let mut dir = SessionDir::open(opts, &design, &display, index, &setup_gaze)?;
    let suffix = format!(
        "{}-{}",
        crate::lsl_out::id_part(&design.name),
        crate::lsl_out::id_part(&opts.participant)
    );
    if let Some(o) = opts.lsl.options("experiment", suffix, true) {
        let (outlets, lines) = crate::lsl_out::Outlets::open(&o)?;
        for l in lines {
            let _ = writeln!(out, "{l}");
        }
        dir.attach_lsl(outlets);
    }
    for line in dir.upgraded().to_vec() {
        let _ = writeln!(out, "{}: {line}", dir.path().display());
        dir.marker(&MarkerRow {
            sitting: dir.sitting(),
            host_us: monotonic_us(),
            trial: None,
            event: "file-columns-added".into(),
            detail: line,
        });
    }
    let start = dir.next_trial();
    if let Some((trial, sitting)) = dir.aborted_trial().filter(|(t, _)| *t < trials.len()) {
        // The trial the last sitting did not finish runs again now: its
        // rows there are aborted (the analysis and the export leave them out).
        dir.marker(&MarkerRow {
            sitting: dir.sitting(),
            host_us: monotonic_us(),
            trial: Some(trial),
            event: "aborted-trial".into(),
            detail: format!(
                "trial {} was not finished in sitting {sitting}; it runs again in this sitting, its rows of sitting {sitting} are aborted",
                trial + 1
            ),
        });
    }
    if start >= trials.len() {
        return Err(format!(
            "{}: every trial ({}) is done; nothing to resume",
            dir.path().display(),
            trials.len()
        ));
    }
    let setup = Setup {
        layout,
        design,
        geometry,
        backend: opts.backend,
        fullscreen: opts.fullscreen,
        monitor: opts.monitor,
        max_trials: opts.max_trials,
        stimulus_pictures: opts.stimulus_pictures,
        screenshots: opts.screenshots.clone(),
        cal_plans,
        drift_plan,
        model,
    };
    if let Some(d) = &opts.screenshots {
        std::fs::create_dir_all(d).map_err(|e| format!("--screenshots {}: {e}", d.display()))?;
    }
    let event_loop =
        {
        crate::screen::close_recordings_if_the_x_server_goes();
        EventLoop::new()
    }.map_err(|e| format!("cannot open a window ({}); the experiment needs a display (run under Xvfb on a machine without one)", crate::screen::plain_error(&e)))?;
    crate::gaze_feed::catch_interrupts();
    let record = dir.recording_path();
    let feed = setup_gaze
        .with_screen(setup.geometry.size_px())
        .spawn(None, Some((&record, display.name.as_str())))?;
    let size_px = (setup.geometry.width_px, setup.geometry.height_px);
    let participant = match (opts.simulate, iscan_master) {
        (Some(seed), Some((port, config))) => Some(Participant::spawn(
            participant::Eye::Iscan {
                port,
                config,
                screen_px: size_px,
            },
            setup.geometry,
            seed,
        )),
        (Some(seed), None) => feed
            .cursor_tx
            .clone()
            .map(|tx| Participant::spawn(participant::Eye::Mouse(tx), setup.geometry, seed)),
        _ => None,
    };
    let resumed = start > 0;
    let flow = Flow::new(
        trials,
        start,
        setup.design.response.confirm_click,
        resumed && setup.design.calibration.at_start,
    );
    let _ = writeln!(
        out,
        "gazecast experiment: {} for {} (row {}), trial {} of {}, session folder {}{}",
        setup.design.name,
        opts.participant,
        index,
        start + 1,
        flow.trials().len(),
        dir.path().display(),
        if participant.is_some() {
            " — SIMULATED participant (synthetic data)"
        } else {
            ""
        }
    );
    let mut runner = Runner {
        setup: &setup,
        out,
        dir,
        feed,
        screen: None,
        flow,
        phase_since_us: monotonic_us(),
        calibration: None,
        attempts: 0,
        checking: None,
        gaze: setup.geometry.centre_px(),
        cursor: setup.geometry.centre_px(),
        trial: None,
        canvas: Vec::new(),
        last_submit_us: None,
        late_after_ms: 1.5 * 1e3 / NOMINAL_REFRESH_HZ,
        participant,
        trials_this_sitting: 0,
        error: None,
        finished: false,
        quitting: false,
        just_calibrated: false,
        shot: Default::default(),
    };
    runner.entered();
    let result = event_loop.run_app(&mut runner);
    // The tracker first: the simulated participant's line closing under a
    // running tracker would be reported as a lost device.
    let recorded = runner.feed.finish();
    runner.participant = None;
    runner.drain();
    for l in runner.feed.report() {
        runner.say(&l);
    }
    if let Ok(Some(line)) = &recorded {
        runner.say(line);
    }
    if let Some(line) = runner.dir.lsl_summary() {
        runner.say(&line);
    }
    let summary = runner.dir.close();
    runner.say(&summary);
    recorded?;
    if let Some(e) = runner.error.take() {
        return Err(e);
    }
    result.map_err(|e| format!("window: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use experiment::design::DriftCheck;
    use experiment::Step;
    use proptest::prelude::*;

    fn murphy() -> Design {
        Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design")
    }

    fn seed_display() -> ScreenGeometry {
        crate::config::load_display(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/displays/tobii-et1750-17in.ron"
        )))
        .expect("display")
        .geometry()
        .expect("geometry")
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Every design that `experiment plan` accepts, `experiment run`
        /// accepts and can set up. `plan`'s trials-on-the-display check
        /// accepting a design implies the shared check accepts it; and
        /// what the shared check accepts gives run everything it builds
        /// before the window: the calibration session (its fit has the
        /// points it needs, at most 25 of each kind), the drift check's
        /// single target wherever the plan puts a drift check, and a flow
        /// that reaches its end.
        #[test]
        fn every_design_plan_accepts_run_accepts(
            points in prop_oneof![0u32..30, Just(36u32), Just(1_000_000u32)],
            validation in prop_oneof![0u32..30, Just(1_000_000u32)],
            drift in proptest::option::of((0u32..50, prop_oneof![Just(f64::NAN), 0.1f64..5.0])),
            at_start in any::<bool>(),
            midpoint in any::<bool>(),
            runs in 1u32..4,
            index in 0usize..30,
        ) {
            let g = seed_display();
            let mut d = murphy();
            d.calibration.points = points;
            d.calibration.validation_points = validation;
            d.calibration.at_start = at_start;
            d.calibration.validate_at_midpoint = midpoint;
            d.runs = runs;
            d.drift_check = drift.map(|(every_trials, threshold_deg)| DriftCheck {
                every_trials,
                threshold_deg,
            });
            let shared = check_design(&d, index, &g);
            if stimulus::plan_on_display(&d, index, &g).is_ok() {
                prop_assert!(shared.is_ok(), "{:?}", shared.err());
            }
            let Ok(c) = shared else {
                return Ok(());
            };
            prop_assert!(d.validate().is_ok());
            prop_assert_eq!(c.cal_plans.0.targets_px.len(), points as usize);
            prop_assert_eq!(c.cal_plans.1.targets_px.len(), validation as usize);
            prop_assert!(points <= 25 && validation <= 25);
            prop_assert!(c.cal_plans.0.targets_px.len() >= c.model.min_points());
            let _session = Session::new(
                c.model,
                c.cal_plans.0.clone(),
                c.cal_plans.1.clone(),
                g,
                d.calibration.accuracy_threshold_deg,
                true,
            );
            let drifts = c
                .trials
                .iter()
                .filter(|t| t.before.contains(&Step::DriftCheck))
                .count();
            prop_assert_eq!(drifts > 0, d.drift_check.is_some());
            if let Some(p) = &c.drift_plan {
                prop_assert_eq!(p.targets_px.len(), 1);
                let _ = Procedure::new(p.clone());
            }
            let mut flow = Flow::new(c.trials.clone(), 0, d.response.confirm_click, false);
            let mut steps = 0usize;
            while flow.phase() != Phase::Done {
                if flow.phase() == Phase::DriftCheck {
                    prop_assert!(c.drift_plan.is_some());
                }
                flow.advance();
                steps += 1;
                prop_assert!(steps < 10 * (c.trials.len() + 2) * 4);
            }
        }
    }
}
