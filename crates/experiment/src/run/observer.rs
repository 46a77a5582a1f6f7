//! A search model whose simulated observer sees what is rendered: the
//! mechanism behind `--participant-model FILE`. **It is a model, not a
//! person**: its parameters are chosen, not fitted to anyone, and every
//! session it runs is marked synthetic.
//!
//! **What it models.** At each fixation the observer examines every cell
//! it has not yet ruled out and identifies each (as the target or as not
//! the target) with probability
//!
//! `p = span(e) · quality(q) · (1 − lapse)`
//!
//! - `e` is the cell's eccentricity from the fixation (degrees, on the
//!   display). `span(e)` says whether the observer's own vision resolves,
//!   at `e`, the detail that tells the faces apart: the Geisler–Perry
//!   cutoff `f_c(e)` of the observer's CSF at the faces' feature contrast
//!   (`foveation::csf`, Murphy 2007 eq. 4.3) against `identify_cpd`, the
//!   spatial frequency the discrimination needs; a logistic of
//!   `f_c(e) / identify_cpd − 1` with width `span_softness`. This is the
//!   visual span: cells beyond it need a fixation nearer to them.
//! - `q` is the **visible fidelity** of the cell as rendered for this
//!   fixation: the frame the condition's method drew, compared with the
//!   same display at full resolution, both averaged over blocks of
//!   `1 / (2 · identify_cpd)` degrees (the detail above the needed
//!   frequency does not matter to the task), as `1 − RMS(difference) /
//!   RMS(full − its mean)` over the cell's disc, clamped to [0, 1]
//!   ([`cell_fidelity`]). `quality(q)` is a logistic of
//!   `(q − fidelity_threshold) / fidelity_slope`, scaled so that `q = 1`
//!   gives 1. A degraded rendering therefore shrinks the span: more
//!   fixations, longer searches — the effect the model implies.
//!
//! With `rendering_matters: false` the observer takes every cell as
//! rendered at full resolution (`q = 1`): the same model without the
//! rendering's effect, whose analysis must find no effect of condition.
//!
//! **The search.** The search starts at the centre (the target preview
//! was there). After each fixation's dwell (`fixation_ms`, uniform) the
//! cells are examined; if the target was identified the eye goes to it
//! (a main-sequence saccade), dwells `target_dwell_ms`, checks it against
//! the reference (when the design has one) `verify_looks` times (there and back) and
//! Space is pressed; otherwise the eye goes to the nearest of three random cells
//! not yet ruled out. After `max_fixations` without the target the
//! observer gives up and presses Space where it looks (an incorrect
//! trial). The evaluation waits for a frame rendered for a gaze within
//! [`FRESH_WITHIN_DEG`] of the fixation (the tracker's latency and the
//! render), at most [`FRESH_WAIT_MS`] beyond the dwell.

use serde::{Deserialize, Serialize};

/// A frame counts as rendered for a fixation when its gaze was within this
/// many degrees of it.
pub const FRESH_WITHIN_DEG: f64 = 1.0;
/// The longest an evaluation waits for such a frame after the dwell (ms).
pub const FRESH_WAIT_MS: f64 = 250.0;

/// The simulated observer's parameters (a RON file,
/// `config/participants/search-observer.ron`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "SearchObserver")]
pub struct ObserverModel {
    /// The observer's contrast threshold model (Geisler–Perry CT0, α, e2).
    pub csf: foveation::csf::GeislerPerry,
    /// Michelson contrast of the features that tell the faces apart.
    pub feature_contrast: f64,
    /// Spatial frequency (cycles/degree) the discrimination needs.
    pub identify_cpd: f64,
    /// Width of the span's edge, relative (logistic of `f_c / f − 1`).
    pub span_softness: f64,
    /// Visible fidelity at which identification is half as likely.
    pub fidelity_threshold: f64,
    /// Width of the fidelity's logistic.
    pub fidelity_slope: f64,
    /// Probability that a cell in view is missed anyway.
    pub lapse: f64,
    /// Dwell of a search fixation (ms), uniform in [min, max).
    pub fixation_ms: (f64, f64),
    /// Dwell on the target once identified, before Space (ms).
    pub target_dwell_ms: (f64, f64),
    /// Fixations after which the observer gives up.
    pub max_fixations: u32,
    /// Times the observer checks the target found against the reference
    /// at the centre before Space (a look at the reference and back, each
    /// dwelling `target_dwell_ms`; Murphy 2007 §7.3: "the subject then
    /// visually verified their selection against the reference mesh"). 0
    /// for designs without a reference.
    pub verify_looks: u32,
    /// `false`: every cell counts as rendered at full resolution (the
    /// model without the rendering's effect).
    pub rendering_matters: bool,
}

