//! Depth of field on the GPU (`dof.wgsl`): level 0 with depth and σ, the
//! anisotropic pyramid, the circular blend, on the frame's pixel words and
//! depth. The focus and what needs f64 come from the CPU (see the module
//! notes of [`super`]).

use foveation::thin_lens::K_SIGMA;
use raycast::gpu::wgpu;
use raycast::gpu::{GpuError, GpuFrame};
use raycast::Camera;

use super::{dispatch, level_layout, CocUniforms, Kernels, Words, SLOT};
use crate::effects::depth_of_field::{
    circular_weights, coc_px, level_for_coc, pyramid_taps, screen_of, top_level, DepthOfField,
    ANISO_DELTA_PX, ATTENTION_MAP_SIZE, CIRCLE, FOCUS_WINDOW_PX, MAX_LEVELS, SIGMA_CAP_PX,
};
use crate::effects::{GpuPass, Pass, PassInput};
use raycast::scene::DofFocus;

/// Bytes of `Params` in `dof.wgsl`.
const PARAMS_BYTES: u64 = 112 + 16 * (MAX_LEVELS as u64 + 1);

/// Entry points, in the order of `Kernels::pipelines`.
const BASE: usize = 0;
const REDUCE: usize = 1;
const BLEND: usize = 2;
/// With foreground smoothing (`dof_foreground.wgsl`).
const FG_RHO: usize = 3;
const FG_LEVEL: usize = 4;

/// The buffers for one frame target.
struct Buffers {
    size: (u32, u32),
    /// The frame's buffers the bind group was made for.
    frame: (wgpu::Buffer, wgpu::Buffer),
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// The colour, depth and σ pyramids (the bind group holds them).
    _pyramid: [wgpu::Buffer; 3],
    /// Foreground smoothing's words (the highest level, ρ, the smoothed
    /// levels): made only for a pass that smooths.
    foreground: Option<wgpu::Buffer>,
    /// The uniform bytes `params` holds: a frame whose uniforms are the
    /// same (the same size, focus and lens) uploads nothing.
    written: Vec<u8>,
}

/// The GPU state of depth of field: the CPU pass (its lens, focus and
/// refocusing state; its own buffers stay empty), the shader and, after the
/// first frame, the pyramid buffers.
pub(crate) struct GpuDof {
    pub pass: DepthOfField,
    kernels: Option<Kernels>,
    buffers: Option<Buffers>,
}

/// One frame's depth of field, at its focal depth.
struct DofFrame<'a> {
    pub state: &'a mut GpuDof,
    pub camera: &'a Camera,
    /// The focal depth ([`super::frame_focus`]), mm.
    pub focus: f64,
}

impl GpuDof {
    pub fn new(pass: DepthOfField) -> Self {
        Self {
            pass,
            kernels: None,
            buffers: None,
        }
    }
}

impl GpuPass for GpuDof {
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
        if self.pass.smooth_foreground {
            "the colour, depth and σ pyramids and foreground smoothing's levels (GPU)".into()
        } else {
            "the colour, depth and σ pyramids (GPU)".into()
        }
    }

    fn detail(&self) -> String {
        let focus = match self.pass.focus {
            DofFocus::Gaze => format!(
                "median depth of the {FOCUS_WINDOW_PX}×{FOCUS_WINDOW_PX} window at the gaze, \
                 read back after the cast (one wait), refocus on the CPU"
            ),
            DofFocus::Fixed { depth_mm } => format!("fixed at {depth_mm} mm"),
            DofFocus::Vergence => format!(
                "the vergence depth, else the median depth of the \
                 {FOCUS_WINDOW_PX}×{FOCUS_WINDOW_PX} window at the gaze read back after the cast; \
                 refocus on the CPU"
            ),
            DofFocus::Attention => format!(
                "the attended object: Lee's attention model ({ATTENTION_MAP_SIZE}² maps) on the \
                 frame's colour, depth and ids on the GPU, per-object statistics read back (one \
                 wait), contexts, Kalman filter and ranking on the CPU; refocus on the CPU"
            ),
        };
        format!(
            "{} — focus {focus}; level 0 (colour, depth, σ) → anisotropic Gaussian pyramid → \
             {}9-point circular blend of two levels",
            self.pass.name(),
            if self.pass.smooth_foreground {
                "foreground smoothing (eqs. 4.10–4.11: ρ at the highest level, smoothed σ) → "
            } else {
                ""
            }
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
        DofFrame {
            state: self,
            camera: input.camera,
            focus,
        }
        .encode(frame, encoder)
    }
}

