//! Depth of field by nonlinear mipmap interpolation (Lee 2009, ch. 4,
//! "DOF1"), on the CPU, as a pass over the G-buffer.
//!
//! Per frame:
//! 1. **Focus** `d_f`: `Fixed(depth_mm)`, or `Gaze`: the median of the
//!    finite depths in a [`FOCUS_WINDOW_PX`]-wide square around the point
//!    of regard, ignoring the background (infinite depth). When the window
//!    holds no surface (gaze on the background or off the screen) the
//!    previous frame's focus is kept; before any, the eye is relaxed
//!    (focused at infinity). `Vergence`: the eye distance of the binocular
//!    3-D gaze point ([`PassInput::vergence_mm`], Murphy & Duchowski eqs.
//!    1–3) where the frame has one, else as `Gaze`. `Attention`: the mean
//!    eye distance of the object Lee's attention model (ch. 3,
//!    [`attention::AttentionTracker`] on this frame's colour, depth and
//!    object ids; every object of importance 1) attends; while none is
//!    attended the last focus is kept. The tracker exists only for this
//!    focus. The focal depth then follows this target as
//!    the scene's `refocus` says ([`super::refocus`], Lee §6.1): at once
//!    (`Instant`, the default), by a 300-ms transition (`Interpolate`) or a
//!    first-order low-pass (`LowPass`), in diopters, timed by the frame's
//!    time ([`PassInput::time_s`]).
//! 2. **Circle of confusion** per pixel by the thin lens (eq. 4.2–4.4,
//!    `foveation::thin_lens`): `C = DPI·(d_s/d_r)·R` with the display's real
//!    geometry: `DPI` the mean of the camera's pixels per mm in x and y,
//!    `d_s` the eye's perpendicular distance to the screen. Depth is the
//!    G-buffer's eye distance. Depths (or a focus) at or inside the focal
//!    length form no real image: they are clamped just beyond it, which
//!    gives the largest blur the pyramid holds; NaN depth is left sharp.
//! 3. **Degree of blur and level** (eq. 4.5–4.6): `σ = C/2`,
//!    `m = 0 if k_σ σ < 0.5 else 1 + log2(k_σ σ)`, clamped to the top level
//!    built. A pixel with `m = 0` (every pixel with `C < 1.5 px`, so every
//!    one under 0.5 px) is left **bit-exact**; pupil 0 is the identity.
//! 4. **Gaussian pyramid** (eq. 4.1) of the colour in linear light (the
//!    frame's bytes decoded with the renderer's gamma 2.2, `crate::colour`): level `l` is level `l − 1` filtered by
//!    a 3×3 Gaussian and halved in each axis, only up to the level the
//!    frame's largest `m` needs ([`MAX_LEVELS`] at most). **Anisotropic**
//!    (eq. 4.9, on by default): isotropic mips of depth Z and σ are built
//!    alongside, and a source texel q is left out of destination texel p
//!    (weight H = 0, the rest renormalised) when `σ_p(l) > σ_q(l−1) + δ`
//!    and `Z_p(l) > Z_f`, so a sharp in-focus object does not leak into the
//!    blurred background around it. The buffers are the pass's own and
//!    reused frame to frame; the pass exists only when the scene lists the
//!    effect. The colour levels, their sizes and bilinear lookup are
//!    `crate::pyramid`'s (shared with image-based foveation); the
//!    anisotropic 4×4 filter is this pass's own.
//! 5. **Nonlinear interpolation over the 8 circular neighbours** (eq. 4.8):
//!    with `l = ⌊m⌋`, `β = m − l`,
//!    `I_p(m) = (1 − β)·A_{l−1}(p) + β·A_l(p)`, where
//!    `A_k(p) = w_G Σ_{q∈Ω} G(q) I_{p + 2^k q}(k)` is the 9-point circular
//!    filter (centre and 8 neighbours on the unit circle, diagonals at
//!    (1/√2, 1/√2)) over level `k` sampled bilinearly at level-0
//!    positions, with offsets of one level-`k` texel (`2^k` px), and
//!    `A_{−1}(p) = I_p(0)`. One 3×3 step over level `k` approximates level
//!    `k + 1`, so the result is level `m` and continuous in `m` (β = 1 at
//!    one level equals β = 0 at the next); 2 × 9 lookups, no mip-biasing.
//!
//! **Decisions on the seed's gaps** (SEED-NOTES §1.2 "Gaps (chapter 4)"):
//! - (4.7)/(4.8) are printed as geometric blends (`I^{1−β} I^β`); this
//!   pass blends **linearly**, `(1 − β)·a + β·b`, in linear light: Lee's
//!   §4.4 calls the linear hardware blend only "marginally" different, and
//!   "nonlinear" names the log2 depth-to-level map.
//! - The 3×3 Gaussian's σ is **1 texel** ([`GAUSS_SIGMA_TEXELS`]) in both
//!   the pyramid (4.1) and the circular filter (4.8), so the 8 circular
//!   neighbours weigh `e^{−1/2}` against the centre's 1.
//! - The spacing of (4.8)'s offsets is not given; one texel of the level
//!   being sampled (see 5.) is the choice that makes the blend continuous.
//! - (4.9) gives no δ: [`ANISO_DELTA_PX`] = 0.75 px of σ (the σ at which
//!   eq. 4.6 starts to blur). Its σ_q is read one level finer than σ_p
//!   (the texels the filter reads); background depth is infinite, so any
//!   background in a texel's footprint makes it "behind the focus".
//!
//! **Foreground smoothing** (§4.3, eqs. 4.10–4.11) is an option
//! (`smooth_foreground: true` in the scene; off by default): the DoN mip ρ
//! and the smoothed σ(n) replace σ(0) around blurred foreground objects
//! (`smooth_foreground`). Off by default because it blurs in-focus pixels
//! beside a blurred foreground, which the rule "a pixel with CoC < 0.5 px
//! is unchanged" forbids; with it on, that rule holds only away from
//! blurred foreground objects, and the pass stays on the CPU on the GPU
//! backend. Ch. 5 splatting, which handles partial occlusion with the
//! hidden surface itself, is [`super::dof_splat`]. The GPU path (the same
//! pass in WGSL, before the frame's read-back) is `crate::gpu`. The ground truth it
//! is measured against is [`super::dof_reference`] (thin-lens distributed
//! ray casting, 64 rays per pixel).
//!
//! This file holds the pass; the focus search shared with ch. 5 is in
//! `focuser`, the gaze-window helpers (also used by the GPU path) in
//! `window`, the pass's pyramid and circular filter in `levels`, and
//! foreground smoothing in `foreground`.

