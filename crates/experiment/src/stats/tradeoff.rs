//! How a measured cost trades against a benefit: the Pareto front of
//! `(cost, benefit)` points and the exponent of a power law (least squares
//! on the logs), as the benchmark reports use them.
//!
//! NaN carries no measurement: a point with a NaN coordinate is never on
//! the Pareto front and dominates nothing.

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

    #[test]
    fn empty_and_single_inputs() {
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), [true]);
    }

    #[test]
    fn nan_points_are_off_the_front_and_dominate_nothing() {
        let front = pareto_front(&[(f64::NAN, 9.0), (5.0, 1.0), (1.0, f64::NAN)]);
        assert_eq!(front, [false, true, false]);
    }
}
