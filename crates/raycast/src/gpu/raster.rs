//! The GPU raster path of the model-based methods: a `wgpu` render pipeline
//! (`raster.wgsl` after `cast.wgsl`) that draws a list of
//! [`WorldTriangle`]s into the same G-buffer the caster fills, the GPU twin
//! of [`crate::raster::rasterize`].
//!
//! - **Projection.** The eye looks through the display: an off-axis
//!   frustum from `camera.eye` through the screen rectangle (z = 0, the
//!   camera's pixel count × pitch, centred on the origin), with the near
//!   plane of the CPU raster ([`NEAR_FRACTION`] of the eye distance in
//!   front of the eye) and the far plane at infinity (reversed Z: depth
//!   `near / distance along −z`, cleared to 0, `Greater` wins, in a
//!   `Depth32Float` buffer, so precision is relative and nothing in front
//!   of the near plane is clipped, as on the CPU). The vertex shader
//!   subtracts the eye before the matrix.
//! - **Coverage and visibility** are the hardware's: pixel centres, its
//!   fill rule and sub-pixel snapping (so silhouette pixels may differ from
//!   the CPU's), the depth test, the hardware's near clipping. Equal depth
//!   keeps the first triangle drawn (the lower index, as on the CPU).
//!   Nothing is culled by facing.
//! - **Shading**, in the fragment shader, is the caster's (`shade`,
//!   `to_rgb8` and the scene's uploaded materials, lights and gamma table):
//!   the normalised blend of the corner normals (perspective-correct
//!   interpolation, the face normal when it vanishes) at the interpolated
//!   world position; the eye distance is that position's distance to the
//!   eye (not the depth buffer's value).
//! - **Targets**: the packed colour word, the eye distance, the object id
//!   and the normal (R32Uint, R32Float, R32Uint, Rgba32Float); a compute
//!   pass resolves them into the frame's buffers, writing the background
//!   (background colour, no hit, depth +∞, [`NO_OBJECT`](crate::NO_OBJECT),
//!   normal 0) where nothing was drawn, and the caster's read-back takes it
//!   from there. Every pixel is in layer `Full`.
//!
//! Triangles with a non-finite corner, zero world area or an object without
//! a material are not uploaded, nor those wholly behind the near plane,
//! as [`crate::raster::rasterize`] skips them; the corners are uploaded per
//! call into a vertex buffer that only grows. The pipelines, targets and
//! buffers are made by the first call: a renderer that never rasterises
//! never has them ([`GpuRenderer::has_raster_buffers`]).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{DMat4, DVec4, Vec3};

use super::buffers::{bind, Layouts};
use super::readback::{copy_out, read_frame};
use super::{GpuError, GpuRenderer};
use crate::camera::Camera;
use crate::frame::{Frame, Layer};
use crate::raster::{RasterStats, NEAR_FRACTION};
use crate::scene::WorldTriangle;

/// `RasterVertex` in raster.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct RasterVertex {
    /// Position; w: the object id (bitcast).
    p: [f32; 4],
    n: [f32; 4],
    face: [f32; 4],
}

const VERTEX_BYTES: u64 = std::mem::size_of::<RasterVertex>() as u64;

/// The colour targets' formats, in `RasterTargets` order.
const TARGETS: [wgpu::TextureFormat; 4] = [
    wgpu::TextureFormat::R32Uint,
    wgpu::TextureFormat::R32Float,
    wgpu::TextureFormat::R32Uint,
    wgpu::TextureFormat::Rgba32Float,
];

/// The off-axis projection of eye-relative world positions (mm) to clip
/// space for `camera`, reversed Z with the far plane at infinity; `None`
/// when the eye is not finite and in front of the screen or the pitch is
/// not positive (nothing is drawn, as on the CPU).
pub fn off_axis_projection(camera: &Camera) -> Option<DMat4> {
    let eye = camera.eye.as_dvec3();
    let [px, py] = camera.pitch().map(f64::from);
    if !(eye.is_finite() && eye.z > 0.0 && px > 0.0 && py > 0.0 && px.is_finite() && py.is_finite())
    {
        return None;
    }
    let d = eye.z;
    let (w, h) = (
        f64::from(camera.width_px) * px,
        f64::from(camera.height_px) * py,
    );
    // The screen's edges relative to the eye, on the plane at distance d.
    let (l, r) = (-w / 2.0 - eye.x, w / 2.0 - eye.x);
    let (b, t) = (-h / 2.0 - eye.y, h / 2.0 - eye.y);
    let near = NEAR_FRACTION * d;
    Some(DMat4::from_cols(
        DVec4::new(2.0 * d / (r - l), 0.0, 0.0, 0.0),
        DVec4::new(0.0, 2.0 * d / (t - b), 0.0, 0.0),
        DVec4::new((r + l) / (r - l), (t + b) / (t - b), 0.0, -1.0),
        DVec4::new(0.0, 0.0, near, 0.0),
    ))
}

