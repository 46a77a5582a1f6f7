//! Luebke & Hallen §6.1's own procedure: a contrast ramp, a response, then
//! a click on where the grating was.
//!
//! "The user fixates on a target while a grating fades in, slowly
//! increasing in contrast. The user is instructed to press the mouse
//! button when something becomes visible. To verify that the user actually
//! saw the grating, he then clicks on it (without looking away from the
//! target)." The seed says nothing more; what this module decided is
//! stated here and in [`RampSpec`]'s fields.
//!
//! # A trial
//!
//! A condition (frequency × eccentricity) is drawn uniformly among the
//! unfinished ones (seeded ChaCha8, as in [`crate::session`]), and a
//! location: one of [`RampSpec::locations`] directions around the fixation
//! point, equally spaced from rightward counter-clockwise (4: right, up,
//! left, down), drawn uniformly. At 0° eccentricity there is one location,
//! the target itself, and the location check cannot verify anything there
//! (only the timing counts).
//!
//! The contrast rises **log-linearly**: `log10 c(t) = s + r·t` from the
//! start `s` to the display's highest contrast, then holds there for
//! [`RampSpec::hold_ms`]. The start is [`RampSpec::start_below_log10`]
//! below the default Geisler–Perry threshold of the condition (the same
//! guess QUEST's prior is centred on), lowered by a further uniform random
//! `0..start_jitter_log10` so the time to threshold cannot be learnt, and
//! never below [`RampSpec::min_start_contrast`]. A log-linear ramp rises by
//! the same factor per second at every contrast, so a response-time error
//! becomes the same log10 error at every threshold.
//!
//! The participant answers with a response time (ms from the ramp's first
//! frame) and then a location click. The **threshold sample** is the
//! contrast shown at the response time minus [`RampSpec::reaction_allowance_ms`].
//! A trial **fails** when the click is on another location
//! ([`RampOutcome::WrongLocation`]), when there is no response by the end
//! of the hold ([`RampOutcome::NoResponse`]) or when the response comes
//! before the allowance has passed ([`RampOutcome::TooEarly`]). A failed
//! trial is repeated later (interleaved), up to
//! [`RampSpec::max_failed_per_condition`] per condition.
//!
//! # The estimate
//!
//! A condition finishes after [`RampSpec::repetitions`] correct trials or
//! `max_failed_per_condition` failed ones. Its threshold is the geometric
//! mean of its correct trials' sample contrasts (the mean of their log10),
//! its spread the standard error of that mean (sample sd over √n, log10),
//! which the fit's `1/sd²` weights need. A condition is **censored** (the
//! display cannot show its threshold; left out of the fit, in the table at
//! the fitted prediction raised to the display's limit) when it ended by
//! failures at least half of which were no-response trials, or when its
//! estimate is within `censor_margin_log10` of the highest contrast. It is
//! **abandoned** when it ended by failures otherwise (mostly wrong clicks).
//!
//! # Bias
//!
//! A ramp's sample is not the 2IFC threshold. Reaction time raises it:
//! the ramp has climbed `r·(RT − allowance)` log10 by the time of the
//! click. Probability summation over the ramp's frames lowers it: the
//! observer has many looks below threshold and may detect at any of them.
//! `crate::observer::SimulatedObserver::respond_ramp` models both, and the
//! guide reports the net bias it measures. No correction beyond the fixed
//! reaction allowance is applied: the real observer's temporal summation
//! is not known.

use crate::session::axis;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use foveation::GeislerPerry;

use crate::session::ConditionResult;
use crate::ParamError;

/// A ramp session's design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RampSpec {
    /// Spatial frequencies, cycles/degree, strictly increasing, > 0.
    pub frequencies_cpd: Vec<f64>,
    /// Eccentricities, degrees, strictly increasing, ≥ 0.
    pub eccentricities_deg: Vec<f64>,
    /// Locations around the fixation point at an eccentricity above 0
    /// (2..=16).
    pub locations: u32,
    /// The ramp starts this far below the default Geisler–Perry threshold,
    /// log10 (in (0, 4]).
    pub start_below_log10: f64,
    /// …and a further uniform random 0..this lower, log10 ([0, 2]).
    pub start_jitter_log10: f64,
    /// The lowest start contrast (in [1e-6, max_contrast)).
    pub min_start_contrast: f64,
    /// The ramp's rate, log10 contrast per second ([0.02, 10]).
    pub rate_log10_per_s: f64,
    /// The highest contrast shown: the ramp's end (in (0, 1]; lowered to
    /// the display's limit).
    pub max_contrast: f64,
    /// Time at the highest contrast after the ramp, ms ([0, 10000]): a
    /// response by its end still counts.
    pub hold_ms: f64,
    /// The frame period of the schedule the simulated observer sees, ms
    /// ([1, 100]; a window shows the schedule at its own frame times).
    pub frame_ms: f64,
    /// Subtracted from the response time before reading the contrast, ms
    /// ([0, 2000]).
    pub reaction_allowance_ms: f64,
    /// Correct trials per condition (2..=1000).
    pub repetitions: u32,
    /// Failed trials after which a condition ends (1..=1000).
    pub max_failed_per_condition: u32,
    /// Estimates this close (log10) to the highest contrast are censored
    /// ([0, 2]).
    pub censor_margin_log10: f64,
    /// Seed of the conditions, locations and start jitter.
    pub seed: u64,
}

