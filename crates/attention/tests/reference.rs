//! The pyramid and the centre–surround maps against a straightforward f64
//! implementation written from the definitions (Lee §3.1.1, eq. 3.4):
//! naive loops, no separable passes, no precomputed taps, libm atan2.
//! Tolerance: 1e-5 absolute for pyramids and scalar contrast (f32 against
//! f64 on values in [0, 1]); 1e-4 for hue contrast (the crate's polynomial
//! atan2 is within 2e-5 rad, divided by π, plus f32 rounding).

use attention::contrast::{CentreSurround, CENTRE_SURROUND_PAIRS};
use attention::pyramid::{Pyramid, PYRAMID_LEVELS};
use attention::synthetic::SplitMix64;

const TAPS: [f64; 4] = [1.0 / 8.0, 3.0 / 8.0, 3.0 / 8.0, 1.0 / 8.0];

#[derive(Clone, Debug)]
struct RefLevel {
    data: Vec<f64>,
    w: usize,
    h: usize,
}

impl RefLevel {
    fn at(&self, x: isize, y: isize) -> f64 {
        let x = x.clamp(0, self.w as isize - 1) as usize;
        let y = y.clamp(0, self.h as isize - 1) as usize;
        self.data[y * self.w + x]
    }
}

/// Level l+1 texel (x, y) = Σ_{i,j} k_i k_j · level_l(2x − 1 + i, 2y − 1 + j), clamped.
fn ref_downsample(src: &RefLevel) -> RefLevel {
    let w = src.w.div_ceil(2).max(1);
    let h = src.h.div_ceil(2).max(1);
    let mut data = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for (j, kj) in TAPS.iter().enumerate() {
                for (i, ki) in TAPS.iter().enumerate() {
                    sum += ki
                        * kj
                        * src.at(
                            2 * x as isize - 1 + i as isize,
                            2 * y as isize - 1 + j as isize,
                        );
                }
            }
            data[y * w + x] = sum;
        }
    }
    RefLevel { data, w, h }
}

fn ref_pyramid(base: &[f32], w: usize, h: usize) -> Vec<RefLevel> {
    let mut levels = vec![RefLevel {
        data: base.iter().map(|&v| f64::from(v)).collect(),
        w,
        h,
    }];
    for _ in 1..PYRAMID_LEVELS {
        let next = ref_downsample(levels.last().expect("level 0 exists"));
        levels.push(next);
    }
    levels
}

/// A texture lookup with bilinear magnification and clamp-to-edge, at the
/// centre of level-0 pixel (x, y).
fn ref_sample(level: &RefLevel, x: usize, y: usize, w0: usize, h0: usize) -> f64 {
    let u = ((x as f64 + 0.5) * level.w as f64 / w0 as f64 - 0.5).clamp(0.0, level.w as f64 - 1.0);
    let v = ((y as f64 + 0.5) * level.h as f64 / h0 as f64 - 0.5).clamp(0.0, level.h as f64 - 1.0);
    let (x0, y0) = (u.floor(), v.floor());
    let (fx, fy) = (u - x0, v - y0);
    let (x0, y0) = (x0 as isize, y0 as isize);
    let a = level.at(x0, y0) * (1.0 - fx) + level.at(x0 + 1, y0) * fx;
    let b = level.at(x0, y0 + 1) * (1.0 - fx) + level.at(x0 + 1, y0 + 1) * fx;
    a * (1.0 - fy) + b * fy
}

fn ref_scalar_contrast(levels: &[RefLevel]) -> Vec<f64> {
    let (w, h) = (levels[0].w, levels[0].h);
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for &(c, s) in &CENTRE_SURROUND_PAIRS {
                sum +=
                    (ref_sample(&levels[c], x, y, w, h) - ref_sample(&levels[s], x, y, w, h)).abs();
            }
            out[y * w + x] = sum / 6.0;
        }
    }
    out
}

fn ref_hue_contrast(lx: &[RefLevel], ly: &[RefLevel]) -> Vec<f64> {
    let (w, h) = (lx[0].w, lx[0].h);
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for &(c, s) in &CENTRE_SURROUND_PAIRS {
                let a = [
                    ref_sample(&lx[c], x, y, w, h),
                    ref_sample(&ly[c], x, y, w, h),
                ];
                let b = [
                    ref_sample(&lx[s], x, y, w, h),
                    ref_sample(&ly[s], x, y, w, h),
                ];
                let (la, lb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
                let weight = la.min(lb);
                if weight > 1e-12 {
                    let angle = (a[0] * b[1] - a[1] * b[0])
                        .abs()
                        .atan2(a[0] * b[0] + a[1] * b[1]);
                    sum += weight * angle / std::f64::consts::PI;
                }
            }
            out[y * w + x] = sum / 6.0;
        }
    }
    out
}

