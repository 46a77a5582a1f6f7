//! Depth of field by point splatting on per-pixel layers (Lee 2009, ch. 5,
//! "DOF2"), on the CPU, as a pass over the G-buffer; the hidden surfaces
//! are cast exactly with rays ([`raycast::layers`]).
//!
//! Per frame:
//! 1. **Focus** `Z_f` and **refocus** exactly as the ch. 4 pass
//!    ([`super::depth_of_field`]: `Fixed`, or the median depth of a
//!    [`FOCUS_WINDOW_PX`](super::depth_of_field::FOCUS_WINDOW_PX) window
//!    at the gaze, the last one kept when the gaze sees no surface; then
//!    [`super::refocus`]).
//! 2. **Visible image V** (§5.1.1): every pixel of the frame, its colour
//!    decoded to linear light (`crate::colour`), its **signed CoC**
//!    `B = ±C` (eq. 5.3's `B = K(Z − Z_f)/Z`, negative in front of the
//!    focus) with `C` from [`coc_px`] (eq. 4.2–4.4, the display's real
//!    pixels per mm and eye distance), on demand, not stored between frames.
//! 3. **Hidden image H** (§5.1.2), only where the seed's three tests let a
//!    hidden fragment through: (a) the visible pixel is not behind the
//!    focus (`Z_v ≤ Z_f`); (b) it is not completely hidden: eq. 5.1,
//!    `𝓛(p) = Σ_{n∈Ω} (Z_v(n) − Z_v(p)) / N_Ω` over [`LAPLACIAN_SAMPLES`]
//!    points within p's CoC, is at least [`LAPLACIAN_THRESHOLD`] (and
//!    positive, whatever threshold is set); (c) the
//!    surface is the second-nearest *object*: the pixel's ray is cast for
//!    its first [`HIDDEN_RAY_HITS`] surfaces ([`raycast::layers`]), and H
//!    is the first whose object differs from the visible one, shaded like a
//!    primary hit; when the ray leaves the scene before such a surface,
//!    H is the background (infinitely far).
//! 4. **Splatting** (§5.1.3, eq. 5.2) of every V and H sample over its CoC
//!    disc: destination q gets the weight `A(p, q) = k_n(C)·cov(p, q)`, with
//!    `cov` the disc's antialiased coverage of q and `k_n(C)` the table
//!    that makes each sprite sum to exactly 1 (Fig. 5.5's per-size
//!    scaling), into one of **three per-pixel layers** (eq. 5.3):
//!    `l = 0` if `B(p) − B_v(q) < −δ C_v(q)`, `l = 2` if it is `> δ C_v(q)`,
//!    else `l = 1`; H samples go to `M¹`/`M²` (added to `L¹`/`L²` as they
//!    come, §5.1.5). The sources are splatted in parallel by bands of
//!    destination rows ([`BAND_ROWS`]): each band adds, in source order, the
//!    part of every sprite that falls on its rows, so the frame is the same
//!    whatever the thread count.
//! 5. **Composition and normalisation** (eq. 5.4): `D ← L²`,
//!    `D ← L¹ + (1 − L¹_a) D`, `D ← L⁰ + (1 − L⁰_a) D`, each `D` with
//!    non-zero alpha divided by its alpha; then encoded with the renderer's
//!    gamma.
//! 6. **Defocused highlights** (§5.2, eq. 5.5, LDR; off by default, see
//!    [`Highlights`]): a bright sample's colour is extrapolated,
//!    `F ← ((1 − λ_n^β) + λ_n^β γ) F` where `λ > λ₀`, before it is splatted.
//!
//! **Sharp pixels are bit-exact**: a pixel whose layers 0 and 1 receive
//! nothing but its own visible sample at full weight (its CoC is at most
//! 1 px, so the sprite covers only itself, and no other sprite of layer
//! 0 or 1 reaches it) keeps its byte: `D = L¹ + 0·D` is its own colour. In
//! particular every pixel whose CoC and whose neighbours' CoC, within
//! `MAX_COC_PX/2 + 1` px, are under 0.5 px is left unchanged (no hidden
//! sample exists there either: test (b) sees no depth change inside a
//! sub-pixel CoC). Pupil 0 is the identity.
//!
//! **Decisions where the seed is silent** (SEED-NOTES §1.3 "Gaps"):
//! - **Hidden surfaces by rays, by object**: the seed's depth offset
//!   `ε = 0.05` (same object out, second-nearest in) is replaced by the
//!   exact test it approximates: the first surface of another object along
//!   the pixel's ray. A hidden part of the visible object itself (a
//!   concave object behind its own front) is not represented. Where the
//!   ray leaves the scene, the hidden surface is the background.
//! - **Eq. 5.1** is read signed, as printed (deeper neighbours mean a
//!   foreground edge), with each depth difference normalised by the
//!   pixel's own depth and clamped to [−1, 1] (a background neighbour,
//!   infinitely deep, counts 1); "0.01 normalised" is 1 % of the pixel's
//!   depth. The 12 "random Poisson-disk" samples are a fixed
//!   golden-angle (Vogel) spiral filling the CoC disc, rounded to pixels,
//!   so a frame is deterministic.
//! - **Sprite footprint**: the seed's rasterised point sprites (Fig. 5.5)
//!   are replaced by an antialiased disc, `cov = clamp(C/2 + 1/2 − ‖q − p‖,
//!   0, 1)`, which is continuous in C; `k_n(C) = 1/Σ_q cov` is tabulated
//!   for diameters quantised to 1/[`COC_STEPS_PER_PX`] px up to
//!   [`MAX_COC_PX`], so every sprite sums to exactly 1 (off-frame parts are
//!   lost, and the normalisation restores the intensity at the borders).
//!   A CoC above [`MAX_COC_PX`] is splatted at that size (the cost is
//!   O(C²) per pixel; Lee's parameters need retuning above 32 px anyway).
//! - **δ** = [`DELTA`] = 0.4 ("for most examples"); `C_v(q)` in eq. 5.3 is
//!   floored at [`DELTA_FLOOR_PX`] = 1 px: at the focal plane `δ·C_v = 0`
//!   would split one in-focus surface by its sub-pixel depth differences.
//! - **H in front of q**: `M⁰` is not defined (§5.1.4); an H sample that
//!   eq. 5.3 puts in front of q's visible surface is added to `M¹`.
//! - **Alpha above 1** (additive splats): before "over", a layer with
//!   `α > 1` is normalised to `α = 1` (its colour divided by α), so
//!   `1 − α` never goes negative.
//! - **Highlights** (eq. 5.5) work on linear light, λ from the linear
//!   colour, and ramp in with the sample's CoC (none at C ≤ 1 px, full
//!   from 2 px): a sharp pixel is never brightened. The reference the
//!   tests compare against clamps every ray to the display's [0, 1], as
//!   an LDR frame does, so highlights are off by default.
//! - **On the GPU** (`gpu::splat`, `splat.wgsl`) the same steps run
//!   between the cast and the read-back, the hidden image cast there too
//!   (`raycast::gpu::GpuFrame::cast_hidden`), the sums in exact fixed
//!   point (2⁻²⁴, 64-bit); this CPU pass is its reference
//!   (`tests/gpu_splat.rs`, within 1/255 per channel).
//! - Not done: the §5.3 acceleration (quarter-resolution point array away
//!   from focus and partial occlusion) and bokeh textures (the IDF is the
//!   uniform disc); at most one hidden image (Lee's).

