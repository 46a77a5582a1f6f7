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
//! applied to each channel as if it were a grey level). Their difference
//! `D = A − B` is split into octave bands, Peli's (1990) band-limited
//! local contrast: band `k` is `G(σ_k) ∗ D − G(2σ_k) ∗ D` (a difference of
//! Gaussians, σ_k = 0.5, 1, 2, … px while 2σ_k is at most a quarter of the
//! frame's shorter side, at most 7 bands), divided by the local mean
//! luminance `G(2σ_k) ∗ (A + B)/2` and by the band's peak gain (0.472:
//! a grating at the band's peak frequency of contrast `c` gives `c`). The
//! band's frequency is its peak, `√(ln 4 / 6) / (π σ_k)` cycles per pixel,
//! in cycles/degree through the local pixels per degree. At every pixel
//! and band the contrast is set against the observer's Geisler–Perry
//! threshold `CT(f, e)` at that pixel's eccentricity from the gaze; the
//! difference's visibility is the largest `log10(c / CT(f, e))` over
//! pixels and bands (a max rule: no probability summation), and the
//! observer names the simplified interval correctly with its psychometric
//! function's probability at that value
//! ([`crate::observer::SimulatedObserver::respond_at`]): at chance (its
//! guess rate) when nothing differs, `p_threshold` when the most visible
//! band is exactly at threshold. A model of a detector, not a person; the
//! bands are isotropic (no orientation channels) and the frames are taken
//! as seen for as long as the observer likes.

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
    /// Upper end of the exact interval of the proportion.
    pub ci_high: f64,
    /// Confidence level of `ci_low`..`ci_high` (from the configuration, in (0, 1)).
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
    /// Contrast of the largest difference (Michelson).
    pub contrast: Option<f64>,
    /// Spatial frequency of the largest difference, cycles/degree.
    pub frequency_cpd: Option<f64>,
    /// Eccentricity of the largest difference, degrees from the gaze.
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

/// `img` (row-major, `w` × `h`) blurred by a Gaussian of `sigma` px, the
/// edges clamped.
fn gaussian_blur(img: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let mut k: Vec<f64> = (-r..=r)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut across = vec![0.0; w * h];
    for y in 0..h {
        let row = &img[y * w..(y + 1) * w];
        for x in 0..w {
            across[y * w + x] = k
                .iter()
                .enumerate()
                .map(|(j, kv)| kv * row[clamp(x as isize + j as isize - r, w)])
                .sum();
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = k
                .iter()
                .enumerate()
                .map(|(j, kv)| kv * across[clamp(y as isize + j as isize - r, h) * w + x])
                .sum();
        }
    }
    out
}

/// The peak gain of a difference of Gaussians σ and 2σ:
/// `4^(−1/3) − 4^(−4/3)`.
const DOG_PEAK_GAIN: f64 = 0.472_470_393_710_577_4;

/// The frequency (cycles per pixel) of that peak for σ = 1 px:
/// `√(ln 4 / 6) / π`.
const DOG_PEAK_CYCLES_PER_PX: f64 = 0.153_003_804_715_964_4;

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
    let mut best = DifferenceVisibility {
        differing_pixels: a.iter().zip(b).filter(|(x, y)| x != y).count(),
        max_log10_over_threshold: None,
        at_px: None,
        contrast: None,
        frequency_cpd: None,
        eccentricity_deg: None,
    };
    if best.differing_pixels == 0 {
        return Ok(best);
    }
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let mean: Vec<f64> = a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect();
    // Each pixel's eccentricity and pixels per degree, once.
    let at = |i: usize| [(i % w) as f64 + 0.5, (i / w) as f64 + 0.5];
    let ecc: Vec<f64> = (0..w * h)
        .map(|i| geometry.eccentricity_deg(at(i), gaze_px))
        .collect();
    let ppd: Vec<f64> = (0..w * h).map(|i| geometry.local_ppd(at(i))).collect();
    let mut sigma = 0.5;
    let mut fine = gaussian_blur(&d, w, h, sigma);
    for _ in 0..7 {
        if 2.0 * sigma > w.min(h) as f64 / 4.0 {
            break;
        }
        let coarse = gaussian_blur(&d, w, h, 2.0 * sigma);
        let local = gaussian_blur(&mean, w, h, 2.0 * sigma);
        for i in 0..w * h {
            let band = (fine[i] - coarse[i]).abs();
            if !(local[i] > 0.0 && band > 0.0) {
                continue;
            }
            let c = (band / (DOG_PEAK_GAIN * local[i])).min(1.0);
            let f = DOG_PEAK_CYCLES_PER_PX / sigma * ppd[i];
            let v = c.log10() - csf.contrast_threshold(f, ecc[i]).log10();
            if v.is_finite() && best.max_log10_over_threshold.is_none_or(|m| v > m) {
                best.max_log10_over_threshold = Some(v);
                best.at_px = Some([(i % w) as u32, (i / w) as u32]);
                best.contrast = Some(c);
                best.frequency_cpd = Some(f);
                best.eccentricity_deg = Some(ecc[i]);
            }
        }
        fine = coarse;
        sigma *= 2.0;
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
        let e = small.eccentricity_deg.unwrap();
        let want = small.contrast.unwrap().log10()
            - csf
                .contrast_threshold(small.frequency_cpd.unwrap(), e)
                .log10();
        assert!((s - want).abs() < 1e-12);
    }

    #[test]
    fn a_grating_difference_reads_as_its_contrast_at_its_frequency() {
        // The constants: the peak of exp(−2π²σ²f²) − exp(−8π²σ²f²).
        let u = 4f64.ln() / 3.0;
        assert!(((-u).exp() - (-4.0 * u).exp() - DOG_PEAK_GAIN).abs() < 1e-12);
        let f = (u / (2.0 * std::f64::consts::PI.powi(2))).sqrt();
        assert!((f - DOG_PEAK_CYCLES_PER_PX).abs() < 1e-12);
        // A vertical grating of contrast 0.05 at the σ = 4 px band's peak,
        // added to a uniform field: read there as 0.05 (within 5 %).
        let g = screen_geometry::Display::seed_17in(256, 128)
            .geometry()
            .unwrap();
        let period = 4.0 / DOG_PEAK_CYCLES_PER_PX;
        let a = vec![10.0; 256 * 128];
        let b: Vec<f64> = (0..256 * 128)
            .map(|i| {
                let x = (i % 256) as f64 + 0.5;
                10.0 * (1.0 + 0.05 * (2.0 * std::f64::consts::PI * x / period).sin())
            })
            .collect();
        // A CSF flat in frequency and eccentricity: the largest contrast wins.
        let flat = foveation::GeislerPerry {
            ct0: 0.01,
            alpha: 1e-9,
            e2_deg: 2.3,
        };
        let v = difference_visibility(&a, &b, &g, g.centre_px(), &flat).unwrap();
        let c = v.contrast.unwrap();
        assert!((c - 0.05).abs() < 0.0025, "{v:?}");
        let ppd = g.local_ppd([128.0, 64.0]);
        let want_f = DOG_PEAK_CYCLES_PER_PX / 4.0 * ppd;
        assert!(
            (v.frequency_cpd.unwrap() / want_f - 1.0).abs() < 0.1,
            "{v:?}"
        );
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
