//! From linear light to 8-bit levels: a measured [`LuminanceTable`]
//! (photometer readings per channel level) or a documented [`GammaCurve`].
//!
//! Both are wrapped in a [`Transfer`], which renders use and whose
//! [`Transfer::kind`] every rendered patch reports, so a stimulus file says
//! whether its contrasts rest on a photometer or on an assumed gamma.

use serde::{Deserialize, Serialize};

use crate::ParamError;

/// Number of levels of one 8-bit channel.
pub const LEVELS: usize = 256;

/// Photometer readings of a display: luminance (cd/m²) at some channel
/// levels, the grey level driven on all three channels.
///
/// Levels must include 0 and 255, be strictly increasing, and the readings
/// must be finite, ≥ 0 and strictly increasing with level (a display whose
/// luminance does not rise with level cannot be inverted). Levels between
/// readings are interpolated linearly in luminance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "LuminanceTableData", into = "LuminanceTableData")]
pub struct LuminanceTable {
    /// Luminance of every level 0..=255, interpolated from the readings.
    luminance: Vec<f64>,
    readings: LuminanceTableData,
}

/// The serialised form of a [`LuminanceTable`]: what a photometer session
/// writes down.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LuminanceTableData {
    /// Channel levels measured, strictly increasing, first 0 and last 255.
    pub levels: Vec<u8>,
    /// Luminance in cd/m² at each level, strictly increasing.
    pub luminance_cd_m2: Vec<f64>,
}

impl TryFrom<LuminanceTableData> for LuminanceTable {
    type Error = ParamError;
    fn try_from(d: LuminanceTableData) -> Result<Self, ParamError> {
        LuminanceTable::new(d.levels, d.luminance_cd_m2)
    }
}

impl From<LuminanceTable> for LuminanceTableData {
    fn from(t: LuminanceTable) -> Self {
        t.readings
    }
}

impl LuminanceTable {
    /// Validates photometer readings (see the type's doc) and interpolates
    /// every level. Each error names the field and the offending entry.
    pub fn new(levels: Vec<u8>, luminance_cd_m2: Vec<f64>) -> Result<Self, ParamError> {
        if levels.len() != luminance_cd_m2.len() {
            return Err(ParamError::new(
                "luminance_cd_m2",
                luminance_cd_m2.len(),
                format!("needs one reading per level ({} levels)", levels.len()),
            ));
        }
        if levels.len() < 2 {
            return Err(ParamError::new(
                "levels",
                levels.len(),
                "needs at least two readings, at levels 0 and 255",
            ));
        }
        if levels[0] != 0 {
            return Err(ParamError::new(
                "levels",
                levels[0],
                "the first reading must be at level 0 (black)",
            ));
        }
        if levels[levels.len() - 1] != 255 {
            return Err(ParamError::new(
                "levels",
                levels[levels.len() - 1],
                "the last reading must be at level 255 (white)",
            ));
        }
        for i in 1..levels.len() {
            if levels[i] <= levels[i - 1] {
                return Err(ParamError::new(
                    "levels",
                    levels[i],
                    format!(
                        "entry {i} must be above entry {} ({})",
                        i - 1,
                        levels[i - 1]
                    ),
                ));
            }
        }
        for (i, &l) in luminance_cd_m2.iter().enumerate() {
            if !l.is_finite() || l < 0.0 {
                return Err(ParamError::new(
                    "luminance_cd_m2",
                    l,
                    format!("entry {i} must be a finite luminance ≥ 0 cd/m²"),
                ));
            }
            if i > 0 && l <= luminance_cd_m2[i - 1] {
                return Err(ParamError::new(
                    "luminance_cd_m2",
                    l,
                    format!(
                        "entry {i} (level {}) must be brighter than entry {} (level {}): \
                         luminance must rise with level to be invertible",
                        levels[i],
                        i - 1,
                        levels[i - 1]
                    ),
                ));
            }
        }
        let mut luminance = Vec::with_capacity(LEVELS);
        for v in 0..LEVELS {
            // The reading at or above v; levels end at 255 so one exists.
            let hi = levels
                .iter()
                .position(|&l| usize::from(l) >= v)
                .unwrap_or(0);
            let l = if usize::from(levels[hi]) == v || hi == 0 {
                luminance_cd_m2[hi]
            } else {
                let (v0, v1) = (f64::from(levels[hi - 1]), f64::from(levels[hi]));
                let t = (v as f64 - v0) / (v1 - v0);
                luminance_cd_m2[hi - 1] + (luminance_cd_m2[hi] - luminance_cd_m2[hi - 1]) * t
            };
            luminance.push(l);
        }
        Ok(Self {
            luminance,
            readings: LuminanceTableData {
                levels,
                luminance_cd_m2,
            },
        })
    }
}