/// `RasterParams` in raster.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct RasterParams {
    clip: [[f32; 4]; 4],
}

/// The colour targets and the depth buffer for one frame size, and the
/// resolve pass's bind group over them.
struct Targets {
    size: (u32, u32),
    views: Vec<wgpu::TextureView>,
    depth: wgpu::TextureView,
    resolve_group: wgpu::BindGroup,
}

/// The raster path's pipelines and buffers (made by the first raster frame).
pub(super) struct GpuRaster {
    draw_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    draw: wgpu::RenderPipeline,
    resolve: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// The corners, three per drawn triangle; capacity in vertices.
    vertices: Option<(wgpu::Buffer, u64, wgpu::BindGroup)>,
    targets: Option<Targets>,
    /// The corners of the last call (reused).
    staging: Vec<RasterVertex>,
}

impl GpuRaster {
    fn new(device: &wgpu::Device, layouts: &Layouts) -> Self {
        use wgpu::ShaderStages as S;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cast.wgsl + raster.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                format!(
                    "{}\n{}",
                    include_str!("cast.wgsl"),
                    include_str!("raster.wgsl")
                )
                .into(),
            ),
        });
        let buffer_entry = |binding, visibility, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let read_only = wgpu::BufferBindingType::Storage { read_only: true };
        let uniform = wgpu::BufferBindingType::Uniform;
        // Group 0 of the draw: params, materials, lights, gamma (cast.wgsl's
        // bindings), the projection and the corners.
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raster draw"),
            entries: &[
                buffer_entry(0, S::VERTEX | S::FRAGMENT, uniform),
                buffer_entry(3, S::FRAGMENT, read_only),
                buffer_entry(4, S::FRAGMENT, read_only),
                buffer_entry(5, S::FRAGMENT, read_only),
                buffer_entry(10, S::VERTEX, uniform),
                buffer_entry(11, S::VERTEX, read_only),
            ],
        });
        let texture_entry = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: S::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raster resolve"),
            entries: &[
                texture_entry(0, wgpu::TextureSampleType::Uint),
                texture_entry(1, float),
                texture_entry(2, wgpu::TextureSampleType::Uint),
                texture_entry(3, float),
            ],
        });
        let pipeline_layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: groups,
                immediate_size: 0,
            })
        };
        let targets = TARGETS.map(|format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        });
        let draw = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("raster"),
            layout: Some(&pipeline_layout("raster draw", &[Some(&draw_layout)])),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("raster_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("raster_fragment"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        let resolve = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("raster resolve"),
            layout: Some(&pipeline_layout(
                "raster resolve",
                &[Some(&layouts.cast), Some(&resolve_layout)],
            )),
            module: &module,
            entry_point: Some("raster_resolve"),
            compilation_options: Default::default(),
            cache: None,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("raster params"),
            size: std::mem::size_of::<RasterParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            draw_layout,
            resolve_layout,
            draw,
            resolve,
            params,
            vertices: None,
            targets: None,
            staging: Vec::new(),
        }
    }
}

/// The corners of the triangles to draw into `out`; returns the stats of
/// the set-up (invalid and behind counted as [`crate::raster::rasterize`]
/// counts them).
fn corners(
    triangles: &[WorldTriangle],
    materials: usize,
    near_z: Option<f32>,
    out: &mut Vec<RasterVertex>,
) -> RasterStats {
    out.clear();
    let mut stats = RasterStats {
        triangles_in: triangles.len() as u64,
        ..RasterStats::default()
    };
    for t in triangles {
        let Some(near_z) = near_z else {
            // No frustum: nothing is drawn (the CPU counts it all behind).
            stats.culled_behind += 1;
            continue;
        };
        let face = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        if t.object as usize >= materials
            || !t.p.iter().all(|p| p.is_finite())
            || face == Vec3::ZERO
        {
            stats.culled_invalid += 1;
            continue;
        }
        if t.p.iter().all(|p| p.z > near_z) {
            stats.culled_behind += 1;
            continue;
        }
        let face = face.try_normalize().unwrap_or(Vec3::ZERO);
        let object = f32::from_bits(t.object);
        for (p, n) in t.p.iter().zip(&t.n) {
            out.push(RasterVertex {
                p: [p.x, p.y, p.z, object],
                n: [n.x, n.y, n.z, 0.0],
                face: [face.x, face.y, face.z, 0.0],
            });
        }
        stats.drawn += 1;
    }
    stats.culled = stats.culled_invalid + stats.culled_behind;
    stats
}