impl Default for RampSpec {
    /// The 2IFC default grid (1–16 cpd × 0–10°); 4 locations; the ramp
    /// from 1–1.3 log10 below the default threshold at 0.25 log10/s, a 1 s
    /// hold, 60 Hz frames; a 300 ms reaction allowance; 8 correct trials
    /// per condition, at most 6 failed.
    fn default() -> Self {
        Self {
            frequencies_cpd: vec![1.0, 2.0, 4.0, 8.0, 16.0],
            eccentricities_deg: vec![0.0, 2.5, 5.0, 10.0],
            locations: 4,
            start_below_log10: 1.0,
            start_jitter_log10: 0.3,
            min_start_contrast: 1e-4,
            rate_log10_per_s: 0.25,
            max_contrast: 1.0,
            hold_ms: 1000.0,
            frame_ms: 1000.0 / 60.0,
            reaction_allowance_ms: 300.0,
            repetitions: 8,
            max_failed_per_condition: 6,
            censor_margin_log10: 0.1,
            seed: 1,
        }
    }
}

fn in_range(field: &'static str, v: f64, lo: f64, hi: f64) -> Result<(), ParamError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ParamError::new(
            field,
            v,
            format!("must be finite and in [{lo}, {hi}]"),
        ))
    }
}

impl RampSpec {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<(), ParamError> {
        axis("frequencies_cpd", &self.frequencies_cpd, true)?;
        axis("eccentricities_deg", &self.eccentricities_deg, false)?;
        if !(2..=16).contains(&self.locations) {
            return Err(ParamError::new(
                "locations",
                self.locations,
                "must be in 2..=16",
            ));
        }
        if !(self.start_below_log10.is_finite()
            && self.start_below_log10 > 0.0
            && self.start_below_log10 <= 4.0)
        {
            return Err(ParamError::new(
                "start_below_log10",
                self.start_below_log10,
                "must be finite and in (0, 4]",
            ));
        }
        in_range("start_jitter_log10", self.start_jitter_log10, 0.0, 2.0)?;
        if !(self.max_contrast.is_finite() && self.max_contrast > 0.0 && self.max_contrast <= 1.0) {
            return Err(ParamError::new(
                "max_contrast",
                self.max_contrast,
                "must be a Michelson contrast in (0, 1]",
            ));
        }
        if !(self.min_start_contrast.is_finite()
            && self.min_start_contrast >= 1e-6
            && self.min_start_contrast < self.max_contrast)
        {
            return Err(ParamError::new(
                "min_start_contrast",
                self.min_start_contrast,
                format!(
                    "must be finite, ≥ 1e-6 and below max_contrast ({})",
                    self.max_contrast
                ),
            ));
        }
        in_range("rate_log10_per_s", self.rate_log10_per_s, 0.02, 10.0)?;
        in_range("hold_ms", self.hold_ms, 0.0, 10_000.0)?;
        in_range("frame_ms", self.frame_ms, 1.0, 100.0)?;
        in_range(
            "reaction_allowance_ms",
            self.reaction_allowance_ms,
            0.0,
            2000.0,
        )?;
        if !(2..=1000).contains(&self.repetitions) {
            return Err(ParamError::new(
                "repetitions",
                self.repetitions,
                "must be in 2..=1000 (two correct trials give a spread)",
            ));
        }
        if !(1..=1000).contains(&self.max_failed_per_condition) {
            return Err(ParamError::new(
                "max_failed_per_condition",
                self.max_failed_per_condition,
                "must be in 1..=1000",
            ));
        }
        in_range("censor_margin_log10", self.censor_margin_log10, 0.0, 2.0)?;
        Ok(())
    }

