//! Fitting the Geisler–Perry CSF to measured thresholds, with bootstrap
//! confidence intervals, and the [`ThresholdTable`] the renderer reads.
//!
//! # The fit
//!
//! `CT(f, e) = CT0·exp(α·f·(e + e2)/e2)` (csf.rs) is, in natural-log
//! threshold,
//!
//! `ln CT = ln CT0 + α·f + (α/e2)·f·e`,
//!
//! linear in `a = ln CT0`, `b = α` and `c = α/e2` with regressors 1, f and
//! f·e. So the least-squares fit on log threshold is a 3 × 3 linear solve,
//! no iteration and no starting values: `CT0 = eᵃ`, `α = b`, `e2 = b/c`.
//! Weighted, each condition counts `1/sd²` (its log10 sd, floored at
//! `min_sd_log10` so no condition dominates). Censored and abandoned
//! conditions are left out. The fit needs at least two eccentricities and
//! two frequencies among the used conditions and must give α > 0 and
//! α/e2 > 0; otherwise it is an error naming the cause.
//!
//! # Bootstrap
//!
//! Each resample redraws every used condition's trials with replacement
//! (as many as it had) and re-estimates its threshold the way the session
//! did: QUEST's posterior mean from the prior and the redrawn trials (the
//! posterior is a product over trials, so it does not depend on their
//! order), or, for an up-down staircase, the mean of a redraw of its used
//! reversals. The fit is repeated on those thresholds (with the original
//! weights); the percentile interval of each parameter over the resamples
//! is reported. Resamples whose fit fails (α or α/e2 ≤ 0) are counted in
//! `failed_resamples` and left out of the intervals. Seeded ChaCha8.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use foveation::perceptibility::{ThresholdTable, ThresholdTableData};
use foveation::GeislerPerry;

use crate::quest::{normalise, QuestMethod};
use crate::ramp::RampSession;
use crate::session::{ConditionResult, Session, Track};
use crate::ParamError;

/// How to fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitOptions {
    /// Weight conditions by `1/sd²` (else equally).
    pub weighted: bool,
    /// Floor on a condition's log10 sd in the weights (> 0).
    pub min_sd_log10: f64,
    /// Bootstrap resamples (0: no intervals; they are then the estimate).
    pub bootstrap_resamples: u32,
    /// Confidence level of the intervals, in (0, 1).
    pub ci_level: f64,
    /// Seed of the resampling.
    pub seed: u64,
}

impl Default for FitOptions {
    /// Weighted, sd floor 0.03 log10, 200 resamples, 95 %.
    fn default() -> Self {
        Self {
            weighted: true,
            min_sd_log10: 0.03,
            bootstrap_resamples: 200,
            ci_level: 0.95,
            seed: 1,
        }
    }
}

/// One measured threshold for the fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitPoint {
    /// Spatial frequency, cycles/degree.
    pub frequency_cpd: f64,
    /// Eccentricity, degrees.
    pub eccentricity_deg: f64,
    /// Threshold, log10 contrast.
    pub log10_threshold: f64,
    /// Its standard deviation, log10.
    pub sd_log10: f64,
}

/// A parameter with its bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The fit to the measured thresholds.
    pub estimate: f64,
    /// Lower end of the percentile interval.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
}

/// The fitted Geisler–Perry parameters and how they were obtained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeislerPerryFit {
    /// True when any answer came from a simulated observer.
    pub synthetic: bool,
    /// CT0.
    pub ct0: Estimate,
    /// α.
    pub alpha: Estimate,
    /// e2, degrees.
    pub e2_deg: Estimate,
    /// Confidence level of the intervals.
    pub ci_level: f64,
    /// Resamples drawn.
    pub bootstrap_resamples: u32,
    /// Resamples whose fit failed (left out of the intervals).
    pub failed_resamples: u32,
    /// Seed of the resampling.
    pub seed: u64,
    /// Weighted by 1/sd²?
    pub weighted: bool,
    /// Conditions used.
    pub conditions_used: u32,
    /// Conditions left out as censored or abandoned.
    pub conditions_left_out: u32,
    /// Root-mean-square residual of the used thresholds, log10.
    pub rms_residual_log10: f64,
}

