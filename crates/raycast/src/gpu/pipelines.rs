//! The shader (`cast.wgsl` followed by `foveated.wgsl`) and its compute
//! pipelines: one for the full-resolution frame, one per foveated [`Stage`].

use super::buffers::Layouts;
use super::foveated::Stage;

pub(super) struct Pipelines {
    /// `full`: cast and shade every pixel.
    pub full: wgpu::ComputePipeline,
    cast_vertices: wgpu::ComputePipeline,
    classify: wgpu::ComputePipeline,
    widen: wgpu::ComputePipeline,
    count_cells: wgpu::ComputePipeline,
    pixels_foveated: wgpu::ComputePipeline,
    prepare_cast: wgpu::ComputePipeline,
    cast_listed: wgpu::ComputePipeline,
}

impl Pipelines {
    pub fn new(device: &wgpu::Device, layouts: &Layouts) -> Self {
        let source = format!(
            "{}\n{}",
            include_str!("cast.wgsl"),
            include_str!("foveated.wgsl")
        );
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("cast.wgsl + foveated.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline_layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: groups,
                immediate_size: 0,
            })
        };
        let cast = pipeline_layout("cast", &[Some(&layouts.cast)]);
        let foveated = pipeline_layout("foveated", &[Some(&layouts.cast), Some(&layouts.foveated)]);
        let prepare = pipeline_layout(
            "prepare cast",
            &[
                Some(&layouts.cast),
                Some(&layouts.foveated),
                Some(&layouts.dispatch),
            ],
        );
        let pipeline = |entry: &str, layout: &wgpu::PipelineLayout| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let stage = |s: Stage| {
            let layout = if s == Stage::PrepareDispatch {
                &prepare
            } else {
                &foveated
            };
            pipeline(s.entry_point(), layout)
        };
        Self {
            full: pipeline("full", &cast),
            cast_vertices: stage(Stage::CastVertices),
            classify: stage(Stage::ClassifyCells),
            widen: stage(Stage::SilhouetteMargin),
            count_cells: stage(Stage::CountRefinedCells),
            pixels_foveated: stage(Stage::InterpolateOrList),
            prepare_cast: stage(Stage::PrepareDispatch),
            cast_listed: stage(Stage::CastListed),
        }
    }

    /// The pipeline of a foveated stage (`None` for the pixel ownership,
    /// whose three pipelines are `ownership::OwnershipPass`'s).
    pub fn stage(&self, s: Stage) -> Option<&wgpu::ComputePipeline> {
        Some(match s {
            Stage::BuildOwnership => return None,
            Stage::CastVertices => &self.cast_vertices,
            Stage::ClassifyCells => &self.classify,
            Stage::SilhouetteMargin => &self.widen,
            Stage::CountRefinedCells => &self.count_cells,
            Stage::InterpolateOrList => &self.pixels_foveated,
            Stage::PrepareDispatch => &self.prepare_cast,
            Stage::CastListed => &self.cast_listed,
        })
    }
}
