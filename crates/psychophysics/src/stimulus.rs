//! Gabor patches: a sinusoidal grating in a Gaussian window, on a grey
//! background, rendered to 8-bit levels with spatial dithering.
//!
//! # Geometry
//!
//! The participant fixates the display's eye point (the screen centre unless
//! the display file says otherwise); the patch is centred on the pixel whose
//! centre lies nearest the requested eccentricity along the horizontal
//! meridian, to the right of fixation. Degrees become pixels with the
//! `screen-geometry` crate at the patch's centre: the pixels per degree
//! along the grating's modulation direction is `1 / eccentricity_deg(p,
//! p + û)` for a one-pixel step û, so the pitch and the oblique view at
//! that eccentricity are accounted for. That value is used across the whole
//! patch (at 10° and σ = 0.5° it changes by under 1 % over ±3σ) and for the
//! window's σ too.
//!
//! # Luminance and contrast
//!
//! The grating is in sine phase, `L(x) = L̄·(1 + C·w(x)·sin(2π f u))`, with
//! `w` the Gaussian window, `u` the distance along the modulation direction
//! and `C` the Michelson contrast in linear light (cd/m²). Sine phase makes
//! the pattern odd about the centre pixel, so the patch's mean luminance is
//! exactly the background's `L̄` at any frequency. `L̄` is the luminance of
//! an 8-bit background level, so a zero contrast renders a uniform field.
//!
//! # Dithering (spatial, random, unbiased)
//!
//! Every pixel's target luminance lies between two levels' luminances
//! `L0 ≤ L < L1`; the pixel shows the upper level with probability
//! `(L − L0)/(L1 − L0)` (seeded ChaCha8), so its *expected* luminance is the
//! target exactly, in linear light. No temporal dithering is done (a single
//! frame is shown as is).
//!
//! The contrast of a rendered patch is measured by the matched filter:
//! the least-squares amplitude of the sampled template `g = w·sin(2π f u)`
//! in `L − L̄`, divided by `L̄`; for the undithered target it is exactly `C`.
//! The dither adds independent noise of variance `ΔL²·p(1 − p) ≤ ΔL²/4` per
//! pixel, so the measured contrast is unbiased with standard deviation
//! `σ_C ≤ ΔL / (2·L̄·√Σg²)`, ΔL the luminance step at the background. That
//! bound is [`GaborPatch::smallest_contrast`]: the contrast whose
//! amplitude equals the dither noise's worst-case standard deviation, the
//! smallest contrast this scheme can show distinguishable from its own
//! noise. For a σ = 0.5° (≈ 19 px) patch at 5° on the seed 17" display,
//! background level 128 of the default γ = 2.2 curve, it is ≈ 3.6·10⁻⁴,
//! where one 8-bit step is a contrast of ≈ 1.7·10⁻² (a unit test holds
//! both figures). [`GaborPatch::dither_contrast_sd`] is the exact σ_C of
//! one render.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use screen_geometry::ScreenGeometry;
use serde::{Deserialize, Serialize};

use crate::luminance::{Transfer, TransferKind};
use crate::ParamError;

/// The largest patch side accepted, pixels.
pub const MAX_PATCH_SIDE_PX: u32 = 2049;

/// What to draw.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaborSpec {
    /// Spatial frequency, cycles per degree, > 0 and below the display's
    /// Nyquist limit at the patch (0.5 cycles per pixel).
    pub frequency_cpd: f64,
    /// Orientation of the bars, degrees; 0 = vertical bars (luminance
    /// varies along x), 90 = horizontal bars.
    pub orientation_deg: f64,
    /// Eccentricity of the patch centre, degrees, ≥ 0, right of fixation.
    pub eccentricity_deg: f64,
    /// Michelson contrast in linear light, 0..=1.
    pub contrast: f64,
    /// Standard deviation of the Gaussian window, degrees, > 0.
    pub sigma_deg: f64,
    /// The background's 8-bit level; its luminance is the patch's mean.
    pub background_level: u8,
}

