//! Calibration, validation and drift checks while the session runs: the
//! check in progress fed each frame, its outcome
//! (`experiment::run::acceptance`), a recalibration after a failure, and
//! the experimenter's decision after too many.

use experiment::run::acceptance::{
    calibration_outcome, validation_outcome, MAX_CALIBRATION_ATTEMPTS,
};
use experiment::run::flow::Phase;
use experiment::session::{CalibrationMarker, MarkerRow, CALIBRATION_MARKER};
use tracker_hal::calibration::{Procedure, Session, SessionRequest, TimedPoint};

use super::state::Runner;
use super::trial;

/// A calibration or validation in progress.
pub(super) enum Checking {
    /// Full calibration (the unattended session policy of tracker-hal).
    Calibrating(Box<Session>),
    /// Validation or drift check of the calibration in use.
    Validating { procedure: Procedure, drift: bool },
    /// Failed too often: the experimenter decides (Space / R).
    Decide(String),
}

impl Runner<'_> {
    /// Calibration and validation bookkeeping once per frame.
    pub(super) fn check(&mut self) {
        let now = self.now();
        let mut outcome: Option<Result<String, String>> = None;
        let mut target = None;
        match &mut self.checking {
            Some(Checking::Calibrating(s)) => {
                let log = s.take_log();
                let requests = s.take_requests();
                for l in log {
                    self.dir.marker(&MarkerRow {
                        sitting: self.dir.sitting(),
                        host_us: now,
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
                            if let Some(m) = calibration_marker(s) {
                                self.dir.marker(&MarkerRow {
                                    sitting: self.dir.sitting(),
                                    host_us: now,
                                    trial: self.flow.trial().map(|t| t.index),
                                    event: CALIBRATION_MARKER.into(),
                                    detail: m.to_detail(),
                                });
                            }
                            outcome = Some(calibration_outcome(&self.setup.design, summary));
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
                    outcome = Some(validation_outcome(
                        &self.setup.design,
                        *drift,
                        self.calibration.as_ref(),
                        &self.setup.geometry,
                        &runs,
                    ));
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

    pub(super) fn canvas_target(&mut self, target: Option<[f64; 2]>) {
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
}

/// The calibration's fields for the BIDS export: the targets shown, the
/// ones fitted, and the validation's mean and worst accuracy; `None`
/// without a fit or a validation point with data.
fn calibration_marker(s: &Session) -> Option<CalibrationMarker> {
    let c = s.calibration()?;
    let summary = s.summary()?;
    let maximal_deg = s
        .points()
        .iter()
        .flatten()
        .map(|p| p.accuracy_deg)
        .fold(f64::NEG_INFINITY, f64::max);
    let m = CalibrationMarker {
        targets: s.calibration_run().plan.targets_px.len(),
        positions_px: c.points.iter().map(|p| p.1).collect(),
        average_deg: summary.accuracy_deg,
        maximal_deg,
    };
    // Only finite values: JSON has no NaN (the export reads it back).
    CalibrationMarker::from_detail(&m.to_detail()).ok()
}
