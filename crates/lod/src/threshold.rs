//! The monotone envelope of a threshold table, which makes the fold test
//! monotone down the tree whatever the calibration (Luebke & Hallen 2001
//! §5.3 footnote 2: "folding a node should not induce more error than
//! folding its parent").
//!
//! `T*(f, e) = min over f' ≥ f, e' ≥ e of T(f', e')` on the table's grid,
//! interpolated exactly as [`ThresholdTable::threshold`] does (bilinear in
//! ln T, clamped at the edges). T* ≤ T everywhere (never less conservative)
//! and is non-decreasing in frequency and eccentricity. For a table that
//! is already non-decreasing — the Geisler–Perry table of
//! `ThresholdTable::from_model` is — T* = T, so the test is exactly
//! `!table.is_perceptible(..)`.

use foveation::perceptibility::{bracket, ThresholdTable};

#[derive(Debug, Clone)]
pub(crate) struct MonotoneThreshold {
    freqs: Vec<f64>,
    eccs: Vec<f64>,
    log_t: Vec<f64>,
}

impl MonotoneThreshold {
    pub(crate) fn new(table: &ThresholdTable) -> Self {
        let freqs = table.frequencies_cpd().to_vec();
        let eccs = table.eccentricities_deg().to_vec();
        let (nf, ne) = (freqs.len(), eccs.len());
        let mut log_t = vec![0.0; nf * ne];
        for ei in (0..ne).rev() {
            for fi in (0..nf).rev() {
                let mut v = table.threshold(freqs[fi], eccs[ei]).ln();
                if fi + 1 < nf {
                    v = v.min(log_t[ei * nf + fi + 1]);
                }
                if ei + 1 < ne {
                    v = v.min(log_t[(ei + 1) * nf + fi]);
                }
                log_t[ei * nf + fi] = v;
            }
        }
        Self { freqs, eccs, log_t }
    }

    /// ln T*(f, e). NaN in, NaN out.
    pub(crate) fn log_threshold(&self, frequency_cpd: f64, eccentricity_deg: f64) -> f64 {
        if frequency_cpd.is_nan() || eccentricity_deg.is_nan() {
            return f64::NAN;
        }
        let nf = self.freqs.len();
        let (e0, e1, te) = bracket(&self.eccs, eccentricity_deg);
        let (f0, f1, tf) = bracket(&self.freqs, frequency_cpd);
        let at = |e: usize, f: usize| self.log_t[e * nf + f];
        let row = |e| at(e, f0) + (at(e, f1) - at(e, f0)) * tf;
        let lo = row(e0);
        lo + (row(e1) - lo) * te
    }

    /// ln T* at column `fi` of the grid, interpolated in eccentricity.
    fn log_column(&self, fi: usize, e: (usize, usize, f64)) -> f64 {
        let nf = self.freqs.len();
        let (e0, e1, te) = e;
        let lo = self.log_t[e0 * nf + fi];
        lo + (self.log_t[e1 * nf + fi] - lo) * te
    }

    /// `ThresholdTable::imperceptible_distance_mm` (Luebke & Hallen §5.3)
    /// computed on T*: the same inversion (the highest column still
    /// perceptible, linear in threshold to the next one, then
    /// `extent / (2 tan(θ/2))` with θ = 1/(2 f_t)), but T* rows are
    /// non-decreasing, so that column is found by bisection instead of a
    /// scan (a budget frame evaluates thousands of nodes). Equal to the
    /// table's answer for tables that are already monotone.
    pub(crate) fn imperceptible_distance_mm(
        &self,
        contrast: f64,
        extent_mm: f64,
        ecc_deg: f64,
    ) -> f64 {
        if extent_mm.is_nan() || contrast.is_nan() || ecc_deg.is_nan() {
            return f64::INFINITY;
        }
        if extent_mm <= 0.0 {
            return 0.0;
        }
        let e = bracket(&self.eccs, ecc_deg);
        let lc = contrast.ln();
        let last = self.freqs.len() - 1;
        if lc < self.log_column(0, e) {
            return 0.0;
        }
        if lc >= self.log_column(last, e) {
            return f64::INFINITY;
        }
        // Column lo is perceptible, column hi is not; bisect to neighbours.
        let (mut lo, mut hi) = (0, last);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if lc >= self.log_column(mid, e) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let i = lo; // the highest perceptible column
        let (t0, t1) = (self.log_column(i, e).exp(), self.log_column(i + 1, e).exp());
        let frac = if t1 > t0 {
            ((contrast - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let f = self.freqs[i] + (self.freqs[i + 1] - self.freqs[i]) * frac;
        let theta_deg = 0.5 / f;
        extent_mm / (2.0 * (theta_deg.to_radians() / 2.0).tan())
    }

    /// `contrast ≥ T*(f, e)`; NaN answers true (keep the detail).
    #[cfg(test)]
    pub(crate) fn is_perceptible(&self, contrast: f64, frequency_cpd: f64, ecc_deg: f64) -> bool {
        let lt = self.log_threshold(frequency_cpd, ecc_deg);
        contrast.is_nan() || lt.is_nan() || contrast.ln() >= lt
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foveation::GeislerPerry;

    #[test]
    fn the_envelope_of_the_model_table_is_the_table() {
        let table = ThresholdTable::from_model(&GeislerPerry::default());
        let env = MonotoneThreshold::new(&table);
        for &(f, e) in &[
            (0.1, 0.0),
            (3.3, 1.7),
            (20.0, 12.0),
            (64.0, 90.0),
            (200.0, 120.0),
        ] {
            let rel = (env.log_threshold(f, e).exp() / table.threshold(f, e) - 1.0).abs();
            assert!(rel < 1e-12, "{f} {e} {rel}");
        }
    }

    #[test]
    fn the_fast_inverse_matches_the_tables_for_the_model() {
        let table = ThresholdTable::from_model(&GeislerPerry::default());
        let env = MonotoneThreshold::new(&table);
        for &c in &[0.001, 0.016, 0.02, 0.05, 0.1, 0.3, 0.9, 1.0] {
            for &e in &[0.0, 0.5, 3.0, 12.0, 29.0, 75.0, 120.0] {
                for &x in &[0.0, 0.3, 4.0] {
                    let want = table.imperceptible_distance_mm(c, x, e);
                    let got = env.imperceptible_distance_mm(c, x, e);
                    assert!(
                        got == want || ((got - want) / want).abs() < 1e-9,
                        "c {c} e {e} x {x}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_dip_at_high_eccentricity_lowers_the_threshold_nearer_the_fovea() {
        // Row 10° is less sensitive than row 20° at 8 cpd: the envelope must
        // take the 20° value at 10°.
        let table = ThresholdTable::new(
            vec![1.0, 8.0],
            vec![0.0, 10.0, 20.0],
            vec![vec![0.01, 0.02], vec![0.02, 0.5], vec![0.03, 0.1]],
        )
        .unwrap();
        let env = MonotoneThreshold::new(&table);
        assert!((env.log_threshold(8.0, 10.0).exp() - 0.1).abs() < 1e-12);
        assert!(env.is_perceptible(0.2, 8.0, 10.0));
        assert!(!table.is_perceptible(0.2, 8.0, 10.0));
    }
}
