//! The GPU core in `wgpu` compute (WGSL in `cast.wgsl`).
//!
//! **State (issue 6, in progress):** the scene (flattened binary BVH,
//! triangles, per-object materials, lights, the gamma table) is uploaded once.
//! Full resolution: one compute pass casts and shades one ray per pixel.
//! Foveated (`foveated.wgsl`): the CPU builds the ray mask and the pixel
//! ownership for the gaze (they depend on the gaze only) and uploads them;
//! the GPU casts the mask vertices, classifies the cells, widens the refined
//! set by the silhouette margin, then per pixel casts (fovea, refined cells)
//! or interpolates (homogeneous cells) and shades — stage for stage the CPU's
//! `render::foveated`. Not yet: building the mask and ownership on the GPU,
//! compacting the refined pixels with an atomic counter and an indirect
//! dispatch, timestamp queries. The frame is read back.
//!
//! Any adapter works, including Mesa's lavapipe (software Vulkan), which is
//! how the tests run on machines without a GPU. A buffer larger than the
//! device's storage-binding limit is refused with a message naming the limit.

use std::sync::mpsc;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::camera::Camera;
use crate::render::{Frame, Layer, Stats, Triggers};
use crate::scene::{Light, Scene};
use foveation::mask::{RayMask, NO_VERTEX};

/// Why the GPU backend cannot render.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter (not even a software one such as Mesa's lavapipe): {0}")]
    NoAdapter(String),
    #[error("the GPU device could not be created: {0}")]
    Device(String),
    #[error("{what} needs {bytes} bytes in one storage buffer; this adapter allows {limit} (max_storage_buffer_binding_size)")]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error("reading the frame back failed: {0}")]
    Readback(String),
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    width: u32,
    height: u32,
    n_lights: u32,
    n_triangles: u32,
    eye: [f32; 4],
    pitch: [f32; 4],
    background: [f32; 4],
    background_rgb8: [u32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuTriangle {
    p: [[f32; 4]; 3],
    n: [[f32; 4]; 3],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuMaterial {
    diffuse: [f32; 4],
    specular: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuLight {
    kind: [u32; 4],
    data: [f32; 4],
}

/// Output buffers for one frame size, reused frame after frame.
struct Target {
    pixels: u32,
    out: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct FovParams {
    n_vertices: u32,
    n_cells: u32,
    silhouette: u32,
    margin: u32,
    crease_cos: f32,
    depth_jump: f32,
    pad: [u32; 2],
}

/// The foveated stages' buffers, grown when a mask needs more.
struct FovTarget {
    vertices: u64,
    cells: u64,
    pixels: u64,
    buffers: Vec<wgpu::Buffer>,
    counters_readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    dispatch_group: wgpu::BindGroup,
}

/// Bytes per vertex hit record in `foveated.wgsl` (`Sample`: 32 bytes).
const SAMPLE_BYTES: u64 = 32;

/// A device with a scene on it.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    fov_pipelines: [wgpu::ComputePipeline; 7],
    fov_layout: wgpu::BindGroupLayout,
    dispatch_layout: wgpu::BindGroupLayout,
    fov_params: wgpu::Buffer,
    fov_target: Option<FovTarget>,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    scene_buffers: [wgpu::Buffer; 5],
    n_triangles: u32,
    n_lights: u32,
    background: [f32; 3],
    background_rgb8: [u8; 3],
    target: Option<Target>,
    adapter: String,
    max_binding: u64,
    timer: Option<Timer>,
    stage_ms: Vec<(&'static str, f64)>,
}

/// The foveated frame's stages, one compute pass each (`foveated.wgsl`).
pub const FOVEATED_STAGES: [&str; 7] = [
    "cast vertices",
    "classify cells",
    "silhouette margin",
    "count refined cells",
    "interpolate or list pixels",
    "prepare dispatch",
    "cast listed pixels",
];

/// The stages (indices into [`FOVEATED_STAGES`]) a foveated frame runs with
/// these triggers: a scene's effects decide, and a pass for an effect the
/// scene does not list is not dispatched. Without any refinement trigger no
/// cell is classified (none can be refined); without the silhouette margin
/// the widening pass does not run.
pub fn foveated_stages(t: &Triggers) -> Vec<usize> {
    let classify = t.silhouette || t.crease_deg.is_some() || t.depth_jump.is_some();
    let mut out = vec![0];
    if classify {
        out.push(1);
        if t.margin {
            out.push(2);
        }
        out.push(3);
    }
    out.extend([4, 5, 6]);
    out
}

/// Timestamp queries around each pass, where the adapter has them.
#[derive(Clone)]
struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f32,
}

impl Timer {
    fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let n = 2 * FOVEATED_STAGES.len() as u32;
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("stage times"),
            ty: wgpu::QueryType::Timestamp,
            count: n,
        });
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 8 * u64::from(n),
                usage,
                mapped_at_creation: false,
            })
        };
        Self {
            set,
            resolve: buffer(
                "stage times",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "stage times readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            period_ns: queue.get_timestamp_period(),
        }
    }

    fn resolve(&self, encoder: &mut wgpu::CommandEncoder, stages: u32) {
        encoder.resolve_query_set(&self.set, 0..2 * stages, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16 * u64::from(stages));
    }

    fn read(
        &self,
        device: &wgpu::Device,
        stages: &[&'static str],
    ) -> Result<Vec<(&'static str, f64)>, GpuError> {
        let words = read_back(device, &self.readback, 16 * stages.len() as u64)?;
        let tick = |k: usize| u64::from(words[2 * k]) | (u64::from(words[2 * k + 1]) << 32);
        Ok(stages
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let ticks = tick(2 * k + 1).saturating_sub(tick(2 * k));
                (*s, ticks as f64 * f64::from(self.period_ns) * 1e-6)
            })
            .collect())
    }
}

fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    timer: Option<&Timer>,
    stage: u32,
    label: &str,
) -> wgpu::ComputePass<'e> {
    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: timer.map(|t| wgpu::ComputePassTimestampWrites {
            query_set: &t.set,
            beginning_of_pass_write_index: Some(2 * stage),
            end_of_pass_write_index: Some(2 * stage + 1),
        }),
    })
}

/// A bind group binding each buffer at its index (0, 1, 2, …).
fn bind_all(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry {
            binding: k as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Binding 0 of both groups: a uniform buffer.
fn uniform_entry() -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The gamma table of `shade::to_rgb8`, as u32 for the shader.
fn gamma_table() -> Vec<u32> {
    (0..=4096)
        .map(|i| {
            let x = i as f32 / 4096.0;
            u32::from(crate::shade::to_rgb8(glam::Vec3::splat(x))[0])
        })
        .collect()
}

/// The adapter `GpuRenderer::new` would use: a real GPU first, a software
/// one (Mesa's lavapipe) if that is all there is.
fn adapter() -> Result<wgpu::Adapter, GpuError> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    // Vulkan, Metal or DX12 unless WGPU_BACKEND says otherwise: probing
    // OpenGL would only print EGL noise on headless machines.
    desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    let instance = wgpu::Instance::new(desc);
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| GpuError::NoAdapter(e.to_string()))
}

/// What adapter there is, without creating a device: `Ok((name, software))`
/// where `software` means a CPU implementation such as lavapipe (slower
/// than the CPU backend; `--backend auto` does not pick it).
pub fn probe() -> Result<(String, bool), GpuError> {
    let info = adapter()?.get_info();
    Ok((info.name, info.device_type == wgpu::DeviceType::Cpu))
}

