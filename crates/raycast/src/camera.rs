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
        }
    }

    /// The world point of screen position `p` (pixels, origin top-left, y down).
    pub fn screen_point(&self, p: [f32; 2]) -> Vec3 {
        Vec3::new(
            (p[0] - self.width_px as f32 / 2.0) * self.pitch_x,
            (self.height_px as f32 / 2.0 - p[1]) * self.pitch_y,
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
