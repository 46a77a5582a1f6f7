//! Calibration, validation and drift checks while the session runs: the
//! check in progress fed each frame, its outcome against the design's
//! threshold, a recalibration after a failure, and the experimenter's
//! decision after too many.

use experiment::run::flow::Phase;
use experiment::session::MarkerRow;
use tracker_hal::calibration::{validate, Procedure, Session, SessionRequest, TimedPoint};
use tracker_hal::clock::monotonic_us;

use super::state::Runner;
use super::trial;

/// Failed validations before the runner asks the experimenter.
const MAX_CALIBRATION_ATTEMPTS: u32 = 3;

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