use foveation::thin_lens::EyeLens;
use raycast::layers::{pixel_layers, MAX_LAYERS};
use raycast::ray::TriangleTest;
use raycast::scene::{DofFocus, DofRefocus};
use raycast::{Frame, NO_OBJECT};
use rayon::prelude::*;

use super::depth_of_field::{coc_px, is_pinhole, screen_of, Focuser};
use super::refocus::Refocus;
use super::{Pass, PassInput};
use crate::colour;
use crate::plan::Channels;

/// Largest CoC diameter splatted, px; larger ones are splatted at this size.
pub const MAX_COC_PX: f32 = 64.0;

/// Steps per px of the quantised sprite diameter (the `k_n(C)` table).
pub const COC_STEPS_PER_PX: f32 = 64.0;

/// Eq. 5.3's δ (Lee: 0.3–0.5, 0.4 "for most examples").
pub const DELTA: f32 = 0.4;

/// Smallest `C_v(q)` (px) in eq. 5.3's tolerance `δ·C_v(q)`.
pub const DELTA_FLOOR_PX: f32 = 1.0;

/// Samples of eq. 5.1 within the CoC (Lee: "e.g., 12 Poisson disk samples").
pub const LAPLACIAN_SAMPLES: usize = 12;

/// Eq. 5.1's threshold (Lee: 0.01 normalised), in units of the pixel's depth.
pub const LAPLACIAN_THRESHOLD: f32 = 0.01;

