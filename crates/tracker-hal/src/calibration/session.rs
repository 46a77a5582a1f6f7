//! The policy of a calibration session, apart from any window: the
//! calibration run, what happens to rejected targets, when to fit, the
//! validation run, which calibration targets to show again after bad
//! validation points, and when an unattended session saves or stops.
//!
//! The caller (the `gazecast calibrate` window) feeds every sample, draws
//! what [`Session::phase`] and the two runs say, turns keys into the
//! actions ([`Session::start`], [`Session::redo_rejected`], …), writes
//! [`Session::take_log`] to its log and does what
//! [`Session::take_requests`] asks (save, or stop with an error).
//!
//! Policy:
//! - When the calibration run is done and every target was accepted, the
//!   model is fitted. With rejected targets, an attended session waits
//!   ([`SessionPhase::Rejected`]: show them again, or fit without them); an
//!   unattended one shows them again once, then fits without any that are
//!   rejected again.
//! - A successful fit starts the validation run on the calibration run's
//!   schedule ([`Procedure::follow`]); a failed fit is
//!   [`SessionPhase::Failed`] (an unattended session stops).
//! - A validation point is bad when it has no usable data or its accuracy
//!   is worse than `max_error_deg`. Redoing the bad points shows the
//!   calibration target nearest each bad point again ([`nearest_targets`]),
//!   then refits and validates again on all validation targets.
//! - An unattended session asks to be saved as soon as validation is done.

use screen_geometry::ScreenGeometry;

use super::fit::{Calibration, Model};
use super::plan::Plan;
use super::procedure::Procedure;
use super::validation::{validate, PointValidation};
use super::window::TimedPoint;

/// Where a session is.
#[derive(Debug, Clone, PartialEq)]
pub enum SessionPhase {
    /// Waiting for the person to start ([`Session::start`]); samples are
    /// ignored.
    Intro,
    /// The calibration targets are shown.
    Calibrating,
    /// Calibration targets that were not accepted (indices), waiting for
    /// [`Session::redo_rejected`] or [`Session::fit_without_rejected`].
    Rejected(Vec<usize>),
    /// The validation targets are shown.
    Validating,
    /// Validation is done: [`Session::redo_bad`], [`Session::validate_again`]
    /// or save.
    Result,
    /// The fit failed (why): [`Session::start_again`].
    Failed(String),
}

/// What a session asks of its caller (an unattended session only).
#[derive(Debug, Clone, PartialEq)]
pub enum SessionRequest {
    /// Validation is done: save the calibration.
    Save,
    /// The fit failed: stop, with this error.
    Abort(String),
}

/// One validation point's outcome: its measures, or why there are none.
pub type PointResult = Result<PointValidation, String>;

/// Means over the validation points that have data, and how many points
/// are bad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidationSummary {
    /// Mean accuracy, degrees.
    pub accuracy_deg: f64,
    /// Mean sample-to-sample RMS precision, degrees.
    pub precision_rms_deg: f64,
    /// Mean precision as spread around the mean gaze, degrees.
    pub precision_std_deg: f64,
    /// Points without data or with an accuracy worse than the limit.
    pub bad: usize,
}

/// A calibration session: a calibration run, a fit, a validation run, and
/// the decisions between them (see the module doc).
#[derive(Debug, Clone)]
pub struct Session {
    model: Model,
    geometry: ScreenGeometry,
    max_error_deg: f64,
    auto: bool,
    /// Rejected targets were shown again once already (unattended).
    redone: bool,
    cal: Procedure,
    val: Procedure,
    phase: SessionPhase,
    calibration: Option<Calibration>,
    points: Vec<PointResult>,
    log: Vec<String>,
    requests: Vec<SessionRequest>,
}

