//! Depth of field by splatting (Lee 2009 ch. 5) on the GPU (`splat.wgsl`),
//! the twin of [`crate::effects::dof_splat`], on the frame's pixel words
//! and depth between the cast and the read-back:
//!
//! 1. **Focus** as [`super::dof`] does it: for `focus: Gaze` (and
//!    `Vergence` without a vergence depth) the 9×9 gaze window of depth and
//!    hit flags is read back, its median and the refocusing dynamics run on
//!    the CPU (the CPU pass's `Focuser`; the preamble is
//!    [`super::frame_focus`], shared with the ch. 4 pass); for `focus: Attention` Lee's attention model runs its
//!    per-pixel part on the frame's colour, depth and id buffers
//!    ([`super::attention`], one read-back of per-object statistics) and
//!    the CPU tracker finishes it, as for the ch. 4 pass.
//! 2. **V** (`splat_visible`): the decoded colour and the signed CoC per
//!    pixel, in f32 from a few uniforms the CPU derives in f64 (the CoC
//!    constant, the focus as two f32, the exact f32 thresholds of "in
//!    front of" and "behind" the focus, the background's CoC); the seed's
//!    tests (a) and (b) (eq. 5.1 over the same golden-angle spiral) mark
//!    the pixels that want a hidden sample.
//! 3. **H**: test (c) is a ray cast on the GPU
//!    ([`raycast::gpu::GpuFrame::cast_hidden`]: the first surface of
//!    another object among the ray's first four, shaded like a primary
//!    hit, or the background), only for the marked pixels; `splat_hidden`
//!    turns it into a sample.
//! 4. **Scatter** (`splat_scatter`): every V and H sprite, one invocation
//!    per source pixel, adds `k_n(C)·cov` (the CPU's table, uploaded) times
//!    its colour into its destination's layer (eq. 5.3) with **fixed-point
//!    atomics**: each term rounded to a multiple of 2⁻²⁴ and added into a
//!    64-bit accumulator (two `u32`, a carry into the high word when the
//!    low one wraps), so the sums are exact whatever order the sprites
//!    land in; terms are clamped to [0, 255].
//! 5. **Composition and normalisation** (`splat_compose`, eq. 5.4) of the
//!    touched pixels, encoded with `colour.wgsl`; the others (and the
//!    whole frame when no sprite is wider than 1 px) keep their bytes.
//!
//! Pay per use: the buffers (152 bytes a pixel: samples 32, flags 4,
//! hidden image 16, layers 100) are made by the first frame of a scene that
//! lists the splat method on the GPU backend; the hidden cast's pipeline by
//! the first frame that casts hidden rays.

use raycast::gpu::wgpu;
use raycast::gpu::{GpuError, GpuFrame};
use raycast::Camera;

use super::{dispatch, CocUniforms, Kernels, Words};
use crate::effects::depth_of_field::screen_of;
use crate::effects::dof_splat::{
    kn_table, signed_coc_px, spiral, DepthOfFieldSplat, COC_STEPS_PER_PX, DELTA, MAX_COC_PX,
};
use crate::effects::{GpuPass, Pass, PassInput};

/// Bytes of `Params` in `splat.wgsl`.
const PARAMS_BYTES: u64 = 192;

/// Accumulator words per pixel (`WORDS` in splat.wgsl).
const WORDS: u64 = 25;

/// Entry points, in the order of `Kernels::pipelines`.
const VISIBLE: usize = 0;
const HIDDEN: usize = 1;
const SCATTER: usize = 2;
const COMPOSE: usize = 3;

struct Buffers {
    size: (u32, u32),
    frame: (wgpu::Buffer, wgpu::Buffer),
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    want: wgpu::Buffer,
    hidden: wgpu::Buffer,
    acc: wgpu::Buffer,
    _work: wgpu::Buffer,
}

/// The GPU state of the splat pass: the CPU pass (lens, focus, refocusing
/// state; its own buffers stay empty), the shader and, after the first
/// frame, the buffers.
pub(crate) struct GpuSplat {
    pub pass: DepthOfFieldSplat,
    kernels: Option<(Kernels, wgpu::Buffer)>,
    buffers: Option<Buffers>,
}

/// One frame's splat pass, at its focal depth.
struct SplatFrame<'a> {
    pub state: &'a mut GpuSplat,
    pub camera: &'a Camera,
    /// The scene's linear background colour.
    pub background: [f32; 3],
    /// The focal depth ([`super::frame_focus`]), mm.
    pub focus: f64,
}

impl GpuSplat {
    pub fn new(pass: DepthOfFieldSplat) -> Self {
        Self {
            pass,
            kernels: None,
            buffers: None,
        }
    }
}

