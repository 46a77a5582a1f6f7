//! How far a foveated frame is from the full-resolution frame of the same
//! gaze: the metrics of the accuracy-versus-time sweep (`gazecast bench
//! accuracy`).
//!
//! - **PSNR** over the screen: `10·log10(255² / MSE)`, the MSE taken over
//!   every colour channel of every pixel (8-bit values). ∞ for identical
//!   images.
//! - **PSNR within r°** of the gaze (r = 2, 5, 10): the same over the pixels
//!   whose centre is at most r degrees of visual angle from the point of
//!   regard. `None` when no pixel is that close (a gaze far off the screen).
//! - **Foveated PSNR**: the PSNR of a visibility-weighted MSE,
//!   `FMSE = Σ w(p)·e²(p) / Σ w(p)`, where `e²(p)` is the pixel's squared
//!   error (mean over channels) and `w(p)` is the fraction of the spatial
//!   frequencies the display can show at `p` that the eye can see there:
//!   `w(p) = min(1, f_c(e(p)) / f_N(p))`, with `f_c` the Geisler–Perry
//!   cut-off at full contrast (Murphy 2007 eq. 4.3, C = 1) at the pixel's
//!   eccentricity `e(p)` and `f_N(p) = ppd(p)/2` the display's Nyquist
//!   frequency there (conservative local pixels per degree). `w = 1` where
//!   the eye resolves single pixels (the fovea on ordinary monitors) and
//!   falls with eccentricity as the eye loses the high frequencies, so the
//!   same error costs less in the periphery than at the gaze. An error spread
//!   evenly over the screen gives the plain PSNR back.
//! - **Silhouette error**: the fraction of pixels whose hit/miss (geometry or
//!   background) differs from the reference.
//!
//! Errors are kept as sums ([`ErrorSum`]) so that results of several gazes
//! merge into one mean (PSNR of the mean MSE, not a mean of dB values, which
//! would be ∞ as soon as one gaze is exact).

use rayon::prelude::*;

use crate::csf::GeislerPerry;
use crate::display::ScreenGeometry;
use crate::error::ParamError;

/// Radii (degrees) of the regions around the gaze with their own PSNR.
pub const REGION_RADII_DEG: [f64; 3] = [2.0, 5.0, 10.0];

/// A sum of squared 8-bit errors and the (possibly weighted) number of
/// values it was taken over.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorSum {
    /// Sum of squared errors (8-bit units²), weighted.
    pub squared: f64,
    /// Number of values summed, or the sum of their weights.
    pub weight: f64,
}

impl ErrorSum {
    fn add(&mut self, squared: f64, weight: f64) {
        self.squared += squared;
        self.weight += weight;
    }

    fn merge(&mut self, o: &ErrorSum) {
        self.add(o.squared, o.weight);
    }

    /// Mean squared error; `None` when nothing was counted.
    pub fn mse(&self) -> Option<f64> {
        (self.weight > 0.0).then(|| self.squared / self.weight)
    }

    /// PSNR in dB; `None` when nothing was counted, ∞ when exact.
    pub fn psnr_db(&self) -> Option<f64> {
        self.mse().map(psnr_db)
    }
}

/// PSNR (dB) of a mean squared error of 8-bit values: in `[0, ∞]` for
/// `mse ∈ [0, 255²]`; ∞ for 0.
pub fn psnr_db(mse: f64) -> f64 {
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0 * 255.0 / mse).log10()
    }
}

/// Error of one frame (or of several merged frames) against its reference.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Quality {
    /// Every pixel of the screen.
    pub screen: ErrorSum,
    /// Pixels within [`REGION_RADII_DEG`] of the gaze.
    pub within: [ErrorSum; 3],
    /// Visibility-weighted (see the module doc).
    pub foveated: ErrorSum,
    /// Pixels whose hit/miss differs from the reference.
    pub hit_mismatch: u64,
    /// Pixels compared.
    pub pixels: u64,
}

impl Quality {
    /// Adds another frame's sums (the mean over gazes).
    pub fn merge(&mut self, o: &Quality) {
        self.screen.merge(&o.screen);
        for (a, b) in self.within.iter_mut().zip(&o.within) {
            a.merge(b);
        }
        self.foveated.merge(&o.foveated);
        self.hit_mismatch += o.hit_mismatch;
        self.pixels += o.pixels;
    }

    /// Fraction of pixels whose hit/miss differs; `None` for no pixels.
    pub fn silhouette_error(&self) -> Option<f64> {
        (self.pixels > 0).then(|| self.hit_mismatch as f64 / self.pixels as f64)
    }
}

/// An 8-bit RGB image with its per-pixel hit/miss.
#[derive(Debug, Clone, Copy)]
pub struct Image<'a> {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Colour, 3 bytes (R, G, B) per pixel, rows top to bottom.
    pub rgb: &'a [u8],
    /// Whether each pixel's ray hit a surface, same order as `rgb`.
    pub hit: &'a [bool],
}

