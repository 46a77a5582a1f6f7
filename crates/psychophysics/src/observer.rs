//! A simulated observer with a known Geisler–Perry contrast sensitivity,
//! for testing the procedure headlessly. **Everything it produces is
//! synthetic**: its responses are [`SyntheticResponse`]s, and a session that
//! records one is marked synthetic for good (see
//! [`crate::session::Session::is_synthetic`]).
//!
//! The observer answers a two-alternative (or `guess_rate`) forced choice
//! with the toolbox Weibull of [`crate::quest`]:
//!
//! `P(c) = λγ + (1 − λ)·(1 − (1 − γ)·exp(−10^(β(log10 c − log10 CT(f, e) + x_T))))`
//!
//! where `CT(f, e)` is its true Geisler–Perry threshold, λ its lapse rate,
//! γ its guess rate and `x_T` puts `P(CT) = p_threshold`: its threshold is
//! defined at the same proportion correct QUEST's is. Response times are
//! log-normal (median `rt_median_ms`, log-sd `rt_log_sd`).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, LogNormal};
use serde::{Deserialize, Serialize};

use foveation::GeislerPerry;

use crate::quest::weibull;
use crate::session::Response;
use crate::ParamError;

/// What a simulated-observer file (RON) holds.
///
/// ```ron
/// (
///     csf: (ct0: 0.0156, alpha: 0.106, e2_deg: 2.3),
///     beta: 3.5,
///     lapse_rate: 0.02,
///     guess_rate: 0.5,
///     p_threshold: 0.82,
///     rt_median_ms: 550.0,
///     rt_log_sd: 0.3,
///     seed: 7,
/// )
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverSpec {
    /// The observer's true Geisler–Perry parameters (CT0, α, e2).
    pub csf: GeislerPerry,
    /// Weibull slope β (> 0, ≤ 100).
    pub beta: f64,
    /// Probability of answering blindly, [0, 0.5).
    pub lapse_rate: f64,
    /// Proportion correct when blind, [0, 1) (2AFC: 0.5).
    pub guess_rate: f64,
    /// Proportion correct at which `csf` gives the threshold.
    pub p_threshold: f64,
    /// Median response time, ms (> 0).
    pub rt_median_ms: f64,
    /// Standard deviation of ln(response time), ≥ 0.
    pub rt_log_sd: f64,
    /// Seed of the observer's random generator.
    pub seed: u64,
}

impl ObserverSpec {
    /// Checks every field; errors name it (`csf.ct0` etc. for the CSF).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.csf.validate().map_err(|e| ParamError {
            field: match e.field {
                "ct0" => "csf.ct0",
                "alpha" => "csf.alpha",
                "e2_deg" => "csf.e2_deg",
                other => other,
            },
            ..e
        })?;
        let q = self.as_quest_params();
        q.validate().map_err(|e| ParamError {
            field: match e.field {
                "delta" => "lapse_rate",
                "gamma" => "guess_rate",
                other => other,
            },
            ..e
        })?;
        if !(self.rt_median_ms.is_finite() && self.rt_median_ms > 0.0) {
            return Err(ParamError::new(
                "rt_median_ms",
                self.rt_median_ms,
                "must be finite and > 0",
            ));
        }
        if !(self.rt_log_sd.is_finite() && (0.0..=3.0).contains(&self.rt_log_sd)) {
            return Err(ParamError::new(
                "rt_log_sd",
                self.rt_log_sd,
                "must be finite and in 0..=3",
            ));
        }
        Ok(())
    }

    /// The observer's psychometric function as QUEST parameters (β, δ = λ,
    /// γ, p_threshold; the grid fields are the defaults).
    pub fn as_quest_params(&self) -> crate::quest::QuestParams {
        crate::quest::QuestParams {
            beta: self.beta,
            delta: self.lapse_rate,
            gamma: self.guess_rate,
            p_threshold: self.p_threshold,
            ..crate::quest::QuestParams::default()
        }
    }
}

