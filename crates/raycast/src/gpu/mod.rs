//! The GPU core in `wgpu` compute (WGSL in `cast.wgsl`).
//!
//! **State (issue 6, in progress):** the scene (flattened binary BVH,
//! triangles, per-object materials, lights, the gamma table) is uploaded once;
//! per frame only the camera changes; one compute pass casts and shades one
//! ray per pixel (full resolution) and the frame is read back. The foveated
//! stages (mask rays, cell classification, refinement with an atomic counter
//! and an indirect dispatch, reconstruction) are **not written yet**: the
//! foveated mode runs on the CPU.
//!
//! Any adapter works, including Mesa's lavapipe (software Vulkan), which is
//! how the tests run on machines without a GPU. A buffer larger than the
//! device's storage-binding limit is refused with a message naming the limit.

use std::sync::mpsc;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::camera::Camera;
use crate::render::{Frame, Layer, Stats};
use crate::scene::{Light, Scene};

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

/// A device with a scene on it.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
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

impl GpuRenderer {
    /// Picks an adapter (a real GPU first, a software one if that is all
    /// there is) and uploads the scene.
    pub fn new(scene: &Scene) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // Vulkan, Metal or DX12 unless WGPU_BACKEND says otherwise: probing
        // OpenGL would only print EGL noise on headless machines.
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let adapter_name = format!(
            "{} ({:?}, {:?}, driver {} {})",
            info.name, info.backend, info.device_type, info.driver, info.driver_info
        );
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("gazecast"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
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
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cast.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("cast.wgsl").into()),
        });
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }];
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
        let c = scene.background;
        Ok(Self {
            device,
            queue,
            pipeline,
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
        })
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
            let mut entries = vec![wgpu::BindGroupEntry {
                binding: 0,
                resource: self.params.as_entire_binding(),
            }];
            for (k, b) in self.scene_buffers.iter().enumerate() {
                entries.push(wgpu::BindGroupEntry {
                    binding: k as u32 + 1,
                    resource: b.as_entire_binding(),
                });
            }
            entries.push(wgpu::BindGroupEntry {
                binding: 6,
                resource: out.as_entire_binding(),
            });
            let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cast"),
                layout: &self.layout,
                entries: &entries,
            });
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

    /// Renders one full-resolution frame (one ray per pixel) and reads it back.
    pub fn render_full(&mut self, cam: &Camera) -> Result<(Frame, Stats), GpuError> {
        let start = Instant::now();
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
        let pipeline = self.pipeline.clone();
        let device = self.device.clone();
        let queue = self.queue.clone();
        let target = self.target(pixels)?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("full"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &target.bind_group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        let bytes = 4 * u64::from(pixels);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&target.out, 0, &target.readback, 0, bytes);
        }
        queue.submit(Some(encoder.finish()));
        let mut frame = Frame {
            width: w,
            height: h,
            rgb: vec![0; 3 * pixels as usize],
            hit: vec![false; pixels as usize],
            layer: vec![Layer::Full; pixels as usize],
        };
        if bytes > 0 {
            let slice = target.readback.slice(..bytes);
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
            {
                let view = slice
                    .get_mapped_range()
                    .map_err(|e| GpuError::Readback(e.to_string()))?;
                let words: &[u32] = bytemuck::cast_slice(&view);
                for (i, &p) in words.iter().enumerate() {
                    frame.rgb[3 * i] = p as u8;
                    frame.rgb[3 * i + 1] = (p >> 8) as u8;
                    frame.rgb[3 * i + 2] = (p >> 16) as u8;
                    frame.hit[i] = (p >> 24) & 1 == 1;
                }
            }
            target.readback.unmap();
        }
        let stats = Stats {
            rays_total: u64::from(pixels),
            rays_refine: u64::from(pixels),
            time_ms: start.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        };
        Ok((frame, stats))
    }
}
