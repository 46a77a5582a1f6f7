//! Luebke & Hallen's empirical perceptual model: a threshold-contrast table
//! over spatial frequency and eccentricity, looked up with linear
//! interpolation (Luebke & Hallen 2001, §3.2 and §6.1), and its inverse used
//! for best-effort ordering (§5.3).

use serde::{Deserialize, Serialize};

use crate::csf::GeislerPerry;
use crate::error::ParamError;

/// Threshold contrast sampled on a frequency × eccentricity grid.
///
/// Built from the Geisler–Perry model by default, or from a user's
/// calibration (`Deserialize`, e.g. from RON). On construction each
/// eccentricity row is clamped below its peak-sensitivity frequency: every
/// lower frequency gets the peak's (lowest) threshold, so the assumption
/// "lower frequencies are at least as perceptible" holds (§6.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ThresholdTableData", into = "ThresholdTableData")]
pub struct ThresholdTable {
    frequencies_cpd: Vec<f64>,
    eccentricities_deg: Vec<f64>,
    /// Row-major natural logarithms: `log_thresholds[e * frequencies.len() + f]`.
    log_thresholds: Vec<f64>,
}

/// The serialised form of a table (what a calibration file holds).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThresholdTableData {
    /// Strictly increasing, ≥ 0.
    pub frequencies_cpd: Vec<f64>,
    /// Strictly increasing, ≥ 0.
    pub eccentricities_deg: Vec<f64>,
    /// One row per eccentricity, one threshold contrast (0, ∞] per frequency.
    pub thresholds: Vec<Vec<f64>>,
}

impl TryFrom<ThresholdTableData> for ThresholdTable {
    type Error = ParamError;
    fn try_from(d: ThresholdTableData) -> Result<Self, ParamError> {
        ThresholdTable::new(d.frequencies_cpd, d.eccentricities_deg, d.thresholds)
    }
}

impl From<ThresholdTable> for ThresholdTableData {
    fn from(t: ThresholdTable) -> Self {
        let nf = t.frequencies_cpd.len();
        let rows = t
            .log_thresholds
            .chunks(nf)
            .map(|r| r.iter().map(|l| l.exp()).collect())
            .collect();
        Self {
            frequencies_cpd: t.frequencies_cpd,
            eccentricities_deg: t.eccentricities_deg,
            thresholds: rows,
        }
    }
}

fn strictly_increasing(field: &'static str, v: &[f64]) -> Result<(), ParamError> {
    if v.is_empty() {
        return Err(ParamError::new(field, "[]", "needs at least one value"));
    }
    for (i, x) in v.iter().enumerate() {
        if !x.is_finite() || *x < 0.0 {
            return Err(ParamError::new(
                field,
                x,
                format!("entry {i} must be finite and ≥ 0"),
            ));
        }
        if i > 0 && *x <= v[i - 1] {
            return Err(ParamError::new(
                field,
                x,
                format!("entry {i} must be larger than entry {}", i - 1),
            ));
        }
    }
    Ok(())
}

impl ThresholdTable {
    /// A table from measured rows (one per eccentricity). Rejects unsorted
    /// axes, ragged rows and thresholds that are not positive.
    pub fn new(
        frequencies_cpd: Vec<f64>,
        eccentricities_deg: Vec<f64>,
        rows: Vec<Vec<f64>>,
    ) -> Result<Self, ParamError> {
        strictly_increasing("frequencies_cpd", &frequencies_cpd)?;
        strictly_increasing("eccentricities_deg", &eccentricities_deg)?;
        if rows.len() != eccentricities_deg.len() {
            return Err(ParamError::new(
                "thresholds",
                rows.len(),
                format!(
                    "needs one row per eccentricity ({})",
                    eccentricities_deg.len()
                ),
            ));
        }
        let nf = frequencies_cpd.len();
        let mut thresholds = Vec::with_capacity(nf * rows.len());
        for (r, row) in rows.iter().enumerate() {
            if row.len() != nf {
                return Err(ParamError::new(
                    "thresholds",
                    row.len(),
                    format!("row {r} needs one value per frequency ({nf})"),
                ));
            }
            if let Some(bad) = row.iter().find(|t| t.is_nan() || **t <= 0.0) {
                return Err(ParamError::new(
                    "thresholds",
                    bad,
                    format!("row {r}: thresholds must be > 0"),
                ));
            }
            // Clamp below the peak-sensitivity (lowest-threshold) frequency (§6.1).
            let (peak, &lowest) = row
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                .unwrap_or((0, &row[0]));
            thresholds.extend(
                row.iter()
                    .enumerate()
                    .map(|(i, &t)| if i < peak { lowest } else { t }.ln()),
            );
        }
        Ok(Self {
            frequencies_cpd,
            eccentricities_deg,
            log_thresholds: thresholds,
        })
    }