/// A rendered patch: levels to display and what they show in linear light.
#[derive(Debug, Clone, PartialEq)]
pub struct GaborPatch {
    /// Side of the square patch, pixels (odd; the centre is a pixel).
    pub side_px: u32,
    /// Screen position of the centre pixel's centre.
    pub centre_px: [f64; 2],
    /// Eccentricity of that pixel centre from fixation, degrees (the
    /// requested one to within half a pixel).
    pub eccentricity_deg: f64,
    /// 8-bit levels, row-major, `side_px²` of them.
    pub levels: Vec<u8>,
    /// The luminance each level shows (cd/m²), from the transfer.
    pub luminance_cd_m2: Vec<f64>,
    /// The background luminance, the patch's intended mean (cd/m²).
    pub mean_luminance_cd_m2: f64,
    /// Pixels per degree along the modulation direction at the centre.
    pub pixels_per_degree: f64,
    /// The grating's frequency on the screen, cycles per pixel.
    pub cycles_per_pixel: f64,
    /// The window's standard deviation, pixels.
    pub sigma_px: f64,
    /// Which conversion to levels was used.
    pub transfer: TransferKind,
    /// Exact standard deviation of this render's measured contrast due to
    /// dithering (see the module doc).
    pub dither_contrast_sd: f64,
    /// Standard deviation of the patch's mean luminance due to dithering.
    pub dither_mean_sd_cd_m2: f64,
    /// The smallest contrast the dithering can show (module doc).
    pub smallest_contrast: f64,
    template: Vec<f64>,
}

fn finite(field: &'static str, v: f64, what: &str) -> Result<f64, ParamError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParamError::new(
            field,
            v,
            format!("must be finite ({what})"),
        ))
    }
}

