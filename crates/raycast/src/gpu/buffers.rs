//! Buffer layouts: the uniforms, the three bind group layouts of the shader
//! and the per-frame buffers by name, with their bind groups. The binding
//! numbers are those of `cast.wgsl` (group 0) and `foveated.wgsl` (groups 1
//! and 2).

use bytemuck::{Pod, Zeroable};

use super::upload::SceneBuffers;
use super::GpuError;

/// `Params` in cast.wgsl (group 0, binding 0).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(super) struct Params {
    pub width: u32,
    pub height: u32,
    pub n_lights: u32,
    pub n_triangles: u32,
    pub eye: [f32; 4],
    pub pitch: [f32; 4],
    pub background: [f32; 4],
    pub background_rgb8: [u32; 4],
}

/// `Fov` in foveated.wgsl (group 1, binding 0).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(super) struct FovParams {
    pub n_vertices: u32,
    pub n_cells: u32,
    pub silhouette: u32,
    pub margin: u32,
    /// Below −1: no crease trigger.
    pub crease_cos: f32,
    /// Below 0: no depth trigger.
    pub depth_jump: f32,
    pub pad: [u32; 2],
}

/// Bytes per vertex hit record in `foveated.wgsl` (`Sample`: 32 bytes).
const SAMPLE_BYTES: u64 = 32;

/// Binding 0 of groups 0 and 1 (and of the ownership pass's group): a
/// uniform buffer.
pub(super) fn uniform_entry() -> wgpu::BindGroupLayoutEntry {
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

pub(super) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
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

/// A bind group binding each buffer at its binding number.
pub(super) fn bind(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    buffers: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|&(binding, b)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// The shader's bind group layouts.
pub(super) struct Layouts {
    /// Group 0 (cast.wgsl): params, the scene (1–5, read only), the frame's
    /// outputs (6–9).
    pub cast: wgpu::BindGroupLayout,
    /// Group 1 (foveated.wgsl): foveated params, the mask and ownership
    /// (1–3, read only), the stages' working buffers (4–8).
    pub foveated: wgpu::BindGroupLayout,
    /// Group 2: the indirect dispatch arguments, written by `prepare_cast`.
    pub dispatch: wgpu::BindGroupLayout,
}

impl Layouts {
    pub fn new(device: &wgpu::Device) -> Self {
        let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
        };
        let mut cast = vec![uniform_entry()];
        cast.extend((1..=5).map(|b| storage_entry(b, true)));
        cast.extend((6..=9).map(|b| storage_entry(b, false)));
        let mut foveated = vec![uniform_entry()];
        foveated.extend((1..=3).map(|b| storage_entry(b, true)));
        foveated.extend((4..=8).map(|b| storage_entry(b, false)));
        Self {
            cast: layout("cast", &cast),
            foveated: layout("foveated", &foveated),
            dispatch: layout("indirect dispatch", &[storage_entry(0, false)]),
        }
    }
}

/// Creates a storage buffer of `size` bytes, refused above `max_binding`.
pub(super) fn storage(
    device: &wgpu::Device,
    what: &'static str,
    size: u64,
    extra: wgpu::BufferUsages,
    max_binding: u64,
) -> Result<wgpu::Buffer, GpuError> {
    if size > max_binding {
        return Err(GpuError::TooLarge {
            what,
            bytes: size,
            limit: max_binding,
        });
    }
    Ok(device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(what),
        size,
        usage: wgpu::BufferUsages::STORAGE | extra,
        mapped_at_creation: false,
    }))
}

/// One buffer per G-buffer field of a frame (`put` in cast.wgsl).
pub(super) struct FrameBuffers {
    /// Colour, hit flag and layer (`pack`): 4 bytes a pixel.
    pub pixels: wgpu::Buffer,
    /// Eye distance (f32): 4 bytes a pixel.
    pub depth: wgpu::Buffer,
    /// Object id (u32): 4 bytes a pixel.
    pub object: wgpu::Buffer,
    /// Normal (3 × f32): 12 bytes a pixel.
    pub normal: wgpu::Buffer,
}

