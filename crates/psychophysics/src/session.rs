//! Interleaved staircases over a frequency × eccentricity grid.
//!
//! One staircase (QUEST or up-down) runs per condition; a seeded ChaCha8
//! generator picks the next trial's condition uniformly among the
//! conditions not yet finished, so the participant cannot predict it. The
//! loop is `next_trial → show, get a response → record`, with no window
//! needed: [`Session::next_trial`] says what to show, [`Session::record`]
//! (a participant) or [`Session::record_synthetic`] (a
//! [`crate::observer::SimulatedObserver`]) takes the answer.
//!
//! # Stopping rules
//!
//! A QUEST condition finishes after `trials_per_condition` valid trials
//! (or earlier if `stop_sd_log10` is set and its posterior sd falls below
//! it); an up-down condition after its own rules (reversals or trials) or
//! `trials_per_condition` valid trials, whichever first. The session ends
//! when every condition has finished.
//!
//! # Lapses
//!
//! Two kinds are handled. Blind answers (a blink, a lapse of attention) are
//! in QUEST's likelihood as δ. Answers whose response time lies outside
//! `valid_rt_ms` (an anticipation, or a participant who looked away) are
//! recorded as invalid and not given to the staircase; the condition comes
//! up again later. A condition with `max_invalid_per_condition` invalid
//! answers is abandoned (finished, no threshold).
//!
//! # Censoring
//!
//! A threshold estimate within `censor_margin_log10` of the highest
//! contrast the display can show (or above it) is *censored*: the display
//! cannot measure it, and the fit leaves it out.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use foveation::GeislerPerry;

use crate::observer::SyntheticResponse;
use crate::quest::{Quest, QuestParams};
use crate::staircase::{Staircase, StaircaseParams};
use crate::ParamError;

/// One answer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Response {
    /// Was the answer right (the interval or location holding the patch)?
    pub correct: bool,
    /// Response time, ms.
    pub rt_ms: f64,
}

/// The procedure every condition runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Procedure {
    /// QUEST; `t_guess` is replaced per condition when
    /// [`SessionSpec::prior_from_default_csf`] is set.
    Quest(QuestParams),
    /// An up-down staircase; `start` likewise.
    Staircase(StaircaseParams),
}

/// A session's design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionSpec {
    /// Spatial frequencies, cycles/degree, strictly increasing, > 0.
    pub frequencies_cpd: Vec<f64>,
    /// Eccentricities, degrees, strictly increasing, ≥ 0.
    pub eccentricities_deg: Vec<f64>,
    /// The staircase each condition runs.
    pub procedure: Procedure,
    /// Valid trials per condition (QUEST: exactly, unless `stop_sd_log10`;
    /// up-down: at most). ≥ 1.
    pub trials_per_condition: u32,
    /// QUEST only: also stop a condition once its posterior sd (log10) is
    /// below this.
    pub stop_sd_log10: Option<f64>,
    /// Centre each condition's prior (QUEST `t_guess`) on the default
    /// Geisler–Perry threshold (Geisler & Perry 1998), or start an up-down
    /// staircase 0.3 log10 units above it, clamped to the display's range.
    pub prior_from_default_csf: bool,
    /// Response times (ms) accepted as valid, (min, max).
    pub valid_rt_ms: (f64, f64),
    /// Invalid answers after which a condition is abandoned (≥ 1).
    pub max_invalid_per_condition: u32,
    /// Estimates this close (log10) to the highest contrast are censored.
    pub censor_margin_log10: f64,
    /// Seed of the condition order.
    pub seed: u64,
}

impl Default for SessionSpec {
    /// A 5 × 4 grid (1–16 cpd, 0–10°), QUEST with 40 trials each.
    fn default() -> Self {
        Self {
            frequencies_cpd: vec![1.0, 2.0, 4.0, 8.0, 16.0],
            eccentricities_deg: vec![0.0, 2.5, 5.0, 10.0],
            procedure: Procedure::Quest(QuestParams::default()),
            trials_per_condition: 40,
            stop_sd_log10: None,
            prior_from_default_csf: true,
            valid_rt_ms: (150.0, 3000.0),
            max_invalid_per_condition: 20,
            censor_margin_log10: 0.1,
            seed: 1,
        }
    }
}