/// Surfaces cast per hidden-image ray (the visible one, its back, and the
/// next object's front and back for closed meshes).
pub const HIDDEN_RAY_HITS: usize = MAX_LAYERS;

/// Destination rows per band of the parallel splat.
pub const BAND_ROWS: usize = 8;

/// Eq. 5.5's parameters (LDR defocused highlights).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Highlights {
    /// λ₀: luminance above which a colour is extrapolated (Lee: 0.8).
    pub threshold: f32,
    /// β: falloff exponent (Lee: 3).
    pub exponent: f32,
    /// γ: gain at full luminance (Lee: 2).
    pub gain: f32,
}

impl Default for Highlights {
    fn default() -> Self {
        Self {
            threshold: 0.8,
            exponent: 3.0,
            gain: 2.0,
        }
    }
}

impl Highlights {
    /// Eq. 5.5 on a linear colour; `weight` ∈ [0, 1] scales the
    /// extrapolation (1: the seed's). Never NaN for finite input.
    pub fn apply(&self, rgb: [f32; 3], weight: f32) -> [f32; 3] {
        let lambda = 0.3 * rgb[0] + 0.59 * rgb[1] + 0.11 * rgb[2];
        let l0 = self.threshold;
        // Only a bright colour, a valid threshold and a positive weight
        // (NaN in any of them: unchanged).
        let bright = lambda > l0 && l0 < 1.0 && weight > 0.0;
        if !bright {
            return rgb;
        }
        let ln = ((lambda - l0) / (1.0 - l0)).min(1.0);
        let lb = ln.powf(self.exponent);
        let scale = (1.0 - lb) + lb * self.gain;
        let scale = 1.0 + (scale - 1.0) * weight.min(1.0);
        if scale.is_finite() {
            rgb.map(|c| c * scale)
        } else {
            rgb
        }
    }
}

/// One splat source: linear colour, signed CoC (px) and quantised diameter.
#[derive(Debug, Clone, Copy, Default)]
struct Sample {
    rgb: [f32; 3],
    /// Signed CoC `B`, px, in [−MAX_COC_PX, MAX_COC_PX].
    b: f32,
    /// Diameter in 1/COC_STEPS_PER_PX px (index into the `k_n` table).
    c: u16,
}

impl Sample {
    fn radius(&self) -> f32 {
        f32::from(self.c) / COC_STEPS_PER_PX * 0.5
    }
}

/// Per-pixel accumulation: layers 0..3, premultiplied RGB and alpha.
type Acc = [[f32; 4]; 3];

/// The ch. 5 depth-of-field pass.
#[derive(Debug)]
pub struct DepthOfFieldSplat {
    /// The eye; `aperture_mm` is the pupil diameter (0: the identity).
    pub lens: EyeLens,
    /// Where the pass focuses (the scene's `focus`: fixed distance, gaze, vergence, attention).
    pub focus: DofFocus,
    /// Eq. 5.3's δ.
    pub delta: f32,
    /// Cast and splat the hidden image H (Lee's "with H"); off, V alone
    /// ("without H", his 32.84 dB against 36.33 dB).
    pub hidden: bool,
    /// Eq. 5.1's threshold; hidden fragments with a smaller 𝓛 are dropped.
    pub laplacian_threshold: f32,
    /// Eq. 5.5's LDR highlights; `None` (the default): off.
    pub highlights: Option<Highlights>,
    /// The ray/triangle test for the hidden rays (the renderer's default).
    pub test: TriangleTest,
    /// Where the pass focuses (shared with the ch. 4 pass; the GPU path
    /// settles its focus here too).
    pub(crate) focuser: Focuser,
    /// V samples, per pixel.
    visible: Vec<Sample>,
    /// H samples, per pixel.
    hidden_samples: Vec<Option<Sample>>,
    /// Destination's signed CoC and eq. 5.3 tolerance, per pixel.
    dest: Vec<(f32, f32)>,
    acc: Vec<Acc>,
    /// Whether layers 0–1 received more than the pixel's own sample at
    /// full weight.
    touched: Vec<bool>,
    /// Hidden samples found in the last frame.
    hidden_count: usize,
}