/// The f32 depths whose level is 0 under the CPU's f64 arithmetic: an
/// interval `[lo, hi]` (empty as `(f32::MAX, 0)`), found by bisection on
/// the bits of positive floats; the CoC is monotone on each side of the
/// focus.
fn sharp_interval(sharp: impl Fn(f32) -> bool, focus_mm: f64) -> (f32, f32) {
    const EMPTY: (f32, f32) = (f32::MAX, 0.0);
    let max = f32::MAX.to_bits();
    let seed = if focus_mm.is_finite() && focus_mm > 0.0 {
        (focus_mm as f32).min(f32::MAX).to_bits()
    } else {
        max
    };
    if !sharp(f32::from_bits(seed)) {
        return EMPTY;
    }
    // First sharp depth in [0, seed].
    let (mut a, mut b) = (0u32, seed);
    while a < b {
        let mid = a + (b - a) / 2;
        if sharp(f32::from_bits(mid)) {
            b = mid;
        } else {
            a = mid + 1;
        }
    }
    let lo = f32::from_bits(a);
    // Last sharp depth in [seed, max].
    let (mut a, mut b) = (seed, max);
    while a < b {
        let mid = a + (b - a).div_ceil(2);
        if sharp(f32::from_bits(mid)) {
            a = mid;
        } else {
            b = mid - 1;
        }
    }
    (lo, f32::from_bits(a))
}

/// The smallest f32 `t` with `f64(t) > v` (v finite).
fn f32_above(v: f64) -> f32 {
    let t = v as f32;
    if f64::from(t) > v {
        return t;
    }
    if t == 0.0 {
        return f32::from_bits(1);
    }
    if t > 0.0 {
        f32::from_bits(t.to_bits() + 1)
    } else {
        f32::from_bits(t.to_bits() - 1)
    }
}