mod focuser;
mod foreground;
mod levels;
mod window;

use foveation::thin_lens::{self, EyeLens};
use raycast::scene::DofFocus;
use raycast::Frame;
use rayon::prelude::*;

use super::refocus::Refocus;
use super::{Pass, PassInput};
use crate::colour;
use crate::plan::Channels;
use crate::pyramid;
use raycast::scene::DofRefocus;

pub(crate) use focuser::Focuser;
pub use focuser::ATTENTION_MAP_SIZE;
use foreground::smooth_foreground;
use levels::{blend, build_pyramid, Image};
pub(crate) use levels::{circular_weights, pyramid_taps, CIRCLE};
pub(crate) use window::{focus_window, median_depth};
pub use window::{gaze_depth_mm, FOCUS_WINDOW_PX};

/// Most pyramid levels above level 0 (σ up to 0.75·2^8 = 192 px).
pub const MAX_LEVELS: usize = 8;

/// σ of the 3×3 Gaussian (4.1, 4.8), in texels of the level it filters.
pub const GAUSS_SIGMA_TEXELS: f64 = 1.0;

/// The depth-of-field pass.
#[derive(Debug)]
pub struct DepthOfField {
    /// The eye; `aperture_mm` is the pupil diameter (0: the identity).
    pub lens: EyeLens,
    /// Where the pass focuses (the scene's `focus`: fixed distance, gaze, vergence, attention).
    pub focus: DofFocus,
    /// The focus search's state (last focus, refocusing, attention model;
    /// the GPU path settles its focus here too).
    pub(crate) focuser: Focuser,
    /// Mipmap level per pixel of the current frame.
    level: Vec<f32>,
    /// Level 0 (linear light, full size) and levels 1… of the pyramid.
    pyramid: Vec<Image>,
    /// Degree of blur σ (px) per pixel of the current frame.
    sigma: Vec<f32>,
    /// Build the colour pyramid with eq. 4.9's H (on by default); off, with
    /// the isotropic G of eq. 4.1.
    pub anisotropic: bool,
    /// Lee §4.3's foreground smoothing (eqs. 4.10–4.11); off by default.
    pub smooth_foreground: bool,
    /// Size of the frame `level` and `sigma` describe.
    maps_size: (usize, usize),
}

