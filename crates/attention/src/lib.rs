//! Decides which object of a rendered scene the observer is looking at:
//! per-frame saliency maps and object-level attention tracking.
//!
//! Saliency maps and object-level attention tracking after Lee 2009,
//! chapter 3 (`shared/seeds/lee-2009-attention-tracking-perceptual-rendering.txt`;
//! spec extract in `SEED-NOTES.md` §1.1). Pure CPU, no GPU, no I/O; the
//! per-pixel passes run on the current rayon pool.
//!
//! One call per frame, [`AttentionTracker::update`], takes the rendered
//! colour, eye-distance and object-id buffers ([`FrameView`]), the
//! per-object data ([`ObjectInfo`]) and the camera's motion
//! ([`CameraMotion`]) and returns the object ranking, the attended object
//! and a gaze point ([`Attention`]). The per-feature maps are readable for
//! debug pictures ([`AttentionTracker::maps`]). [`eval`] scores rankings
//! against recorded gaze (Lee's `A_1`–`A_3`); [`synthetic`] makes test
//! scenes.
//!
//! ## CPU and GPU
//!
//! `update` is two halves with one record between them ([`measure`]):
//! [`AttentionTracker::measure`] runs the per-pixel and per-map part
//! (steps 1–6 below) and returns each object's pixel statistics
//! ([`FrameMeasure`]); [`AttentionTracker::update_measured`] finishes a
//! frame from such a record (steps 7–9: contexts, Kalman filter, ranking,
//! threshold). A GPU implementation of steps 1–6 — gazecast's
//! `pipeline::gpu_attention`, WGSL on the renderer's own frame buffers —
//! fills the same record, so the finishing code exists once and this crate
//! has no GPU dependency. This crate's CPU path is the reference; the
//! pipeline crate states and tests the tolerance between the two.
//!
//! ## The pipeline (Lee Fig. 3.1) and where each formula is
//!
//! 1. **Downsample** the frame to an `M × M` map, `M` in 64..=512 (Lee
//!    §3.4), by area average: map cell `c` covers frame pixels
//!    `⌊c·W/M⌋ .. ⌊(c+1)·W/M⌋` (at least one; a frame smaller than the map
//!    repeats pixels). The map is square whatever the frame's aspect, as
//!    Lee's textures. RGB is averaged as stored (display-encoded, like a
//!    2006 GPU's non-sRGB mipmaps), then converted per cell.
//! 2. **Features** (§3.1.1, [`pyramid`], [`hls`]):
//!    - `B_l`: HLS lightness `(max + min)/2`.
//!    - `B_h`: HLS (hexcone) hue as a chroma-weighted vector
//!      `C·(cos h, sin h)`, `C = max − min`.
//!    - `B_d` (eq. 3.1): `(z − z_near)/(z_far − z_near)` on the linear eye
//!      distance, clamped to [0, 1]; background (non-finite) = 1.
//!    - `B_s` (eq. 3.2): object pixels / frame pixels, counted at frame
//!      resolution; background 0.
//!    - `B_m` (eq. 3.3): speed of the object's outermost vertex, divided by
//!      the fastest visible object's.
//! 3. **Pyramids**, levels 0–6 (§3.1.1), [`pyramid::Pyramid`].
//! 4. **Centre–surround** (eq. 3.4, Fig. 3.3), [`contrast::CentreSurround`]:
//!    pairs (0,3) (0,4) (1,4) (1,5) (2,5) (2,6), all levels bilinearly
//!    magnified to level 0.
//! 5. **Weights and normalisation** (eq. 3.5, 3.6), [`contrast::combine`].
//! 6. **Object saliency** (eq. 3.7): `Ŝ_o(k) = T_i(k) · mean S_p` over the
//!    object's pixels.
//! 7. **Spatial context** (eq. 3.9), [`context::spatial_context`];
//!    **temporal context** (eq. 3.10), [`context::TemporalContext`].
//! 8. **Final attention** (eq. 3.8) `S_o = (T_s + T_t)·Ŝ_o`, smoothed per
//!    object by a Kalman filter (§3.2.1, §3.3), [`kalman::ScalarKalman`].
//! 9. **Ranking and attended object**: not in the seed beyond "arg-max";
//!    see decisions 13–15.
//!
//! ## Decisions on the seed's gaps (SEED-NOTES §1.1 "Gaps", §1.4, §1.5)
//!
//! 1. **Pyramid filter.** Lee uses hardware mipmaps (2×2 box). We use a
//!    Gaussian pyramid: separable binomial `[1, 3, 3, 1]/8`, decimate by 2,
//!    texel centres aligned as a mipmap's (level `l+1` texel `x` at `2x+0.5`
//!    of level `l`), clamp at edges, `ceil(n/2)` sizes. Any `M` in range
//!    works (level 6 of 64 is 1×1).
//! 2. **`texture2D` LOD bias** (§3.3 gap): the contrast pass runs at level-0
//!    resolution, where bias = level, so we sample level `i` explicitly.
//! 3. **Circular hue** (eq. 3.4 and averaging): hue is carried as the
//!    chroma-weighted vector, so every average (downsample, pyramid,
//!    bilinear) is the angle of the chroma-weighted mean vector. The hue
//!    term of eq. 3.4 is `min(|a|, |b|) · ∠(a, b) / 180°` — the wrapped
//!    angle (350° vs 10° = 20°) weighted by the less chromatic side, so
//!    greys (undefined hue) carry no hue contrast. Chroma, not HLS
//!    saturation, is the weight: saturation is 1 for any nearly black or
//!    white tint (e.g. RGB (1, 0, 0)/255).
//! 4. **Depth range** (eq. 3.1): `z_near = 100 mm`, `z_far = 100 m`
//!    ([`AttentionConfig`]); linear in eye distance (not a hardware
//!    z-buffer's 1/z).
//! 5. **`B_s`, `B_m` scale and format**: maps are f32; `B_m` is divided by
//!    the fastest visible object so every feature lies in [0, 1]. Eq. 3.6
//!    divides each contrast by its maximum, so any further linear rescale
//!    (and the per-frame `dt` of eq. 3.3) cancels. Input motion is the
//!    outermost vertex's world velocity in mm/s; non-finite counts as 0.
//! 6. **Flat features** (eq. 3.6): `w_f = 1/max C_f`, but 0 when
//!    `max C_f ≤ 1e-5` ([`contrast::MIN_CONTRAST`]) — noise is not
//!    amplified to full contrast.
//! 7. **`S̄_p → S_p`** (eq. 3.5): divided by its maximum (not min–max, so no
//!    contrast stays 0). If no feature has contrast (or all are off), `S_p`
//!    is 1 everywhere ([`Attention::bottom_up_informative`] = false): "nothing
//!    stands out" leaves objects ranked by importance and contexts rather
//!    than all at 0. An object filling a uniform screen is therefore
//!    attended.
//! 8. **Object pixels** (eq. 3.7): `n(k)` and the mean of `S_p` use the
//!    frame-resolution item buffer, each frame pixel reading its map cell.
//!    `T_i` is clamped to [0, 1] (non-finite = 0), so `S_o ≤ 1`.
//! 9. **Spatial context `x` and `y`** (eq. 3.9): `x` = mean eye distance of
//!    the object's visible pixels with finite depth (`z_far` if none) — this
//!    is also the focus distance Lee §6.1 reuses. `y` = distance of the
//!    object's pixel centroid from the screen centre over half the screen
//!    diagonal (0 centre, 1 corner).
//! 10. **Spatial constants**: `L = 3000 mm` (a room-scale viewing distance;
//!     the seed gives none), `c_x = L·√2` (the seed's `L/0.707`, exact so
//!     the peak is at `L`), `c_y = 3` (weight `e^{-3} ≈ 0.05` in a corner,
//!     `e^{-0.75} ≈ 0.47` halfway), `c_s = 0.5·√(2e) ≈ 1.1658` so that
//!     `max T_s = 0.5` exactly (SEED-NOTES \[derived\]). `v·w > 0` uses the
//!     camera's world view direction and velocity; a camera at rest (or
//!     non-finite motion) takes the "otherwise" branch. `Δx > 0` needs the
//!     object visible in the previous frame too (else `Δx = 0`). Invisible
//!     objects have `T_s = 0`.
//! 11. **Temporal window** (eq. 3.10): `λ = 60` frames (1 s at 60 Hz). The
//!     sum is always over `λ` entries: frames before an object appeared count
//!     as 0, so `T_t` ramps up over `λ` frames.
//! 12. **Ablations** (Table 3.2): [`Features::lee_groups`] switches Lee's
//!     groups B = {`B_l`, `B_h`}, E = {`B_d`, `B_s`, `B_m`} (3-D/object
//!     features, not an egocentric context) and T = {`T_s`, `T_t`};
//!     single features can be switched too. With T off, eq. 3.8's factor is
//!     1; with only `T_s` or only `T_t`, that term alone. With B and E off,
//!     `S_p ≡ 1` (decision 7); Lee's random-pixel baseline is the caller's.
//! 13. **Kalman noise**: constant-velocity model on (`S_o`, rate), process
//!     noise density `q = 1 /s³`, measurement variance `r = 0.05²`; starts at
//!     the first measurement with variances (`r`, 1). At 60 Hz the value
//!     settles within about 10 frames and a ±0.05 frame-to-frame flicker
//!     is reduced below ±0.02. Output clamped to [0, 1]. Listed but
//!     invisible objects are measured as 0; objects missing from the list
//!     are forgotten.
//! 14. **Ranking**: visible listed objects with `T_i > 0` (Lee uses `T_i`
//!     to exclude walls, floor, sky), by smoothed attention, highest first;
//!     **ties: the lower id first**.
//! 15. **Attended object and threshold** (§6.1's unvalued threshold): the
//!     first of the ranking if its smoothed attention is at least
//!     `attention_threshold = 0.01`; otherwise (and for an empty frame)
//!     `None`. It is always visible in the frame.
//! 16. **Gaze point**: the attended object's saliency peak — the centroid of
//!     its pixels inside the map cell of highest `S_p` (ties: lowest cell
//!     index), or its centroid when the map is flat. Frame pixels, y down.
//! 17. **Ids**: ids missing from the object list are treated as background
//!     (counted in [`Attention::unlisted_pixels`]); `u32::MAX` is background.
//!
//! ## Numerics and limits
//!
//! No NaN reaches an output for any input: non-finite depths are
//! background, non-finite importances 0, non-finite motion none, every
//! division is guarded. Frames are checked before anything is sized from
//! them: sides ≤ 16 384 px, ≤ 2²⁶ pixels, every buffer exactly
//! `width·height` (×3 for RGB); at most 4 096 objects (Lee §7.4 uses
//! 256). No frame-sized buffer is allocated. Results do not depend on the thread count (fixed
//! row blocks, ordered reductions). The hue contrast uses a polynomial
//! `atan2` (error < 2e-5 rad, [`fast_math::atan2`]).
//!
//! ## Performance
//!
//! When the frame is at least as large as the map (the usual case), one
//! fused pass reads each frame buffer once and records, per map cell, the
//! pixels of each object in it; `B_s` and eq. 3.7 are finished from those
//! records. Smaller frames take a three-pass path; a unit test checks that
//! both agree. Bilinear magnification is done separably (each coarse level
//! is magnified horizontally once per frame).
//!
//! `benches/attention.rs` (1280×1024 frame, 30 objects, 2 rayon threads;
//! `cargo bench --bench attention -- --warm-up-time 1 --measurement-time 3`)
//! on a shared 2-core machine under load: about 20 ms per frame at 256² and
//! 7.7 ms at 64² (criterion means); the fastest single frames (example
//! `profile_frame`) 12–15 ms and 3 ms. At 64² most of the time is the
//! pass over the 1.3-Mpixel frame. Lee's figures (GeForce 7900GTX: 5.68 ms
//! at 256², 0.97 ms at 64², §3.4, §7.2) exclude producing the RGB, depth
//! and item-buffer images; here those arrive at frame size and the
//! downsampling to the map is part of the measured time.

#![warn(missing_docs)]

pub mod config;
pub mod context;
pub mod contrast;
mod error;
pub mod eval;
pub mod fast_math;
pub mod frame;
pub mod hls;
pub mod kalman;
pub mod measure;
pub mod pyramid;
pub mod synthetic;
mod tracker;

pub use config::{
    AttentionConfig, Features, KalmanParams, SpatialContextParams, MAX_MAP_SIZE, MIN_MAP_SIZE,
};
pub use error::AttentionError;
pub use eval::{top_k_hit, AccuracyAccumulator};
pub use frame::{CameraMotion, FrameView, ObjectInfo, BACKGROUND_ID};
pub use measure::{CellAxis, FrameMeasure, ObjectIndex, ObjectMeasure};
pub use tracker::{Attention, AttentionTracker, Feature, ObjectAttention, SaliencyMaps};