impl Session {
    /// A session fitting `model` on `calibration`'s targets and validating
    /// on `validation`'s, angles from `geometry`. `auto`: unattended (no
    /// keys: starts at once, decides alone, asks to be saved).
    pub fn new(
        model: Model,
        calibration: Plan,
        validation: Plan,
        geometry: ScreenGeometry,
        max_error_deg: f64,
        auto: bool,
    ) -> Self {
        Self {
            model,
            geometry,
            max_error_deg,
            auto,
            redone: false,
            cal: Procedure::new(calibration),
            val: Procedure::new(validation),
            phase: if auto {
                SessionPhase::Calibrating
            } else {
                SessionPhase::Intro
            },
            calibration: None,
            points: Vec::new(),
            log: Vec::new(),
            requests: Vec::new(),
        }
    }

    /// Where the session stands.
    pub fn phase(&self) -> &SessionPhase {
        &self.phase
    }

    /// The calibration run (its plan, current target and results).
    pub fn calibration_run(&self) -> &Procedure {
        &self.cal
    }

    /// The validation run.
    pub fn validation_run(&self) -> &Procedure {
        &self.val
    }

    /// The fitted calibration, once there is one.
    pub fn calibration(&self) -> Option<&Calibration> {
        self.calibration.as_ref()
    }

    /// Per validation target (in the order of
    /// [`Procedure::results`] of the validation run), its outcome.
    pub fn points(&self) -> &[PointResult] {
        &self.points
    }

    /// The validation accuracy (degrees) above which a point is bad.
    pub fn max_error_deg(&self) -> f64 {
        self.max_error_deg
    }

    /// Whether the session is unattended (starts at once, decides alone).
    pub fn is_auto(&self) -> bool {
        self.auto
    }

    /// What happened since the last call, one line each (targets rejected
    /// and shown again, the fit, targets redone).
    pub fn take_log(&mut self) -> Vec<String> {
        std::mem::take(&mut self.log)
    }

    /// What the session asks of its caller since the last call.
    pub fn take_requests(&mut self) -> Vec<SessionRequest> {
        std::mem::take(&mut self.requests)
    }

    /// Feeds one sample to the run being shown (ignored in the other
    /// phases) and moves on when that run is done.
    pub fn feed(&mut self, sample: TimedPoint) {
        match self.phase {
            SessionPhase::Calibrating => self.cal.feed(sample),
            SessionPhase::Validating => self.val.feed(sample),
            _ => return,
        }
        self.advance();
    }

    /// The person is ready: the calibration targets start (from the intro).
    pub fn start(&mut self) {
        if self.phase == SessionPhase::Intro {
            self.phase = SessionPhase::Calibrating;
        }
        self.advance();
    }

    /// Shows the rejected targets again (from [`SessionPhase::Rejected`]).
    pub fn redo_rejected(&mut self) {
        if let SessionPhase::Rejected(r) = &self.phase {
            for i in r.clone() {
                self.cal.redo(i);
            }
            self.cal.restart();
            self.phase = SessionPhase::Calibrating;
        }
        self.advance();
    }

    /// Fits without the rejected targets (from [`SessionPhase::Rejected`]).
    pub fn fit_without_rejected(&mut self) {
        if matches!(self.phase, SessionPhase::Rejected(_)) {
            self.cal.restart();
            self.fit();
        }
        self.advance();
    }

    /// Runs the calibration again from its first target (from
    /// [`SessionPhase::Failed`]).
    pub fn start_again(&mut self) {
        if matches!(self.phase, SessionPhase::Failed(_)) {
            self.cal = Procedure::new(self.cal.plan.clone());
            self.phase = SessionPhase::Calibrating;
        }
        self.advance();
    }

    /// Shows the calibration target nearest each bad validation point
    /// again, then refits and validates again (from
    /// [`SessionPhase::Result`]). `false` (nothing done) when no point is
    /// bad.
    pub fn redo_bad(&mut self) -> bool {
        let bad = self.bad_points();
        if self.phase != SessionPhase::Result || bad.is_empty() {
            return false;
        }
        let redo = nearest_targets(&self.cal.plan.targets_px, &bad);
        self.log.push(format!(
            "redoing calibration targets {redo:?} (nearest the bad validation points)"
        ));
        for i in redo {
            self.cal.redo(i);
        }
        self.cal.restart();
        self.phase = SessionPhase::Calibrating;
        self.advance();
        true
    }