    /// The design with its highest contrast lowered to `max_contrast` (the
    /// display's limit) when that is lower; `max_contrast` must be finite
    /// and in (0, 1] and above `min_start_contrast`.
    pub fn limited_to_contrast(mut self, max_contrast: f64) -> Result<Self, ParamError> {
        if !(max_contrast.is_finite() && max_contrast > 0.0 && max_contrast <= 1.0) {
            return Err(ParamError::new(
                "max_contrast",
                max_contrast,
                "must be a Michelson contrast in (0, 1]",
            ));
        }
        self.max_contrast = self.max_contrast.min(max_contrast);
        if self.min_start_contrast >= self.max_contrast {
            return Err(ParamError::new(
                "max_contrast",
                max_contrast,
                format!(
                    "is at or below the design's lowest start contrast ({})",
                    self.min_start_contrast
                ),
            ));
        }
        Ok(self)
    }

    /// Locations at eccentricity `e`: one at 0°, [`Self::locations`] else.
    pub fn locations_at(&self, eccentricity_deg: f64) -> u32 {
        if eccentricity_deg > 0.0 {
            self.locations
        } else {
            1
        }
    }
}

/// A ramp's contrast over time: `log10 c(t) = start + rate·t` up to
/// `log10 max`, then `max` until `end_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampSchedule {
    /// Start, log10 contrast.
    pub start_log10: f64,
    /// Rate, log10 per second.
    pub rate_log10_per_s: f64,
    /// The highest contrast, log10.
    pub max_log10: f64,
    /// Time at the highest contrast after the ramp, ms.
    pub hold_ms: f64,
}

impl RampSchedule {
    /// Checks the schedule (start below max, rate > 0, all finite, hold ≥ 0).
    pub fn new(
        start_log10: f64,
        rate_log10_per_s: f64,
        max_log10: f64,
        hold_ms: f64,
    ) -> Result<Self, ParamError> {
        if !(max_log10.is_finite() && max_log10 <= 0.0) {
            return Err(ParamError::new(
                "max_log10",
                max_log10,
                "must be finite and ≤ 0 (contrast ≤ 1)",
            ));
        }
        if !(start_log10.is_finite() && start_log10 < max_log10 && start_log10 >= -6.0) {
            return Err(ParamError::new(
                "start_log10",
                start_log10,
                format!("must be finite, ≥ −6 and below max_log10 ({max_log10})"),
            ));
        }
        in_range("rate_log10_per_s", rate_log10_per_s, 0.02, 10.0)?;
        in_range("hold_ms", hold_ms, 0.0, 10_000.0)?;
        Ok(Self {
            start_log10,
            rate_log10_per_s,
            max_log10,
            hold_ms,
        })
    }

    /// The ramp's duration (start to max), ms.
    pub fn ramp_ms(&self) -> f64 {
        (self.max_log10 - self.start_log10) / self.rate_log10_per_s * 1000.0
    }

    /// The trial's end (ramp and hold), ms: responses after it are none.
    pub fn end_ms(&self) -> f64 {
        self.ramp_ms() + self.hold_ms
    }

    /// log10 contrast at `t_ms` after the first frame (clamped to the start
    /// before 0 and to the max after the ramp; NaN stays NaN).
    pub fn log10_at(&self, t_ms: f64) -> f64 {
        (self.start_log10 + self.rate_log10_per_s * t_ms.max(0.0) / 1000.0).min(self.max_log10)
    }

    /// Michelson contrast at `t_ms`.
    pub fn contrast_at(&self, t_ms: f64) -> f64 {
        10f64.powf(self.log10_at(t_ms))
    }

    /// Frames of period `frame_ms` from 0 to the end: how many. `frame_ms`
    /// must be in [1, 100] (the count is then at most ≈ 1.3 million).
    pub fn frames(&self, frame_ms: f64) -> Result<u64, ParamError> {
        in_range("frame_ms", frame_ms, 1.0, 100.0)?;
        Ok((self.end_ms() / frame_ms).floor() as u64 + 1)
    }
}

/// What to show: a condition, a location and a ramp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampTrial {
    /// Position in the session, from 0 (failed trials included).
    pub index: u32,
    /// Condition index: `eccentricity index × frequencies + frequency index`.
    pub condition: usize,
    /// Spatial frequency, cycles/degree.
    pub frequency_cpd: f64,
    /// Eccentricity, degrees.
    pub eccentricity_deg: f64,
    /// Locations at this eccentricity ([`RampSpec::locations_at`]).
    pub locations: u32,
    /// The location shown, `0..locations`.
    pub location: u32,
    /// Its direction from the fixation point, degrees counter-clockwise
    /// from rightward (screen up is 90°).
    pub direction_deg: f64,
    /// The contrast over time.
    pub schedule: RampSchedule,
}

