//! The GPU paths of the two image passes, depth of field
//! ([`crate::effects::depth_of_field`]) and image-based foveation
//! ([`crate::image_foveation`]): the same filters in WGSL (`dof.wgsl`,
//! `image_foveation.wgsl`, sharing `colour.wgsl` and the pyramid's buffer,
//! footprint and lookup in `pyramid.wgsl`, which their shaders put before
//! their own source), encoded on a GPU frame's
//! colour and depth buffers between its cast and its read-back through
//! [`raycast::gpu::GpuPost`], so the image makes no CPU round trip. The CPU
//! code is the reference; the GPU output equals it within 1/255 per
//! channel (`tests/gpu_effects.rs`).
//!
//! What stays on the CPU, per frame:
//! - image-based foveation's level map (it depends on the gaze only, not on
//!   the image): computed by [`ImageFoveation`](crate::image_foveation::ImageFoveation)
//!   exactly as the CPU path does and uploaded (4 bytes a pixel, like the
//!   hybrid method's pixel ownership), only when the gaze or the size
//!   changed;
//! - depth of field's focus: for `focus: Gaze` the 9×9 window of depth and
//!   hit flags around the gaze is read back (at most 2 × 81 words, one wait
//!   on the GPU after the cast), its median and the refocusing dynamics
//!   run on the CPU (the pass's `Focuser`, the CPU pass's own code; one
//!   preamble, `frame_focus`, for both depth-of-field passes);
//!   what needs f64 is turned into a few f32 uniforms there: the CoC
//!   constant, the exact depth interval whose level is 0 (so the sharp
//!   pixels are the CPU's, bit for bit) and the f32 threshold of "behind
//!   the focus" (eq. 4.9).
//!
//! Depth of field by splatting (Lee ch. 5, `splat.wgsl`) runs here too,
//! its hidden image cast on the GPU (see [`splat`]'s notes).
//!
//! Depth of field's `focus: Attention` runs Lee's attention model here
//! (`attention.wgsl`, see [`attention`]'s notes): its per-pixel and
//! per-map part on the frame's colour, depth and object ids, a read-back of
//! per-object statistics, and the CPU tracker's finishing steps, before the
//! blur; the frame's surface buffers need not come back for it.
//!
//! Pay per use: a renderer makes a pass's GPU state only when the scene
//! lists `DepthOfField` or the method is `Image`, and its buffers with its
//! first frame; the attention passes only for `focus: Attention`.

mod attention;
mod dof;
mod image;
mod por;
mod splat;

pub(crate) use attention::{made_on_this_thread, GpuSaliency, PrepareError, SaliencyInput};
pub(crate) use dof::GpuDof;
pub(crate) use image::GpuImagePass;
pub(crate) use por::GpuPor;
pub(crate) use splat::GpuSplat;

use raycast::gpu::wgpu;
use raycast::gpu::{GpuError, GpuFrame, GpuPost, TrafficCounter};

use foveation::thin_lens::EyeLens;
use raycast::scene::DofFocus;

use crate::colour;
use crate::effects::depth_of_field::{coc_px, focus_window, is_pinhole, median_depth, Focuser};
use crate::effects::{GpuPass, PassInput};

/// Bytes of one uniform slot (one dispatch's params, a dynamic offset).
const SLOT: u64 = 256;

