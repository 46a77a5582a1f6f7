//! QUEST (Watson & Pelli 1983), as in Pelli's `Quest` toolbox and
//! PsychoPy's `QuestHandler`: a Bayesian threshold estimate on a grid of
//! log10 intensities.
//!
//! Intensities are log10 contrasts. The psychometric function is the
//! Weibull of the toolbox,
//!
//! `P(x; T) = δγ + (1 − δ)·(1 − (1 − γ)·exp(−10^(β(x − T + x_T))))`,
//!
//! with slope β, lapse rate δ, guess rate γ and `x_T` chosen so that
//! `P(T; T) = p_threshold` (the threshold is defined at that proportion
//! correct). The prior is a Gaussian on T (mean `t_guess`, sd
//! `t_guess_sd`), sampled on `t_guess ± range/2` every `grain`. Each
//! response multiplies the posterior by the likelihood of that response,
//! evaluated exactly at every grid point (the toolbox reads it from a table
//! indexed by the rounded intensity; both agree at intensities on the grid).
//! The estimate is the posterior mean, mode or a quantile (the toolbox's
//! `QuestMean`, `QuestMode`, `QuestQuantile`); the next trial is placed at
//! the estimate chosen by [`QuestMethod`], clamped to `[min, max]`
//! intensities the display can show.

use serde::{Deserialize, Serialize};

use crate::ParamError;

/// How the next intensity (and the reported estimate) is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum QuestMethod {
    /// Posterior median (quantile 0.5). The toolbox's `QuestQuantile`
    /// defaults instead to a quantile order computed from the
    /// psychometric function (`q.quantileOrder`, after King-Smith et al.
    /// 1994); that order is not implemented here.
    Quantile,
    /// Posterior mean (King-Smith et al. 1994 recommend it).
    Mean,
    /// Posterior mode (Watson & Pelli's original maximum).
    Mode,
}

/// QUEST's parameters; the defaults are the toolbox's (β 3.5, δ 0.01,
/// γ 0.5, p 0.82, grain 0.01, range 5) with a 2AFC guess rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuestParams {
    /// Prior mean of the threshold, log10 contrast.
    pub t_guess: f64,
    /// Prior standard deviation, log10 units (> 0; be generous).
    pub t_guess_sd: f64,
    /// Proportion correct that defines the threshold, in (γ, 1 − δ(1 − γ)).
    pub p_threshold: f64,
    /// Weibull slope β (> 0).
    pub beta: f64,
    /// Lapse rate δ: fraction of trials answered blindly, [0, 0.5).
    pub delta: f64,
    /// Guess rate γ: proportion correct when blind, [0, 1) (2AFC: 0.5).
    pub gamma: f64,
    /// Grid step, log10 units (> 0).
    pub grain: f64,
    /// Width of the grid, log10 units, centred on `t_guess` (> grain).
    pub range: f64,
    /// Estimate and placement rule.
    pub method: QuestMethod,
    /// Lowest and highest intensity that can be shown, log10 contrast.
    pub min_intensity: f64,
    /// See `min_intensity`; log10 of the largest contrast (0 = contrast 1).
    pub max_intensity: f64,
}

impl Default for QuestParams {
    fn default() -> Self {
        Self {
            t_guess: -1.5,
            t_guess_sd: 1.0,
            p_threshold: 0.82,
            beta: 3.5,
            delta: 0.01,
            gamma: 0.5,
            grain: 0.01,
            range: 5.0,
            method: QuestMethod::Mean,
            min_intensity: -4.0,
            max_intensity: 0.0,
        }
    }
}

fn check(field: &'static str, v: f64, ok: bool, what: &str) -> Result<(), ParamError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(ParamError::new(
            field,
            v,
            format!("must be finite and {what}"),
        ))
    }
}

