//! The image pyramid of the two image passes, depth of field
//! ([`crate::effects::depth_of_field`], Lee ch. 4) and image-based
//! foveation ([`crate::image_foveation`]): what is the same in both, once.
//!
//! - **A level** ([`Level`]): linear RGB, row-major; level 0 is the frame's
//!   bytes decoded with the renderer's gamma ([`Level::decode`]), level
//!   `l` is `div_ceil(2)` of level `l − 1` in each axis ([`Level::halve`]),
//!   as many as the frame's size allows up to a pass's maximum
//!   ([`top_level`]).
//! - **REDUCE's footprint** ([`Kernel`]): destination texel `x` of an
//!   `N`-tap kernel reads source texels `2x − ⌊(N−1)/2⌋ …` (tap `t`:
//!   [`Kernel::source`]), edges clamped; its separable form
//!   ([`Kernel::reduce`], rows then columns) is Burt & Adelson's REDUCE.
//! - **The bilinear lookup** ([`bilinear`], [`Level::bilinear`]): a level
//!   (or a scalar mip beside it) at a continuous texel position, texel
//!   centres at integers, clamped to the edge; [`level_coords`] is the
//!   centre of a level-0 pixel in level-`k` texels ([`Level::at_pixel`]).
//!
//! What stays with each pass is its filter: image-based foveation's
//! 5-tap binomial `[1 4 6 4 1]/16` centred on texel `2x`, applied by
//! [`Kernel::reduce`]; depth of field's 3×3 Gaussian of σ = 1 texel
//! centred between texels `2x` and `2x + 1`, sampled bilinearly (4 taps),
//! which cannot be separable: eq. 4.9's anisotropic weight drops
//! source texels per destination texel (by the destination's depth and
//! blur) and renormalises the rest, and it carries the depth and blur
//! mips beside the colour. A separable sum also rounds differently from a
//! 4×4 one, so each keeps its order of summation (which its GPU twin
//! repeats). The GPU side of this module is `gpu/pyramid.wgsl`. The two blends differ too:
//! foveation reads levels `⌊m⌋` and `⌈m⌉` themselves, depth of field the
//! 9-point circular filter (eq. 4.8) over levels `⌊m⌋ − 1` and `⌊m⌋`.

use crate::colour;
use rayon::prelude::*;

/// A texel a level or a mip holds, interpolated linearly.
pub(crate) trait Texel: Copy {
    /// `self + (other − self)·f`, per channel.
    fn lerp(self, other: Self, f: f32) -> Self;
}

impl Texel for f32 {
    #[inline]
    fn lerp(self, other: Self, f: f32) -> Self {
        self + (other - self) * f
    }
}

impl Texel for [f32; 3] {
    #[inline]
    fn lerp(self, other: Self, f: f32) -> Self {
        [0, 1, 2].map(|k| self[k] + (other[k] - self[k]) * f)
    }
}

/// One pyramid level: linear RGB, row-major.
#[derive(Debug, Clone, Default)]
pub(crate) struct Level {
    pub w: usize,
    pub h: usize,
    pub px: Vec<[f32; 3]>,
}

impl Level {
    pub fn reshape(&mut self, w: usize, h: usize) {
        self.w = w;
        self.h = h;
        self.px.resize(w * h, [0.0; 3]);
    }

    /// The size of the level after `self` (half, rounded up, each axis).
    pub fn halve(&self) -> (usize, usize) {
        (self.w.div_ceil(2), self.h.div_ceil(2))
    }

    /// Level 0: the `w`×`h` frame's bytes `rgb` in linear light.
    pub fn decode(&mut self, rgb: &[u8], (w, h): (usize, usize)) {
        let lut = colour::decode_lut();
        self.reshape(w, h);
        self.px
            .par_iter_mut()
            .zip(rgb.par_chunks_exact(3))
            .for_each(|(p, c)| *p = [lut[c[0] as usize], lut[c[1] as usize], lut[c[2] as usize]]);
    }

    /// Bilinear sample at texel position (`x`, `y`), texel centres at
    /// integers, clamped to the edge.
    #[inline]
    pub fn bilinear(&self, x: f32, y: f32) -> [f32; 3] {
        bilinear(&self.px, self.w, self.h, x, y)
    }

    /// The level (level `k`) at the centre of level-0 pixel (`x`, `y`).
    #[inline]
    pub fn at_pixel(&self, k: usize, x: usize, y: usize) -> [f32; 3] {
        let (u, v) = level_coords(k, x, y);
        self.bilinear(u, v)
    }
}

/// The `w`×`h` row-major `data` (a level's colour or a mip beside it)
/// bilinearly at texel position (`x`, `y`), texel centres at integers,
/// clamped to the edge.
#[inline]
pub(crate) fn bilinear<T: Texel>(data: &[T], w: usize, h: usize, x: f32, y: f32) -> T {
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as usize, y0 as usize);
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let p = |x: usize, y: usize| data[y * w + x];
    let top = p(x0, y0).lerp(p(x1, y0), fx);
    let bot = p(x0, y1).lerp(p(x1, y1), fx);
    top.lerp(bot, fy)
}