/// The 255 f32 values where [`colour::encode`] moves from byte b to b + 1,
/// found from `encode` itself (the smallest f32 it maps above b), so that
/// the GPU's encoding is the CPU's by construction.
fn encode_thresholds() -> [f32; 255] {
    let mut t = [0.0f32; 255];
    for (b, v) in t.iter_mut().enumerate() {
        // Bisect on the bits of positive floats (ordered like the floats).
        let (mut lo, mut hi) = (0u32, 2.0f32.to_bits());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if usize::from(colour::encode(f32::from_bits(mid))) > b {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        *v = f32::from_bits(lo);
    }
    t
}

/// What a pass's shader binds: group 0 of `colour.wgsl` and its own
/// storage buffers at bindings 4….
pub(super) struct Kernels {
    pub layout: wgpu::BindGroupLayout,
    pub pipelines: Vec<wgpu::ComputePipeline>,
    /// `colour.wgsl`'s `lut` and `thresholds` (bindings 1 and 2), for
    /// shaders that decode or encode colour; `None` for one that only reads
    /// the packed words (the bindings are then left out of the layout).
    pub colour_tables: Option<[wgpu::Buffer; 2]>,
}

impl Kernels {
    /// The shader `colour.wgsl` + `source`, its entry points, and the
    /// colour tables. `extra` lists bindings 4… as read-only or not.
    pub fn new(
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        label: &str,
        source: &str,
        entries: &[&str],
        extra: &[bool],
        params_bytes: u64,
    ) -> Self {
        Self::build(
            device,
            traffic,
            label,
            source,
            entries,
            extra,
            params_bytes,
            true,
        )
    }

    /// [`Kernels::new`] for a shader none of whose entry points decodes or
    /// encodes colour: no colour tables are made or bound.
    pub fn without_colour_tables(
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        label: &str,
        source: &str,
        entries: &[&str],
        extra: &[bool],
        params_bytes: u64,
    ) -> Self {
        Self::build(
            device,
            traffic,
            label,
            source,
            entries,
            extra,
            params_bytes,
            false,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        label: &str,
        source: &str,
        entries: &[&str],
        extra: &[bool],
        params_bytes: u64,
        colour_tables: bool,
    ) -> Self {
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let mut layout_entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(params_bytes),
            },
            count: None,
        }];
        if colour_tables {
            layout_entries.extend([storage(1, true), storage(2, true)]);
        }
        layout_entries.push(storage(3, false));
        for (k, &read_only) in extra.iter().enumerate() {
            layout_entries.push(storage(4 + k as u32, read_only));
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &layout_entries,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(
                format!("{}\n{}", include_str!("colour.wgsl"), source).into(),
            ),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipelines = entries
            .iter()
            .map(|entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect();
        let table = |what, words: &[f32]| {
            traffic.buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some(what),
                    contents: bytemuck::cast_slice(words),
                    usage: wgpu::BufferUsages::STORAGE,
                },
            )
        };
        Self {
            layout,
            pipelines,
            colour_tables: colour_tables.then(|| {
                [
                    table("decode table", colour::decode_lut()),
                    table("encode thresholds", &encode_thresholds()),
                ]
            }),
        }
    }

    /// The bind group over `params` (one [`SLOT`] bound), the tables, the
    /// frame's pixels and `extra` at bindings 4….
    pub fn bind(
        &self,
        device: &wgpu::Device,
        params: &wgpu::Buffer,
        params_bytes: u64,
        pixels: &wgpu::Buffer,
        extra: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: params,
                offset: 0,
                size: wgpu::BufferSize::new(params_bytes),
            }),
        }];
        if let Some([lut, thresholds]) = &self.colour_tables {
            entries.extend([
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lut.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: thresholds.as_entire_binding(),
                },
            ]);
        }
        entries.push(wgpu::BindGroupEntry {
            binding: 3,
            resource: pixels.as_entire_binding(),
        });
        for (k, b) in extra.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: 4 + k as u32,
                resource: b.as_entire_binding(),
            });
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("post"),
            layout: &self.layout,
            entries: &entries,
        })
    }
}

/// One compute pass: `pipeline` over a `w`×`h` grid in workgroups of 8×8
/// with the uniform slot `slot`.
pub(super) fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    traffic: &TrafficCounter,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    slot: u32,
    (w, h): (u32, u32),
) {
    dispatch_groups(
        encoder,
        traffic,
        pipeline,
        group,
        slot,
        [w.div_ceil(8), h.div_ceil(8), 1],
    );
}

/// One compute pass: `pipeline` over `groups` workgroups (x, y, z) with
/// the uniform slot `slot`; nothing for an empty grid.
pub(super) fn dispatch_groups(
    encoder: &mut wgpu::CommandEncoder,
    traffic: &TrafficCounter,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    slot: u32,
    groups: [u32; 3],
) {
    if groups.contains(&0) {
        return;
    }
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("post pass"),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[slot * SLOT as u32]);
    traffic.dispatch(&mut pass, groups[0], groups[1], groups[2]);
}