    /// The table the Geisler–Perry model predicts, on a log-spaced frequency
    /// axis (0.5–64 cpd) and eccentricities 0–90°.
    pub fn from_model(model: &GeislerPerry) -> Self {
        let frequencies: Vec<f64> = (0..=28)
            .map(|i| 0.5 * 2f64.powf(f64::from(i) / 4.0))
            .collect();
        let eccentricities: Vec<f64> = [
            0.0, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 90.0,
        ]
        .to_vec();
        let rows = eccentricities
            .iter()
            .map(|&e| {
                frequencies
                    .iter()
                    .map(|&f| model.contrast_threshold(f, e))
                    .collect()
            })
            .collect();
        // The model's thresholds are positive and the axes sorted by construction.
        Self::new(frequencies, eccentricities, rows)
            .unwrap_or_else(|e| unreachable!("model table: {e}"))
    }

    /// This table inside its grid, `model` outside it: a table on the
    /// union of this grid's axes and [`ThresholdTable::from_model`]'s, whose
    /// entries inside this table's frequency and eccentricity ranges are this
    /// table's (interpolated as [`ThresholdTable::threshold`] does) and whose
    /// entries outside are `model`'s predictions.
    ///
    /// A measured table covers a few frequencies and eccentricities (by
    /// default 1–16 cpd × 0–10°); looked up alone it would clamp a 30°
    /// query to its 10° row and call a far-peripheral change as visible as
    /// one at 10°. Extended by the participant's fitted model, the
    /// periphery follows that participant's fitted CSF instead of the
    /// edge of the grid.
    pub fn extended_by(&self, model: &GeislerPerry) -> Self {
        let base = Self::from_model(model);
        let union = |a: &[f64], b: &[f64]| {
            let mut v: Vec<f64> = a.iter().chain(b).copied().collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        let frequencies = union(&self.frequencies_cpd, &base.frequencies_cpd);
        let eccentricities = union(&self.eccentricities_deg, &base.eccentricities_deg);
        let inside = |v: &[f64], x: f64| v[0] <= x && x <= v[v.len() - 1];
        let rows = eccentricities
            .iter()
            .map(|&e| {
                frequencies
                    .iter()
                    .map(|&f| {
                        if inside(&self.frequencies_cpd, f) && inside(&self.eccentricities_deg, e) {
                            self.threshold(f, e)
                        } else {
                            model.contrast_threshold(f, e)
                        }
                    })
                    .collect()
            })
            .collect();
        // Both axes are sorted and deduplicated, every entry positive (a
        // table's thresholds are, and a valid model's are).
        Self::new(frequencies, eccentricities, rows).unwrap_or_else(|_| self.clone())
    }

    /// The table's spatial frequencies (cycles/degree), strictly increasing:
    /// one threshold per frequency in each row.
    pub fn frequencies_cpd(&self) -> &[f64] {
        &self.frequencies_cpd
    }

    /// The table's eccentricities (degrees), strictly increasing: one row
    /// of thresholds per eccentricity.
    pub fn eccentricities_deg(&self) -> &[f64] {
        &self.eccentricities_deg
    }

    fn log_at(&self, e_index: usize, f_index: usize) -> f64 {
        self.log_thresholds[e_index * self.frequencies_cpd.len() + f_index]
    }

    /// Threshold contrast at (`frequency_cpd`, `eccentricity_deg`): linear
    /// interpolation between table entries, done on the logarithm of the
    /// threshold (thresholds span many decades; the Geisler–Perry log
    /// threshold is bilinear in f and e, so a model-built table reproduces
    /// the model exactly, and interpolating raw values would over-estimate
    /// thresholds, i.e. call visible changes invisible). Clamped to the
    /// table's edges (a frequency below the table uses the first column,
    /// which the peak clamp made the most sensitive one). NaN in, NaN out.
    pub fn threshold(&self, frequency_cpd: f64, eccentricity_deg: f64) -> f64 {
        if frequency_cpd.is_nan() || eccentricity_deg.is_nan() {
            return f64::NAN;
        }
        let (e0, e1, te) = bracket(&self.eccentricities_deg, eccentricity_deg);
        let (f0, f1, tf) = bracket(&self.frequencies_cpd, frequency_cpd);
        let row = |e| self.log_at(e, f0) + (self.log_at(e, f1) - self.log_at(e, f0)) * tf;
        let lo = row(e0);
        (lo + (row(e1) - lo) * te).exp()
    }

    /// Would a grating of this contrast, frequency and eccentricity be seen?
    /// (Luebke & Hallen §3: an operation is applied only if its worst-case
    /// grating is not perceptible.) A NaN argument answers `true`: when in
    /// doubt, keep the detail.
    pub fn is_perceptible(&self, contrast: f64, frequency_cpd: f64, eccentricity_deg: f64) -> bool {
        let t = self.threshold(frequency_cpd, eccentricity_deg);
        contrast.is_nan() || t.is_nan() || contrast >= t
    }

    /// Highest frequency (cpd) at which `contrast` is still perceptible at
    /// `eccentricity_deg`, by inverting the table row (linear between
    /// columns). `None` if it is imperceptible at every frequency in the
    /// table; `Some(∞)` if it is perceptible even at the highest one (the
    /// table cannot say where it stops; callers must treat that as "always").
    pub fn threshold_frequency_cpd(&self, contrast: f64, eccentricity_deg: f64) -> Option<f64> {
        if contrast.is_nan() || eccentricity_deg.is_nan() {
            return Some(f64::INFINITY);
        }
        let f = &self.frequencies_cpd;
        let t = |i| self.threshold(f[i], eccentricity_deg);
        if contrast < t(0) {
            return None;
        }
        let last = f.len() - 1;
        if contrast >= t(last) {
            return Some(f64::INFINITY);
        }
        // Highest column still perceptible, then interpolate to the next one.
        let i = (0..last).rev().find(|&i| contrast >= t(i)).unwrap_or(0);
        let (t0, t1) = (t(i), t(i + 1));
        let frac = if t1 > t0 {
            ((contrast - t0) / (t1 - t0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some(f[i] + (f[i + 1] - f[i]) * frac)
    }

    /// Viewing distance (mm) beyond which a change of `contrast` spread over
    /// `extent_mm` on the screen becomes imperceptible at `eccentricity_deg`
    /// (Luebke & Hallen §5.3: order best-effort work by this distance).
    ///
    /// The worst-case frequency of a region spanning θ degrees is 1/(2θ) cpd
    /// (§3.1); the change is invisible once 1/(2θ) exceeds the threshold
    /// frequency f_t, i.e. θ < 1/(2 f_t), i.e. distance > extent / (2 tan(θ/2)).
    /// 0 if it is never perceptible; +∞ if it is perceptible at any distance
    /// the table covers. The eccentricity is held fixed.
    pub fn imperceptible_distance_mm(
        &self,
        contrast: f64,
        extent_mm: f64,
        eccentricity_deg: f64,
    ) -> f64 {
        if extent_mm.is_nan() {
            return f64::INFINITY;
        }
        if extent_mm <= 0.0 {
            return 0.0;
        }
        match self.threshold_frequency_cpd(contrast, eccentricity_deg) {
            None => 0.0,
            Some(f) if f.is_infinite() => f64::INFINITY,
            Some(f) => {
                let theta_deg = 0.5 / f;
                extent_mm / (2.0 * (theta_deg.to_radians() / 2.0).tan())
            }
        }
    }
}

/// Indices bracketing `x` in sorted `axis` and the interpolation weight,
/// clamped to the ends: the one lookup of every threshold table (this
/// module's and `lod`'s envelope). A NaN `x` gives weight NaN at index 0
/// (NaN in, NaN out); an empty axis gives `(0, 0, NaN)`.
pub fn bracket(axis: &[f64], x: f64) -> (usize, usize, f64) {
    let Some(last) = axis.len().checked_sub(1) else {
        return (0, 0, f64::NAN);
    };
    if x.is_nan() {
        return (0, 0, f64::NAN);
    }
    if x <= axis[0] {
        return (0, 0, 0.0);
    }
    if x >= axis[last] {
        return (last, last, 0.0);
    }
    let hi = axis.partition_point(|&a| a <= x).min(last);
    let lo = hi - 1;
    (lo, hi, (x - axis[lo]) / (axis[hi] - axis[lo]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extended_table_keeps_the_measured_grid_and_follows_the_model_outside() {
        let model = GeislerPerry {
            ct0: 0.03,
            alpha: 0.15,
            e2_deg: 2.0,
        };
        let measured = ThresholdTable::new(
            vec![1.0, 4.0, 16.0],
            vec![0.0, 10.0],
            vec![vec![0.02, 0.05, 0.3], vec![0.04, 0.2, 0.9]],
        )
        .unwrap();
        let t = measured.extended_by(&model);
        for (f, e) in [(1.0, 0.0), (4.0, 10.0), (2.5, 5.0), (16.0, 10.0)] {
            let (a, b) = (t.threshold(f, e), measured.threshold(f, e));
            assert!((a / b - 1.0).abs() < 1e-9, "({f}, {e}): {a} vs {b}");
        }
        for (f, e) in [(32.0, 0.0), (4.0, 30.0), (0.5, 60.0)] {
            let (a, b) = (t.threshold(f, e), model.contrast_threshold(f, e));
            assert!((a / b - 1.0).abs() < 1e-9, "({f}, {e}): {a} vs {b}");
        }
    }

    #[test]
    fn bracket_clamps_interpolates_and_passes_nan_through() {
        let axis = [1.0, 2.0, 4.0];
        assert_eq!(bracket(&axis, 0.0), (0, 0, 0.0));
        assert_eq!(bracket(&axis, 9.0), (2, 2, 0.0));
        assert_eq!(bracket(&axis, 3.0), (1, 2, 0.5));
        assert_eq!(bracket(&axis, 2.0), (1, 2, 0.0));
        assert_eq!(bracket(&axis, f64::INFINITY), (2, 2, 0.0));
        assert_eq!(bracket(&axis, f64::NEG_INFINITY), (0, 0, 0.0));
        let (lo, hi, w) = bracket(&axis, f64::NAN);
        assert_eq!((lo, hi), (0, 0));
        assert!(w.is_nan());
        assert!(bracket(&[], 1.0).2.is_nan());
        assert_eq!(bracket(&[5.0], 1.0), (0, 0, 0.0));
    }

    #[test]
    fn model_table_reproduces_the_model_at_grid_points() {
        let m = GeislerPerry::default();
        let t = ThresholdTable::from_model(&m);
        for &e in t.eccentricities_deg() {
            for &f in t.frequencies_cpd() {
                let rel = (t.threshold(f, e) / m.contrast_threshold(f, e) - 1.0).abs();
                assert!(rel < 1e-12);
            }
        }
    }

    #[test]
    fn lower_frequencies_than_the_peak_get_the_peak_threshold() {
        // A calibrated row whose sensitivity peaks at 4 cpd (threshold 0.002).
        let t = ThresholdTable::new(
            vec![1.0, 2.0, 4.0, 8.0],
            vec![0.0],
            vec![vec![0.01, 0.004, 0.002, 0.02]],
        )
        .unwrap();
        assert!((t.threshold(1.0, 0.0) - 0.002).abs() < 1e-15);
        assert!((t.threshold(0.1, 0.0) - 0.002).abs() < 1e-15);
        assert!(t.is_perceptible(0.003, 1.5, 0.0));
        assert!(!t.is_perceptible(0.003, 8.0, 0.0));
    }

    #[test]
    fn ragged_rows_name_the_row() {
        let e = ThresholdTable::new(
            vec![1.0, 2.0],
            vec![0.0, 5.0],
            vec![vec![0.1, 0.2], vec![0.1]],
        )
        .unwrap_err();
        assert!(e.reason.contains("row 1"), "{e}");
    }

    #[test]
    fn imperceptible_distance_grows_with_contrast() {
        let t = ThresholdTable::from_model(&GeislerPerry::default());
        let near = t.imperceptible_distance_mm(0.05, 1.0, 5.0);
        let far = t.imperceptible_distance_mm(0.5, 1.0, 5.0);
        assert!(
            near.is_finite() && far.is_finite() && far > near,
            "{near} {far}"
        );
        assert_eq!(t.imperceptible_distance_mm(0.001, 1.0, 5.0), 0.0);
    }
}
