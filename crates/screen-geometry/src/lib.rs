//! The display geometry gazecast's crates share: a [`Display`] as a lab
//! describes it (`config/displays/*.ron`), its validated [`ScreenGeometry`]
//! (pixel pitch, eye position), and the visual angle between two screen
//! points seen from the eye.
//!
//! `foveation` (the perceptual maths) and
//! `tracker-hal` (gaze sources, calibration) both need it and know nothing
//! of each other, so it lives here, below both; `foveation` re-exports it
//! (`foveation::Display`, `foveation::ScreenGeometry`,
//! `foveation::ParamError`), so its users need not name this crate.
//!
//! The eye sits on the screen normal through a configurable point (default the
//! screen centre) at `eye_distance_mm`. Screen coordinates are pixels with the
//! origin at the top-left corner, x to the right, y down; a pixel's centre is at
//! `(x + 0.5, y + 0.5)`.

#![warn(missing_docs)]

use serde::{Deserialize, Serialize};

/// A value the maths refuses, named by the field it came from so a caller
/// (the config loader, the CLI) can point a person at the right place. The
/// one error type of this crate and of `foveation`, which re-exports it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {value}: {reason}")]
pub struct ParamError {
    /// Dotted path of the offending field, e.g. `size_mm.0` or `contrast`.
    pub field: &'static str,
    /// The value as given, formatted.
    pub value: String,
    /// What is wrong and what would be accepted.
    pub reason: String,
}

impl ParamError {
    /// An error about `field` (its dotted path), which had `value` (formatted
    /// for the message), saying `reason`.
    pub fn new(
        field: &'static str,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Self {
            field,
            value: tidy_value(&value.to_string()),
            reason: reason.into(),
        }
    }
}

/// A number for a message: as Rust prints it inside 1e-4..1e9 (and zero,
/// infinities, NaN), otherwise in scientific notation with at most six
/// significant digits (`1e-300`, `-1.23457e308`), never a 300-digit decimal.
pub fn fmt_f64(v: f64) -> String {
    let a = v.abs();
    if !v.is_finite() || v == 0.0 || (1e-4..1e9).contains(&a) {
        return v.to_string();
    }
    let s = format!("{v:.5e}");
    match s.split_once('e') {
        Some((mantissa, exp)) if mantissa.contains('.') => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exp}")
        }
        _ => s,
    }
}

/// A value's text as [`ParamError`] shows it: a decimal number outside
/// 1e-4..1e9 is rewritten with [`fmt_f64`]; integers that fit 64 bits
/// (pixel counts, sizes) and anything else are kept as they are.
fn tidy_value(s: &str) -> String {
    let digits = s.strip_prefix('-').unwrap_or(s);
    let integer = !digits.is_empty() && digits.chars().all(|c| c.is_ascii_digit());
    if integer && digits.len() <= 20 {
        return s.to_string();
    }
    match s.parse::<f64>() {
        Ok(v) => fmt_f64(v),
        Err(_) => s.to_string(),
    }
}

/// Checks that `value` is finite and strictly positive (foveation's
/// parameter checks use it too).
pub fn positive(field: &'static str, value: f64) -> Result<f64, ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ParamError::new(
            field,
            value,
            "must be a finite number greater than zero",
        ))
    }
}

/// Euclidean norm of a 3-vector; the plain square root when the sum of
/// squares can neither overflow nor underflow, `hypot` otherwise.
pub fn norm3(v: [f64; 3]) -> f64 {
    let s = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if s.is_normal() && s < 1e300 {
        s.sqrt()
    } else {
        v[0].hypot(v[1]).hypot(v[2])
    }
}

/// Eye distances (mm) a measured eye position may stand for: a head 10 cm
/// to 3 m from the screen; others are not plausible measurements (the
/// ray masks ignore them, the trackers' eye-distance readings drop them).
pub const EYE_DISTANCE_RANGE_MM: std::ops::RangeInclusive<f64> = 100.0..=3000.0;

/// The longest screen side accepted, pixels: 16384.
///
/// The largest 2D texture every desktop GPU API guarantees (Direct3D 11/12
/// feature level 11, Vulkan and Metal on desktop adapters), so the GPU
/// back-end can hold any accepted frame in one texture; it also keeps ray
/// mask vertices (stored as `f32`) within 1/1024 px of where they belong,
/// since `f32` resolves 2⁻¹⁰ at 16384.
pub const MAX_SIDE_PX: u32 = 16_384;

