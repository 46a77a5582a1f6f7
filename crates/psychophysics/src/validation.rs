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
//! ([`analyse`]); and the simulated observer's model of how visible the
//! difference between the two renderings is ([`difference_visibility`]).
//! `gazecast thresholds validate --headless` runs it with a simulated
//! observer; **the windowed trials (a person answering in a
//! gaze-contingent window) are not built.**
//!
//! # The simulated observer's model of detectability
//!
//! The two frames (full and simplified, rendered for the same gaze) are
//! turned into luminance (each channel's level through the display's
//! transfer, weighted 0.2126 / 0.7152 / 0.0722: the Rec. 709 weights,
//! applied to each channel as if it were a grey level). At every pixel whose
//! luminance differs (`a` in one frame, `b` in the other) the difference
//! is a modulation of Michelson contrast `c = |a − b| / (a + b)`. Its
//! spatial frequency comes from its extent: the longer of the horizontal
//! and the vertical run of differing pixels through that pixel, in degrees
//! at that pixel (`run_px / local ppd`), taken as half a cycle, `f = 1 /
//! (2 · extent)` (the larger extent is the lower frequency, the more
//! visible one: conservative, like Luebke & Hallen's bounding-sphere
//! extent). The observer's threshold there is its Geisler–Perry
//! `CT(f, e)` at the pixel's eccentricity `e` from the gaze. The
//! difference's visibility is the largest `log10(c / CT(f, e))` over the
//! frame (a max rule: no probability summation), and the observer names
//! the simplified interval correctly with its psychometric function's
//! probability at that value ([`crate::observer::SimulatedObserver::respond_at`]):
//! at chance (its guess rate) when nothing differs, `p_threshold` when the
//! most visible pixel is exactly at threshold.

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

/// How visible the difference between two renderings of one gaze is to
/// an observer with a given CSF (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DifferenceVisibility {
    /// Pixels whose luminance differs.
    pub differing_pixels: usize,
    /// The largest `log10(c / CT(f, e))`; `None` when nothing differs.
    pub max_log10_over_threshold: Option<f64>,
    /// Where that is (pixel x, y), its contrast, frequency (cycles/degree)
    /// and eccentricity (degrees from the gaze).
    pub at_px: Option<[u32; 2]>,
    pub contrast: Option<f64>,
    pub frequency_cpd: Option<f64>,
    pub eccentricity_deg: Option<f64>,
}

impl DifferenceVisibility {
    /// The value the observer's psychometric function takes: −∞ when
    /// nothing differs.
    pub fn log10_over_threshold(&self) -> f64 {
        self.max_log10_over_threshold.unwrap_or(f64::NEG_INFINITY)
    }
}

/// Each pixel's luminance (cd/m²) of an 8-bit RGB frame (module doc).
pub fn frame_luminance(rgb: &[u8], transfer: &crate::luminance::Transfer) -> Vec<f64> {
    let lut: Vec<f64> = (0..=255u8).map(|l| transfer.luminance(l)).collect();
    rgb.chunks_exact(3)
        .map(|p| {
            0.2126 * lut[usize::from(p[0])]
                + 0.7152 * lut[usize::from(p[1])]
                + 0.0722 * lut[usize::from(p[2])]
        })
        .collect()
}

/// The run of `true` through each index of `mask` along a line of
/// `len` items `stride` apart from `start`: each gets its run's length.
fn runs(mask: &[bool], start: usize, len: usize, stride: usize, out: &mut [u32]) {
    let mut k = 0;
    while k < len {
        if !mask[start + k * stride] {
            k += 1;
            continue;
        }
        let from = k;
        while k < len && mask[start + k * stride] {
            k += 1;
        }
        for j in from..k {
            out[start + j * stride] = (k - from) as u32;
        }
    }
}