fn random_map(rng: &mut SplitMix64, w: usize, h: usize) -> Vec<f32> {
    // Smooth blobs plus noise, so that every scale has structure.
    let blobs: Vec<[f32; 4]> = (0..6)
        .map(|_| {
            [
                rng.range(0.0, w as f32),
                rng.range(0.0, h as f32),
                rng.range(2.0, 20.0),
                rng.unit(),
            ]
        })
        .collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let mut v = 0.3 * rng.unit();
            for b in &blobs {
                let d2 = (x - b[0]).powi(2) + (y - b[1]).powi(2);
                v += b[3] * (-d2 / (b[2] * b[2])).exp();
            }
            v.min(1.0)
        })
        .collect()
}

fn max_abs_diff(a: &[f32], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(&a, &b)| (f64::from(a) - b).abs())
        .fold(0.0, f64::max)
}

const SIZES: [(usize, usize); 4] = [(64, 64), (128, 128), (100, 64), (65, 97)];

#[test]
fn pyramid_levels_match_the_naive_reference() {
    let mut rng = SplitMix64::new(1);
    for (w, h) in SIZES {
        let base = random_map(&mut rng, w, h);
        let pyramid = Pyramid::from_base(&base, w, h).expect("valid base");
        let reference = ref_pyramid(&base, w, h);
        for (l, r) in reference.iter().enumerate() {
            let level = pyramid.level(l);
            assert_eq!(
                (level.width, level.height),
                (r.w, r.h),
                "level {l} size at {w}x{h}"
            );
            let err = max_abs_diff(level.data, &r.data);
            assert!(err < 1e-5, "level {l} of {w}x{h}: max error {err}");
        }
    }
}

#[test]
fn scalar_centre_surround_matches_the_naive_reference() {
    let mut rng = SplitMix64::new(2);
    let mut cs = CentreSurround::new();
    for (w, h) in SIZES {
        let base = random_map(&mut rng, w, h);
        let pyramid = Pyramid::from_base(&base, w, h).expect("valid base");
        let mut out = vec![0.0; w * h];
        cs.scalar(&pyramid, &mut out);
        let reference = ref_scalar_contrast(&ref_pyramid(&base, w, h));
        let err = max_abs_diff(&out, &reference);
        assert!(err < 1e-5, "{w}x{h}: max error {err}");
        assert!(reference.iter().any(|&v| v > 0.01), "test map has contrast");
    }
}

#[test]
fn hue_centre_surround_matches_the_naive_reference() {
    let mut rng = SplitMix64::new(3);
    let mut cs = CentreSurround::new();
    for (w, h) in SIZES {
        // Hue vectors C·(cos h, sin h) with random hue and chroma.
        let chroma = random_map(&mut rng, w, h);
        let hue = random_map(&mut rng, w, h);
        let vx: Vec<f32> = chroma
            .iter()
            .zip(&hue)
            .map(|(c, h)| c * (h * 6.0).cos())
            .collect();
        let vy: Vec<f32> = chroma
            .iter()
            .zip(&hue)
            .map(|(c, h)| c * (h * 6.0).sin())
            .collect();
        let px = Pyramid::from_base(&vx, w, h).expect("valid base");
        let py = Pyramid::from_base(&vy, w, h).expect("valid base");
        let mut out = vec![0.0; w * h];
        cs.hue(&px, &py, &mut out);
        let reference = ref_hue_contrast(&ref_pyramid(&vx, w, h), &ref_pyramid(&vy, w, h));
        let err = max_abs_diff(&out, &reference);
        assert!(err < 1e-4, "{w}x{h}: max error {err}");
        assert!(reference.iter().any(|&v| v > 0.01), "test map has contrast");
    }
}

#[test]
fn a_constant_map_has_no_contrast_at_any_scale() {
    let base = vec![0.37f32; 64 * 64];
    let pyramid = Pyramid::from_base(&base, 64, 64).expect("valid base");
    for l in 0..PYRAMID_LEVELS {
        assert!(pyramid
            .level(l)
            .data
            .iter()
            .all(|&v| (v - 0.37).abs() < 1e-6));
    }
    let mut out = vec![1.0; 64 * 64];
    CentreSurround::new().scalar(&pyramid, &mut out);
    assert!(out.iter().all(|&v| v.abs() < 1e-6));
}
