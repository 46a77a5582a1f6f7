//! The order of screens in a session, apart from any window: instructions,
//! then for each trial the steps the plan puts before it (breaks,
//! calibration, validation, drift checks), the target preview, the search
//! display and, when the design asks, the confirming click.
//!
//! The runner asks [`Flow::phase`] what to show and calls
//! [`Flow::advance`] when the screen is done ([`Flow::recalibrate`] when a
//! validation fails). A resumed session starts at its first unfinished
//! trial with a calibration and validation of its own: a new sitting needs
//! a new calibration.

use std::collections::VecDeque;

use crate::{Step, Trial};

/// One screen of the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// What the participant will do; Space starts.
    Instructions,
    /// A rest: within a run (`between_runs == false`) or between runs.
    Rest {
        /// Whether the rest falls between two runs (else within a run).
        between_runs: bool,
    },
    /// Full calibration (targets, fit) followed by its validation.
    Calibration,
    /// Validation of the calibration in use; `midpoint` for the session's
    /// mid-point check. Above the design's threshold: recalibrate.
    Validation {
        /// Whether this is the session's mid-point check.
        midpoint: bool,
    },
    /// Single-target drift check.
    DriftCheck,
    /// The practice trials are over (Murphy 2007 §7.1.5: questions, a
    /// stretch); Space starts the experiment.
    PracticeOver,
    /// The trial's target alone at the centre, as long as wanted; Space
    /// starts the search.
    Preview,
    /// The search display; Space ends the search.
    Search,
    /// Click on the object found.
    Confirm,
    /// The session is over.
    Done,
}

impl Phase {
    /// Name used in the data files' `phase` column.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Instructions => "instructions",
            Phase::Rest {
                between_runs: false,
            } => "break",
            Phase::Rest { between_runs: true } => "run-break",
            Phase::Calibration => "calibration",
            Phase::Validation { midpoint: false } => "validation",
            Phase::Validation { midpoint: true } => "midpoint-validation",
            Phase::DriftCheck => "drift-check",
            Phase::PracticeOver => "practice-over",
            Phase::Preview => "preview",
            Phase::Search => "search",
            Phase::Confirm => "confirm",
            Phase::Done => "done",
        }
    }

    /// Whether the phase belongs to a trial (its samples carry the trial).
    pub fn in_trial(self) -> bool {
        matches!(self, Phase::Preview | Phase::Search | Phase::Confirm)
    }

    /// The data files' name of the phase in a practice trial
    /// (`practice-search`, …) or an experimental one ([`Phase::name`]):
    /// what marks practice rows in the samples, frames and markers.
    pub fn name_in(self, practice: bool) -> &'static str {
        match self {
            Phase::Preview if practice => "practice-preview",
            Phase::Search if practice => "practice-search",
            Phase::Confirm if practice => "practice-confirm",
            p => p.name(),
        }
    }
}

/// Where a session is.
#[derive(Debug, Clone)]
pub struct Flow {
    trials: Vec<Trial>,
    /// Index into `trials` of the trial the queued phases lead to.
    trial: usize,
    queue: VecDeque<Phase>,
    phase: Phase,
    confirm_click: bool,
}

fn step_phase(s: Step) -> Phase {
    match s {
        Step::RunBreak => Phase::Rest { between_runs: true },
        Step::Break => Phase::Rest {
            between_runs: false,
        },
        Step::Calibration => Phase::Calibration,
        Step::Validation => Phase::Validation { midpoint: false },
        Step::MidpointValidation => Phase::Validation { midpoint: true },
        Step::DriftCheck => Phase::DriftCheck,
        Step::PracticeOver => Phase::PracticeOver,
    }
}

impl Flow {
    /// A session over `trials` (the participant's whole plan) starting at
    /// trial index `start` (0, or the first unfinished one with
    /// `--resume`). `calibrate_first`: begin with a calibration and
    /// validation even where the plan has none before `start` (a resumed
    /// sitting; a design whose calibration is off at the start leaves it
    /// false for a fresh session).
    pub fn new(
        trials: Vec<Trial>,
        start: usize,
        confirm_click: bool,
        calibrate_first: bool,
    ) -> Self {
        let mut f = Self {
            trials,
            trial: start,
            queue: VecDeque::new(),
            phase: Phase::Instructions,
            confirm_click,
        };
        if calibrate_first {
            f.queue.push_back(Phase::Calibration);
            f.queue.push_back(Phase::Validation { midpoint: false });
        }
        f.queue_trial(calibrate_first);
        f
    }

    fn queue_trial(&mut self, calibrated: bool) {
        let Some(t) = self.trials.get(self.trial) else {
            self.queue.push_back(Phase::Done);
            return;
        };
        for &s in &t.before {
            let p = step_phase(s);
            // A fresh calibration already validates; drop the plan's own.
            if calibrated
                && matches!(
                    p,
                    Phase::Calibration | Phase::Validation { .. } | Phase::DriftCheck
                )
            {
                continue;
            }
            self.queue.push_back(p);
        }
        self.queue.push_back(Phase::Preview);
        self.queue.push_back(Phase::Search);
        if self.confirm_click {
            self.queue.push_back(Phase::Confirm);
        }
    }