impl QuestParams {
    /// Checks every field (ranges in the field docs).
    pub fn validate(&self) -> Result<(), ParamError> {
        check("t_guess", self.t_guess, true, "a log10 contrast")?;
        check("t_guess_sd", self.t_guess_sd, self.t_guess_sd > 0.0, "> 0")?;
        check(
            "beta",
            self.beta,
            self.beta > 0.0 && self.beta <= 100.0,
            "in (0, 100]",
        )?;
        check(
            "delta",
            self.delta,
            (0.0..0.5).contains(&self.delta),
            "in [0, 0.5)",
        )?;
        check(
            "gamma",
            self.gamma,
            (0.0..1.0).contains(&self.gamma),
            "in [0, 1)",
        )?;
        let top = self.delta * self.gamma + (1.0 - self.delta);
        check(
            "p_threshold",
            self.p_threshold,
            self.p_threshold > self.gamma && self.p_threshold < top,
            &format!("between γ = {} and 1 − δ(1 − γ) = {top}", self.gamma),
        )?;
        check("grain", self.grain, self.grain > 0.0, "> 0")?;
        check(
            "range",
            self.range,
            self.range > self.grain && self.range / self.grain <= 100_000.0,
            "above grain and at most 100000 grains",
        )?;
        check(
            "min_intensity",
            self.min_intensity,
            true,
            "a log10 contrast",
        )?;
        check(
            "max_intensity",
            self.max_intensity,
            self.max_intensity > self.min_intensity,
            "above min_intensity",
        )?;
        Ok(())
    }

    /// `x_T`: the offset that puts `p_threshold` at the threshold,
    /// `log10(−ln((1 − δ + δγ − p) / ((1 − δ)(1 − γ)))) / β` (closed form of
    /// the toolbox's interpolation).
    pub fn x_threshold(&self) -> f64 {
        let (d, g, p) = (self.delta, self.gamma, self.p_threshold);
        (-((1.0 - d + d * g - p) / ((1.0 - d) * (1.0 - g))).ln()).log10() / self.beta
    }

    /// Probability of a correct answer at intensity `x` when the threshold
    /// is `t` (both log10 contrast).
    pub fn p_correct(&self, x: f64, t: f64) -> f64 {
        weibull(
            x - t + self.x_threshold(),
            self.beta,
            self.delta,
            self.gamma,
        )
    }
}

/// The toolbox's Weibull at offset `x2` (log10 units from the function's
/// own scale point).
pub fn weibull(x2: f64, beta: f64, delta: f64, gamma: f64) -> f64 {
    delta * gamma + (1.0 - delta) * (1.0 - (1.0 - gamma) * (-(10f64.powf(beta * x2))).exp())
}

/// One QUEST staircase: the posterior over the threshold and its trials.
#[derive(Debug, Clone, PartialEq)]
pub struct Quest {
    params: QuestParams,
    x_threshold: f64,
    /// Grid of thresholds, log10 contrast.
    grid: Vec<f64>,
    /// Log posterior (unnormalised) at each grid point.
    log_pdf: Vec<f64>,
    trials: Vec<(f64, bool)>,
}

impl Quest {
    /// A fresh staircase with the Gaussian prior.
    pub fn new(params: QuestParams) -> Result<Self, ParamError> {
        params.validate()?;
        let half = (params.range / 2.0 / params.grain).round() as i64;
        let grid: Vec<f64> = (-half..=half)
            .map(|i| params.t_guess + i as f64 * params.grain)
            .collect();
        let log_pdf = grid
            .iter()
            .map(|t| -0.5 * ((t - params.t_guess) / params.t_guess_sd).powi(2))
            .collect();
        Ok(Self {
            x_threshold: params.x_threshold(),
            params,
            grid,
            log_pdf,
            trials: Vec::new(),
        })
    }

    /// The parameters it was made with.
    pub fn params(&self) -> &QuestParams {
        &self.params
    }

    /// Trials so far: (intensity, correct).
    pub fn trials(&self) -> &[(f64, bool)] {
        &self.trials
    }

    /// The grid of thresholds (log10 contrast).
    pub fn grid(&self) -> &[f64] {
        &self.grid
    }

    /// Log-likelihood of one response at every grid point.
    pub fn log_likelihood(&self, intensity: f64, correct: bool) -> Vec<f64> {
        self.grid
            .iter()
            .map(|t| self.log_likelihood_at(intensity, correct, *t))
            .collect()
    }

    fn log_likelihood_at(&self, intensity: f64, correct: bool, t: f64) -> f64 {
        let p = weibull(
            intensity - t + self.x_threshold,
            self.params.beta,
            self.params.delta,
            self.params.gamma,
        );
        let q = if correct { p } else { 1.0 - p };
        // δ = 0 can give q = 0; keep the log finite so one lapse cannot
        // zero the posterior everywhere.
        q.max(1e-300).ln()
    }