impl DofFrame<'_> {
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let (w, h) = (frame.width(), frame.height());
        let focus = self.focus;
        let top = top_level(w as usize, h as usize);
        if top == 0 {
            return Ok(encoder); // every level is 0: nothing to blur
        }
        let lens = self.state.pass.lens;
        let (ds, ppmm) = screen_of(self.camera);
        let sharp =
            |d: f32| level_for_coc(coc_px(&lens, f64::from(d), focus, ds, ppmm), top as f64) <= 0.0;
        let (sharp_lo, sharp_hi) = sharp_interval(sharp, focus);
        // `coc_px`'s clamps, for the per-pixel CoC in f32.
        let CocUniforms {
            nearest,
            finite,
            k,
            focus_hi,
            focus_lo,
            ..
        } = CocUniforms::new(&lens, focus, ds, ppmm);
        let z_behind = if focus.is_finite() {
            f32_above(focus)
        } else {
            f32::MAX
        };
        let coc_background = coc_px(&lens, f64::INFINITY, focus, ds, ppmm) as f32;
        let taps = pyramid_taps();
        let (g, norm) = circular_weights();

        let device = frame.device();
        let st = &mut *self.state;
        // Pay per use: foreground smoothing's shader code, entry points
        // and buffer only for a pass that smooths.
        let smooth = st.pass.smooth_foreground;
        let kernels = st.kernels.get_or_insert_with(|| {
            let (source, entries, extra): (String, &[&str], &[bool]) = if smooth {
                (
                    [
                        include_str!("pyramid.wgsl"),
                        include_str!("dof.wgsl"),
                        include_str!("dof_foreground.wgsl"),
                    ]
                    .join("\n"),
                    &[
                        "dof_base",
                        "dof_reduce",
                        "dof_blend",
                        "dof_fg_rho",
                        "dof_fg_level",
                    ],
                    &[true, false, false, false, false],
                )
            } else {
                (
                    [
                        include_str!("pyramid.wgsl"),
                        include_str!("dof.wgsl"),
                        include_str!("dof_sharp_foreground.wgsl"),
                    ]
                    .join("\n"),
                    &["dof_base", "dof_reduce", "dof_blend"],
                    &[true, false, false, false],
                )
            };
            Kernels::new(
                device,
                frame.traffic(),
                "dof.wgsl",
                &source,
                entries,
                extra,
                PARAMS_BYTES,
            )
        });
        let (layout, texels) = level_layout(w, h, top + 1);
        let stale = st.buffers.as_ref().is_none_or(|b| {
            b.size != (w, h) || b.frame.0 != *frame.pixels() || b.frame.1 != *frame.depth()
        });
        if stale {
            st.buffers = None;
            let px = frame.storage_buffer(
                "the depth-of-field pyramid",
                16 * texels,
                wgpu::BufferUsages::empty(),
            )?;
            let z = frame.storage_buffer(
                "the depth-of-field depth mip",
                4 * texels,
                wgpu::BufferUsages::empty(),
            )?;
            let sg = frame.storage_buffer(
                "the depth-of-field blur mip",
                4 * texels,
                wgpu::BufferUsages::empty(),
            )?;
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("depth-of-field params"),
                size: SLOT * (MAX_LEVELS as u64 + 1),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            // The highest level, ρ at up to level 1's size, a level per
            // pixel.
            let foreground = if smooth {
                let [_, w1, h1] = layout[1];
                let words = 1 + u64::from(w1) * u64::from(h1) + u64::from(w) * u64::from(h);
                Some(frame.storage_buffer(
                    "foreground smoothing's levels",
                    4 * words,
                    // Its first word is cleared every frame.
                    wgpu::BufferUsages::COPY_DST,
                )?)
            } else {
                None
            };
            let mut bound = vec![frame.depth(), &px, &z, &sg];
            bound.extend(foreground.as_ref());
            let group = kernels.bind(device, &params, PARAMS_BYTES, frame.pixels(), &bound);
            st.buffers = Some(Buffers {
                size: (w, h),
                frame: (frame.pixels().clone(), frame.depth().clone()),
                params,
                group,
                _pyramid: [px, z, sg],
                foreground,
                written: Vec::new(),
            });
        }
        let Some(b) = st.buffers.as_mut() else {
            return Ok(encoder);
        };
        let mut all = Vec::with_capacity(SLOT as usize * (MAX_LEVELS + 1));
        for src in 0..=MAX_LEVELS {
            let mut words = Words::default();
            words.u(w).u(h).u(top as u32 + 1).u(src as u32);
            words
                .f(k as f32)
                .f(focus_hi)
                .f(focus_lo)
                .u(u32::from(finite));
            words
                .f(coc_background)
                .f(sharp_lo)
                .f(sharp_hi)
                .u(u32::from(sharp(f32::INFINITY)));
            words
                .f(z_behind)
                .f(K_SIGMA as f32)
                .f(top as f32)
                .u(u32::from(st.pass.anisotropic));
            for t in taps {
                words.f(t);
            }
            words.f(g).f(norm).f(CIRCLE[4].0).f(ANISO_DELTA_PX);
            words.f(nearest as f32).f(SIGMA_CAP_PX).f(focus as f32).u(0);
            for l in 0..=MAX_LEVELS {
                let [off, lw, lh] = layout.get(l).copied().unwrap_or([0, 1, 1]);
                words.u(off).u(lw).u(lh).u(0);
            }
            words.pad_to(SLOT as usize);
            all.extend(words.0);
        }
        if b.written != all {
            frame.write_buffer(&b.params, 0, &all);
            b.written = all;
        }
        let p = &kernels.pipelines;
        if let Some(fg) = &b.foreground {
            // The highest level starts at 0 (f32 bits of 0.0).
            encoder.clear_buffer(fg, 0, Some(4));
        }
        dispatch(&mut encoder, frame.traffic(), &p[BASE], &b.group, 0, (w, h));
        for src in 0..top {
            let [_, tw, th] = layout[src + 1];
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[REDUCE],
                &b.group,
                src as u32,
                (tw, th),
            );
        }
        if b.foreground.is_some() {
            // ρ at the highest level needed (at most level 1's size), then
            // every pixel's smoothed level.
            let [_, w1, h1] = layout[1];
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[FG_RHO],
                &b.group,
                0,
                (w1, h1),
            );
            dispatch(
                &mut encoder,
                frame.traffic(),
                &p[FG_LEVEL],
                &b.group,
                0,
                (w, h),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sharp_interval_is_the_cpus_set() {
        let lens = foveation::thin_lens::EyeLens {
            focal_length_mm: 17.0,
            aperture_mm: 8.0,
            retina_distance_mm: 24.0,
        };
        for focus in [540.0, 812.3, f64::INFINITY] {
            let sharp =
                |d: f32| level_for_coc(coc_px(&lens, f64::from(d), focus, 540.0, 1.9), 6.0) <= 0.0;
            let (lo, hi) = sharp_interval(sharp, focus);
            assert!(lo <= hi, "{focus}");
            assert!(sharp(lo) && sharp(hi));
            assert!(!sharp(f32::from_bits(lo.to_bits() - 1)));
            if hi < f32::MAX {
                assert!(!sharp(f32::from_bits(hi.to_bits() + 1)));
            }
        }
        assert_eq!(f32_above(1.0), f32::from_bits(1.0f32.to_bits() + 1));
        assert!(f64::from(f32_above(0.1)) > 0.1);
    }
}
