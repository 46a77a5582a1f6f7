//! The foveated frame (`foveated.wgsl`): the CPU's `render::foveated`,
//! stage for stage, one compute pass per [`Stage`]. The CPU builds the ray
//! mask for the gaze and uploads it (vertices, cells, fovea spans); the
//! pixel ownership is built from it on the GPU (`ownership.wgsl`), or on
//! the CPU and uploaded for a mask beyond the shader's exact range.

use std::time::Instant;

use foveation::mask::{RayMask, NO_VERTEX};

use super::buffers::{FovParams, FoveatedTarget};
use super::ownership::OwnershipPass;
use super::readback::{copy_out, read_back, read_frame};
use super::timer::begin_pass;
use super::{GpuError, GpuPost, GpuRenderer};
use crate::camera::Camera;
use crate::frame::Frame;
use crate::render::{Stats, Triggers};

/// A stage of the foveated frame: one compute pass each, in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Build the pixel ownership of a newly uploaded mask (clear, fovea
    /// spans, cells): only in a frame whose mask is new.
    BuildOwnership,
    /// Cast a ray through every mask vertex.
    CastVertices,
    /// Mark the cells that are not homogeneous under the triggers.
    ClassifyCells,
    /// Also mark the cells that share a vertex with a marked one.
    SilhouetteMargin,
    /// Count the refined cells (for the stats).
    CountRefinedCells,
    /// Interpolate the pixels of homogeneous cells; list the fovea and
    /// refined pixels to cast.
    InterpolateOrList,
    /// Write the indirect dispatch arguments for the listed pixels.
    PrepareDispatch,
    /// Cast and shade the listed pixels.
    CastListed,
}

impl Stage {
    /// Every stage, in pass order.
    pub const ALL: [Stage; 8] = [
        Stage::BuildOwnership,
        Stage::CastVertices,
        Stage::ClassifyCells,
        Stage::SilhouetteMargin,
        Stage::CountRefinedCells,
        Stage::InterpolateOrList,
        Stage::PrepareDispatch,
        Stage::CastListed,
    ];