/// A display assumed to follow `L(v) = black + (white − black)·(v/255)^γ`.
///
/// Used when no photometer readings exist; a render that used it says so
/// ([`TransferKind::Gamma`]). The sRGB-like default is γ = 2.2, black
/// 0.5 cd/m², white 100 cd/m² (a typical office LCD, not a measurement).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GammaCurve {
    /// Exponent γ, 0.5–5.
    pub gamma: f64,
    /// Luminance at level 0, cd/m², ≥ 0.
    pub black_cd_m2: f64,
    /// Luminance at level 255, cd/m², above `black_cd_m2`.
    pub white_cd_m2: f64,
}

impl Default for GammaCurve {
    fn default() -> Self {
        Self {
            gamma: 2.2,
            black_cd_m2: 0.5,
            white_cd_m2: 100.0,
        }
    }
}

impl GammaCurve {
    /// Checks the parameters (ranges in the field docs).
    pub fn validate(&self) -> Result<(), ParamError> {
        if !(self.gamma.is_finite() && (0.5..=5.0).contains(&self.gamma)) {
            return Err(ParamError::new(
                "gamma",
                self.gamma,
                "must be a finite exponent in 0.5..=5",
            ));
        }
        if !(self.black_cd_m2.is_finite() && self.black_cd_m2 >= 0.0) {
            return Err(ParamError::new(
                "black_cd_m2",
                self.black_cd_m2,
                "must be a finite luminance ≥ 0 cd/m²",
            ));
        }
        if !(self.white_cd_m2.is_finite() && self.white_cd_m2 > self.black_cd_m2) {
            return Err(ParamError::new(
                "white_cd_m2",
                self.white_cd_m2,
                "must be finite and brighter than black_cd_m2",
            ));
        }
        Ok(())
    }
}

/// Which conversion a render used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum TransferKind {
    /// Photometer readings ([`LuminanceTable`]).
    Measured,
    /// An assumed gamma curve with this exponent ([`GammaCurve`]).
    Gamma(f64),
}

/// The conversion between 8-bit levels and linear light (cd/m²), with the
/// luminance of all 256 levels precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct Transfer {
    kind: TransferKind,
    luminance: Vec<f64>,
}

impl Transfer {
    /// From photometer readings.
    pub fn measured(table: &LuminanceTable) -> Self {
        Self {
            kind: TransferKind::Measured,
            luminance: table.luminance.clone(),
        }
    }

    /// From an assumed gamma curve (validated).
    pub fn gamma(curve: GammaCurve) -> Result<Self, ParamError> {
        curve.validate()?;
        let luminance = (0..LEVELS)
            .map(|v| {
                curve.black_cd_m2
                    + (curve.white_cd_m2 - curve.black_cd_m2) * (v as f64 / 255.0).powf(curve.gamma)
            })
            .collect();
        Ok(Self {
            kind: TransferKind::Gamma(curve.gamma),
            luminance,
        })
    }

    /// Which conversion this is.
    pub fn kind(&self) -> TransferKind {
        self.kind
    }

    /// Luminance (cd/m²) of `level`.
    pub fn luminance(&self, level: u8) -> f64 {
        self.luminance[usize::from(level)]
    }

    /// The inverse: the two levels bracketing `luminance_cd_m2` and the
    /// fraction of the way (in linear light) from the lower to the upper,
    /// `(lo, frac)` with `frac` in [0, 1); a luminance equal to a level's
    /// gives that level and 0. `None` outside [L(0), L(255)] or for NaN.
    pub fn invert(&self, luminance_cd_m2: f64) -> Option<(u8, f64)> {
        let l = luminance_cd_m2;
        if l.is_nan() || l < self.luminance[0] || l > self.luminance[LEVELS - 1] {
            return None;
        }
        // Largest level whose luminance is ≤ l (the table strictly rises).
        let lo = self.luminance.partition_point(|&x| x <= l) - 1;
        if lo == LEVELS - 1 {
            return Some((255, 0.0));
        }
        let (l0, l1) = (self.luminance[lo], self.luminance[lo + 1]);
        let frac = ((l - l0) / (l1 - l0)).clamp(0.0, 1.0);
        // lo < 255 here, so it fits a u8.
        Some((lo as u8, if frac >= 1.0 { 0.0 } else { frac }))
    }