/// One frame's per-pixel maps of the pass, row-major.
#[derive(Debug, Clone, Copy)]
pub struct DofMaps<'a> {
    /// Frame width, pixels.
    pub width: usize,
    /// Frame height, pixels.
    pub height: usize,
    /// Degree of blur σ = CoC / 2 (eq. 4.5), px; capped at 10⁶.
    pub sigma_px: &'a [f32],
    /// The continuous mip level m (eq. 4.6); 0: the pixel is left as it is.
    pub level: &'a [f32],
}

impl DepthOfField {
    /// The pass for an eye `lens` focusing by `focus`; the pyramid uses eq. 4.9's
    /// anisotropic filter and the foreground is not smoothed (the defaults).
    pub fn new(lens: EyeLens, focus: DofFocus) -> Self {
        Self {
            lens,
            focus,
            focuser: Focuser::new(focus),
            level: Vec::new(),
            pyramid: Vec::new(),
            sigma: Vec::new(),
            anisotropic: true,
            smooth_foreground: false,
            maps_size: (0, 0),
        }
    }

    /// The object the attention focus attended in the last frame (`focus:
    /// Attention` only; `None` otherwise or when none was attended).
    pub fn attended_object(&self) -> Option<u32> {
        self.focuser.attended_object()
    }

    /// The last blurred frame's maps (σ and mip level per pixel), for debug
    /// pictures. With foreground smoothing the level is the smoothed one
    /// (from σ(n)), σ the pixel's own; `None` before any frame or when the last frame was not
    /// blurred at all (pupil 0, an empty frame).
    pub fn maps(&self) -> Option<DofMaps<'_>> {
        let (w, h) = self.maps_size;
        (w * h > 0 && self.level.len() == w * h && self.sigma.len() == w * h).then_some(DofMaps {
            width: w,
            height: h,
            sigma_px: &self.sigma,
            level: &self.level,
        })
    }

    /// Whether the pass holds an attention model (only `focus: Attention`).
    pub fn has_attention_model(&self) -> bool {
        self.attention().is_some()
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

    /// The focal depth of the last frame the pass blurred (after the
    /// refocusing dynamics), mm; `None` before any.
    pub fn focal_depth_mm(&self) -> Option<f64> {
        self.focuser.refocus.focus_mm()
    }

    /// Number of pyramid levels (level 0 included) allocated so far.
    pub fn allocated_levels(&self) -> usize {
        self.pyramid.len()
    }

    /// The pass for a scene's `DepthOfField` effect of the mipmap method;
    /// `None` for any other (the splatting method is another pass).
    pub fn from_effect(effect: &raycast::scene::PostPass) -> Option<Self> {
        match effect {
            raycast::scene::PostPass::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                method: raycast::scene::DofMethod::Mipmap,
                smooth_foreground,
                // The scene refuses highlights with the mipmap method.
                highlights: _,
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
                pass.smooth_foreground = *smooth_foreground;
                Some(pass)
            }
            _ => None,
        }
    }

    /// `focus: Attention`'s model, read only.
    pub fn attention(&self) -> Option<&crate::frame_attention::FrameAttention> {
        self.focuser.attention()
    }
}

/// Whether the pupil of `lens` is zero (or invalid): a depth-of-field pass
/// (either chapter's) is then the identity and does not even update its
/// focus.
pub(crate) fn is_pinhole(lens: &EyeLens) -> bool {
    lens.aperture_mm.is_nan() || lens.aperture_mm <= 0.0
}

/// The screen as the pass sees it: (`d_s`, the eye's distance to the
/// screen in mm; the mean pixels per mm of x and y), as in `run`.
pub(crate) fn screen_of(camera: &raycast::Camera) -> (f64, f64) {
    let pitch = camera.pitch();
    let ppmm = 0.5 * (1.0 / f64::from(pitch[0]) + 1.0 / f64::from(pitch[1]));
    (f64::from(camera.eye.z), ppmm)
}