impl GeislerPerryFit {
    /// The point estimate as a model.
    pub fn model(&self) -> GeislerPerry {
        GeislerPerry {
            ct0: self.ct0.estimate,
            alpha: self.alpha.estimate,
            e2_deg: self.e2_deg.estimate,
        }
    }
}

/// Fits `points` by (weighted) least squares on log threshold (module doc).
pub fn fit_points(
    points: &[FitPoint],
    weighted: bool,
    min_sd_log10: f64,
) -> Result<GeislerPerry, ParamError> {
    let mut ecc: Vec<f64> = points.iter().map(|p| p.eccentricity_deg).collect();
    ecc.sort_by(f64::total_cmp);
    ecc.dedup();
    let mut freq: Vec<f64> = points.iter().map(|p| p.frequency_cpd).collect();
    freq.sort_by(f64::total_cmp);
    freq.dedup();
    if ecc.len() < 2 || freq.len() < 2 {
        return Err(ParamError::new(
            "thresholds",
            points.len(),
            format!(
                "the fit needs measured thresholds at two or more frequencies and \
                 eccentricities (have {} and {})",
                freq.len(),
                ecc.len()
            ),
        ));
    }
    let mut ata = [[0.0f64; 3]; 3];
    let mut aty = [0.0f64; 3];
    for p in points {
        for (field, v) in [
            ("frequency_cpd", p.frequency_cpd),
            ("eccentricity_deg", p.eccentricity_deg),
            ("log10_threshold", p.log10_threshold),
            ("sd_log10", p.sd_log10),
        ] {
            if !v.is_finite() {
                return Err(ParamError::new(field, v, "a fit point must be finite"));
            }
        }
        let w = if weighted {
            1.0 / p.sd_log10.max(min_sd_log10).powi(2)
        } else {
            1.0
        };
        let x = [1.0, p.frequency_cpd, p.frequency_cpd * p.eccentricity_deg];
        let y = p.log10_threshold * std::f64::consts::LN_10;
        for i in 0..3 {
            aty[i] += w * x[i] * y;
            for j in 0..3 {
                ata[i][j] += w * x[i] * x[j];
            }
        }
    }
    let [a, b, c] = solve3(ata, aty).ok_or_else(|| {
        ParamError::new(
            "thresholds",
            points.len(),
            "the frequencies and eccentricities do not determine CT0, α and e2 (singular fit)",
        )
    })?;
    if b.is_nan() || b <= 0.0 {
        return Err(ParamError::new(
            "alpha",
            b,
            "the fit gives α ≤ 0: thresholds do not rise with frequency",
        ));
    }
    if c.is_nan() || c <= 0.0 {
        return Err(ParamError::new(
            "e2_deg",
            b / c,
            "the fit gives α/e2 ≤ 0: thresholds do not rise with eccentricity",
        ));
    }
    Ok(GeislerPerry {
        ct0: a.exp(),
        alpha: b,
        e2_deg: b / c,
    })
}

/// Gaussian elimination with partial pivoting; `None` when singular.
fn solve3(mut m: [[f64; 3]; 3], mut v: [f64; 3]) -> Option<[f64; 3]> {
    let scale = m
        .iter()
        .flatten()
        .fold(0.0f64, |s, x| s.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, piv);
        v.swap(col, piv);
        for r in col + 1..3 {
            let k = m[r][col] / m[col][col];
            let pivot_row = m[col];
            for (x, p) in m[r].iter_mut().zip(pivot_row).skip(col) {
                *x -= k * p;
            }
            v[r] -= k * v[col];
        }
    }
    let mut x = [0.0; 3];
    for r in (0..3).rev() {
        let s: f64 = (r + 1..3).map(|cc| m[r][cc] * x[cc]).sum();
        x[r] = (v[r] - s) / m[r][r];
    }
    x.iter().all(|x| x.is_finite()).then_some(x)
}

