//! The hidden-image cast (`hidden.wgsl` after `cast.wgsl`): per pixel asked
//! for, the first surface of an object other than the visible one along
//! the primary ray, shaded like a primary hit — the GPU twin of
//! [`crate::layers::pixel_layers`] with the ch. 5 pass's rule. Its pipeline
//! is made by the first frame that asks for it ([`GpuFrame::cast_hidden`]).

use std::sync::OnceLock;

use super::buffers::{bind, storage_entry, Layouts};
use super::{GpuError, GpuFrame};

/// Surfaces kept per ray (`HIDDEN_HITS` in hidden.wgsl).
pub const HIDDEN_HITS: usize = crate::layers::MAX_LAYERS;

/// The hidden cast's layout (group 1) and pipeline.
pub(super) struct HiddenCast {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl HiddenCast {
    fn new(device: &wgpu::Device, layouts: &Layouts) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hidden cast"),
            entries: &[storage_entry(0, true), storage_entry(1, false)],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cast.wgsl + hidden.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                format!(
                    "{}\n{}",
                    include_str!("cast.wgsl"),
                    include_str!("hidden.wgsl")
                )
                .into(),
            ),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hidden cast"),
            bind_group_layouts: &[Some(&layouts.cast), Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("hidden"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("hidden"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self { layout, pipeline }
    }
}

/// What a [`GpuFrame`] needs to cast hidden rays: the frame's group 0 and
/// the renderer's (lazily made) pipeline.
pub(super) struct HiddenHook<'a> {
    pub layouts: &'a Layouts,
    pub cast_group: &'a wgpu::BindGroup,
    pub cast: &'a OnceLock<HiddenCast>,
}

impl GpuFrame<'_> {
    /// Encodes the hidden-image cast: for every pixel whose word in `want`
    /// (one `u32` a pixel) is non-zero, the first surface of an object other
    /// than the visible one along its primary ray, among the first
    /// [`HIDDEN_HITS`] distinct surfaces, deeper than the visible one, into
    /// `out` (one `vec4<f32>` a pixel): its linear colour clamped to [0, 1]
    /// and its eye distance (mm); `w = −2` where the ray leaves the scene
    /// before such a surface (the background), `w = −1` where none is
    /// found or none was asked for. Both buffers hold at least
    /// `width·height` entries.
    pub fn cast_hidden(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        want: &wgpu::Buffer,
        out: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let n = u64::from(self.width) * u64::from(self.height);
        if want.size() < 4 * n || out.size() < 16 * n {
            return Err(GpuError::Readback(
                "hidden cast: buffers smaller than the frame".into(),
            ));
        }
        let hook = &self.hidden;
        let cast = hook
            .cast
            .get_or_init(|| HiddenCast::new(self.device, hook.layouts));
        let group = bind(
            self.device,
            &cast.layout,
            "hidden cast",
            &[(0, want), (1, out)],
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("hidden cast"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&cast.pipeline);
        pass.set_bind_group(0, hook.cast_group, &[]);
        pass.set_bind_group(1, &group, &[]);
        self.traffic.dispatch(
            &mut pass,
            self.width.div_ceil(8),
            self.height.div_ceil(8),
            1,
        );
        Ok(())
    }
}