/// A participant's answer to a ramp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampResponse {
    /// The "seen" response, ms after the ramp's first frame; `None`: none
    /// by the end.
    pub response_ms: Option<f64>,
    /// The location clicked, `0..locations`; `None`: no click.
    pub clicked_location: Option<u32>,
}

/// A simulated observer's answer: it can only be recorded as synthetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticRampResponse(pub RampResponse);

/// How a trial ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RampOutcome {
    /// Responded, clicked the location shown: a threshold sample.
    Correct,
    /// Clicked another location (or none): failed.
    WrongLocation,
    /// No response by the end of the hold: failed.
    NoResponse,
    /// Responded before the reaction allowance had passed: failed.
    TooEarly,
}

impl RampOutcome {
    /// The name written in `trials.tsv`.
    pub fn name(&self) -> &'static str {
        match self {
            RampOutcome::Correct => "correct",
            RampOutcome::WrongLocation => "wrong_location",
            RampOutcome::NoResponse => "no_response",
            RampOutcome::TooEarly => "too_early",
        }
    }
}

/// One trial as recorded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampRecord {
    /// The trial shown.
    pub trial: RampTrial,
    /// The answer.
    pub response: RampResponse,
    /// How it ended.
    pub outcome: RampOutcome,
    /// The contrast on screen at the response (or at the end: the last
    /// contrast shown).
    pub stop_contrast: f64,
    /// Correct trials: the threshold sample, log10 contrast at
    /// `response − reaction allowance`.
    pub sample_log10: Option<f64>,
    /// The condition's estimate after this trial, log10 (NaN before its
    /// first correct trial).
    pub estimate_log10: f64,
    /// Its standard error after this trial, log10 (NaN before two correct
    /// trials).
    pub se_log10: f64,
    /// Did this trial finish its condition?
    pub finished_condition: bool,
}

/// A condition's ramp result, with the counts behind it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RampConditionResult {
    /// The result in the form the fit and the table take.
    pub result: ConditionResult,
    /// Correct trials (samples).
    pub correct: u32,
    /// Failed by a wrong click.
    pub wrong_location: u32,
    /// Failed by no response.
    pub no_response: u32,
    /// Failed by a response before the allowance.
    pub too_early: u32,
    /// Standard deviation of the samples, log10 (NaN below two).
    pub sample_sd_log10: f64,
}

/// A running ramp session.
#[derive(Debug, Clone)]
pub struct RampSession {
    spec: RampSpec,
    samples: Vec<Vec<f64>>,
    failed: Vec<[u32; 3]>,
    rng: ChaCha8Rng,
    pending: Option<RampTrial>,
    records: Vec<RampRecord>,
    synthetic: bool,
}

fn mean_se(v: &[f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, f64::NAN, f64::NAN);
    }
    let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, sd, sd / n.sqrt())
}

impl RampSession {
    /// Validates the design.
    pub fn new(spec: RampSpec) -> Result<Self, ParamError> {
        spec.validate()?;
        let n = spec.frequencies_cpd.len() * spec.eccentricities_deg.len();
        Ok(Self {
            samples: vec![Vec::new(); n],
            failed: vec![[0; 3]; n],
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
            pending: None,
            records: Vec::new(),
            synthetic: false,
            spec,
        })
    }

    /// The design.
    pub fn spec(&self) -> &RampSpec {
        &self.spec
    }

    /// Every trial recorded so far.
    pub fn records(&self) -> &[RampRecord] {
        &self.records
    }

    /// Has any answer come from a simulated observer?
    pub fn is_synthetic(&self) -> bool {
        self.synthetic
    }

    /// Condition `c`'s correct trials' samples, log10.
    pub fn samples(&self, c: usize) -> &[f64] {
        self.samples.get(c).map_or(&[], |v| v.as_slice())
    }

    fn failed_total(&self, c: usize) -> u32 {
        self.failed[c].iter().sum()
    }

    fn condition_finished(&self, c: usize) -> bool {
        self.samples[c].len() >= self.spec.repetitions as usize
            || self.failed_total(c) >= self.spec.max_failed_per_condition
    }

    /// Has every condition finished?
    pub fn is_finished(&self) -> bool {
        (0..self.samples.len()).all(|c| self.condition_finished(c))
    }

