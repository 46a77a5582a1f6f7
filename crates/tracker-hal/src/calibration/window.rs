//! The stable fixation on one target: the window of lowest dispersion,
//! outliers rejected, averaged.

/// One raw sample taken while a target was shown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPoint {
    /// The sample's time, µs (the samples' own clock: mapped device time).
    pub t_us: u64,
    /// `None`: invalid (blink, lost eye).
    pub raw: Option<[f64; 2]>,
}

/// The stable fixation on one target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableWindow {
    /// Mean of the window's samples after outlier rejection.
    pub raw: [f64; 2],
    /// Time of the window's first sample, µs.
    pub start_us: u64,
    /// Time of the window's last sample, µs.
    pub end_us: u64,
    /// Samples kept / in the window.
    pub kept: usize,
    /// Samples in the window before outlier rejection.
    pub in_window: usize,
    /// Dispersion of the window: (max−min) in x plus (max−min) in y.
    pub dispersion: f64,
}

/// Finds the `window_us` span of valid samples with the lowest dispersion
/// (among windows holding at least `min_samples`), rejects samples farther
/// than 3 × 1.4826 × MAD from the median in either axis, and averages the
/// rest.
///
/// Dispersion is I-DT's: (max − min) in x plus (max − min) in y (Salvucci &
/// Goldberg 2000, "Identifying fixations and saccades in eye-tracking
/// protocols", ETRA). The outlier rule is the median ± 3 scaled MAD of
/// Leys et al. 2013 ("Detecting outliers: do not use standard deviation
/// around the mean, use absolute deviation around the median", J. Exp.
/// Soc. Psychol. 49(4)): 1.4826 × MAD estimates the standard deviation of
/// normal data, so the cut is about 3 σ. A MAD of 0 (more than half the
/// samples identical) rejects nothing. "Median" here is the middle sample
/// after sorting, the upper of the two middle ones for an even count.
pub fn stable_window(
    samples: &[TimedPoint],
    window_us: u64,
    min_samples: usize,
) -> Result<StableWindow, String> {
    let valid: Vec<(u64, [f64; 2])> = samples
        .iter()
        .filter_map(|s| {
            s.raw
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .map(|p| (s.t_us, p))
        })
        .collect();
    if valid.is_empty() {
        return Err("no valid samples (the tracker lost the eyes for the whole target)".into());
    }
    let min_samples = min_samples.max(1);
    let mut best: Option<(f64, usize, usize)> = None;
    let mut end = 0;
    for start in 0..valid.len() {
        end = end.max(start);
        while end + 1 < valid.len() && valid[end + 1].0 - valid[start].0 <= window_us {
            end += 1;
        }
        if end + 1 - start < min_samples {
            continue;
        }
        let w = &valid[start..=end];
        let span = |k: usize| {
            let (lo, hi) = w
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.1[k]), hi.max(p.1[k]))
                });
            hi - lo
        };
        let d = span(0) + span(1);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, start, end));
        }
    }
    let Some((dispersion, s, e)) = best else {
        return Err(format!(
            "fewer than {min_samples} valid samples within any {} ms",
            window_us / 1000
        ));
    };
    let w = &valid[s..=e];
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut keep = vec![true; w.len()];
    for k in 0..2 {
        let mut xs: Vec<f64> = w.iter().map(|p| p.1[k]).collect();
        let m = median(&mut xs);
        let mut dev: Vec<f64> = w.iter().map(|p| (p.1[k] - m).abs()).collect();
        let mad = median(&mut dev);
        for (i, p) in w.iter().enumerate() {
            if mad > 0.0 && (p.1[k] - m).abs() > 3.0 * 1.4826 * mad {
                keep[i] = false;
            }
        }
    }
    let kept: Vec<[f64; 2]> = w
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(p, _)| p.1)
        .collect();
    let n = kept.len() as f64;
    Ok(StableWindow {
        raw: [
            kept.iter().map(|p| p[0]).sum::<f64>() / n,
            kept.iter().map(|p| p[1]).sum::<f64>() / n,
        ],
        start_us: w[0].0,
        end_us: w[w.len() - 1].0,
        kept: kept.len(),
        in_window: w.len(),
        dispersion,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stable_window_ignores_the_saccade_and_outliers() {
        let mut s: Vec<TimedPoint> = (0..100)
            .map(|i| TimedPoint {
                t_us: i * 4_000,
                // Moving for the first 40 samples, then still at (10, 20).
                raw: Some(if i < 40 {
                    [i as f64, 2.0 * i as f64]
                } else {
                    [10.0 + 0.01 * (i % 3) as f64, 20.0]
                }),
            })
            .collect();
        s[70].raw = Some([500.0, 500.0]); // a spike
        s[71].raw = None; // a dropout
        let w = stable_window(&s, 200_000, 5).expect("window");
        assert!(
            (w.raw[0] - 10.01).abs() < 0.02 && (w.raw[1] - 20.0).abs() < 1e-9,
            "{w:?}"
        );
        assert!(w.start_us >= 40 * 4_000);
    }
}