/// A response made by a simulated observer: it can only be recorded as
/// synthetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticResponse(pub Response);

/// A validated observer with its generator.
#[derive(Debug, Clone)]
pub struct SimulatedObserver {
    spec: ObserverSpec,
    x_threshold: f64,
    rt: LogNormal<f64>,
    rng: ChaCha8Rng,
}

impl SimulatedObserver {
    /// Validates `spec` and seeds the generator.
    pub fn new(spec: ObserverSpec) -> Result<Self, ParamError> {
        spec.validate()?;
        let rt = LogNormal::new(spec.rt_median_ms.ln(), spec.rt_log_sd).map_err(|e| {
            ParamError::new("rt_log_sd", spec.rt_log_sd, format!("log-normal: {e}"))
        })?;
        Ok(Self {
            x_threshold: spec.as_quest_params().x_threshold(),
            spec,
            rt,
            rng: ChaCha8Rng::seed_from_u64(spec.seed),
        })
    }

    /// Reads and validates a RON observer file's text.
    pub fn from_ron(text: &str) -> Result<Self, ParamError> {
        let spec: ObserverSpec = ron::from_str(text).map_err(|e| {
            ParamError::new(
                "observer",
                "(file)",
                format!("not a simulated-observer RON: {e}"),
            )
        })?;
        Self::new(spec)
    }

    /// The parameters it was made with.
    pub fn spec(&self) -> &ObserverSpec {
        &self.spec
    }

    /// Probability of a correct answer (module doc). Contrast 0 gives γ.
    pub fn p_correct(&self, frequency_cpd: f64, eccentricity_deg: f64, contrast: f64) -> f64 {
        let ct = self
            .spec
            .csf
            .contrast_threshold(frequency_cpd, eccentricity_deg);
        self.p_correct_at(contrast.log10() - ct.log10())
    }

    /// Probability of a correct answer to a stimulus `log10_over_threshold`
    /// (log10 of its contrast over the observer's threshold for it; 0 at
    /// threshold gives `p_threshold`, −∞ gives γ).
    pub fn p_correct_at(&self, log10_over_threshold: f64) -> f64 {
        weibull(
            log10_over_threshold + self.x_threshold,
            self.spec.beta,
            self.spec.lapse_rate,
            self.spec.guess_rate,
        )
    }

    /// Answers one trial whose stimulus is `log10_over_threshold` (see
    /// [`SimulatedObserver::p_correct_at`]); NaN is an error, −∞ (nothing
    /// to see) answers at the guess rate.
    pub fn respond_at(
        &mut self,
        log10_over_threshold: f64,
    ) -> Result<SyntheticResponse, ParamError> {
        if log10_over_threshold.is_nan() {
            return Err(ParamError::new(
                "log10_over_threshold",
                log10_over_threshold,
                "must be a number (−∞: nothing to see)",
            ));
        }
        let p = self.p_correct_at(log10_over_threshold);
        Ok(self.answer(p))
    }

    /// A correct answer with probability `p` and a response time.
    fn answer(&mut self, p: f64) -> SyntheticResponse {
        let correct = self.rng.random::<f64>() < p;
        let rt_ms = self.rt.sample(&mut self.rng);
        SyntheticResponse(Response { correct, rt_ms })
    }