/// The most pixels a screen may have: 67,108,864 = 8192 × 8192.
///
/// A G-buffer frame costs 25 bytes a pixel (colour 3, hit 1, depth 4,
/// object id 4, normal 12, layer 1), so the largest accepted frame takes
/// 1.7 GB; the 4K (3840 × 2160, 8.3 Mpx) and 8K UHD (7680 × 4320, 33.2 Mpx)
/// panels, and 8K × 8K, pass with room to spare, while 70000 × 70000 (the
/// 14.7 GB colour buffer that aborted) and 16384 × 16384 (6.7 GB) do not.
pub const MAX_PIXELS: u64 = 67_108_864;

/// Checks a resolution against the size limits before anything is sized
/// from it: each side from 1 to [`MAX_SIDE_PX`] and at most [`MAX_PIXELS`]
/// in all. The error names `resolution_px.0` (width), `resolution_px.1`
/// (height) or `resolution_px` (the product).
pub fn check_resolution(width_px: u32, height_px: u32) -> Result<(), ParamError> {
    for (field, side) in [
        ("resolution_px.0", width_px),
        ("resolution_px.1", height_px),
    ] {
        if !(1..=MAX_SIDE_PX).contains(&side) {
            return Err(ParamError::new(
                field,
                side,
                format!("must be from 1 to {MAX_SIDE_PX} pixels"),
            ));
        }
    }
    let pixels = u64::from(width_px) * u64::from(height_px);
    if pixels > MAX_PIXELS {
        return Err(ParamError::new(
            "resolution_px",
            format!("({width_px}, {height_px})"),
            format!(
                "{pixels} pixels; at most {MAX_PIXELS} (8192 x 8192) are accepted, \
                 which 8K UHD (7680 x 4320) fits"
            ),
        ));
    }
    Ok(())
}

/// A physical display as a lab describes it (`config/displays/*.ron`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Display {
    /// Human-readable name, shown in reports.
    pub name: String,
    /// Resolution in pixels, (width, height).
    pub resolution_px: (u32, u32),
    /// Physical size of the active area in millimetres, (width, height).
    pub size_mm: (f64, f64),
    /// Distance from the eye to the screen plane along the normal, mm.
    pub eye_distance_mm: f64,
    /// Screen point (pixels) the eye's normal passes through; `None` = centre.
    #[serde(default)]
    pub eye_point_px: Option<(f64, f64)>,
}

impl Display {
    /// The seed's set-up (Murphy 2007 ch. 7.1, `config/displays/
    /// tobii-et1750-17in.ron`): the Tobii ET-1750's 17" LCD, 337.9 ×
    /// 270.3 mm, the eye 540 mm away on the centre's normal, at `w`×`h`
    /// pixels — the physical size stays and the pitch follows, so tests and
    /// benches can use the seed's display at any pixel count without
    /// reading the file (a test checks the two agree at 1280×1024).
    pub fn seed_17in(w: u32, h: u32) -> Display {
        Display {
            name: format!("17in at {w}x{h}"),
            resolution_px: (w, h),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 540.0,
            eye_point_px: None,
        }
    }

    /// Checks every field and returns the derived geometry. The resolution
    /// must be within [`MAX_SIDE_PX`] and [`MAX_PIXELS`] (see
    /// [`check_resolution`]).
    pub fn geometry(&self) -> Result<ScreenGeometry, ParamError> {
        let (w, h) = self.resolution_px;
        check_resolution(w, h)?;
        let width_mm = positive("size_mm.0", self.size_mm.0)?;
        let height_mm = positive("size_mm.1", self.size_mm.1)?;
        let eye_distance_mm = positive("eye_distance_mm", self.eye_distance_mm)?;
        let (ex, ey) = self
            .eye_point_px
            .unwrap_or((f64::from(w) / 2.0, f64::from(h) / 2.0));
        if !ex.is_finite() {
            return Err(ParamError::new(
                "eye_point_px.0",
                ex,
                "must be a finite pixel coordinate",
            ));
        }
        if !ey.is_finite() {
            return Err(ParamError::new(
                "eye_point_px.1",
                ey,
                "must be a finite pixel coordinate",
            ));
        }
        Ok(ScreenGeometry {
            width_px: w,
            height_px: h,
            pitch_x_mm: width_mm / f64::from(w),
            pitch_y_mm: height_mm / f64::from(h),
            eye_point_px: [ex, ey],
            eye_distance_mm,
        })
    }
}