impl GpuRenderer {
    /// Whether the raster path's pipelines and buffers exist (made by the
    /// first [`GpuRenderer::rasterize`]; a renderer that only casts never
    /// has them).
    pub fn has_raster_buffers(&self) -> bool {
        self.raster.is_some()
    }

    /// Draws `triangles` (object ids index the uploaded scene's materials)
    /// as seen by `camera` with the GPU's rasteriser into `frame` (which
    /// takes the camera's size), filling the surface buffers when `surface`
    /// is set: an off-axis frustum through the display (reversed Z, far
    /// plane at infinity, the CPU raster's near plane), the hardware's
    /// coverage and depth test, the caster's shading in the fragment shader
    /// and a compute pass that resolves the targets into the frame's
    /// buffers (the notes are in `gpu/raster.rs`). The stats count as
    /// [`crate::raster::rasterize`]'s, except that the GPU does not report
    /// its coverage: `drawn` holds every triangle uploaded (also those that
    /// cover no pixel centre, so `culled_no_pixels` is 0) and `fragments`
    /// is 0; `pixels_covered` is counted from the frame.
    pub fn rasterize(
        &mut self,
        camera: &Camera,
        triangles: &[WorldTriangle],
        surface: bool,
        frame: &mut Frame,
    ) -> Result<RasterStats, GpuError> {
        let start = Instant::now();
        let traffic = self.traffic.clone();
        let before = traffic.total();
        let (w, h) = (camera.width_px, camera.height_px);
        let pixels = self.write_params(camera)?;
        let limit = self.device.limits().max_texture_dimension_2d;
        if w > limit || h > limit {
            return Err(GpuError::TextureTooLarge {
                width: w,
                height: h,
                limit,
            });
        }
        let projection = off_axis_projection(camera);
        let near_z = projection.map(|_| camera.eye.z * (1.0 - NEAR_FRACTION as f32));
        let device = self.device.clone();
        let queue = self.queue.clone();
        let layouts = &self.layouts;
        let raster = self
            .raster
            .get_or_insert_with(|| GpuRaster::new(&device, layouts));
        let mut stats = corners(
            triangles,
            self.scene.n_materials as usize,
            near_z,
            &mut raster.staging,
        );
        if pixels == 0 {
            *frame = Frame::blank(w, h, self.background_rgb8, Layer::Full, surface);
            stats.time_ms = start.elapsed().as_secs_f64() * 1e3;
            self.frame_traffic = traffic.total().since(before);
            return Ok(stats);
        }
        let clip = projection
            .unwrap_or(DMat4::ZERO)
            .as_mat4()
            .to_cols_array_2d();
        traffic.write_buffer(
            &queue,
            &raster.params,
            0,
            bytemuck::bytes_of(&RasterParams { clip }),
        );

        // The corners: a buffer that only grows.
        let n_vertices = raster.staging.len() as u64;
        let bytes = n_vertices * VERTEX_BYTES;
        if bytes > self.max_binding {
            return Err(GpuError::TooLarge {
                what: "the triangles to rasterise",
                bytes,
                limit: self.max_binding,
            });
        }
        if raster.vertices.as_ref().is_none_or(|v| v.1 < n_vertices) {
            raster.vertices = None;
            let cap = (n_vertices + n_vertices / 4)
                .max(3 * 1024)
                .min(self.max_binding / VERTEX_BYTES);
            let buffer = super::buffers::storage(
                &device,
                "the triangles to rasterise",
                cap * VERTEX_BYTES,
                wgpu::BufferUsages::COPY_DST,
                self.max_binding,
            )?;
            let group = bind(
                &device,
                &raster.draw_layout,
                "raster draw",
                &[
                    (0, &self.params),
                    (3, &self.scene.object_materials),
                    (4, &self.scene.lights),
                    (5, &self.scene.gamma),
                    (10, &raster.params),
                    (11, &buffer),
                ],
            );
            raster.vertices = Some((buffer, cap, group));
        }
        // The targets, remade when the frame size changes.
        if raster.targets.as_ref().is_none_or(|t| t.size != (w, h)) {
            raster.targets = None;
            raster.targets = Some(targets(&device, &raster.resolve_layout, w, h));
        }
        let raster: &GpuRaster = raster;
        let (vertex_buffer, _, draw_group) = raster
            .vertices
            .as_ref()
            .ok_or_else(|| GpuError::Readback("no raster vertex buffer".into()))?;
        if n_vertices > 0 {
            traffic.write_buffer(
                &queue,
                vertex_buffer,
                0,
                bytemuck::cast_slice(&raster.staging),
            );
        }
        let targets = raster
            .targets
            .as_ref()
            .ok_or_else(|| GpuError::Readback("no raster targets".into()))?;

        // The frame's output buffers (shared with the caster).
        let target = match &self.target {
            Some(t) if t.pixels == pixels => t,
            _ => {
                self.target = None;
                self.target = Some(super::buffers::FrameTarget::new(
                    &device,
                    &self.layouts,
                    &self.params,
                    &self.scene,
                    pixels,
                    self.max_binding,
                )?);
                self.target
                    .as_ref()
                    .ok_or_else(|| GpuError::Readback("no frame buffers".into()))?
            }
        };

        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("raster frame"),
        });
        {
            let attachments: Vec<_> = targets
                .views
                .iter()
                .map(|view| {
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                })
                .collect();
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("raster"),
                color_attachments: &attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &targets.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if n_vertices > 0 {
                pass.set_pipeline(&raster.draw);
                pass.set_bind_group(0, draw_group, &[]);
                // n_vertices ≤ max_binding / 48 < 2^32.
                traffic.draw(&mut pass, 0..n_vertices as u32, 0..1);
            }
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("raster resolve"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&raster.resolve);
            pass.set_bind_group(0, &target.bind_group, &[]);
            pass.set_bind_group(1, &targets.resolve_group, &[]);
            traffic.dispatch(&mut pass, w.div_ceil(8), h.div_ceil(8), 1);
        }
        copy_out(&mut encoder, &target.out, &target.readback, pixels);
        traffic.submit(&queue, encoder.finish());
        self.last_size = Some((w, h));
        *frame = read_frame(&device, &traffic, &target.readback, w, h, surface)?;
        self.stage_ms.clear();
        stats.pixels_covered = frame.hit.iter().filter(|&&h| h).count() as u64;
        stats.time_ms = start.elapsed().as_secs_f64() * 1e3;
        self.frame_traffic = traffic.total().since(before);
        Ok(stats)
    }
}

