//! Per-frame inputs: the rendered buffers, the per-object data and the
//! camera's motion.

use crate::error::AttentionError;

/// Object id of background pixels in [`FrameView::object`].
pub const BACKGROUND_ID: u32 = u32::MAX;

/// Largest frame side accepted, in pixels.
pub const MAX_FRAME_SIDE: u32 = 16_384;

/// Largest frame accepted, in pixels (`width * height`).
pub const MAX_FRAME_PIXELS: u64 = 1 << 26;

/// Most objects accepted in one frame's object list.
pub const MAX_OBJECTS: usize = 4_096;

/// One rendered frame, borrowed: colour, eye distance and object id per pixel.
/// All three buffers are row-major, top row first, `width * height` pixels.
#[derive(Clone, Copy, Debug)]
pub struct FrameView<'a> {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// 8-bit display-encoded RGB (gamma about 2.2), 3 bytes per pixel.
    pub rgb: &'a [u8],
    /// Distance from the eye per pixel in mm; `+inf` or NaN where nothing was
    /// hit. Other non-finite values count as background too.
    pub depth_mm: &'a [f32],
    /// Object id per pixel; [`BACKGROUND_ID`] where no object was hit.
    pub object: &'a [u32],
}

impl FrameView<'_> {
    /// Pixel count, after checking the size and every buffer length.
    pub fn validate(&self) -> Result<u64, AttentionError> {
        let pixels = crate::measure::check_frame_size(self.width, self.height)?;
        let check = |buffer: &'static str, expected: u64, actual: usize| {
            let actual = actual as u64;
            if actual == expected {
                Ok(())
            } else {
                Err(AttentionError::BufferLength {
                    buffer,
                    expected,
                    actual,
                })
            }
        };
        check("rgb", pixels * 3, self.rgb.len())?;
        check("depth_mm", pixels, self.depth_mm.len())?;
        check("object", pixels, self.object.len())?;
        Ok(pixels)
    }
}

/// What the renderer knows about one object this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectInfo {
    /// The id written in [`FrameView::object`]; not [`BACKGROUND_ID`].
    pub id: u32,
    /// Task importance `T_i` from the scene file (Lee eq. 3.7), clamped to
    /// [0, 1]; 0 excludes the object (walls, floor, sky). Non-finite counts as 0.
    pub importance: f32,
    /// World-space velocity of the object's vertex farthest from its centre,
    /// mm/s (Lee eq. 3.3: covers translation and spin). Non-finite counts as
    /// no motion.
    pub motion_mm_per_s: [f32; 3],
}

impl ObjectInfo {
    /// An object with the given id and importance that does not move.
    pub fn still(id: u32, importance: f32) -> Self {
        Self {
            id,
            importance,
            motion_mm_per_s: [0.0; 3],
        }
    }

    /// `T_i` as used: clamped to [0, 1], non-finite as 0.
    pub fn importance_used(&self) -> f32 {
        if self.importance.is_finite() {
            self.importance.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// `B_m` before normalisation: the speed, non-finite as 0.
    pub fn speed_used(&self) -> f32 {
        let [x, y, z] = self.motion_mm_per_s.map(f64::from);
        let speed = (x * x + y * y + z * z).sqrt();
        if speed.is_finite() {
            (speed as f32).min(f32::MAX)
        } else {
            0.0
        }
    }
}

/// The observer's motion, for the spatial context (Lee eq. 3.9): `v` is the
/// view direction, `w` the motion direction; only the sign of `v · w` is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraMotion {
    /// View direction in world space (any length).
    pub view_dir: [f32; 3],
    /// Camera velocity in world space, mm/s.
    pub velocity_mm_per_s: [f32; 3],
}

impl CameraMotion {
    /// A camera that does not move (the "otherwise" branch of eq. 3.9 applies
    /// to every object).
    pub const STATIC: Self = Self {
        view_dir: [0.0, 0.0, -1.0],
        velocity_mm_per_s: [0.0; 3],
    };

    /// A camera looking along `view_dir` and moving at `velocity_mm_per_s`.
    pub fn new(view_dir: [f32; 3], velocity_mm_per_s: [f32; 3]) -> Self {
        Self {
            view_dir,
            velocity_mm_per_s,
        }
    }

    /// From glam vectors (world space; velocity in mm/s).
    #[cfg(feature = "glam")]
    pub fn from_glam(view_dir: glam::Vec3, velocity_mm_per_s: glam::Vec3) -> Self {
        Self {
            view_dir: view_dir.to_array(),
            velocity_mm_per_s: velocity_mm_per_s.to_array(),
        }
    }

    /// `v · w > 0`: the observer moves forward. Non-finite inputs count as a
    /// camera at rest.
    pub fn moving_forward(&self) -> bool {
        let v = self.view_dir.map(f64::from);
        let w = self.velocity_mm_per_s.map(f64::from);
        let dot = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
        dot.is_finite() && dot > 0.0
    }
}

impl Default for CameraMotion {
    fn default() -> Self {
        Self::STATIC
    }
}

#[cfg(feature = "glam")]
impl ObjectInfo {
    /// From a glam velocity (world space, mm/s, of the outermost vertex).
    pub fn from_glam(id: u32, importance: f32, motion_mm_per_s: glam::Vec3) -> Self {
        Self {
            id,
            importance,
            motion_mm_per_s: motion_mm_per_s.to_array(),
        }
    }
}
