//! Image-based foveation: a full-resolution frame blurred by a
//! multiresolution pyramid whose level per pixel follows the CSF cut-off
//! (Geisler & Perry 1998; the image-based family of Murphy 2007 §2.3 and
//! §3.1). It is the third family a lab compares with the hybrid ray mask
//! and the model-based methods: the rendering cost is a full frame's, and
//! the saving is bandwidth, not rays.
//!
//! **The level per pixel** is tied to the ray mask by one number: the
//! allowed ray spacing `s` (pixels) that [`SamplingModel`] gives at the
//! pixel for the gaze — the Nyquist spacing of the Geisler–Perry cut-off
//! `f_c(e)` at the pixel's eccentricity, through the local pixels per
//! degree, clamped to `[1, max_spacing_px]`, with the model's inset. A
//! spacing of `s` px carries frequencies up to `1/(2s)` cycles per pixel;
//! pyramid level `k` (downsampled `2^k` times) carries up to `1/(2·2^k)`.
//! So the level is `m = log2(s)`: where the ray mask casts every pixel
//! (`s = 1`, the fovea and any inset) the pixel is left untouched, bit for
//! bit, and where the mask spaces its rays 17 px apart the image keeps
//! what a level of 4.09 keeps.
//!
//! **The pyramid** is Burt & Adelson's Gaussian pyramid (the one Geisler &
//! Perry build): each level the previous one filtered by the separable
//! 5-tap binomial `[1 4 6 4 1]/16` and decimated by 2, edges clamped, in
//! linear light (the renderer's gamma 2.2 decoded and encoded again by
//! [`crate::colour`]). Only the levels the frame's largest `m`
//! needs are built. The levels, REDUCE and the bilinear lookup are
//! `crate::pyramid`'s, shared with depth of field; the binomial kernel is
//! this filter's own.
//!
//! **The blend** between the two levels around a fractional `m` (a gap the
//! seeds leave: Geisler & Perry blend by the levels' transfer functions at
//! the cut-off) is linear in the level, each level sampled bilinearly at
//! the pixel's centre: continuous in `m`, so the blur grows with
//! eccentricity without visible rings.
//!
//! The hit mask, depth and ids are the full frame's: only colour is
//! filtered, so silhouettes are exact by construction and the blur alone is
//! what the quality figures measure.

use crate::colour;
use crate::pyramid::{self, Kernel, Level, Texel};
use foveation::SamplingModel;
use raycast::Frame;
use rayon::prelude::*;

/// The deepest level built: 2^7 = 128 px per texel, far beyond any
/// spacing a sampling model allows (its `max_spacing_px` is clamped here).
pub const MAX_LEVEL: usize = 7;

/// The binomial 5-tap kernel of Burt & Adelson's REDUCE.
const TAPS: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

/// The image-based foveation filter, with its buffers (reused frame after
/// frame; a renderer makes one only for `Method::Image`).
#[derive(Debug, Clone, Default)]
pub struct ImageFoveation {
    /// Level per pixel of the current frame (0: untouched).
    level: Vec<f32>,
    /// Levels 0 (the frame in linear light) … the deepest needed.
    pyramid: Vec<Level>,
    /// The horizontal pass of REDUCE.
    row_pass: Vec<[f32; 3]>,
    /// The level at each block corner, and whether the block must be
    /// evaluated exactly.
    corners: Vec<(f32, bool)>,
}

/// Image-based foveation as the image method's pass in the frame plan:
/// the filter under the frame's sampling model
/// ([`Pass::prepare`](crate::effects::Pass::prepare)), timed.
#[derive(Debug, Clone, Default)]
pub struct ImagePass {
    pub(crate) filter: ImageFoveation,
    pub(crate) model: Option<SamplingModel>,
    /// Wall time of the last frame's filter (on the GPU: its level map), ms.
    pub(crate) ms: f64,
}

impl ImagePass {
    /// The filter (its level map and pyramid).
    pub fn filter(&self) -> &ImageFoveation {
        &self.filter
    }

    /// Wall time of the last frame's filter, ms (on the GPU backend: the
    /// CPU's level map only; the blur is in the GPU frame).
    pub fn ms(&self) -> f64 {
        self.ms
    }

    /// The model's largest ray spacing, px (NaN before the first frame).
    pub fn max_spacing_px(&self) -> f64 {
        self.model.map_or(f64::NAN, |m| m.max_spacing_px)
    }
}

impl crate::effects::Pass for ImagePass {
    fn name(&self) -> &'static str {
        "image-based foveation"
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn role(&self) -> crate::plan::Role {
        crate::plan::Role::MethodPass
    }

    fn owns(&self) -> String {
        "the level map and the pyramid's levels down to the deepest needed".into()
    }

    fn prepare(&mut self, model: &SamplingModel) {
        self.model = Some(*model);
    }

