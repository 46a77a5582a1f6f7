//! The pass's pyramid and its lookups (eq. 4.1, 4.8, 4.9): each level's
//! colour with its depth and blur mips, the anisotropic build, the 3×3
//! Gaussian's taps and the 9-point circular filter with the linear blend
//! between levels.

use rayon::prelude::*;

use super::{ANISO_DELTA_PX, GAUSS_SIGMA_TEXELS};
use crate::pyramid::{self, Kernel, Level, Texel};

/// One level: the colour ([`Level`], linear RGB) and, row-major beside
/// it, the depth (Z) and degree of blur (B, σ in px) mips of eq. 4.9.
#[derive(Debug, Clone, Default)]
pub(super) struct Image {
    pub(super) colour: Level,
    pub(super) z: Vec<f32>,
    pub(super) sigma: Vec<f32>,
    /// The DoN mip ρ (eq. 4.10): only with foreground smoothing, only at
    /// the top level built (the one eq. 4.11 reads); empty otherwise.
    pub(super) rho: Vec<f32>,
}

/// The colour level's size, texels and lookups.
impl std::ops::Deref for Image {
    type Target = Level;
    fn deref(&self) -> &Level {
        &self.colour
    }
}

impl std::ops::DerefMut for Image {
    fn deref_mut(&mut self) -> &mut Level {
        &mut self.colour
    }
}

impl Image {
    pub(super) fn reshape(&mut self, w: usize, h: usize) {
        self.colour.reshape(w, h);
        self.z.resize(w * h, 0.0);
        self.sigma.resize(w * h, 0.0);
    }
}

/// Decodes level 0 (colour, depth, σ) and builds levels 1..=`levels`
/// (eq. 4.1; with `anisotropic`, eq. 4.9's H instead of G for the colour),
/// reusing the buffers. Each level-`l` texel is the 3×3 Gaussian centred on
/// its centre in level `l − 1` (between 2×2 texels), sampled bilinearly:
/// 4×4 taps of weights `a_i·a_j`.
#[allow(clippy::too_many_arguments)]
pub(super) fn build_pyramid(
    pyramid: &mut Vec<Image>,
    rgb: &[u8],
    depth: &[f32],
    sigma: &[f32],
    (w, h): (usize, usize),
    levels: usize,
    focus_mm: f64,
    anisotropic: bool,
) {
    if pyramid.len() < levels + 1 {
        pyramid.resize_with(levels + 1, Image::default);
    }
    let focus = focus_mm as f32;
    let base = &mut pyramid[0];
    base.reshape(w, h);
    base.colour.decode(rgb, (w, h));
    for (z, &d) in base.z.iter_mut().zip(depth) {
        *z = if d.is_nan() { focus } else { d };
    }
    base.sigma.copy_from_slice(&sigma[..w * h]);
    let taps = pyramid_taps();
    let at = Kernel::<4>::source;
    for l in 1..=levels {
        let (lo, hi) = pyramid.split_at_mut(l);
        let src = &lo[l - 1];
        let dst = &mut hi[0];
        let (nw, nh) = src.halve();
        dst.reshape(nw, nh);
        // Rows of the destination in parallel.
        let rows = dst
            .colour
            .px
            .par_chunks_mut(nw)
            .zip(dst.z.par_chunks_mut(nw))
            .zip(dst.sigma.par_chunks_mut(nw))
            .enumerate();
        rows.for_each(|(y, ((px_row, z_row), sigma_row))| {
            for x in 0..nw {
                // Isotropic depth and σ (Z and B mips).
                let (mut z, mut sg) = (0.0f32, 0.0f32);
                for (ty, wy) in taps.iter().enumerate() {
                    let row = at(y, ty, src.h) * src.w;
                    for (tx, wx) in taps.iter().enumerate() {
                        let q = row + at(x, tx, src.w);
                        z += wy * wx * src.z[q];
                        sg += wy * wx * src.sigma[q];
                    }
                }
                let background = f64::from(z) > focus_mm;
                // Colour with H: sharper sources left out of a blurrier
                // background texel, the rest renormalised.
                let (mut acc, mut total) = ([0.0f32; 3], 0.0f32);
                for (ty, wy) in taps.iter().enumerate() {
                    let row = at(y, ty, src.h) * src.w;
                    for (tx, wx) in taps.iter().enumerate() {
                        let q = row + at(x, tx, src.w);
                        if anisotropic && background && sg > src.sigma[q] + ANISO_DELTA_PX {
                            continue;
                        }
                        add_scaled(&mut acc, wy * wx, src.px[q]);
                        total += wy * wx;
                    }
                }
                z_row[x] = z;
                sigma_row[x] = sg;
                px_row[x] = if total > 0.0 {
                    acc.map(|a| a / total)
                } else {
                    src.px[at(y, 1, src.h) * src.w + at(x, 1, src.w)]
                };
            }
        });
    }
}