    /// The next trial, or `None` when the session is over. Asking again
    /// before recording an answer gives the same trial.
    pub fn next_trial(&mut self) -> Option<RampTrial> {
        if let Some(t) = self.pending {
            return Some(t);
        }
        let open: Vec<usize> = (0..self.samples.len())
            .filter(|&c| !self.condition_finished(c))
            .collect();
        if open.is_empty() {
            return None;
        }
        let c = open[self.rng.random_range(0..open.len())];
        let nf = self.spec.frequencies_cpd.len();
        let (f, e) = (
            self.spec.frequencies_cpd[c % nf],
            self.spec.eccentricities_deg[c / nf],
        );
        let locations = self.spec.locations_at(e);
        let location = self.rng.random_range(0..locations);
        let jitter = self.rng.random::<f64>() * self.spec.start_jitter_log10;
        let max_log10 = self.spec.max_contrast.log10();
        let guess = GeislerPerry::default().contrast_threshold(f, e).log10();
        // Below the max by at least 0.1 log10 and above the floor: both
        // were checked against each other by validate().
        let start = (guess - self.spec.start_below_log10 - jitter)
            .min(max_log10 - 0.1)
            .max(self.spec.min_start_contrast.log10())
            .min(max_log10 - 1e-3);
        let schedule = RampSchedule {
            start_log10: start,
            rate_log10_per_s: self.spec.rate_log10_per_s,
            max_log10,
            hold_ms: self.spec.hold_ms,
        };
        let t = RampTrial {
            index: self.records.len() as u32,
            condition: c,
            frequency_cpd: f,
            eccentricity_deg: e,
            locations,
            location,
            direction_deg: 360.0 * f64::from(location) / f64::from(locations),
            schedule,
        };
        self.pending = Some(t);
        Some(t)
    }

    /// Records a participant's answer to `trial`, which must be the one
    /// [`Self::next_trial`] gave last. A response time must be a number
    /// ≥ 0; a clicked location must be one of the trial's.
    pub fn record(
        &mut self,
        trial: &RampTrial,
        response: RampResponse,
    ) -> Result<RampOutcome, ParamError> {
        if self.pending != Some(*trial) {
            return Err(ParamError::new(
                "trial",
                trial.index,
                "is not the trial awaiting an answer (ask next_trial first, answer once)",
            ));
        }
        if let Some(t) = response.response_ms {
            if t.is_nan() || t < 0.0 {
                return Err(ParamError::new(
                    "response_ms",
                    t,
                    "must be a number ≥ 0 (ms after the ramp's first frame)",
                ));
            }
        }
        if let Some(l) = response.clicked_location {
            if l >= trial.locations {
                return Err(ParamError::new(
                    "clicked_location",
                    l,
                    format!("must be in 0..{}", trial.locations),
                ));
            }
        }
        self.pending = None;
        let s = &trial.schedule;
        let allowance = self.spec.reaction_allowance_ms;
        let (outcome, stop_ms) = match response.response_ms {
            None => (RampOutcome::NoResponse, s.end_ms()),
            Some(t) if t > s.end_ms() => (RampOutcome::NoResponse, s.end_ms()),
            Some(t) if t < allowance => (RampOutcome::TooEarly, t),
            Some(t) if response.clicked_location != Some(trial.location) => {
                (RampOutcome::WrongLocation, t)
            }
            Some(t) => (RampOutcome::Correct, t),
        };
        let c = trial.condition;
        let sample_log10 =
            (outcome == RampOutcome::Correct).then(|| s.log10_at(stop_ms - allowance));
        match (outcome, sample_log10) {
            (_, Some(x)) => self.samples[c].push(x),
            (RampOutcome::WrongLocation, _) => self.failed[c][0] += 1,
            (RampOutcome::NoResponse, _) => self.failed[c][1] += 1,
            _ => self.failed[c][2] += 1,
        }
        let (m, _, se) = mean_se(&self.samples[c]);
        self.records.push(RampRecord {
            trial: *trial,
            response,
            outcome,
            stop_contrast: s.contrast_at(stop_ms),
            sample_log10,
            estimate_log10: m,
            se_log10: se,
            finished_condition: self.condition_finished(c),
        });
        Ok(outcome)
    }

    /// Records a simulated observer's answer; the session becomes synthetic.
    pub fn record_synthetic(
        &mut self,
        trial: &RampTrial,
        response: SyntheticRampResponse,
    ) -> Result<RampOutcome, ParamError> {
        let o = self.record(trial, response.0)?;
        self.synthetic = true;
        Ok(o)
    }