impl GpuRenderer {
    /// Picks an adapter (a real GPU first, a software one if that is all
    /// there is) and uploads the scene.
    pub fn new(scene: &Scene) -> Result<Self, GpuError> {
        let adapter = adapter()?;
        let info = adapter.get_info();
        let adapter_name = format!(
            "{} ({:?}, {:?}, driver {} {})",
            info.name, info.backend, info.device_type, info.driver, info.driver_info
        );
        let limits = adapter.limits();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("gazecast"),
            required_limits: limits.clone(),
            required_features: if timestamps {
                wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let timer = timestamps.then(|| Timer::new(&device, &queue));
        let max_binding = limits.max_storage_buffer_binding_size;

        let nodes: &[u8] = bytemuck::cast_slice(&scene.bvh.nodes);
        let triangles: Vec<GpuTriangle> = scene
            .triangles
            .iter()
            .map(|t| {
                let obj = f32::from_bits(t.object);
                GpuTriangle {
                    p: [
                        [t.p[0].x, t.p[0].y, t.p[0].z, obj],
                        [t.p[1].x, t.p[1].y, t.p[1].z, 0.0],
                        [t.p[2].x, t.p[2].y, t.p[2].z, 0.0],
                    ],
                    n: [
                        [t.n[0].x, t.n[0].y, t.n[0].z, 0.0],
                        [t.n[1].x, t.n[1].y, t.n[1].z, 0.0],
                        [t.n[2].x, t.n[2].y, t.n[2].z, 0.0],
                    ],
                }
            })
            .collect();
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                diffuse: [m.diffuse.0, m.diffuse.1, m.diffuse.2, m.shininess],
                specular: [m.specular.0, m.specular.1, m.specular.2, 0.0],
            })
            .collect();
        let mut lights: Vec<GpuLight> = scene
            .lights
            .iter()
            .map(|l| match *l {
                Light::Headlight { intensity } => GpuLight {
                    kind: [0; 4],
                    data: [0.0, 0.0, 0.0, intensity],
                },
                Light::Point {
                    position_mm: p,
                    intensity,
                } => GpuLight {
                    kind: [1, 0, 0, 0],
                    data: [p.0, p.1, p.2, intensity],
                },
                Light::Directional {
                    direction: d,
                    intensity,
                } => GpuLight {
                    kind: [2, 0, 0, 0],
                    data: [d.0, d.1, d.2, intensity],
                },
            })
            .collect();
        let n_lights = lights.len() as u32;
        // Storage buffers may not be empty.
        lights.push(GpuLight::zeroed());
        let mut triangles = triangles;
        let n_triangles = triangles.len() as u32;
        if triangles.is_empty() {
            triangles.push(GpuTriangle::zeroed());
        }
        let gamma = gamma_table();
        let upload = |what: &'static str, bytes: &[u8]| -> Result<wgpu::Buffer, GpuError> {
            if bytes.len() as u64 > max_binding {
                return Err(GpuError::TooLarge {
                    what,
                    bytes: bytes.len() as u64,
                    limit: max_binding,
                });
            }
            Ok(
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(what),
                    contents: bytes,
                    usage: wgpu::BufferUsages::STORAGE,
                }),
            )
        };
        let scene_buffers = [
            upload("the BVH", nodes)?,
            upload("the triangles", bytemuck::cast_slice(&triangles))?,
            upload("the materials", bytemuck::cast_slice(&materials))?,
            upload("the lights", bytemuck::cast_slice(&lights))?,
            upload("the gamma table", bytemuck::cast_slice(&gamma))?,
        ];
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let source = format!(
            "{}\n{}",
            include_str!("cast.wgsl"),
            include_str!("foveated.wgsl")
        );
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cast.wgsl + foveated.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let mut entries = vec![uniform_entry()];
        entries.extend((1..=5).map(|b| storage_entry(b, true)));
        entries.push(storage_entry(6, false));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cast"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cast"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("full"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("full"),
            compilation_options: Default::default(),
            cache: None,
        });
        let mut fov_entries = vec![uniform_entry()];
        fov_entries.extend((1..=3).map(|b| storage_entry(b, true)));
        fov_entries.extend((4..=8).map(|b| storage_entry(b, false)));
        let fov_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("foveated"),
            entries: &fov_entries,
        });
        let fov_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("foveated"),
            bind_group_layouts: &[Some(&layout), Some(&fov_layout)],
            immediate_size: 0,
        });
        let dispatch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("indirect dispatch"),
            entries: &[storage_entry(0, false)],
        });
        let prepare_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("prepare cast"),
            bind_group_layouts: &[Some(&layout), Some(&fov_layout), Some(&dispatch_layout)],
            immediate_size: 0,
        });
        let fov_pipeline = |entry: &str| {
            let layout = if entry == "prepare_cast" {
                &prepare_layout
            } else {
                &fov_pipeline_layout
            };
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let fov_pipelines = [
            fov_pipeline("cast_vertices"),
            fov_pipeline("classify"),
            fov_pipeline("widen"),
            fov_pipeline("count_cells"),
            fov_pipeline("pixels_foveated"),
            fov_pipeline("prepare_cast"),
            fov_pipeline("cast_listed"),
        ];
        let fov_params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("foveated params"),
            size: std::mem::size_of::<FovParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let c = scene.background;
        Ok(Self {
            device,
            queue,
            pipeline,
            fov_pipelines,
            fov_layout,
            dispatch_layout,
            fov_params,
            fov_target: None,
            layout,
            params,
            scene_buffers,
            n_triangles,
            n_lights,
            background: [c.x, c.y, c.z],
            background_rgb8: scene.background_rgb8,
            target: None,
            adapter: adapter_name,
            max_binding,
            timer,
            stage_ms: Vec::new(),
        })
    }

    /// Whether the foveated stages' buffers exist (they are made by the first
    /// foveated frame; a full-resolution scene never allocates them).
    pub fn has_foveated_buffers(&self) -> bool {
        self.fov_target.is_some()
    }

    /// The largest storage buffer one binding may hold on this device (bytes).
    pub fn max_binding_bytes(&self) -> u64 {
        self.max_binding
    }

    /// GPU time of each stage of the last frame (ms), from timestamp
    /// queries; empty when the adapter has none.
    pub fn stage_ms(&self) -> &[(&'static str, f64)] {
        &self.stage_ms
    }

    /// The adapter in words (name, backend, type, driver).
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    fn target(&mut self, pixels: u32) -> Result<&Target, GpuError> {
        if self.target.as_ref().is_none_or(|t| t.pixels != pixels) {
            let size = 4 * u64::from(pixels.max(1));
            if size > self.max_binding {
                return Err(GpuError::TooLarge {
                    what: "the frame",
                    bytes: size,
                    limit: self.max_binding,
                });
            }
            let out = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pixels"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut all: Vec<&wgpu::Buffer> = vec![&self.params];
            all.extend(self.scene_buffers.iter());
            all.push(&out);
            let bind_group = bind_all(&self.device, &self.layout, "cast", &all);
            self.target = Some(Target {
                pixels,
                out,
                readback,
                bind_group,
            });
        }
        self.target
            .as_ref()
            .ok_or_else(|| GpuError::Readback("no target".into()))
    }

    fn write_params(&self, cam: &Camera) -> Result<u32, GpuError> {
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = w.checked_mul(h).ok_or(GpuError::TooLarge {
            what: "the frame",
            bytes: u64::from(w) * u64::from(h) * 4,
            limit: self.max_binding,
        })?;
        let pitch = cam.pitch();
        let params = Params {
            width: w,
            height: h,
            n_lights: self.n_lights,
            n_triangles: self.n_triangles,
            eye: [cam.eye.x, cam.eye.y, cam.eye.z, 0.0],
            pitch: [pitch[0], pitch[1], 0.0, 0.0],
            background: [
                self.background[0],
                self.background[1],
                self.background[2],
                0.0,
            ],
            background_rgb8: [
                u32::from(self.background_rgb8[0]),
                u32::from(self.background_rgb8[1]),
                u32::from(self.background_rgb8[2]),
                0,
            ],
        };
        self.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        Ok(pixels)
    }

    /// Renders one full-resolution frame (one ray per pixel) and reads it back.
    pub fn render_full(&mut self, cam: &Camera) -> Result<(Frame, Stats), GpuError> {
        let start = Instant::now();
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = self.write_params(cam)?;
        let pipeline = self.pipeline.clone();
        let device = self.device.clone();
        let queue = self.queue.clone();
        let timer = self.timer.clone();
        let target = self.target(pixels)?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let mut pass = begin_pass(&mut encoder, timer.as_ref(), 0, "cast and shade");
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &target.bind_group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        let bytes = 4 * u64::from(pixels);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&target.out, 0, &target.readback, 0, bytes);
        }
        if let Some(t) = &timer {
            t.resolve(&mut encoder, 1);
        }
        queue.submit(Some(encoder.finish()));
        let mut frame = blank_frame(w, h);
        if bytes > 0 {
            let words = read_back(&device, &target.readback, bytes)?;
            unpack(&words, &mut frame);
        }
        self.stage_ms = match &timer {
            Some(t) => t.read(&device, &["cast and shade"])?,
            None => Vec::new(),
        };
        let stats = Stats {
            rays_total: u64::from(pixels),
            rays_refine: u64::from(pixels),
            time_ms: start.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        };
        Ok((frame, stats))
    }

    fn fov_target(&mut self, vertices: u64, cells: u64, pixels: u64) -> Result<(), GpuError> {
        let fits = self
            .fov_target
            .as_ref()
            .is_some_and(|t| t.vertices >= vertices && t.cells >= cells && t.pixels >= pixels);
        if fits {
            return Ok(());
        }
        // Grow with headroom so a moving gaze does not reallocate every frame.
        let (nv, nc, np) = (
            (vertices.max(1) * 5 / 4).max(1024),
            (cells.max(1) * 5 / 4).max(1024),
            pixels.max(1),
        );
        let sizes: [(&'static str, u64, wgpu::BufferUsages); 6] = [
            ("the mask vertices", 8 * nv, wgpu::BufferUsages::COPY_DST),
            ("the mask cells", 16 * nc, wgpu::BufferUsages::COPY_DST),
            ("the pixel ownership", 4 * np, wgpu::BufferUsages::COPY_DST),
            (
                "the vertex hits",
                SAMPLE_BYTES * nv,
                wgpu::BufferUsages::empty(),
            ),
            ("the refined flags", 4 * nc, wgpu::BufferUsages::COPY_DST),
            ("the touched vertices", 4 * nv, wgpu::BufferUsages::COPY_DST),
        ];
        let mut buffers = Vec::new();
        for (what, size, extra) in sizes {
            if size > self.max_binding {
                return Err(GpuError::TooLarge {
                    what,
                    bytes: size,
                    limit: self.max_binding,
                });
            }
            buffers.push(self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(what),
                size,
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            }));
        }
        buffers.push(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        }));
        if 4 * np > self.max_binding {
            return Err(GpuError::TooLarge {
                what: "the list of pixels to cast",
                bytes: 4 * np,
                limit: self.max_binding,
            });
        }
        buffers.push(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixels to cast"),
            size: 4 * np,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        }));
        buffers.push(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("indirect dispatch"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            mapped_at_creation: false,
        }));
        let counters_readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters readback"),
            size: 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let dispatch_group = bind_all(
            &self.device,
            &self.dispatch_layout,
            "indirect dispatch",
            &[&buffers[8]],
        );
        let mut all: Vec<&wgpu::Buffer> = vec![&self.fov_params];
        all.extend(buffers[..8].iter());
        let bind_group = bind_all(&self.device, &self.fov_layout, "foveated", &all);
        self.fov_target = Some(FovTarget {
            vertices: nv,
            cells: nc,
            pixels: np,
            buffers,
            counters_readback,
            bind_group,
            dispatch_group,
        });
        Ok(())
    }

    /// Renders one foveated frame for the ray mask `mask` (built for the
    /// gaze on the CPU) with the refinement `triggers`, and reads it back.
    pub fn render_foveated(
        &mut self,
        cam: &Camera,
        mask: &RayMask,
        triggers: &Triggers,
    ) -> Result<(Frame, Stats), GpuError> {
        let start = Instant::now();
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = self.write_params(cam)?;
        let owner = crate::render::ownership(mask, w as usize, h as usize);
        let (nv, nc) = (mask.vertices.len() as u64, mask.cells.len() as u64);
        self.fov_target(nv, nc, u64::from(pixels))?;
        let fov = FovParams {
            n_vertices: nv as u32,
            n_cells: nc as u32,
            silhouette: u32::from(triggers.silhouette),
            margin: u32::from(triggers.margin),
            crease_cos: triggers.crease_deg.map_or(-2.0, |d| d.to_radians().cos()),
            depth_jump: triggers.depth_jump.unwrap_or(-1.0),
            pad: [0; 2],
        };
        self.queue
            .write_buffer(&self.fov_params, 0, bytemuck::bytes_of(&fov));
        // Triangles carry NO_VERTEX (u32::MAX) as their fourth corner, as
        // `foveated.wgsl` expects.
        const _: () = assert!(NO_VERTEX == u32::MAX);
        let cells: &[u8] = bytemuck::cast_slice(&mask.cells);
        let device = self.device.clone();
        let queue = self.queue.clone();
        let pipelines = self.fov_pipelines.clone();
        let target = self.target(pixels)?;
        let (out, readback, bind0) = (
            target.out.clone(),
            target.readback.clone(),
            target.bind_group.clone(),
        );
        let Some(ft) = self.fov_target.as_ref() else {
            return Err(GpuError::Readback("no foveated buffers".into()));
        };
        let b = &ft.buffers;
        if nv > 0 {
            queue.write_buffer(&b[0], 0, bytemuck::cast_slice(&mask.vertices));
        }
        if nc > 0 {
            queue.write_buffer(&b[1], 0, cells);
        }
        if !owner.is_empty() {
            queue.write_buffer(&b[2], 0, bytemuck::cast_slice(&owner));
        }
        queue.write_buffer(&b[6], 0, &[0u8; 16]);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("foveated frame"),
        });
        let stages = foveated_stages(triggers);
        let names: Vec<&'static str> = stages.iter().map(|&k| FOVEATED_STAGES[k]).collect();
        if triggers.margin {
            encoder.clear_buffer(&b[5], 0, None);
        }
        if !stages.contains(&1) {
            // Nothing is classified: no cell is refined.
            encoder.clear_buffer(&b[4], 0, None);
        }
        let groups = |n: u64| {
            let g = n.div_ceil(64).max(1);
            ((g.min(65_535)) as u32, g.div_ceil(65_535) as u32)
        };
        let timer = self.timer.clone();
        // One pass per stage, so that each can be timed.
        for (slot, &k) in stages.iter().enumerate() {
            let stage = FOVEATED_STAGES[k];
            let mut pass = begin_pass(&mut encoder, timer.as_ref(), slot as u32, stage);
            pass.set_bind_group(0, &bind0, &[]);
            pass.set_bind_group(1, &ft.bind_group, &[]);
            pass.set_pipeline(&pipelines[k]);
            match k {
                0 => {
                    let (x, y) = groups(nv);
                    pass.dispatch_workgroups(x, y, 1);
                }
                1..=3 => {
                    let (x, y) = groups(nc);
                    pass.dispatch_workgroups(x, y, 1);
                }
                4 => pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1),
                5 => {
                    pass.set_bind_group(2, &ft.dispatch_group, &[]);
                    pass.dispatch_workgroups(1, 1, 1);
                }
                _ => pass.dispatch_workgroups_indirect(&b[8], 0),
            }
        }
        let bytes = 4 * u64::from(pixels);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&out, 0, &readback, 0, bytes);
        }
        if let Some(t) = &timer {
            t.resolve(&mut encoder, stages.len() as u32);
        }
        encoder.copy_buffer_to_buffer(&b[6], 0, &ft.counters_readback, 0, 16);
        queue.submit(Some(encoder.finish()));
        let mut frame = blank_frame(w, h);
        if bytes > 0 {
            let words = read_back(&device, &readback, bytes)?;
            unpack(&words, &mut frame);
        }
        let counters = read_back(&device, &ft.counters_readback, 16)?;
        self.stage_ms = match &timer {
            Some(t) => t.read(&device, &names)?,
            None => Vec::new(),
        };
        let stats = Stats {
            rays_fovea: u64::from(counters[0]),
            rays_mask: nv,
            rays_refine: u64::from(counters[1]),
            rays_total: u64::from(counters[0]) + nv + u64::from(counters[1]),
            cells_total: nc,
            cells_refined: u64::from(counters[2]),
            pixels_uncovered: 0,
            time_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        Ok((frame, stats))
    }
}