impl ObserverModel {
    /// Checks every parameter: the field at fault and why.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let bad = |f: &str, why: String| Err((f.to_string(), why));
        if let Err(e) = self.csf.validate() {
            return bad(&format!("csf.{}", e.field), e.to_string());
        }
        let unit = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
        if !(unit(self.feature_contrast) && self.feature_contrast > 0.0) {
            return bad(
                "feature_contrast",
                format!("{}: give a contrast in (0, 1]", self.feature_contrast),
            );
        }
        if !(self.identify_cpd.is_finite() && (0.1..=60.0).contains(&self.identify_cpd)) {
            return bad(
                "identify_cpd",
                format!("{}: give 0.1 to 60 cycles/degree", self.identify_cpd),
            );
        }
        for (f, v) in [
            ("span_softness", self.span_softness),
            ("fidelity_slope", self.fidelity_slope),
        ] {
            if !(v.is_finite() && (1e-3..=10.0).contains(&v)) {
                return bad(f, format!("{v}: give 0.001 to 10"));
            }
        }
        if !unit(self.fidelity_threshold) {
            return bad(
                "fidelity_threshold",
                format!("{}: give 0 to 1", self.fidelity_threshold),
            );
        }
        if !(unit(self.lapse) && self.lapse < 1.0) {
            return bad("lapse", format!("{}: give 0 to below 1", self.lapse));
        }
        for (f, (a, b)) in [
            ("fixation_ms", self.fixation_ms),
            ("target_dwell_ms", self.target_dwell_ms),
        ] {
            if !(a.is_finite() && b.is_finite() && 20.0 <= a && a < b && b <= 10_000.0) {
                return bad(f, format!("({a}, {b}): give 20 ≤ min < max ≤ 10000 ms"));
            }
        }
        if self.verify_looks > 10 {
            return bad(
                "verify_looks",
                format!("{}: give 0 to 10", self.verify_looks),
            );
        }
        if !(1..=1000).contains(&self.max_fixations) {
            return bad(
                "max_fixations",
                format!("{}: give 1 to 1000", self.max_fixations),
            );
        }
        Ok(())
    }

    /// Side of the blocks (px) the fidelity averages over on a display of
    /// `ppd` pixels per degree: half a period of `identify_cpd`.
    pub fn block_px(&self, ppd: f64) -> usize {
        let b = ppd / (2.0 * self.identify_cpd);
        if b.is_finite() {
            b.round().clamp(1.0, 64.0) as usize
        } else {
            1
        }
    }

    /// The visual span's factor at eccentricity `e_deg`.
    pub fn span(&self, e_deg: f64) -> f64 {
        let fc = self.csf.cutoff_frequency_cpd(self.feature_contrast, e_deg);
        if fc.is_nan() {
            return 0.0;
        }
        logistic((fc / self.identify_cpd - 1.0) / self.span_softness)
    }

    /// The rendering's factor for visible fidelity `q` (1 at `q = 1`).
    pub fn quality(&self, q: f64) -> f64 {
        if !self.rendering_matters {
            return 1.0;
        }
        let q = if q.is_nan() { 0.0 } else { q.clamp(0.0, 1.0) };
        let f = |q: f64| logistic((q - self.fidelity_threshold) / self.fidelity_slope);
        (f(q) / f(1.0)).clamp(0.0, 1.0)
    }

    /// Probability of identifying a cell at `e_deg` rendered with visible
    /// fidelity `q`.
    pub fn p_identify(&self, e_deg: f64, q: f64) -> f64 {
        (self.span(e_deg) * self.quality(q) * (1.0 - self.lapse)).clamp(0.0, 1.0)
    }
}