impl DepthOfFieldSplat {
    /// The pass for an eye `lens` focusing by `focus`, with the default δ,
    /// hidden image, Laplacian threshold and triangle test, and no highlights.
    pub fn new(lens: EyeLens, focus: DofFocus) -> Self {
        Self {
            lens,
            focus,
            delta: DELTA,
            hidden: true,
            laplacian_threshold: LAPLACIAN_THRESHOLD,
            highlights: None,
            test: TriangleTest::default(),
            focuser: Focuser::new(focus),
            visible: Vec::new(),
            hidden_samples: Vec::new(),
            dest: Vec::new(),
            acc: Vec::new(),
            touched: Vec::new(),
            hidden_count: 0,
        }
    }

    /// The pass refocusing as `refocus` says (default `Instant`).
    pub fn with_refocus(mut self, refocus: DofRefocus) -> Self {
        self.focuser.refocus = Refocus::new(refocus);
        self
    }

    /// How the focal depth follows its target.
    pub fn refocus(&self) -> DofRefocus {
        self.focuser.refocus.mode
    }

    /// The focal depth of the last frame blurred, mm; `None` before any.
    pub fn focal_depth_mm(&self) -> Option<f64> {
        self.focuser.refocus.focus_mm()
    }

    /// The pass a scene's `DepthOfField(…, method: Splat)` asks for.
    pub fn from_effect(effect: &raycast::scene::PostPass) -> Option<Self> {
        match effect {
            raycast::scene::PostPass::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                method: raycast::scene::DofMethod::Splat,
                // The scene refuses it with Splat (partial occlusion is
                // what the hidden image does).
                smooth_foreground: _,
                highlights,
            } => {
                let mut pass = Self::new(
                    EyeLens {
                        focal_length_mm: *focal_length_mm,
                        aperture_mm: *pupil_mm,
                        retina_distance_mm: *retina_distance_mm,
                    },
                    *focus,
                )
                .with_refocus(*refocus);
                pass.highlights = highlights.then(Highlights::default);
                Some(pass)
            }
            _ => None,
        }
    }

    /// `focus: Attention`'s model, read only.
    pub fn attention(&self) -> Option<&crate::frame_attention::FrameAttention> {
        self.focuser.attention()
    }

    /// Hidden-image samples splatted in the last frame.
    pub fn hidden_samples(&self) -> usize {
        self.hidden_count
    }
}

/// Signed CoC `B` (px) of `depth_mm` for focus `focus_mm`: `−C` in front of
/// the focus, `+C` behind, `C` from [`coc_px`] clamped to [`MAX_COC_PX`];
/// 0 for NaN depth or a zero pupil; never NaN.
pub fn signed_coc_px(
    lens: &EyeLens,
    depth_mm: f64,
    focus_mm: f64,
    screen_distance_mm: f64,
    pixels_per_mm: f64,
) -> f32 {
    if depth_mm.is_nan() {
        return 0.0;
    }
    let c = coc_px(lens, depth_mm, focus_mm, screen_distance_mm, pixels_per_mm);
    let c = if c.is_nan() {
        0.0
    } else {
        c.min(f64::from(MAX_COC_PX)) as f32
    };
    // Compare as `coc_px` does: both clamped just beyond the focal length.
    let nearest = lens.focal_length_mm * (1.0 + 1e-9);
    let f = if focus_mm.is_nan() {
        f64::INFINITY
    } else {
        focus_mm.max(nearest)
    };
    let d = depth_mm.max(nearest);
    if d < f {
        -c
    } else if d > f {
        c
    } else {
        0.0
    }
}

/// `k_n(C)` (eq. 5.2) for every quantised diameter: 1 / Σ_q cov(q).
pub(crate) fn kn_table() -> &'static [f32] {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let n = (MAX_COC_PX * COC_STEPS_PER_PX) as usize;
        (0..=n)
            .map(|i| {
                let r = i as f32 / COC_STEPS_PER_PX * 0.5;
                let rr = r + 0.5;
                let ext = rr.floor() as i32;
                let mut sum = 0.0f64;
                for dy in -ext..=ext {
                    for dx in -ext..=ext {
                        sum += f64::from(coverage(r, (dx * dx + dy * dy) as f32));
                    }
                }
                (1.0 / sum) as f32
            })
            .collect()
    })
}

/// The antialiased coverage of the pixel at squared distance `d2` by a
/// disc of radius `r`: `clamp(r + 1/2 − d, 0, 1)`.
#[inline]
fn coverage(r: f32, d2: f32) -> f32 {
    let inner = r - 0.5;
    if inner > 0.0 && d2 <= inner * inner {
        1.0
    } else {
        (r + 0.5 - d2.sqrt()).clamp(0.0, 1.0)
    }
}