    /// Every condition's result, in condition order (module doc: the
    /// estimate, censoring and abandoning). A condition without a sample
    /// reports the display's highest contrast with sd 0.
    pub fn ramp_results(&self) -> Vec<RampConditionResult> {
        let nf = self.spec.frequencies_cpd.len();
        let max_log10 = self.spec.max_contrast.log10();
        (0..self.samples.len())
            .map(|c| {
                let [wrong, none, early] = self.failed[c];
                let failed = wrong + none + early;
                let (m, sd, se) = mean_se(&self.samples[c]);
                let ended_by_failures = failed >= self.spec.max_failed_per_condition;
                let n = self.samples[c].len() as u32;
                let (est, se) = if n == 0 { (max_log10, 0.0) } else { (m, se) };
                let censored = (ended_by_failures && 2 * none >= failed)
                    || (n > 0 && est >= max_log10 - self.spec.censor_margin_log10);
                let abandoned = !censored && (ended_by_failures || n < 2);
                RampConditionResult {
                    result: ConditionResult {
                        frequency_cpd: self.spec.frequencies_cpd[c % nf],
                        eccentricity_deg: self.spec.eccentricities_deg[c / nf],
                        log10_threshold: est,
                        sd_log10: if se.is_nan() { 0.0 } else { se },
                        threshold: 10f64.powf(est),
                        valid_trials: n,
                        invalid_trials: failed,
                        censored,
                        abandoned,
                    },
                    correct: n,
                    wrong_location: wrong,
                    no_response: none,
                    too_early: early,
                    sample_sd_log10: sd,
                }
            })
            .collect()
    }

    /// [`Self::ramp_results`] in the form the fit and the table take.
    pub fn results(&self) -> Vec<ConditionResult> {
        self.ramp_results().into_iter().map(|r| r.result).collect()
    }
}

