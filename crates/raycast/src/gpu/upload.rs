//! The scene on the GPU, uploaded once: the flattened binary BVH, the
//! triangles, the per-object materials, the lights and the gamma table
//! (group 0, bindings 1–5 of `cast.wgsl`).

use super::{GpuError, TrafficCounter};
use crate::scene::{Light, Scene};
use bytemuck::{Pod, Zeroable};

/// `Triangle` in cast.wgsl: corners (the first's w: the object id, bitcast)
/// and corner normals.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuTriangle {
    p: [[f32; 4]; 3],
    n: [[f32; 4]; 3],
}

/// `Material` in cast.wgsl (diffuse w: shininess).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuMaterial {
    diffuse: [f32; 4],
    specular: [f32; 4],
}

/// `Light` in cast.wgsl (kind 0 headlight, 1 point, 2 directional).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuLight {
    kind: [u32; 4],
    data: [f32; 4],
}

/// The scene's storage buffers, by name.
pub(super) struct SceneBuffers {
    pub bvh: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
    /// One material per object (`Scene::object_materials`).
    pub object_materials: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    /// `shade::to_rgb8`'s gamma table.
    pub gamma: wgpu::Buffer,
    /// Triangles and lights in the scene (the buffers hold at least one
    /// element each: storage buffers may not be empty).
    pub n_triangles: u32,
    pub n_lights: u32,
    /// Objects with a material (`Scene::object_materials`).
    pub n_materials: u32,
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

fn triangles(scene: &Scene) -> Vec<GpuTriangle> {
    let mut out: Vec<GpuTriangle> = scene
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
    if out.is_empty() {
        out.push(GpuTriangle::zeroed());
    }
    out
}

fn object_materials(scene: &Scene) -> Vec<GpuMaterial> {
    let mut out: Vec<GpuMaterial> = scene
        .object_materials
        .iter()
        .map(|m| GpuMaterial {
            diffuse: [m.diffuse.0, m.diffuse.1, m.diffuse.2, m.shininess],
            specular: [m.specular.0, m.specular.1, m.specular.2, 0.0],
        })
        .collect();
    if out.is_empty() {
        out.push(GpuMaterial::zeroed());
    }
    out
}

fn lights(scene: &Scene) -> Vec<GpuLight> {
    let mut out: Vec<GpuLight> = scene
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
    out.push(GpuLight::zeroed());
    out
}

impl SceneBuffers {
    /// Uploads `scene`, refusing any buffer above `max_binding` bytes.
    pub fn upload(
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        scene: &Scene,
        max_binding: u64,
    ) -> Result<Self, GpuError> {
        Self::upload_with(device, traffic, scene, max_binding, None)
    }

    /// [`SceneBuffers::upload`] with `gamma`, the gamma table already on
    /// the device (it depends on no scene), when given.
    pub fn upload_with(
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        scene: &Scene,
        max_binding: u64,
        gamma: Option<wgpu::Buffer>,
    ) -> Result<Self, GpuError> {
        let upload = |what: &'static str, bytes: &[u8]| -> Result<wgpu::Buffer, GpuError> {
            if bytes.len() as u64 > max_binding {
                return Err(GpuError::TooLarge {
                    what,
                    bytes: bytes.len() as u64,
                    limit: max_binding,
                });
            }
            Ok(traffic.buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some(what),
                    contents: bytes,
                    // A moving scene's next pose is written into them.
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                },
            ))
        };
        Ok(Self {
            bvh: upload("the BVH", bytemuck::cast_slice(&scene.bvh.nodes))?,
            triangles: upload("the triangles", bytemuck::cast_slice(&triangles(scene)))?,
            object_materials: upload(
                "the materials",
                bytemuck::cast_slice(&object_materials(scene)),
            )?,
            lights: upload("the lights", bytemuck::cast_slice(&lights(scene)))?,
            gamma: match gamma {
                Some(g) => g,
                None => upload("the gamma table", bytemuck::cast_slice(&gamma_table()))?,
            },
            n_triangles: scene.triangles.len() as u32,
            n_lights: scene.lights.len() as u32,
            n_materials: scene.object_materials.len() as u32,
        })
    }

    /// Writes `scene` (another pose of the scene these buffers hold) into
    /// them when each of its BVH, triangles, materials and lights fits
    /// (a rebuilt BVH may have more nodes); `false`, writing nothing, when
    /// one does not. Nodes past the new BVH's are never reached.
    pub fn rewrite(
        &mut self,
        queue: &wgpu::Queue,
        traffic: &TrafficCounter,
        scene: &Scene,
    ) -> bool {
        let triangles = triangles(scene);
        let materials = object_materials(scene);
        let lights = lights(scene);
        let parts: [(&wgpu::Buffer, &[u8]); 4] = [
            (&self.bvh, bytemuck::cast_slice(&scene.bvh.nodes)),
            (&self.triangles, bytemuck::cast_slice(&triangles)),
            (&self.object_materials, bytemuck::cast_slice(&materials)),
            (&self.lights, bytemuck::cast_slice(&lights)),
        ];
        if parts.iter().any(|(b, bytes)| bytes.len() as u64 > b.size()) {
            return false;
        }
        for (b, bytes) in parts {
            traffic.write_buffer(queue, b, 0, bytes);
        }
        self.n_triangles = scene.triangles.len() as u32;
        self.n_lights = scene.lights.len() as u32;
        self.n_materials = scene.object_materials.len() as u32;
        true
    }
}