impl Image<'_> {
    fn check(&self, field: &'static str) -> Result<usize, ParamError> {
        let n = self.width as usize * self.height as usize;
        if self.rgb.len() != 3 * n || self.hit.len() != n {
            return Err(ParamError::new(
                field,
                format!(
                    "{}x{} with {} bytes, {} hit flags",
                    self.width,
                    self.height,
                    self.rgb.len(),
                    self.hit.len()
                ),
                "needs 3 bytes and one hit flag per pixel",
            ));
        }
        Ok(n)
    }
}

/// Visibility weight `w(p)` of the module doc: the fraction of the display's
/// frequency band at `p_px` that the eye sees with the gaze at `gaze_px`.
/// In `[0, 1]`; NaN only for NaN input.
pub fn visibility(
    geometry: &ScreenGeometry,
    csf: &GeislerPerry,
    gaze_px: [f64; 2],
    p_px: [f64; 2],
) -> f64 {
    weight(
        geometry,
        csf,
        geometry.eccentricity_deg(gaze_px, p_px),
        p_px,
    )
}

/// `w(p)` for a pixel at eccentricity `e_deg`.
fn weight(geometry: &ScreenGeometry, csf: &GeislerPerry, e_deg: f64, p_px: [f64; 2]) -> f64 {
    let nyquist_cpd = geometry.local_ppd(p_px) / 2.0;
    (csf.cutoff_frequency_cpd(1.0, e_deg) / nyquist_cpd).clamp(0.0, 1.0)
}

/// What each pixel contributes for one gaze: its eccentricity and its
/// visibility weight. Depends on the display and the gaze only, so a sweep
/// computes it once per gaze and compares every configuration against it.
#[derive(Debug, Clone)]
pub struct GazeWeights {
    width: u32,
    height: u32,
    eccentricity_deg: Vec<f32>,
    visibility: Vec<f32>,
}

impl GazeWeights {
    /// For the gaze `gaze_px` (finite, anywhere, also off the screen).
    pub fn new(
        geometry: &ScreenGeometry,
        csf: &GeislerPerry,
        gaze_px: [f64; 2],
    ) -> Result<Self, ParamError> {
        csf.validate()?;
        if !(gaze_px[0].is_finite() && gaze_px[1].is_finite()) {
            return Err(ParamError::new(
                "gaze_px",
                format!("{gaze_px:?}"),
                "must be finite",
            ));
        }
        let (w, h) = (geometry.width_px as usize, geometry.height_px as usize);
        let per_pixel: Vec<(f32, f32)> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let p = [(i % w) as f64 + 0.5, (i / w) as f64 + 0.5];
                let e = geometry.eccentricity_deg(gaze_px, p);
                (e as f32, weight(geometry, csf, e, p) as f32)
            })
            .collect();
        let (eccentricity_deg, visibility) = per_pixel.into_iter().unzip();
        Ok(Self {
            width: geometry.width_px,
            height: geometry.height_px,
            eccentricity_deg,
            visibility,
        })
    }
}

/// Compares `test` with `reference` (same size; the geometry's size) for the
/// gaze `gaze_px` (finite, anywhere, also off the screen).
pub fn compare(
    geometry: &ScreenGeometry,
    csf: &GeislerPerry,
    gaze_px: [f64; 2],
    reference: &Image,
    test: &Image,
) -> Result<Quality, ParamError> {
    compare_with(&GazeWeights::new(geometry, csf, gaze_px)?, reference, test)
}

