//! A transformed up-down staircase (Levitt 1971), as PsychoPy's
//! `StairHandler` runs it: `n_down` correct answers in a row lower the
//! intensity by one step, `n_up` wrong answers in a row raise it; a change
//! of direction is a reversal, and each reversal halves the step (down to
//! `min_step`). It stops after `max_reversals` reversals or `max_trials`
//! trials, whichever comes first. The estimate is the mean intensity at the
//! reversals after the first `discard_reversals`.
//!
//! 3-down-1-up converges on the intensity answered correctly with
//! probability 0.5^(1/3) ≈ 0.794; `n_down`-down-1-up on 0.5^(1/n_down).
//! Intensities are log10 contrasts, so steps are ratios.

use serde::{Deserialize, Serialize};

use crate::ParamError;

/// A staircase's rules.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaircaseParams {
    /// First intensity, log10 contrast.
    pub start: f64,
    /// First step, log10 units (> 0).
    pub step: f64,
    /// Smallest step after halving, log10 units (> 0, ≤ `step`).
    pub min_step: f64,
    /// Correct answers in a row that lower the intensity (≥ 1).
    pub n_down: u32,
    /// Wrong answers in a row that raise it (≥ 1).
    pub n_up: u32,
    /// Stop after this many reversals (≥ 1).
    pub max_reversals: u32,
    /// Stop after this many trials (≥ 1).
    pub max_trials: u32,
    /// Reversals left out of the estimate, from the start.
    pub discard_reversals: u32,
    /// Lowest intensity shown, log10 contrast.
    pub min_intensity: f64,
    /// Highest intensity shown, log10 contrast (0 = contrast 1).
    pub max_intensity: f64,
}

impl Default for StaircaseParams {
    /// 3-down-1-up from contrast 0.1 in steps of 0.2 log10 units (halving
    /// to 0.025), 10 reversals (the first 2 discarded) or 80 trials.
    fn default() -> Self {
        Self {
            start: -1.0,
            step: 0.2,
            min_step: 0.025,
            n_down: 3,
            n_up: 1,
            max_reversals: 10,
            max_trials: 80,
            discard_reversals: 2,
            min_intensity: -4.0,
            max_intensity: 0.0,
        }
    }
}

impl StaircaseParams {
    /// Checks every field (ranges in the field docs).
    pub fn validate(&self) -> Result<(), ParamError> {
        let finite = |field, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(ParamError::new(field, v, "must be finite"))
            }
        };
        finite("start", self.start)?;
        finite("min_intensity", self.min_intensity)?;
        finite("max_intensity", self.max_intensity)?;
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(ParamError::new("step", self.step, "must be finite and > 0"));
        }
        if !(self.min_step.is_finite() && self.min_step > 0.0 && self.min_step <= self.step) {
            return Err(ParamError::new(
                "min_step",
                self.min_step,
                "must be finite, > 0 and at most step",
            ));
        }
        for (field, v) in [
            ("n_down", self.n_down),
            ("n_up", self.n_up),
            ("max_reversals", self.max_reversals),
            ("max_trials", self.max_trials),
        ] {
            if v == 0 {
                return Err(ParamError::new(field, v, "must be at least 1"));
            }
        }
        if self.max_intensity <= self.min_intensity {
            return Err(ParamError::new(
                "max_intensity",
                self.max_intensity,
                "must be above min_intensity",
            ));
        }
        if !(self.min_intensity..=self.max_intensity).contains(&self.start) {
            return Err(ParamError::new(
                "start",
                self.start,
                "must lie within min_intensity..=max_intensity",
            ));
        }
        Ok(())
    }
}

/// Direction of the last move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Direction {
    /// Intensity lowered (after `n_down` correct).
    Down,
    /// Intensity raised (after `n_up` wrong).
    Up,
}

/// One running staircase.
#[derive(Debug, Clone, PartialEq)]
pub struct Staircase {
    params: StaircaseParams,
    intensity: f64,
    step: f64,
    correct_run: u32,
    wrong_run: u32,
    direction: Option<Direction>,
    reversals: Vec<f64>,
    trials: Vec<(f64, bool)>,
}

impl Staircase {
    /// A staircase at its start.
    pub fn new(params: StaircaseParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(Self {
            intensity: params.start,
            step: params.step,
            params,
            correct_run: 0,
            wrong_run: 0,
            direction: None,
            reversals: Vec::new(),
            trials: Vec::new(),
        })
    }

    /// The rules it was made with.
    pub fn params(&self) -> &StaircaseParams {
        &self.params
    }

    /// The intensity of the next trial.
    pub fn next_intensity(&self) -> f64 {
        self.intensity
    }

    /// The current step, log10 units.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Intensities at the reversals so far.
    pub fn reversals(&self) -> &[f64] {
        &self.reversals
    }

