//! The camera is the person's eye looking through the physical display: an
//! off-axis frustum from the eye position through the display's rectangle,
//! so one pixel subtends exactly what the foveation maths assumes.

use foveation::ScreenGeometry;
use glam::Vec3;

use crate::ray::Ray;

/// The eye looking through the physical display: makes the primary ray
/// of each pixel (an off-axis frustum through the screen rectangle).
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// Eye position in world mm (screen centre = origin, z towards the viewer).
    pub eye: Vec3,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// The display's pixel pitch, mm.
    pitch_x: f32,
    pitch_y: f32,
    /// Display pixels per pixel of this camera: 1 for the display's own
    /// camera, the layer's step for a window ([`Camera::window`]).
    step: f32,
    /// `x0 − W/2` and `H/2 − y0` in display pixels, for a grid whose first
    /// pixel starts at display pixel (x0, y0) of a W×H display: `(−W/2,
    /// H/2)` for the display's own camera. Screen point of this camera's
    /// position p: `((p.x·step + shift.x)·pitch_x, (shift.y − p.y·step)·pitch_y)`.
    shift: [f32; 2],
}

impl Camera {
    /// The display's own camera: one ray per display pixel, from the eye
    /// position of `g`.
    pub fn new(g: &ScreenGeometry) -> Self {
        let [w, h] = g.size_px();
        let eye = Vec3::new(
            ((g.eye_point_px[0] - w / 2.0) * g.pitch_x_mm) as f32,
            ((h / 2.0 - g.eye_point_px[1]) * g.pitch_y_mm) as f32,
            g.eye_distance_mm as f32,
        );
        Self {
            eye,
            width_px: g.width_px,
            height_px: g.height_px,
            pitch_x: g.pitch_x_mm as f32,
            pitch_y: g.pitch_y_mm as f32,
            step: 1.0,
            shift: [-(g.width_px as f32) / 2.0, g.height_px as f32 / 2.0],
        }
    }

    /// A camera for a window of this one's screen sampled every `step`
    /// pixels: its pixel (i, j) has its centre at this camera's screen
    /// position (x0 + (i + ½)·step, y0 + (j + ½)·step), and it is
    /// `width_px`×`height_px` pixels. The eye is the same, and so is every
    /// ray, bit for bit, where both cameras have a pixel centre (for whole
    /// `x0`, `y0` and `step` and a screen under 2^22 px a side: the screen
    /// positions are then exact in f32). `step` must be finite and positive.
    pub fn window(&self, x0: f32, y0: f32, step: f32, width_px: u32, height_px: u32) -> Camera {
        Camera {
            eye: self.eye,
            width_px,
            height_px,
            pitch_x: self.pitch_x,
            pitch_y: self.pitch_y,
            step: self.step * step,
            shift: [
                self.shift[0] + x0 * self.step,
                self.shift[1] - y0 * self.step,
            ],
        }
    }

    /// This camera's grid on the display: its step (display pixels per
    /// pixel) and shift (`x0 − W/2`, `H/2 − y0`, see the field), for the
    /// GPU core's uniforms.
    pub fn grid(&self) -> (f32, [f32; 2]) {
        (self.step, self.shift)
    }

    /// The world point of screen position `p` (pixels, origin top-left, y down).
    pub fn screen_point(&self, p: [f32; 2]) -> Vec3 {
        Vec3::new(
            (p[0] * self.step + self.shift[0]) * self.pitch_x,
            (self.shift[1] - p[1] * self.step) * self.pitch_y,
            0.0,
        )
    }

    /// The ray from the eye through screen position `p`; `t = 1` at the screen.
    pub fn ray(&self, p: [f32; 2]) -> Ray {
        Ray::new(self.eye, self.screen_point(p) - self.eye)
    }

    /// Pixel pitch (mm) in x and y of this camera's pixels (the display's,
    /// times the step for a window).
    pub fn pitch(&self) -> [f32; 2] {
        [self.pitch_x * self.step, self.pitch_y * self.step]
    }

    /// The display's pixel pitch (mm), whatever the camera's step.
    pub fn display_pitch(&self) -> [f32; 2] {
        [self.pitch_x, self.pitch_y]
    }

    /// The ray through the centre of pixel (x, y).
    pub fn pixel_ray(&self, x: u32, y: u32) -> Ray {
        self.ray([x as f32 + 0.5, y as f32 + 0.5])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn display() -> Camera {
        let d = foveation::Display {
            name: "17in".into(),
            resolution_px: (1280, 1024),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 600.0,
            eye_point_px: None,
        };
        Camera::new(&d.geometry().expect("geometry"))
    }

    #[test]
    fn a_window_samples_the_screen_points_it_says() {
        let cam = display();
        for (x0, y0, step, w, h) in [
            (0.0, 0.0, 1.0, 1280, 1024),
            (300.0, 200.0, 1.0, 64, 48),
            (0.0, 0.0, 4.0, 320, 256),
            (517.0, 33.0, 2.0, 100, 90),
            (-10.0, -6.0, 3.0, 7, 5),
        ] {
            let win = cam.window(x0, y0, step, w, h);
            for (i, j) in [(0, 0), (w - 1, h - 1), (w / 2, h / 3)] {
                let p = [x0 + (i as f32 + 0.5) * step, y0 + (j as f32 + 0.5) * step];
                let a = cam.screen_point(p);
                let b = win.screen_point([i as f32 + 0.5, j as f32 + 0.5]);
                assert!((a - b).length() < 1e-3, "{x0} {y0} {step}: {a} vs {b}");
            }
        }
        // At step 1 a window's rays are the display's, bit for bit.
        for (x0, y0) in [(0u32, 0u32), (300, 200), (1, 1023), (1279, 7)] {
            let win = cam.window(x0 as f32, y0 as f32, 1.0, 1, 1);
            let a = cam.pixel_ray(x0, y0);
            let b = win.pixel_ray(0, 0);
            assert_eq!(
                a.dir.to_array().map(f32::to_bits),
                b.dir.to_array().map(f32::to_bits)
            );
        }
        // The display's own camera: the old arithmetic, (p − W/2)·pitch.
        for p in [[0.5f32, 0.5], [640.0, 512.0], [1279.5, 1023.5]] {
            let x = (p[0] - 1280.0 / 2.0) * cam.pitch()[0];
            let y = (1024.0 / 2.0 - p[1]) * cam.pitch()[1];
            let got = cam.screen_point(p);
            assert_eq!(
                (got.x.to_bits(), got.y.to_bits()),
                (x.to_bits(), y.to_bits())
            );
        }
    }
}
