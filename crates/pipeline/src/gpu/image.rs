//! Image-based foveation on the GPU (`image_foveation.wgsl`): decode,
//! REDUCE level by level, blend, on the frame's pixel words. The level map
//! is the CPU's ([`ImageFoveation::levels`](crate::image_foveation::ImageFoveation::levels)),
//! uploaded when the gaze or the frame size changed.

use raycast::gpu::wgpu;
use raycast::gpu::{GpuError, GpuFrame};

use super::{dispatch, level_layout, Kernels, Words, SLOT};
use crate::effects::{GpuPass, Pass, PassInput};
use crate::image_foveation::{ImagePass, MAX_LEVEL};
use foveation::SamplingModel;

/// Bytes of `Params` in `image_foveation.wgsl`.
const PARAMS_BYTES: u64 = 16 + 16 * (MAX_LEVEL as u64 + 1);

/// Entry points, in the order of `Kernels::pipelines`.
const BASE: usize = 0;
const ROWS: usize = 1;
const COLUMNS: usize = 2;
const BLEND: usize = 3;

/// The buffers for one frame size.
struct Buffers {
    size: (u32, u32),
    /// The pixels buffer the bind group was made for (a new frame target
    /// means a new bind group).
    pixels: wgpu::Buffer,
    params: wgpu::Buffer,
    level_map: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Keeps the pyramid and REDUCE buffers alive (the bind group holds them).
    _pyramid: wgpu::Buffer,
    _rows: wgpu::Buffer,
}

/// The GPU state of image-based foveation: made when the method is
/// `Image` on the GPU backend, its buffers with the first frame.
#[derive(Default)]
struct GpuImage {
    kernels: Option<Kernels>,
    buffers: Option<Buffers>,
    /// The gaze and size whose level map is on the GPU.
    uploaded: Option<([u64; 2], (u32, u32))>,
}

/// One frame's image-based foveation: the state, the CPU's level map and
/// the deepest level it needs (`None`: nothing to blur).
struct ImageFrame<'a> {
    pub state: &'a mut GpuImage,
    pub levels: &'a [f32],
    pub needed: Option<usize>,
    pub gaze_px: [f64; 2],
}

/// Image-based foveation's pass on the GPU: the CPU pass (whose filter
/// computes the level map, uploaded when the gaze moves, and never builds
/// its CPU pyramid) and the GPU state.
pub(crate) struct GpuImagePass {
    pass: ImagePass,
    state: GpuImage,
}

impl GpuImagePass {
    pub fn new(pass: ImagePass) -> Self {
        Self {
            pass,
            state: GpuImage::default(),
        }
    }
}

impl GpuPass for GpuImagePass {
    fn reference(&self) -> &dyn Pass {
        &self.pass
    }

    fn prepare(&mut self, model: &SamplingModel) {
        self.pass.prepare(model);
    }

    fn has_buffers(&self) -> bool {
        self.state.buffers.is_some()
    }

    fn owns(&self) -> String {
        "the level map (CPU and GPU), the GPU pyramid and REDUCE rows".into()
    }

    fn detail(&self) -> String {
        format!(
            "image-based foveation on the GPU: level log2(ray spacing) per \
             pixel (spacing ≤ {} px) from the CPU, uploaded when the gaze moves; decode → \
             Gaussian pyramid (REDUCE, rows then columns) → blend of adjacent levels",
            self.pass.max_spacing_px()
        )
    }

    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        input: &PassInput<'_>,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let Some(model) = self.pass.model else {
            return Ok(encoder);
        };
        let started = std::time::Instant::now();
        let size = (
            input.camera.width_px as usize,
            input.camera.height_px as usize,
        );
        let needed = self.pass.filter.levels_for(&model, input.gaze_px, size);
        self.pass.ms = started.elapsed().as_secs_f64() * 1e3;
        ImageFrame {
            state: &mut self.state,
            levels: self.pass.filter.levels(),
            needed,
            gaze_px: input.gaze_px,
        }
        .encode(frame, encoder)
    }
}

impl ImageFrame<'_> {
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let Some(needed) = self.needed else {
            return Ok(encoder);
        };
        let (w, h) = (frame.width(), frame.height());
        let pixels = u64::from(w) * u64::from(h);
        if pixels == 0 || self.levels.len() as u64 != pixels {
            return Ok(encoder);
        }
        let device = frame.device();
        let st = &mut *self.state;
        let kernels = st.kernels.get_or_insert_with(|| {
            Kernels::new(
                device,
                frame.traffic(),
                "image_foveation.wgsl",
                concat!(
                    include_str!("pyramid.wgsl"),
                    "\n",
                    include_str!("image_foveation.wgsl")
                ),
                &["fov_base", "fov_rows", "fov_columns", "fov_blend"],
                &[true, false, false],
                PARAMS_BYTES,
            )
        });
        let (layout, texels) = level_layout(w, h, MAX_LEVEL + 1);
        let stale = st
            .buffers
            .as_ref()
            .is_none_or(|b| b.size != (w, h) || b.pixels != *frame.pixels());
        if stale {
            st.buffers = None;
            st.uploaded = None;
            let pyramid = frame.storage_buffer(
                "the image pyramid",
                16 * texels,
                wgpu::BufferUsages::empty(),
            )?;
            // REDUCE's horizontal pass: half the width by the full height.
            let rows = frame.storage_buffer(
                "the REDUCE rows",
                16 * u64::from(w.div_ceil(2)) * u64::from(h),
                wgpu::BufferUsages::empty(),
            )?;
            let level_map =
                frame.storage_buffer("the level map", 4 * pixels, wgpu::BufferUsages::COPY_DST)?;
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("image foveation params"),
                size: SLOT * (MAX_LEVEL as u64 + 1),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group = kernels.bind(
                device,
                &params,
                PARAMS_BYTES,
                frame.pixels(),
                &[&level_map, &pyramid, &rows],
            );
            st.buffers = Some(Buffers {
                size: (w, h),
                pixels: frame.pixels().clone(),
                params,
                level_map,
                group,
                _pyramid: pyramid,
                _rows: rows,
            });
        }
        let Some(b) = st.buffers.as_ref() else {
            return Ok(encoder);
        };
        let key = (self.gaze_px.map(f64::to_bits), (w, h));
        if st.uploaded != Some(key) {
            let bytes: Vec<u8> = self.levels.iter().flat_map(|m| m.to_le_bytes()).collect();
            frame.write_buffer(&b.level_map, 0, &bytes);
            st.uploaded = Some(key);
        }
        let n_levels = needed + 1;
        let mut all = Vec::with_capacity((SLOT as usize) * (MAX_LEVEL + 1));
        for src in 0..=MAX_LEVEL {
            let mut words = Words::default();
            words.u(w).u(h).u(n_levels as u32).u(src as u32);
            for l in &layout {
                words.u(l[0]).u(l[1]).u(l[2]).u(0);
            }
            words.pad_to(SLOT as usize);
            all.extend(words.0);
        }
        frame.write_buffer(&b.params, 0, &all);
        let p = &kernels.pipelines;
        dispatch(&mut encoder, frame.traffic(), &p[BASE], &b.group, 0, (w, h));
        for src in 0..needed {
            let [_, _, sh] = layout[src];
            let [_, tw, th] = layout[src + 1];
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[ROWS],
                &b.group,
                src as u32,
                (tw, sh),
            );
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[COLUMNS],
                &b.group,
                src as u32,
                (tw, th),
            );
        }
        dispatch(
            &mut encoder,
            frame.traffic(),
            &p[BLEND],
            &b.group,
            0,
            (w, h),
        );
        Ok(encoder)
    }
}
