//! The full-resolution frame: one compute pass casts and shades one ray per
//! pixel and fills the G-buffer. The frame's params and output buffers are
//! shared with the foveated frame.

use std::time::Instant;

use super::buffers::{FrameTarget, Params};
use super::readback::{copy_out, read_frame};
use super::timer::begin_pass;
use super::{GpuError, GpuPost, GpuRenderer};
use crate::camera::Camera;
use crate::frame::Frame;
use crate::render::Stats;

/// The name of the full-resolution frame's one pass in
/// [`GpuRenderer::stage_ms`].
const CAST_AND_SHADE: &str = "cast and shade";

impl GpuRenderer {
    /// Makes sure `self.target` holds the output buffers for a frame of
    /// `pixels` pixels (made, or remade when the size changed), and returns
    /// them.
    pub(super) fn frame_target(&mut self, pixels: u32) -> Result<&FrameTarget, GpuError> {
        if self.target.as_ref().is_none_or(|t| t.pixels != pixels) {
            // Free the old buffers before making the new ones.
            self.target = None;
            self.target = Some(FrameTarget::new(
                &self.device,
                &self.layouts,
                &self.params,
                &self.scene,
                pixels,
                self.max_binding,
            )?);
        }
        self.target
            .as_ref()
            .ok_or_else(|| GpuError::Readback("no frame buffers".into()))
    }

    /// Writes the camera's `Params`; returns the number of pixels.
    pub(super) fn write_params(&self, cam: &Camera) -> Result<u32, GpuError> {
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = w.checked_mul(h).ok_or(GpuError::TooLarge {
            what: "the frame",
            bytes: u64::from(w) * u64::from(h) * 4,
            limit: self.max_binding,
        })?;
        let pitch = cam.display_pitch();
        let (step, shift) = cam.grid();
        let [r, g, b] = self.background_rgb8.map(u32::from);
        let params = Params {
            width: w,
            height: h,
            n_lights: self.scene.n_lights,
            n_triangles: self.scene.n_triangles,
            eye: [cam.eye.x, cam.eye.y, cam.eye.z, step],
            pitch: [pitch[0], pitch[1], shift[0], shift[1]],
            background: [
                self.background[0],
                self.background[1],
                self.background[2],
                0.0,
            ],
            background_rgb8: [r, g, b, 0],
        };
        self.traffic
            .write_buffer(&self.queue, &self.params, 0, bytemuck::bytes_of(&params));
        Ok(pixels)
    }

    /// Renders one full-resolution frame (one ray per pixel) and reads it back.
    pub fn render_full(&mut self, cam: &Camera) -> Result<(Frame, Stats), GpuError> {
        self.render_full_with(cam, None)
    }

    /// [`GpuRenderer::render_full`] with `post`'s passes encoded on the
    /// frame's buffers between the cast and the read-back.
    pub fn render_full_with(
        &mut self,
        cam: &Camera,
        post: Option<&mut dyn GpuPost>,
    ) -> Result<(Frame, Stats), GpuError> {
        let start = Instant::now();
        let traffic = self.traffic.clone();
        let before = traffic.total();
        let (w, h) = (cam.width_px, cam.height_px);
        let pixels = self.write_params(cam)?;
        let device = self.device.clone();
        let queue = self.queue.clone();
        let timer = self.timer.clone();
        let pipeline = self.pipelines.full.clone();
        let surface = self.surface;
        self.frame_target(pixels)?;
        let target = self
            .target
            .as_ref()
            .ok_or_else(|| GpuError::Readback("no frame buffers".into()))?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let mut pass = begin_pass(&mut encoder, timer.as_ref(), 0, CAST_AND_SHADE);
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &target.bind_group, &[]);
            traffic.dispatch(&mut pass, w.div_ceil(8), h.div_ceil(8), 1);
        }
        encoder = self.encode_post(target, post, (w, h), encoder)?;
        // Without a read-back the frame stays here for its presenter, and
        // nothing waits for the GPU.
        let read = self.read_back;
        let timer = timer.filter(|_| read);
        if read {
            copy_out(&mut encoder, &target.out, &target.readback, pixels);
        }
        if let Some(t) = &timer {
            t.resolve(&mut encoder, 1);
        }
        traffic.submit(&queue, encoder.finish());
        self.last_size = Some((w, h));
        let frame = if read {
            read_frame(&device, &traffic, &target.readback, w, h, surface)?
        } else {
            Frame::on_device(w, h)
        };
        self.stage_ms = match &timer {
            Some(t) => t.read(&device, &traffic, &[CAST_AND_SHADE])?,
            None => Vec::new(),
        };
        self.frame_traffic = traffic.total().since(before);
        let stats = Stats {
            rays_total: u64::from(pixels),
            rays_full: u64::from(pixels),
            time_ms: start.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        };
        Ok((frame, stats))
    }
}