/// A uniform block written word by word (u32 or f32, 4 bytes each).
#[derive(Default)]
pub(super) struct Words(pub Vec<u8>);

impl Words {
    pub fn u(&mut self, v: u32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f(&mut self, v: f32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    /// Pads to `bytes` (the struct's size in WGSL).
    pub fn pad_to(&mut self, bytes: usize) -> &mut Self {
        self.0.resize(bytes.max(self.0.len()), 0);
        self
    }
}

/// Level sizes of a pyramid over a `w`×`h` frame, levels 0..`n`: each
/// `div_ceil(2)` of the one before; with each level's first texel in one
/// array of them all, and the total.
pub(super) fn level_layout(w: u32, h: u32, n: usize) -> (Vec<[u32; 3]>, u64) {
    let (mut lw, mut lh, mut off) = (w, h, 0u64);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push([off as u32, lw, lh]);
        off += u64::from(lw) * u64::from(lh);
        lw = lw.div_ceil(2);
        lh = lh.div_ceil(2);
    }
    (out, off)
}

/// A frame's GPU passes in the plan's order, as the hook between the cast
/// and the read-back.
pub(crate) struct Chain<'a, 'b> {
    pub passes: &'a mut [Box<dyn GpuPass>],
    pub input: &'a PassInput<'b>,
}

impl GpuPost for Chain<'_, '_> {
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        for pass in self.passes.iter_mut() {
            encoder = pass.encode(frame, encoder, self.input)?;
        }
        Ok(encoder)
    }
}

/// The focus found in the gaze window read back (the median of its hit
/// depths), for both depth-of-field passes.
pub(crate) fn gaze_window_depth(
    frame: &GpuFrame<'_>,
    encoder: wgpu::CommandEncoder,
    gaze_px: [f64; 2],
) -> Result<(Option<f64>, wgpu::CommandEncoder), GpuError> {
    let (w, h) = (frame.width(), frame.height());
    match focus_window(i64::from(w), i64::from(h), gaze_px) {
        Some((x0, y0, x1, y1)) if x0 <= x1 && y0 <= y1 => {
            let n = (x1 - x0 + 1) as u64;
            let mut reads = Vec::new();
            for y in y0..=y1 {
                let first = y as u64 * u64::from(w) + x0 as u64;
                reads.push((frame.depth(), first, n));
                reads.push((frame.pixels(), first, n));
            }
            let (words, next) = frame.read_words(encoder, &reads)?;
            let mut depths = Vec::with_capacity(81);
            for pair in words.chunks_exact(2) {
                for (&d, &p) in pair[0].iter().zip(&pair[1]) {
                    let hit = (p >> 24) & 1 == 1;
                    depths.push(if hit {
                        f32::from_bits(d)
                    } else {
                        f32::INFINITY
                    });
                }
            }
            Ok((median_depth(depths), next))
        }
        _ => Ok((None, encoder)),
    }
}

/// The focal depth of this frame for a GPU depth-of-field pass, the same
/// preamble for both chapters' passes (`dof`, `splat`): `None` where the
/// pass is the identity this frame (an empty frame, or a pinhole, whose
/// focus is then not even updated); else what the focus search finds
/// ([`found_focus`]) settled by the pass's own [`Focuser`] (the CPU pass's
/// refocusing state and code), as the CPU pass's `run` does.
pub(crate) fn frame_focus(
    lens: &EyeLens,
    focus: DofFocus,
    focuser: &mut Focuser,
    frame: &GpuFrame<'_>,
    encoder: wgpu::CommandEncoder,
    input: &PassInput<'_>,
) -> Result<(Option<f64>, wgpu::CommandEncoder), GpuError> {
    if frame.width() == 0 || frame.height() == 0 || is_pinhole(lens) {
        return Ok((None, encoder));
    }
    let attention = focuser.attention_model().map(|model| AttentionFocus {
        model,
        scene: input.scene,
        time_s: input.time_s,
    });
    let (found, encoder) = found_focus(
        focus,
        input.vergence_mm,
        frame,
        encoder,
        input.gaze_px,
        attention,
    )?;
    Ok((Some(focuser.settle(focus, found, input.time_s)), encoder))
}