/// The conditions a fit uses: neither censored nor abandoned.
pub fn fit_points_of(session: &Session) -> Vec<(usize, FitPoint)> {
    fit_points_of_results(&session.results())
}

/// The conditions among `results` a fit uses: neither censored nor
/// abandoned, with at least one valid trial.
pub fn fit_points_of_results(results: &[ConditionResult]) -> Vec<(usize, FitPoint)> {
    results
        .iter()
        .enumerate()
        .filter(|(_, r)| !r.censored && !r.abandoned && r.valid_trials > 0)
        .map(|(i, r)| {
            (
                i,
                FitPoint {
                    frequency_cpd: r.frequency_cpd,
                    eccentricity_deg: r.eccentricity_deg,
                    log10_threshold: r.log10_threshold,
                    sd_log10: r.sd_log10,
                },
            )
        })
        .collect()
}

/// A condition's resampler.
enum Resampler {
    Quest {
        prior: Vec<f64>,
        grid: Vec<f64>,
        trial_ll: Vec<Vec<f64>>,
        method: QuestMethod,
    },
    Reversals(Vec<f64>),
    /// A ramp condition's samples (log10): the mean of a redraw.
    Samples(Vec<f64>),
}

impl Resampler {
    fn new(track: &Track) -> Self {
        match track {
            Track::Quest(q) => {
                let p = q.params();
                let grid = q.grid().to_vec();
                let prior = grid
                    .iter()
                    .map(|t| -0.5 * ((t - p.t_guess) / p.t_guess_sd).powi(2))
                    .collect();
                let trial_ll = q
                    .trials()
                    .iter()
                    .map(|&(x, r)| q.log_likelihood(x, r))
                    .collect();
                Resampler::Quest {
                    prior,
                    grid,
                    trial_ll,
                    method: p.method,
                }
            }
            Track::Staircase(s) => Resampler::Reversals(s.used_reversals().to_vec()),
        }
    }

    fn draw(&self, rng: &mut ChaCha8Rng, scratch: &mut Vec<f64>) -> f64 {
        match self {
            Resampler::Quest {
                prior,
                grid,
                trial_ll,
                method,
            } => {
                scratch.clear();
                scratch.extend_from_slice(prior);
                let n = trial_ll.len();
                for _ in 0..n {
                    let ll = &trial_ll[rng.random_range(0..n)];
                    for (s, l) in scratch.iter_mut().zip(ll) {
                        *s += l;
                    }
                }
                let pdf = normalise(scratch);
                match method {
                    QuestMethod::Mode => {
                        let i = (0..pdf.len())
                            .max_by(|&i, &j| pdf[i].total_cmp(&pdf[j]))
                            .unwrap_or(0);
                        grid[i]
                    }
                    QuestMethod::Quantile => {
                        let mut cum = 0.0;
                        let mut out = grid[grid.len() - 1];
                        for (p, t) in pdf.iter().zip(grid) {
                            cum += p;
                            if cum >= 0.5 {
                                out = *t;
                                break;
                            }
                        }
                        out
                    }
                    QuestMethod::Mean => pdf.iter().zip(grid).map(|(p, t)| p * t).sum(),
                }
            }
            Resampler::Reversals(r) | Resampler::Samples(r) => {
                if r.is_empty() {
                    return f64::NAN;
                }
                let n = r.len();
                (0..n).map(|_| r[rng.random_range(0..n)]).sum::<f64>() / n as f64
            }
        }
    }
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let (i, frac) = (pos.floor() as usize, pos - pos.floor());
    let j = (i + 1).min(sorted.len() - 1);
    sorted[i] + (sorted[j] - sorted[i]) * frac
}

/// Fits a session's thresholds and bootstraps the intervals.
pub fn fit_session(session: &Session, options: &FitOptions) -> Result<GeislerPerryFit, ParamError> {
    let results = session.results();
    let resamplers = fit_points_of_results(&results)
        .iter()
        .map(|(i, _)| Resampler::new(&session.tracks()[*i]))
        .collect();
    fit_with(&results, resamplers, session.is_synthetic(), options)
}

