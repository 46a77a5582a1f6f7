//! Seven-level image pyramids (Lee §3.1.1: levels 0, finest, to 6) and the
//! bilinear magnification that samples a coarse level at level-0 pixels
//! (Lee Fig. 3.3, `texture2D(DSM, tc0, float(i))`).
//!
//! Lee builds the levels with hardware mipmapping (a 2×2 box). Here each
//! level is the previous one filtered by the separable binomial kernel
//! `[1, 3, 3, 1] / 8` and decimated by 2 — a Gaussian pyramid (as in
//! Itti et al. \[47\]) whose texel centres sit where a mipmap's do: texel `x`
//! of level `l + 1` is centred at `2x + 0.5` of level `l`. Borders clamp to
//! the edge. An odd size rounds up (`ceil(n / 2)`), never below 1.

/// Levels per pyramid (Lee §3.1.1: 0 to 6).
pub const PYRAMID_LEVELS: usize = 7;

/// The binomial taps, applied at `2x − 1, 2x, 2x + 1, 2x + 2`.
pub const BINOMIAL_TAPS: [f32; 4] = [0.125, 0.375, 0.375, 0.125];

/// One level of a pyramid, borrowed.
#[derive(Clone, Copy, Debug)]
pub struct Level<'a> {
    /// Row-major values.
    pub data: &'a [f32],
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
}

/// A pyramid of one scalar channel. Buffers are kept between frames.
#[derive(Clone, Debug, Default)]
pub struct Pyramid {
    sizes: [(usize, usize); PYRAMID_LEVELS],
    levels: [Vec<f32>; PYRAMID_LEVELS],
    scratch: Vec<f32>,
}

/// Size of the next coarser level along one axis.
pub fn coarser_len(len: usize) -> usize {
    len.div_ceil(2).max(1)
}

impl Pyramid {
    /// An empty pyramid; give it a base with [`Pyramid::base_mut`].
    pub fn new() -> Self {
        Self::default()
    }

    /// A pyramid built from a base image; `None` if a side is 0 or the
    /// length is not `width * height`.
    pub fn from_base(base: &[f32], width: usize, height: usize) -> Option<Self> {
        if width == 0 || height == 0 || width.checked_mul(height)? != base.len() {
            return None;
        }
        let mut pyramid = Self::new();
        pyramid.base_mut(width, height).copy_from_slice(base);
        pyramid.rebuild();
        Some(pyramid)
    }

    /// Level 0, resized to `width × height` (each at least 1) for the
    /// caller to fill; then call [`Pyramid::rebuild`].
    pub fn base_mut(&mut self, width: usize, height: usize) -> &mut [f32] {
        let (width, height) = (width.max(1), height.max(1));
        self.sizes[0] = (width, height);
        self.levels[0].resize(width * height, 0.0);
        &mut self.levels[0]
    }

    /// Recomputes levels 1 to 6 from level 0.
    pub fn rebuild(&mut self) {
        for l in 1..PYRAMID_LEVELS {
            let (w, h) = self.sizes[l - 1];
            let (lower, upper) = self.levels.split_at_mut(l);
            self.sizes[l] = downsample(&lower[l - 1], w, h, &mut upper[0], &mut self.scratch);
        }
    }

    /// Level `l` (0 to 6). Levels above 6 return level 6.
    pub fn level(&self, l: usize) -> Level<'_> {
        let l = l.min(PYRAMID_LEVELS - 1);
        let (width, height) = self.sizes[l];
        Level {
            data: &self.levels[l],
            width,
            height,
        }
    }
}