impl FrameBuffers {
    /// Each buffer's name (for errors) and bytes per pixel, in field order.
    pub const PER_PIXEL: [(&'static str, u64); 4] = [
        ("the frame", 4),
        ("the frame's depth", 4),
        ("the frame's object ids", 4),
        ("the frame's normals", 12),
    ];

    /// Buffers for `pixels` pixels (at least one), with `usage`; refused
    /// above `max_binding` bytes when they are to be bound as storage.
    fn new(
        device: &wgpu::Device,
        pixels: u32,
        usage: wgpu::BufferUsages,
        max_binding: u64,
    ) -> Result<Self, GpuError> {
        let n = u64::from(pixels.max(1));
        let [pixels, depth, object, normal] = Self::PER_PIXEL;
        let make = |(what, per_pixel): (&'static str, u64)| {
            if usage.contains(wgpu::BufferUsages::STORAGE) {
                storage(device, what, per_pixel * n, usage, max_binding)
            } else {
                Ok(device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(what),
                    size: per_pixel * n,
                    usage,
                    mapped_at_creation: false,
                }))
            }
        };
        Ok(Self {
            pixels: make(pixels)?,
            depth: make(depth)?,
            object: make(object)?,
            normal: make(normal)?,
        })
    }

    /// The buffers with their bytes per pixel, in field order.
    pub fn each(&self) -> [(&wgpu::Buffer, u64); 4] {
        let [p, d, o, n] = Self::PER_PIXEL.map(|(_, b)| b);
        [
            (&self.pixels, p),
            (&self.depth, d),
            (&self.object, o),
            (&self.normal, n),
        ]
    }
}

/// The frame's outputs for one frame size, reused frame after frame, and
/// group 0's bind group over them.
pub(super) struct FrameTarget {
    pub pixels: u32,
    pub out: FrameBuffers,
    pub readback: FrameBuffers,
    pub bind_group: wgpu::BindGroup,
}

/// Group 0 of the cast over the params, the scene and the frame's
/// outputs.
pub(super) fn cast_group(
    device: &wgpu::Device,
    layouts: &Layouts,
    params: &wgpu::Buffer,
    scene: &SceneBuffers,
    out: &FrameBuffers,
) -> wgpu::BindGroup {
    bind(
        device,
        &layouts.cast,
        "cast",
        &[
            (0, params),
            (1, &scene.bvh),
            (2, &scene.triangles),
            (3, &scene.object_materials),
            (4, &scene.lights),
            (5, &scene.gamma),
            (6, &out.pixels),
            (7, &out.depth),
            (8, &out.object),
            (9, &out.normal),
        ],
    )
}

impl FrameTarget {
    pub fn new(
        device: &wgpu::Device,
        layouts: &Layouts,
        params: &wgpu::Buffer,
        scene: &SceneBuffers,
        pixels: u32,
        max_binding: u64,
    ) -> Result<Self, GpuError> {
        let out = FrameBuffers::new(
            device,
            pixels,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            max_binding,
        )?;
        let readback = FrameBuffers::new(
            device,
            pixels,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            max_binding,
        )?;
        let bind_group = cast_group(device, layouts, params, scene, &out);
        Ok(Self {
            pixels,
            out,
            readback,
            bind_group,
        })
    }
}

