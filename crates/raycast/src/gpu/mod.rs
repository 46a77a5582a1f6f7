//! The GPU core in `wgpu` compute (WGSL in `cast.wgsl` and `foveated.wgsl`).
//!
//! The scene (flattened binary BVH, triangles, per-object materials, lights,
//! the gamma table) is uploaded once. Both paths fill the whole G-buffer
//! [`Frame`](crate::Frame) — colour, hit, eye distance, object id, normal and layer — the
//! same as the CPU's `render`, and read it back.
//!
//! - Full resolution: one compute pass casts and shades one ray per pixel.
//! - Foveated: the CPU builds the ray mask and the pixel ownership for the
//!   gaze (they depend on the gaze only) and uploads them; the GPU casts the
//!   mask vertices, classifies the cells, widens the refined set by the
//!   silhouette margin, interpolates the pixels of homogeneous cells and
//!   appends the fovea and refined pixels to a list (an atomic counter), and
//!   casts that list with an indirect dispatch — stage for stage the CPU's
//!   `render::foveated` ([`Stage`], [`foveated_stages`]). Building the mask
//!   and the ownership on the GPU is not done.
//! - A caller may encode its own compute passes on the frame's colour,
//!   depth and object-id buffers between the cast and the read-back ([`GpuPost`],
//!   `render_full_with`, `render_foveated_with`): the pipeline's depth of
//!   field and image-based foveation run there. Such a pass may also cast
//!   the hidden image of Lee's ch. 5 ([`GpuFrame::cast_hidden`], `hidden`:
//!   the first surface of another object along each pixel's ray, the GPU
//!   twin of [`crate::layers`]); its pipeline is made on first use.
//! - Raster (the model-based methods): a render pipeline draws a list of
//!   triangles through the display's off-axis frustum with a depth buffer
//!   and the caster's shading, and a compute pass resolves its targets into
//!   the frame's buffers ([`GpuRenderer::rasterize`], the GPU twin of
//!   [`crate::raster::rasterize`]); made on first use.
//! - Where the adapter has timestamp queries, every pass is timed
//!   ([`GpuRenderer::stage_ms`]).
//! - Every byte uploaded or read back and every dispatch, draw and
//!   submission goes through one [`TrafficCounter`] (the caller's post
//!   passes too, [`GpuFrame::traffic`]): [`GpuRenderer::frame_traffic`] is
//!   the last frame's [`Traffic`], counted at the `wgpu` calls.
//!
//! Any adapter works, including Mesa's lavapipe (software Vulkan), which is
//! how the tests run on machines without a GPU. A buffer larger than the
//! device's storage-binding limit is refused with a message naming the limit.
//!
//! Modules, one concept each: `device` (adapter selection, [`probe`]),
//! `timer` (timestamp queries), `upload` (the scene's buffers), `buffers`
//! (uniform layouts, bind group layouts and the named per-frame buffers),
//! `pipelines` (the shader and its compute pipelines), `full` (the
//! full-resolution frame), `foveated` (the foveated frame and its stages),
//! `readback` (mapping and unpacking the frame), `post` (the caller's
//! passes before the read-back), `raster` (the raster path), `traffic`
//! (what a frame moves between the CPU and the GPU).

mod buffers;
mod device;
mod foveated;
mod full;
mod hidden;
pub mod ownership;
mod pipelines;
mod post;
mod raster;
mod readback;
mod timer;
mod traffic;
mod upload;

pub use device::{open_device, open_shared, probe, GpuDevice};
pub use foveated::{foveated_stages, Stage};
pub use hidden::HIDDEN_HITS;
pub use post::{read_words, storage_buffer, GpuFrame, GpuPost};
pub use raster::off_axis_projection;
pub use traffic::{Traffic, TrafficCounter};
/// The `wgpu` this backend is built on, for callers of [`GpuPost`].
pub use wgpu;

use std::sync::Arc;

use crate::scene::Scene;

use buffers::{FoveatedTarget, FrameTarget, Layouts};
use pipelines::Pipelines;
use timer::Timer;
use upload::SceneBuffers;