/// [`compare`] with the per-gaze weights computed beforehand.
pub fn compare_with(
    weights: &GazeWeights,
    reference: &Image,
    test: &Image,
) -> Result<Quality, ParamError> {
    let n = reference.check("reference")?;
    test.check("test")?;
    if (reference.width, reference.height) != (test.width, test.height)
        || (reference.width, reference.height) != (weights.width, weights.height)
    {
        return Err(ParamError::new(
            "test",
            format!("{}x{}", test.width, test.height),
            format!(
                "reference is {}x{} and the display {}x{}: all three must agree",
                reference.width, reference.height, weights.width, weights.height
            ),
        ));
    }
    let w = reference.width as usize;
    if n == 0 {
        return Ok(Quality::default());
    }
    let rows = (0..reference.height as usize).into_par_iter().map(|y| {
        let mut q = Quality::default();
        for i in y * w..(y + 1) * w {
            let sq: f64 = (0..3)
                .map(|c| {
                    let d = f64::from(reference.rgb[3 * i + c]) - f64::from(test.rgb[3 * i + c]);
                    d * d
                })
                .sum();
            let e = f64::from(weights.eccentricity_deg[i]);
            q.screen.add(sq, 3.0);
            for (r, sum) in REGION_RADII_DEG.iter().zip(&mut q.within) {
                if e <= *r {
                    sum.add(sq, 3.0);
                }
            }
            let v = f64::from(weights.visibility[i]);
            q.foveated.add(v * sq / 3.0, v);
            q.hit_mismatch += u64::from(reference.hit[i] != test.hit[i]);
            q.pixels += 1;
        }
        q
    });
    Ok(rows.reduce(Quality::default, |mut a, b| {
        a.merge(&b);
        a
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::display::Display;
    use proptest::prelude::*;

    fn geometry(w: u32, h: u32) -> ScreenGeometry {
        // The seed's 17" panel, shrunk in pixels but not in millimetres.
        Display {
            eye_distance_mm: 600.0,
            ..Display::seed_17in(w, h)
        }
        .geometry()
        .expect("valid display")
    }

    fn image<'a>(w: u32, h: u32, rgb: &'a [u8], hit: &'a [bool]) -> Image<'a> {
        Image {
            width: w,
            height: h,
            rgb,
            hit,
        }
    }

    #[test]
    fn identical_images_are_exact() {
        let g = geometry(64, 48);
        let rgb: Vec<u8> = (0..64 * 48 * 3).map(|i| (i * 7 % 251) as u8).collect();
        let hit = vec![true; 64 * 48];
        let a = image(64, 48, &rgb, &hit);
        let q = compare(&g, &GeislerPerry::default(), [32.0, 24.0], &a, &a).expect("same size");
        assert_eq!(q.screen.psnr_db(), Some(f64::INFINITY));
        assert_eq!(q.foveated.psnr_db(), Some(f64::INFINITY));
        assert!(q.within.iter().all(|s| s.psnr_db() == Some(f64::INFINITY)));
        assert_eq!(q.silhouette_error(), Some(0.0));
    }

    #[test]
    fn a_uniform_offset_has_the_textbook_psnr_everywhere() {
        let g = geometry(40, 30);
        let a = vec![100u8; 40 * 30 * 3];
        let b = vec![110u8; 40 * 30 * 3];
        let hit = vec![false; 40 * 30];
        let q = compare(
            &g,
            &GeislerPerry::default(),
            [5.0, 5.0],
            &image(40, 30, &a, &hit),
            &image(40, 30, &b, &hit),
        )
        .expect("same size");
        let want = 20.0 * (255.0f64 / 10.0).log10();
        for got in [
            q.screen.psnr_db(),
            q.foveated.psnr_db(),
            q.within[0].psnr_db(),
        ] {
            assert!(
                (got.expect("pixels") - want).abs() < 1e-9,
                "{got:?} vs {want}"
            );
        }
    }

    #[test]
    fn a_known_blur_has_its_computed_psnr() {
        // Vertical 1-px stripes 0/255, blurred by a 2-tap box (with wrap):
        // every pixel becomes 128 (127.5 rounded up), so the errors are 128
        // and 127 on alternate columns.
        let (w, h) = (32u32, 16u32);
        let sharp: Vec<u8> = (0..w * h)
            .flat_map(|i| [if i % 2 == 0 { 0u8 } else { 255 }; 3])
            .collect();
        let blurred: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                let (x, y) = (i % w, i / w);
                let a = u32::from(sharp[3 * (y * w + x) as usize]);
                let b = u32::from(sharp[3 * (y * w + (x + 1) % w) as usize]);
                [(a + b).div_ceil(2) as u8; 3]
            })
            .collect();
        let hit = vec![true; (w * h) as usize];
        let q = compare(
            &geometry(w, h),
            &GeislerPerry::default(),
            [0.0, 0.0],
            &image(w, h, &sharp, &hit),
            &image(w, h, &blurred, &hit),
        )
        .expect("same size");
        let mse = (128.0f64 * 128.0 + 127.0 * 127.0) / 2.0;
        let got = q.screen.psnr_db().expect("pixels");
        assert!((got - psnr_db(mse)).abs() < 1e-9, "{got}");
        assert!((got - 6.0205).abs() < 1e-4, "{got}");
    }

    #[test]
    fn the_foveated_metric_ranks_a_peripheral_error_as_less_visible() {
        let (w, h) = (400u32, 320u32);
        let g = geometry(w, h);
        let gaze = [40.0, 40.0];
        let reference = vec![80u8; (w * h * 3) as usize];
        let hit = vec![true; (w * h) as usize];
        // The same 10×10 block of error, at the gaze or in the far corner.
        let spoil = |cx: u32, cy: u32| {
            let mut v = reference.clone();
            for y in cy - 5..cy + 5 {
                for x in cx - 5..cx + 5 {
                    let i = 3 * (y * w + x) as usize;
                    v[i..i + 3].copy_from_slice(&[200, 10, 10]);
                }
            }
            v
        };
        let (at_gaze, far) = (spoil(40, 40), spoil(390, 310));
        let csf = GeislerPerry::default();
        let r = image(w, h, &reference, &hit);
        let qa = compare(&g, &csf, gaze, &r, &image(w, h, &at_gaze, &hit)).expect("size");
        let qb = compare(&g, &csf, gaze, &r, &image(w, h, &far, &hit)).expect("size");
        assert_eq!(
            qa.screen.psnr_db(),
            qb.screen.psnr_db(),
            "plain PSNR is blind to where"
        );
        let (fa, fb) = (
            qa.foveated.psnr_db().expect("pixels"),
            qb.foveated.psnr_db().expect("pixels"),
        );
        assert!(fb > fa + 3.0, "peripheral error {fb} dB vs foveal {fa} dB");
        assert!(qa.within[0].psnr_db().expect("pixels").is_finite());
        assert_eq!(qb.within[0].psnr_db(), Some(f64::INFINITY));
    }

    #[test]
    fn visibility_is_one_at_the_gaze_and_falls_with_eccentricity() {
        let g = geometry(1280, 1024);
        let csf = GeislerPerry::default();
        let gaze = [640.0, 512.0];
        assert_eq!(visibility(&g, &csf, gaze, gaze), 1.0);
        let mut last = 1.0;
        for x in (640..1280).step_by(40) {
            let v = visibility(&g, &csf, gaze, [f64::from(x), 512.0]);
            assert!(v <= last + 1e-12 && v > 0.0, "{x}: {v}");
            last = v;
        }
        assert!(last < 0.5, "at the screen edge {last}");
    }

    #[test]
    fn bad_input_is_an_error_not_nan() {
        let g = geometry(8, 8);
        let rgb = vec![0u8; 8 * 8 * 3];
        let hit = vec![false; 64];
        let ok = image(8, 8, &rgb, &hit);
        let short = image(8, 8, &rgb[..10], &hit);
        let csf = GeislerPerry::default();
        assert!(compare(&g, &csf, [0.0, 0.0], &ok, &short).is_err());
        assert!(compare(&g, &csf, [f64::NAN, 0.0], &ok, &ok).is_err());
        assert!(compare(&g, &csf, [0.0, f64::INFINITY], &ok, &ok).is_err());
        let other = geometry(8, 9);
        assert!(compare(&other, &csf, [0.0, 0.0], &ok, &ok).is_err());
        assert_eq!(ErrorSum::default().psnr_db(), None);
        assert_eq!(Quality::default().silhouette_error(), None);
    }

    #[test]
    fn merged_sums_are_the_mean_over_frames() {
        let mut a = Quality::default();
        a.screen.add(300.0, 3.0); // MSE 100
        let mut b = Quality::default();
        b.screen.add(0.0, 3.0); // exact
        a.merge(&b);
        assert_eq!(a.screen.mse(), Some(50.0));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

        /// Random images, sizes and gazes (far off the screen, tiny screens):
        /// every figure is in range and never NaN.
        #[test]
        fn metrics_stay_in_range(
            w in 1u32..24, h in 1u32..24,
            seed in any::<u64>(),
            gx in prop_oneof![-1e7f64..1e7, -50.0f64..50.0, Just(0.0)],
            gy in prop_oneof![-1e7f64..1e7, -50.0f64..50.0, Just(0.0)],
        ) {
            let g = geometry(w, h);
            let n = (w * h) as usize;
            let mut s = seed | 1;
            let mut next = || { s ^= s << 13; s ^= s >> 7; s ^= s << 17; s };
            let a: Vec<u8> = (0..3 * n).map(|_| next() as u8).collect();
            let b: Vec<u8> = (0..3 * n).map(|_| next() as u8).collect();
            let ha: Vec<bool> = (0..n).map(|_| next() % 2 == 0).collect();
            let hb: Vec<bool> = (0..n).map(|_| next() % 2 == 0).collect();
            let q = compare(&g, &GeislerPerry::default(), [gx, gy],
                &image(w, h, &a, &ha), &image(w, h, &b, &hb)).expect("valid");
            let sums = [q.screen, q.foveated, q.within[0], q.within[1], q.within[2]];
            for s in sums {
                if let Some(p) = s.psnr_db() {
                    prop_assert!(p >= 0.0 && !p.is_nan(), "{p}");
                }
            }
            prop_assert!(q.screen.psnr_db().is_some());
            let e = q.silhouette_error().expect("pixels");
            prop_assert!((0.0..=1.0).contains(&e));
            // A visible pixel always exists on a non-empty screen: the weight
            // is positive at any finite eccentricity.
            prop_assert!(q.foveated.weight > 0.0);
        }
    }
}