/// The bias of a ramp's mean log10 sample against the 2IFC threshold,
/// log10, for a simulated observer `spec` ([`crate::observer`]) whose look
/// lasts `look_ms`, on a ramp of `rate_log10_per_s` with
/// `reaction_allowance_ms`, from a start far below threshold, lapses left
/// out. A model's figure, for checking the simulation and for the guide.
///
/// Probability summation: the cumulative hazard up to the detection
/// contrast `X` is `(Y − Y₀)/κ` with `Y = 10^(β(X + x_T))` and
/// `κ = β·r·ln10·look`; it is Exp(1)-distributed, so with `Y₀ → 0`,
/// `E[X] = (log10 κ − γ_E/ln10)/β − x_T` (γ_E Euler's constant).
/// Reaction time: `+ r·(E[RT] − allowance)`, `E[RT]` the log-normal's mean.
pub fn model_bias_log10(
    spec: &crate::observer::ObserverSpec,
    look_ms: f64,
    rate_log10_per_s: f64,
    reaction_allowance_ms: f64,
) -> Result<f64, ParamError> {
    spec.validate()?;
    in_range("look_ms", look_ms, 1.0, 10_000.0)?;
    in_range("rate_log10_per_s", rate_log10_per_s, 0.02, 10.0)?;
    in_range("reaction_allowance_ms", reaction_allowance_ms, 0.0, 2000.0)?;
    const EULER_GAMMA: f64 = 0.577_215_664_901_532_9;
    let ln10 = std::f64::consts::LN_10;
    let x_t = spec.as_quest_params().x_threshold();
    let kappa = spec.beta * rate_log10_per_s * ln10 * look_ms / 1000.0;
    let summation = (kappa.log10() - EULER_GAMMA / ln10) / spec.beta - x_t;
    let mean_rt = spec.rt_median_ms * (spec.rt_log_sd.powi(2) / 2.0).exp();
    Ok(summation + rate_log10_per_s * (mean_rt - reaction_allowance_ms) / 1000.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::{ObserverSpec, SimulatedObserver};
    use proptest::prelude::*;

    fn observer(seed: u64) -> SimulatedObserver {
        SimulatedObserver::new(ObserverSpec {
            csf: GeislerPerry {
                ct0: 0.012,
                alpha: 0.095,
                e2_deg: 2.8,
            },
            beta: 3.5,
            lapse_rate: 0.02,
            guess_rate: 0.5,
            p_threshold: 0.82,
            rt_median_ms: 550.0,
            rt_log_sd: 0.3,
            seed,
        })
        .unwrap()
    }

    #[test]
    fn the_schedule_rises_monotonically_to_the_max_and_holds() {
        let s = RampSchedule::new(-3.0, 0.25, -0.1, 1000.0).unwrap();
        assert!((s.ramp_ms() - 11_600.0).abs() < 1e-6);
        let frames = s.frames(1000.0 / 60.0).unwrap();
        let mut last = 0.0;
        for k in 0..frames {
            let c = s.contrast_at(k as f64 * 1000.0 / 60.0);
            assert!(c >= last, "frame {k}: {c} < {last}");
            assert!(c > 0.0 && c <= 10f64.powf(-0.1) + 1e-12);
            last = c;
        }
        assert!((last - 10f64.powf(-0.1)).abs() < 1e-12, "ends at the max");
        assert!((s.contrast_at(0.0) - 1e-3).abs() < 1e-15);
        // log-linear: one second multiplies the contrast by 10^0.25.
        assert!((s.contrast_at(2000.0) / s.contrast_at(1000.0) - 10f64.powf(0.25)).abs() < 1e-9);
        assert!(s.contrast_at(-5.0) == s.contrast_at(0.0));
        assert!(RampSchedule::new(-1.0, 0.25, -1.0, 0.0).is_err());
        assert!(RampSchedule::new(-1.0, 0.0, 0.0, 0.0).is_err());
    }

    #[test]
    fn a_wrong_click_or_no_response_fails_and_is_repeated() {
        let spec = RampSpec {
            frequencies_cpd: vec![4.0],
            eccentricities_deg: vec![5.0],
            repetitions: 2,
            max_failed_per_condition: 3,
            ..RampSpec::default()
        };
        let mut s = RampSession::new(spec).unwrap();
        let t = s.next_trial().unwrap();
        assert_eq!(s.next_trial(), Some(t));
        let wrong = (t.location + 1) % t.locations;
        let r = RampResponse {
            response_ms: Some(2000.0),
            clicked_location: Some(wrong),
        };
        assert_eq!(s.record(&t, r).unwrap(), RampOutcome::WrongLocation);
        assert!(s.records()[0].sample_log10.is_none());
        assert_eq!(s.record(&t, r).unwrap_err().field, "trial");
        let t = s.next_trial().unwrap();
        let none = RampResponse {
            response_ms: None,
            clicked_location: None,
        };
        assert_eq!(s.record(&t, none).unwrap(), RampOutcome::NoResponse);
        assert!((s.records()[1].stop_contrast - s.spec().max_contrast).abs() < 1e-12);
        let t = s.next_trial().unwrap();
        let early = RampResponse {
            response_ms: Some(100.0),
            clicked_location: Some(t.location),
        };
        assert_eq!(s.record(&t, early).unwrap(), RampOutcome::TooEarly);
        // Three failures end the condition: mostly not "no response", so
        // abandoned rather than censored.
        assert!(s.is_finished());
        let r = s.ramp_results()[0];
        assert_eq!((r.wrong_location, r.no_response, r.too_early), (1, 1, 1));
        assert!(r.result.abandoned && !r.result.censored);
    }

    #[test]
    fn a_correct_click_samples_the_contrast_before_the_allowance() {
        let spec = RampSpec {
            frequencies_cpd: vec![4.0],
            eccentricities_deg: vec![5.0],
            repetitions: 2,
            ..RampSpec::default()
        };
        let mut s = RampSession::new(spec).unwrap();
        for _ in 0..2 {
            let t = s.next_trial().unwrap();
            let r = RampResponse {
                response_ms: Some(2300.0),
                clicked_location: Some(t.location),
            };
            assert_eq!(s.record(&t, r).unwrap(), RampOutcome::Correct);
            let x = s.records().last().unwrap().sample_log10.unwrap();
            assert!((x - t.schedule.log10_at(2000.0)).abs() < 1e-12);
            assert!((x - (t.schedule.start_log10 + 0.5)).abs() < 1e-12);
        }
        assert!(s.next_trial().is_none());
        let r = s.ramp_results()[0];
        assert_eq!(r.correct, 2);
        assert!(!r.result.censored && !r.result.abandoned);
        let bad = RampResponse {
            response_ms: Some(f64::NAN),
            clicked_location: Some(0),
        };
        let mut s2 = RampSession::new(RampSpec::default()).unwrap();
        let t = s2.next_trial().unwrap();
        assert_eq!(s2.record(&t, bad).unwrap_err().field, "response_ms");
        let off = RampResponse {
            response_ms: Some(1000.0),
            clicked_location: Some(99),
        };
        assert_eq!(s2.record(&t, off).unwrap_err().field, "clicked_location");
    }

    #[test]
    fn an_invisible_condition_is_censored_not_abandoned() {
        // Nothing is seen: every trial runs out; the condition is beyond
        // the display.
        let spec = RampSpec {
            frequencies_cpd: vec![16.0],
            eccentricities_deg: vec![10.0],
            ..RampSpec::default()
        };
        let mut s = RampSession::new(spec).unwrap();
        while let Some(t) = s.next_trial() {
            let none = RampResponse {
                response_ms: None,
                clicked_location: None,
            };
            s.record(&t, none).unwrap();
        }
        let r = s.ramp_results()[0];
        assert_eq!(r.no_response, 6);
        assert!(r.result.censored && !r.result.abandoned);
    }

    #[test]
    fn the_simulated_observer_sees_the_ramp_near_its_threshold() {
        // One condition, many repetitions: the sample's geometric mean
        // sits near the observer's threshold (the bias is the guide's).
        let spec = RampSpec {
            frequencies_cpd: vec![4.0],
            eccentricities_deg: vec![5.0],
            repetitions: 200,
            max_failed_per_condition: 200,
            ..RampSpec::default()
        };
        let mut obs = observer(5);
        let truth = obs.spec().csf.contrast_threshold(4.0, 5.0).log10();
        let mut s = RampSession::new(spec).unwrap();
        while let Some(t) = s.next_trial() {
            let r = obs.respond_ramp(&t, s.spec().frame_ms).unwrap();
            s.record_synthetic(&t, r).unwrap();
        }
        assert!(s.is_synthetic());
        let r = s.ramp_results()[0];
        let bias = r.result.log10_threshold - truth;
        // The model's figure (≈ −0.12 log10: probability summation −0.19,
        // reaction time beyond the allowance +0.07); 200 samples' standard
        // error is ≈ 0.01.
        let model =
            model_bias_log10(obs.spec(), crate::observer::RAMP_LOOK_MS, 0.25, 300.0).unwrap();
        assert!((model + 0.12).abs() < 0.01, "model {model}");
        assert!((bias - model).abs() < 0.04, "bias {bias}, model {model}");
        // Lapses click a random location: some fail on the location check.
        assert!(r.wrong_location + r.too_early > 0, "{r:?}");
        assert!(r.sample_sd_log10 > 0.02 && r.sample_sd_log10 < 0.3, "{r:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

        #[test]
        fn bad_designs_are_refused_not_panicked_on(
            rate in prop_oneof![Just(0.0), Just(-1.0), Just(f64::NAN), Just(f64::INFINITY), Just(1e300), 0.02f64..10.0],
            start in prop_oneof![Just(0.0), Just(f64::NAN), Just(1e9), 0.01f64..4.0],
            frame in prop_oneof![Just(0.0), Just(f64::NAN), Just(1e12), 1.0f64..100.0],
            hold in prop_oneof![Just(-1.0), Just(f64::NAN), Just(1e12), 0.0f64..10_000.0],
            reps in prop_oneof![Just(0u32), Just(1), Just(u32::MAX), 2u32..20],
            locations in prop_oneof![Just(0u32), Just(1), Just(u32::MAX), 2u32..16],
            max_c in prop_oneof![Just(0.0), Just(f64::NAN), Just(2.0), 0.05f64..1.0],
        ) {
            let spec = RampSpec {
                frequencies_cpd: vec![2.0, 8.0],
                eccentricities_deg: vec![0.0, 5.0],
                rate_log10_per_s: rate,
                start_below_log10: start,
                frame_ms: frame,
                hold_ms: hold,
                repetitions: reps,
                locations,
                max_contrast: max_c,
                max_failed_per_condition: 2,
                ..RampSpec::default()
            };
            let valid = spec.validate().is_ok();
            match RampSession::new(spec) {
                Err(e) => prop_assert!(!valid && !e.field.is_empty()),
                Ok(mut s) => {
                    prop_assert!(valid);
                    // A few trials run, bounded, and every schedule is sane.
                    let mut obs = observer(1);
                    for _ in 0..6 {
                        let Some(t) = s.next_trial() else { break };
                        let sc = t.schedule;
                        prop_assert!(sc.start_log10 < sc.max_log10);
                        prop_assert!(sc.end_ms().is_finite());
                        let r = obs.respond_ramp(&t, s.spec().frame_ms).unwrap();
                        s.record_synthetic(&t, r).unwrap();
                    }
                }
            }
        }

        #[test]
        fn schedules_refuse_bad_numbers(
            start in prop_oneof![Just(f64::NAN), Just(f64::NEG_INFINITY), Just(-1e9), -6.0f64..0.0],
            rate in prop_oneof![Just(f64::NAN), Just(0.0), Just(1e300), 0.02f64..10.0],
            max in prop_oneof![Just(f64::NAN), Just(1.0), -1.0f64..0.0],
            frame in prop_oneof![Just(f64::NAN), Just(0.0), Just(1e300), 1.0f64..100.0],
        ) {
            match RampSchedule::new(start, rate, max, 500.0) {
                Err(e) => prop_assert!(!e.field.is_empty()),
                Ok(s) => {
                    prop_assert!(s.end_ms().is_finite() && s.end_ms() > 0.0);
                    match s.frames(frame) {
                        Ok(n) => prop_assert!(n <= 1_400_000),
                        Err(e) => prop_assert_eq!(e.field, "frame_ms"),
                    }
                }
            }
        }
    }
}
