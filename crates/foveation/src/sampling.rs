//! How densely the screen must be sampled: the CSF cut-off turned into a ray
//! spacing with the Nyquist criterion (Murphy 2007 §4.4.4, DESIGN.md).

use crate::csf::GeislerPerry;
use crate::display::ScreenGeometry;
use crate::error::{positive, ParamError};

/// The seed's maximum ray spacing in pixels (Murphy 2007 §4.4.4: n ∈ [1..17]).
pub const SEED_MAX_SPACING_PX: f64 = 17.0;

/// A display, a CSF and a contrast level: everything that decides the
/// allowed ray spacing at a screen point for a given point of regard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SamplingModel {
    /// The display and the eye's position.
    pub geometry: ScreenGeometry,
    /// The contrast-sensitivity model giving the cut-off frequency.
    pub csf: GeislerPerry,
    /// Michelson contrast C of the worst-case stimulus (1 = the seed's choice).
    pub contrast: f64,
    /// Largest spacing ever allowed, pixels (the seed's n_max = 17).
    pub max_spacing_px: f64,
    /// Diameter, in degrees of visual angle, of a full-resolution inset
    /// around the POR that the ray mask casts one ray per pixel in whatever
    /// the CSF allows (Murphy 2007 ch. 7's "high-resolution inset"); 0: none,
    /// the one-ray-per-pixel disc is the CSF's alone. Set with
    /// [`SamplingModel::with_inset_deg`].
    pub inset_deg: f64,
    /// Gaze tolerance, degrees of visual angle: the spacing at a point is
    /// the one its eccentricity less this allows (`f_c(max(e − ε, 0))`),
    /// so a mask built for a POR `c` is dense enough for every POR within
    /// `ε` of `c` at the eye (the angle between two lines of sight obeys
    /// the triangle inequality, and the allowed spacing grows with
    /// eccentricity). A renderer may then keep one mask while the gaze
    /// stays within `ε` of the POR it was built for (a fixation's jitter)
    /// and reuse its work. 0 (the default): the mask fits its POR alone.
    /// Set with [`SamplingModel::with_gaze_tolerance_deg`].
    pub gaze_tolerance_deg: f64,
}

/// The largest gaze tolerance [`SamplingModel::with_gaze_tolerance_deg`]
/// takes, degrees: a tolerance this wide already makes a fovea about 20°
/// across, most of a desktop display.
pub const MAX_GAZE_TOLERANCE_DEG: f64 = 10.0;

/// The allowed spacing at one point, with what it was derived from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spacing {
    /// Allowed ray spacing in pixels, clamped to `[1, max_spacing_px]`.
    pub spacing_px: f64,
    /// Eccentricity of the point from the POR, degrees.
    pub eccentricity_deg: f64,
    /// Conservative local pixels per degree at the point.
    pub ppd: f64,
}

impl SamplingModel {
    /// Validates the contrast (must exceed CT0: at C ≤ CT0 nothing is
    /// perceptible and no mask is meaningful) and the maximum spacing (≥ 1).
    pub fn new(
        geometry: ScreenGeometry,
        csf: GeislerPerry,
        contrast: f64,
        max_spacing_px: f64,
    ) -> Result<Self, ParamError> {
        csf.validate()?;
        if !(contrast.is_finite() && contrast > csf.ct0) {
            return Err(ParamError::new(
                "contrast",
                contrast,
                format!(
                    "must be a finite contrast above CT0 = {:.6}; at or below it nothing is \
                     perceptible, so there is no sampling requirement to build a mask from",
                    csf.ct0
                ),
            ));
        }
        positive("max_spacing_px", max_spacing_px)?;
        if max_spacing_px < 1.0 {
            return Err(ParamError::new(
                "max_spacing_px",
                max_spacing_px,
                "must be at least 1",
            ));
        }
        Ok(Self {
            geometry,
            csf,
            contrast,
            max_spacing_px,
            inset_deg: 0.0,
            gaze_tolerance_deg: 0.0,
        })
    }

    /// The same model with a gaze tolerance of `deg` degrees (see
    /// [`SamplingModel::gaze_tolerance_deg`]). 0 removes it. Errors: not
    /// finite, negative, or above [`MAX_GAZE_TOLERANCE_DEG`].
    pub fn with_gaze_tolerance_deg(mut self, deg: f64) -> Result<Self, ParamError> {
        if !(deg.is_finite() && (0.0..=MAX_GAZE_TOLERANCE_DEG).contains(&deg)) {
            return Err(ParamError::new(
                "gaze_tolerance_deg",
                deg,
                format!("must be a finite angle in [0, {MAX_GAZE_TOLERANCE_DEG}] degrees"),
            ));
        }
        self.gaze_tolerance_deg = deg;
        Ok(self)
    }

    /// Whether a mask built for the POR `built_px` serves the POR `gaze_px`
    /// under this model's gaze tolerance: the two lines of sight are at
    /// most [`SamplingModel::gaze_tolerance_deg`] apart at the eye (and the
    /// tolerance is not 0). Non-finite points never do.
    pub fn within_tolerance(&self, built_px: [f64; 2], gaze_px: [f64; 2]) -> bool {
        self.gaze_tolerance_deg > 0.0
            && built_px.iter().chain(&gaze_px).all(|v| v.is_finite())
            && self.geometry.eccentricity_deg(built_px, gaze_px) <= self.gaze_tolerance_deg
    }

