//! The POR box on the GPU (`por.wgsl`): the CPU's
//! [`draw_box`](crate::effects::por_overlay::draw_box) on the frame's
//! packed words, equal to it pixel for pixel (`tests/gpu_plan.rs`). One
//! dispatch over the box's bounding square clipped to the frame; a uniform
//! of 32 bytes per frame.

use raycast::gpu::wgpu;
use raycast::gpu::{GpuError, GpuFrame};

use super::{dispatch, Kernels, Words};
use crate::effects::por_overlay::PorOverlay;
use crate::effects::{GpuPass, Pass, PassInput};

/// Bytes of `PorParams` in `por.wgsl`.
const PARAMS_BYTES: u64 = 32;

/// Half-sizes the GPU pass takes (larger boxes, which no lab draws, run on
/// the CPU): every coordinate then fits the shader's i32.
pub(crate) const MAX_HALF_PX: i64 = 1 << 16;

/// The frame sizes the GPU pass takes (a side of at most 2^24 px).
const MAX_SIDE: u32 = 1 << 24;

pub(crate) struct GpuPor {
    pass: PorOverlay,
    kernels: Option<Kernels>,
    /// The params uniform, the pixels buffer the bind group was made for,
    /// and the bind group.
    buffers: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
}

impl GpuPor {
    /// The GPU twin of `pass`, for a half-size up to [`MAX_HALF_PX`].
    pub fn new(pass: PorOverlay) -> Option<Self> {
        (0..=MAX_HALF_PX).contains(&pass.half_px).then_some(Self {
            pass,
            kernels: None,
            buffers: None,
        })
    }
}

/// The box's bounding square (outline lines reach one pixel past the
/// half-size when it is 0) clipped to a `w`×`h` frame: first pixel, size,
/// and the rounded centre; `None` when nothing of it is on the frame or
/// the centre is not finite — the CPU's `draw_box` rule.
fn clipped_square(w: u32, h: u32, centre: [f64; 2], r: i64) -> Option<([u32; 4], [i64; 2])> {
    let reach = r as f64 + 2.0;
    let near = |c: f64, n: u32| c.is_finite() && c > -reach && c < f64::from(n) + reach;
    if !near(centre[0], w) || !near(centre[1], h) {
        return None;
    }
    let (cx, cy) = (centre[0].round() as i64, centre[1].round() as i64);
    let span = |c: i64, n: u32| {
        let lo = (c - r - 1).max(0);
        let hi = (c + r + 1).min(i64::from(n) - 1);
        (lo <= hi).then_some((lo as u32, (hi - lo + 1) as u32))
    };
    let (x0, bw) = span(cx, w)?;
    let (y0, bh) = span(cy, h)?;
    Some(([x0, y0, bw, bh], [cx, cy]))
}

impl GpuPass for GpuPor {
    fn reference(&self) -> &dyn Pass {
        &self.pass
    }

    fn has_buffers(&self) -> bool {
        self.buffers.is_some()
    }

    fn detail(&self) -> String {
        format!(
            "{}: one dispatch over its {} px square, a 32-byte uniform per frame",
            self.pass.name(),
            2 * self.pass.half_px + 3
        )
    }

    fn owns(&self) -> String {
        "a 32-byte uniform".into()
    }

    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
        input: &PassInput<'_>,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let (w, h) = (frame.width(), frame.height());
        if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
            return Ok(encoder);
        }
        let Some(([x0, y0, bw, bh], [cx, cy])) =
            clipped_square(w, h, input.gaze_px, self.pass.half_px)
        else {
            return Ok(encoder);
        };
        let device = frame.device();
        let kernels = self.kernels.get_or_insert_with(|| {
            Kernels::without_colour_tables(
                device,
                frame.traffic(),
                "por.wgsl",
                include_str!("por.wgsl"),
                &["por_box"],
                &[],
                PARAMS_BYTES,
            )
        });
        if self
            .buffers
            .as_ref()
            .is_none_or(|(_, pixels, _)| pixels != frame.pixels())
        {
            let params = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("POR box params"),
                size: super::SLOT,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let group = kernels.bind(device, &params, PARAMS_BYTES, frame.pixels(), &[]);
            self.buffers = Some((params, frame.pixels().clone(), group));
        }
        let Some((params, _, group)) = self.buffers.as_ref() else {
            return Ok(encoder);
        };
        // In range by construction: |cx| < w + r + 2 with w, r < 2^24.
        let (cx, cy, r) = (cx as i32, cy as i32, self.pass.half_px as i32);
        let mut words = Words::default();
        words.u(x0).u(y0).u(bw).u(bh).u(w);
        words.0.extend(cx.to_le_bytes());
        words.0.extend(cy.to_le_bytes());
        words.0.extend(r.to_le_bytes());
        frame.write_buffer(params, 0, &words.0);
        dispatch(
            &mut encoder,
            frame.traffic(),
            &kernels.pipelines[0],
            group,
            0,
            (bw, bh),
        );
        Ok(encoder)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_square_is_clipped_and_far_boxes_are_skipped() {
        assert_eq!(
            clipped_square(100, 80, [10.0, 10.0], 32),
            Some(([0, 0, 44, 44], [10, 10]))
        );
        assert_eq!(clipped_square(100, 80, [f64::NAN, 1.0], 32), None);
        assert_eq!(clipped_square(100, 80, [1e12, 1.0], 32), None);
        // Just off the frame, the box's edge still shows.
        assert_eq!(
            clipped_square(100, 80, [-33.0, 40.0], 32),
            Some(([0, 7, 1, 67], [-33, 40]))
        );
        assert!(GpuPor::new(PorOverlay { half_px: -1 }).is_none());
        assert!(GpuPor::new(PorOverlay {
            half_px: MAX_HALF_PX + 1
        })
        .is_none());
    }
}
