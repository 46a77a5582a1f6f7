//! Analysis statistics for the search-time data: means ± SE, one-way
//! ANOVA, repeated-measures one-way ANOVA with the Greenhouse–Geisser
//! correction, and pairwise t-tests with a pooled SD and Holm-adjusted
//! p-values (the analyses of Murphy 2007 §7.2, plus the within-subjects
//! analysis its design calls for).
//!
//! The F and t tail probabilities are regularised incomplete beta
//! functions from `statrs` (its checked form: an argument it cannot take is
//! an error here, never a panic or a NaN). Every input value must be
//! finite: NaN or ±∞ is an error naming the group and position; a sum,
//! mean square or statistic that overflows is [`StatsError::Overflow`].
//!
//! The benchmark and session reports' descriptive figures live in two
//! submodules: [`nearest_rank`] (median and percentiles of timings) and
//! [`tradeoff`] (the Pareto front, a power law's exponent).

pub mod nearest_rank;
pub mod tradeoff;

use statrs::function::beta::checked_beta_reg;

/// Why a statistic could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatsError {
    /// A value is NaN or infinite.
    #[error("group {group}, value {index} is not finite ({value})")]
    NotFinite {
        /// Group (or subject row) index.
        group: usize,
        /// Position within the group.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A group has no values.
    #[error("group {0} is empty")]
    EmptyGroup(usize),
    /// The test needs more groups (conditions).
    #[error("need at least {needed} groups, got {got}")]
    TooFewGroups {
        /// Minimum.
        needed: usize,
        /// Supplied.
        got: usize,
    },
    /// No degrees of freedom left for the error term.
    #[error("no error degrees of freedom (every group has a single value, or a single subject)")]
    NoErrorDf,
    /// Every value within every group (or every residual) is identical and
    /// so are the group means: the ratio is 0/0.
    #[error("zero variance: the statistic is 0/0")]
    ZeroVariance,
    /// An intermediate sum or the statistic is not a finite number (the
    /// values are too large to square and add in `f64`).
    #[error("{0} overflows: the values are too large for the arithmetic")]
    Overflow(&'static str),
    /// The tail probability cannot be computed for these arguments.
    #[error("no p-value for {statistic} = {value} on ({df1}, {df2}) degrees of freedom")]
    NoPValue {
        /// `F` or `t`.
        statistic: &'static str,
        /// The statistic.
        value: f64,
        /// First (or only) degrees of freedom.
        df1: f64,
        /// Second degrees of freedom (`t`: the same as `df1`).
        df2: f64,
    },
    /// Repeated-measures rows differ in length.
    #[error("subject {subject} has {got} values, expected {expected}")]
    Ragged {
        /// Row index.
        subject: usize,
        /// Its length.
        got: usize,
        /// Length of row 0.
        expected: usize,
    },
}

fn check_finite(groups: &[&[f64]]) -> Result<(), StatsError> {
    for (g, xs) in groups.iter().enumerate() {
        if let Some((i, &v)) = xs.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(StatsError::NotFinite {
                group: g,
                index: i,
                value: v,
            });
        }
    }
    Ok(())
}

/// Mean, SD and standard error of one sample.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Number of values.
    pub n: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Sample SD, `sqrt(Σ(x − x̄)² / (n − 1))`; 0 when `n = 1`.
    pub sd: f64,
    /// Standard error of the mean, `sd / sqrt(n)`; 0 when `n = 1`.
    pub se: f64,
}

/// Mean ± SE of one sample (the error bars of Murphy 2007, Figs. 7.3–7.4).
/// Formulas: the usual unbiased sample variance and `SE = s/√n`
/// (e.g. Howell, *Statistical Methods for Psychology*, 8th ed., chs. 2 and 7).
pub fn summarize(xs: &[f64]) -> Result<Summary, StatsError> {
    if xs.is_empty() {
        return Err(StatsError::EmptyGroup(0));
    }
    check_finite(&[xs])?;
    let n = xs.len();
    let mean = xs.iter().sum::<f64>() / n as f64;
    let sd = if n > 1 {
        (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    } else {
        0.0
    };
    if !(mean.is_finite() && sd.is_finite()) {
        return Err(StatsError::Overflow("the mean or the SD"));
    }
    Ok(Summary {
        n,
        mean,
        sd,
        se: sd / (n as f64).sqrt(),
    })
}

/// A one-way (between-groups) ANOVA table.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Anova {
    /// Between-groups sum of squares, `Σ nᵢ (x̄ᵢ − x̄)²`.
    pub ss_between: f64,
    /// Within-groups sum of squares, `Σᵢ Σⱼ (xᵢⱼ − x̄ᵢ)²`.
    pub ss_within: f64,
    /// `k − 1`.
    pub df_between: f64,
    /// `N − k`.
    pub df_within: f64,
    /// `ss_between / df_between`.
    pub ms_between: f64,
    /// `ss_within / df_within`: the pooled variance.
    pub ms_within: f64,
    /// `ms_between / ms_within` (`+∞` when only the means differ).
    pub f: f64,
    /// `P(F(df_between, df_within) ≥ f)`.
    pub p: f64,
}