    /// Answers one trial. The contrast must be finite and in 0..=1, the
    /// frequency finite and > 0, the eccentricity finite and ≥ 0.
    pub fn respond(
        &mut self,
        frequency_cpd: f64,
        eccentricity_deg: f64,
        contrast: f64,
    ) -> Result<SyntheticResponse, ParamError> {
        if !(frequency_cpd.is_finite() && frequency_cpd > 0.0) {
            return Err(ParamError::new(
                "frequency_cpd",
                frequency_cpd,
                "must be finite and > 0",
            ));
        }
        if !(eccentricity_deg.is_finite() && eccentricity_deg >= 0.0) {
            return Err(ParamError::new(
                "eccentricity_deg",
                eccentricity_deg,
                "must be finite and ≥ 0",
            ));
        }
        if !(contrast.is_finite() && (0.0..=1.0).contains(&contrast)) {
            return Err(ParamError::new(
                "contrast",
                contrast,
                "must be a Michelson contrast in 0..=1",
            ));
        }
        let p = self.p_correct(frequency_cpd, eccentricity_deg, contrast);
        Ok(self.answer(p))
    }
}

/// The duration of one "look" whose detection probability is the
/// observer's psychometric function, ms: the 2IFC interval
/// (`gazecast thresholds measure --interval-ms`, default 200 ms) its
/// threshold is defined for. [`SimulatedObserver::respond_ramp`] spreads
/// that look's detection hazard over time.
pub const RAMP_LOOK_MS: f64 = 200.0;

impl SimulatedObserver {
    /// The observer's chance of detecting contrast `log10_over_threshold`
    /// in one look, its forced-choice function corrected for guessing and
    /// lapses: `D = 1 − exp(−H)`, `H = 10^(β(x + x_T)))`; returns `H`, the
    /// look's detection hazard.
    pub fn detection_hazard_at(&self, log10_over_threshold: f64) -> f64 {
        10f64.powf(self.spec.beta * (log10_over_threshold + self.x_threshold))
    }

