//! What the GPU frame moves between the CPU and the GPU, counted where it
//! is moved: every byte handed to `Queue::write_buffer` /
//! `Queue::write_texture` or to a buffer created with contents
//! (`create_buffer_init`, mapped at creation), every byte of a range mapped
//! for reading (`map_async` with `MapMode::Read`), every compute dispatch
//! (direct or indirect), draw call and queue submission. Nothing is
//! estimated: the GPU core and the pipeline's GPU passes make these calls
//! only through a [`TrafficCounter`], which adds the very lengths it passes
//! to `wgpu`.
//!
//! The counter is cumulative (atomics, shared by the renderer and the
//! passes that encode on its frames); a frame's [`Traffic`] is the
//! difference of two totals ([`Traffic::since`]).

use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes and calls between the CPU and the GPU: one frame's
/// ([`super::GpuRenderer::frame_traffic`]) or a total.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize)]
pub struct Traffic {
    /// Bytes uploaded: `write_buffer`, `write_texture`, buffers created
    /// with contents.
    pub uploaded_bytes: u64,
    /// Bytes read back: ranges mapped for reading.
    pub read_back_bytes: u64,
    /// Compute dispatches (direct and indirect).
    pub dispatches: u64,
    /// Draw calls in render passes.
    pub draws: u64,
    /// Queue submissions.
    pub submits: u64,
}

impl Traffic {
    /// What was counted after `earlier` (a total taken before this one).
    pub fn since(self, earlier: Traffic) -> Traffic {
        Traffic {
            uploaded_bytes: self.uploaded_bytes.saturating_sub(earlier.uploaded_bytes),
            read_back_bytes: self.read_back_bytes.saturating_sub(earlier.read_back_bytes),
            dispatches: self.dispatches.saturating_sub(earlier.dispatches),
            draws: self.draws.saturating_sub(earlier.draws),
            submits: self.submits.saturating_sub(earlier.submits),
        }
    }
}

/// The running totals behind [`Traffic`]; every call that moves bytes or
/// work to the GPU goes through one of its methods.
#[derive(Debug, Default)]
pub struct TrafficCounter {
    uploaded: AtomicU64,
    read_back: AtomicU64,
    dispatches: AtomicU64,
    draws: AtomicU64,
    submits: AtomicU64,
}

fn add(counter: &AtomicU64, n: u64) {
    counter.fetch_add(n, Ordering::Relaxed);
}

impl TrafficCounter {
    /// Everything counted so far.
    pub fn total(&self) -> Traffic {
        Traffic {
            uploaded_bytes: self.uploaded.load(Ordering::Relaxed),
            read_back_bytes: self.read_back.load(Ordering::Relaxed),
            dispatches: self.dispatches.load(Ordering::Relaxed),
            draws: self.draws.load(Ordering::Relaxed),
            submits: self.submits.load(Ordering::Relaxed),
        }
    }

    /// `queue.write_buffer(buffer, offset, data)`, counting `data`'s bytes.
    pub fn write_buffer(
        &self,
        queue: &wgpu::Queue,
        buffer: &wgpu::Buffer,
        offset: wgpu::BufferAddress,
        data: &[u8],
    ) {
        add(&self.uploaded, data.len() as u64);
        queue.write_buffer(buffer, offset, data);
    }

    /// `queue.write_texture(…)`, counting `data`'s bytes.
    pub fn write_texture(
        &self,
        queue: &wgpu::Queue,
        texture: wgpu::TexelCopyTextureInfo<'_>,
        data: &[u8],
        layout: wgpu::TexelCopyBufferLayout,
        size: wgpu::Extent3d,
    ) {
        add(&self.uploaded, data.len() as u64);
        queue.write_texture(texture, data, layout, size);
    }

    /// A buffer created with `desc.contents` (mapped at creation and
    /// filled), counting its bytes.
    pub fn buffer_init(
        &self,
        device: &wgpu::Device,
        desc: &wgpu::util::BufferInitDescriptor<'_>,
    ) -> wgpu::Buffer {
        add(&self.uploaded, desc.contents.len() as u64);
        wgpu::util::DeviceExt::create_buffer_init(device, desc)
    }

    /// `queue.submit(command)`, counting one submission.
    pub fn submit(&self, queue: &wgpu::Queue, command: wgpu::CommandBuffer) {
        add(&self.submits, 1);
        queue.submit(Some(command));
    }

    /// `pass.dispatch_workgroups(x, y, z)`, counting one dispatch.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, x: u32, y: u32, z: u32) {
        add(&self.dispatches, 1);
        pass.dispatch_workgroups(x, y, z);
    }

    /// `pass.dispatch_workgroups_indirect(buffer, offset)`, counting one
    /// dispatch.
    pub fn dispatch_indirect(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        buffer: &wgpu::Buffer,
        offset: wgpu::BufferAddress,
    ) {
        add(&self.dispatches, 1);
        pass.dispatch_workgroups_indirect(buffer, offset);
    }

    /// `pass.draw(vertices, instances)`, counting one draw call.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        vertices: std::ops::Range<u32>,
        instances: std::ops::Range<u32>,
    ) {
        add(&self.draws, 1);
        pass.draw(vertices, instances);
    }

    /// `bytes` of a range mapped for reading (counted when the map is
    /// asked for).
    pub(super) fn read(&self, bytes: u64) {
        add(&self.read_back, bytes);
    }
}
