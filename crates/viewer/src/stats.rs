//! The few statistics the reports use: the median and nearest-rank
//! percentiles of timings, the Pareto front of a cost/benefit trade-off and
//! the exponent of a power law (least squares on the logs).
//!
//! NaN carries no measurement: the order statistics leave NaN values out
//! (NaN only when nothing else is left), and a point with a NaN coordinate
//! is never on the Pareto front and dominates nothing.

/// The values that are not NaN, sorted ascending.
fn sorted(values: &[f64]) -> Vec<f64> {
    let mut s: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
    s.sort_by(f64::total_cmp);
    s
}

/// The nearest-rank percentile of sorted values: the value at rank
/// `round(p/100 · (n − 1))`, always one of the values.
fn rank(sorted: &[f64], p: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else {
        return f64::NAN;
    };
    let k = ((p.clamp(0.0, 100.0) / 100.0) * last as f64).round() as usize;
    sorted[k.min(last)]
}

/// The `p`-th percentile (0–100, nearest rank; see the module notes on
/// NaN). NaN when there are no values.
pub fn percentile(values: &[f64], p: f64) -> f64 {
    rank(&sorted(values), p)
}

/// The median as a nearest rank: the middle value, the upper of the two
/// middle ones for an even count (always a measured value). NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    percentile(values, 50.0)
}

/// The 50th, 95th and 99th percentiles (one sort). NaN when empty.
pub fn p50_95_99(values: &[f64]) -> [f64; 3] {
    let s = sorted(values);
    [50.0, 95.0, 99.0].map(|p| rank(&s, p))
}

/// Which `(cost, benefit)` points are on the Pareto front: no other point
/// has at most the cost and at least the benefit and is strictly better in
/// one. Equal points do not dominate each other.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let valid = |p: &(f64, f64)| !p.0.is_nan() && !p.1.is_nan();
    let dominates =
        |o: &(f64, f64), p: &(f64, f64)| o.0 <= p.0 && o.1 >= p.1 && (o.0 < p.0 || o.1 > p.1);
    points
        .iter()
        .map(|p| valid(p) && !points.iter().filter(|o| valid(o)).any(|o| dominates(o, p)))
        .collect()
}

/// Least-squares slope of ln y against ln x: the exponent `k` of
/// `y ∝ x^k`. Points with x or y not positive (or NaN) are left out; `None`
/// with fewer than two distinct x left.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (logs.len() >= 2 && sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_ranks() {
        let v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        assert_eq!(p50_95_99(&v), [51.0, 95.0, 99.0]);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&v, 100.0), 100.0);
        assert_eq!(percentile(&v, 150.0), 100.0, "p is clamped to 0–100");
    }

    #[test]
    fn the_median_is_a_measured_value() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        // Even count: the upper middle value, as `sorted[n / 2]`.
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        assert_eq!(median(&[2.0, 1.0]), 2.0);
    }

    #[test]
    fn empty_and_single_inputs() {
        assert!(median(&[]).is_nan());
        assert!(percentile(&[], 95.0).is_nan());
        assert!(p50_95_99(&[]).iter().all(|v| v.is_nan()));
        assert_eq!(median(&[7.5]), 7.5);
        assert_eq!(p50_95_99(&[7.5]), [7.5; 3]);
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), [true]);
    }

    #[test]
    fn nan_is_left_out_whatever_its_position() {
        for v in [
            vec![f64::NAN, 3.0, 1.0, 2.0],
            vec![3.0, 1.0, 2.0, f64::NAN],
            vec![3.0, -f64::NAN, 1.0, 2.0],
        ] {
            assert_eq!(median(&v), 2.0, "{v:?}");
            assert_eq!(p50_95_99(&v), [2.0, 3.0, 3.0], "{v:?}");
        }
        assert!(median(&[f64::NAN, f64::NAN]).is_nan());
        // Infinities are values: they sort to the ends.
        assert_eq!(median(&[f64::INFINITY, 1.0, f64::NEG_INFINITY]), 1.0);
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_points() {
        // (cost, benefit): fast and poor, slow and good, dominated by the
        // second, equal to the first (neither dominates the other).
        let front = pareto_front(&[(10.0, 1.0), (20.0, 3.0), (25.0, 2.0), (10.0, 1.0)]);
        assert_eq!(front, [true, true, false, true]);
        // −∞ benefit (no figure) is dominated by any point as fast.
        assert_eq!(
            pareto_front(&[(1.0, f64::NEG_INFINITY), (1.0, 0.0)]),
            [false, true]
        );
    }

    #[test]
    fn nan_points_are_off_the_front_and_dominate_nothing() {
        let front = pareto_front(&[(f64::NAN, 9.0), (5.0, 1.0), (1.0, f64::NAN)]);
        assert_eq!(front, [false, true, false]);
    }

    #[test]
    fn log_log_slope_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 1e5, 1e6]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(0.5)))
            .collect();
        let k = log_log_slope(&pts).expect("three points");
        assert!((k - 0.5).abs() < 1e-12, "{k}");
        assert_eq!(log_log_slope(&[(1.0, 2.0)]), None);
        assert_eq!(log_log_slope(&[(1.0, 2.0), (1.0, 3.0)]), None);
        assert_eq!(log_log_slope(&[]), None);
        // Non-positive and NaN points are left out.
        let mut noisy = pts.clone();
        noisy.extend([(0.0, 1.0), (f64::NAN, 2.0), (1e7, -1.0)]);
        assert_eq!(log_log_slope(&noisy), log_log_slope(&pts));
    }
}