/// The visibility of the difference between the luminance images `a` and
/// `b` (row-major, `geometry`'s size) to an observer with `csf` looking at
/// `gaze_px` (module doc).
pub fn difference_visibility(
    a: &[f64],
    b: &[f64],
    geometry: &screen_geometry::ScreenGeometry,
    gaze_px: [f64; 2],
    csf: &foveation::GeislerPerry,
) -> Result<DifferenceVisibility, ParamError> {
    let (w, h) = (geometry.width_px as usize, geometry.height_px as usize);
    if a.len() != w * h || b.len() != w * h {
        return Err(ParamError::new(
            "frames",
            format!("{} and {} pixels", a.len(), b.len()),
            format!("must both be {w} × {h}"),
        ));
    }
    let differs: Vec<bool> = a.iter().zip(b).map(|(x, y)| x != y).collect();
    let mut across = vec![0u32; w * h];
    let mut down = vec![0u32; w * h];
    for y in 0..h {
        runs(&differs, y * w, w, 1, &mut across);
    }
    for x in 0..w {
        runs(&differs, x, h, w, &mut down);
    }
    let mut best = DifferenceVisibility {
        differing_pixels: differs.iter().filter(|&&d| d).count(),
        max_log10_over_threshold: None,
        at_px: None,
        contrast: None,
        frequency_cpd: None,
        eccentricity_deg: None,
    };
    for i in (0..w * h).filter(|&i| differs[i]) {
        let sum = a[i] + b[i];
        if !(sum.is_finite() && sum > 0.0) {
            continue;
        }
        let c = ((a[i] - b[i]).abs() / sum).min(1.0);
        let p = [(i % w) as f64 + 0.5, (i / w) as f64 + 0.5];
        let extent_deg = f64::from(across[i].max(down[i])) / geometry.local_ppd(p);
        let f = 1.0 / (2.0 * extent_deg);
        let e = geometry.eccentricity_deg(p, gaze_px);
        let v = c.log10() - csf.contrast_threshold(f, e).log10();
        if v.is_finite() && best.max_log10_over_threshold.is_none_or(|m| v > m) {
            best.max_log10_over_threshold = Some(v);
            best.at_px = Some([(i % w) as u32, (i / w) as u32]);
            best.contrast = Some(c);
            best.frequency_cpd = Some(f);
            best.eccentricity_deg = Some(e);
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> screen_geometry::ScreenGeometry {
        screen_geometry::Display::seed_17in(64, 48)
            .geometry()
            .unwrap()
    }

    #[test]
    fn nothing_differs_nothing_to_see() {
        let g = geometry();
        let a = vec![10.0; 64 * 48];
        let v = difference_visibility(&a, &a, &g, g.centre_px(), &Default::default()).unwrap();
        assert_eq!(v.differing_pixels, 0);
        assert_eq!(v.log10_over_threshold(), f64::NEG_INFINITY);
        assert_eq!(
            difference_visibility(&a, &a[1..], &g, g.centre_px(), &Default::default())
                .unwrap_err()
                .field,
            "frames"
        );
    }

    #[test]
    fn a_difference_is_more_visible_larger_stronger_and_nearer_the_gaze() {
        let g = geometry();
        let csf = foveation::GeislerPerry::default();
        let a = vec![10.0; 64 * 48];
        let patch = |x0: usize, y0: usize, side: usize, delta: f64| {
            let mut b = a.clone();
            for y in y0..y0 + side {
                for x in x0..x0 + side {
                    b[y * 64 + x] += delta;
                }
            }
            difference_visibility(&a, &b, &g, [32.0, 24.0], &csf).unwrap()
        };
        let small = patch(30, 22, 2, 1.0);
        assert_eq!(small.differing_pixels, 4);
        // Contrast 1 / 21 at the pixel's extent of 2 px.
        assert!((small.contrast.unwrap() - 1.0 / 21.0).abs() < 1e-12);
        let ppd = g.local_ppd([31.0, 23.0]);
        assert!((small.frequency_cpd.unwrap() - ppd / 4.0).abs() < 0.05 * ppd);
        let large = patch(28, 20, 8, 1.0);
        let strong = patch(30, 22, 2, 5.0);
        let far = patch(2, 2, 2, 1.0);
        let (s, l, st, f) = (
            small.log10_over_threshold(),
            large.log10_over_threshold(),
            strong.log10_over_threshold(),
            far.log10_over_threshold(),
        );
        assert!(l > s && st > s && f < s, "{s} {l} {st} {f}");
        // By hand: log10(c / CT(f, e)) at the best pixel.
        let e = small.eccentricity_deg.unwrap();
        let want = (1.0f64 / 21.0).log10()
            - csf
                .contrast_threshold(small.frequency_cpd.unwrap(), e)
                .log10();
        assert!((s - want).abs() < 1e-12);
    }

    #[test]
    fn luminance_of_a_frame_uses_the_transfer() {
        let t = crate::luminance::Transfer::gamma(Default::default()).unwrap();
        let l = frame_luminance(&[0, 0, 0, 255, 255, 255, 128, 128, 128], &t);
        assert_eq!(l.len(), 3);
        assert!((l[0] - t.luminance(0)).abs() < 1e-9);
        assert!((l[1] - t.luminance(255)).abs() < 1e-9);
        assert!((l[2] - t.luminance(128)).abs() < 1e-9);
    }

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
