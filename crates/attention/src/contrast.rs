//! Centre–surround contrast (Lee eq. 3.4) and the combination into pixel
//! saliency (eq. 3.5, 3.6).
//!
//! `C_f = (1/6) Σ_{i∈{0,1,2}} Σ_{j∈{3,4}} |B_f^i − B_f^{i+j}|`: the pairs
//! (0,3), (0,4), (1,4), (1,5), (2,5), (2,6). Every level is sampled at the
//! level-0 pixel by bilinear magnification (Lee Fig. 3.3), so `C_f` has the
//! size of level 0. For hue the absolute difference is
//! [`crate::hls::hue_vector_contrast`].

use rayon::prelude::*;

use crate::hls::hue_vector_contrast_with_lengths;
use crate::pyramid::{AxisTaps, Pyramid, PYRAMID_LEVELS};

/// The (centre, surround) level pairs of eq. 3.4.
pub const CENTRE_SURROUND_PAIRS: [(usize, usize); 6] =
    [(0, 3), (0, 4), (1, 4), (1, 5), (2, 5), (2, 6)];

/// A contrast whose map maximum is at or below this counts as no contrast:
/// its weight `w_f` (eq. 3.6) is 0 rather than `1 / max`. Feature values
/// are in [0, 1]; 8-bit quantisation alone is 1/255.
pub const MIN_CONTRAST: f32 = 1e-5;

/// Bilinear taps from level 0 into levels 1 to 6, both axes.
#[derive(Clone, Debug, Default)]
pub(crate) struct MagnifyTaps {
    x: [AxisTaps; PYRAMID_LEVELS],
    y: [AxisTaps; PYRAMID_LEVELS],
    key: Vec<(usize, usize)>,
}

impl MagnifyTaps {
    fn prepare(&mut self, pyramid: &Pyramid) {
        let key: Vec<(usize, usize)> = (0..PYRAMID_LEVELS)
            .map(|l| (pyramid.level(l).width, pyramid.level(l).height))
            .collect();
        if key == self.key {
            return;
        }
        let (w0, h0) = key[0];
        for (l, &(w, h)) in key.iter().enumerate().skip(1) {
            self.x[l].fill(w0, w);
            self.y[l].fill(h0, h);
        }
        self.key = key;
    }
}

/// Levels 1..6 magnified horizontally to level-0 width (level `l` becomes
/// `w0 × h_l`): bilinear magnification is separable, so each level-0 row
/// then needs only a vertical lerp of two of these rows.
#[derive(Clone, Debug, Default)]
struct Magnified {
    rows: [Vec<f32>; PYRAMID_LEVELS],
}

impl Magnified {
    fn build(&mut self, pyramid: &Pyramid, taps: &MagnifyTaps) {
        let w0 = pyramid.level(0).width;
        for l in 1..PYRAMID_LEVELS {
            let level = pyramid.level(l);
            let t = &taps.x[l];
            let out = &mut self.rows[l];
            out.resize(w0 * level.height, 0.0);
            out.par_chunks_mut(w0).enumerate().for_each(|(r, out)| {
                let src = &level.data[r * level.width..(r + 1) * level.width];
                for (((o, &lo), &hi), &f) in out.iter_mut().zip(&t.lo).zip(&t.hi).zip(&t.frac) {
                    let (a, b) = (src[lo as usize], src[hi as usize]);
                    *o = a + f * (b - a);
                }
            });
        }
    }
}

/// Per-row scratch: every level magnified to the level-0 row `y` (`up[0]`
/// is level 0's row itself, copied).
struct RowScratch {
    up: [Vec<f32>; PYRAMID_LEVELS],
}

impl RowScratch {
    fn new() -> Self {
        Self {
            up: Default::default(),
        }
    }