    /// Answers a Luebke & Hallen ramp ([`crate::ramp`]) frame by frame.
    ///
    /// With probability `lapse_rate` the trial is a lapse: a response at a
    /// uniformly random time during the trial and a click on a uniformly
    /// random location. Otherwise, at each frame `k` (time `k·frame_ms`,
    /// the trial's own [`crate::ramp::RampSchedule`]) the observer detects
    /// with probability `1 − exp(−H(c_k)·frame_ms/RAMP_LOOK_MS)`:
    /// probability summation over time with the hazard of one look
    /// ([`RAMP_LOOK_MS`]) spread evenly over it, so the frame rate does
    /// not matter. On detection it responds a log-normal response time
    /// later (its `rt_median_ms`, `rt_log_sd`) and clicks the location
    /// shown; a response after the trial's end is no response. No
    /// detection by the end: no response. `frame_ms` must be in [1, 100].
    pub fn respond_ramp(
        &mut self,
        trial: &crate::ramp::RampTrial,
        frame_ms: f64,
    ) -> Result<crate::ramp::SyntheticRampResponse, ParamError> {
        use crate::ramp::{RampResponse, SyntheticRampResponse};
        let s = &trial.schedule;
        let frames = s.frames(frame_ms)?;
        if trial.locations == 0 || trial.location >= trial.locations {
            return Err(ParamError::new(
                "location",
                trial.location,
                format!("must be in 0..{}", trial.locations),
            ));
        }
        let end = s.end_ms();
        if self.rng.random::<f64>() < self.spec.lapse_rate {
            let t = self.rng.random::<f64>() * end;
            let l = self.rng.random_range(0..trial.locations);
            return Ok(SyntheticRampResponse(RampResponse {
                response_ms: Some(t),
                clicked_location: Some(l),
            }));
        }
        let log_ct = self
            .spec
            .csf
            .contrast_threshold(trial.frequency_cpd, trial.eccentricity_deg)
            .log10();
        let share = frame_ms / RAMP_LOOK_MS;
        for k in 0..frames {
            let t = k as f64 * frame_ms;
            let h = self.detection_hazard_at(s.log10_at(t) - log_ct);
            let p = -(-h * share).exp_m1();
            if self.rng.random::<f64>() < p {
                let rt = self.rt.sample(&mut self.rng);
                let at = t + rt;
                return Ok(SyntheticRampResponse(if at <= end {
                    RampResponse {
                        response_ms: Some(at),
                        clicked_location: Some(trial.location),
                    }
                } else {
                    RampResponse {
                        response_ms: None,
                        clicked_location: None,
                    }
                }));
            }
        }
        Ok(SyntheticRampResponse(RampResponse {
            response_ms: None,
            clicked_location: None,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const EXAMPLE: &str = "(
        csf: (ct0: 0.0156, alpha: 0.106, e2_deg: 2.3),
        beta: 3.5, lapse_rate: 0.02, guess_rate: 0.5, p_threshold: 0.82,
        rt_median_ms: 550.0, rt_log_sd: 0.3, seed: 7,
    )";

    #[test]
    fn reads_ron_and_answers_at_its_threshold() {
        let mut o = SimulatedObserver::from_ron(EXAMPLE).unwrap();
        let ct = o.spec().csf.contrast_threshold(4.0, 5.0);
        assert!((o.p_correct(4.0, 5.0, ct) - 0.82).abs() < 1e-12);
        assert!((o.p_correct(4.0, 5.0, 0.0) - 0.5).abs() < 1e-12);
        assert!((o.p_correct(4.0, 5.0, 1.0) - 0.99).abs() < 1e-3);
        let n = 4000;
        let mut hits = 0;
        for _ in 0..n {
            let SyntheticResponse(r) = o.respond(4.0, 5.0, ct).unwrap();
            hits += usize::from(r.correct);
            assert!(r.rt_ms > 0.0);
        }
        let rate = hits as f64 / n as f64;
        assert!((rate - 0.82).abs() < 0.025, "{rate}");
    }

    #[test]
    fn answers_by_the_contrast_over_its_threshold() {
        let mut o = SimulatedObserver::from_ron(EXAMPLE).unwrap();
        assert!((o.p_correct_at(0.0) - 0.82).abs() < 1e-12);
        assert!((o.p_correct_at(f64::NEG_INFINITY) - 0.5).abs() < 1e-12);
        assert!(o.p_correct_at(1.0) > 0.98);
        let ct = o.spec().csf.contrast_threshold(2.0, 5.0);
        assert!((o.p_correct(2.0, 5.0, 3.0 * ct) - o.p_correct_at(3f64.log10())).abs() < 1e-12);
        assert_eq!(
            o.respond_at(f64::NAN).unwrap_err().field,
            "log10_over_threshold"
        );
        let n = 4000;
        let hits = (0..n)
            .filter(|_| o.respond_at(f64::NEG_INFINITY).unwrap().0.correct)
            .count();
        let rate = hits as f64 / n as f64;
        assert!((rate - 0.5).abs() < 0.03, "{rate}");
    }

    #[test]
    fn bad_files_and_inputs_are_named() {
        let bad = EXAMPLE.replace("ct0: 0.0156", "ct0: 2.0");
        assert_eq!(
            SimulatedObserver::from_ron(&bad).unwrap_err().field,
            "csf.ct0"
        );
        let bad = EXAMPLE.replace("lapse_rate: 0.02", "lapse_rate: 0.7");
        assert_eq!(
            SimulatedObserver::from_ron(&bad).unwrap_err().field,
            "lapse_rate"
        );
        let bad = EXAMPLE.replace("seed: 7", "seed: 7, colour: 3");
        let e = SimulatedObserver::from_ron(&bad).unwrap_err();
        assert!(e.reason.contains("colour"), "{e}");
        let mut o = SimulatedObserver::from_ron(EXAMPLE).unwrap();
        assert_eq!(o.respond(4.0, 5.0, f64::NAN).unwrap_err().field, "contrast");
        assert_eq!(
            o.respond(-1.0, 5.0, 0.1).unwrap_err().field,
            "frequency_cpd"
        );
        assert_eq!(
            o.respond(1.0, f64::INFINITY, 0.1).unwrap_err().field,
            "eccentricity_deg"
        );
    }
}
