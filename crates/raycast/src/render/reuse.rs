//! Temporal reuse during fixations (Murphy 2007 §8.2.4, "intermediate mesh
//! caching"; issue 15): in a static scene seen from a still eye a cast
//! sample depends only on its ray, so samples are kept by their exact screen
//! position and only what the cache lacks is cast.
//!
//! Two kinds of sample are kept, both bit for bit what a fresh cast gives,
//! so a frame rendered with reuse equals the frame rendered without it:
//!
//! - **Pixel centres.** The fovea, refined and gap pixels are cast at pixel
//!   centres, fixed screen positions whatever the gaze. The cache holds the
//!   hit (or miss) of every centre cast since it was last emptied; a centre
//!   the new frame casts again takes it from there. Shading is not cached:
//!   it is computed from the hit each frame as before, so materials, lights
//!   and background may change without emptying the cache.
//! - **The whole mask.** The mesh vertices sit at `POR + r·(cos, sin)` with
//!   radii and spacings that depend on the POR: for any move of the gaze
//!   larger than the f32 rounding of the positions (about 10⁻⁴ px on the
//!   seed display) no vertex of the new mask lands where an old one was
//!   (measured: 0 or 1 of 217 k shared for moves of 0.001–16 px; all of
//!   them for the same gaze). So the vertex rays are reused only when the
//!   mask is kept ([`Scratch::mask_for`]: the same gaze, model and layout,
//!   or a gaze within the model's gaze tolerance of the mask's POR): then
//!   the vertex hits, the classification, the margin and the pixel owners
//!   of the last frame are all still right and are kept.
//! - **The whole frame.** A second frame in a row with a kept mask and
//!   the same shading inputs and surface flag is the last one, copied.
//!
//! The cache is emptied when what a cast depends on changes: the scene
//! ([`Scene::revision`], and which accelerator it traverses), the camera
//! (eye position, pixel count, pitch) or the triangle test. The kept frame
//! state is dropped as well when the triggers or `check_coverage` change.
//! It is allocated only when reuse is on ([`Scratch::with_reuse`]), sized
//! from the camera, and reused across frames.

use super::*;
use crate::scene::{Accel, Light, Material};

/// What temporal reuse did in the last frame rendered with a [`Scratch`]
/// (all zero when reuse is off or the frame was full resolution).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct ReuseStats {
    /// The cache was emptied at the start of the frame (its first frame, or
    /// the scene, camera or triangle test changed).
    pub invalidated: bool,
    /// The mask was kept from the last frame (the same gaze, or one within
    /// the model's gaze tolerance): its vertex rays, classification, margin
    /// and pixel owners were kept, not redone.
    pub mask_reused: bool,
    /// The whole frame was the last one's, copied: the mask was kept for
    /// a second frame in a row with nothing else changed (the same scene,
    /// shading, camera, settings and surface buffers), so every pixel
    /// would come out as it did.
    pub frame_reused: bool,
    /// Fovea, refined and gap pixels whose hit came from the cache.
    pub pixels_reused: u64,
    /// Fovea, refined and gap pixels cast (and kept for later frames).
    pub pixels_cast: u64,
}

/// Everything a cast depends on besides its screen position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct CastKey {
    revision: u64,
    accel: Accel,
    grid: bool,
    eye: [u32; 3],
    size: [u32; 2],
    pitch: [u32; 2],
    test: TriangleTest,
}

impl CastKey {
    pub(super) fn new(scene: &Scene, cam: &Camera, test: TriangleTest) -> Self {
        let [px, py] = cam.pitch();
        Self {
            revision: scene.revision(),
            accel: scene.accel,
            grid: scene.grid.is_some(),
            eye: cam.eye.to_array().map(f32::to_bits),
            size: [cam.width_px, cam.height_px],
            pitch: [px.to_bits(), py.to_bits()],
            test,
        }
    }
}

/// What the kept mask, vertex hits, refined flags and owners were made with,
/// besides the mask itself and the [`CastKey`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct FrameKey {
    pub(super) triggers: Triggers,
    pub(super) check_coverage: bool,
}

/// The hit of the ray through one pixel centre, valid while `stamp >> 1`
/// is the cache's epoch; the low bit of `stamp` says hit (1) or miss (0).
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    hit: Hit,
    stamp: u32,
}

// 28 bytes a pixel, as the docs say.
const _: () = assert!(std::mem::size_of::<Sample>() == 28);