/// The 3×3 Gaussian's weight of a neighbour against the centre's 1,
/// `e^{−1/(2σ²)}` with σ = [`GAUSS_SIGMA_TEXELS`].
fn gauss_neighbour() -> f32 {
    (-1.0 / (2.0 * GAUSS_SIGMA_TEXELS * GAUSS_SIGMA_TEXELS)).exp() as f32
}

/// The 4 taps (per axis) of a pyramid texel: the 3×3 Gaussian centred
/// between 2×2 source texels, sampled bilinearly (eq. 4.1).
pub(crate) fn pyramid_taps() -> [f32; 4] {
    let g = gauss_neighbour();
    let norm = 2.0 * (1.0 + 2.0 * g);
    [g / norm, (1.0 + g) / norm, (1.0 + g) / norm, g / norm]
}

/// The circular filter's neighbour weight and its normalisation
/// `1/(1 + 8g)` (eq. 4.8).
pub(crate) fn circular_weights() -> (f32, f32) {
    let g = gauss_neighbour();
    (g, 1.0 / (1.0 + 8.0 * g))
}

/// `acc += w·v`.
#[inline]
fn add_scaled(acc: &mut [f32; 3], w: f32, v: [f32; 3]) {
    for (a, v) in acc.iter_mut().zip(v) {
        *a += w * v;
    }
}

/// The 8 circular neighbours (unit circle) of eq. 4.8.
pub(crate) const CIRCLE: [(f32, f32); 8] = [
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    ),
    (
        std::f32::consts::FRAC_1_SQRT_2,
        -std::f32::consts::FRAC_1_SQRT_2,
    ),
    (
        -std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    ),
    (
        -std::f32::consts::FRAC_1_SQRT_2,
        -std::f32::consts::FRAC_1_SQRT_2,
    ),
];

/// `A_k(p)`: the 9-point circular Gaussian over level `k`, offsets of one
/// level-`k` texel, at the centre of level-0 pixel (`x`, `y`).
fn circular(img: &Image, k: usize, x: usize, y: usize) -> [f32; 3] {
    let (u, v) = pyramid::level_coords(k, x, y);
    let (g, norm) = circular_weights();
    let mut acc = img.bilinear(u, v);
    for (dx, dy) in CIRCLE {
        let s = img.bilinear(u + dx, v + dy);
        add_scaled(&mut acc, g, s);
    }
    acc.map(|a| a * norm)
}

/// Eq. 4.8 with a linear blend: level `m` > 0 at pixel (`x`, `y`).
pub(super) fn blend(pyramid: &[Image], x: usize, y: usize, m: f64) -> [f32; 3] {
    let l = m.floor() as usize;
    let beta = (m - l as f64) as f32;
    let a = if l == 0 {
        pyramid[0].px[y * pyramid[0].w + x]
    } else {
        circular(&pyramid[l - 1], l - 1, x, y)
    };
    if beta <= 0.0 || l >= pyramid.len() {
        return a;
    }
    a.lerp(circular(&pyramid[l], l, x, y), beta)
}
