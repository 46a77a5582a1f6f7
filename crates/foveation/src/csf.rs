//! The Geisler–Perry contrast threshold model and its inversions
//! (Murphy 2007, §4.4.3, eq. 4.1–4.3; Geisler & Perry 1998).

use serde::{Deserialize, Serialize};

use crate::error::{positive, ParamError};

/// Parameters of `CT(f, e) = CT0 · exp(α · f · (e + e2) / e2)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeislerPerry {
    /// Minimum contrast threshold CT0 (at f → 0, e = 0).
    pub ct0: f64,
    /// Spatial frequency decay constant α.
    pub alpha: f64,
    /// Half-resolution eccentricity e2, degrees.
    pub e2_deg: f64,
}

impl Default for GeislerPerry {
    /// Geisler & Perry's fitted values as used in Murphy 2007 §4.4.3:
    /// CT0 = 1/64, α = 0.106, e2 = 2.3°.
    fn default() -> Self {
        Self {
            ct0: 1.0 / 64.0,
            alpha: 0.106,
            e2_deg: 2.3,
        }
    }
}

impl GeislerPerry {
    /// Checks the parameters: 0 < CT0 < 1, α > 0, e2 > 0.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("ct0", self.ct0)?;
        if self.ct0 >= 1.0 {
            return Err(ParamError::new(
                "ct0",
                self.ct0,
                "must be below 1 (a contrast)",
            ));
        }
        positive("alpha", self.alpha)?;
        positive("e2_deg", self.e2_deg)?;
        Ok(())
    }

    /// Contrast threshold at spatial frequency `f_cpd` and eccentricity
    /// `e_deg` (Murphy 2007, eq. 4.1). Negative eccentricities are taken as 0;
    /// huge arguments give +∞, never NaN (NaN only from a NaN argument).
    pub fn contrast_threshold(&self, f_cpd: f64, e_deg: f64) -> f64 {
        let e = e_deg.max(0.0);
        let f = f_cpd.max(0.0);
        if f == 0.0 {
            // 0 · ∞ would be NaN for e = ∞; a zero frequency has threshold CT0.
            return self.ct0;
        }
        self.ct0 * (self.alpha * f * ((e + self.e2_deg) / self.e2_deg)).exp()
    }

    /// Highest perceptible spatial frequency (cycles/degree) at eccentricity
    /// `e_deg` for a stimulus of Michelson contrast `contrast`: eq. 4.3 with
    /// the unit contrast of the seed generalised to C,
    /// `f_c(e) = e2 · ln(C / CT0) / (α · (e + e2))`.
    ///
    /// C = 1 is the seed's conservative case. C ≤ CT0 means nothing is
    /// perceptible: the band is empty and the result is 0, never negative.
    pub fn cutoff_frequency_cpd(&self, contrast: f64, e_deg: f64) -> f64 {
        if contrast.is_nan() || e_deg.is_nan() {
            return f64::NAN;
        }
        if contrast <= self.ct0 {
            return 0.0;
        }
        let e = e_deg.max(0.0);
        let f = self.e2_deg * (contrast / self.ct0).ln() / (self.alpha * (e + self.e2_deg));
        if f.is_finite() {
            f.max(0.0)
        } else if e.is_infinite() {
            0.0
        } else {
            f64::INFINITY
        }
    }

    /// Eccentricity (degrees) beyond which frequency `f_cpd` at contrast
    /// `contrast` is no longer perceptible (Murphy 2007, eq. 4.2, generalised
    /// to C). `None` when it is not perceptible even at the fovea (including
    /// C ≤ CT0); `Some(∞)` for f = 0.
    pub fn eccentricity_limit_deg(&self, f_cpd: f64, contrast: f64) -> Option<f64> {
        if f_cpd.is_nan() || contrast.is_nan() || contrast <= self.ct0 || f_cpd < 0.0 {
            return None;
        }
        if f_cpd == 0.0 {
            return Some(f64::INFINITY);
        }
        let e = self.e2_deg / (self.alpha * f_cpd) * (contrast / self.ct0).ln() - self.e2_deg;
        (e >= 0.0).then_some(e)
    }

    /// Contrast sensitivity (1 / threshold), the quantity the CSF plots.
    pub fn sensitivity(&self, f_cpd: f64, e_deg: f64) -> f64 {
        1.0 / self.contrast_threshold(f_cpd, e_deg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn foveal_cutoff_at_unit_contrast_matches_the_seed_constants() {
        let m = GeislerPerry::default();
        // e2 ln(64) / (α e2) = ln 64 / 0.106 ≈ 39.23 cpd
        let f = m.cutoff_frequency_cpd(1.0, 0.0);
        assert!((f - 64f64.ln() / 0.106).abs() < 1e-12);
    }

    #[test]
    fn cutoff_and_limit_are_inverses() {
        let m = GeislerPerry::default();
        for e in [0.0, 1.0, 5.0, 20.0, 60.0] {
            let f = m.cutoff_frequency_cpd(0.5, e);
            let back = m.eccentricity_limit_deg(f, 0.5).unwrap();
            assert!((back - e).abs() < 1e-9, "{e} -> {f} -> {back}");
            assert!((m.contrast_threshold(f, e) - 0.5).abs() < 1e-12);
        }
    }

    #[test]
    fn contrast_at_or_below_ct0_is_an_empty_band() {
        let m = GeislerPerry::default();
        assert_eq!(m.cutoff_frequency_cpd(m.ct0, 0.0), 0.0);
        assert_eq!(m.cutoff_frequency_cpd(0.0, 10.0), 0.0);
        assert_eq!(m.eccentricity_limit_deg(1.0, 0.001), None);
    }
}
