//! The runner's state in the window and how it moves from screen to
//! screen: the tracker's samples taken each frame, the screen entered, the
//! participant's keys and clicks acted on, a trial ended and written.

use std::io::Write;

use experiment::run::flow::{Flow, Phase};
use experiment::run::participant::Action;
use experiment::session::{MarkerRow, SampleRow};
use tracker_hal::calibration::{Calibration, Procedure, Session, TimedPoint};
use tracker_hal::clock::monotonic_us;
use tracker_hal::events::TimedGaze;

use super::calibrating::Checking;
use super::participant::Participant;
use super::session_dir::SessionDir;
use super::setup::Setup;
use super::trial::TrialState;
use crate::gaze_feed::{GazeFeed, TrackerMsg};
use crate::screen::Screen;

/// The longest a trial's end waits for the tracker's samples captured up
/// to its response (a delivery stall; the events are computed on them).
const RESPONSE_SAMPLES_WAIT: std::time::Duration = std::time::Duration::from_millis(500);
/// Refresh rate assumed when the monitor reports none (Hz).
pub(super) const NOMINAL_REFRESH_HZ: f64 = 60.0;

/// The session's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RunClock {
    /// The host's monotonic clock (a session in a window).
    Host,
    /// A headless simulation's virtual clock (µs), advanced one frame
    /// period at a time by its loop ([`super::headless`]); it starts at
    /// the sitting's host anchor.
    Virtual(u64),
}

/// The session in its window (or in a headless simulation).
pub(super) struct Runner<'a> {
    pub(super) setup: &'a Setup,
    pub(super) clock: RunClock,
    pub(super) out: &'a mut dyn Write,
    pub(super) dir: SessionDir,
    pub(super) feed: GazeFeed,
    pub(super) screen: Option<Screen>,
    /// The GPU device the window presents on and every trial's renderer
    /// renders on (the GPU backend in a window); `None` otherwise, where
    /// each trial's renderer opens its own.
    pub(super) gpu: Option<raycast::gpu::SharedDevice>,
    /// The trial whose reference object the window's overlay holds.
    pub(super) overlay_trial: Option<usize>,
    pub(super) flow: Flow,
    pub(super) phase_since_us: u64,
    /// Raw tracker units → screen px, once calibrated.
    pub(super) calibration: Option<Calibration>,
    pub(super) attempts: u32,
    pub(super) checking: Option<Checking>,
    pub(super) gaze: [f64; 2],
    pub(super) cursor: [f64; 2],
    pub(super) trial: Option<TrialState>,
    pub(super) canvas: Vec<u8>,
    pub(super) last_submit_us: Option<u64>,
    pub(super) late_after_ms: f64,
    pub(super) participant: Option<Participant>,
    pub(super) trials_this_sitting: usize,
    pub(super) error: Option<String>,
    pub(super) finished: bool,
    /// The event loop was asked to end: no more frames.
    pub(super) quitting: bool,
    /// Screens saved by `--screenshots` (one per kind).
    pub(super) shot: std::collections::HashSet<&'static str>,
    /// A calibration (with its own validation) just succeeded: the plan's
    /// validation straight after it is that one.
    pub(super) just_calibrated: bool,
}

