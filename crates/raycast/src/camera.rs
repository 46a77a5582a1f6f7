//! The camera is the person's eye looking through the physical display: an
//! off-axis frustum from the eye position through the display's rectangle,
//! so one pixel subtends exactly what the foveation maths assumes.

use foveation::ScreenGeometry;
use glam::Vec3;

use crate::ray::Ray;

#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// Eye position in world mm (screen centre = origin, z towards the viewer).
    pub eye: Vec3,
    pub width_px: u32,
    pub height_px: u32,
    pitch_x: f32,
    pitch_y: f32,
    /// Where this camera's pixel grid is centred on the screen (world mm
    /// from the screen's centre): zero for the display's own camera; a
    /// window of the screen sampled at its own resolution
    /// ([`Camera::window`]) is centred elsewhere.
    offset_mm: [f32; 2],
}

impl Camera {
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
            offset_mm: [0.0, 0.0],
        }
    }

    /// A camera for a window of this one's screen sampled every `step`
    /// pixels: its pixel (i, j) has its centre at this camera's screen
    /// position (x0 + (i + ½)·step, y0 + (j + ½)·step), and it is
    /// `width_px`×`height_px` pixels. The eye is the same; so is every
    /// ray's direction up to f32 rounding (the window's own rays are built
    /// from its centre). `step` must be finite and positive.
    pub fn window(&self, x0: f32, y0: f32, step: f32, width_px: u32, height_px: u32) -> Camera {
        let (w, h) = (self.width_px as f32, self.height_px as f32);
        let centre = [
            x0 + 0.5 * width_px as f32 * step,
            y0 + 0.5 * height_px as f32 * step,
        ];
        Camera {
            eye: self.eye,
            width_px,
            height_px,
            pitch_x: self.pitch_x * step,
            pitch_y: self.pitch_y * step,
            offset_mm: [
                self.offset_mm[0] + (centre[0] - w / 2.0) * self.pitch_x,
                self.offset_mm[1] + (h / 2.0 - centre[1]) * self.pitch_y,
            ],
        }
    }

    /// The window's centre on the screen, world mm from the screen's
    /// centre (zero for a display's own camera).
    pub fn offset_mm(&self) -> [f32; 2] {
        self.offset_mm
    }

    /// The world point of screen position `p` (pixels, origin top-left, y down).
    pub fn screen_point(&self, p: [f32; 2]) -> Vec3 {
        let x = (p[0] - self.width_px as f32 / 2.0) * self.pitch_x;
        let y = (self.height_px as f32 / 2.0 - p[1]) * self.pitch_y;
        // A zero offset adds nothing, not even a sign to a zero.
        let shift = |v: f32, o: f32| if o == 0.0 { v } else { v + o };
        Vec3::new(
            shift(x, self.offset_mm[0]),
            shift(y, self.offset_mm[1]),
            0.0,
        )
    }

    /// The ray from the eye through screen position `p`; `t = 1` at the screen.
    pub fn ray(&self, p: [f32; 2]) -> Ray {
        Ray::new(self.eye, self.screen_point(p) - self.eye)
    }

    /// Pixel pitch (mm) in x and y.
    pub fn pitch(&self) -> [f32; 2] {
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
        // The whole screen at step 1 is the camera itself, bit for bit.
        let same = cam.window(0.0, 0.0, 1.0, 1280, 1024);
        assert_eq!(same.offset_mm(), [0.0, 0.0]);
        for p in [[0.5, 0.5], [640.0, 512.0], [1279.5, 1023.5]] {
            let (a, b) = (cam.screen_point(p), same.screen_point(p));
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
    }
}