/// Eq. 5.3: the layer of a source of signed CoC `b` at a destination of
/// (signed CoC, tolerance) `dest`.
#[inline]
fn layer(b: f32, dest: (f32, f32)) -> usize {
    let d = b - dest.0;
    if d < -dest.1 {
        0
    } else if d > dest.1 {
        2
    } else {
        1
    }
}

/// The 12-point golden-angle spiral of eq. 5.1 on the unit disc.
pub(crate) fn spiral() -> &'static [[f32; 2]; LAPLACIAN_SAMPLES] {
    static S: std::sync::OnceLock<[[f32; 2]; LAPLACIAN_SAMPLES]> = std::sync::OnceLock::new();
    S.get_or_init(|| {
        let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
        let mut s = [[0.0f32; 2]; LAPLACIAN_SAMPLES];
        for (k, p) in s.iter_mut().enumerate() {
            let r = ((k as f64 + 0.5) / LAPLACIAN_SAMPLES as f64).sqrt();
            let a = golden * k as f64;
            *p = [(r * a.cos()) as f32, (r * a.sin()) as f32];
        }
        s
    })
}

/// Eq. 5.1 at pixel (`x`, `y`) of CoC `c` px over `depth` (w × h).
fn laplacian(depth: &[f32], (w, h): (usize, usize), x: usize, y: usize, c: f32) -> f32 {
    let zp = depth[y * w + x];
    let radius = 0.5 * c;
    let mut sum = 0.0f32;
    for &[u, v] in spiral() {
        let nx = (x as f32 + u * radius).round().clamp(0.0, (w - 1) as f32) as usize;
        let ny = (y as f32 + v * radius).round().clamp(0.0, (h - 1) as f32) as usize;
        let zn = depth[ny * w + nx];
        let term = if zn == zp {
            0.0 // also both infinite
        } else if zn.is_infinite() && zn > 0.0 {
            1.0
        } else {
            ((zn - zp) / zp).clamp(-1.0, 1.0)
        };
        if !term.is_nan() {
            sum += term;
        }
    }
    sum / LAPLACIAN_SAMPLES as f32
}

impl Pass for DepthOfFieldSplat {
    fn name(&self) -> &'static str {
        "depth of field (Lee ch. 5, splatting)"
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reads(&self) -> Channels {
        // The hidden image needs the object ids whatever the focus.
        Channels::COLOUR | Channels::HIT | Channels::DEPTH | Channels::ID
    }

    fn owns(&self) -> String {
        "the V and H samples, the hidden image and three accumulation layers".into()
    }

    fn into_gpu(self: Box<Self>) -> Result<Box<dyn super::GpuPass>, Box<dyn Pass>> {
        Ok(Box::new(crate::gpu::GpuSplat::new(*self)))
    }