    /// The stage in words (the names [`GpuRenderer::stage_ms`] reports).
    pub fn name(self) -> &'static str {
        match self {
            Stage::BuildOwnership => "build pixel ownership",
            Stage::CastVertices => "cast vertices",
            Stage::ClassifyCells => "classify cells",
            Stage::SilhouetteMargin => "silhouette margin",
            Stage::CountRefinedCells => "count refined cells",
            Stage::InterpolateOrList => "interpolate or list pixels",
            Stage::PrepareDispatch => "prepare dispatch",
            Stage::CastListed => "cast listed pixels",
        }
    }

    /// Its entry point in `foveated.wgsl`.
    pub(super) fn entry_point(self) -> &'static str {
        match self {
            Stage::BuildOwnership => "own_cells",
            Stage::CastVertices => "cast_vertices",
            Stage::ClassifyCells => "classify",
            Stage::SilhouetteMargin => "widen",
            Stage::CountRefinedCells => "count_cells",
            Stage::InterpolateOrList => "pixels_foveated",
            Stage::PrepareDispatch => "prepare_cast",
            Stage::CastListed => "cast_listed",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The stages a foveated frame runs with these triggers, in order, for a
/// mask the GPU already holds (a new mask runs
/// [`Stage::BuildOwnership`] first): a scene's effects decide, and a pass
/// for an effect the scene does not list is not dispatched. Without any refinement trigger no cell is classified
/// (none can be refined); without the silhouette margin the widening pass
/// does not run.
pub fn foveated_stages(t: &Triggers) -> Vec<Stage> {
    let classify = t.silhouette || t.crease_deg.is_some() || t.depth_jump.is_some();
    let mut out = vec![Stage::CastVertices];
    if classify {
        out.push(Stage::ClassifyCells);
        if t.margin {
            out.push(Stage::SilhouetteMargin);
        }
        out.push(Stage::CountRefinedCells);
    }
    out.extend([
        Stage::InterpolateOrList,
        Stage::PrepareDispatch,
        Stage::CastListed,
    ]);
    out
}

/// Workgroups (x, y) for `n` threads in groups of 64, at most 65535 in x
/// (the shaders index `x + y · 65535 · 64`).
pub(super) fn groups(n: u64) -> (u32, u32) {
    let g = n.div_ceil(64).max(1);
    (g.min(65_535) as u32, g.div_ceil(65_535) as u32)
}

impl GpuRenderer {
    /// Makes sure the foveated buffers hold this many vertices, cells and
    /// pixels (new buffers hold no mask).
    fn foveated_target(&mut self, vertices: u64, cells: u64, pixels: u64) -> Result<(), GpuError> {
        if self
            .fov_target
            .as_ref()
            .is_some_and(|t| t.fits(vertices, cells, pixels))
        {
            return Ok(());
        }
        self.uploaded_mask = None;
        self.fov_target = Some(FoveatedTarget::new(
            &self.device,
            &self.layouts,
            &self.fov_params,
            (vertices, cells, pixels),
            self.max_binding,
        )?);
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
        self.render_foveated_with(cam, mask, triggers, None)
    }

    /// [`GpuRenderer::render_foveated`] with `post`'s passes encoded on the
    /// frame's buffers between the last stage and the read-back.
    pub fn render_foveated_with(
        &mut self,
        cam: &Camera,
        mask: &RayMask,
        triggers: &Triggers,
        post: Option<&mut dyn GpuPost>,
    ) -> Result<(Frame, Stats), GpuError> {
        self.render_foveated_kept(cam, mask, None, triggers, post)
    }

    /// [`GpuRenderer::render_foveated_with`] for a mask of a known
    /// `generation` ([`crate::render::Scratch::mask_for`]): when the GPU
    /// already holds that mask for this frame size (the last foveated frame
    /// uploaded it, and a gaze within the model's tolerance kept it), its
    /// pixel ownership is not rasterised again and nothing of it is
    /// uploaded (4 bytes a pixel of owners, 33 MB at 3840×2160, besides the
    /// vertices and cells). `None`: always uploaded.
    pub fn render_foveated_kept(
        &mut self,
        cam: &Camera,
        mask: &RayMask,
        generation: Option<(u64, u64)>,
        triggers: &Triggers,
        post: Option<&mut dyn GpuPost>,
    ) -> Result<(Frame, Stats), GpuError> {
        let start = Instant::now();
        let traffic = self.traffic.clone();
        let before = traffic.total();
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = self.write_params(cam)?;
        let (nv, nc) = (mask.vertices.len() as u64, mask.cells.len() as u64);
        let too_many = |what, n: u64| GpuError::TooLarge {
            what,
            bytes: n,
            limit: u64::from(u32::MAX),
        };
        let n_vertices = u32::try_from(nv).map_err(|_| too_many("the mask vertices", nv))?;
        let n_cells = u32::try_from(nc).map_err(|_| too_many("the mask cells", nc))?;
        self.foveated_target(nv, nc, u64::from(pixels))?;
        let key = generation.map(|g| (g, (w, h)));
        let upload = key.is_none() || key != self.uploaded_mask;
        // A new mask's ownership is built on the GPU from the mask itself;
        // only a mask beyond the shader's exact range is rasterised here and
        // uploaded, 4 bytes a pixel.
        let on_gpu = upload && super::ownership::fits(mask, w, h);
        let owner = if upload && !on_gpu {
            crate::render::ownership(mask, w as usize, h as usize)
        } else {
            Vec::new()
        };
        let device = self.device.clone();
        let queue = self.queue.clone();
        let timer = self.timer.clone();
        self.frame_target(pixels)?;
        let (Some(target), Some(ft)) = (self.target.as_ref(), self.fov_target.as_ref()) else {
            return Err(GpuError::Readback("no frame or foveated buffers".into()));
        };
        let fov = FovParams {
            n_vertices,
            n_cells,
            silhouette: u32::from(triggers.silhouette),
            margin: u32::from(triggers.margin),
            crease_cos: triggers.crease_deg.map_or(-2.0, |d| d.to_radians().cos()),
            depth_jump: triggers.depth_jump.unwrap_or(-1.0),
            pad: [0; 2],
        };
        traffic.write_buffer(&queue, &self.fov_params, 0, bytemuck::bytes_of(&fov));
        // Triangles carry NO_VERTEX (u32::MAX) as their fourth corner, as
        // `foveated.wgsl` expects.
        const _: () = assert!(NO_VERTEX == u32::MAX);
        let pipelines = &self.pipelines;
        let mask_before = traffic.total();
        if upload && nv > 0 {
            traffic.write_buffer(
                &queue,
                &ft.mask_vertices,
                0,
                bytemuck::cast_slice(&mask.vertices),
            );
        }
        if upload && nc > 0 {
            traffic.write_buffer(&queue, &ft.mask_cells, 0, bytemuck::cast_slice(&mask.cells));
        }
        if !owner.is_empty() {
            traffic.write_buffer(&queue, &ft.owner, 0, bytemuck::cast_slice(&owner));
        }
        let ownership = if on_gpu {
            let pass = self
                .ownership
                .get_or_insert_with(|| OwnershipPass::new(&device));
            Some(pass.prepare(
                &device,
                &queue,
                &traffic,
                self.max_binding,
                mask,
                (&ft.mask_vertices, &ft.mask_cells, &ft.owner),
                (w, h),
            )?)
        } else {
            None
        };
        self.mask_upload_bytes = traffic.total().since(mask_before).uploaded_bytes;
        // Only now does the GPU hold this mask (an error above uploaded
        // nothing, and the next frame must upload it).
        self.uploaded_mask = key;
        traffic.write_buffer(&queue, &ft.counters, 0, &[0u8; 16]);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("foveated frame"),
        });
        let mut stages = foveated_stages(triggers);
        if ownership.is_some() {
            stages.insert(0, Stage::BuildOwnership);
        }
        if triggers.margin {
            encoder.clear_buffer(&ft.touched, 0, None);
        }
        if !stages.contains(&Stage::ClassifyCells) {
            // Nothing is classified: no cell is refined.
            encoder.clear_buffer(&ft.refined, 0, None);
        }
        // One pass per stage, so that each can be timed.
        for (slot, &stage) in stages.iter().enumerate() {
            let mut pass = begin_pass(&mut encoder, timer.as_ref(), slot as u32, stage.name());
            if stage == Stage::BuildOwnership {
                if let (Some(own), Some(prepared)) = (self.ownership.as_ref(), ownership.as_ref()) {
                    own.encode(&mut pass, &traffic, prepared);
                }
                continue;
            }
            pass.set_bind_group(0, &target.bind_group, &[]);
            pass.set_bind_group(1, &ft.bind_group, &[]);
            if let Some(p) = pipelines.stage(stage) {
                pass.set_pipeline(p);
            }
            match stage {
                Stage::CastVertices => {
                    let (x, y) = groups(nv);
                    traffic.dispatch(&mut pass, x, y, 1);
                }
                Stage::ClassifyCells | Stage::SilhouetteMargin | Stage::CountRefinedCells => {
                    let (x, y) = groups(nc);
                    traffic.dispatch(&mut pass, x, y, 1);
                }
                Stage::InterpolateOrList => {
                    traffic.dispatch(&mut pass, w.div_ceil(8), h.div_ceil(8), 1)
                }
                Stage::PrepareDispatch => {
                    pass.set_bind_group(2, &ft.dispatch_group, &[]);
                    traffic.dispatch(&mut pass, 1, 1, 1);
                }
                Stage::CastListed => traffic.dispatch_indirect(&mut pass, &ft.dispatch, 0),
                // Encoded above, with its own pipelines and bind group.
                Stage::BuildOwnership => {}
            }
        }
        encoder = self.encode_post(target, post, (w, h), encoder)?;
        // Without a read-back the frame stays here for its presenter; only
        // the ray counters come back.
        let read = self.read_back;
        let timer = timer.filter(|_| read);
        if read {
            copy_out(&mut encoder, &target.out, &target.readback, pixels);
        }
        if let Some(t) = &timer {
            t.resolve(&mut encoder, stages.len() as u32);
        }
        encoder.copy_buffer_to_buffer(&ft.counters, 0, &ft.counters_readback, 0, 16);
        traffic.submit(&queue, encoder.finish());
        self.last_size = Some((w, h));
        let frame = if read {
            read_frame(&device, &traffic, &target.readback, w, h, self.surface)?
        } else {
            Frame::on_device(w, h)
        };
        let counters = read_back(&device, &traffic, &ft.counters_readback, 16)?;
        let [fovea, refine, cells_refined, _listed] =
            [0, 1, 2, 3].map(|k| counters.get(k).copied().map_or(0, u64::from));
        self.stage_ms = match &timer {
            Some(t) => {
                let names: Vec<&'static str> = stages.iter().map(|s| s.name()).collect();
                t.read(&device, &traffic, &names)?
            }
            None => Vec::new(),
        };
        let stats = Stats {
            rays_fovea: fovea,
            rays_mask: nv,
            rays_refine: refine,
            rays_full: 0,
            rays_total: fovea + nv + refine,
            cells_total: nc,
            cells_refined,
            pixels_uncovered: 0,
            time_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        self.frame_traffic = traffic.total().since(before);
        Ok((frame, stats))
    }

    /// The pixel owners the GPU holds for the last foveated frame of `w` ×
    /// `h` pixels (a cell index, `render::OWNER_FOVEA` or
    /// `render::OWNER_NONE` per pixel, row-major), read back: what the
    /// ownership pass built, for tests and checks (a frame never reads
    /// them back).
    pub fn pixel_owners(&self, w: u32, h: u32) -> Result<Vec<u32>, GpuError> {
        let Some(ft) = self.fov_target.as_ref() else {
            return Err(GpuError::Readback("no foveated frame yet".into()));
        };
        let n = u64::from(w) * u64::from(h);
        if n > ft.pixels {
            return Err(GpuError::Readback(format!(
                "{w}x{h} is larger than the last foveated frame"
            )));
        }
        let encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("pixel owners"),
            });
        let (mut words, _) = super::post::read_words(
            &self.device,
            &self.queue,
            &self.traffic,
            encoder,
            &[(&ft.owner, 0, n)],
        )?;
        Ok(words.pop().unwrap_or_default())
    }
}