    /// Records a response at `intensity` (log10 contrast, finite).
    pub fn update(&mut self, intensity: f64, correct: bool) -> Result<(), ParamError> {
        if !intensity.is_finite() {
            return Err(ParamError::new(
                "intensity",
                intensity,
                "must be a finite log10 contrast",
            ));
        }
        let ll = self.log_likelihood(intensity, correct);
        for (lp, l) in self.log_pdf.iter_mut().zip(ll) {
            *lp += l;
        }
        self.trials.push((intensity, correct));
        Ok(())
    }

    /// The normalised posterior over the grid.
    pub fn pdf(&self) -> Vec<f64> {
        normalise(&self.log_pdf)
    }

    /// Posterior mean (log10 contrast).
    pub fn mean(&self) -> f64 {
        let pdf = self.pdf();
        pdf.iter().zip(&self.grid).map(|(p, t)| p * t).sum()
    }

    /// Posterior standard deviation (log10 units).
    pub fn sd(&self) -> f64 {
        posterior_sd(&self.pdf(), &self.grid)
    }

    /// Posterior mode (the first maximum).
    pub fn mode(&self) -> f64 {
        let mut best = 0;
        for (i, lp) in self.log_pdf.iter().enumerate() {
            if *lp > self.log_pdf[best] {
                best = i;
            }
        }
        self.grid[best]
    }

    /// Posterior quantile `q` in [0, 1], interpolated linearly in the
    /// cumulative distribution as the toolbox does.
    pub fn quantile(&self, q: f64) -> f64 {
        quantile(&self.pdf(), &self.grid, q)
    }

    /// The estimate [`QuestParams::method`] chooses.
    pub fn estimate(&self) -> f64 {
        match self.params.method {
            QuestMethod::Quantile => self.quantile(0.5),
            QuestMethod::Mean => self.mean(),
            QuestMethod::Mode => self.mode(),
        }
    }

    /// The next intensity to test: the estimate, clamped to what the
    /// display can show.
    pub fn next_intensity(&self) -> f64 {
        self.estimate()
            .clamp(self.params.min_intensity, self.params.max_intensity)
    }
}

/// exp of log values, scaled to sum to 1.
pub(crate) fn normalise(log_pdf: &[f64]) -> Vec<f64> {
    let max = log_pdf.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut pdf: Vec<f64> = log_pdf.iter().map(|l| (l - max).exp()).collect();
    let sum: f64 = pdf.iter().sum();
    for p in &mut pdf {
        *p /= sum;
    }
    pdf
}

pub(crate) fn posterior_sd(pdf: &[f64], grid: &[f64]) -> f64 {
    let m: f64 = pdf.iter().zip(grid).map(|(p, t)| p * t).sum();
    let v: f64 = pdf
        .iter()
        .zip(grid)
        .map(|(p, t)| p * (t - m) * (t - m))
        .sum();
    v.max(0.0).sqrt()
}