    fn run(&mut self, frame: &mut Frame, input: &PassInput<'_>) {
        let (w, h) = (frame.width_px as usize, frame.height_px as usize);
        let Some(n) = w.checked_mul(h) else { return };
        if n == 0 || !frame.has_surface() || frame.len() != n || frame.rgb.len() < 3 * n {
            return;
        }
        self.hidden_count = 0;
        if is_pinhole(&self.lens) {
            return; // pupil 0: a pinhole, everything sharp
        }
        let focus = self.focuser.focus_mm(self.focus, frame, input);
        let (ds, ppmm) = screen_of(input.camera);
        let lens = self.lens;
        let delta = if self.delta.is_finite() {
            self.delta.max(0.0)
        } else {
            DELTA
        };
        let highlights = self.highlights;
        let quantise = |b: f32| (b.abs().min(MAX_COC_PX) * COC_STEPS_PER_PX).round() as u16;
        let boost = |rgb: [f32; 3], c: f32| match highlights {
            Some(hl) => hl.apply(rgb, (c - 1.0).clamp(0.0, 1.0)),
            None => rgb,
        };

        // 2. V: colour, signed CoC, the destination's tolerance.
        let lut = colour::decode_lut();
        self.visible.resize(n, Sample::default());
        self.dest.resize(n, (0.0, 0.0));
        let depth = &frame.depth_mm;
        let rgb = &frame.rgb;
        self.visible
            .par_iter_mut()
            .zip(self.dest.par_iter_mut())
            .enumerate()
            .for_each(|(i, (s, d))| {
                let b = signed_coc_px(&lens, f64::from(depth[i]), focus, ds, ppmm);
                let c = b.abs();
                let px = [
                    lut[rgb[3 * i] as usize],
                    lut[rgb[3 * i + 1] as usize],
                    lut[rgb[3 * i + 2] as usize],
                ];
                *s = Sample {
                    rgb: boost(px, c),
                    b,
                    c: quantise(b),
                };
                *d = (b, delta * c.max(DELTA_FLOOR_PX));
            });
        // 3. H: the second-nearest object, where the seed's tests pass.
        self.hidden_samples.clear();
        self.hidden_samples.resize(n, None);
        if self.hidden {
            let threshold = self.laplacian_threshold;
            let visible = &self.visible;
            let object = &frame.object;
            let hit = &frame.hit;
            let scene = input.scene;
            let camera = input.camera;
            let test = self.test;
            let background = scene.background.to_array().map(|c| c.clamp(0.0, 1.0));
            let cast_ok = camera.width_px as usize == w && camera.height_px as usize == h;
            let b_bg = signed_coc_px(&lens, f64::INFINITY, focus, ds, ppmm);
            if cast_ok {
                self.hidden_samples
                    .par_chunks_mut(w)
                    .enumerate()
                    .for_each(|(y, row)| {
                        for (x, slot) in row.iter_mut().enumerate() {
                            let i = y * w + x;
                            let zv = depth[i];
                            // (a) the visible surface is not behind the focus.
                            let in_front = f64::from(zv) <= focus; // false for NaN
                            if !hit[i] || !in_front {
                                continue;
                            }
                            // (b) not completely hidden (eq. 5.1).
                            let c = visible[i].b.abs();
                            // No deeper neighbour at all (𝓛 ≤ 0) rejects
                            // whatever the threshold: sharp pixels stay exact.
                            let l = laplacian(depth, (w, h), x, y, c);
                            if l < threshold || l <= 0.0 {
                                continue;
                            }
                            // (c) the first surface of another object.
                            let Ok(layers) = pixel_layers(
                                scene,
                                camera,
                                x as u32,
                                y as u32,
                                HIDDEN_RAY_HITS,
                                test,
                            ) else {
                                continue;
                            };
                            let other = layers.as_slice().iter().skip(1).find(|l| {
                                l.hit.object != object[i]
                                    && l.hit.object != NO_OBJECT
                                    && l.depth_mm > zv
                            });
                            let (rgb, b) = match other {
                                Some(l) => (
                                    l.colour.to_array().map(|v| v.clamp(0.0, 1.0)),
                                    signed_coc_px(&lens, f64::from(l.depth_mm), focus, ds, ppmm),
                                ),
                                None if layers.exhausted() => (background, b_bg),
                                None => continue,
                            };
                            *slot = Some(Sample {
                                rgb: boost(rgb, b.abs()),
                                b,
                                c: quantise(b),
                            });
                        }
                    });
            }
        }
        self.hidden_count = self.hidden_samples.iter().filter(|s| s.is_some()).count();
        let one_px = COC_STEPS_PER_PX as u16;
        if self.visible.iter().all(|s| s.c <= one_px)
            && self.hidden_samples.iter().flatten().all(|s| s.c <= one_px)
        {
            // Every sprite covers its own pixel only (and highlights ramp
            // in above 1 px): nothing moves.
            return;
        }

        // 4. Splat by bands of destination rows.
        let kn = kn_table();
        // Per source row: the farthest row any of its sprites reaches.
        let reach: Vec<usize> = (0..h)
            .map(|y| {
                let row = &self.visible[y * w..(y + 1) * w];
                let hid = &self.hidden_samples[y * w..(y + 1) * w];
                let r = row
                    .iter()
                    .map(|s| s.c)
                    .chain(hid.iter().flatten().map(|s| s.c))
                    .max()
                    .unwrap_or(0);
                let r = f32::from(r) / COC_STEPS_PER_PX * 0.5;
                (r + 0.5).floor() as usize
            })
            .collect();
        let max_reach = reach.iter().copied().max().unwrap_or(0);
        self.acc.clear();
        self.acc.resize(n, [[0.0; 4]; 3]);
        self.touched.clear();
        self.touched.resize(n, false);
        let visible = &self.visible;
        let hidden = &self.hidden_samples;
        let dest = &self.dest;
        self.acc
            .par_chunks_mut(BAND_ROWS * w)
            .zip(self.touched.par_chunks_mut(BAND_ROWS * w))
            .enumerate()
            .for_each(|(band, (acc, touched))| {
                let y0 = band * BAND_ROWS;
                let y1 = y0 + acc.len() / w;
                let mut band = Band {
                    acc,
                    touched,
                    dest: &dest[y0 * w..y1 * w],
                    w,
                    y0,
                    y1,
                    kn,
                };
                let from = y0.saturating_sub(max_reach);
                let to = (y1 + max_reach).min(h);
                for (ys, &r) in reach.iter().enumerate().take(to).skip(from) {
                    if ys + r < y0 || ys >= y1 + r {
                        continue;
                    }
                    for xs in 0..w {
                        let i = ys * w + xs;
                        band.splat(xs, ys, &visible[i], true);
                        if let Some(s) = &hidden[i] {
                            band.splat(xs, ys, s, false);
                        }
                    }
                }
            });

        // 5. Composition and normalisation (eq. 5.4).
        let acc = &self.acc;
        let touched = &self.touched;
        frame
            .rgb
            .par_chunks_mut(3 * w)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let i = y * w + x;
                    if !touched[i] {
                        continue; // its own sharp sample over the rest: itself
                    }
                    let c = compose(&acc[i]);
                    row[3 * x..3 * x + 3].copy_from_slice(&colour::encode3(c));
                }
            });
    }
}