    /// The screen to show now.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The current screen's name in the data files: [`Phase::name_in`]
    /// with whether its trial is a practice trial.
    pub fn phase_name(&self) -> &'static str {
        let practice = self.phase.in_trial() && self.trial().is_some_and(|t| t.practice);
        self.phase.name_in(practice)
    }

    /// The trial the current screen belongs to or leads to (`None` once
    /// every trial is done).
    pub fn trial(&self) -> Option<&Trial> {
        self.trials.get(self.trial)
    }

    /// Every trial of the plan.
    pub fn trials(&self) -> &[Trial] {
        &self.trials
    }

    /// The current screen is done: the next one. After the last screen of
    /// a trial the next trial's screens are queued.
    pub fn advance(&mut self) {
        if self.phase == Phase::Done {
            return;
        }
        let ends_trial = match self.phase {
            Phase::Search => !self.confirm_click,
            Phase::Confirm => true,
            _ => false,
        };
        if ends_trial {
            self.trial += 1;
            self.queue.clear();
            self.queue_trial(false);
        }
        self.phase = self.queue.pop_front().unwrap_or(Phase::Done);
    }

    /// A validation or drift check failed: calibrate and validate again
    /// before going on.
    pub fn recalibrate(&mut self) {
        self.queue.push_front(Phase::Validation { midpoint: false });
        self.queue.push_front(Phase::Calibration);
        self.phase = self.queue.pop_front().unwrap_or(Phase::Done);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::Design;

    fn murphy() -> Vec<Trial> {
        let d = Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design");
        crate::plan(&d, 0).expect("plan")
    }

    /// Walks a flow to its end, answering every screen; returns the
    /// phases in order with the trial index they belong to.
    fn walk(mut f: Flow, fail_validations: usize) -> Vec<(Phase, Option<usize>)> {
        let mut seen = Vec::new();
        let mut fails = fail_validations;
        for _ in 0..10_000 {
            let p = f.phase();
            seen.push((p, f.trial().map(|t| t.index)));
            if p == Phase::Done {
                break;
            }
            if matches!(p, Phase::Validation { .. }) && fails > 0 {
                fails -= 1;
                f.recalibrate();
            } else {
                f.advance();
            }
        }
        seen
    }

    #[test]
    fn the_seed_session_runs_every_trial_with_its_steps_in_order() {
        let seen = walk(Flow::new(murphy(), 0, false, false), 0);
        assert_eq!(seen.last().map(|s| s.0), Some(Phase::Done));
        let searches: Vec<usize> = seen
            .iter()
            .filter(|s| s.0 == Phase::Search)
            .filter_map(|s| s.1)
            .collect();
        assert_eq!(searches, (0..44).collect::<Vec<_>>());
        let names: Vec<&str> = seen.iter().take(5).map(|s| s.0.name()).collect();
        assert_eq!(
            names,
            [
                "instructions",
                "calibration",
                "validation",
                "preview",
                "search"
            ]
        );
        // The mid-point validation comes before trial 22's preview.
        let i = seen
            .iter()
            .position(|s| s.0 == Phase::Validation { midpoint: true })
            .expect("midpoint validation");
        assert_eq!(seen[i].1, Some(22));
        assert_eq!(seen[i + 1], (Phase::Preview, Some(22)));
        let rests = seen
            .iter()
            .filter(|s| matches!(s.0, Phase::Rest { .. }))
            .count();
        assert_eq!(rests, 4 + 3);
    }

    #[test]
    fn a_failed_validation_recalibrates_then_goes_on() {
        let seen = walk(Flow::new(murphy(), 0, true, false), 2);
        let first: Vec<&str> = seen.iter().take(8).map(|s| s.0.name()).collect();
        assert_eq!(
            first,
            [
                "instructions",
                "calibration",
                "validation",
                "calibration",
                "validation",
                "calibration",
                "validation",
                "preview"
            ]
        );
        // With the click: search, confirm, then the next trial.
        let k = seen
            .iter()
            .position(|s| s.0 == Phase::Search)
            .expect("search");
        assert_eq!(seen[k + 1].0, Phase::Confirm);
        assert_eq!(seen[k + 2], (Phase::Preview, Some(1)));
    }

    #[test]
    fn a_resumed_session_calibrates_and_starts_at_its_trial() {
        let seen = walk(Flow::new(murphy(), 22, false, true), 0);
        let first: Vec<(&str, Option<usize>)> =
            seen.iter().take(5).map(|s| (s.0.name(), s.1)).collect();
        // Trial 22's own run break stays; its mid-point validation is the
        // fresh calibration's.
        assert_eq!(
            first,
            [
                ("instructions", Some(22)),
                ("calibration", Some(22)),
                ("validation", Some(22)),
                ("run-break", Some(22)),
                ("preview", Some(22)),
            ]
        );
        let searches = seen.iter().filter(|s| s.0 == Phase::Search).count();
        assert_eq!(searches, 22);
        // Past the end: done at once.
        let end = walk(Flow::new(murphy(), 44, false, true), 0);
        assert_eq!(end.last().map(|s| s.0), Some(Phase::Done));
    }

    /// With practice, the data files name the practice trials' screens
    /// `practice-preview`, `practice-search` (and confirm), and the screen
    /// that ends practice comes before the first experimental trial.
    #[test]
    fn practice_screens_are_named_as_practice() {
        let mut d = Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design");
        d.practice = Some(crate::design::Practice {
            trials: 2,
            condition: "control".into(),
        });
        let mut f = Flow::new(crate::plan(&d, 0).expect("plan"), 0, true, false);
        let mut names = Vec::new();
        while f.phase() != Phase::Done && names.len() < 40 {
            names.push((f.phase_name(), f.trial().map(|t| t.index)));
            f.advance();
        }
        assert_eq!(
            names[..12],
            [
                ("instructions", Some(0)),
                ("calibration", Some(0)),
                ("validation", Some(0)),
                ("practice-preview", Some(0)),
                ("practice-search", Some(0)),
                ("practice-confirm", Some(0)),
                ("practice-preview", Some(1)),
                ("practice-search", Some(1)),
                ("practice-confirm", Some(1)),
                ("practice-over", Some(2)),
                ("preview", Some(2)),
                ("search", Some(2)),
            ]
        );
    }
}