/// One search by the observer, advanced frame by frame
/// ([`ObserverSearch::step`]).
#[derive(Debug, Clone)]
pub struct ObserverSearch {
    /// The reference the target found is checked against (px), if any.
    reference: Option<[f64; 2]>,
    /// Where the eye is (px).
    fixation: [f64; 2],
    /// When the current fixation's cells are examined (ms after onset).
    eval_at_ms: f64,
    ruled_out: Vec<bool>,
    fixations: u32,
    space_at_ms: Option<f64>,
    found: bool,
}

/// What one step of a search gives: looks (ms after the onset, px) and,
/// once decided, when Space is pressed (ms after the onset).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SearchStep {
    /// Where the eye lands: (ms after the onset, screen px), in time order.
    pub looks: Vec<(f64, [f64; 2])>,
    /// When Space is pressed (ms after the onset), once the search has decided.
    pub space_ms: Option<f64>,
}

impl ObserverSearch {
    /// A search over `objects` objects starting with a fixation at `start`
    /// (the centre, where the preview was), with the reference at
    /// `reference` (px) when the design has one.
    pub fn start<R: rand::Rng>(
        model: &ObserverModel,
        start: [f64; 2],
        reference: Option<[f64; 2]>,
        objects: usize,
        rng: &mut R,
    ) -> Self {
        Self {
            reference,
            fixation: start,
            eval_at_ms: uniform(model.fixation_ms, rng),
            ruled_out: vec![false; objects],
            fixations: 0,
            space_at_ms: None,
            found: false,
        }
    }

    /// Where the eye is (px): where a confirming click goes.
    pub fn fixation(&self) -> [f64; 2] {
        self.fixation
    }

    /// Whether the target was identified (else the observer gave up).
    pub fn found(&self) -> bool {
        self.found
    }

    /// Fixations examined so far.
    pub fn fixations(&self) -> u32 {
        self.fixations
    }

    /// Advances the search to `elapsed_ms` after the onset. `objects`: the
    /// search objects' centres (px), `target` the target's index among
    /// them; `fidelity`: the newest frame's gaze (px) and each object's
    /// visible fidelity in it ([`cell_fidelity`]), if any.
    #[allow(clippy::too_many_arguments)]
    pub fn step<R: rand::Rng>(
        &mut self,
        model: &ObserverModel,
        geometry: &screen_geometry::ScreenGeometry,
        objects: &[[f64; 2]],
        target: Option<usize>,
        elapsed_ms: f64,
        fidelity: Option<([f64; 2], &[f64])>,
        rng: &mut R,
    ) -> SearchStep {
        let mut out = SearchStep::default();
        if self.space_at_ms.is_some() || elapsed_ms < self.eval_at_ms {
            return out;
        }
        // The frame for this fixation: rendered for a gaze near it.
        let fresh = fidelity
            .filter(|(g, q)| {
                q.len() == objects.len()
                    && geometry.eccentricity_deg(*g, self.fixation) <= FRESH_WITHIN_DEG
            })
            .map(|(_, q)| q);
        if fresh.is_none() && elapsed_ms < self.eval_at_ms + FRESH_WAIT_MS {
            return out;
        }
        let now = elapsed_ms;
        self.fixations += 1;
        for (k, o) in objects.iter().enumerate() {
            if self.ruled_out.get(k).copied().unwrap_or(true) {
                continue;
            }
            let e = geometry.eccentricity_deg(self.fixation, *o);
            let q = fresh.and_then(|q| q.get(k).copied()).unwrap_or(0.0);
            if rng.random::<f64>() < model.p_identify(e, q) {
                if Some(k) == target {
                    self.found = true;
                } else {
                    self.ruled_out[k] = true;
                }
            }
        }
        let go = |to: [f64; 2], from: [f64; 2]| {
            now + tracker_hal::sim::main_sequence_duration_ms(geometry.eccentricity_deg(from, to))
        };
        if self.found {
            let t = target
                .and_then(|k| objects.get(k))
                .copied()
                .unwrap_or(self.fixation);
            let arrive = if t == self.fixation {
                now
            } else {
                out.looks.push((now, t));
                go(t, self.fixation)
            };
            self.fixation = t;
            let mut space = arrive + uniform(model.target_dwell_ms, rng);
            // Checks against the reference: there and back, dated ahead.
            for _ in 0..model.verify_looks {
                let Some(reference) = self.reference.filter(|r| *r != t) else {
                    break;
                };
                out.looks.push((space, reference));
                let there = space
                    + tracker_hal::sim::main_sequence_duration_ms(
                        geometry.eccentricity_deg(t, reference),
                    )
                    + uniform(model.target_dwell_ms, rng);
                out.looks.push((there, t));
                space = there
                    + tracker_hal::sim::main_sequence_duration_ms(
                        geometry.eccentricity_deg(reference, t),
                    )
                    + uniform(model.target_dwell_ms, rng);
            }
            self.space_at_ms = Some(space);
            out.space_ms = Some(space);
            return out;
        }
        let open: Vec<usize> = (0..objects.len())
            .filter(|&k| !self.ruled_out[k] && objects[k] != self.fixation)
            .collect();
        if self.fixations >= model.max_fixations || open.is_empty() {
            // Gives up: Space where it looks (an incorrect trial).
            self.space_at_ms = Some(now);
            out.space_ms = Some(now);
            return out;
        }
        let here = self.fixation;
        let d = |k: usize| (objects[k][0] - here[0]).hypot(objects[k][1] - here[1]);
        let next = (0..3)
            .map(|_| open[rng.random_range(0..open.len())])
            .min_by(|&a, &b| d(a).total_cmp(&d(b)))
            .unwrap_or(open[0]);
        let to = objects[next];
        out.looks.push((now, to));
        self.eval_at_ms = go(to, here) + uniform(model.fixation_ms, rng);
        self.fixation = to;
        out
    }
}