impl Runner<'_> {
    /// Now on the session's clock (µs).
    pub(super) fn now(&self) -> u64 {
        match self.clock {
            RunClock::Host => monotonic_us(),
            RunClock::Virtual(t) => t,
        }
    }

    pub(super) fn say(&mut self, line: &str) {
        let _ = writeln!(self.out, "{line}");
    }

    pub(super) fn marker(&mut self, event: &str, detail: String) {
        let row = MarkerRow {
            sitting: self.dir.sitting(),
            host_us: self.now(),
            trial: self.flow.trial().map(|t| t.index),
            event: event.to_string(),
            detail,
        };
        self.dir.marker(&row);
    }

    pub(super) fn size(&self) -> (u32, u32) {
        (self.setup.geometry.width_px, self.setup.geometry.height_px)
    }

    /// Every queued sample: logged, fed to the check in progress and to
    /// the trial; the newest valid one is the gaze.
    pub(super) fn drain(&mut self) {
        let phase = self.flow.phase();
        let phase_name = self.flow.phase_name();
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
                    eyes,
                    eye_px,
                    ..
                } => {
                    // The combined gaze, and each eye's point alike: the
                    // session's calibration once there is one, the
                    // source's mapping before.
                    let screen = Some(self.setup.geometry.size_px());
                    let map = |raw: Option<[f64; 2]>, source: Option<[f64; 2]>| {
                        match (&self.calibration, raw) {
                            (Some(c), Some(r)) => c.map(r),
                            _ => source,
                        }
                        .filter(|g| tracker_hal::plausibility::plausible(*g, screen))
                    };
                    let mapped = map(raw, gaze_px);
                    let left = map(eyes[0].position, eye_px[0]);
                    let right = map(eyes[1].position, eye_px[1]);
                    self.dir.sample(&SampleRow {
                        sitting: self.dir.sitting(),
                        mapped_us,
                        device_us,
                        arrival_us,
                        time_order: time_order.name().into(),
                        segment,
                        trial,
                        phase: phase_name.into(),
                        raw_x: raw.map(|r| r[0]),
                        raw_y: raw.map(|r| r[1]),
                        x_px: mapped.map(|g| g[0]),
                        y_px: mapped.map(|g| g[1]),
                        left_x_px: left.map(|g| g[0]),
                        left_y_px: left.map(|g| g[1]),
                        left_pupil: eyes[0].pupil,
                        right_x_px: right.map(|g| g[0]),
                        right_y_px: right.map(|g| g[1]),
                        right_pupil: eyes[1].pupil,
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
    pub(super) fn entered(&mut self) {
        let now = self.now();
        self.phase_since_us = now;
        let phase = self.flow.phase();
        let detail = self
            .flow
            .trial()
            .map(|t| format!("trial {} ({})", t.index + 1, t.condition_name))
            .unwrap_or_default();
        self.marker(&format!("start:{}", self.flow.phase_name()), detail);
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
                    // Search frames stay on the GPU where the window
                    // draws from the renderers' device.
                    let on_gpu = self
                        .screen
                        .as_ref()
                        .filter(|s| s.presents_from_gpu())
                        .and(self.gpu.as_ref());
                    match TrialState::new(self.setup, &t, self.gpu.as_ref(), on_gpu.is_some()) {
                        Ok(s) => self.trial = Some(s),
                        Err(e) => self.error = Some(e),
                    }
                }
            }
            _ => {}
        }
        if let Some(p) = &self.participant {
            let (objects, target) = match (&self.trial, self.flow.trial()) {
                // The reference cell holds the target mesh but is not
                // the target to find: never a stop of the search.
                (Some(_), Some(t)) => (
                    self.setup.layout.search_centres(t.reference_cell),
                    Some(self.setup.layout.centre_px(t.target_cell)),
                ),
                _ => (Vec::new(), None),
            };
            // The screen's set-up (the trial's scenes) took time: it starts now.
            let reference = self
                .flow
                .trial()
                .and_then(|t| t.reference_cell)
                .map(|c| self.setup.layout.centre_px(c));
            p.show(phase, self.now(), &objects, target, reference);
        }
    }

    pub(super) fn advance(&mut self) {
        self.checking = None;
        self.flow.advance();
        self.entered();
    }

    pub(super) fn act(&mut self, action: Action) {
        let phase = self.flow.phase();
        match action {
            Action::Space { host_us } => {
                self.marker("key", format!("space {host_us}"));
                match phase {
                    Phase::Instructions
                    | Phase::Rest { .. }
                    | Phase::PracticeOver
                    | Phase::Preview => self.advance(),
                    Phase::Search => {
                        let responded = self.trial.as_mut().is_some_and(|t| t.respond(host_us));
                        if responded {
                            if self.setup.design.response.confirm_click {
                                self.advance();
                            } else {
                                self.end_trial(None);
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
                    self.end_trial(Some(cell));
                }
            }
        }
    }

    /// The trial's response is complete: write it, then the next screen.
    pub(super) fn end_trial(&mut self, click: Option<Option<(u32, u32)>>) {
        // Its eye-movement events are computed on the tracker's clock: wait
        // (at most RESPONSE_SAMPLES_WAIT) until the tracker has delivered
        // the samples captured up to the response, however late delivery is.
        // (A headless simulation has delivered them already: its tracker
        // ticks up to the frame's virtual time before the frame.)
        let waited = std::time::Instant::now();
        while self.clock == RunClock::Host
            && self.trial.as_ref().is_some_and(TrialState::awaits_samples)
            && waited.elapsed() < RESPONSE_SAMPLES_WAIT
        {
            std::thread::sleep(std::time::Duration::from_millis(5));
            self.drain();
        }
        let (Some(state), Some(t)) = (self.trial.take(), self.flow.trial().cloned()) else {
            return;
        };
        if let Some((kept, frames, tolerance)) = state.kept_frames() {
            self.marker(
                "frames-kept",
                format!("{kept} of {frames} search frames showed the frame before again (gaze within {tolerance}° of the gaze it was rendered for; frames.tsv repeats its rays and render time)"),
            );
        }
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
                return self.quit();
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
            return self.quit();
        }
        self.advance();
    }

    /// Ends the session after this frame (the window's handler closes
    /// the event loop; the headless loop stops).
    pub(super) fn quit(&mut self) {
        self.quitting = true;
    }
}