/// Why the GPU backend cannot render.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpuError {
    /// No adapter was found; the message says why.
    #[error("no GPU adapter (not even a software one such as Mesa's lavapipe): {0}")]
    NoAdapter(String),
    /// The adapter would not give a device.
    #[error("the GPU device could not be created: {0}")]
    Device(String),
    /// A buffer would exceed the adapter's largest storage-buffer binding.
    #[error("{what} needs {bytes} bytes in one storage buffer; this adapter allows {limit} (max_storage_buffer_binding_size)")]
    TooLarge {
        /// What the buffer holds.
        what: &'static str,
        /// Bytes it needs.
        bytes: u64,
        /// The adapter's limit, bytes.
        limit: u64,
    },
    /// The raster targets exceed the adapter's largest 2-D texture.
    #[error("the raster targets need {width}×{height} pixels; this adapter's textures hold at most {limit} a side (max_texture_dimension_2d)")]
    TextureTooLarge {
        /// Width needed, pixels.
        width: u32,
        /// Height needed, pixels.
        height: u32,
        /// The adapter's largest texture side, pixels.
        limit: u32,
    },
    /// Mapping the read-back buffer failed.
    #[error("reading the frame back failed: {0}")]
    Readback(String),
}

/// The instance, adapter, device and queue a [`GpuRenderer`] renders on,
/// for a window that presents its frames on the same device
/// ([`GpuRenderer::shared`]); every handle is a cheap clone.
#[derive(Clone)]
pub struct SharedDevice {
    /// The wgpu instance.
    pub instance: wgpu::Instance,
    /// The adapter the device was made on.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    /// Bytes and calls moved on the device, shared with the renderer.
    pub traffic: Arc<TrafficCounter>,
}

/// A device with a scene on it.
pub struct GpuRenderer {
    instance: wgpu::Instance,
    adapter_handle: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    layouts: Layouts,
    pipelines: Pipelines,
    /// The `Params` uniform (group 0, binding 0).
    params: wgpu::Buffer,
    /// The `FovParams` uniform (group 1, binding 0).
    fov_params: wgpu::Buffer,
    scene: SceneBuffers,
    background: [f32; 3],
    background_rgb8: [u8; 3],
    /// The frame's output buffers, for the last frame size.
    target: Option<FrameTarget>,
    /// The foveated stages' buffers, made by the first foveated frame.
    fov_target: Option<FoveatedTarget>,
    /// The generation and frame size of the mask whose vertices, cells and
    /// pixel owners `fov_target` holds ([`GpuRenderer::render_foveated_kept`]);
    /// `None` after any other upload.
    uploaded_mask: Option<((u64, u64), (u32, u32))>,
    /// Bytes of mask and pixel owners the last foveated frame uploaded.
    mask_upload_bytes: u64,
    /// The pixel-ownership pipelines, made by the first new mask.
    ownership: Option<ownership::OwnershipPass>,
    adapter: String,
    max_binding: u64,
    /// The adapter reports `TIMESTAMP_QUERY`.
    timestamps: bool,
    timer: Option<Timer>,
    stage_ms: Vec<(&'static str, f64)>,
    /// Read the surface buffers (depth, object id, normal) back.
    surface: bool,
    /// Read each frame back ([`GpuRenderer::set_read_back`]).
    read_back: bool,
    /// The size of the last frame rendered into `target`.
    last_size: Option<(u32, u32)>,
    /// The hidden-image cast's pipeline, made by the first frame that asks.
    hidden: std::sync::OnceLock<hidden::HiddenCast>,
    /// The raster path's pipelines and buffers, made by the first
    /// [`GpuRenderer::rasterize`].
    raster: Option<raster::GpuRaster>,
    /// Every byte and call between the CPU and this device, since it was
    /// made (shared with the passes that encode on its frames).
    traffic: Arc<TrafficCounter>,
    /// What the last frame (`render_full_with`, `render_foveated_kept`,
    /// `rasterize`) moved, its post passes included.
    frame_traffic: Traffic,
}

impl GpuRenderer {
    /// Whether each frame is read back (the default). Off, a ray-cast
    /// frame (`render_full_with`, `render_foveated_kept`) leaves its
    /// outputs in the device's buffers for a caller that presents them
    /// there ([`GpuRenderer::frame_pixels`]): the `Frame` it returns has the
    /// frame's size and no pixels, and its pass timestamps are not read
    /// (`stage_ms` is empty). A foveated frame still reads its 16 bytes of
    /// ray counters (its `Stats`). [`GpuRenderer::read_last_frame`] reads
    /// such a frame back on demand (a screenshot). The raster path always
    /// reads back.
    pub fn set_read_back(&mut self, on: bool) {
        self.read_back = on;
    }