const EMPTY: Sample = Sample {
    hit: Hit {
        t: 0.0,
        object: NO_OBJECT,
        triangle: 0,
        normal: Vec3::ZERO,
    },
    stamp: 0,
};

/// Epochs run from 1 to this; past it every stamp is cleared and they start
/// again (stamps are `epoch << 1 | hit`).
const LAST_EPOCH: u32 = u32::MAX >> 1;

impl Sample {
    /// The kept hit if this sample was cast in `epoch`.
    #[inline]
    pub(super) fn get(&self, epoch: u32) -> Option<Option<Hit>> {
        (self.stamp >> 1 == epoch).then(|| (self.stamp & 1 == 1).then_some(self.hit))
    }

    #[inline]
    pub(super) fn set(&mut self, epoch: u32, hit: Option<Hit>) {
        *self = match hit {
            Some(hit) => Sample {
                hit,
                stamp: (epoch << 1) | 1,
            },
            None => Sample {
                stamp: epoch << 1,
                ..EMPTY
            },
        };
    }
}

/// The cache of a [`Scratch`] with reuse on.
#[derive(Debug, Default)]
pub(super) struct Reuse {
    key: Option<CastKey>,
    /// Samples stamped with this epoch are valid; 0 before the first frame.
    pub(super) epoch: u32,
    /// One per pixel, row-major (`width × height` of the key's camera).
    pub(super) samples: Vec<Sample>,
    /// Set when a foveated frame finished with the mask, vertex hits,
    /// refined flags and owners now in the scratch: what they were made with.
    pub(super) frame: Option<FrameKey>,
    pub(super) stats: ReuseStats,
    /// The last frame rendered with a kept mask, what it was rendered with,
    /// and its stats: the next frame with the same mask and inputs is a copy.
    pub(super) last: Option<Box<Kept>>,
}

/// A whole frame kept for the next one.
#[derive(Debug, Default)]
pub(super) struct Kept {
    pub(super) frame: Frame,
    pub(super) stats: Stats,
    pub(super) key: Option<OutKey>,
    /// The generation of the mask it was drawn with.
    pub(super) generation: (u64, u64),
}

/// What a frame's pixels depend on besides the mask, the casts
/// ([`CastKey`]) and the frame state ([`FrameKey`]): the shading inputs
/// (materials, lights, background, which the cast cache does not key on)
/// and whether the surface buffers are filled.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct OutKey {
    surface: bool,
    background: [u32; 3],
    background_rgb8: [u8; 3],
    materials: Vec<Material>,
    lights: Vec<Light>,
}

impl OutKey {
    /// Whether `self` is the key of a frame of `scene` with `surface`
    /// (compared without allocating).
    pub(super) fn matches(&self, scene: &Scene, surface: bool) -> bool {
        self.surface == surface
            && self.background == scene.background.to_array().map(f32::to_bits)
            && self.background_rgb8 == scene.background_rgb8
            && self.materials == scene.object_materials
            && self.lights == scene.lights
    }

    /// Makes `self` the key of a frame of `scene` with `surface`, reusing
    /// its buffers.
    pub(super) fn set(key: &mut Option<OutKey>, scene: &Scene, surface: bool) {
        let k = key.get_or_insert_with(|| OutKey {
            surface,
            background: [0; 3],
            background_rgb8: [0; 3],
            materials: Vec::new(),
            lights: Vec::new(),
        });
        k.surface = surface;
        k.background = scene.background.to_array().map(f32::to_bits);
        k.background_rgb8 = scene.background_rgb8;
        k.materials.clone_from(&scene.object_materials);
        k.lights.clone_from(&scene.lights);
    }
}

impl Reuse {
    /// Forgets the key: the next frame empties the cache.
    pub(super) fn invalidate(&mut self) {
        self.key = None;
        self.frame = None;
        if let Some(k) = self.last.as_deref_mut() {
            k.key = None;
        }
    }

    /// Makes the cache valid for `key`: emptied (and sized for the camera)
    /// when the key differs from the last frame's. Returns whether it was.
    pub(super) fn begin(&mut self, key: CastKey, w: usize, h: usize) -> bool {
        if self.key == Some(key) && self.samples.len() == w * h {
            return false;
        }
        self.key = Some(key);
        self.frame = None;
        if let Some(k) = self.last.as_deref_mut() {
            k.key = None;
        }
        if self.epoch >= LAST_EPOCH {
            self.epoch = 0;
            self.samples.par_iter_mut().for_each(|s| *s = EMPTY);
        }
        self.epoch += 1;
        self.samples.resize(w * h, EMPTY);
        true
    }
}
