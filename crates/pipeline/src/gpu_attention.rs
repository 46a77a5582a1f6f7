//! Lee's attention model (2009 ch. 3) with its per-pixel and per-map part
//! on the GPU, for a frame held on the CPU ([`attention::FrameView`]): the
//! frame is uploaded, the WGSL passes measure it (`gpu/attention.wgsl`),
//! and the CPU tracker finishes it ([`attention::AttentionTracker::update_measured`]).
//! The renderer runs the same passes on its own GPU frame without the
//! upload (`DepthOfField(focus: Attention)` on the GPU backend).
//!
//! # The split
//!
//! - **GPU**: the area-average downsampling to the `M × M` map, the five
//!   features, the 7-level pyramids, centre–surround contrast with the
//!   circular hue term, the per-feature maxima and weights, `S_p`, and the
//!   per-object reductions: pixel count, depth sum, centroid sums, the sum
//!   of `S_p`, the peak cell and its pixels' centroid.
//! - **CPU** ([`attention::AttentionTracker`], the same code as the CPU
//!   path): spatial and temporal contexts, final attention, the Kalman
//!   filter, ranking, the threshold. It needs only the per-object
//!   statistics ([`attention::FrameMeasure`]).
//!
//! # Tolerance
//!
//! The GPU measures the frame in f32 where the CPU uses f64 in places,
//! adds some sums in fixed point, and a GPU may fuse multiply-adds and
//! divide to 2.5 ulp (WGSL); the hexcone hue's sine and cosine are
//! polynomials (WGSL's own may be off by 2^-11). What is stated, and
//! tested on Mesa's lavapipe (`tests/gpu_attention.rs`; no real GPU has
//! run it):
//!
//! - **Exact**: pixel counts, background and unlisted counts, centroid
//!   sums, the peak cell's pixel sums (integers).
//! - **Within [`SALIENCY_TOLERANCE`] = 1e-4** (absolute; all lie in
//!   [0, 1]): `S_p` per map cell, `Ŝ_o` (eq. 3.7), `T_s`, `S_o` before
//!   smoothing and the smoothed attention. Condition: every switched-on
//!   feature's contrast maximum is at least 0.01 (its weight `w_f`,
//!   eq. 3.6, at most 100).
//! - **Mean eye distance** (`x` of eq. 3.9, the focus of Lee §6.1): within
//!   0.01 mm + 1e-5 of it. The GPU adds depths in 1/256 mm and counts a
//!   depth above [`DEPTH_CAP_MM`] = 2^29 mm (about 537 km) as 2^29 mm, so
//!   that the 64-bit sum of a frame's 2^26 pixels cannot wrap: an object
//!   with such depths has the mean of its capped depths.
//! - **Saliency peak**: the CPU's cell, unless the CPU's `S_p` at the
//!   GPU's cell is within the tolerance of the CPU's peak.
//! - **Ranking and attended object**: the CPU's, except where two of the
//!   CPU's attentions (or the first and the threshold) are within twice
//!   the tolerance (each may move by the tolerance).
//!
//! Why 1e-4, and why the condition: the two f32 chains (area average, HLS,
//! pyramid, bilinear magnification, eq. 3.4) differ by a few ulp of values
//! up to 1, a few 1e-7 in a contrast map. Eq. 3.6 multiplies that by `w_f`.
//! With `w_f ≤ 100` the result stays below 1e-4 with room. The largest
//! `S_p` difference measured is 3.6e-7, on synthetic, hand-made, random and
//! rendered frames. A feature with almost no contrast (just above
//! `MIN_CONTRAST` = 1e-5) amplifies the rounding up to 1e5-fold. A
//! contrived frame, a whole-screen object whose stripes differ in depth by
//! 1 mm (`w_d` ≈ 29 000), differs by 1.4e-5. A contrast maximum within
//! rounding of `MIN_CONTRAST` itself may switch the feature on for one path
//! and off for the other; that case is outside the statement.
//!
//! # Cost
//!
//! Per frame: the upload of the frame (12 bytes a pixel; not done in the
//! renderer, whose frame is already on the GPU), one submission and wait,
//! and a read-back of `64 + 64·n` bytes for `n` listed objects. The `S_p`
//! map is read back only by [`GpuAttention::saliency_map`] (`4·M²` bytes).
//! `benches/attention_gpu.rs` times it; on lavapipe (a CPU rasteriser) its
//! figures say nothing about a real GPU.

