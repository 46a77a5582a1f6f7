//! The post-pass hook: a caller's compute passes on a frame's buffers,
//! encoded between the cast and the read-back ([`GpuPost`]), so that an
//! image pass (depth of field, image-based foveation) runs on the GPU
//! without a CPU round trip of the image.
//!
//! The frame's buffers as [`GpuFrame`] shows them:
//! - `pixels`: one `u32` per pixel (row-major), `pack` in cast.wgsl: red in
//!   bits 0–7, green 8–15, blue 16–23 (gamma-encoded bytes, what the
//!   read-back turns into `Frame::rgb`), the hit flag in bit 24, the layer
//!   in bits 25–26. A pass that changes the colour must keep bits 24–31.
//! - `depth`: one `f32` per pixel, the eye distance (mm) where the hit flag
//!   is set, `3.4028235e38` (f32::MAX) where it is not.
//! - `object_ids`: one `u32` per pixel, the object hit, `0xffffffff` where
//!   nothing is (Lee's item buffer; the attention model reads it).
//!
//! All three are bound as storage (`pixels` read-write). A pass may submit the
//! encoder it is given and go on in a new one (to read a few words back,
//! [`GpuFrame::read_words`]); the read-back is appended to the encoder it
//! returns. Post passes are not timed in `stage_ms`: the frame's `Stats`
//! time (wall clock) includes them. What they upload, read back, dispatch
//! and submit goes through [`GpuFrame::traffic`], so that it counts in the
//! frame's [`Traffic`](super::Traffic).

use super::buffers::storage;
use super::hidden::HiddenHook;
use super::readback::read_back;
use super::{GpuError, TrafficCounter};

/// A frame on the GPU after its cast, before its read-back.
pub struct GpuFrame<'a> {
    pub(super) device: &'a wgpu::Device,
    pub(super) queue: &'a wgpu::Queue,
    pub(super) pixels: &'a wgpu::Buffer,
    pub(super) depth: &'a wgpu::Buffer,
    pub(super) object: &'a wgpu::Buffer,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) max_binding: u64,
    /// The renderer's counter of bytes and calls.
    pub(super) traffic: &'a TrafficCounter,
    /// The frame's cast bind group and the hidden-image pipeline.
    pub(super) hidden: HiddenHook<'a>,
}

impl<'a> GpuFrame<'a> {
    /// The renderer's device.
    pub fn device(&self) -> &'a wgpu::Device {
        self.device
    }

    /// The renderer's queue (submit through [`GpuFrame::traffic`] to have it counted).
    pub fn queue(&self) -> &'a wgpu::Queue {
        self.queue
    }

    /// The renderer's counter: a pass uploads, dispatches and submits
    /// through it (not through `queue()` directly), so that the frame's
    /// [`Traffic`](super::Traffic) holds what it moved.
    pub fn traffic(&self) -> &'a TrafficCounter {
        self.traffic
    }

    /// `queue().write_buffer(…)`, counted.
    pub fn write_buffer(&self, buffer: &wgpu::Buffer, offset: u64, data: &[u8]) {
        self.traffic.write_buffer(self.queue, buffer, offset, data);
    }

    /// The packed colour words (see the module's notes), `width·height` of them.
    pub fn pixels(&self) -> &'a wgpu::Buffer {
        self.pixels
    }

    /// The eye distance per pixel (f32, mm; f32::MAX where nothing is hit).
    pub fn depth(&self) -> &'a wgpu::Buffer {
        self.depth
    }

    /// The object id per pixel (u32; `0xffffffff` where nothing is hit).
    pub fn object_ids(&self) -> &'a wgpu::Buffer {
        self.object
    }

    /// Frame width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Frame height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The device's `max_storage_buffer_binding_size` (bytes).
    pub fn max_binding_bytes(&self) -> u64 {
        self.max_binding
    }

    /// A storage buffer of `bytes` bytes (with `extra` usages), refused with
    /// [`GpuError::TooLarge`] above the storage-binding limit.
    pub fn storage_buffer(
        &self,
        what: &'static str,
        bytes: u64,
        extra: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        storage_buffer(self.device, what, bytes, extra, self.max_binding)
    }

    /// Submits `encoder` with copies of the word ranges `reads` (buffer,
    /// first word, number of words) into one small mappable buffer, waits,
    /// and returns the words of each range, with a fresh encoder for the
    /// rest of the frame. For small reads (a focus window): every word
    /// costs a wait on the GPU.
    pub fn read_words(
        &self,
        encoder: wgpu::CommandEncoder,
        reads: &[(&wgpu::Buffer, u64, u64)],
    ) -> Result<(Vec<Vec<u32>>, wgpu::CommandEncoder), GpuError> {
        read_words(self.device, self.queue, self.traffic, encoder, reads)
    }
}