    fn load(&mut self, pyramid: &Pyramid, magnified: &Magnified, taps: &MagnifyTaps, y: usize) {
        let base = pyramid.level(0);
        let w0 = base.width;
        self.up[0].clear();
        self.up[0].extend_from_slice(&base.data[y * w0..(y + 1) * w0]);
        for l in 1..PYRAMID_LEVELS {
            let (lo, hi, f) = (
                taps.y[l].lo[y] as usize,
                taps.y[l].hi[y] as usize,
                taps.y[l].frac[y],
            );
            let rows = &magnified.rows[l];
            let a = &rows[lo * w0..(lo + 1) * w0];
            let b = &rows[hi * w0..(hi + 1) * w0];
            let up = &mut self.up[l];
            up.resize(w0, 0.0);
            for ((o, &a), &b) in up.iter_mut().zip(a).zip(b) {
                *o = a + f * (b - a);
            }
        }
    }

    /// The seven rows, each exactly `w` long.
    fn rows(&self, w: usize) -> [&[f32]; PYRAMID_LEVELS] {
        std::array::from_fn(|l| &self.up[l][..w])
    }
}

/// Computes centre–surround maps; holds the magnification taps and
/// buffers between frames.
#[derive(Clone, Debug, Default)]
pub struct CentreSurround {
    taps: MagnifyTaps,
    first: Magnified,
    second: Magnified,
}

impl CentreSurround {
    /// A new operator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Eq. 3.4 for a scalar feature: `out` (level-0 size) gets `C_f`.
    /// Rows run in parallel on the current rayon pool.
    ///
    /// # Panics
    /// If `out.len()` differs from level 0's pixel count.
    pub fn scalar(&mut self, pyramid: &Pyramid, out: &mut [f32]) {
        self.taps.prepare(pyramid);
        let base = pyramid.level(0);
        assert_eq!(
            out.len(),
            base.data.len(),
            "contrast map must match level 0"
        );
        self.first.build(pyramid, &self.taps);
        let (taps, magnified) = (&self.taps, &self.first);
        let w = base.width;
        out.par_chunks_mut(w)
            .enumerate()
            .for_each_init(RowScratch::new, |s, (y, o)| {
                s.load(pyramid, magnified, taps, y);
                let c = s.rows(w);
                for (x, o) in o.iter_mut().enumerate() {
                    let sum = (c[0][x] - c[3][x]).abs()
                        + (c[0][x] - c[4][x]).abs()
                        + (c[1][x] - c[4][x]).abs()
                        + (c[1][x] - c[5][x]).abs()
                        + (c[2][x] - c[5][x]).abs()
                        + (c[2][x] - c[6][x]).abs();
                    *o = sum * (1.0 / 6.0);
                }
            });
    }

    /// Eq. 3.4 for hue: `px`, `py` are the pyramids of the chroma-weighted
    /// hue vector's two components (same sizes); `out` gets `C_h`.
    ///
    /// # Panics
    /// If the pyramids' base sizes differ or `out` does not match them.
    pub fn hue(&mut self, px: &Pyramid, py: &Pyramid, out: &mut [f32]) {
        self.taps.prepare(px);
        let bx = px.level(0);
        let by = py.level(0);
        assert_eq!(
            (bx.width, bx.height),
            (by.width, by.height),
            "hue pyramids differ"
        );
        assert_eq!(out.len(), bx.data.len(), "contrast map must match level 0");
        self.first.build(px, &self.taps);
        self.second.build(py, &self.taps);
        let (taps, mx, my) = (&self.taps, &self.first, &self.second);
        let w = bx.width;
        let init = || (RowScratch::new(), RowScratch::new(), RowScratch::new());
        out.par_chunks_mut(w)
            .enumerate()
            .for_each_init(init, |(sx, sy, sl), (y, o)| {
                sx.load(px, mx, taps, y);
                sy.load(py, my, taps, y);
                let (cx, cy) = (sx.rows(w), sy.rows(w));
                // Vector lengths per level, then one plain loop per pair, so
                // that each loop vectorises.
                for l in 0..PYRAMID_LEVELS {
                    let len = &mut sl.up[l];
                    len.clear();
                    len.extend(
                        cx[l]
                            .iter()
                            .zip(cy[l])
                            .map(|(&x, &y)| (x * x + y * y).sqrt()),
                    );
                }
                let lens = sl.rows(w);
                o.fill(0.0);
                for &(i, j) in &CENTRE_SURROUND_PAIRS {
                    let (ax, ay, la) = (cx[i], cy[i], lens[i]);
                    let (bx, by, lb) = (cx[j], cy[j], lens[j]);
                    for x in 0..w {
                        o[x] += hue_vector_contrast_with_lengths(
                            [ax[x], ay[x]],
                            la[x],
                            [bx[x], by[x]],
                            lb[x],
                        );
                    }
                }
                for v in o.iter_mut() {
                    *v *= 1.0 / 6.0;
                }
            });
    }
}