/// Fits a Luebke & Hallen ramp session's thresholds (each condition's
/// geometric mean, weighted by its standard error) and bootstraps the
/// intervals by redrawing each condition's samples.
pub fn fit_ramp(
    session: &RampSession,
    options: &FitOptions,
) -> Result<GeislerPerryFit, ParamError> {
    let results = session.results();
    let resamplers = fit_points_of_results(&results)
        .iter()
        .map(|(i, _)| Resampler::Samples(session.samples(*i).to_vec()))
        .collect();
    fit_with(&results, resamplers, session.is_synthetic(), options)
}

/// The fit of `results` with one resampler per used condition.
fn fit_with(
    results: &[ConditionResult],
    resamplers: Vec<Resampler>,
    synthetic: bool,
    options: &FitOptions,
) -> Result<GeislerPerryFit, ParamError> {
    if !(options.min_sd_log10.is_finite() && options.min_sd_log10 > 0.0) {
        return Err(ParamError::new(
            "min_sd_log10",
            options.min_sd_log10,
            "must be finite and > 0",
        ));
    }
    if !(options.ci_level > 0.0 && options.ci_level < 1.0) {
        return Err(ParamError::new(
            "ci_level",
            options.ci_level,
            "must be in (0, 1)",
        ));
    }
    let used = fit_points_of_results(results);
    let points: Vec<FitPoint> = used.iter().map(|(_, p)| *p).collect();
    let model = fit_points(&points, options.weighted, options.min_sd_log10)?;
    let n_cond = results.len();
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut scratch = Vec::new();
    let (mut ct0s, mut alphas, mut e2s) = (Vec::new(), Vec::new(), Vec::new());
    let mut failed = 0u32;
    let mut resampled = points.clone();
    for _ in 0..options.bootstrap_resamples {
        for (p, r) in resampled.iter_mut().zip(&resamplers) {
            p.log10_threshold = r.draw(&mut rng, &mut scratch);
        }
        match fit_points(&resampled, options.weighted, options.min_sd_log10) {
            Ok(m) => {
                ct0s.push(m.ct0);
                alphas.push(m.alpha);
                e2s.push(m.e2_deg);
            }
            Err(_) => failed += 1,
        }
    }
    let tail = (1.0 - options.ci_level) / 2.0;
    let interval = |mut v: Vec<f64>, estimate: f64| {
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            Estimate {
                estimate,
                ci_low: estimate,
                ci_high: estimate,
            }
        } else {
            Estimate {
                estimate,
                ci_low: percentile(&v, tail),
                ci_high: percentile(&v, 1.0 - tail),
            }
        }
    };
    let rms = (points
        .iter()
        .map(|p| {
            let r = p.log10_threshold
                - model
                    .contrast_threshold(p.frequency_cpd, p.eccentricity_deg)
                    .log10();
            r * r
        })
        .sum::<f64>()
        / points.len() as f64)
        .sqrt();
    Ok(GeislerPerryFit {
        synthetic,
        ct0: interval(ct0s, model.ct0),
        alpha: interval(alphas, model.alpha),
        e2_deg: interval(e2s, model.e2_deg),
        ci_level: options.ci_level,
        bootstrap_resamples: options.bootstrap_resamples,
        failed_resamples: failed,
        seed: options.seed,
        weighted: options.weighted,
        conditions_used: points.len() as u32,
        conditions_left_out: (n_cond - points.len()) as u32,
        rms_residual_log10: rms,
    })
}

/// The session's thresholds as a [`ThresholdTable`] on its grid (rows by
/// eccentricity): measured thresholds where a condition was used by the
/// fit; the fitted model's prediction, raised to at least the display's
/// highest contrast, where it was censored; the fitted prediction where it
/// was abandoned.
pub fn threshold_table(
    session: &Session,
    fit: &GeislerPerryFit,
) -> Result<ThresholdTable, ParamError> {
    let spec = session.spec();
    let max_contrast: Vec<f64> = session
        .tracks()
        .iter()
        .map(|t| {
            10f64.powf(match t {
                Track::Quest(q) => q.params().max_intensity,
                Track::Staircase(s) => s.params().max_intensity,
            })
        })
        .collect();
    table_with(
        &spec.frequencies_cpd,
        &spec.eccentricities_deg,
        &session.results(),
        &max_contrast,
        fit,
    )
}