/// A storage buffer of `bytes` bytes (at least 4, with `extra` usages) on
/// `device`, refused with [`GpuError::TooLarge`] above `max_binding`.
pub fn storage_buffer(
    device: &wgpu::Device,
    what: &'static str,
    bytes: u64,
    extra: wgpu::BufferUsages,
    max_binding: u64,
) -> Result<wgpu::Buffer, GpuError> {
    storage(device, what, bytes.max(4), extra, max_binding)
}

/// Submits `encoder` with copies of the word ranges `reads` (buffer, first
/// word, number of words; each buffer with `COPY_SRC`) into one small
/// mappable buffer, waits, and returns the words of each range, with a
/// fresh encoder for what follows. Every call is a wait on the GPU.
pub fn read_words(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    traffic: &TrafficCounter,
    mut encoder: wgpu::CommandEncoder,
    reads: &[(&wgpu::Buffer, u64, u64)],
) -> Result<(Vec<Vec<u32>>, wgpu::CommandEncoder), GpuError> {
    let total: u64 = reads.iter().map(|r| r.2).sum();
    let fresh = |d: &wgpu::Device| {
        d.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame, after a read"),
        })
    };
    if total == 0 {
        return Ok((reads.iter().map(|_| Vec::new()).collect(), encoder));
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("post read"),
        size: 4 * total,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut at = 0u64;
    for &(buffer, first, n) in reads {
        if n > 0 {
            encoder.copy_buffer_to_buffer(buffer, 4 * first, &staging, 4 * at, 4 * n);
        }
        at += n;
    }
    traffic.submit(queue, encoder.finish());
    let words = read_back(device, traffic, &staging, 4 * total)?;
    let mut out = Vec::with_capacity(reads.len());
    let mut at = 0usize;
    for &(_, _, n) in reads {
        let n = n as usize;
        let part = words
            .get(at..at + n)
            .ok_or_else(|| GpuError::Readback("short post read".into()))?;
        out.push(part.to_vec());
        at += n;
    }
    Ok((out, fresh(device)))
}

/// Compute passes a caller encodes on a frame's buffers between the cast
/// and the read-back ([`GpuRenderer::render_full_with`](super::GpuRenderer::render_full_with),
/// [`GpuRenderer::render_foveated_with`](super::GpuRenderer::render_foveated_with)).
pub trait GpuPost {
    /// Encodes the passes on `frame` into `encoder` (which it may submit,
    /// going on in a new one) and returns the encoder the read-back is
    /// appended to.
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError>;
}

impl super::GpuRenderer {
    /// Encodes `post`'s passes on the frame target's buffers, between the
    /// cast and the read-back: the one hook every method's GPU frame uses.
    pub(super) fn encode_post(
        &self,
        target: &super::buffers::FrameTarget,
        post: Option<&mut dyn GpuPost>,
        (width, height): (u32, u32),
        encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let Some(post) = post else {
            return Ok(encoder);
        };
        let frame = GpuFrame {
            device: &self.device,
            queue: &self.queue,
            pixels: &target.out.pixels,
            depth: &target.out.depth,
            object: &target.out.object,
            width,
            height,
            max_binding: self.max_binding,
            traffic: &self.traffic,
            hidden: super::hidden::HiddenHook {
                layouts: &self.layouts,
                cast_group: &target.bind_group,
                cast: &self.hidden,
            },
        };
        post.encode(&frame, encoder)
    }
}
