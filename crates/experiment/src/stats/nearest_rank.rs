//! Nearest-rank order statistics of measured timings: the median and
//! percentiles the benchmark and session reports quote (always one of the
//! measured values, never an interpolation).
//!
//! NaN carries no measurement: it is left out (the result is NaN only when
//! nothing else is left).

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
}