fn blank_frame(w: u32, h: u32) -> Frame {
    let n = w as usize * h as usize;
    Frame {
        width: w,
        height: h,
        rgb: vec![0; 3 * n],
        hit: vec![false; n],
        layer: vec![Layer::Full; n],
    }
}

/// Maps `buffer` (after the submission that fills it) and copies its words out.
fn read_back(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u32>, GpuError> {
    let slice = buffer.slice(..bytes);
    let (tx, rx) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let words = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        bytemuck::cast_slice::<u8, u32>(&view).to_vec()
    };
    buffer.unmap();
    Ok(words)
}

/// Pixel words (`pack` in cast.wgsl) into a frame: RGB, hit, layer.
fn unpack(words: &[u32], frame: &mut Frame) {
    for (i, &p) in words.iter().enumerate().take(frame.hit.len()) {
        frame.rgb[3 * i] = p as u8;
        frame.rgb[3 * i + 1] = (p >> 8) as u8;
        frame.rgb[3 * i + 2] = (p >> 16) as u8;
        frame.hit[i] = (p >> 24) & 1 == 1;
        frame.layer[i] = match (p >> 25) & 3 {
            1 => Layer::Fovea,
            2 => Layer::Interpolated,
            3 => Layer::Refined,
            _ => Layer::Full,
        };
    }
}