/// Validated, derived geometry of one display and one eye position. Cheap to copy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenGeometry {
    /// Horizontal resolution, pixels.
    pub width_px: u32,
    /// Vertical resolution, pixels.
    pub height_px: u32,
    /// Width of one pixel, millimetres.
    pub pitch_x_mm: f64,
    /// Height of one pixel, millimetres.
    pub pitch_y_mm: f64,
    /// Screen point (pixels, origin top-left) the eye's normal passes through.
    pub eye_point_px: [f64; 2],
    /// Distance from the eye to the screen plane along that normal, millimetres.
    pub eye_distance_mm: f64,
}

impl ScreenGeometry {
    /// Screen size in pixels as floats, (width, height).
    pub fn size_px(&self) -> [f64; 2] {
        [f64::from(self.width_px), f64::from(self.height_px)]
    }

    /// The larger of the two pixel pitches. Used wherever a conservative
    /// isotropic pitch is needed (real displays have square pixels to within
    /// a fraction of a percent).
    pub fn max_pitch_mm(&self) -> f64 {
        self.pitch_x_mm.max(self.pitch_y_mm)
    }

    /// Vector from the eye to screen point `p_px`, in millimetres. The screen
    /// is the plane z = 0 and the eye is at z = `eye_distance_mm`.
    pub fn eye_to_point_mm(&self, p_px: [f64; 2]) -> [f64; 3] {
        [
            (p_px[0] - self.eye_point_px[0]) * self.pitch_x_mm,
            (p_px[1] - self.eye_point_px[1]) * self.pitch_y_mm,
            -self.eye_distance_mm,
        ]
    }

    /// Distance from the eye to screen point `p_px`, mm.
    pub fn eye_distance_to_mm(&self, p_px: [f64; 2]) -> f64 {
        norm3(self.eye_to_point_mm(p_px))
    }

    /// Eccentricity of `b_px` seen from the eye while it fixates `a_px`: the
    /// angle at the eye between the two lines of sight, in degrees.
    ///
    /// Computed as `atan2(|a×b|, a·b)` (DESIGN.md; Murphy 2007 §4.4.3 needs
    /// e(x, y) for eq. 4.3), with `b = a + d` and `d` taken directly from the
    /// pixel difference, so `a×b = a×d` has no cancellation: identical points
    /// give exactly 0 and nearly identical points keep full relative precision.
    pub fn eccentricity_deg(&self, a_px: [f64; 2], b_px: [f64; 2]) -> f64 {
        let a = self.eye_to_point_mm(a_px);
        let d = [
            (b_px[0] - a_px[0]) * self.pitch_x_mm,
            (b_px[1] - a_px[1]) * self.pitch_y_mm,
            0.0,
        ];
        let cross = [
            a[1] * d[2] - a[2] * d[1],
            a[2] * d[0] - a[0] * d[2],
            a[0] * d[1] - a[1] * d[0],
        ];
        let dot = a[0] * (a[0] + d[0]) + a[1] * (a[1] + d[1]) + a[2] * (a[2] + d[2]);
        norm3(cross).atan2(dot).to_degrees()
    }

    /// Conservative local pixels per degree at `p_px`: the fewest pixels per
    /// degree over all directions on the screen at that point.
    ///
    /// A step of one pixel perpendicular to the line of sight subtends
    /// `pitch / R` radians (R = eye-to-point distance); a step along the
    /// oblique direction subtends less (`pitch·cosθ / R`). Using the larger
    /// angle per pixel means a spacing converted with this value never exceeds
    /// its angular bound in any direction.
    pub fn local_ppd(&self, p_px: [f64; 2]) -> f64 {
        self.eye_distance_to_mm(p_px) / self.max_pitch_mm() * std::f64::consts::PI / 180.0
    }