/// The thin-lens CoC of both GPU depth-of-field passes as f32 uniforms,
/// derived in f64 with `coc_px`'s clamps: per pixel `C(d) = k·|d − d_f|/d`
/// for a finite focus (`d_f` as `focus_hi + focus_lo`, two f32) or `k/d`
/// for a focus at infinity, the depth clamped to `nearest` first.
pub(super) struct CocUniforms {
    /// `coc_px`'s nearest depth (just beyond the focal length), mm.
    pub nearest: f64,
    /// The focus as `coc_px` clamps it (NaN: infinity), mm.
    pub focus_c: f64,
    /// Whether `focus_c` is finite.
    pub finite: bool,
    /// The CoC constant (may be infinite or NaN for a degenerate lens).
    pub k: f64,
    pub focus_hi: f32,
    pub focus_lo: f32,
}

impl CocUniforms {
    /// For `lens` focused at `focus_mm` on the screen `screen_of` gives.
    pub fn new(lens: &EyeLens, focus_mm: f64, ds: f64, ppmm: f64) -> Self {
        let nearest = lens.focal_length_mm * (1.0 + 1e-9);
        let focus_c = if focus_mm.is_nan() {
            f64::INFINITY
        } else {
            focus_mm.max(nearest)
        };
        let finite = focus_c.is_finite();
        let k = if finite {
            // C(∞) = DPI·(d_s/d_r)·E·F/(d_f − F): C(d) = C(∞)·|d − d_f|/d.
            coc_px(lens, f64::INFINITY, focus_mm, ds, ppmm)
        } else {
            // Focus at infinity: C(d) = DPI·(d_s/d_r)·E·F/d.
            ppmm * (ds / lens.retina_distance_mm) * (lens.aperture_mm * lens.focal_length_mm)
        };
        let focus_hi = if finite { focus_c as f32 } else { 0.0 };
        let focus_lo = if finite {
            (focus_c - f64::from(focus_hi)) as f32
        } else {
            0.0
        };
        Self {
            nearest,
            focus_c,
            finite,
            k,
            focus_hi,
            focus_lo,
        }
    }
}

/// `focus: Attention`'s model and what it reads besides the frame.
struct AttentionFocus<'a> {
    model: &'a mut crate::frame_attention::FrameAttention,
    scene: &'a raycast::Scene,
    time_s: Option<f64>,
}

/// What a GPU depth-of-field pass's focus search finds this frame, as the
/// CPU's `Focuser` would (then settled by [`frame_focus`]): the
/// vergence depth, or the gaze window's median read back (one wait) where
/// the focus needs it; for `Attention`, the attended object's mean eye
/// distance from Lee's model run on the frame's buffers (its GPU passes,
/// one wait, and the CPU tracker's finishing steps); nothing for a fixed
/// focus.
fn found_focus(
    focus: DofFocus,
    vergence_mm: Option<f64>,
    frame: &GpuFrame<'_>,
    encoder: wgpu::CommandEncoder,
    gaze_px: [f64; 2],
    attention: Option<AttentionFocus<'_>>,
) -> Result<(Option<f64>, wgpu::CommandEncoder), GpuError> {
    let vergence = vergence_mm.filter(|d| d.is_finite() && *d > 0.0);
    match focus {
        DofFocus::Fixed { .. } => Ok((None, encoder)),
        DofFocus::Attention => match attention {
            Some(a) => a.model.depth_mm_on_gpu(frame, encoder, a.scene, a.time_s),
            None => Ok((None, encoder)),
        },
        DofFocus::Vergence if vergence.is_some() => Ok((vergence, encoder)),
        DofFocus::Gaze | DofFocus::Vergence => gaze_window_depth(frame, encoder, gaze_px),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thresholds_are_where_encode_steps() {
        let t = encode_thresholds();
        for (b, &v) in t.iter().enumerate() {
            assert_eq!(usize::from(colour::encode(v)), b + 1);
            let below = f32::from_bits(v.to_bits() - 1);
            assert_eq!(usize::from(colour::encode(below)), b);
        }
    }
}