impl GaborPatch {
    /// Renders `spec` on the display `geometry` through `transfer`,
    /// dithering with a ChaCha8 generator seeded by `dither_seed`.
    ///
    /// Errors name the field: a non-finite or out-of-range value, a
    /// frequency above the Nyquist limit at that eccentricity, a patch that
    /// does not fit on the screen or exceeds [`MAX_PATCH_SIDE_PX`], or a
    /// contrast whose peaks leave the display's luminance range.
    pub fn render(
        spec: &GaborSpec,
        geometry: &ScreenGeometry,
        transfer: &Transfer,
        dither_seed: u64,
    ) -> Result<Self, ParamError> {
        let f = finite("frequency_cpd", spec.frequency_cpd, "cycles per degree")?;
        if f <= 0.0 {
            return Err(ParamError::new("frequency_cpd", f, "must be > 0"));
        }
        let theta = finite("orientation_deg", spec.orientation_deg, "degrees")?.to_radians();
        let ecc = finite("eccentricity_deg", spec.eccentricity_deg, "degrees")?;
        if !(0.0..90.0).contains(&ecc) {
            return Err(ParamError::new(
                "eccentricity_deg",
                ecc,
                "must be in 0..90 degrees",
            ));
        }
        let c = finite("contrast", spec.contrast, "a Michelson contrast")?;
        if !(0.0..=1.0).contains(&c) {
            return Err(ParamError::new(
                "contrast",
                c,
                "must be a Michelson contrast in 0..=1",
            ));
        }
        let sigma_deg = finite("sigma_deg", spec.sigma_deg, "degrees")?;
        if sigma_deg <= 0.0 {
            return Err(ParamError::new("sigma_deg", sigma_deg, "must be > 0"));
        }

        // Centre: the pixel centre nearest the eccentricity, right of the eye point.
        let eye = geometry.eye_point_px;
        let dx_px = geometry.eye_distance_mm * ecc.to_radians().tan() / geometry.pitch_x_mm;
        let cx = ((eye[0] + dx_px) - 0.5).round() + 0.5;
        let cy = (eye[1] - 0.5).round() + 0.5;
        let centre = [cx, cy];
        let (dir_x, dir_y) = (theta.cos(), theta.sin());
        let deg_per_px = geometry.eccentricity_deg(centre, [cx + dir_x, cy + dir_y]);
        let ppd = 1.0 / deg_per_px;
        let cpp = f / ppd;
        if cpp.is_nan() || cpp >= 0.5 {
            return Err(ParamError::new(
                "frequency_cpd",
                f,
                format!(
                    "is above the display's Nyquist limit at {ecc}° ({:.3} cpd, \
                     0.5 cycles per pixel at {ppd:.2} pixels/degree)",
                    0.5 * ppd
                ),
            ));
        }
        let sigma_px = sigma_deg * ppd;
        let half = (3.0 * sigma_px).ceil();
        if !(sigma_px >= 0.5 && 2.0 * half < f64::from(MAX_PATCH_SIDE_PX)) {
            return Err(ParamError::new(
                "sigma_deg",
                sigma_deg,
                format!(
                    "gives a window σ of {sigma_px:.3} px; needs 0.5 px ≤ σ and a patch \
                     (±3σ) of at most {MAX_PATCH_SIDE_PX} px"
                ),
            ));
        }
        let [w, h] = geometry.size_px();
        if cx - half - 0.5 < 0.0
            || cx + half + 0.5 > w
            || cy - half - 0.5 < 0.0
            || cy + half + 0.5 > h
        {
            return Err(ParamError::new(
                "eccentricity_deg",
                ecc,
                format!(
                    "puts the {side} px patch (±3σ) off the {w}×{h} px screen",
                    side = 2.0 * half + 1.0
                ),
            ));
        }
        let ecc_actual = geometry.eccentricity_deg(eye, centre);

        let bg = spec.background_level;
        let l_mean = transfer.luminance(bg);
        let (l_min, l_max) = (transfer.luminance(0), transfer.luminance(255));
        if l_mean * (1.0 + c) > l_max || l_mean * (1.0 - c) < l_min {
            let c_max = ((l_max - l_mean) / l_mean).min((l_mean - l_min) / l_mean);
            return Err(ParamError::new(
                "contrast",
                c,
                format!(
                    "peaks leave the display's range {l_min}–{l_max} cd/m² around the \
                     background level {bg} ({l_mean} cd/m²); at most {c_max:.4}"
                ),
            ));
        }

        let n = 2 * half as usize + 1;
        let mut rng = ChaCha8Rng::seed_from_u64(dither_seed);
        let mut levels = Vec::with_capacity(n * n);
        let mut luminance = Vec::with_capacity(n * n);
        let mut template = Vec::with_capacity(n * n);
        let (mut var_sum, mut var_g2, mut g2) = (0.0, 0.0, 0.0);
        let two_pi_f = 2.0 * std::f64::consts::PI * cpp;
        for j in 0..n {
            let dy = j as f64 - half;
            for i in 0..n {
                let dx = i as f64 - half;
                let u = dx * dir_x + dy * dir_y;
                let win = (-(dx * dx + dy * dy) / (2.0 * sigma_px * sigma_px)).exp();
                let g = win * (two_pi_f * u).sin();
                let target = l_mean * (1.0 + c * g);
                let (lo, frac) = transfer.invert(target).ok_or_else(|| {
                    ParamError::new(
                        "contrast",
                        c,
                        "a pixel's luminance left the display's range",
                    )
                })?;
                let up = rng.random::<f64>() < frac;
                let level = if up { lo + 1 } else { lo };
                let step = transfer.step_above(lo);
                let var = step * step * frac * (1.0 - frac);
                var_sum += var;
                var_g2 += var * g * g;
                g2 += g * g;
                levels.push(level);
                luminance.push(transfer.luminance(level));
                template.push(g);
            }
        }
        let step_bg = transfer
            .step_above(bg)
            .max(transfer.step_above(bg.saturating_sub(1)));
        let (dither_contrast_sd, smallest_contrast) = if g2 > 0.0 {
            (
                var_g2.sqrt() / g2 / l_mean,
                step_bg / (2.0 * l_mean * g2.sqrt()),
            )
        } else {
            (0.0, f64::INFINITY)
        };
        Ok(Self {
            side_px: n as u32,
            centre_px: centre,
            eccentricity_deg: ecc_actual,
            levels,
            luminance_cd_m2: luminance,
            mean_luminance_cd_m2: l_mean,
            pixels_per_degree: ppd,
            cycles_per_pixel: cpp,
            sigma_px,
            transfer: transfer.kind(),
            dither_contrast_sd,
            dither_mean_sd_cd_m2: var_sum.sqrt() / (n * n) as f64,
            smallest_contrast,
            template,
        })
    }