    /// Trials so far: (intensity, correct).
    pub fn trials(&self) -> &[(f64, bool)] {
        &self.trials
    }

    /// The last move, if any.
    pub fn direction(&self) -> Option<Direction> {
        self.direction
    }

    /// Has a stopping rule been met?
    pub fn is_finished(&self) -> bool {
        self.reversals.len() >= self.params.max_reversals as usize
            || self.trials.len() >= self.params.max_trials as usize
    }

    /// Records the answer to a trial at [`Self::next_intensity`].
    pub fn update(&mut self, correct: bool) {
        self.trials.push((self.intensity, correct));
        if correct {
            self.correct_run += 1;
            self.wrong_run = 0;
            if self.correct_run >= self.params.n_down {
                self.correct_run = 0;
                self.shift(Direction::Down);
            }
        } else {
            self.wrong_run += 1;
            self.correct_run = 0;
            if self.wrong_run >= self.params.n_up {
                self.wrong_run = 0;
                self.shift(Direction::Up);
            }
        }
    }

    fn shift(&mut self, dir: Direction) {
        if self.direction.is_some_and(|d| d != dir) {
            self.reversals.push(self.intensity);
            self.step = (self.step / 2.0).max(self.params.min_step);
        }
        self.direction = Some(dir);
        let delta = match dir {
            Direction::Down => -self.step,
            Direction::Up => self.step,
        };
        self.intensity =
            (self.intensity + delta).clamp(self.params.min_intensity, self.params.max_intensity);
    }

    /// The reversals the estimate uses (all after the discarded ones; all
    /// of them if too few remain).
    pub fn used_reversals(&self) -> &[f64] {
        let d = self.params.discard_reversals as usize;
        if self.reversals.len() > d {
            &self.reversals[d..]
        } else {
            &self.reversals
        }
    }

    /// Threshold estimate, log10 contrast: the mean of
    /// [`Self::used_reversals`]; the current intensity before any reversal.
    pub fn estimate(&self) -> f64 {
        let r = self.used_reversals();
        if r.is_empty() {
            self.intensity
        } else {
            r.iter().sum::<f64>() / r.len() as f64
        }
    }

    /// Standard error of the estimate (sd of the used reversals / √n);
    /// `None` with fewer than two.
    pub fn standard_error(&self) -> Option<f64> {
        let r = self.used_reversals();
        if r.len() < 2 {
            return None;
        }
        let n = r.len() as f64;
        let m = r.iter().sum::<f64>() / n;
        let v = r.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
        Some((v / n).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quest::QuestParams;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn three_down_one_up_moves_and_reverses() {
        let mut s = Staircase::new(StaircaseParams::default()).unwrap();
        for _ in 0..3 {
            s.update(true);
        }
        assert!((s.next_intensity() - -1.2).abs() < 1e-12);
        s.update(false); // up: a reversal at -1.2, step halves to 0.1
        assert_eq!(s.reversals(), &[-1.2]);
        assert!((s.step() - 0.1).abs() < 1e-12);
        assert!((s.next_intensity() - -1.1).abs() < 1e-12);
        s.update(true);
        s.update(false); // a wrong answer breaks the run: up again, no reversal
        assert_eq!(s.reversals().len(), 1);
        assert!((s.next_intensity() - -1.0).abs() < 1e-12);
    }

    #[test]
    fn stops_after_reversals_or_trials() {
        let p = StaircaseParams {
            max_trials: 5,
            ..StaircaseParams::default()
        };
        let mut s = Staircase::new(p).unwrap();
        for _ in 0..5 {
            assert!(!s.is_finished());
            s.update(true);
        }
        assert!(s.is_finished());
        let e = Staircase::new(StaircaseParams {
            n_down: 0,
            ..StaircaseParams::default()
        })
        .unwrap_err();
        assert_eq!(e.field, "n_down");
    }

    /// 3-down-1-up tracks the 79.4 %-correct point of a Weibull observer.
    #[test]
    fn converges_on_the_794_percent_point() {
        let obs = QuestParams::default();
        let truth = -1.6; // the observer's 82 % point
                          // The 0.5^(1/3) point, found by bisection on the observer's function.
        let target = 0.5f64.powf(1.0 / 3.0);
        let (mut lo, mut hi) = (-4.0, 0.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if obs.p_correct(mid, truth) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut sum = 0.0;
        let runs = 30;
        for seed in 0..runs {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut s = Staircase::new(StaircaseParams {
                max_reversals: 14,
                max_trials: 200,
                ..StaircaseParams::default()
            })
            .unwrap();
            while !s.is_finished() {
                let x = s.next_intensity();
                s.update(rng.random::<f64>() < obs.p_correct(x, truth));
            }
            sum += s.estimate();
        }
        let mean = sum / runs as f64;
        assert!(
            (mean - lo).abs() < 0.06,
            "mean estimate {mean} vs 79.4 % point {lo}"
        );
    }
}