/// One-way ANOVA over `k ≥ 2` groups of any sizes (≥ 1 each, `N > k`).
///
/// Formulas: the partition `SS_total = SS_between + SS_within` with
/// `F = (SS_between/(k−1)) / (SS_within/(N−k))` on `(k−1, N−k)` degrees of
/// freedom (Fisher 1925; e.g. Howell, *Statistical Methods for Psychology*,
/// 8th ed., ch. 11). Murphy (2007) §7.2 reports it as `F(10,473)`.
///
/// Zero within-group variance with different means gives `F = +∞`, `p = 0`;
/// with equal means too it is [`StatsError::ZeroVariance`].
pub fn one_way_anova(groups: &[&[f64]]) -> Result<Anova, StatsError> {
    let k = groups.len();
    if k < 2 {
        return Err(StatsError::TooFewGroups { needed: 2, got: k });
    }
    if let Some(g) = groups.iter().position(|g| g.is_empty()) {
        return Err(StatsError::EmptyGroup(g));
    }
    check_finite(groups)?;
    let n_total: usize = groups.iter().map(|g| g.len()).sum();
    if n_total <= k {
        return Err(StatsError::NoErrorDf);
    }
    let grand = groups.iter().flat_map(|g| g.iter()).sum::<f64>() / n_total as f64;
    let mut ss_between = 0.0;
    let mut ss_within = 0.0;
    for g in groups {
        let m = g.iter().sum::<f64>() / g.len() as f64;
        ss_between += g.len() as f64 * (m - grand).powi(2);
        ss_within += g.iter().map(|x| (x - m).powi(2)).sum::<f64>();
    }
    let df_between = (k - 1) as f64;
    let df_within = (n_total - k) as f64;
    let ms_between = ss_between / df_between;
    let ms_within = ss_within / df_within;
    let (f, p) = f_test(ms_between, ms_within, df_between, df_within)?;
    Ok(Anova {
        ss_between,
        ss_within,
        df_between,
        df_within,
        ms_between,
        ms_within,
        f,
        p,
    })
}

/// `F = num / den` and its upper-tail p on `(d1, d2)` df.
fn f_test(num: f64, den: f64, d1: f64, d2: f64) -> Result<(f64, f64), StatsError> {
    if !num.is_finite() {
        return Err(StatsError::Overflow("the between-groups mean square"));
    }
    if !den.is_finite() {
        return Err(StatsError::Overflow("the error mean square"));
    }
    // Relative tolerance: residual sums of squares that are zero in exact
    // arithmetic come out as rounding noise.
    if den <= 0.0 || den <= num.abs() * 1e-14 {
        if num > 0.0 {
            return Ok((f64::INFINITY, 0.0));
        }
        return Err(StatsError::ZeroVariance);
    }
    let f = num / den;
    if !f.is_finite() {
        return Err(StatsError::Overflow("F"));
    }
    Ok((f, f_sf(f, d1, d2)?))
}

/// Upper tail of the F distribution, `P(F(d1, d2) ≥ f) = I_x(d2/2, d1/2)`
/// with `x = d2 / (d2 + d1·f)` (Abramowitz & Stegun 26.6.2), written so
/// that a huge `f` gives `x → 0` rather than ∞/∞.
pub fn f_sf(f: f64, d1: f64, d2: f64) -> Result<f64, StatsError> {
    let none = || StatsError::NoPValue {
        statistic: "F",
        value: f,
        df1: d1,
        df2: d2,
    };
    if !(d1 > 0.0 && d2 > 0.0 && d1.is_finite() && d2.is_finite()) || f.is_nan() {
        return Err(none());
    }
    if f <= 0.0 {
        return Ok(1.0);
    }
    if f.is_infinite() {
        return Ok(0.0);
    }
    let x = d2 / (d2 + d1 * f);
    checked_beta_reg(d2 / 2.0, d1 / 2.0, x.clamp(0.0, 1.0)).map_err(|_| none())
}