impl GpuPass for GpuSplat {
    fn reference(&self) -> &dyn Pass {
        &self.pass
    }

    fn has_buffers(&self) -> bool {
        self.buffers.is_some()
    }

    fn focal_depth_mm(&self) -> Option<f64> {
        self.pass.focal_depth_mm()
    }

    fn has_attention_buffers(&self) -> bool {
        self.pass.attention().is_some_and(|a| a.has_gpu_buffers())
    }

    fn owns(&self) -> String {
        "the V and H samples, the hidden image and three fixed-point layers (GPU)".into()
    }

    fn detail(&self) -> String {
        use crate::effects::depth_of_field::{ATTENTION_MAP_SIZE, FOCUS_WINDOW_PX};
        use raycast::scene::DofFocus;
        let focus = match self.pass.focus {
            DofFocus::Gaze | DofFocus::Vergence => format!(
                "the median depth of the {FOCUS_WINDOW_PX}×{FOCUS_WINDOW_PX} window at the gaze \
                 (or the vergence depth) read back after the cast, refocus on the CPU"
            ),
            DofFocus::Fixed { depth_mm } => format!("fixed at {depth_mm} mm"),
            DofFocus::Attention => format!(
                "the attended object: Lee's attention model ({ATTENTION_MAP_SIZE}² maps) on the \
                 GPU frame, per-object statistics read back, finished on the CPU"
            ),
        };
        format!(
            "{} — focus {focus}; V with signed CoC and eq. 5.1 → hidden image cast on the GPU \
             (first other object along the ray) → scatter into three layers (fixed-point atomics, \
             2^-24) → composition and normalisation",
            self.pass.name()
        )
    }

    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        input: &PassInput<'_>,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let pass = &mut self.pass;
        let (focus, encoder) = super::frame_focus(
            &pass.lens,
            pass.focus,
            &mut pass.focuser,
            frame,
            encoder,
            input,
        )?;
        let Some(focus) = focus else {
            return Ok(encoder);
        };
        SplatFrame {
            state: self,
            camera: input.camera,
            background: input.scene.background.to_array(),
            focus,
        }
        .encode(frame, encoder)
    }
}

/// The next f32 up (finite, not the largest).
fn next_up(t: f32) -> f32 {
    if t == 0.0 {
        f32::from_bits(1)
    } else if t > 0.0 {
        f32::from_bits(t.to_bits() + 1)
    } else {
        f32::from_bits(t.to_bits() - 1)
    }
}

/// The smallest f32 `t` with `f64(t) > v` (or `≥ v` with `or_equal`);
/// `f32::MAX` when none below it does.
fn f32_from(v: f64, or_equal: bool) -> f32 {
    let ok = |t: f32| {
        if or_equal {
            f64::from(t) >= v
        } else {
            f64::from(t) > v
        }
    };
    if v.is_nan() || v >= f64::from(f32::MAX) {
        return f32::MAX;
    }
    let mut t = (v as f32).max(f32::MIN);
    // Step down while the one below still qualifies, up until one does.
    while t > f32::MIN && ok(-next_up(-t)) {
        t = -next_up(-t);
    }
    while !ok(t) && t < f32::MAX {
        t = next_up(t);
    }
    t
}