fn uniform<R: rand::Rng>((a, b): (f64, f64), rng: &mut R) -> f64 {
    if b > a {
        rng.random_range(a..b)
    } else {
        a
    }
}

fn logistic(x: f64) -> f64 {
    if x.is_nan() {
        return 0.0;
    }
    1.0 / (1.0 + (-x).exp())
}

/// Luminance (Rec. 709 weights on the 8-bit values) of pixel `i`.
fn luma(rgb: &[u8], i: usize) -> f64 {
    let p = &rgb[3 * i..3 * i + 3];
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// The visible fidelity of each cell (centres and radius in px) of
/// `rendered` against `full` (both RGB8, `size` px): both averaged over
/// `block` × `block` pixel blocks whose centres lie in the cell's disc,
/// then `1 − RMS(rendered − full) / RMS(full − mean(full))`, clamped to
/// [0, 1]. A cell with no complete block inside the image, or buffers of
/// the wrong size, is 0 (nothing seen); a flat cell is 1 when it matches.
pub fn cell_fidelity(
    rendered: &[u8],
    full: &[u8],
    size: (u32, u32),
    centres_px: &[[f64; 2]],
    radius_px: f64,
    block: usize,
) -> Vec<f64> {
    let (w, h) = (size.0 as usize, size.1 as usize);
    let n = w.saturating_mul(h).saturating_mul(3);
    if rendered.len() != n || full.len() != n || block == 0 || !radius_px.is_finite() {
        return vec![0.0; centres_px.len()];
    }
    let r = radius_px.max(0.0);
    let b = block as f64;
    let mut pairs: Vec<(f64, f64)> = Vec::new();
    centres_px
        .iter()
        .map(|c| {
            pairs.clear();
            if !(c[0].is_finite() && c[1].is_finite()) {
                return 0.0;
            }
            let first = |v: f64| ((v - r) / b).floor().max(0.0) as usize;
            let (bx0, by0) = (first(c[0]), first(c[1]));
            let (bx1, by1) = (
                (((c[0] + r) / b).ceil().max(0.0) as usize).min(w / block),
                (((c[1] + r) / b).ceil().max(0.0) as usize).min(h / block),
            );
            for by in by0..by1 {
                for bx in bx0..bx1 {
                    let (cx, cy) = ((bx as f64 + 0.5) * b, (by as f64 + 0.5) * b);
                    if (cx - c[0]).hypot(cy - c[1]) > r {
                        continue;
                    }
                    let (mut a, mut f) = (0.0, 0.0);
                    for y in by * block..(by + 1) * block {
                        for x in bx * block..(bx + 1) * block {
                            a += luma(rendered, y * w + x);
                            f += luma(full, y * w + x);
                        }
                    }
                    let k = (block * block) as f64;
                    pairs.push((a / k, f / k));
                }
            }
            if pairs.is_empty() {
                return 0.0;
            }
            let m = pairs.len() as f64;
            let mean = pairs.iter().map(|p| p.1).sum::<f64>() / m;
            let signal = pairs.iter().map(|p| (p.1 - mean).powi(2)).sum::<f64>() / m;
            let error = pairs.iter().map(|p| (p.0 - p.1).powi(2)).sum::<f64>() / m;
            if signal <= 1e-12 {
                return if error <= 1e-12 { 1.0 } else { 0.0 };
            }
            (1.0 - (error / signal).sqrt()).clamp(0.0, 1.0)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    pub(crate) fn shipped() -> ObserverModel {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/participants/search-observer.ron"
        ))
        .expect("observer file");
        ron::from_str(&text).expect("observer")
    }

    #[test]
    fn the_shipped_observer_is_valid_and_its_span_and_quality_fall() {
        let m = shipped();
        m.validate().expect("valid");
        // The span falls with eccentricity; at the fovea it is near 1.
        assert!(m.span(0.0) > 0.95);
        assert!(m.span(2.0) > m.span(6.0) && m.span(6.0) > m.span(15.0));
        assert!(m.span(60.0) < 0.05);
        // Fidelity: 1 at full fidelity, falling below the threshold.
        assert!((m.quality(1.0) - 1.0).abs() < 1e-12);
        assert!(m.quality(m.fidelity_threshold) < 0.6);
        assert!(m.quality(0.0) < 0.01);
        let off = ObserverModel {
            rendering_matters: false,
            ..m.clone()
        };
        assert_eq!(off.quality(0.0), 1.0);
    }

    #[test]
    fn bad_parameters_name_their_field() {
        let m = shipped();
        let cases: Vec<(ObserverModel, &str)> = vec![
            (
                ObserverModel {
                    identify_cpd: 0.0,
                    ..m.clone()
                },
                "identify_cpd",
            ),
            (
                ObserverModel {
                    lapse: 1.0,
                    ..m.clone()
                },
                "lapse",
            ),
            (
                ObserverModel {
                    fixation_ms: (300.0, 200.0),
                    ..m.clone()
                },
                "fixation_ms",
            ),
            (
                ObserverModel {
                    fidelity_threshold: f64::NAN,
                    ..m.clone()
                },
                "fidelity_threshold",
            ),
            (
                ObserverModel {
                    max_fixations: 0,
                    ..m.clone()
                },
                "max_fixations",
            ),
            (
                ObserverModel {
                    csf: foveation::csf::GeislerPerry { ct0: 2.0, ..m.csf },
                    ..m.clone()
                },
                "csf.ct0",
            ),
        ];
        for (bad, field) in cases {
            assert_eq!(bad.validate().map_err(|e| e.0), Err(field.to_string()));
        }
    }

    fn picture(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Vec<u8> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .flat_map(|(x, y)| {
                let v = f(x, y);
                [v, v, v]
            })
            .collect()
    }

    #[test]
    fn fidelity_is_one_for_the_same_picture_and_falls_with_blur() {
        let (w, h) = (64, 48);
        let full = picture(w, h, |x, y| if (x / 4 + y / 4) % 2 == 0 { 200 } else { 40 });
        let flat = picture(w, h, |_, _| 120);
        let centres = [[20.0, 20.0], [44.0, 24.0], [1000.0, 1000.0]];
        let same = cell_fidelity(&full, &full, (w, h), &centres, 12.0, 4);
        assert_eq!(same[..2], [1.0, 1.0]);
        assert_eq!(same[2], 0.0, "a cell off the picture is not seen");
        let lost = cell_fidelity(&flat, &full, (w, h), &centres, 12.0, 4);
        assert!(lost[0] < 0.1, "{lost:?}");
        // Averaged over blocks of 8 the checkerboard of 4 is flat: its
        // loss is detail above the needed frequency, invisible to the task.
        let coarse = cell_fidelity(&flat, &full, (w, h), &centres, 12.0, 8);
        assert!(coarse[0] > 0.9, "{coarse:?}");
        // Wrong sizes see nothing rather than read out of bounds.
        assert_eq!(
            cell_fidelity(&full[3..], &full, (w, h), &centres, 12.0, 4),
            vec![0.0; 3]
        );
    }

    /// Mean fixations of `n` searches on the seed's grid where every cell
    /// but the one fixated has visible fidelity `q`.
    fn mean_fixations(m: &ObserverModel, q: f64, n: u64) -> f64 {
        use crate::run::layout::Layout;
        use crate::run::test_support::{murphy, seed_display};
        use rand::SeedableRng;
        let g = seed_display();
        let l = Layout::new(&murphy(), &g);
        let objects: Vec<[f64; 2]> = l.centres_px.clone();
        let mut total = 0.0;
        for seed in 0..n {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let target = (seed as usize * 7 + 3) % objects.len();
            let mut s = ObserverSearch::start(m, g.centre_px(), None, objects.len(), &mut rng);
            let mut t = 0.0;
            while s.space_at_ms.is_none() {
                t += 1000.0 / 60.0;
                // The frame for where the eye is: the fovea at full detail.
                let fid: Vec<f64> = objects
                    .iter()
                    .map(|o| {
                        if g.eccentricity_deg(*o, s.fixation()) < 2.0 {
                            1.0
                        } else {
                            q
                        }
                    })
                    .collect();
                s.step(
                    m,
                    &g,
                    &objects,
                    Some(target),
                    t,
                    Some((s.fixation(), &fid)),
                    &mut rng,
                );
                assert!(t < 600_000.0, "a search ends");
            }
            assert!(s.found() || s.fixations() >= m.max_fixations);
            total += f64::from(s.fixations());
        }
        total / n as f64
    }

    /// The mechanism: a degraded periphery needs more fixations; without
    /// the rendering's effect it needs the same.
    #[test]
    fn a_degraded_rendering_needs_more_fixations_and_none_without_the_effect() {
        let m = shipped();
        let full = mean_fixations(&m, 1.0, 200);
        let degraded = mean_fixations(&m, 0.5, 200);
        assert!(degraded > 1.2 * full, "{full} vs {degraded}");
        let off = ObserverModel {
            rendering_matters: false,
            ..m
        };
        assert_eq!(
            mean_fixations(&off, 1.0, 200),
            mean_fixations(&off, 0.5, 200)
        );
    }

    proptest! {
        #[test]
        fn probabilities_stay_in_the_unit_interval(
            e in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(-1.0), 0.0f64..200.0],
            q in prop_oneof![Just(f64::NAN), Just(-3.0), Just(7.0), 0.0f64..1.0],
        ) {
            let m = shipped();
            let p = m.p_identify(e, q);
            prop_assert!((0.0..=1.0).contains(&p), "{p}");
        }

        #[test]
        fn fidelity_stays_in_the_unit_interval(
            seed in any::<u64>(),
            r in prop_oneof![Just(0.0), Just(f64::NAN), Just(1e9), 0.0f64..40.0],
            block in 1usize..12,
        ) {
            let (w, h) = (40u32, 30u32);
            let a = picture(w, h, |x, y| ((u64::from(x * 31 + y * 17) ^ seed) % 256) as u8);
            let b = picture(w, h, |x, y| ((u64::from(x * 7 + y * 3) ^ seed) % 256) as u8);
            for q in cell_fidelity(&a, &b, (w, h), &[[10.0, 10.0], [f64::NAN, 3.0]], r, block) {
                prop_assert!((0.0..=1.0).contains(&q), "{q}");
            }
        }
    }
}
