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
//! ([`smooth_foreground`]). Off by default because it blurs in-focus pixels
//! beside a blurred foreground, which the rule "a pixel with CoC < 0.5 px
//! is unchanged" forbids; with it on, that rule holds only away from
//! blurred foreground objects, and the pass stays on the CPU on the GPU
//! backend. Ch. 5 splatting, which handles partial occlusion with the
//! hidden surface itself, is [`super::dof_splat`]. The GPU path (the same
//! pass in WGSL, before the frame's read-back) is `crate::gpu`. The ground truth it
//! is measured against is [`super::dof_reference`] (thin-lens distributed
//! ray casting, 64 rays per pixel).

use foveation::thin_lens::{self, EyeLens};
use raycast::scene::DofFocus;
use raycast::Frame;
use rayon::prelude::*;

use super::refocus::Refocus;
use super::{Pass, PassInput};
use crate::colour;
use crate::plan::Channels;
use crate::pyramid::{self, Kernel, Level, Texel};
use raycast::scene::DofRefocus;

/// Side of the square around the gaze whose depths' median is the focus
/// for `focus: Gaze`, px.
pub const FOCUS_WINDOW_PX: i64 = 9;

/// Most pyramid levels above level 0 (σ up to 0.75·2^8 = 192 px).
pub const MAX_LEVELS: usize = 8;

/// σ of the 3×3 Gaussian (4.1, 4.8), in texels of the level it filters.
pub const GAUSS_SIGMA_TEXELS: f64 = 1.0;

/// The depth-of-field pass.
#[derive(Debug)]
pub struct DepthOfField {
    /// The eye; `aperture_mm` is the pupil diameter (0: the identity).
    pub lens: EyeLens,
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
    pub width: usize,
    pub height: usize,
    /// Degree of blur σ = CoC / 2 (eq. 4.5), px; capped at 10⁶.
    pub sigma_px: &'a [f32],
    /// The continuous mip level m (eq. 4.6); 0: the pixel is left as it is.
    pub level: &'a [f32],
}

/// Saliency map side of the attention focus (Lee's smallest, 64²: the
/// attended object, not a fine map, is what the focus needs).
pub const ATTENTION_MAP_SIZE: u32 = 64;

/// `focus: Attention`'s model.
type AttentionModel = crate::frame_attention::FrameAttention;

/// One level: the colour ([`Level`], linear RGB) and, row-major beside
/// it, the depth (Z) and degree of blur (B, σ in px) mips of eq. 4.9.
#[derive(Debug, Clone, Default)]
struct Image {
    colour: Level,
    z: Vec<f32>,
    sigma: Vec<f32>,
    /// The DoN mip ρ (eq. 4.10): only with foreground smoothing, only at
    /// the top level built (the one eq. 4.11 reads); empty otherwise.
    rho: Vec<f32>,
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
    fn reshape(&mut self, w: usize, h: usize) {
        self.colour.reshape(w, h);
        self.z.resize(w * h, 0.0);
        self.sigma.resize(w * h, 0.0);
    }
}