/// The top pyramid level a `w`×`h` frame allows (at most [`MAX_LEVELS`]),
/// as in `run`.
pub(crate) fn top_level(w: usize, h: usize) -> usize {
    pyramid::top_level(w, h, MAX_LEVELS)
}

/// Circle of confusion on the screen, px, for `depth_mm` while the eye
/// focuses at `focus_mm` (eq. 4.2–4.4), total: 0 for a zero (or invalid)
/// pupil or a NaN depth; depths and focus at or inside the focal length are
/// clamped just beyond it (a huge, finite or infinite, CoC); never NaN.
pub fn coc_px(
    lens: &EyeLens,
    depth_mm: f64,
    focus_mm: f64,
    screen_distance_mm: f64,
    pixels_per_mm: f64,
) -> f64 {
    let valid = |v: f64| v.is_finite() && v > 0.0;
    if !valid(lens.aperture_mm)
        || !valid(lens.focal_length_mm)
        || !valid(lens.retina_distance_mm)
        || !valid(screen_distance_mm)
        || !valid(pixels_per_mm)
        || depth_mm.is_nan()
    {
        return 0.0;
    }
    let nearest = lens.focal_length_mm * (1.0 + 1e-9);
    let focus = if focus_mm.is_nan() {
        f64::INFINITY
    } else {
        focus_mm.max(nearest)
    };
    let c = lens
        .coc_px(
            depth_mm.max(nearest),
            focus,
            screen_distance_mm,
            pixels_per_mm,
        )
        .unwrap_or(f64::INFINITY);
    if c.is_nan() {
        f64::INFINITY
    } else {
        c
    }
}

/// The continuous mipmap level for a CoC of `coc_px` (σ = C/2, eq. 4.6),
/// at most `max_level`; 0 for NaN.
pub fn level_for_coc(coc_px: f64, max_level: f64) -> f64 {
    let m = thin_lens::mipmap_level(thin_lens::degree_of_blur(coc_px));
    if m.is_nan() {
        0.0
    } else {
        m.clamp(0.0, max_level)
    }
}

impl Pass for DepthOfField {
    fn name(&self) -> &'static str {
        match self.focus {
            DofFocus::Gaze => "depth of field (Lee ch. 4, focus at the gaze's depth)",
            DofFocus::Fixed { .. } => "depth of field (Lee ch. 4, fixed focus)",
            DofFocus::Vergence => "depth of field (Lee ch. 4, focus at the vergence depth, else the gaze's)",
            DofFocus::Attention => "depth of field (Lee ch. 4, focus on the attended object: Lee ch. 3 saliency at 64²)",
        }
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reads(&self) -> Channels {
        let ids = if self.focus == DofFocus::Attention {
            Channels::ID
        } else {
            Channels::NONE
        };
        Channels::COLOUR | Channels::HIT | Channels::DEPTH | ids
    }

    fn owns(&self) -> String {
        "a colour pyramid with its depth and blur mips, the CoC and level maps".into()
    }

    fn into_gpu(self: Box<Self>) -> Result<Box<dyn super::GpuPass>, Box<dyn Pass>> {
        Ok(Box::new(crate::gpu::GpuDof::new(*self)))
    }

