//! Lee §4.3's foreground smoothing (eqs. 4.10–4.11), an option of the
//! pass: the DoN mip ρ and the smoothed σ(n) replace σ(0) around blurred
//! foreground objects.

use foveation::thin_lens;
use rayon::prelude::*;

use super::levels::{Image, CIRCLE};
use super::GAUSS_SIGMA_TEXELS;
use crate::pyramid::{self, Kernel};

/// Lee §4.3, foreground smoothing, after the pyramid is built to level
/// `top` (≥ 1): the DoN mip ρ (eq. 4.10) at level `top`, then for
/// every pixel ρ(M) at the top level M = `top` by the 9-point circular
/// filter, n by eq. 4.11 (eq. 4.6 applied to ρ), and where n > 0 the
/// smoothed σ(n) — the B mip at level n, blended linearly between levels
/// and sampled bilinearly, level 0 being the pixel's own σ — replaces
/// σ(0) in the pixel's mip level. Ω' of eq. 4.10 is the 4×4 taps of the
/// level's Gaussian that are in front of the focus and of the texel.
/// Depth mips average the background's infinite depth, so a level-(M−1)
/// texel that mixes a foreground object with empty background counts as
/// background: against an empty background the smoothing is weaker at
/// the silhouette than against a surface behind it.
pub(super) fn smooth_foreground(
    pyramid: &mut [Image],
    level: &mut [f32],
    (w, h): (usize, usize),
    top: usize,
    focus_mm: f64,
) {
    let focus = focus_mm as f32;
    // Only ρ(M) is read (eq. 4.11), and ρ(M) needs only σ(M − 1).
    for l in top..=top {
        let (lo, hi) = pyramid.split_at_mut(l);
        let src = &lo[l - 1];
        let dst = &mut hi[0];
        let (nw, nh) = (dst.w, dst.h);
        let at = Kernel::<4>::source;
        let mut rho = std::mem::take(&mut dst.rho);
        rho.clear();
        rho.resize(nw * nh, 0.0);
        rho.par_chunks_mut(nw).enumerate().for_each(|(y, row)| {
            for (x, r) in row.iter_mut().enumerate() {
                let zp = dst.z[y * nw + x];
                let mut best = 0.0f32;
                for ty in 0..4 {
                    let line = at(y, ty, src.h) * src.w;
                    for tx in 0..4 {
                        let q = line + at(x, tx, src.w);
                        if src.z[q] < focus && src.z[q] < zp {
                            best = best.max(src.sigma[q]);
                        }
                    }
                }
                *r = best;
            }
        });
        dst.rho = rho;
    }
    let top_level = &pyramid[top];
    let max_level = top as f64;
    level.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, m) in row.iter_mut().enumerate() {
            let rho_m = circular_scalar(top_level, &top_level.rho, top, x, y);
            let n = thin_lens::mipmap_level(f64::from(rho_m));
            if n.is_nan() || n <= 0.0 {
                continue;
            }
            let n = n.min(max_level);
            let sigma = sigma_at_level(pyramid, x, y, n);
            let smoothed = thin_lens::mipmap_level(f64::from(sigma));
            *m = if smoothed.is_nan() {
                0.0
            } else {
                smoothed.clamp(0.0, max_level) as f32
            };
        }
    });
    debug_assert!(level.len() == w * h);
}

/// A scalar channel of `img` (level `k`) bilinearly at the centre of
/// level-0 pixel (`x`, `y`) offset by (`dx`, `dy`) level-`k` texels.
fn scalar_at(img: &Image, data: &[f32], k: usize, x: usize, y: usize, (dx, dy): (f32, f32)) -> f32 {
    let (u, v) = pyramid::level_coords(k, x, y);
    pyramid::bilinear(data, img.w, img.h, u + dx, v + dy)
}

/// The 9-point circular filter of eq. 4.8 over a scalar channel.
fn circular_scalar(img: &Image, data: &[f32], k: usize, x: usize, y: usize) -> f32 {
    let g = (-1.0 / (2.0 * GAUSS_SIGMA_TEXELS * GAUSS_SIGMA_TEXELS)).exp() as f32;
    let mut acc = scalar_at(img, data, k, x, y, (0.0, 0.0));
    for d in CIRCLE {
        acc += g * scalar_at(img, data, k, x, y, d);
    }
    acc / (1.0 + 8.0 * g)
}

/// The B mip (σ) at continuous level `n` for pixel (`x`, `y`): linear
/// between levels, bilinear within one; level 0 is the pixel's σ.
fn sigma_at_level(pyramid: &[Image], x: usize, y: usize, n: f64) -> f32 {
    let l = (n.floor() as usize).min(pyramid.len() - 1);
    let f = (n - l as f64) as f32;
    let at = |k: usize| {
        let img = &pyramid[k];
        scalar_at(img, &img.sigma, k, x, y, (0.0, 0.0))
    };
    let a = at(l);
    if f <= 0.0 || l + 1 >= pyramid.len() {
        return a;
    }
    a + (at(l + 1) - a) * f
}