/// A grid axis: one to 64 values, each finite and above 0
/// (`min_exclusive`) or at 0 and above, in increasing order. (The 2IFC and
/// the ramp sessions share it.)
pub(crate) fn axis(field: &'static str, v: &[f64], min_exclusive: bool) -> Result<(), ParamError> {
    if v.is_empty() {
        return Err(ParamError::new(field, "[]", "needs at least one value"));
    }
    if v.len() > 64 {
        return Err(ParamError::new(field, v.len(), "at most 64 values"));
    }
    for (i, x) in v.iter().enumerate() {
        let ok = x.is_finite() && if min_exclusive { *x > 0.0 } else { *x >= 0.0 };
        if !ok {
            let bound = if min_exclusive { "> 0" } else { "≥ 0" };
            return Err(ParamError::new(
                field,
                x,
                format!("entry {i} must be finite and {bound}"),
            ));
        }
        if i > 0 && *x <= v[i - 1] {
            return Err(ParamError::new(
                field,
                x,
                format!("entry {i} must be above entry {}", i - 1),
            ));
        }
    }
    Ok(())
}

impl SessionSpec {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<(), ParamError> {
        axis("frequencies_cpd", &self.frequencies_cpd, true)?;
        axis("eccentricities_deg", &self.eccentricities_deg, false)?;
        match &self.procedure {
            Procedure::Quest(q) => q.validate()?,
            Procedure::Staircase(s) => s.validate()?,
        }
        if !(1..=10_000).contains(&self.trials_per_condition) {
            return Err(ParamError::new(
                "trials_per_condition",
                self.trials_per_condition,
                "must be 1 to 10000",
            ));
        }
        if let Some(sd) = self.stop_sd_log10 {
            if !(sd.is_finite() && sd > 0.0) {
                return Err(ParamError::new(
                    "stop_sd_log10",
                    sd,
                    "must be finite and > 0",
                ));
            }
        }
        let (lo, hi) = self.valid_rt_ms;
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
            return Err(ParamError::new(
                "valid_rt_ms",
                format!("({lo}, {hi})"),
                "needs finite 0 ≤ min < max",
            ));
        }
        if self.max_invalid_per_condition == 0 {
            return Err(ParamError::new(
                "max_invalid_per_condition",
                0,
                "must be at least 1",
            ));
        }
        if !(self.censor_margin_log10.is_finite() && self.censor_margin_log10 >= 0.0) {
            return Err(ParamError::new(
                "censor_margin_log10",
                self.censor_margin_log10,
                "must be finite and ≥ 0",
            ));
        }
        Ok(())
    }
}

impl SessionSpec {
    /// The design with its highest intensity lowered to log10 of
    /// `max_contrast` (the display's limit, e.g.
    /// [`crate::luminance::Transfer::max_contrast`]) when that is lower.
    /// `max_contrast` must be finite and in (0, 1].
    pub fn limited_to_contrast(mut self, max_contrast: f64) -> Result<Self, ParamError> {
        if !(max_contrast.is_finite() && max_contrast > 0.0 && max_contrast <= 1.0) {
            return Err(ParamError::new(
                "max_contrast",
                max_contrast,
                "must be a Michelson contrast in (0, 1]",
            ));
        }
        let top = max_contrast.log10();
        let (max, min) = match &mut self.procedure {
            Procedure::Quest(q) => (&mut q.max_intensity, q.min_intensity),
            Procedure::Staircase(s) => {
                s.start = s.start.min(top);
                (&mut s.max_intensity, s.min_intensity)
            }
        };
        if top <= min {
            return Err(ParamError::new(
                "max_contrast",
                max_contrast,
                format!("is at or below the design's lowest intensity (log10 {min})"),
            ));
        }
        *max = max.min(top);
        Ok(self)
    }
}

/// One condition's staircase.
#[derive(Debug, Clone, PartialEq)]
pub enum Track {
    /// A QUEST posterior.
    Quest(Quest),
    /// An up-down staircase.
    Staircase(Staircase),
}

impl Track {
    fn next_intensity(&self) -> f64 {
        match self {
            Track::Quest(q) => q.next_intensity(),
            Track::Staircase(s) => s.next_intensity(),
        }
    }

    /// Threshold estimate, log10 contrast.
    pub fn estimate(&self) -> f64 {
        match self {
            Track::Quest(q) => q.estimate(),
            Track::Staircase(s) => s.estimate(),
        }
    }