    /// The highest Michelson contrast a pattern with mean luminance
    /// L(`background_level`) can have on this display:
    /// `min(L(255) − L̄, L̄ − L(0)) / L̄`, less one part in 10⁹ so that a
    /// render at exactly this contrast never rounds past the display's range.
    pub fn max_contrast(&self, background_level: u8) -> f64 {
        let l = self.luminance(background_level);
        if l <= 0.0 {
            return 0.0;
        }
        let c = (self.luminance[LEVELS - 1] - l).min(l - self.luminance[0]) / l;
        (c * (1.0 - 1e-9)).clamp(0.0, 1.0)
    }

    /// The luminance step between `level` and the next level up (the step
    /// below 255 for level 255).
    pub fn step_above(&self, level: u8) -> f64 {
        let v = usize::from(level).min(LEVELS - 2);
        self.luminance[v + 1] - self.luminance[v]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_interpolate_and_invert() {
        let t = LuminanceTable::new(vec![0, 128, 255], vec![1.0, 21.0, 101.0]).unwrap();
        let tr = Transfer::measured(&t);
        assert_eq!(tr.kind(), TransferKind::Measured);
        assert_eq!(tr.luminance(0), 1.0);
        assert_eq!(tr.luminance(128), 21.0);
        assert!((tr.luminance(64) - 11.0).abs() < 1e-12);
        assert_eq!(tr.invert(21.0), Some((128, 0.0)));
        let (lo, f) = tr.invert(11.05).unwrap();
        assert_eq!(lo, 64);
        assert!((f - 0.32).abs() < 1e-9, "{f}");
        assert_eq!(tr.invert(101.0), Some((255, 0.0)));
        assert_eq!(tr.invert(0.5), None);
        assert_eq!(tr.invert(f64::NAN), None);
    }

    #[test]
    fn bad_readings_are_named() {
        let e = LuminanceTable::new(vec![0, 128, 255], vec![1.0, 0.5, 101.0]).unwrap_err();
        assert_eq!(e.field, "luminance_cd_m2");
        assert!(e.reason.contains("level 128"), "{e}");
        let e = LuminanceTable::new(vec![0, 200], vec![1.0, 2.0]).unwrap_err();
        assert_eq!(e.field, "levels");
        let e = LuminanceTable::new(vec![0, 255], vec![1.0]).unwrap_err();
        assert_eq!(e.field, "luminance_cd_m2");
        let e = LuminanceTable::new(vec![0, 255], vec![f64::NAN, 2.0]).unwrap_err();
        assert!(e.to_string().contains("NaN"), "{e}");
        let ron_text = "(levels: [0, 255], luminance_cd_m2: [0.3, 120.0])";
        let t: LuminanceTable = ron::from_str(ron_text).unwrap();
        assert_eq!(Transfer::measured(&t).luminance(255), 120.0);
        assert!(
            ron::from_str::<LuminanceTable>("(levels: [0, 9], luminance_cd_m2: [0.3, 1.0])")
                .is_err()
        );
    }

    #[test]
    fn gamma_curve_is_checked_and_reported() {
        let tr = Transfer::gamma(GammaCurve::default()).unwrap();
        assert_eq!(tr.kind(), TransferKind::Gamma(2.2));
        assert_eq!(tr.luminance(0), 0.5);
        // Around level 128 (22.34 cd/m²) the dark side limits it.
        let c = tr.max_contrast(128);
        assert!((c - (22.342_211_948_449_354 - 0.5) / 22.342_211_948_449_354).abs() < 1e-8);
        assert_eq!(tr.max_contrast(0), 0.0);
        assert!((tr.luminance(255) - 100.0).abs() < 1e-12);
        let bad = GammaCurve {
            gamma: f64::INFINITY,
            ..GammaCurve::default()
        };
        assert_eq!(Transfer::gamma(bad).unwrap_err().field, "gamma");
        let bad = GammaCurve {
            white_cd_m2: 0.1,
            ..GammaCurve::default()
        };
        assert_eq!(Transfer::gamma(bad).unwrap_err().field, "white_cd_m2");
    }
}