    /// Screen centre in pixels.
    pub fn centre_px(&self) -> [f64; 2] {
        let [w, h] = self.size_px();
        [w / 2.0, h / 2.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn dissertation_display() -> Display {
        Display::seed_17in(1280, 1024)
    }

    #[test]
    fn eccentricity_along_the_axis_is_the_arctangent() {
        let g = dissertation_display().geometry().unwrap();
        let c = g.centre_px();
        let p = [c[0] + 100.0, c[1]];
        let expected = (100.0 * g.pitch_x_mm / 540.0_f64).atan().to_degrees();
        assert!((g.eccentricity_deg(c, p) - expected).abs() < 1e-12);
    }

    #[test]
    fn zero_pixels_are_rejected_with_the_field_named() {
        let mut d = dissertation_display();
        d.resolution_px.1 = 0;
        assert_eq!(d.geometry().unwrap_err().field, "resolution_px.1");
        let mut d = dissertation_display();
        d.size_mm.0 = f64::NAN;
        assert_eq!(d.geometry().unwrap_err().field, "size_mm.0");
    }

    #[test]
    fn resolution_limits_hold_for_each_side_and_the_product() {
        let with = |w: u32, h: u32| {
            let mut d = dissertation_display();
            d.resolution_px = (w, h);
            d.geometry().map(|_| ()).map_err(|e| e.field)
        };
        // 0, 1, the limit, limit + 1 and u32::MAX, for each side.
        for (side, ok) in [
            (0, false),
            (1, true),
            (MAX_SIDE_PX, true),
            (MAX_SIDE_PX + 1, false),
            (u32::MAX, false),
        ] {
            let want = |f| if ok { Ok(()) } else { Err(f) };
            assert_eq!(with(side, 1), want("resolution_px.0"), "width {side}");
            assert_eq!(with(1, side), want("resolution_px.1"), "height {side}");
        }
        assert_eq!(with(u32::MAX, u32::MAX), Err("resolution_px.0"));
        assert_eq!(with(70_000, 70_000), Err("resolution_px.0"));
        // The product: 8192² is the limit; one pixel more is refused.
        assert_eq!(u64::from(8192u32 * 8192), MAX_PIXELS);
        assert_eq!(with(8192, 8192), Ok(()));
        assert_eq!(with(MAX_SIDE_PX, 4096), Ok(()));
        assert_eq!(with(8193, 8192), Err("resolution_px"));
        assert_eq!(with(MAX_SIDE_PX, 4097), Err("resolution_px"));
        assert_eq!(with(MAX_SIDE_PX, MAX_SIDE_PX), Err("resolution_px"));
        // Real panels pass.
        for (w, h) in [(1280, 1024), (1920, 1080), (3840, 2160), (7680, 4320)] {
            assert_eq!(with(w, h), Ok(()), "{w}x{h}");
        }
    }

    #[test]
    fn tiny_and_huge_values_print_in_scientific_notation() {
        let e = ParamError::new("size_mm.0", 1e-300, "x");
        assert_eq!(e.value, "1e-300");
        assert!(e.to_string().len() < 40, "{e}");
        assert_eq!(
            ParamError::new("f", -1.234_567_89e308, "x").value,
            "-1.23457e308"
        );
        assert_eq!(ParamError::new("f", 1e-308, "x").value, "1e-308");
        assert_eq!(ParamError::new("f", 337.9, "x").value, "337.9");
        assert_eq!(ParamError::new("f", 0.0001, "x").value, "0.0001");
        assert_eq!(ParamError::new("f", f64::NAN, "x").value, "NaN");
        assert_eq!(ParamError::new("f", u32::MAX, "x").value, "4294967295");
        assert_eq!(ParamError::new("f", "(1, 2)", "x").value, "(1, 2)");
        assert_eq!(fmt_f64(2.5e9), "2.5e9");
        assert_eq!(fmt_f64(1e9), "1e9");
        assert_eq!(fmt_f64(999_999_999.5), "999999999.5");
    }

    #[test]
    fn ppd_at_the_centre_matches_the_small_angle_formula() {
        let g = dissertation_display().geometry().unwrap();
        let ppd = g.local_ppd(g.centre_px());
        let expected = 540.0 / g.max_pitch_mm() * std::f64::consts::PI / 180.0;
        assert!((ppd - expected).abs() < 1e-9, "{ppd} vs {expected}");
        // The dissertation's set-up: about 37 px/deg at the centre.
        assert!((35.0..40.0).contains(&ppd));
    }
}

/// The README's examples, compiled and run as doc-tests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