    /// Uncertainty of the estimate, log10: QUEST's posterior sd, or the
    /// up-down reversals' standard error (its current step before two
    /// reversals).
    pub fn spread(&self) -> f64 {
        match self {
            Track::Quest(q) => q.sd(),
            Track::Staircase(s) => s.standard_error().unwrap_or(s.step()),
        }
    }

    fn max_intensity(&self) -> f64 {
        match self {
            Track::Quest(q) => q.params().max_intensity,
            Track::Staircase(s) => s.params().max_intensity,
        }
    }
}

/// What to show next.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Trial {
    /// Position in the session, from 0 (invalid trials included).
    pub index: u32,
    /// Condition index: `eccentricity index × frequencies + frequency index`.
    pub condition: usize,
    /// Spatial frequency, cycles/degree.
    pub frequency_cpd: f64,
    /// Eccentricity, degrees.
    pub eccentricity_deg: f64,
    /// The contrast, log10.
    pub log10_contrast: f64,
    /// The Michelson contrast to show.
    pub contrast: f64,
}

/// One trial as recorded, with the staircase's state after it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// The trial shown.
    pub trial: Trial,
    /// The answer.
    pub response: Response,
    /// Was it given to the staircase (response time within `valid_rt_ms`)?
    pub valid: bool,
    /// The condition's estimate after this trial, log10 contrast.
    pub estimate_log10: f64,
    /// Its spread after this trial, log10 ([`Track::spread`]).
    pub spread_log10: f64,
    /// Up-down: reversals so far (0 for QUEST).
    pub reversals: u32,
    /// Did this trial finish its condition?
    pub finished_condition: bool,
}

/// A condition's result.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConditionResult {
    /// Spatial frequency, cycles/degree.
    pub frequency_cpd: f64,
    /// Eccentricity, degrees.
    pub eccentricity_deg: f64,
    /// Threshold estimate, log10 contrast.
    pub log10_threshold: f64,
    /// Its spread, log10 ([`Track::spread`]).
    pub sd_log10: f64,
    /// The threshold contrast, `10^log10_threshold`.
    pub threshold: f64,
    /// Trials given to the staircase.
    pub valid_trials: u32,
    /// Trials recorded as invalid.
    pub invalid_trials: u32,
    /// At or above the display's highest contrast (module doc).
    pub censored: bool,
    /// Abandoned after too many invalid answers.
    pub abandoned: bool,
}

/// A running session.
#[derive(Debug, Clone)]
pub struct Session {
    spec: SessionSpec,
    tracks: Vec<Track>,
    invalid: Vec<u32>,
    rng: ChaCha8Rng,
    pending: Option<Trial>,
    records: Vec<TrialRecord>,
    synthetic: bool,
}

impl Session {
    /// Validates the design and sets up one staircase per condition.
    pub fn new(spec: SessionSpec) -> Result<Self, ParamError> {
        spec.validate()?;
        let model = GeislerPerry::default();
        let mut tracks = Vec::new();
        for &e in &spec.eccentricities_deg {
            for &f in &spec.frequencies_cpd {
                let guess = model.contrast_threshold(f, e).log10();
                let track = match spec.procedure {
                    Procedure::Quest(mut q) => {
                        if spec.prior_from_default_csf {
                            q.t_guess = guess.clamp(q.min_intensity, q.max_intensity);
                        }
                        Track::Quest(Quest::new(q)?)
                    }
                    Procedure::Staircase(mut s) => {
                        if spec.prior_from_default_csf {
                            s.start = (guess + 0.3).clamp(s.min_intensity, s.max_intensity);
                        }
                        Track::Staircase(Staircase::new(s)?)
                    }
                };
                tracks.push(track);
            }
        }
        Ok(Self {
            invalid: vec![0; tracks.len()],
            tracks,
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            pending: None,
            records: Vec::new(),
            synthetic: false,
            spec,
        })
    }

    /// The design.
    pub fn spec(&self) -> &SessionSpec {
        &self.spec
    }

    /// The staircases, in condition order.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Every trial recorded so far.
    pub fn records(&self) -> &[TrialRecord] {
        &self.records
    }

    /// Has any answer come from a simulated observer? Then everything
    /// made from this session is synthetic.
    pub fn is_synthetic(&self) -> bool {
        self.synthetic
    }