    /// Mean luminance of the rendered patch, cd/m².
    pub fn rendered_mean_cd_m2(&self) -> f64 {
        self.luminance_cd_m2.iter().sum::<f64>() / self.luminance_cd_m2.len() as f64
    }

    /// Michelson contrast measured from the rendered linear-light patch by
    /// the matched filter (module doc). 0 when the template is all zero.
    pub fn measured_contrast(&self) -> f64 {
        let l = self.mean_luminance_cd_m2;
        let (mut num, mut den) = (0.0, 0.0);
        for (lum, g) in self.luminance_cd_m2.iter().zip(&self.template) {
            num += (lum - l) * g;
            den += g * g;
        }
        if den > 0.0 {
            num / den / l
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::luminance::{GammaCurve, LuminanceTable};
    use proptest::prelude::*;
    use screen_geometry::Display;

    fn setup() -> (ScreenGeometry, Transfer) {
        let g = Display::seed_17in(1280, 1024).geometry().unwrap();
        (g, Transfer::gamma(GammaCurve::default()).unwrap())
    }

    fn spec() -> GaborSpec {
        GaborSpec {
            frequency_cpd: 2.0,
            orientation_deg: 0.0,
            eccentricity_deg: 5.0,
            contrast: 0.1,
            sigma_deg: 0.5,
            background_level: 128,
        }
    }

    #[test]
    fn geometry_puts_the_patch_at_its_eccentricity() {
        let (g, t) = setup();
        let p = GaborPatch::render(&spec(), &g, &t, 1).unwrap();
        assert!(
            (p.eccentricity_deg - 5.0).abs() < 0.05,
            "{}",
            p.eccentricity_deg
        );
        assert_eq!(p.side_px % 2, 1);
        assert!((p.cycles_per_pixel * p.pixels_per_degree - 2.0).abs() < 1e-12);
        assert_eq!(p.transfer, TransferKind::Gamma(2.2));
        // About 37 px per degree on the seed display at 540 mm.
        assert!(
            (35.0..40.0).contains(&p.pixels_per_degree),
            "{}",
            p.pixels_per_degree
        );
    }

    #[test]
    fn smallest_contrast_is_tiny_but_positive() {
        let (g, t) = setup();
        let p = GaborPatch::render(&spec(), &g, &t, 1).unwrap();
        assert!(
            (3.0e-4..4.5e-4).contains(&p.smallest_contrast),
            "{}",
            p.smallest_contrast
        );
        let one_step = t.step_above(128) / t.luminance(128);
        assert!((0.015..0.019).contains(&one_step), "{one_step}");
        assert!(p.dither_contrast_sd <= p.smallest_contrast * 1.000001);
    }

    #[test]
    fn bad_inputs_are_named() {
        let (g, t) = setup();
        let field = |s: GaborSpec| GaborPatch::render(&s, &g, &t, 0).unwrap_err().field;
        assert_eq!(
            field(GaborSpec {
                frequency_cpd: f64::NAN,
                ..spec()
            }),
            "frequency_cpd"
        );
        assert_eq!(
            field(GaborSpec {
                frequency_cpd: 1e9,
                ..spec()
            }),
            "frequency_cpd"
        );
        assert_eq!(
            field(GaborSpec {
                contrast: 1.5,
                ..spec()
            }),
            "contrast"
        );
        assert_eq!(
            field(GaborSpec {
                contrast: f64::NAN,
                ..spec()
            }),
            "contrast"
        );
        assert_eq!(
            field(GaborSpec {
                eccentricity_deg: 60.0,
                ..spec()
            }),
            "eccentricity_deg"
        );
        assert_eq!(
            field(GaborSpec {
                eccentricity_deg: f64::INFINITY,
                ..spec()
            }),
            "eccentricity_deg"
        );
        assert_eq!(
            field(GaborSpec {
                sigma_deg: 1e300,
                ..spec()
            }),
            "sigma_deg"
        );
        assert_eq!(
            field(GaborSpec {
                orientation_deg: f64::NAN,
                ..spec()
            }),
            "orientation_deg"
        );
        // Full contrast around a dark background cannot be shown.
        let e = GaborPatch::render(
            &GaborSpec {
                contrast: 1.0,
                background_level: 200,
                ..spec()
            },
            &g,
            &t,
            0,
        )
        .unwrap_err();
        assert!(e.reason.contains("at most"), "{e}");
    }

    #[test]
    fn a_photometer_table_is_used_and_reported() {
        let (g, _) = setup();
        // A display measured at five levels (cd/m²).
        let table = LuminanceTable::new(
            vec![0, 64, 128, 192, 255],
            vec![0.4, 6.0, 24.0, 58.0, 110.0],
        )
        .unwrap();
        let t = Transfer::measured(&table);
        let p = GaborPatch::render(&spec(), &g, &t, 5).unwrap();
        assert_eq!(p.transfer, TransferKind::Measured);
        assert_eq!(p.mean_luminance_cd_m2, 24.0);
        assert!((p.measured_contrast() - 0.1).abs() <= 6.0 * p.dither_contrast_sd);
        // The highest contrast the transfer allows renders.
        for bg in [40u8, 128, 250] {
            let c = t.max_contrast(bg);
            let s = GaborSpec {
                contrast: c,
                background_level: bg,
                ..spec()
            };
            GaborPatch::render(&s, &g, &t, 1).unwrap();
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(48)))]

        #[test]
        fn mean_and_contrast_survive_dithering(
            f in 0.5f64..8.0,
            o in 0.0f64..180.0,
            e in 0.0f64..10.0,
            c in 0.0f64..0.5,
            bg in 90u8..170,
            seed: u64,
        ) {
            let (g, t) = setup();
            let s = GaborSpec { frequency_cpd: f, orientation_deg: o, eccentricity_deg: e,
                contrast: c, sigma_deg: 0.4, background_level: bg };
            let p = GaborPatch::render(&s, &g, &t, seed).unwrap();
            let l = p.mean_luminance_cd_m2;
            prop_assert!((p.rendered_mean_cd_m2() - l).abs() <= 6.0 * p.dither_mean_sd_cd_m2 + 1e-9 * l,
                "mean {} vs {l} (sd {})", p.rendered_mean_cd_m2(), p.dither_mean_sd_cd_m2);
            prop_assert!((p.measured_contrast() - c).abs() <= 6.0 * p.dither_contrast_sd + 1e-9,
                "contrast {} vs {c} (sd {})", p.measured_contrast(), p.dither_contrast_sd);
        }

        #[test]
        fn zero_contrast_is_a_uniform_field(bg: u8, o in 0.0f64..180.0, seed: u64) {
            let (g, t) = setup();
            let s = GaborSpec { contrast: 0.0, orientation_deg: o, background_level: bg, ..spec() };
            let p = GaborPatch::render(&s, &g, &t, seed).unwrap();
            prop_assert!(p.levels.iter().all(|&v| v == bg));
            prop_assert_eq!(p.measured_contrast(), 0.0);
        }

        #[test]
        fn huge_or_nan_inputs_are_rejected(x in prop_oneof![Just(f64::NAN), Just(f64::INFINITY),
            Just(f64::NEG_INFINITY), 1e6f64..1e300, -1e300f64..-1e6]) {
            let (g, t) = setup();
            for s in [GaborSpec { frequency_cpd: x, ..spec() }, GaborSpec { contrast: x, ..spec() },
                GaborSpec { eccentricity_deg: x, ..spec() }, GaborSpec { sigma_deg: x, ..spec() }] {
                let e = GaborPatch::render(&s, &g, &t, 0);
                prop_assert!(e.is_err(), "{s:?} accepted");
                let e = e.unwrap_err();
                prop_assert!(!e.reason.is_empty());
            }
        }
    }
}