/// [`threshold_table`] of a Luebke & Hallen ramp session (the same rules;
/// the display's highest contrast is the ramp's end).
pub fn ramp_threshold_table(
    session: &RampSession,
    fit: &GeislerPerryFit,
) -> Result<ThresholdTable, ParamError> {
    let spec = session.spec();
    let results = session.results();
    let max_contrast = vec![spec.max_contrast; results.len()];
    table_with(
        &spec.frequencies_cpd,
        &spec.eccentricities_deg,
        &results,
        &max_contrast,
        fit,
    )
}

fn table_with(
    frequencies_cpd: &[f64],
    eccentricities_deg: &[f64],
    results: &[ConditionResult],
    max_contrast: &[f64],
    fit: &GeislerPerryFit,
) -> Result<ThresholdTable, ParamError> {
    let nf = frequencies_cpd.len().max(1);
    let model = fit.model();
    let rows = results
        .chunks(nf)
        .enumerate()
        .map(|(ei, row)| {
            row.iter()
                .enumerate()
                .map(|(fi, r)| {
                    let predicted = model.contrast_threshold(r.frequency_cpd, r.eccentricity_deg);
                    if r.censored && !r.abandoned {
                        predicted.max(max_contrast.get(ei * nf + fi).copied().unwrap_or(1.0))
                    } else if r.abandoned || r.valid_trials == 0 {
                        predicted
                    } else {
                        r.threshold
                    }
                })
                .collect()
        })
        .collect();
    ThresholdTable::try_from(ThresholdTableData {
        frequencies_cpd: frequencies_cpd.to_vec(),
        eccentricities_deg: eccentricities_deg.to_vec(),
        thresholds: rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_model_thresholds_are_fitted_exactly() {
        let truth = GeislerPerry {
            ct0: 0.012,
            alpha: 0.09,
            e2_deg: 3.1,
        };
        let mut pts = Vec::new();
        for f in [1.0, 3.0, 9.0] {
            for e in [0.0, 4.0, 12.0] {
                pts.push(FitPoint {
                    frequency_cpd: f,
                    eccentricity_deg: e,
                    log10_threshold: truth.contrast_threshold(f, e).log10(),
                    sd_log10: 0.1,
                });
            }
        }
        for weighted in [false, true] {
            let m = fit_points(&pts, weighted, 0.03).unwrap();
            assert!((m.ct0 / truth.ct0 - 1.0).abs() < 1e-9, "{m:?}");
            assert!((m.alpha / truth.alpha - 1.0).abs() < 1e-9, "{m:?}");
            assert!((m.e2_deg / truth.e2_deg - 1.0).abs() < 1e-9, "{m:?}");
        }
    }

    #[test]
    fn degenerate_designs_are_refused_with_the_cause() {
        let p = |f: f64, e: f64, l: f64| FitPoint {
            frequency_cpd: f,
            eccentricity_deg: e,
            log10_threshold: l,
            sd_log10: 0.1,
        };
        let one_ecc = [p(1.0, 0.0, -2.0), p(2.0, 0.0, -1.9), p(4.0, 0.0, -1.7)];
        let e = fit_points(&one_ecc, true, 0.03).unwrap_err();
        assert!(e.reason.contains("two or more"), "{e}");
        // Thresholds falling with eccentricity: no positive e2.
        let falling = [
            p(1.0, 0.0, -2.0),
            p(4.0, 0.0, -1.6),
            p(1.0, 10.0, -2.1),
            p(4.0, 10.0, -2.0),
        ];
        assert_eq!(
            fit_points(&falling, true, 0.03).unwrap_err().field,
            "e2_deg"
        );
        let nan = [p(1.0, 0.0, f64::NAN), p(4.0, 5.0, -1.6)];
        assert_eq!(
            fit_points(&nan, true, 0.03).unwrap_err().field,
            "log10_threshold"
        );
    }
}