    /// Runs the validation again with the same calibration (from
    /// [`SessionPhase::Result`]).
    pub fn validate_again(&mut self) {
        if self.phase == SessionPhase::Result {
            self.val = Procedure::new(self.val.plan.clone());
            self.phase = SessionPhase::Validating;
        }
        self.advance();
    }

    /// Validation targets (px) that failed or missed by more than
    /// `max_error_deg`.
    pub fn bad_points(&self) -> Vec<[f64; 2]> {
        self.val
            .results()
            .zip(&self.points)
            .filter(|(_, p)| {
                p.as_ref()
                    .map_or(true, |p| p.accuracy_deg > self.max_error_deg)
            })
            .map(|(r, _)| r.target_px)
            .collect()
    }

    /// Accuracy and precision means over the points with data, and the
    /// number of bad points; `None` when no point has data.
    pub fn summary(&self) -> Option<ValidationSummary> {
        let ok: Vec<&PointValidation> = self.points.iter().flatten().collect();
        if ok.is_empty() {
            return None;
        }
        let n = ok.len() as f64;
        let mean = |f: fn(&PointValidation) -> f64| ok.iter().map(|p| f(p)).sum::<f64>() / n;
        Some(ValidationSummary {
            accuracy_deg: mean(|p| p.accuracy_deg),
            precision_rms_deg: mean(|p| p.precision_rms_deg),
            precision_std_deg: mean(|p| p.precision_std_deg),
            bad: self.bad_points().len(),
        })
    }

    /// Phase changes when a run is done.
    fn advance(&mut self) {
        match self.phase {
            SessionPhase::Calibrating if self.cal.done() => {
                let rejected = self.cal.rejected();
                if rejected.is_empty() {
                    self.fit();
                } else if !self.auto {
                    self.phase = SessionPhase::Rejected(rejected);
                } else if !self.redone {
                    self.redone = true;
                    self.log.push(format!(
                        "calibration targets {rejected:?} rejected: shown again"
                    ));
                    for i in rejected {
                        self.cal.redo(i);
                    }
                } else {
                    self.log.push(format!(
                        "calibration targets {rejected:?} rejected again: fitting without them"
                    ));
                    self.fit();
                }
            }
            SessionPhase::Validating if self.val.done() => {
                self.points = self.validation_points();
                self.phase = SessionPhase::Result;
                if self.auto {
                    self.requests.push(SessionRequest::Save);
                }
            }
            _ => {}
        }
    }

    /// Fits on the accepted targets; validation follows on success.
    fn fit(&mut self) {
        match self.cal.fit(self.model) {
            Ok(c) => {
                self.log.push(format!(
                    "fitted {:?} on {} targets: RMS residual {:.2} px",
                    c.model,
                    c.points.len(),
                    c.rms_residual_px
                ));
                self.calibration = Some(c);
                self.val = Procedure::new(self.val.plan.clone());
                self.val.follow(&self.cal);
                self.phase = SessionPhase::Validating;
            }
            Err(e) => {
                self.log.push(format!("the fit failed: {e}"));
                if self.auto {
                    self.requests
                        .push(SessionRequest::Abort(format!("calibration failed: {e}")));
                }
                self.phase = SessionPhase::Failed(e.to_string());
            }
        }
    }

    /// Each validation target validated on its own.
    fn validation_points(&self) -> Vec<PointResult> {
        let Some(c) = &self.calibration else {
            return Vec::new();
        };
        self.val
            .results()
            .map(|r| {
                let run = [(r.target_px, r.samples.clone())];
                validate(c, &self.geometry, &run)
                    .map(|v| v.points[0])
                    .map_err(|e| e.to_string())
            })
            .collect()
    }
}