impl DepthOfField {
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
    pub fn from_effect(effect: &raycast::scene::Effect) -> Option<Self> {
        match effect {
            raycast::scene::Effect::DepthOfField {
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

/// Where a depth-of-field pass focuses, frame after frame: the search for
/// the focus target its [`DofFocus`] names, the last focus found (held
/// while a frame finds none), the refocusing dynamics and, for `focus:
/// Attention` only, Lee's attention model. Shared by the ch. 4 and ch. 5
/// passes.
#[derive(Debug, Default)]
pub(crate) struct Focuser {
    /// The focus of the last frame whose search found one.
    last_focus_mm: Option<f64>,
    /// How the focal depth follows the focus target.
    pub(crate) refocus: Refocus,
    /// Lee's attention model, for `focus: Attention` only.
    attention: Option<Box<AttentionModel>>,
}

impl Focuser {
    pub(crate) fn new(focus: DofFocus) -> Self {
        Self {
            attention: if focus == DofFocus::Attention {
                AttentionModel::new(ATTENTION_MAP_SIZE).ok().map(Box::new)
            } else {
                None
            },
            ..Self::default()
        }
    }

    pub(crate) fn attended_object(&self) -> Option<u32> {
        self.attention.as_ref().and_then(|a| a.attended())
    }

    /// `focus: Attention`'s model, for a pass whose focus search runs
    /// elsewhere (the GPU path); `None` for other focuses.
    pub(crate) fn attention_model(&mut self) -> Option<&mut AttentionModel> {
        self.attention.as_deref_mut()
    }

    pub(crate) fn attention(&self) -> Option<&AttentionModel> {
        self.attention.as_deref()
    }

    /// The focus distance for `frame`, mm (may be infinite), after the
    /// refocusing dynamics.
    pub(crate) fn focus_mm(
        &mut self,
        focus: DofFocus,
        frame: &Frame,
        input: &PassInput<'_>,
    ) -> f64 {
        let found = match focus {
            DofFocus::Fixed { .. } => None,
            DofFocus::Gaze => gaze_depth_mm(frame, input.gaze_px),
            DofFocus::Vergence => {
                vergence_or(input.vergence_mm, || gaze_depth_mm(frame, input.gaze_px))
            }
            DofFocus::Attention => match &mut self.attention {
                Some(a) => a.depth_mm(frame, input.scene, input.time_s),
                None => None,
            },
        };
        self.settle(focus, found, input.time_s)
    }

    /// The focal depth for a frame whose search `found` a depth (or none:
    /// the last one holds; before any, infinity), after the refocusing
    /// dynamics. A fixed focus is fixed.
    pub(crate) fn settle(
        &mut self,
        focus: DofFocus,
        found: Option<f64>,
        time_s: Option<f64>,
    ) -> f64 {
        let target = match focus {
            DofFocus::Fixed { depth_mm } => depth_mm,
            _ => {
                if let Some(d) = found {
                    self.last_focus_mm = Some(d);
                }
                self.last_focus_mm.unwrap_or(f64::INFINITY)
            }
        };
        if target > 0.0 {
            self.refocus.update(target, time_s)
        } else {
            target // only an unvalidated fixed focus: `coc_px` clamps it
        }
    }
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

/// The [`FOCUS_WINDOW_PX`] square around `gaze_px` clipped to a `w`×`h`
/// frame, as [`gaze_depth_mm`] reads it: inclusive pixel bounds `(x0, y0, x1, y1)`, empty (x0 > x1 or
/// y0 > y1) when it misses the frame; `None` for a non-finite gaze.
pub(crate) fn focus_window(w: i64, h: i64, gaze_px: [f64; 2]) -> Option<(i64, i64, i64, i64)> {
    if !gaze_px[0].is_finite() || !gaze_px[1].is_finite() {
        return None;
    }
    let half = FOCUS_WINDOW_PX / 2;
    // Clamp before converting so a far-off gaze cannot overflow.
    let cx = gaze_px[0].floor().clamp(-1e9, 1e9) as i64;
    let cy = gaze_px[1].floor().clamp(-1e9, 1e9) as i64;
    Some((
        (cx - half).max(0),
        (cy - half).max(0),
        (cx + half).min(w - 1),
        (cy + half).min(h - 1),
    ))
}

/// The median of the finite positive depths of a window (the focus of
/// `focus: Gaze`, as [`gaze_depth_mm`] takes it), or `None` when it holds
/// none.
pub(crate) fn median_depth(mut depths: Vec<f32>) -> Option<f64> {
    depths.retain(|d| d.is_finite() && *d > 0.0);
    if depths.is_empty() {
        return None;
    }
    depths.sort_by(f32::total_cmp);
    Some(f64::from(depths[depths.len() / 2]))
}

/// `focus: Vergence`'s depth: the vergence depth when valid (finite,
/// positive), else the gaze's (`gaze`, evaluated only then).
pub(crate) fn vergence_or(
    vergence_mm: Option<f64>,
    gaze: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    vergence_mm
        .filter(|d| d.is_finite() && *d > 0.0)
        .or_else(gaze)
}

/// The median of the finite positive depths in the [`FOCUS_WINDOW_PX`]
/// square around `gaze_px`, or `None` when it holds none.
pub fn gaze_depth_mm(frame: &Frame, gaze_px: [f64; 2]) -> Option<f64> {
    if !frame.has_surface() {
        return None;
    }
    let w = i64::from(frame.width_px);
    let (x0, y0, x1, y1) = focus_window(w, i64::from(frame.height_px), gaze_px)?;
    let mut depths = Vec::with_capacity((FOCUS_WINDOW_PX * FOCUS_WINDOW_PX) as usize);
    for y in y0..=y1 {
        for x in x0..=x1 {
            depths.push(frame.depth_mm[(y * w + x) as usize]);
        }
    }
    median_depth(depths)
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
        // Foreground smoothing has no GPU implementation.
        if self.smooth_foreground {
            return Err(self);
        }
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

/// Decodes level 0 (colour, depth, σ) and builds levels 1..=`levels`
/// (eq. 4.1; with `anisotropic`, eq. 4.9's H instead of G for the colour),
/// reusing the buffers. Each level-`l` texel is the 3×3 Gaussian centred on
/// its centre in level `l − 1` (between 2×2 texels), sampled bilinearly:
/// 4×4 taps of weights `a_i·a_j`.
#[allow(clippy::too_many_arguments)]
fn build_pyramid(
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
fn smooth_foreground(
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
fn blend(pyramid: &[Image], x: usize, y: usize, m: f64) -> [f32; 3] {
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