/// One binomial filter-and-decimate step: `src` is `w × h`; `dst` becomes
/// `ceil(w/2) × ceil(h/2)`, which is returned.
pub fn downsample(
    src: &[f32],
    w: usize,
    h: usize,
    dst: &mut Vec<f32>,
    scratch: &mut Vec<f32>,
) -> (usize, usize) {
    let (w2, h2) = (coarser_len(w), coarser_len(h));
    let at = |i: isize, len: usize| i.clamp(0, len as isize - 1) as usize;
    let [k0, k1, k2, k3] = BINOMIAL_TAPS;
    // Horizontal pass: w2 × h.
    scratch.resize(w2 * h, 0.0);
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let out = &mut scratch[y * w2..(y + 1) * w2];
        for (x2, o) in out.iter_mut().enumerate() {
            let c = 2 * x2 as isize;
            *o = k0 * row[at(c - 1, w)]
                + k1 * row[at(c, w)]
                + k2 * row[at(c + 1, w)]
                + k3 * row[at(c + 2, w)];
        }
    }
    // Vertical pass: w2 × h2.
    dst.resize(w2 * h2, 0.0);
    for y2 in 0..h2 {
        let c = 2 * y2 as isize;
        let rows = [at(c - 1, h), at(c, h), at(c + 1, h), at(c + 2, h)];
        let out = &mut dst[y2 * w2..(y2 + 1) * w2];
        for (x2, o) in out.iter_mut().enumerate() {
            *o = k0 * scratch[rows[0] * w2 + x2]
                + k1 * scratch[rows[1] * w2 + x2]
                + k2 * scratch[rows[2] * w2 + x2]
                + k3 * scratch[rows[3] * w2 + x2];
        }
    }
    (w2, h2)
}

/// Where level-0 index `i` (of `base_len`) falls in a level of `level_len`
/// texels, in texel-centre units, clamped to the edge texels: a texture
/// lookup at normalised coordinate `(i + 0.5) / base_len`.
pub fn texel_coordinate(i: usize, base_len: usize, level_len: usize) -> f32 {
    let u = (i as f64 + 0.5) * level_len as f64 / base_len.max(1) as f64 - 0.5;
    u.clamp(0.0, (level_len.max(1) - 1) as f64) as f32
}

/// Precomputed bilinear taps along one axis: lower texel, upper texel and
/// the weight of the upper one, for each level-0 index (the
/// magnification of [`crate::contrast::CentreSurround`]; a GPU
/// implementation uploads the same taps).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisTaps {
    /// The lower texel of each level-0 index.
    pub lo: Vec<u32>,
    /// The upper texel (the lower one at the last texel).
    pub hi: Vec<u32>,
    /// The upper texel's weight, [0, 1).
    pub frac: Vec<f32>,
}

impl AxisTaps {
    /// The taps of a level of `level_len` texels (at least 1) sampled at
    /// each of `base_len` level-0 indices ([`texel_coordinate`]). Both
    /// lengths are the caller's (map sides, not frame sizes): this
    /// allocates `base_len` entries per table.
    pub fn fill(&mut self, base_len: usize, level_len: usize) {
        let level_len = level_len.max(1);
        self.lo.clear();
        self.hi.clear();
        self.frac.clear();
        for i in 0..base_len {
            let u = texel_coordinate(i, base_len, level_len);
            let lo = u.floor() as usize;
            let hi = (lo + 1).min(level_len - 1);
            self.lo.push(lo as u32);
            self.hi.push(hi as u32);
            self.frac.push(u - lo as f32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_halve_and_round_up_to_one() {
        let base = vec![0.5f32; 100 * 64];
        let p = Pyramid::from_base(&base, 100, 64).expect("valid base");
        let sizes: Vec<_> = (0..PYRAMID_LEVELS)
            .map(|l| (p.level(l).width, p.level(l).height))
            .collect();
        assert_eq!(
            sizes,
            [
                (100, 64),
                (50, 32),
                (25, 16),
                (13, 8),
                (7, 4),
                (4, 2),
                (2, 1)
            ]
        );
        assert!(p.level(6).data.iter().all(|&v| (v - 0.5).abs() < 1e-6));
    }

    #[test]
    fn from_base_rejects_mismatched_lengths() {
        assert!(Pyramid::from_base(&[0.0; 10], 3, 3).is_none());
        assert!(Pyramid::from_base(&[], 0, 3).is_none());
    }
}