/// For each of `points`, the index of the nearest of `targets` (Euclidean
/// distance in px; the first on a tie), each index once, in the order first
/// found.
pub fn nearest_targets(targets: &[[f64; 2]], points: &[[f64; 2]]) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for b in points {
        let nearest = (0..targets.len()).min_by(|&i, &j| {
            let d = |k: usize| (targets[k][0] - b[0]).hypot(targets[k][1] - b[1]);
            d(i).total_cmp(&d(j))
        });
        if let Some(i) = nearest.filter(|i| !out.contains(i)) {
            out.push(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ScreenGeometry {
        crate::test_support::seed_display(600.0)
    }

    /// 9 calibration targets, 4 validation targets, 200 + 400 ms each.
    fn session(auto: bool) -> Session {
        let (cal, val) = crate::test_support::nine_and_four();
        Session::new(Model::Affine, cal, val, geometry(), 0.5, auto)
    }

    /// Feeds 250 Hz samples while targets are shown, until the session
    /// waits: the raw point of an identity tracker is `eye(validating,
    /// target index, target px)`, `None` for closed eyes.
    fn run(
        s: &mut Session,
        t: &mut u64,
        mut eye: impl FnMut(bool, usize, [f64; 2]) -> Option<[f64; 2]>,
    ) {
        for _ in 0..100_000 {
            let (validating, run) = match s.phase() {
                SessionPhase::Calibrating => (false, s.calibration_run()),
                SessionPhase::Validating => (true, s.validation_run()),
                _ => return,
            };
            let raw = run.target().and_then(|(i, at)| eye(validating, i, at));
            s.feed(TimedPoint { t_us: *t, raw });
            *t += 4_000;
        }
        panic!("the session never waited: {:?}", s.phase());
    }

    fn open(_: bool, _: usize, at: [f64; 2]) -> Option<[f64; 2]> {
        Some(at)
    }

    #[test]
    fn unattended_rejected_targets_are_shown_once_more_then_it_saves() {
        let mut s = session(true);
        assert_eq!(s.phase(), &SessionPhase::Calibrating);
        // Eyes closed through the whole first showing of target 4 (150
        // samples), open when it comes again.
        let mut seen4 = 0;
        let mut t = 0;
        run(&mut s, &mut t, |v, i, at| {
            if !v && i == 4 {
                seen4 += 1;
                if seen4 <= 152 {
                    return None;
                }
            }
            Some(at)
        });
        let log = s.take_log();
        assert_eq!(log[0], "calibration targets [4] rejected: shown again");
        assert!(log[1].starts_with("fitted Affine on 9 targets"), "{log:?}");
        assert_eq!(s.phase(), &SessionPhase::Result);
        assert_eq!(s.take_requests(), vec![SessionRequest::Save]);
        let sum = s.summary().expect("points with data");
        assert!(sum.accuracy_deg < 1e-6 && sum.bad == 0, "{sum:?}");
        assert_eq!(s.points().len(), 4);
    }

    #[test]
    fn unattended_targets_rejected_twice_are_left_out() {
        let mut s = session(true);
        let mut t = 0;
        run(&mut s, &mut t, |v, i, at| (v || i != 4).then_some(at));
        let log = s.take_log();
        assert_eq!(
            log[1],
            "calibration targets [4] rejected again: fitting without them"
        );
        assert_eq!(s.calibration().expect("fitted").points.len(), 8);
        assert_eq!(s.take_requests(), vec![SessionRequest::Save]);
    }

    #[test]
    fn an_attended_session_waits_for_the_person() {
        let mut s = session(false);
        // Before the start, samples are not the person's.
        s.feed(TimedPoint {
            t_us: 0,
            raw: Some([0.0, 0.0]),
        });
        assert_eq!(s.phase(), &SessionPhase::Intro);
        assert_eq!(s.calibration_run().results().count(), 0);
        s.start();
        let mut t = 0;
        run(&mut s, &mut t, |v, i, at| (v || i != 4).then_some(at));
        assert_eq!(s.phase(), &SessionPhase::Rejected(vec![4]));
        let mut other = s.clone();
        // Show them again: now accepted, fitted on all 9.
        s.redo_rejected();
        assert_eq!(s.calibration_run().target().map(|t| t.0), Some(4));
        // (`run` goes on through the validation that follows the fit.)
        run(&mut s, &mut t, open);
        assert_eq!(s.phase(), &SessionPhase::Result);
        assert_eq!(s.calibration().expect("fitted").points.len(), 9);
        // Attended: nothing is saved without the person.
        assert!(s.take_requests().is_empty());
        // Or fit without them.
        other.fit_without_rejected();
        assert_eq!(other.phase(), &SessionPhase::Validating);
        assert_eq!(other.calibration().expect("fitted").points.len(), 8);
    }

    #[test]
    fn bad_validation_points_redo_the_nearest_calibration_target() {
        let mut s = session(false);
        s.start();
        let mut t = 0;
        // Validation target 0 (320, 256) is missed by 40 px (about 1°).
        let eye = |v: bool, i: usize, at: [f64; 2]| {
            Some(if v && i == 0 {
                [at[0] + 40.0, at[1]]
            } else {
                at
            })
        };
        run(&mut s, &mut t, eye);
        assert_eq!(s.phase(), &SessionPhase::Result);
        assert_eq!(s.bad_points(), vec![[320.0, 256.0]]);
        assert_eq!(s.summary().expect("data").bad, 1);
        s.take_log();
        assert!(s.redo_bad());
        assert_eq!(
            s.take_log(),
            vec!["redoing calibration targets [0] (nearest the bad validation points)"]
        );
        assert_eq!(s.phase(), &SessionPhase::Calibrating);
        assert_eq!(s.calibration_run().target().map(|t| t.0), Some(0));
        // The refit is followed by the whole validation again (the
        // person now looks at every target).
        run(&mut s, &mut t, open);
        assert_eq!(s.phase(), &SessionPhase::Result);
        assert_eq!(s.validation_run().results().count(), 4);
        assert!(s.bad_points().is_empty());
        assert!(!s.redo_bad(), "nothing to redo");
        s.validate_again();
        assert_eq!(s.phase(), &SessionPhase::Validating);
        assert_eq!(s.validation_run().results().count(), 0);
    }

    #[test]
    fn a_failed_fit_stops_an_unattended_session_and_waits_in_an_attended_one() {
        let mut s = session(true);
        let mut t = 0;
        run(&mut s, &mut t, |_, _, _| None);
        assert!(
            matches!(s.phase(), SessionPhase::Failed(_)),
            "{:?}",
            s.phase()
        );
        let r = s.take_requests();
        assert!(
            matches!(&r[..], [SessionRequest::Abort(e)] if e.starts_with("calibration failed: ")),
            "{r:?}"
        );
        let mut s = session(false);
        s.start();
        run(&mut s, &mut t, |_, _, _| None);
        s.fit_without_rejected();
        assert!(matches!(s.phase(), SessionPhase::Failed(_)));
        assert!(s.take_requests().is_empty());
        s.start_again();
        assert_eq!(s.phase(), &SessionPhase::Calibrating);
        assert_eq!(s.calibration_run().results().count(), 0);
    }

    #[test]
    fn nearest_targets_are_found_once_each() {
        let targets = [[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]];
        assert_eq!(
            nearest_targets(&targets, &[[90.0, 5.0], [80.0, -5.0], [1.0, 60.0]]),
            vec![1, 2]
        );
        // A tie goes to the first target.
        assert_eq!(nearest_targets(&targets, &[[50.0, 0.0]]), vec![0]);
        assert!(nearest_targets(&[], &[[1.0, 1.0]]).is_empty());
    }
}
