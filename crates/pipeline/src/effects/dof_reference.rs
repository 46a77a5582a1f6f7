//! Ground truth for the depth-of-field pass: thin-lens **distributed ray
//! casting** (Cook et al. 1984), on the CPU. Not a pass: tests and
//! comparisons call [`render_reference`].
//!
//! Per pixel, `N = side²` rays (default side 8, **N = 64**) leave points
//! of the pupil disc and meet at the pixel's focal point, each shaded
//! exactly as the CPU renderer shades a primary ray
//! ([`raycast::shade::ray_colour`]: the background on a miss, Blinn–Phong
//! at the closest hit, viewed from the ray's pupil point); the pixel is the
//! mean of the rays' colours, each clamped to [0, 1] as a display shows
//! it, written with the renderer's gamma table.
//!
//! - **Pupil samples**: a jittered (stratified) `side × side` grid over the
//!   unit square mapped to the disc by Shirley & Chiu's concentric map
//!   (area-preserving, so the strata stay equal-area on the disc); the
//!   jitter is a hash of the pixel, the sample and `seed`: deterministic.
//!   The disc is centred on the eye, parallel to the screen.
//! - **Focal point**: the point at eye distance `d_f` on the ray through
//!   the pixel centre (the G-buffer's depth is the eye distance, and so is
//!   the pass's focus); `d_f = inf` makes every ray parallel to it.
//! - **Pupil diameter**: the disc's diameter is chosen so that its
//!   geometric circle of confusion, seen from the eye on the screen, is
//!   exactly Lee's eq. 4.2–4.4 for every depth:
//!   `A = E·F·d_f / (d_r·(d_f − F))` (`E·F/d_r` for `d_f = inf`). (Lee's
//!   model keeps `d_r` fixed while the focus changes, so his `E` is not
//!   the diameter of a pinhole-camera aperture; with this `A` the
//!   reference and the pass blur by the same amount, and what is compared
//!   is the method, not the lens model.)

use foveation::thin_lens::EyeLens;
use raycast::ray::TriangleTest;
use raycast::shade::{ray_colour, to_rgb8_array};
use raycast::{Camera, Scene};

/// Pupil samples per axis by default: N = 64 rays per pixel.
pub const REFERENCE_SIDE: u32 = 8;

/// The pupil disc diameter (mm) whose geometric circle of confusion is
/// eq. 4.2–4.4's for `lens` focused at `focus_mm` (see the module); 0 for
/// an invalid lens. A focus at or inside the focal length is clamped just
/// beyond it, as the pass does.
pub fn equivalent_pupil_mm(lens: &EyeLens, focus_mm: f64) -> f64 {
    let (e, f, dr) = (
        lens.aperture_mm,
        lens.focal_length_mm,
        lens.retina_distance_mm,
    );
    let ok = |v: f64| v.is_finite() && v > 0.0;
    if !ok(e) || !ok(f) || !ok(dr) || focus_mm.is_nan() {
        return 0.0;
    }
    let df = focus_mm.max(f * (1.0 + 1e-9));
    if df.is_infinite() {
        e * f / dr
    } else {
        e * f * df / (dr * (df - f))
    }
}

/// Shirley & Chiu's concentric map of (`u`, `v`) ∈ [0, 1]² to the unit disc.
pub fn concentric_disc(u: f64, v: f64) -> [f64; 2] {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let q = std::f64::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, q * (b / a))
    } else {
        (b, 2.0 * q - q * (a / b))
    };
    [r * phi.cos(), r * phi.sin()]
}

/// SplitMix64: the jitter's hash.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A hash → [0, 1).
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The `side²` pupil samples of pixel `pixel` on the unit disc.
pub fn pupil_samples(side: u32, pixel: u64, seed: u64) -> Vec<[f64; 2]> {
    let side = side.max(1);
    let mut out = Vec::with_capacity((side * side) as usize);
    for j in 0..side {
        for i in 0..side {
            let h = mix(seed ^ mix(pixel ^ mix(u64::from(j * side + i))));
            let u = (f64::from(i) + unit(h)) / f64::from(side);
            let v = (f64::from(j) + unit(mix(h))) / f64::from(side);
            out.push(concentric_disc(u, v));
        }
    }
    out
}

/// The thin-lens reference frame (sRGB bytes, row-major RGB, the camera's
/// size) of `scene` seen by `lens` focused at eye distance `focus_mm`, with
/// `side²` rays per pixel (at least 1; [`REFERENCE_SIDE`] for N = 64).
/// A zero pupil casts every ray through the eye: the pinhole frame.
pub fn render_reference(
    scene: &Scene,
    camera: &Camera,
    lens: &EyeLens,
    focus_mm: f64,
    side: u32,
    seed: u64,
) -> Vec<u8> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let radius = 0.5 * equivalent_pupil_mm(lens, focus_mm);
    let focus = if focus_mm.is_nan() {
        f64::INFINITY
    } else {
        focus_mm.max(lens.focal_length_mm * (1.0 + 1e-9))
    };
    let eye = camera.eye;
    let eye = [f64::from(eye.x), f64::from(eye.y), f64::from(eye.z)];
    let mut rgb = vec![0u8; 3 * w * h];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rows_per = h.div_ceil(threads.max(1)).max(1);
    std::thread::scope(|s| {
        for (chunk, out) in rgb.chunks_mut(3 * w * rows_per).enumerate() {
            s.spawn(move || {
                for (r, row) in out.chunks_mut(3 * w).enumerate() {
                    let y = chunk * rows_per + r;
                    for x in 0..w {
                        let p = camera.screen_point([x as f32 + 0.5, y as f32 + 0.5]);
                        let d = [
                            f64::from(p.x) - eye[0],
                            f64::from(p.y) - eye[1],
                            f64::from(p.z) - eye[2],
                        ];
                        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        let u = d.map(|c| c / len);
                        let fp = u.map(|c| c * focus);
                        let mut acc = [0.0f64; 3];
                        let samples = pupil_samples(side, (y * w + x) as u64, seed);
                        for &[a, b] in &samples {
                            let off = [a * radius, b * radius, 0.0];
                            let origin = [0, 1, 2].map(|k| (eye[k] + off[k]) as f32);
                            let dir = if focus.is_finite() {
                                [0, 1, 2].map(|k| (fp[k] - off[k]) as f32)
                            } else {
                                u.map(|c| c as f32)
                            };
                            let c = ray_colour(scene, origin, dir, TriangleTest::Watertight);
                            for k in 0..3 {
                                acc[k] += f64::from(c[k].clamp(0.0, 1.0));
                            }
                        }
                        let n = samples.len().max(1) as f64;
                        let c = to_rgb8_array(acc.map(|a| (a / n) as f32));
                        row[3 * x..3 * x + 3].copy_from_slice(&c);
                    }
                }
            });
        }
    });
    rgb
}

/// PSNR (dB) of `a` against `b`, 8-bit samples: `10·log10(255² / MSE)`;
/// `inf` for identical images, NaN for different lengths or empty ones.
pub fn psnr(a: &[u8], b: &[u8]) -> f64 {
    if a.len() != b.len() || a.is_empty() {
        return f64::NAN;
    }
    let se: f64 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum();
    let mse = se / a.len() as f64;
    10.0 * (255.0f64 * 255.0 / mse).log10()
}
