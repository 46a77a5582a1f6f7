//! The validation Luebke & Hallen ran (2001, §6.2): can a participant tell
//! the rendering simplified at their own thresholds from the full one?
//! As a two-interval forced choice: each trial shows one scene twice,
//! once full and once simplified (gaze-contingent, at the participant's
//! thresholds), in a random order; the participant says which interval was
//! simplified. A participant who cannot tell is at chance (0.5).
//!
//! This module is the design and the analysis, no window: the trial
//! schedule ([`ValidationDesign::schedule`], a seeded and balanced order)
//! and the proportion correct against chance with an exact (Clopper–
//! Pearson) binomial interval and a one-sided exact binomial test
//! ([`analyse`]). **The windowed trials (rendering each scene full and
//! simplified in a gaze-contingent window) are not built.**

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::ParamError;

/// A validation design (RON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationDesign {
    /// Scene files, each shown in `trials_per_scene` trials.
    pub scenes: Vec<String>,
    /// Trials per scene, even (half with the simplified rendering first), ≥ 2.
    pub trials_per_scene: u32,
    /// Level of the binomial interval, in (0, 1), e.g. 0.95.
    pub ci_level: f64,
    /// Seed of the trial order.
    pub seed: u64,
}

/// One scheduled trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationTrial {
    /// Position in the session, from 0.
    pub index: u32,
    /// The scene file.
    pub scene: String,
    /// Which interval (0 or 1) shows the simplified rendering.
    pub simplified_interval: u8,
}

impl ValidationDesign {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.scenes.is_empty() {
            return Err(ParamError::new("scenes", "[]", "needs at least one scene"));
        }
        if self.trials_per_scene < 2 || !self.trials_per_scene.is_multiple_of(2) {
            return Err(ParamError::new(
                "trials_per_scene",
                self.trials_per_scene,
                "must be even and at least 2 (half with the simplified rendering first)",
            ));
        }
        if !(self.ci_level.is_finite() && self.ci_level > 0.0 && self.ci_level < 1.0) {
            return Err(ParamError::new(
                "ci_level",
                self.ci_level,
                "must be in (0, 1)",
            ));
        }
        Ok(())
    }

    /// Every trial in a seeded random order; each scene has the simplified
    /// rendering first in exactly half its trials.
    pub fn schedule(&self) -> Result<Vec<ValidationTrial>, ParamError> {
        self.validate()?;
        let mut trials = Vec::new();
        for scene in &self.scenes {
            for k in 0..self.trials_per_scene {
                trials.push((scene.clone(), (k % 2) as u8));
            }
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        trials.shuffle(&mut rng);
        Ok(trials
            .into_iter()
            .enumerate()
            .map(|(i, (scene, simplified_interval))| ValidationTrial {
                index: i as u32,
                scene,
                simplified_interval,
            })
            .collect())
    }
}

/// Proportion correct against chance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ValidationResult {
    /// Trials answered.
    pub trials: u32,
    /// Answers naming the simplified interval.
    pub correct: u32,
    /// `correct / trials`.
    pub proportion_correct: f64,
    /// The exact (Clopper–Pearson) interval of the proportion.
    pub ci_low: f64,
    pub ci_high: f64,
    pub ci_level: f64,
    /// One-sided exact binomial test against chance (0.5): P(X ≥ correct).
    pub p_value: f64,
    /// Did the interval lie wholly above chance (the participant could
    /// tell)? `false` says only that this session could not show it.
    pub above_chance: bool,
}

fn ln_choose(n: u32, k: u32) -> f64 {
    let k = k.min(n - k);
    (1..=k)
        .map(|i| f64::from(n - k + i).ln() - f64::from(i).ln())
        .sum()
}

/// P(X ≤ k) for X ~ Binomial(n, p).
fn binomial_cdf(k: u32, n: u32, p: f64) -> f64 {
    if k >= n {
        return 1.0;
    }
    if p <= 0.0 {
        return 1.0;
    }
    if p >= 1.0 {
        return 0.0;
    }
    let (lp, lq) = (p.ln(), (1.0 - p).ln());
    (0..=k)
        .map(|j| (ln_choose(n, j) + f64::from(j) * lp + f64::from(n - j) * lq).exp())
        .sum::<f64>()
        .min(1.0)
}