impl SplatFrame<'_> {
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let (w, h) = (frame.width(), frame.height());
        let focus = self.focus;
        let pass = &self.state.pass;
        let lens = pass.lens;
        let (ds, ppmm) = screen_of(self.camera);
        let CocUniforms {
            nearest,
            focus_c,
            finite,
            k,
            focus_hi,
            focus_lo,
        } = CocUniforms::new(&lens, focus, ds, ppmm);
        let k = if k.is_finite() { k } else { 0.0 };
        let (z_in_front, z_behind) = if finite {
            (f32_from(focus_c, true), f32_from(focus_c, false))
        } else {
            (f32::MAX, f32::MAX)
        };
        let z_front = if focus.is_nan() {
            0.0
        } else if focus.is_infinite() {
            if focus > 0.0 {
                f32::MAX
            } else {
                f32::MIN
            }
        } else {
            f32_from(focus, false)
        };
        let b_background = signed_coc_px(&lens, f64::INFINITY, focus, ds, ppmm);
        let delta = if pass.delta.is_finite() {
            pass.delta.max(0.0)
        } else {
            DELTA
        };
        let hidden = pass.hidden;
        let hl = pass.highlights;
        let lap_threshold = pass.laplacian_threshold;

        let device = frame.device();
        // colour.wgsl's three tables and pixels, and six of the pass's own.
        let needed = 9;
        let limit = device.limits().max_storage_buffers_per_shader_stage;
        if limit < needed {
            return Err(GpuError::Device(format!(
                "depth of field by splatting binds {needed} storage buffers; this device allows {limit} per shader stage"
            )));
        }
        let st = &mut *self.state;
        let (kernels, kn) = st.kernels.get_or_insert_with(|| {
            let kernels = Kernels::new(
                device,
                frame.traffic(),
                "splat.wgsl",
                include_str!("splat.wgsl"),
                &[
                    "splat_visible",
                    "splat_hidden",
                    "splat_scatter",
                    "splat_compose",
                ],
                &[true, true, false, false, false, false],
                PARAMS_BYTES,
            );
            let kn = frame.traffic().buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("splat k_n table"),
                    contents: bytemuck::cast_slice(kn_table()),
                    usage: wgpu::BufferUsages::STORAGE,
                },
            );
            (kernels, kn)
        });
        let n = u64::from(w) * u64::from(h);
        let stale = st.buffers.as_ref().is_none_or(|b| {
            b.size != (w, h) || b.frame.0 != *frame.pixels() || b.frame.1 != *frame.depth()
        });
        if stale {
            st.buffers = None;
            let none = wgpu::BufferUsages::empty();
            let work = frame.storage_buffer("the splat samples (V and H)", 32 * n, none)?;
            let want = frame.storage_buffer("the splat hidden-sample flags", 4 * n, none)?;
            let hidden = frame.storage_buffer("the hidden image", 16 * n, none)?;
            let acc = frame.storage_buffer(
                "the splat layers (fixed-point sums)",
                4 * (WORDS * n + 1),
                wgpu::BufferUsages::COPY_DST,
            )?;
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("splat params"),
                size: super::SLOT,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group = kernels.bind(
                device,
                &params,
                PARAMS_BYTES,
                frame.pixels(),
                &[frame.depth(), kn, &work, &want, &hidden, &acc],
            );
            st.buffers = Some(Buffers {
                size: (w, h),
                frame: (frame.pixels().clone(), frame.depth().clone()),
                params,
                group,
                want,
                hidden,
                acc,
                _work: work,
            });
        }
        let Some(b) = st.buffers.as_ref() else {
            return Ok(encoder);
        };
        let mut words = Words::default();
        words
            .u(w)
            .u(h)
            .u(u32::from(hidden))
            .u(u32::from(hl.is_some()));
        words
            .f(k as f32)
            .f(focus_hi)
            .f(focus_lo)
            .u(u32::from(finite));
        words.f(b_background).f(z_in_front).f(z_behind).f(z_front);
        words
            .f(nearest as f32)
            .f(delta)
            .f(lap_threshold)
            .f(MAX_COC_PX);
        let hl = hl.unwrap_or_default();
        words
            .f(hl.threshold)
            .f(hl.exponent)
            .f(hl.gain)
            .f(COC_STEPS_PER_PX);
        for c in self.background {
            words.f(c.clamp(0.0, 1.0));
        }
        words.f(0.0);
        for [u, v] in spiral() {
            words.f(*u).f(*v);
        }
        words.pad_to(PARAMS_BYTES as usize);
        frame.write_buffer(&b.params, 0, &words.0);
        encoder.clear_buffer(&b.acc, 0, None);
        let p = &kernels.pipelines;
        dispatch(
            &mut encoder,
            frame.traffic(),
            &p[VISIBLE],
            &b.group,
            0,
            (w, h),
        );
        if hidden {
            frame.cast_hidden(&mut encoder, &b.want, &b.hidden)?;
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[HIDDEN],
                &b.group,
                0,
                (w, h),
            );
        }
        dispatch(
            &mut encoder,
            frame.traffic(),
            &p[SCATTER],
            &b.group,
            0,
            (w, h),
        );
        dispatch(
            &mut encoder,
            frame.traffic(),
            &p[COMPOSE],
            &b.group,
            0,
            (w, h),
        );
        Ok(encoder)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_focus_thresholds_are_exact() {
        for v in [540.0, 812.3, 0.1, 1e-3, 2100.000001, -3.5] {
            let above = f32_from(v, false);
            assert!(
                f64::from(above) > v && f64::from(-next_up(-above)) <= v,
                "{v}"
            );
            let at = f32_from(v, true);
            assert!(f64::from(at) >= v && f64::from(-next_up(-at)) < v, "{v}");
        }
        assert_eq!(f32_from(540.0, true), 540.0);
        assert_eq!(f32_from(f64::NAN, true), f32::MAX);
    }
}