/// Two-sided p of Student's t on `df` degrees of freedom,
/// `P(|T| ≥ |t|) = I_x(df/2, 1/2)` with `x = df / (df + t²)` (Abramowitz &
/// Stegun 26.7.1), written so that a huge `t` gives `x → 0`.
pub fn t_two_sided_p(t: f64, df: f64) -> Result<f64, StatsError> {
    let none = || StatsError::NoPValue {
        statistic: "t",
        value: t,
        df1: df,
        df2: df,
    };
    if !(df > 0.0 && df.is_finite()) || t.is_nan() {
        return Err(none());
    }
    if t.is_infinite() {
        return Ok(0.0);
    }
    let x = df / (df + t * t);
    checked_beta_reg(df / 2.0, 0.5, x.clamp(0.0, 1.0))
        .map(|p| p.min(1.0))
        .map_err(|_| none())
}

/// A repeated-measures (within-subjects) one-way ANOVA table.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RmAnova {
    /// Number of subjects `n`.
    pub subjects: usize,
    /// Number of conditions `k`.
    pub conditions: usize,
    /// `n Σⱼ (x̄.ⱼ − x̄)²`.
    pub ss_conditions: f64,
    /// `k Σᵢ (x̄ᵢ. − x̄)²`.
    pub ss_subjects: f64,
    /// `Σᵢⱼ (xᵢⱼ − x̄ᵢ. − x̄.ⱼ + x̄)²`: the subject × condition interaction.
    pub ss_error: f64,
    /// `k − 1`.
    pub df_conditions: f64,
    /// `(n − 1)(k − 1)`.
    pub df_error: f64,
    /// `(ss_conditions/df_conditions) / (ss_error/df_error)`.
    pub f: f64,
    /// Uncorrected p on `(df_conditions, df_error)`.
    pub p: f64,
    /// Greenhouse–Geisser ε̂, in `[1/(k−1), 1]`.
    pub gg_epsilon: f64,
    /// p on `(ε̂·df_conditions, ε̂·df_error)`.
    pub p_gg: f64,
}

/// Repeated-measures one-way ANOVA: `data[i][j]` is subject `i`'s score in
/// condition `j` (e.g. the subject's mean search time per scene type).
///
/// Sums of squares: `SS_total = SS_subjects + SS_conditions + SS_error`,
/// `F = MS_conditions / MS_error` on `(k−1, (n−1)(k−1))` df (Howell,
/// *Statistical Methods for Psychology*, 8th ed., ch. 14; Maxwell, Delaney
/// & Kelley, *Designing Experiments and Analyzing Data*, 3rd ed., ch. 11).
///
/// Sphericity correction: Greenhouse & Geisser (1959, *Psychometrika* 24,
/// 95–112), after Box (1954): with `S` the `k×k` sample covariance matrix
/// of the conditions and `S*` its double-centred form
/// `s*ᵢⱼ = sᵢⱼ − s̄ᵢ. − s̄.ⱼ + s̄..`,
/// `ε̂ = (Σᵢ s*ᵢᵢ)² / ((k − 1) Σᵢⱼ s*ᵢⱼ²)`
/// (Maxwell, Delaney & Kelley, ch. 11), and both df are
/// multiplied by `ε̂`.
pub fn rm_anova(data: &[&[f64]]) -> Result<RmAnova, StatsError> {
    let n = data.len();
    if n < 2 {
        return Err(StatsError::NoErrorDf);
    }
    let k = data[0].len();
    if let Some((i, row)) = data.iter().enumerate().find(|(_, r)| r.len() != k) {
        return Err(StatsError::Ragged {
            subject: i,
            got: row.len(),
            expected: k,
        });
    }
    if k < 2 {
        return Err(StatsError::TooFewGroups { needed: 2, got: k });
    }
    check_finite(data)?;
    let (nf, kf) = (n as f64, k as f64);
    let row_mean: Vec<f64> = data.iter().map(|r| r.iter().sum::<f64>() / kf).collect();
    let col_mean: Vec<f64> = (0..k)
        .map(|j| data.iter().map(|r| r[j]).sum::<f64>() / nf)
        .collect();
    let grand = row_mean.iter().sum::<f64>() / nf;
    let ss_conditions = nf * col_mean.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_subjects = kf * row_mean.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let mut ss_error = 0.0;
    for (i, r) in data.iter().enumerate() {
        for (j, x) in r.iter().enumerate() {
            ss_error += (x - row_mean[i] - col_mean[j] + grand).powi(2);
        }
    }
    let df_conditions = kf - 1.0;
    let df_error = (nf - 1.0) * (kf - 1.0);
    let (f, p) = f_test(
        ss_conditions / df_conditions,
        ss_error / df_error,
        df_conditions,
        df_error,
    )?;

    // Greenhouse-Geisser epsilon from the double-centred covariance matrix.
    let mut cov = vec![vec![0.0; k]; k];
    for (a, row) in cov.iter_mut().enumerate() {
        for (b, c) in row.iter_mut().enumerate() {
            *c = data
                .iter()
                .map(|r| (r[a] - col_mean[a]) * (r[b] - col_mean[b]))
                .sum::<f64>()
                / (nf - 1.0);
        }
    }
    let cov_row: Vec<f64> = cov.iter().map(|r| r.iter().sum::<f64>() / kf).collect();
    let cov_grand = cov_row.iter().sum::<f64>() / kf;
    let mut trace = 0.0;
    let mut sum_sq = 0.0;
    for a in 0..k {
        for b in 0..k {
            // The covariance matrix is symmetric: column means = row means.
            let d = cov[a][b] - cov_row[a] - cov_row[b] + cov_grand;
            if a == b {
                trace += d;
            }
            sum_sq += d * d;
        }
    }
    let lower = 1.0 / df_conditions;
    let gg_epsilon = if sum_sq > 0.0 {
        (trace * trace / (df_conditions * sum_sq)).clamp(lower, 1.0)
    } else {
        1.0
    };
    if !(trace.is_finite() && sum_sq.is_finite()) {
        return Err(StatsError::Overflow("the covariance of the conditions"));
    }
    let p_gg = if f.is_infinite() {
        0.0
    } else {
        f_sf(f, gg_epsilon * df_conditions, gg_epsilon * df_error)?
    };
    Ok(RmAnova {
        subjects: n,
        conditions: k,
        ss_conditions,
        ss_subjects,
        ss_error,
        df_conditions,
        df_error,
        f,
        p,
        gg_epsilon,
        p_gg,
    })
}