    /// The same model with a full-resolution inset `diameter_deg` wide
    /// (degrees of visual angle at the eye) around the POR: the mask's
    /// one-ray-per-pixel disc becomes the larger of the CSF's and the
    /// smallest disc holding every point within `diameter_deg / 2` of the
    /// POR ([`crate::mask`]). 0 removes the inset. Errors: not finite, negative,
    /// or 180° and more (a half-angle of 90° reaches the screen's plane).
    pub fn with_inset_deg(mut self, diameter_deg: f64) -> Result<Self, ParamError> {
        if !(diameter_deg.is_finite() && (0.0..180.0).contains(&diameter_deg)) {
            return Err(ParamError::new(
                "inset_deg",
                diameter_deg,
                "must be a finite diameter in [0, 180) degrees",
            ));
        }
        self.inset_deg = diameter_deg;
        Ok(self)
    }

    /// Allowed spacing in degrees at eccentricity `e_deg`: half a period of
    /// the cut-off frequency, `1 / (2 f_c(e))` (Nyquist). +∞ if nothing is
    /// perceptible there.
    pub fn nyquist_spacing_deg(&self, e_deg: f64) -> f64 {
        let f = self.csf.cutoff_frequency_cpd(self.contrast, e_deg);
        if f > 0.0 {
            0.5 / f
        } else {
            f64::INFINITY
        }
    }

    /// Allowed spacing at screen point `p_px` while the eye fixates `por_px`,
    /// converted to pixels with the conservative local pixels-per-degree and
    /// clamped to `[1, max_spacing_px]`.
    pub fn spacing_at(&self, por_px: [f64; 2], p_px: [f64; 2]) -> Spacing {
        self.from_por(por_px).spacing_at(p_px)
    }

    /// Precomputes what does not change while the POR stays at `por_px`.
    pub fn from_por(&self, por_px: [f64; 2]) -> PorSampler {
        let g = &self.geometry;
        PorSampler {
            por_px,
            pitch: [g.pitch_x_mm, g.pitch_y_mm],
            eye_to_por_mm: g.eye_to_point_mm(por_px),
            // f_c(e) = e2·ln(C/CT0) / (α·(e + e2)): the numerator is constant.
            cutoff_numerator: self.csf.e2_deg * (self.contrast / self.csf.ct0).ln()
                / self.csf.alpha,
            e2_deg: self.csf.e2_deg,
            ppd_per_mm: std::f64::consts::PI / 180.0 / g.max_pitch_mm(),
            max_spacing_px: self.max_spacing_px,
            tolerance_deg: self.gaze_tolerance_deg,
        }
    }

    /// Rays per pixel the continuous Nyquist bound asks for at `p_px`:
    /// `min(1, (2 f_c(e) / ppd)²)` (no `max_spacing_px` floor).
    pub fn required_density(&self, por_px: [f64; 2], p_px: [f64; 2]) -> f64 {
        let e = self.geometry.eccentricity_deg(por_px, p_px);
        let e = if self.gaze_tolerance_deg > 0.0 {
            (e - self.gaze_tolerance_deg).max(0.0)
        } else {
            e
        };
        let f = self.csf.cutoff_frequency_cpd(self.contrast, e);
        let per_px = 2.0 * f / self.geometry.local_ppd(p_px);
        (per_px * per_px).min(1.0)
    }
}

/// The allowed spacing around one POR, with the per-POR constants hoisted out
/// of the per-point work (the mask evaluates it tens of thousands of times).
/// Gives the same values as [`SamplingModel::spacing_at`] to rounding.
#[derive(Debug, Clone, Copy)]
pub struct PorSampler {
    por_px: [f64; 2],
    pitch: [f64; 2],
    eye_to_por_mm: [f64; 3],
    cutoff_numerator: f64,
    e2_deg: f64,
    ppd_per_mm: f64,
    max_spacing_px: f64,
    tolerance_deg: f64,
}

impl PorSampler {
    /// The point of regard the sampler was made for, screen pixels.
    pub fn por_px(&self) -> [f64; 2] {
        self.por_px
    }

    /// See [`SamplingModel::spacing_at`].
    pub fn spacing_at(&self, p_px: [f64; 2]) -> Spacing {
        let a = self.eye_to_por_mm;
        let d = [
            (p_px[0] - self.por_px[0]) * self.pitch[0],
            (p_px[1] - self.por_px[1]) * self.pitch[1],
        ];
        // a × d with d_z = 0, and a·(a + d): the eccentricity formula of
        // ScreenGeometry::eccentricity_deg.
        let cross = [-a[2] * d[1], a[2] * d[0], a[0] * d[1] - a[1] * d[0]];
        let b = [a[0] + d[0], a[1] + d[1], a[2]];
        let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let eccentricity_deg = norm3(cross).atan2(dot).to_degrees();
        let ppd = norm3(b) * self.ppd_per_mm;
        // The gaze tolerance lowers the eccentricity the cut-off is taken at.
        let e = if self.tolerance_deg > 0.0 {
            (eccentricity_deg - self.tolerance_deg).max(0.0)
        } else {
            eccentricity_deg
        };
        let cutoff = self.cutoff_numerator / (e + self.e2_deg);
        let raw = 0.5 / cutoff * ppd;
        let spacing_px = if raw.is_nan() {
            1.0
        } else {
            raw.clamp(1.0, self.max_spacing_px)
        };
        Spacing {
            spacing_px,
            eccentricity_deg,
            ppd,
        }
    }
}

/// Euclidean norm; plain square root when it cannot overflow or underflow.
pub(crate) use screen_geometry::norm3;