/// One band of destination rows being splatted into.
struct Band<'a> {
    acc: &'a mut [Acc],
    touched: &'a mut [bool],
    dest: &'a [(f32, f32)],
    w: usize,
    y0: usize,
    y1: usize,
    kn: &'a [f32],
}

impl Band<'_> {
    /// Adds the part of `s`'s sprite (centred on pixel `xs`, `ys`) on the
    /// band's rows; `own` for a V sample (it may land on its own pixel).
    #[inline]
    fn splat(&mut self, xs: usize, ys: usize, s: &Sample, own: bool) {
        let r = s.radius();
        if r <= 0.5 {
            // C ≤ 1 px: the sprite covers its own pixel, at weight 1.
            if (self.y0..self.y1).contains(&ys) {
                let q = (ys - self.y0) * self.w + xs;
                let mut l = layer(s.b, self.dest[q]);
                if !own && l == 0 {
                    l = 1;
                }
                let slot = &mut self.acc[q][l];
                slot[0] += s.rgb[0];
                slot[1] += s.rgb[1];
                slot[2] += s.rgb[2];
                slot[3] += 1.0;
                if l < 2 && !own {
                    self.touched[q] = true;
                }
            }
            return;
        }
        let rr = r + 0.5;
        let ext = rr.floor() as usize;
        let kn = self.kn[usize::from(s.c).min(self.kn.len() - 1)];
        let lo = ys.saturating_sub(ext).max(self.y0);
        let hi = (ys + ext + 1).min(self.y1);
        let w = self.w;
        for yd in lo..hi {
            let dy = yd as f32 - ys as f32;
            let span2 = rr * rr - dy * dy;
            if span2 < 0.0 {
                continue;
            }
            let half = span2.sqrt().floor() as usize;
            let x_lo = xs.saturating_sub(half);
            let x_hi = (xs + half + 1).min(w);
            let base = (yd - self.y0) * w;
            for xd in x_lo..x_hi {
                let dx = xd as f32 - xs as f32;
                let cov = coverage(r, dx * dx + dy * dy);
                if cov <= 0.0 {
                    continue;
                }
                let a = cov * kn;
                let q = base + xd;
                let mut l = layer(s.b, self.dest[q]);
                if !own && l == 0 {
                    l = 1; // M⁰ is not defined: hidden samples occlude nothing
                }
                let slot = &mut self.acc[q][l];
                slot[0] += a * s.rgb[0];
                slot[1] += a * s.rgb[1];
                slot[2] += a * s.rgb[2];
                slot[3] += a;
                if l < 2 {
                    self.touched[q] = true;
                }
            }
        }
    }
}