use attention::{
    Attention, AttentionConfig, AttentionError, AttentionTracker, CameraMotion, FrameMeasure,
    FrameView, ObjectInfo,
};
use raycast::gpu::{open_device, storage_buffer, wgpu, GpuDevice, GpuError};

use crate::gpu::{GpuSaliency, PrepareError, SaliencyInput};

/// The stated GPU–CPU tolerance of `S_p`, `Ŝ_o` and `S_o` (absolute; see
/// the module docs).
pub const SALIENCY_TOLERANCE: f32 = 1e-4;

/// Eye distances above this (2^29 mm, about 537 km) count as this on the
/// GPU: `MAX_FRAME_PIXELS` (2^26) pixels at this depth, in 1/256 mm, sum to
/// 2^63, so the per-object 64-bit sum cannot wrap (asserted at compile
/// time). 2^30 mm would reach 2^64; 2^30 − 1 is not an f32.
pub const DEPTH_CAP_MM: f32 = (1u32 << 29) as f32;

/// How many GPU attention states (the shader and buffers' owner) this
/// thread has made, renderers and [`GpuAttention`] alike: pay per use is
/// tested with it (a renderer whose scene asks for no attention must leave
/// it unchanged). Per thread, because tests run in parallel; a renderer
/// makes the state on the thread that renders.
#[doc(hidden)]
pub fn states_made_on_this_thread() -> u64 {
    crate::gpu::made_on_this_thread()
}