    fn valid_trials(&self, c: usize) -> usize {
        match &self.tracks[c] {
            Track::Quest(q) => q.trials().len(),
            Track::Staircase(s) => s.trials().len(),
        }
    }

    fn condition_finished(&self, c: usize) -> bool {
        if self.invalid[c] >= self.spec.max_invalid_per_condition {
            return true;
        }
        if self.valid_trials(c) >= self.spec.trials_per_condition as usize {
            return true;
        }
        match &self.tracks[c] {
            Track::Quest(q) => self
                .spec
                .stop_sd_log10
                .is_some_and(|sd| !q.trials().is_empty() && q.sd() < sd),
            Track::Staircase(s) => s.is_finished(),
        }
    }

    /// Has every condition finished?
    pub fn is_finished(&self) -> bool {
        (0..self.tracks.len()).all(|c| self.condition_finished(c))
    }

    /// The next trial, or `None` when the session is over. Asking again
    /// before recording an answer gives the same trial.
    pub fn next_trial(&mut self) -> Option<Trial> {
        if let Some(t) = self.pending {
            return Some(t);
        }
        let open: Vec<usize> = (0..self.tracks.len())
            .filter(|&c| !self.condition_finished(c))
            .collect();
        if open.is_empty() {
            return None;
        }
        let c = open[self.rng.random_range(0..open.len())];
        let nf = self.spec.frequencies_cpd.len();
        let x = self.tracks[c].next_intensity();
        let t = Trial {
            index: self.records.len() as u32,
            condition: c,
            frequency_cpd: self.spec.frequencies_cpd[c % nf],
            eccentricity_deg: self.spec.eccentricities_deg[c / nf],
            log10_contrast: x,
            contrast: 10f64.powf(x),
        };
        self.pending = Some(t);
        Some(t)
    }

    /// Records a participant's answer to `trial`, which must be the one
    /// [`Self::next_trial`] gave last.
    pub fn record(&mut self, trial: &Trial, response: Response) -> Result<(), ParamError> {
        if self.pending != Some(*trial) {
            return Err(ParamError::new(
                "trial",
                trial.index,
                "is not the trial awaiting an answer (ask next_trial first, answer once)",
            ));
        }
        if response.rt_ms.is_nan() {
            return Err(ParamError::new(
                "rt_ms",
                response.rt_ms,
                "must be a number (ms)",
            ));
        }
        self.pending = None;
        let c = trial.condition;
        let (lo, hi) = self.spec.valid_rt_ms;
        let valid = (lo..=hi).contains(&response.rt_ms);
        if valid {
            match &mut self.tracks[c] {
                Track::Quest(q) => q.update(trial.log10_contrast, response.correct)?,
                Track::Staircase(s) => s.update(response.correct),
            }
        } else {
            self.invalid[c] += 1;
        }
        let track = &self.tracks[c];
        let reversals = match track {
            Track::Quest(_) => 0,
            Track::Staircase(s) => s.reversals().len() as u32,
        };
        self.records.push(TrialRecord {
            trial: *trial,
            response,
            valid,
            estimate_log10: track.estimate(),
            spread_log10: track.spread(),
            reversals,
            finished_condition: self.condition_finished(c),
        });
        Ok(())
    }

    /// Records a simulated observer's answer; the session becomes synthetic.
    pub fn record_synthetic(
        &mut self,
        trial: &Trial,
        response: SyntheticResponse,
    ) -> Result<(), ParamError> {
        self.record(trial, response.0)?;
        self.synthetic = true;
        Ok(())
    }