/// The centre of level-0 pixel (`x`, `y`) in level-`k` texel coordinates
/// (centres at integers).
#[inline]
pub(crate) fn level_coords(k: usize, x: usize, y: usize) -> (f32, f32) {
    let scale = (1u32 << k) as f32;
    (
        (x as f32 + 0.5) / scale - 0.5,
        (y as f32 + 0.5) / scale - 0.5,
    )
}

/// The deepest level a `w`×`h` frame allows, at most `max`: every level
/// keeps at least one texel per axis.
pub(crate) fn top_level(w: usize, h: usize, max: usize) -> usize {
    let mut top = 0usize;
    while top < max && (w >> (top + 1)) >= 1 && (h >> (top + 1)) >= 1 {
        top += 1;
    }
    top
}

/// An `N`-tap REDUCE kernel (weights per axis): destination texel `x`
/// reads source texels `2x + t − ⌊(N−1)/2⌋`, `t` = 0…N−1, edges clamped —
/// centred on source texel `2x` for odd `N`, between `2x` and `2x + 1` for
/// even `N`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Kernel<const N: usize>(pub [f32; N]);

impl<const N: usize> Kernel<N> {
    /// Source texel of tap `t` for destination texel `x`, in a source of
    /// `n` texels: `(2x + t).saturating_sub(⌊(N−1)/2⌋).min(n − 1)`.
    #[inline]
    pub fn source(x: usize, t: usize, n: usize) -> usize {
        (2 * x + t).saturating_sub((N - 1) / 2).min(n - 1)
    }

    /// REDUCE: `src` filtered by the kernel in x then y (separable) and
    /// decimated by 2 into `dst`; `row_pass` holds the horizontal pass.
    pub fn reduce(&self, src: &Level, dst: &mut Level, row_pass: &mut Vec<[f32; 3]>) {
        let (nw, nh) = src.halve();
        dst.reshape(nw, nh);
        // Horizontal: every source row, decimated in x.
        row_pass.resize(nw * src.h, [0.0; 3]);
        row_pass
            .par_chunks_mut(nw)
            .enumerate()
            .for_each(|(y, out)| {
                let row = &src.px[y * src.w..(y + 1) * src.w];
                for (x, o) in out.iter_mut().enumerate() {
                    let mut acc = [0.0f32; 3];
                    for (t, wt) in self.0.iter().enumerate() {
                        let sx = Self::source(x, t, src.w);
                        for k in 0..3 {
                            acc[k] += wt * row[sx][k];
                        }
                    }
                    *o = acc;
                }
            });
        // Vertical, decimated in y.
        let rows: &[[f32; 3]] = row_pass;
        dst.px.par_chunks_mut(nw).enumerate().for_each(|(y, out)| {
            for (x, o) in out.iter_mut().enumerate() {
                let mut acc = [0.0f32; 3];
                for (t, wt) in self.0.iter().enumerate() {
                    let sy = Self::source(y, t, src.h);
                    for k in 0..3 {
                        acc[k] += wt * rows[sy * nw + x][k];
                    }
                }
                *o = acc;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_footprint_is_centred_and_clamped() {
        // 5 taps centred on 2x; 4 taps between 2x and 2x + 1.
        let five: Vec<usize> = (0..5).map(|t| Kernel::<5>::source(3, t, 100)).collect();
        assert_eq!(five, [4, 5, 6, 7, 8]);
        let four: Vec<usize> = (0..4).map(|t| Kernel::<4>::source(3, t, 100)).collect();
        assert_eq!(four, [5, 6, 7, 8]);
        assert_eq!(Kernel::<5>::source(0, 0, 9), 0);
        assert_eq!(Kernel::<4>::source(4, 3, 9), 8);
    }

    #[test]
    fn bilinear_is_exact_at_texel_centres_and_clamped() {
        let mut l = Level::default();
        l.reshape(3, 2);
        for (i, p) in l.px.iter_mut().enumerate() {
            *p = [i as f32; 3];
        }
        assert_eq!(l.bilinear(1.0, 1.0), [4.0; 3]);
        assert_eq!(l.bilinear(-5.0, 9.0), [3.0; 3]);
        assert_eq!(l.bilinear(0.5, 0.0), [0.5; 3]);
        let z: Vec<f32> = (0..6).map(|i| i as f32).collect();
        assert_eq!(bilinear(&z, 3, 2, 0.5, 0.5), 2.0);
        assert_eq!(top_level(16, 3, 8), 1);
        assert_eq!(top_level(1, 1, 8), 0);
        assert_eq!(top_level(1 << 12, 1 << 12, 7), 7);
    }
}