/// Why the GPU model could not run a frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpuAttentionError {
    /// The model refused the input (frame size, buffer lengths, object
    /// list, time step, configuration).
    #[error("attention: {0}")]
    Attention(#[from] AttentionError),
    /// The GPU failed (no adapter, a buffer over the binding limit, a
    /// failed read-back).
    #[error("attention on the GPU: {0}")]
    Gpu(#[from] GpuError),
}

impl From<PrepareError> for GpuAttentionError {
    fn from(e: PrepareError) -> Self {
        match e {
            PrepareError::Attention(a) => Self::Attention(a),
            PrepareError::Gpu(g) => Self::Gpu(g),
        }
    }
}

/// A frame's buffers on the GPU.
struct Uploaded {
    width: u32,
    height: u32,
    pixels: wgpu::Buffer,
    depth: wgpu::Buffer,
    ids: wgpu::Buffer,
}

/// The attention model with its per-pixel part on a GPU of its own.
pub struct GpuAttention {
    gpu: GpuDevice,
    saliency: GpuSaliency,
    frame: Option<Uploaded>,
    tracker: AttentionTracker,
    /// The packed colour words of the last upload (kept for the next).
    words: Vec<u32>,
}

impl GpuAttention {
    /// Checks `config` and opens a device (a real GPU first, else a software
    /// one such as lavapipe). Nothing else is made before the first frame.
    pub fn new(config: AttentionConfig) -> Result<Self, GpuAttentionError> {
        let tracker = AttentionTracker::new(config)?;
        let gpu = open_device()?;
        Ok(Self {
            gpu,
            saliency: GpuSaliency::new(config),
            frame: None,
            tracker,
            words: Vec::new(),
        })
    }

    /// The adapter in words.
    pub fn adapter(&self) -> &str {
        &self.gpu.adapter
    }

    /// Everything this model has moved to and from its device since it was
    /// made (uploads, read-backs, dispatches, submissions).
    pub fn traffic_total(&self) -> raycast::gpu::Traffic {
        self.gpu.traffic.total()
    }

    /// The CPU tracker that finishes each frame (its history, its
    /// configuration; its maps are not filled by GPU frames).
    pub fn tracker(&self) -> &AttentionTracker {
        &self.tracker
    }

    /// Copies `frame` to the GPU (checked first), for [`GpuAttention::measure`]
    /// and [`GpuAttention::update_uploaded`]. Buffers are kept while the
    /// size stays.
    pub fn upload(&mut self, frame: &FrameView<'_>) -> Result<(), GpuAttentionError> {
        let pixels = frame.validate()?;
        let (w, h) = (frame.width, frame.height);
        let bytes = 4 * pixels;
        if self
            .frame
            .as_ref()
            .is_none_or(|f| (f.width, f.height) != (w, h))
        {
            self.frame = None;
            let make = |what| {
                storage_buffer(
                    &self.gpu.device,
                    what,
                    bytes,
                    wgpu::BufferUsages::COPY_DST,
                    self.gpu.max_binding,
                )
            };
            self.frame = Some(Uploaded {
                width: w,
                height: h,
                pixels: make("attention input colour")?,
                depth: make("attention input depth")?,
                ids: make("attention input ids")?,
            });
        }
        let Some(f) = self.frame.as_ref() else {
            return Err(GpuError::Readback("no input buffers".into()).into());
        };
        // The cast's packing: RGB in bits 0-23, the hit flag (every pixel
        // of a CPU frame; its ids and depths say what is background) in 24.
        self.words.clear();
        self.words.extend(
            frame
                .rgb
                .chunks_exact(3)
                .map(|c| u32::from(c[0]) | u32::from(c[1]) << 8 | u32::from(c[2]) << 16 | 1 << 24),
        );
        let (queue, traffic) = (&self.gpu.queue, &self.gpu.traffic);
        traffic.write_buffer(queue, &f.pixels, 0, bytemuck::cast_slice(&self.words));
        traffic.write_buffer(queue, &f.depth, 0, bytemuck::cast_slice(frame.depth_mm));
        traffic.write_buffer(queue, &f.ids, 0, bytemuck::cast_slice(frame.object));
        Ok(())
    }

    /// Measures the uploaded frame on the GPU (one wait): the per-object
    /// statistics in the order of `objects`.
    pub fn measure(&mut self, objects: &[ObjectInfo]) -> Result<FrameMeasure, GpuAttentionError> {
        let Some(f) = self.frame.as_ref() else {
            return Err(GpuError::Readback("attention: no frame uploaded".into()).into());
        };
        let input = SaliencyInput {
            device: &self.gpu.device,
            queue: &self.gpu.queue,
            traffic: &self.gpu.traffic,
            pixels: &f.pixels,
            depth: &f.depth,
            ids: &f.ids,
            width: f.width,
            height: f.height,
            max_binding: self.gpu.max_binding,
        };
        self.saliency.prepare(&input, objects)?;
        let encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("attention"),
            });
        let (measure, _) = self.saliency.measure(&input, encoder)?;
        Ok(measure)
    }

    /// Measures the uploaded frame and finishes it on the CPU (contexts,
    /// filter, ranking): what [`AttentionTracker::update`] returns for it,
    /// within the module's tolerance.
    pub fn update_uploaded(
        &mut self,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
    ) -> Result<Attention, GpuAttentionError> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(AttentionError::InvalidTimeStep(dt_s).into());
        }
        let measure = self.measure(objects)?;
        Ok(self
            .tracker
            .update_measured(&measure, objects, camera, dt_s)?)
    }

    /// [`GpuAttention::upload`] then [`GpuAttention::update_uploaded`].
    pub fn update(
        &mut self,
        frame: &FrameView<'_>,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
    ) -> Result<Attention, GpuAttentionError> {
        self.upload(frame)?;
        self.update_uploaded(objects, camera, dt_s)
    }

    /// The last frame's `S_p` map (`M²`, row-major), read back (`4·M²`
    /// bytes, one wait); `None` before the first frame.
    pub fn saliency_map(&self) -> Result<Option<Vec<f32>>, GpuAttentionError> {
        Ok(self
            .saliency
            .read_saliency_map(&self.gpu.device, &self.gpu.queue, &self.gpu.traffic)?)
    }

    /// The last frame's weights `w_f` (eq. 3.6) in `Feature::ALL` order.
    pub fn weights(&self) -> [f32; 5] {
        self.saliency.weights()
    }

    /// Whether the GPU buffers exist (made by the first frame).
    pub fn has_buffers(&self) -> bool {
        self.saliency.has_buffers()
    }
}