/// The colour targets and depth buffer of a `w` × `h` frame (both ≥ 1 and
/// within the texture limit) and the resolve pass's bind group over them.
fn targets(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, w: u32, h: u32) -> Targets {
    let texture = |label, format, usage| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
    let names = [
        "raster colour",
        "raster eye distance",
        "raster object",
        "raster normal",
    ];
    let views: Vec<wgpu::TextureView> = names
        .iter()
        .zip(TARGETS)
        .map(|(&name, format)| texture(name, format, usage))
        .collect();
    let depth = texture(
        "raster depth",
        wgpu::TextureFormat::Depth32Float,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let entries: Vec<wgpu::BindGroupEntry> = views
        .iter()
        .enumerate()
        .map(|(i, view)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: wgpu::BindingResource::TextureView(view),
        })
        .collect();
    let resolve_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("raster resolve"),
        layout,
        entries: &entries,
    });
    Targets {
        size: (w, h),
        views,
        depth,
        resolve_group,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The projection maps the screen's corners to the NDC corners and the
    /// near plane to depth 1, and a point on the screen plane to the pixel
    /// the camera says.
    #[test]
    fn the_off_axis_frustum_maps_the_screen_rectangle() {
        let g = foveation::Display {
            name: "t".into(),
            resolution_px: (320, 256),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 540.0,
            eye_point_px: Some((40.0, 200.0)),
        }
        .geometry()
        .expect("geometry");
        let cam = Camera::new(&g);
        let m = off_axis_projection(&cam).expect("a frustum");
        let eye = cam.eye.as_dvec3();
        let ndc = |p: glam::DVec3| {
            let c = m * (p - eye).extend(1.0);
            c.truncate() / c.w
        };
        for (px, want) in [
            ([0.0, 0.0], [-1.0, 1.0]),
            ([320.0, 256.0], [1.0, -1.0]),
            ([320.0, 0.0], [1.0, 1.0]),
            ([160.0, 128.0], [0.0, 0.0]),
        ] {
            let p = ndc(cam.screen_point(px).as_dvec3());
            assert!(
                (p.x - want[0]).abs() < 1e-5 && (p.y - want[1]).abs() < 1e-5,
                "{px:?} → {p}"
            );
            assert!((p.z - NEAR_FRACTION).abs() < 1e-9, "depth {}", p.z);
        }
        let near = eye - glam::DVec3::Z * (NEAR_FRACTION * eye.z);
        assert!((ndc(near).z - 1.0).abs() < 1e-12);
        let mut behind = cam;
        behind.eye.z = -1.0;
        assert!(off_axis_projection(&behind).is_none());
    }
}
