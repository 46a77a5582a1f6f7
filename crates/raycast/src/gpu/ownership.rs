//! Pixel ownership built on the GPU (`ownership.wgsl`): a new ray mask
//! uploads only itself — its vertices and cells (which the foveated stages
//! read anyway) and its fovea spans (12 bytes a row) — instead of 4 bytes
//! a pixel of owners rasterised on the CPU (33 MB at 3840×2160). The
//! shader is the CPU's `render::ownership` in exact integer arithmetic, so
//! the owners are the same bit for bit (a test compares them over many
//! gazes and sizes).
//!
//! The shader's arithmetic holds while every snapped coordinate stays
//! below 2²⁹ (1/65536 px): masks with a vertex 8192 px or more off the
//! origin, or frames 8192 px or more a side, keep the CPU's ownership and
//! its upload ([`fits`]).

use bytemuck::{Pod, Zeroable};
use foveation::mask::RayMask;

use super::buffers::{bind, storage, storage_entry, uniform_entry};
use super::{GpuError, TrafficCounter};

/// `Own` in ownership.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct OwnParams {
    width: u32,
    height: u32,
    n_spans: u32,
    n_cells: u32,
}

/// Bytes of one fovea span as uploaded: (y, x_start, x_end, 0).
pub const SPAN_BYTES: u64 = 16;

/// Bytes of the pass's uniforms (`Own`).
pub const UNIFORM_BYTES: u64 = std::mem::size_of::<OwnParams>() as u64;

/// Compute dispatches of one ownership build.
pub const DISPATCHES: u64 = 3;

/// The largest vertex coordinate and frame side (px) the shader's exact
/// arithmetic covers.
const LIMIT_PX: f32 = 8192.0;

/// Whether the GPU can build this mask's ownership for a `w` × `h` frame
/// exactly (see the module documentation).
pub fn fits(mask: &RayMask, w: u32, h: u32) -> bool {
    (w as f32) < LIMIT_PX
        && (h as f32) < LIMIT_PX
        && mask
            .vertices
            .iter()
            .all(|v| v[0].abs() < LIMIT_PX && v[1].abs() < LIMIT_PX)
}

/// The ownership pipelines, their layout and the buffers of the mask's
/// fovea spans.
pub(crate) struct OwnershipPass {
    layout: wgpu::BindGroupLayout,
    clear: wgpu::ComputePipeline,
    fovea: wgpu::ComputePipeline,
    cells: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// Capacity in spans, and the buffer.
    spans: Option<(u64, wgpu::Buffer)>,
}

/// What [`OwnershipPass::prepare`] uploaded, for [`OwnershipPass::encode`].
pub(crate) struct Prepared {
    group: wgpu::BindGroup,
    size: (u32, u32),
    n_spans: u32,
    n_cells: u32,
}

impl OwnershipPass {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("ownership.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("ownership.wgsl").into()),
        });
        let mut entries = vec![uniform_entry()];
        entries.extend((1..=3).map(|b| storage_entry(b, true)));
        entries.push(storage_entry(4, false));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ownership"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ownership"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ownership params"),
            size: std::mem::size_of::<OwnParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            clear: pipeline("own_clear"),
            fovea: pipeline("own_fovea"),
            cells: pipeline("own_cells"),
            layout,
            params,
            spans: None,
        }
    }

    /// Uploads the mask's fovea spans and the pass's uniforms, and binds
    /// them with the mask's `vertices` and `cells` (already uploaded) and
    /// the `owner` buffer the pass writes.
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        traffic: &TrafficCounter,
        max_binding: u64,
        mask: &RayMask,
        (vertices, cells, owner): (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer),
        (w, h): (u32, u32),
    ) -> Result<Prepared, GpuError> {
        let spans: Vec<[u32; 4]> = mask
            .fovea
            .iter()
            .map(|s| [s.y, s.x_start, s.x_end, 0])
            .collect();
        let too_many = |what, n: usize| GpuError::TooLarge {
            what,
            bytes: n as u64,
            limit: u64::from(u32::MAX),
        };
        let n_spans =
            u32::try_from(spans.len()).map_err(|_| too_many("fovea spans", spans.len()))?;
        let n_cells = u32::try_from(mask.cells.len())
            .map_err(|_| too_many("mask cells", mask.cells.len()))?;
        let need = spans.len().max(1) as u64;
        if self.spans.as_ref().is_none_or(|(cap, _)| *cap < need) {
            // Room for a taller fovea without a new buffer every frame.
            let cap = (need * 5 / 4).max(256);
            let buffer = storage(
                device,
                "the fovea spans",
                SPAN_BYTES * cap,
                wgpu::BufferUsages::COPY_DST,
                max_binding,
            )?;
            self.spans = Some((cap, buffer));
        }
        let Some((_, span_buffer)) = self.spans.as_ref() else {
            return Err(GpuError::Readback("no fovea span buffer".into()));
        };
        if !spans.is_empty() {
            traffic.write_buffer(queue, span_buffer, 0, bytemuck::cast_slice(&spans));
        }
        let params = OwnParams {
            width: w,
            height: h,
            n_spans,
            n_cells,
        };
        traffic.write_buffer(queue, &self.params, 0, bytemuck::bytes_of(&params));
        let group = bind(
            device,
            &self.layout,
            "ownership",
            &[
                (0, &self.params),
                (1, vertices),
                (2, cells),
                (3, span_buffer),
                (4, owner),
            ],
        );
        Ok(Prepared {
            group,
            size: (w, h),
            n_spans,
            n_cells,
        })
    }

    /// Encodes the pass's [`DISPATCHES`] dispatches (clear, fovea spans,
    /// cells) in `pass`; an empty fovea or cell list dispatches one
    /// workgroup that does nothing.
    pub fn encode(&self, pass: &mut wgpu::ComputePass<'_>, traffic: &TrafficCounter, p: &Prepared) {
        let (w, h) = p.size;
        pass.set_bind_group(0, &p.group, &[]);
        pass.set_pipeline(&self.clear);
        traffic.dispatch(pass, w.div_ceil(8), h.div_ceil(8), 1);
        pass.set_pipeline(&self.fovea);
        let (x, y) = super::foveated::groups(u64::from(p.n_spans));
        traffic.dispatch(pass, x, y, 1);
        pass.set_pipeline(&self.cells);
        // One thread per cell.
        let (x, y) = super::foveated::groups(u64::from(p.n_cells));
        traffic.dispatch(pass, x, y, 1);
    }
}