/// The foveated stages' buffers (groups 1 and 2), grown when a mask needs
/// more.
pub(super) struct FoveatedTarget {
    /// Capacity: mask vertices, cells and pixels.
    pub vertices: u64,
    pub cells: u64,
    pub pixels: u64,
    /// The mask's vertices (screen positions).
    pub mask_vertices: wgpu::Buffer,
    /// The mask's cells (four vertex indices, the fourth `NO_VERTEX` for a
    /// triangle).
    pub mask_cells: wgpu::Buffer,
    /// Each pixel's owner: a cell, the fovea or none.
    pub owner: wgpu::Buffer,
    /// Each mask vertex's cast sample (only the shader reads and writes it).
    #[allow(dead_code)]
    pub vertex_hits: wgpu::Buffer,
    /// Per cell: refined (1) or not.
    pub refined: wgpu::Buffer,
    /// Per vertex: a corner of a heterogeneous cell (the silhouette margin).
    pub touched: wgpu::Buffer,
    /// Fovea rays, refined rays, refined cells, pixels listed to cast.
    pub counters: wgpu::Buffer,
    /// The pixels to cast, appended by `pixels_foveated` (only the shader
    /// reads and writes it).
    #[allow(dead_code)]
    pub cast_list: wgpu::Buffer,
    /// Workgroup counts of the indirect dispatch of `cast_listed`.
    pub dispatch: wgpu::Buffer,
    pub counters_readback: wgpu::Buffer,
    /// Group 1.
    pub bind_group: wgpu::BindGroup,
    /// Group 2 (the dispatch arguments).
    pub dispatch_group: wgpu::BindGroup,
}

impl FoveatedTarget {
    /// Whether these buffers hold a mask of this size and a frame of this
    /// many pixels.
    pub fn fits(&self, vertices: u64, cells: u64, pixels: u64) -> bool {
        self.vertices >= vertices && self.cells >= cells && self.pixels >= pixels
    }

    /// Buffers for at least this many vertices, cells and pixels.
    pub fn new(
        device: &wgpu::Device,
        layouts: &Layouts,
        fov_params: &wgpu::Buffer,
        (vertices, cells, pixels): (u64, u64, u64),
        max_binding: u64,
    ) -> Result<Self, GpuError> {
        use wgpu::BufferUsages as U;
        // Grow with headroom so a moving gaze does not reallocate every frame.
        let (nv, nc, np) = (
            (vertices.max(1) * 5 / 4).max(1024),
            (cells.max(1) * 5 / 4).max(1024),
            pixels.max(1),
        );
        let buffer = |what, size, extra| storage(device, what, size, extra, max_binding);
        let mask_vertices = buffer("the mask vertices", 8 * nv, U::COPY_DST)?;
        let mask_cells = buffer("the mask cells", 16 * nc, U::COPY_DST)?;
        let owner = buffer("the pixel ownership", 4 * np, U::COPY_DST | U::COPY_SRC)?;
        let vertex_hits = buffer("the vertex hits", SAMPLE_BYTES * nv, U::empty())?;
        let refined = buffer("the refined flags", 4 * nc, U::COPY_DST)?;
        let touched = buffer("the touched vertices", 4 * nv, U::COPY_DST)?;
        let counters = buffer("counters", 16, U::COPY_DST | U::COPY_SRC)?;
        let cast_list = buffer("the list of pixels to cast", 4 * np, U::empty())?;
        let dispatch = buffer("indirect dispatch", 16, U::INDIRECT)?;
        let counters_readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters readback"),
            size: 16,
            usage: U::MAP_READ | U::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind(
            device,
            &layouts.foveated,
            "foveated",
            &[
                (0, fov_params),
                (1, &mask_vertices),
                (2, &mask_cells),
                (3, &owner),
                (4, &vertex_hits),
                (5, &refined),
                (6, &touched),
                (7, &counters),
                (8, &cast_list),
            ],
        );
        let dispatch_group = bind(
            device,
            &layouts.dispatch,
            "indirect dispatch",
            &[(0, &dispatch)],
        );
        Ok(Self {
            vertices: nv,
            cells: nc,
            pixels: np,
            mask_vertices,
            mask_cells,
            owner,
            vertex_hits,
            refined,
            touched,
            counters,
            cast_list,
            dispatch,
            counters_readback,
            bind_group,
            dispatch_group,
        })
    }
}