    /// Every condition's result, in condition order.
    pub fn results(&self) -> Vec<ConditionResult> {
        let nf = self.spec.frequencies_cpd.len();
        self.tracks
            .iter()
            .enumerate()
            .map(|(c, track)| {
                let est = track.estimate();
                ConditionResult {
                    frequency_cpd: self.spec.frequencies_cpd[c % nf],
                    eccentricity_deg: self.spec.eccentricities_deg[c / nf],
                    log10_threshold: est,
                    sd_log10: track.spread(),
                    threshold: 10f64.powf(est),
                    valid_trials: self.valid_trials(c) as u32,
                    invalid_trials: self.invalid[c],
                    censored: est >= track.max_intensity() - self.spec.censor_margin_log10,
                    abandoned: self.invalid[c] >= self.spec.max_invalid_per_condition,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::{ObserverSpec, SimulatedObserver};

    fn observer(rt_log_sd: f64) -> SimulatedObserver {
        SimulatedObserver::new(ObserverSpec {
            csf: GeislerPerry::default(),
            beta: 3.5,
            lapse_rate: 0.02,
            guess_rate: 0.5,
            p_threshold: 0.82,
            rt_median_ms: 550.0,
            rt_log_sd,
            seed: 3,
        })
        .unwrap()
    }

    fn run(spec: SessionSpec, obs: &mut SimulatedObserver) -> Session {
        let mut s = Session::new(spec).unwrap();
        while let Some(t) = s.next_trial() {
            let r = obs
                .respond(t.frequency_cpd, t.eccentricity_deg, t.contrast)
                .unwrap();
            s.record_synthetic(&t, r).unwrap();
        }
        s
    }

    #[test]
    fn interleaves_conditions_and_stops() {
        let spec = SessionSpec {
            trials_per_condition: 10,
            ..SessionSpec::default()
        };
        let s = run(spec.clone(), &mut observer(0.3));
        assert!(s.is_synthetic());
        assert_eq!(s.records().len(), 200);
        // Interleaved: the first 20 trials visit many conditions.
        let mut seen: Vec<usize> = s.records()[..20]
            .iter()
            .map(|r| r.trial.condition)
            .collect();
        seen.sort();
        seen.dedup();
        assert!(seen.len() >= 8, "{seen:?}");
        assert!(s.results().iter().all(|r| r.valid_trials == 10));
        // The same seed gives the same order.
        let again = run(spec, &mut observer(0.3));
        assert_eq!(again.records(), s.records());
    }

    #[test]
    fn out_of_range_response_times_are_not_used() {
        // A wide RT spread puts some answers outside 150–3000 ms.
        let spec = SessionSpec {
            trials_per_condition: 10,
            ..SessionSpec::default()
        };
        let s = run(spec, &mut observer(1.2));
        let invalid = s.records().iter().filter(|r| !r.valid).count();
        assert!(invalid > 5, "{invalid}");
        for r in s.results() {
            assert!(r.valid_trials == 10 || r.abandoned);
        }
    }

    #[test]
    fn answers_must_match_the_pending_trial() {
        let mut s = Session::new(SessionSpec::default()).unwrap();
        let t = s.next_trial().unwrap();
        assert_eq!(s.next_trial(), Some(t));
        let r = Response {
            correct: true,
            rt_ms: 500.0,
        };
        s.record(&t, r).unwrap();
        assert!(!s.is_synthetic());
        assert_eq!(s.record(&t, r).unwrap_err().field, "trial");
        let bad = SessionSpec {
            frequencies_cpd: vec![2.0, 1.0],
            ..SessionSpec::default()
        };
        assert_eq!(Session::new(bad).unwrap_err().field, "frequencies_cpd");
    }

    #[test]
    fn the_display_limit_caps_every_trial() {
        let spec = SessionSpec {
            trials_per_condition: 10,
            ..SessionSpec::default()
        }
        .limited_to_contrast(0.5)
        .unwrap();
        let s = run(spec, &mut observer(0.3));
        assert!(s.records().iter().all(|r| r.trial.contrast <= 0.5 + 1e-12));
        // High-frequency peripheral conditions sit at the cap: censored.
        assert!(s.results().iter().any(|r| r.censored));
        let e = SessionSpec::default()
            .limited_to_contrast(f64::NAN)
            .unwrap_err();
        assert_eq!(e.field, "max_contrast");
    }

    #[test]
    fn staircases_interleave_too() {
        let spec = SessionSpec {
            procedure: Procedure::Staircase(StaircaseParams::default()),
            frequencies_cpd: vec![2.0, 4.0],
            eccentricities_deg: vec![0.0, 5.0],
            trials_per_condition: 120,
            ..SessionSpec::default()
        };
        let mut obs = observer(0.3);
        let s = run(spec, &mut obs);
        for r in s.results() {
            let truth = obs
                .spec()
                .csf
                .contrast_threshold(r.frequency_cpd, r.eccentricity_deg)
                .log10();
            // 3-down-1-up aims a little below the 82 % threshold.
            assert!((r.log10_threshold - truth).abs() < 0.25, "{r:?} vs {truth}");
        }
    }
}