    fn run(&mut self, frame: &mut Frame, input: &crate::effects::PassInput<'_>) {
        let Some(model) = self.model else { return };
        let started = std::time::Instant::now();
        self.filter.apply(frame, &model, input.gaze_px);
        self.ms = started.elapsed().as_secs_f64() * 1e3;
    }

    fn into_gpu(
        self: Box<Self>,
    ) -> Result<Box<dyn crate::effects::GpuPass>, Box<dyn crate::effects::Pass>> {
        Ok(Box::new(crate::gpu::GpuImagePass::new(*self)))
    }
}

/// The side of the blocks whose level is interpolated from their corners.
pub const BLOCK: usize = 8;

impl ImageFoveation {
    /// Pyramid levels allocated so far (0 before the first blurred frame).
    pub fn allocated_levels(&self) -> usize {
        self.pyramid.len()
    }

    /// The level per pixel of the last frame (`m = log2(spacing)`, exact
    /// near the fovea, interpolated from 8-px blocks elsewhere).
    pub fn levels(&self) -> &[f32] {
        &self.level
    }

    /// Blurs `frame`'s colour in place for the gaze `gaze_px` (screen px):
    /// each pixel to the pyramid level of its allowed ray spacing under
    /// `model`. Pixels at level 0 are not written. A non-finite gaze leaves
    /// the frame as it is (the caller refuses it first).
    pub fn apply(&mut self, frame: &mut Frame, model: &SamplingModel, gaze_px: [f64; 2]) {
        let (w, h) = (frame.width_px as usize, frame.height_px as usize);
        if w == 0 || h == 0 || frame.rgb.len() < 3 * w * h {
            return;
        }
        if !(gaze_px[0].is_finite() && gaze_px[1].is_finite()) {
            return;
        }
        let Some(needed) = self.levels_for(model, gaze_px, (w, h)) else {
            return;
        };
        self.build(&frame.rgb, (w, h), needed);
        let pyramid = &self.pyramid[..=needed];
        let levels = &self.level;
        frame
            .rgb
            .par_chunks_mut(3 * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let m = levels[y * w + x];
                    if m <= 0.0 {
                        continue;
                    }
                    let c = blend(pyramid, x, y, m);
                    row[3 * x..3 * x + 3].copy_from_slice(&colour::encode3(c));
                }
            });
    }

    /// Fills the level map ([`ImageFoveation::levels`]) of a `w`×`h` frame
    /// for the gaze and returns the deepest pyramid level it needs
    /// (⌈max m⌉ as far as the frame's size allows; `None`: every level is
    /// 0, nothing to blur). It depends on the gaze only: the GPU path
    /// uploads it.
    pub(crate) fn levels_for(
        &mut self,
        model: &SamplingModel,
        gaze_px: [f64; 2],
        (w, h): (usize, usize),
    ) -> Option<usize> {
        let sampler = model.from_por(gaze_px);
        let inset_half = 0.5 * model.inset_deg;
        let max_level = model.max_spacing_px.max(1.0).log2().min(MAX_LEVEL as f64);
        self.level_map(&sampler, (w, h), inset_half, max_level);
        let max_m = self.level.iter().fold(0.0f32, |a, &m| a.max(m));
        if max_m <= 0.0 {
            return None;
        }
        // Levels 0..=⌈max m⌉, as far as the frame's size allows.
        let top = pyramid::top_level(w, h, MAX_LEVEL);
        Some((max_m.ceil() as usize).min(top))
    }

    /// The level per pixel. The spacing is smooth away from the fovea, so it
    /// is evaluated exactly at the corners of [`BLOCK`]-px blocks and the
    /// level interpolated bilinearly inside a block; a block is evaluated
    /// exactly at every pixel where it could hold a pixel of spacing 1 or
    /// the inset's edge (a corner's spacing below 2 px, or a corner within
    /// 2° of the inset's edge), so every pixel whose own spacing is 1 stays
    /// at level 0.
    fn level_map(
        &mut self,
        sampler: &foveation::sampling::PorSampler,
        (w, h): (usize, usize),
        inset_half: f64,
        max_level: f64,
    ) {
        let exact = |x: f64, y: f64| {
            let s = sampler.spacing_at([x, y]);
            let m = if s.eccentricity_deg < inset_half {
                0.0
            } else {
                level_for_spacing(s.spacing_px, max_level)
            };
            (m as f32, s)
        };
        let (bw, bh) = (w.div_ceil(BLOCK) + 1, h.div_ceil(BLOCK) + 1);
        self.corners.resize(bw * bh, (0.0, false));
        self.corners
            .par_chunks_mut(bw)
            .enumerate()
            .for_each(|(by, row)| {
                let y = ((by * BLOCK) as f64 + 0.5).min(h as f64 - 0.5);
                for (bx, c) in row.iter_mut().enumerate() {
                    let x = ((bx * BLOCK) as f64 + 0.5).min(w as f64 - 0.5);
                    let (m, s) = exact(x, y);
                    let near = s.spacing_px.is_nan()
                        || s.spacing_px < 2.0
                        || s.eccentricity_deg.is_nan()
                        || (inset_half > 0.0 && s.eccentricity_deg <= inset_half + 2.0);
                    *c = (m, near);
                }
            });
        let corners = &self.corners;
        self.level.resize(w * h, 0.0);
        self.level
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                let by = y / BLOCK;
                let y0 = (by * BLOCK) as f64 + 0.5;
                let y1 = (((by + 1) * BLOCK) as f64 + 0.5).min(h as f64 - 0.5);
                let py = y as f64 + 0.5;
                let fy = if y1 > y0 {
                    ((py - y0) / (y1 - y0)) as f32
                } else {
                    0.0
                };
                for (bx, chunk) in row.chunks_mut(BLOCK).enumerate() {
                    let c = [
                        corners[by * bw + bx],
                        corners[by * bw + bx + 1],
                        corners[(by + 1) * bw + bx],
                        corners[(by + 1) * bw + bx + 1],
                    ];
                    let x0 = (bx * BLOCK) as f64 + 0.5;
                    if c.iter().any(|&(_, near)| near) {
                        for (i, m) in chunk.iter_mut().enumerate() {
                            *m = exact(x0 + i as f64, py).0;
                        }
                        continue;
                    }
                    let x1 = (((bx + 1) * BLOCK) as f64 + 0.5).min(w as f64 - 0.5);
                    let top = |fx: f32| c[0].0 + (c[1].0 - c[0].0) * fx;
                    let bot = |fx: f32| c[2].0 + (c[3].0 - c[2].0) * fx;
                    for (i, m) in chunk.iter_mut().enumerate() {
                        let px = x0 + i as f64;
                        let fx = if x1 > x0 {
                            ((px - x0) / (x1 - x0)) as f32
                        } else {
                            0.0
                        };
                        let (t, b) = (top(fx), bot(fx));
                        *m = t + (b - t) * fy;
                    }
                }
            });
    }

    /// Decodes level 0 and builds levels 1..=`levels` by REDUCE.
    fn build(&mut self, rgb: &[u8], (w, h): (usize, usize), levels: usize) {
        if self.pyramid.len() < levels + 1 {
            self.pyramid.resize_with(levels + 1, Level::default);
        }
        self.pyramid[0].decode(rgb, (w, h));
        for l in 1..=levels {
            let (lo, hi) = self.pyramid.split_at_mut(l);
            reduce(&lo[l - 1], &mut hi[0], &mut self.row_pass);
        }
    }
}