fn quantile(pdf: &[f64], grid: &[f64], q: f64) -> f64 {
    let q = if q.is_nan() { 0.5 } else { q.clamp(0.0, 1.0) };
    let mut cum = 0.0;
    for (i, p) in pdf.iter().enumerate() {
        let next = cum + p;
        if next >= q && *p > 0.0 {
            if i == 0 {
                return grid[0];
            }
            let frac = (q - cum) / p;
            return grid[i - 1] + (grid[i] - grid[i - 1]) * frac;
        }
        cum = next;
    }
    grid[grid.len() - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn x_threshold_puts_p_threshold_at_the_threshold() {
        let p = QuestParams::default();
        // Toolbox defaults: (1 − .01 + .005 − .82)/(.99 · .5) = 0.353535…
        let expected = (-(0.175f64 / 0.495).ln()).log10() / 3.5;
        assert!((p.x_threshold() - expected).abs() < 1e-15);
        assert!(
            (p.x_threshold() - 0.004843).abs() < 1e-5,
            "{}",
            p.x_threshold()
        );
        for t in [-2.0, -1.0, 0.3] {
            assert!((p.p_correct(t, t) - 0.82).abs() < 1e-12);
        }
        // Far below threshold: the guess rate with lapses; far above: 1 − δ(1 − γ).
        assert!((p.p_correct(-9.0, 0.0) - 0.5).abs() < 1e-12);
        assert!((p.p_correct(9.0, 0.0) - 0.995).abs() < 1e-12);
    }

    /// Figures from an independent re-typing of the toolbox's
    /// `QuestCreate`/`QuestRecompute`/`QuestUpdate`/`QuestMean`/`QuestSd`/
    /// `QuestMode` in plain Python (tGuess −1, tGuessSd 0.5, defaults
    /// otherwise; responses at grid intensities so the table lookup is
    /// exact). The re-typing follows the toolbox code as its ports show it:
    /// `p2` evaluated at `x2 + xThreshold`, `xThreshold` by `interp1` over
    /// the strictly monotonic part of `p2`, the likelihood row read at
    /// `len(pdf) + i − round((intensity − tGuess)/grain)` of the flipped
    /// table. (The toolbox's help text writes `x − xThreshold`; its code
    /// adds.)
    #[test]
    fn posterior_matches_the_toolbox_formulas() {
        let params = QuestParams {
            t_guess: -1.0,
            t_guess_sd: 0.5,
            ..QuestParams::default()
        };
        let mut q = Quest::new(params).unwrap();
        assert_eq!(q.grid().len(), 501);
        assert!((q.mean() - -1.0).abs() < 1e-12);
        assert!((q.sd() - 0.5).abs() < 1e-4, "{}", q.sd());
        for (x, r) in [(-1.0, true), (-1.2, false), (-1.1, true), (-1.5, false)] {
            q.update(x, r).unwrap();
        }
        let (m, sd, mode) = (q.mean(), q.sd(), q.mode());
        let (pm, psd, pmode) = (PY_MEAN, PY_SD, PY_MODE);
        assert!((m - pm).abs() < 1e-9, "mean {m} vs {pm}");
        assert!((sd - psd).abs() < 1e-9, "sd {sd} vs {psd}");
        assert!((mode - pmode).abs() < 1e-9, "mode {mode} vs {pmode}");
        assert!((m - PY_MEAN_INTERP).abs() < 1e-5);
    }

    // From the Python re-typing with `x_T` in closed form.
    const PY_MEAN: f64 = -0.818_869_698_253_316_3;
    const PY_SD: f64 = 0.335_250_626_723_420_5;
    const PY_MODE: f64 = -1.06;
    // The same with the toolbox's `interp1` for `x_T` (0.0048435 instead of
    // 0.0048394): the mean moves by 2.3e-6.
    const PY_MEAN_INTERP: f64 = -0.818_867_438_016_418;

    #[test]
    fn converges_on_a_simulated_weibull_observer() {
        for (seed, truth) in [(1u64, -1.7), (2, -1.2), (3, -2.3), (4, -0.8)] {
            let params = QuestParams::default();
            let mut q = Quest::new(params).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for _ in 0..80 {
                let x = q.next_intensity();
                let correct = rng.random::<f64>() < params.p_correct(x, truth);
                q.update(x, correct).unwrap();
            }
            let est = q.mean();
            assert!((est - truth).abs() < 0.15, "seed {seed}: {est} vs {truth}");
            assert!(q.sd() < 0.15, "sd {}", q.sd());
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = |p: QuestParams| Quest::new(p).unwrap_err().field;
        let d = QuestParams::default();
        assert_eq!(
            bad(QuestParams {
                beta: f64::NAN,
                ..d
            }),
            "beta"
        );
        assert_eq!(
            bad(QuestParams {
                p_threshold: 0.4,
                ..d
            }),
            "p_threshold"
        );
        assert_eq!(
            bad(QuestParams {
                p_threshold: 0.999,
                ..d
            }),
            "p_threshold"
        );
        assert_eq!(bad(QuestParams { grain: 0.0, ..d }), "grain");
        assert_eq!(bad(QuestParams { range: 1e9, ..d }), "range");
        assert_eq!(
            bad(QuestParams {
                max_intensity: -5.0,
                ..d
            }),
            "max_intensity"
        );
        let mut q = Quest::new(d).unwrap();
        assert_eq!(q.update(f64::NAN, true).unwrap_err().field, "intensity");
    }
}