/// One pairwise comparison.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Pair {
    /// First group index.
    pub a: usize,
    /// Second group index (`a < b`).
    pub b: usize,
    /// `mean(a) − mean(b)`.
    pub diff: f64,
    /// `diff / sqrt(MS_within (1/nₐ + 1/n_b))`.
    pub t: f64,
    /// `N − k`, the pooled variance's df.
    pub df: f64,
    /// Unadjusted two-sided p.
    pub p: f64,
    /// Holm-adjusted p over all `k(k−1)/2` pairs.
    pub p_holm: f64,
}

/// Pairwise t-tests between all groups with the SD pooled over all groups
/// (Fisher's LSD form: `t = (x̄ₐ − x̄_b) / sqrt(MS_within (1/nₐ + 1/n_b))`
/// on `N − k` df; Fisher 1935, *The Design of Experiments*; Howell 8th ed.
/// ch. 12), as Murphy (2007) §7.2 ("t-tests with pooled SD"), with
/// Holm-adjusted p-values ([`holm`]). Matches R's
/// `pairwise.t.test(x, g, pool.sd = TRUE, p.adjust.method = "holm")`.
/// Pairs are listed `(0,1), (0,2), …, (1,2), …`.
pub fn pairwise_t_pooled(groups: &[&[f64]]) -> Result<Vec<Pair>, StatsError> {
    let anova = one_way_anova(groups)?;
    if anova.ms_within <= 0.0 {
        return Err(StatsError::ZeroVariance);
    }
    let df = anova.df_within;
    let means: Vec<f64> = groups
        .iter()
        .map(|g| g.iter().sum::<f64>() / g.len() as f64)
        .collect();
    let mut pairs = Vec::new();
    for a in 0..groups.len() {
        for b in a + 1..groups.len() {
            let diff = means[a] - means[b];
            let se = (anova.ms_within
                * (1.0 / groups[a].len() as f64 + 1.0 / groups[b].len() as f64))
                .sqrt();
            let t = diff / se;
            if !t.is_finite() {
                return Err(StatsError::Overflow("t"));
            }
            let p = t_two_sided_p(t, df)?;
            pairs.push(Pair {
                a,
                b,
                diff,
                t,
                df,
                p,
                p_holm: p,
            });
        }
    }
    let adjusted = holm(&pairs.iter().map(|p| p.p).collect::<Vec<_>>());
    for (pair, h) in pairs.iter_mut().zip(adjusted) {
        pair.p_holm = h;
    }
    Ok(pairs)
}

/// Holm's step-down adjustment: with the `m` p-values sorted ascending,
/// `p̃₍ᵢ₎ = max_{j ≤ i} min(1, (m − j + 1) p₍ⱼ₎)` (1-based ranks), returned
/// in the input order. Holm (1979), "A simple sequentially rejective
/// multiple test procedure", *Scand. J. Statist.* 6, 65–70; the
/// adjusted-p form as in R's `p.adjust(method = "holm")`.
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut out = vec![0.0; m];
    let mut running: f64 = 0.0;
    for (rank, &i) in order.iter().enumerate() {
        running = running.max(((m - rank) as f64 * p[i]).min(1.0));
        out[i] = running;
    }
    out
}