/// The `p` in [0, 1] where the decreasing `f(p)` crosses `target`, by bisection.
fn solve_decreasing(f: impl Fn(f64) -> f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The proportion correct of `correct` out of `trials` against chance
/// (0.5), with the exact `ci_level` interval (Clopper & Pearson 1934) and
/// the one-sided exact binomial test.
pub fn analyse(trials: u32, correct: u32, ci_level: f64) -> Result<ValidationResult, ParamError> {
    if trials == 0 {
        return Err(ParamError::new("trials", 0, "needs at least one answer"));
    }
    if correct > trials {
        return Err(ParamError::new(
            "correct",
            correct,
            format!("is more than the {trials} trials"),
        ));
    }
    if !(ci_level.is_finite() && ci_level > 0.0 && ci_level < 1.0) {
        return Err(ParamError::new("ci_level", ci_level, "must be in (0, 1)"));
    }
    let alpha = 1.0 - ci_level;
    // Lower: P(X ≥ k | p) = α/2, i.e. P(X ≤ k − 1 | p) = 1 − α/2;
    // upper: P(X ≤ k | p) = α/2. Both CDFs fall as p rises.
    let ci_low = if correct == 0 {
        0.0
    } else {
        solve_decreasing(|p| binomial_cdf(correct - 1, trials, p), 1.0 - alpha / 2.0)
    };
    let ci_high = if correct == trials {
        1.0
    } else {
        solve_decreasing(|p| binomial_cdf(correct, trials, p), alpha / 2.0)
    };
    let p_value = if correct == 0 {
        1.0
    } else {
        1.0 - binomial_cdf(correct - 1, trials, 0.5)
    };
    Ok(ValidationResult {
        trials,
        correct,
        proportion_correct: f64::from(correct) / f64::from(trials),
        ci_low,
        ci_high,
        ci_level,
        p_value: p_value.clamp(0.0, 1.0),
        above_chance: ci_low > 0.5,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_is_balanced_seeded_and_shuffled() {
        let d = ValidationDesign {
            scenes: vec!["a.ron".into(), "b.ron".into()],
            trials_per_scene: 10,
            ci_level: 0.95,
            seed: 3,
        };
        let s = d.schedule().unwrap();
        assert_eq!(s.len(), 20);
        for scene in ["a.ron", "b.ron"] {
            let first: usize = s
                .iter()
                .filter(|t| t.scene == scene && t.simplified_interval == 0)
                .count();
            assert_eq!(first, 5);
        }
        assert_eq!(d.schedule().unwrap(), s);
        // Not in the order built (a's ten, then b's).
        assert!(s[..10].iter().any(|t| t.scene == "b.ron"));
        let odd = ValidationDesign {
            trials_per_scene: 3,
            ..d.clone()
        };
        assert_eq!(odd.schedule().unwrap_err().field, "trials_per_scene");
        let none = ValidationDesign {
            scenes: vec![],
            ..d
        };
        assert_eq!(none.validate().unwrap_err().field, "scenes");
    }

    #[test]
    fn clopper_pearson_matches_exact_rational_arithmetic() {
        // Reference values computed independently in Python with exact
        // rationals (fractions.Fraction, math.comb; the same defining
        // equations solved by bisection to 2^-45), not from a statistics
        // package: 7 of 20 → [0.1539092, 0.5921885], P(X ≥ 7 | 0.5) =
        // 0.94234085; 45 of 60 → [0.6214036, 0.8528139], 6.7257040e-05.
        let r = analyse(20, 7, 0.95).unwrap();
        assert!((r.ci_low - 0.153_909_2).abs() < 1e-6, "{r:?}");
        assert!((r.ci_high - 0.592_188_5).abs() < 1e-6, "{r:?}");
        assert!((r.p_value - 0.942_340_85).abs() < 1e-7, "{r:?}");
        assert!(!r.above_chance);
        let r = analyse(60, 45, 0.95).unwrap();
        assert!((r.ci_low - 0.621_403_6).abs() < 1e-6, "{r:?}");
        assert!((r.ci_high - 0.852_813_9).abs() < 1e-6, "{r:?}");
        assert!((r.p_value - 6.725_704e-5).abs() < 1e-10, "{r:?}");
        assert!(r.above_chance);
    }

    #[test]
    fn the_edges_of_the_interval() {
        // 0 of n: [0, 1 − (α/2)^(1/n)]; n of n: [(α/2)^(1/n), 1].
        let r = analyse(10, 0, 0.95).unwrap();
        assert_eq!(r.ci_low, 0.0);
        assert!((r.ci_high - (1.0 - 0.025f64.powf(0.1))).abs() < 1e-9);
        assert_eq!(r.p_value, 1.0);
        let r = analyse(10, 10, 0.95).unwrap();
        assert_eq!(r.ci_high, 1.0);
        assert!((r.ci_low - 0.025f64.powf(0.1)).abs() < 1e-9);
        assert!((r.p_value - 0.5f64.powi(10)).abs() < 1e-12);
        assert_eq!(analyse(0, 0, 0.95).unwrap_err().field, "trials");
        assert_eq!(analyse(5, 6, 0.95).unwrap_err().field, "correct");
        assert_eq!(analyse(5, 3, 1.0).unwrap_err().field, "ci_level");
    }
}
