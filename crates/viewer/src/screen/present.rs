//! Presenting a frame that stayed on the GPU: a render pass on the
//! renderer's own device draws the frame's pixel words (and the HUD's
//! overlay) into the surface texture, so the frame is neither read back
//! nor uploaded again. Made only for a window whose surface is on the
//! renderer's device ([`super::Screen::open`] with a shared device).

use std::borrow::Cow;

/// The uniform: the frame's size and the overlay's.
#[repr(C)]
#[derive(Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
struct Sizes {
    width: u32,
    height: u32,
    overlay_width: u32,
    overlay_height: u32,
    overlay_x: u32,
    overlay_y: u32,
    pad: [u32; 2],
}

/// An [`Overlay`] that owns its words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OverlayBuf {
    /// RGBA words, row-major (see [`Overlay`]).
    pub words: Vec<u32>,
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// Top left in the frame, pixels.
    pub origin: (u32, u32),
}

impl OverlayBuf {
    /// The overlay, borrowed.
    pub fn as_overlay(&self) -> Overlay<'_> {
        Overlay {
            words: &self.words,
            size: self.size,
            origin: self.origin,
        }
    }
}

/// An overlay drawn over the frame: RGBA words (row-major, red in the low
/// byte, alpha 0 where the frame shows through), its size and its top
/// left in the frame.
#[derive(Clone, Copy)]
pub struct Overlay<'a> {
    /// RGBA words, row-major, red in the low byte; alpha 0 shows the frame.
    pub words: &'a [u32],
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// Top left in the frame, pixels.
    pub origin: (u32, u32),
}

/// The pipeline, its uniform and the overlay's buffer.
pub(super) struct GpuPresent {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sizes: wgpu::Buffer,
    /// The sizes the uniform holds (written only when they change).
    written: Option<Sizes>,
    overlay: wgpu::Buffer,
    overlay_size: (u32, u32),
    overlay_origin: (u32, u32),
    /// The bind group and the frame buffer it was made for: made again
    /// only when the renderer's buffer or the overlay's changes, not per
    /// frame.
    group: Option<(wgpu::Buffer, wgpu::BindGroup)>,
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn overlay_buffer(device: &wgpu::Device, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("HUD overlay"),
        size: bytes.max(4),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

impl GpuPresent {
    /// The pipeline for a surface of `format` (8-bit RGBA or BGRA).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("present"),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(include_str!("present.wgsl"))),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("present"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage_entry(1),
                storage_entry(2),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("present"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("present"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let sizes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("present sizes"),
            size: std::mem::size_of::<Sizes>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            sizes,
            written: None,
            overlay: overlay_buffer(device, 4),
            overlay_size: (0, 0),
            overlay_origin: (0, 0),
            group: None,
        }
    }

    /// Replaces the overlay (`None`, or one whose words do not match its
    /// size: no overlay); returns the bytes uploaded.
    pub fn set_overlay(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        overlay: Option<Overlay<'_>>,
    ) -> u64 {
        let Some(o) = overlay.filter(|o| {
            u64::from(o.size.0) * u64::from(o.size.1) == o.words.len() as u64 && !o.words.is_empty()
        }) else {
            self.overlay_size = (0, 0);
            return 0;
        };
        let bytes: &[u8] = bytemuck::cast_slice(o.words);
        if self.overlay.size() < bytes.len() as u64 {
            self.overlay = overlay_buffer(device, bytes.len() as u64);
            self.group = None;
        }
        queue.write_buffer(&self.overlay, 0, bytes);
        self.overlay_size = o.size;
        self.overlay_origin = o.origin;
        bytes.len() as u64
    }

    /// Encodes the draw of the `w` × `h` frame in `pixels` (with the
    /// overlay) into `view`; returns the command buffer and the bytes
    /// uploaded (the uniform, when the sizes changed).
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        view: &wgpu::TextureView,
        pixels: &wgpu::Buffer,
        (width, height): (u32, u32),
    ) -> (wgpu::CommandBuffer, u64) {
        let sizes = Sizes {
            width,
            height,
            overlay_width: self.overlay_size.0,
            overlay_height: self.overlay_size.1,
            overlay_x: self.overlay_origin.0,
            overlay_y: self.overlay_origin.1,
            pad: [0; 2],
        };
        let mut uploaded = 0;
        if self.written != Some(sizes) {
            queue.write_buffer(&self.sizes, 0, bytemuck::bytes_of(&sizes));
            self.written = Some(sizes);
            uploaded = std::mem::size_of::<Sizes>() as u64;
        }
        if self.group.as_ref().is_none_or(|(b, _)| b != pixels) {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("present"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.sizes.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: pixels.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: self.overlay.as_entire_binding(),
                    },
                ],
            });
            self.group = Some((pixels.clone(), group));
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("present"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("present"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            // Made just above.
            if let Some((_, group)) = &self.group {
                pass.set_bind_group(0, group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
        (encoder.finish(), uploaded)
    }
}