/// Eq. 3.6: `w_f = 1 / max C_f`, or 0 when the maximum is at most
/// [`MIN_CONTRAST`] (a flat feature says nothing).
pub fn contrast_weight(contrast: &[f32]) -> f32 {
    let max = contrast
        .iter()
        .copied()
        .fold(0.0f32, |m, v| if v > m { v } else { m });
    contrast_weight_of_max(max)
}

/// `w_f` (eq. 3.6) from a contrast map's maximum (NaN entries skipped, as
/// [`contrast_weight`] does): `1 / max`, or 0 when `max` is at or below
/// [`MIN_CONTRAST`] or not finite.
pub fn contrast_weight_of_max(max: f32) -> f32 {
    if max > MIN_CONTRAST && max.is_finite() {
        1.0 / max
    } else {
        0.0
    }
}

/// Eq. 3.5 and the normalisation to [0, 1]: `out = Σ w_f C_f`, divided by
/// its maximum. When every weight is 0 (no feature on, or none with any
/// contrast) the map carries no bottom-up information and `out` is 1
/// everywhere, so object saliency falls back to task importance.
/// Returns whether the map is informative (false for that fallback).
pub fn combine(contrasts: &[(&[f32], f32)], out: &mut [f32]) -> bool {
    let active: Vec<(&[f32], f32)> = contrasts
        .iter()
        .copied()
        .filter(|&(c, w)| w > 0.0 && c.len() == out.len())
        .collect();
    if active.is_empty() {
        out.fill(1.0);
        return false;
    }
    out.par_iter_mut().enumerate().for_each(|(i, o)| {
        *o = active.iter().map(|&(c, w)| w * c[i]).sum();
    });
    let max = out
        .iter()
        .copied()
        .fold(0.0f32, |m, v| if v > m { v } else { m });
    if !(max > 0.0 && max.is_finite()) {
        out.fill(1.0);
        return false;
    }
    let inv = 1.0 / max;
    out.par_iter_mut()
        .for_each(|o| *o = (*o * inv).clamp(0.0, 1.0));
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_weight_of_a_map_is_the_weight_of_its_maximum() {
        for map in [
            &[0.0f32, 0.25, 0.5][..],
            &[f32::NAN, 0.2, 0.1],
            &[0.0; 4],
            &[MIN_CONTRAST, 0.0],
            &[0.0, f32::INFINITY],
            &[],
        ] {
            let max = map
                .iter()
                .copied()
                .filter(|v| !v.is_nan())
                .fold(0.0f32, f32::max);
            assert_eq!(contrast_weight(map), contrast_weight_of_max(max), "{map:?}");
        }
        assert_eq!(contrast_weight_of_max(0.5), 2.0);
        assert_eq!(contrast_weight_of_max(MIN_CONTRAST), 0.0);
        assert_eq!(contrast_weight_of_max(f32::NAN), 0.0);
        assert_eq!(contrast_weight_of_max(f32::INFINITY), 0.0);
    }
}