/// Level `log2(spacing)`, 0 for a spacing of 1 px or less (or NaN),
/// at most `max_level`.
pub fn level_for_spacing(spacing_px: f64, max_level: f64) -> f64 {
    if spacing_px.is_nan() || spacing_px <= 1.0 {
        return 0.0;
    }
    spacing_px.log2().min(max_level).max(0.0)
}

/// Burt & Adelson's REDUCE: `src` filtered by the separable binomial
/// kernel and decimated by 2 into `dst` (edges clamped).
fn reduce(src: &Level, dst: &mut Level, row_pass: &mut Vec<[f32; 3]>) {
    Kernel(TAPS).reduce(src, dst, row_pass);
}

/// The colour at level `m` > 0: linear between levels ⌊m⌋ and ⌈m⌉.
fn blend(pyramid: &[Level], x: usize, y: usize, m: f32) -> [f32; 3] {
    let l = (m.floor() as usize).min(pyramid.len() - 1);
    let beta = m - l as f32;
    let a = if l == 0 {
        pyramid[0].px[y * pyramid[0].w + x]
    } else {
        pyramid[l].at_pixel(l, x, y)
    };
    if beta <= 0.0 || l + 1 >= pyramid.len() {
        return a;
    }
    a.lerp(pyramid[l + 1].at_pixel(l + 1, x, y), beta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_is_the_log_of_the_spacing() {
        assert_eq!(level_for_spacing(1.0, 4.0), 0.0);
        assert_eq!(level_for_spacing(0.5, 4.0), 0.0);
        assert_eq!(level_for_spacing(f64::NAN, 4.0), 0.0);
        assert_eq!(level_for_spacing(4.0, 4.0), 2.0);
        assert_eq!(level_for_spacing(1e9, 4.0), 4.0);
        assert_eq!(level_for_spacing(f64::INFINITY, 4.0), 4.0);
    }

    #[test]
    fn reduce_keeps_a_constant_image_constant() {
        let src = Level {
            w: 5,
            h: 3,
            px: vec![[0.25, 0.5, 1.0]; 15],
        };
        let mut dst = Level::default();
        let mut scratch = Vec::new();
        reduce(&src, &mut dst, &mut scratch);
        assert_eq!((dst.w, dst.h), (3, 2));
        for p in &dst.px {
            for (a, b) in p.iter().zip([0.25, 0.5, 1.0]) {
                assert!((a - b).abs() < 1e-6, "{p:?}");
            }
        }
    }
}