/// Eq. 5.4 with the normalisation: back to front, each `D` divided by its
/// alpha; a layer with alpha above 1 is normalised to 1 first.
fn compose(acc: &Acc) -> [f32; 3] {
    let mut d = [0.0f32; 3];
    let mut da = 0.0f32;
    for l in [2usize, 1, 0] {
        let [r, g, b, a] = acc[l];
        let (mut c, mut a) = ([r, g, b], a);
        if l == 2 {
            // D ← L²
            if a > 0.0 {
                d = c.map(|v| v / a);
                da = 1.0;
            }
            continue;
        }
        if a > 1.0 {
            c = c.map(|v| v / a);
            a = 1.0;
        }
        let t = 1.0 - a;
        for k in 0..3 {
            d[k] = c[k] + t * d[k];
        }
        da = a + t * da;
        if da > 0.0 {
            d = d.map(|v| v / da);
            da = 1.0;
        }
    }
    d.map(|v| if v.is_finite() { v } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_sprite_sums_to_one_and_a_small_one_covers_its_pixel_only() {
        let kn = kn_table();
        for i in [0usize, 1, 32, 64, 65, 100, 640, 4096] {
            let r = i as f32 / COC_STEPS_PER_PX * 0.5;
            let ext = (r + 0.5).floor() as i32;
            let mut sum = 0.0f64;
            for dy in -ext..=ext {
                for dx in -ext..=ext {
                    sum += f64::from(coverage(r, (dx * dx + dy * dy) as f32) * kn[i]);
                }
            }
            assert!((sum - 1.0).abs() < 1e-4, "{i}: {sum}");
        }
        // C ≤ 1 px: the disc covers the own pixel only (splatted at
        // weight exactly 1).
        for i in 0..=64usize {
            let r = i as f32 / COC_STEPS_PER_PX * 0.5;
            assert_eq!(coverage(r, 1.0), 0.0, "{i}");
        }
    }

    #[test]
    fn the_layers_follow_eq_5_3() {
        let dest = (2.0, 0.4 * 2.0);
        assert_eq!(layer(-10.0, dest), 0);
        assert_eq!(layer(2.5, dest), 1);
        assert_eq!(layer(1.3, dest), 1);
        assert_eq!(layer(3.0, dest), 2);
    }

    #[test]
    fn composition_is_over_with_normalisation() {
        // A half-covering front layer over an opaque hidden one.
        let mut acc: Acc = [[0.0; 4]; 3];
        acc[0] = [0.5, 0.0, 0.0, 0.5];
        acc[2] = [0.0, 0.0, 2.0, 2.0];
        let c = compose(&acc);
        assert!(
            (c[0] - 0.5).abs() < 1e-6 && (c[2] - 0.5).abs() < 1e-6,
            "{c:?}"
        );
        // Hypo intensities are normalised; alpha above 1 is clamped.
        acc = [[0.0; 4]; 3];
        acc[1] = [0.3, 0.3, 0.3, 0.5];
        assert_eq!(compose(&acc), [0.6; 3]);
        acc[1] = [1.2, 0.0, 0.0, 1.5];
        acc[2] = [0.0, 1.0, 0.0, 1.0];
        let c = compose(&acc);
        assert!((c[0] - 0.8).abs() < 1e-6 && c[1] == 0.0, "{c:?}");
        assert_eq!(compose(&[[0.0; 4]; 3]), [0.0; 3]);
    }

    #[test]
    fn highlights_follow_eq_5_5() {
        let hl = Highlights::default();
        assert_eq!(hl.apply([0.5; 3], 1.0), [0.5; 3]);
        let white = hl.apply([1.0; 3], 1.0);
        assert!((white[0] - 2.0).abs() < 1e-6);
        // λ = 0.9: λ_n = 0.5, λ_n³ = 0.125, gain 1.125.
        let c = hl.apply([0.9; 3], 1.0);
        assert!((c[0] - 0.9 * 1.125).abs() < 1e-5, "{c:?}");
        assert_eq!(hl.apply([1.0; 3], 0.0), [1.0; 3]);
        assert!(hl.apply([f32::NAN; 3], 1.0)[0].is_nan());
    }

    #[test]
    fn the_signed_coc_is_negative_in_front_and_zero_at_focus() {
        let lens = EyeLens::default();
        assert!(signed_coc_px(&lens, 300.0, 600.0, 540.0, 2.0) < 0.0);
        assert!(signed_coc_px(&lens, 1200.0, 600.0, 540.0, 2.0) > 0.0);
        assert_eq!(signed_coc_px(&lens, 600.0, 600.0, 540.0, 2.0), 0.0);
        assert_eq!(
            signed_coc_px(&lens, f64::INFINITY, f64::INFINITY, 540.0, 2.0),
            0.0
        );
        for d in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e300] {
            for f in [0.0, f64::NAN, f64::INFINITY, 16.7] {
                let b = signed_coc_px(&lens, d, f, 540.0, 2.0);
                assert!(!b.is_nan() && b.abs() <= MAX_COC_PX, "{d} {f} {b}");
            }
        }
    }
}
