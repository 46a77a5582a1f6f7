//! Depth of field with the thin-lens model: circle of confusion and the
//! continuous mipmap level that approximates the blur (Lee 2009, §4.1.2–4.1.3,
//! eq. 4.2–4.6).

use serde::{Deserialize, Serialize};

use crate::error::{positive, ParamError};

/// The eye as a thin lens.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EyeLens {
    /// F: focal length, mm (Lee: 16.7 mm for an adult eye at infinity).
    pub focal_length_mm: f64,
    /// E: effective lens (pupil) diameter, mm (Lee's example: 4 mm).
    pub aperture_mm: f64,
    /// d_r: lens-to-retina (image plane) distance, mm (Lee: 24 mm).
    pub retina_distance_mm: f64,
}

impl Default for EyeLens {
    fn default() -> Self {
        Self {
            focal_length_mm: 16.7,
            aperture_mm: 4.0,
            retina_distance_mm: 24.0,
        }
    }
}

/// Lee's scaling constant k_σ = 2/3, from σ = (3/2)·2^(m-1) (eq. 4.5).
pub const K_SIGMA: f64 = 2.0 / 3.0;

impl EyeLens {
    /// Checks that every length is positive and finite; the error names the field.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("focal_length_mm", self.focal_length_mm)?;
        positive("aperture_mm", self.aperture_mm)?;
        positive("retina_distance_mm", self.retina_distance_mm)?;
        Ok(())
    }

    /// Diameter of the circle of confusion on the retina, mm, for an object
    /// at depth `depth_mm` while the eye focuses at `focus_mm` (eq. 4.2–4.3):
    /// `R = (E·F / (d_f − F)) · |d − d_f| / d`.
    ///
    /// Depths must exceed the focal length (nearer objects form no real
    /// image). Infinite depths are the limits: d → ∞ gives `E·F/(d_f − F)`,
    /// d_f → ∞ gives `E·F/d`.
    pub fn coc_retina_mm(&self, depth_mm: f64, focus_mm: f64) -> Result<f64, ParamError> {
        self.validate()?;
        let f = self.focal_length_mm;
        let e = self.aperture_mm;
        for (field, v) in [("depth_mm", depth_mm), ("focus_mm", focus_mm)] {
            if v.is_nan() || v <= f {
                return Err(ParamError::new(
                    field,
                    v,
                    format!("must be beyond the focal length ({f} mm) to form a real image"),
                ));
            }
        }
        Ok(match (depth_mm.is_infinite(), focus_mm.is_infinite()) {
            (true, true) => 0.0,
            (true, false) => e * f / (focus_mm - f),
            (false, true) => e * f / depth_mm,
            (false, false) => e * f / (focus_mm - f) * (depth_mm - focus_mm).abs() / depth_mm,
        })
    }

    /// Circle of confusion on the screen in pixels (eq. 4.4):
    /// `C = DPI · (d_s / d_r) · R`, with `pixels_per_mm` the screen's DPI in
    /// dots per mm and `screen_distance_mm` the lens-to-screen distance d_s.
    pub fn coc_px(
        &self,
        depth_mm: f64,
        focus_mm: f64,
        screen_distance_mm: f64,
        pixels_per_mm: f64,
    ) -> Result<f64, ParamError> {
        positive("screen_distance_mm", screen_distance_mm)?;
        positive("pixels_per_mm", pixels_per_mm)?;
        let r = self.coc_retina_mm(depth_mm, focus_mm)?;
        Ok(pixels_per_mm * (screen_distance_mm / self.retina_distance_mm) * r)
    }
}

/// Degree of blurring σ for a pixel-space CoC diameter (Lee §4.1.3: σ = C/2).
pub fn degree_of_blur(coc_px: f64) -> f64 {
    coc_px / 2.0
}

/// Continuous mipmap level for degree of blurring σ (eq. 4.6): 0 when
/// `k_σ·σ < 0.5` (no visible blur), else `1 + log2(k_σ·σ)`. Never negative;
/// NaN only for NaN input.
pub fn mipmap_level(sigma: f64) -> f64 {
    if sigma.is_nan() {
        return f64::NAN;
    }
    let s = K_SIGMA * sigma;
    if s < 0.5 {
        0.0
    } else {
        1.0 + s.log2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lees_worked_example_stays_under_ten_pixels() {
        // Lee §4.1.5: projection display 3 m away, 0.32 px/mm, F = 17 mm,
        // E = 4 mm, d_r = 24 mm, nearest object at 300 mm: CoC ≤ 10 px.
        let lens = EyeLens {
            focal_length_mm: 17.0,
            aperture_mm: 4.0,
            retina_distance_mm: 24.0,
        };
        let c = lens.coc_px(300.0, 3000.0, 3000.0, 0.32).unwrap();
        assert!(c > 1.0 && c <= 10.0, "{c}");
    }

    #[test]
    fn in_focus_is_zero_blur_and_level_zero() {
        let lens = EyeLens::default();
        assert_eq!(lens.coc_retina_mm(600.0, 600.0).unwrap(), 0.0);
        assert_eq!(mipmap_level(degree_of_blur(0.0)), 0.0);
    }

    #[test]
    fn mip_level_inverts_eq_4_5() {
        for m in [1.0, 2.0, 3.5] {
            let sigma = 1.5 * 2f64.powf(m - 1.0);
            assert!((mipmap_level(sigma) - m).abs() < 1e-12);
        }
    }

    #[test]
    fn depth_inside_the_focal_length_is_an_error() {
        let e = EyeLens::default().coc_retina_mm(10.0, 500.0).unwrap_err();
        assert_eq!(e.field, "depth_mm");
    }
}