    /// Whether each frame is read back ([`GpuRenderer::set_read_back`]).
    pub fn reads_back(&self) -> bool {
        self.read_back
    }

    /// The last frame's pixel words on the device (`pack` in cast.wgsl:
    /// red, green, blue in the low three bytes, the hit flag and layer
    /// above), row-major, with its size; `None` before the first frame.
    pub fn frame_pixels(&self) -> Option<(&wgpu::Buffer, (u32, u32))> {
        Some((&self.target.as_ref()?.out.pixels, self.last_size?))
    }

    /// Reads the last frame's buffers back now (with the surface buffers
    /// when frames read them): what a frame rendered without read-back
    /// showed, for a screenshot.
    pub fn read_last_frame(&self) -> Result<crate::frame::Frame, GpuError> {
        let (Some(target), Some((w, h))) = (self.target.as_ref(), self.last_size) else {
            return Err(GpuError::Readback("no frame yet".into()));
        };
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("read the last frame"),
            });
        readback::copy_out(&mut encoder, &target.out, &target.readback, w * h);
        self.traffic.submit(&self.queue, encoder.finish());
        readback::read_frame(
            &self.device,
            &self.traffic,
            &target.readback,
            w,
            h,
            self.surface,
        )
    }

    /// The device this renderer renders on, for a window that presents its
    /// frames without a read-back (its surface must be made from this
    /// instance, and the adapter must be able to present to it).
    pub fn shared(&self) -> SharedDevice {
        SharedDevice {
            instance: self.instance.clone(),
            adapter: self.adapter_handle.clone(),
            device: self.device.clone(),
            queue: self.queue.clone(),
            traffic: self.traffic.clone(),
        }
    }

    /// Whether frames read the surface buffers (depth, object id, normal)
    /// back (the default); without them a frame has empty surface buffers
    /// and its read-back moves a fifth of the bytes.
    pub fn set_surface(&mut self, on: bool) {
        self.surface = on;
    }

    /// Picks an adapter (a real GPU first, a software one if that is all
    /// there is) and uploads the scene.
    pub fn new(scene: &Scene) -> Result<Self, GpuError> {
        Self::from_opened(device::open()?, scene)
    }

    /// A renderer with `scene` on a device already open (another
    /// renderer's, [`GpuRenderer::shared`], or [`open_shared`]'s), so that
    /// a window made on that device presents its frames and several
    /// renderers in turn (an experiment's trials) share one device. Its
    /// traffic is counted apart from the other users of the device.
    pub fn on_device(shared: &SharedDevice, scene: &Scene) -> Result<Self, GpuError> {
        Self::from_opened(device::Opened::of(shared), scene)
    }

    fn from_opened(opened: device::Opened, scene: &Scene) -> Result<Self, GpuError> {
        let device = opened.device;
        let max_binding = opened.max_binding;
        let timer = opened
            .timestamps
            .then(|| Timer::new(&device, &opened.queue));
        let traffic = Arc::new(TrafficCounter::default());
        let scene_buffers = SceneBuffers::upload(&device, &traffic, scene, max_binding)?;
        let layouts = Layouts::new(&device);
        let pipelines = Pipelines::new(&device, &layouts);
        let uniform = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let params = uniform("params", std::mem::size_of::<buffers::Params>() as u64);
        let fov_params = uniform(
            "foveated params",
            std::mem::size_of::<buffers::FovParams>() as u64,
        );
        let c = scene.background;
        Ok(Self {
            instance: opened.instance,
            adapter_handle: opened.adapter,
            read_back: true,
            last_size: None,
            queue: opened.queue,
            layouts,
            pipelines,
            params,
            fov_params,
            scene: scene_buffers,
            background: [c.x, c.y, c.z],
            background_rgb8: scene.background_rgb8,
            target: None,
            fov_target: None,
            uploaded_mask: None,
            mask_upload_bytes: 0,
            ownership: None,
            adapter: opened.name,
            max_binding,
            timestamps: opened.timestamps,
            timer,
            stage_ms: Vec::new(),
            surface: true,
            hidden: std::sync::OnceLock::new(),
            raster: None,
            traffic,
            frame_traffic: Traffic::default(),
            device,
        })
    }

    /// Replaces the scene on the device with `scene` as posed for the
    /// next frame (a moving scene, its BVH rebuilt on the CPU for the
    /// pose): its BVH, triangles, materials and lights are written into the
    /// buffers already there, or, when the pose's BVH outgrows them, into
    /// new ones (the gamma table is kept) and the cast's bind group is
    /// remade. The bytes count in the traffic of whoever measures around
    /// it.
    pub fn set_scene(&mut self, scene: &Scene) -> Result<(), GpuError> {
        let c = scene.background;
        self.background = [c.x, c.y, c.z];
        self.background_rgb8 = scene.background_rgb8;
        if self.scene.rewrite(&self.queue, &self.traffic, scene) {
            return Ok(());
        }
        self.scene = SceneBuffers::upload_with(
            &self.device,
            &self.traffic,
            scene,
            self.max_binding,
            Some(self.scene.gamma.clone()),
        )?;
        if let Some(t) = &mut self.target {
            t.bind_group = buffers::cast_group(
                &self.device,
                &self.layouts,
                &self.params,
                &self.scene,
                &t.out,
            );
        }
        // The raster path's groups hold the old materials and lights.
        self.raster = None;
        Ok(())
    }

    /// Whether the foveated stages' buffers exist (they are made by the first
    /// foveated frame; a full-resolution scene never allocates them).
    pub fn has_foveated_buffers(&self) -> bool {
        self.fov_target.is_some()
    }

    /// Bytes of ray mask the last foveated frame uploaded: its vertices,
    /// cells and fovea spans with the ownership pass's uniforms (the GPU
    /// builds the pixel owners), or its vertices, cells and pixel owners (4
    /// bytes a pixel) for a mask beyond the ownership shader's exact range
    /// (a vertex 8192 px or more off the origin); 0 when it rendered a mask
    /// already on the GPU ([`GpuRenderer::render_foveated_kept`]).
    pub fn mask_upload_bytes(&self) -> u64 {
        self.mask_upload_bytes
    }

    /// Whether the hidden-image cast's pipeline exists (made by the first
    /// frame whose post pass casts hidden rays, [`GpuFrame::cast_hidden`]).
    pub fn has_hidden_pipeline(&self) -> bool {
        self.hidden.get().is_some()
    }

    /// The largest storage buffer one binding may hold on this device (bytes).
    pub fn max_binding_bytes(&self) -> u64 {
        self.max_binding
    }

    /// GPU time of each stage of the last frame (ms), from timestamp
    /// queries; empty when the adapter has none. The names are
    /// [`Stage::name`] for a foveated frame and `"cast and shade"` for a
    /// full-resolution one.
    pub fn stage_ms(&self) -> &[(&'static str, f64)] {
        &self.stage_ms
    }

    /// Whether the adapter reports timestamp queries (`TIMESTAMP_QUERY`):
    /// then [`GpuRenderer::stage_ms`] has one entry per pass of the last
    /// frame, otherwise it is empty.
    pub fn has_timestamps(&self) -> bool {
        self.timestamps
    }

    /// The adapter in words (name, backend, type, driver).
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// What the last frame moved between the CPU and the GPU (its
    /// uploads, read-backs, dispatches, draws and submissions, its post
    /// passes included), counted at the `wgpu` calls; zero before the first.
    pub fn frame_traffic(&self) -> Traffic {
        self.frame_traffic
    }

    /// Everything this renderer has moved since it was made, the scene's
    /// upload included: a caller that renders several times per frame (or
    /// reads a frame's buffers after it) takes the difference of two totals.
    pub fn traffic_total(&self) -> Traffic {
        self.traffic.total()
    }

    /// The counter the renderer's calls go through, for passes that move
    /// bytes on its device outside a frame's post hook.
    pub fn traffic_counter(&self) -> &Arc<TrafficCounter> {
        &self.traffic
    }
}