    fn run(&mut self, frame: &mut Frame, input: &PassInput<'_>) {
        self.maps_size = (0, 0);
        let (w, h) = (frame.width_px as usize, frame.height_px as usize);
        if w == 0 || h == 0 || !frame.has_surface() || frame.rgb.len() < 3 * w * h {
            return;
        }
        if is_pinhole(&self.lens) {
            return; // pupil 0: a pinhole, everything sharp
        }
        let focus = self.focuser.focus_mm(self.focus, frame, input);
        let (ds, ppmm) = screen_of(input.camera);
        let top = top_level(w, h);
        self.level.clear();
        self.level.reserve(w * h);
        self.sigma.clear();
        self.sigma.reserve(w * h);
        self.maps_size = (w, h);
        let mut max_m = 0.0f64;
        for &d in &frame.depth_mm {
            let c = coc_px(&self.lens, f64::from(d), focus, ds, ppmm);
            let m = level_for_coc(c, top as f64);
            max_m = max_m.max(m);
            self.level.push(m as f32);
            let sigma = thin_lens::degree_of_blur(c) as f32;
            self.sigma.push(sigma.min(SIGMA_CAP_PX));
        }
        if max_m <= 0.0 {
            return;
        }
        // Levels 0..=needed: β > 0 at l = ⌊m⌋ reads level l; m ≤ top.
        let needed = (max_m.ceil() as usize).min(top);
        build_pyramid(
            &mut self.pyramid,
            &frame.rgb,
            &frame.depth_mm,
            &self.sigma,
            (w, h),
            needed,
            focus,
            self.anisotropic,
        );
        if self.smooth_foreground && needed >= 1 {
            smooth_foreground(&mut self.pyramid, &mut self.level, (w, h), needed, focus);
        }
        // Rows in parallel: each pixel reads the pyramid and writes itself.
        let pyramid = &self.pyramid;
        frame.rgb[..3 * w * h]
            .par_chunks_mut(3 * w)
            .zip(self.level.par_chunks(w))
            .enumerate()
            .for_each(|(y, (row, levels))| {
                for (x, &m) in levels.iter().enumerate() {
                    if m <= 0.0 {
                        continue;
                    }
                    let c = blend(pyramid, x, y, f64::from(m));
                    for (byte, v) in row[3 * x..3 * x + 3].iter_mut().zip(c) {
                        *byte = colour::encode(v);
                    }
                }
            });
    }
}

/// The anisotropic filter's tolerance δ (eq. 4.9), in px of σ: a source
/// texel at most this much sharper than the destination still counts.
pub const ANISO_DELTA_PX: f32 = 0.75;

/// Largest σ the pyramid's blur buffer holds (px): keeps sums finite.
pub(crate) const SIGMA_CAP_PX: f32 = 1e6;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lees_vr_example_is_under_ten_pixels() {
        // Lee §4.6: 1024×768 on 3.2 m × 2.4 m at 3 m (0.32 px/mm),
        // d_s/d_r = 125, E = 4 mm, F = 17 mm, nearest object at 300 mm.
        let lens = EyeLens {
            focal_length_mm: 17.0,
            aperture_mm: 4.0,
            retina_distance_mm: 24.0,
        };
        let at_inf = coc_px(&lens, 300.0, f64::INFINITY, 3000.0, 0.32);
        let at_screen = coc_px(&lens, 300.0, 3000.0, 3000.0, 0.32);
        assert!((at_inf - 9.07).abs() < 0.01, "{at_inf}");
        assert!((at_screen - 8.21).abs() < 0.01, "{at_screen}");
        assert!(at_inf <= 10.0 && at_screen <= 10.0);
    }

    #[test]
    fn the_blend_is_continuous_across_integer_levels() {
        let mut img = Image::default();
        img.reshape(16, 16);
        for (i, p) in img.px.iter_mut().enumerate() {
            *p = [((i * 37) % 11) as f32 / 11.0; 3];
        }
        let mut dof = DepthOfField::new(EyeLens::default(), DofFocus::Gaze);
        let rgb: Vec<u8> = img
            .px
            .iter()
            .flat_map(|p| p.map(|v| (v * 255.0) as u8))
            .collect();
        let depth = vec![1000.0f32; 256];
        let sigma = vec![4.0f32; 256];
        build_pyramid(
            &mut dof.pyramid,
            &rgb,
            &depth,
            &sigma,
            (16, 16),
            3,
            500.0,
            true,
        );
        for m in [1.0f64, 2.0] {
            let below = blend(&dof.pyramid, 7, 5, m - 1e-6);
            let at = blend(&dof.pyramid, 7, 5, m);
            for c in 0..3 {
                assert!((below[c] - at[c]).abs() < 1e-4, "m = {m}: {below:?} {at:?}");
            }
        }
    }

    #[test]
    fn degenerate_inputs_give_no_nan() {
        let lens = EyeLens {
            aperture_mm: 1e6,
            ..EyeLens::default()
        };
        for d in [0.0, -5.0, 16.7, f64::INFINITY, f64::NAN, 1e300] {
            for f in [0.0, 16.7, f64::INFINITY, f64::NAN, 600.0] {
                let c = coc_px(&lens, d, f, 540.0, 2.0);
                assert!(!c.is_nan(), "{d} {f}");
                let m = level_for_coc(c, 8.0);
                assert!((0.0..=8.0).contains(&m), "{d} {f} {m}");
            }
        }
    }
}
