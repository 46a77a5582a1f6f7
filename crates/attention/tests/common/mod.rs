//! Frame building helpers shared by the integration tests.
#![allow(dead_code)]

use attention::{FrameView, BACKGROUND_ID};

/// An owned frame that tests paint into.
#[derive(Clone, Debug)]
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
    pub depth_mm: Vec<f32>,
    pub object: Vec<u32>,
}

impl Canvas {
    /// A background-only frame of one colour at infinite depth.
    pub fn new(width: u32, height: u32, rgb: [u8; 3]) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            rgb: rgb.iter().copied().cycle().take(n * 3).collect(),
            depth_mm: vec![f32::INFINITY; n],
            object: vec![BACKGROUND_ID; n],
        }
    }

    pub fn view(&self) -> FrameView<'_> {
        FrameView {
            width: self.width,
            height: self.height,
            rgb: &self.rgb,
            depth_mm: &self.depth_mm,
            object: &self.object,
        }
    }

    /// Paints pixels `[x0, x1) × [y0, y1)` (clipped), given as `[x0, y0, x1, y1]`.
    pub fn rect(&mut self, [x0, y0, x1, y1]: [u32; 4], id: u32, rgb: [u8; 3], depth_mm: f32) {
        for y in y0..y1.min(self.height) {
            for x in x0..x1.min(self.width) {
                self.set(x, y, id, rgb, depth_mm);
            }
        }
    }

    /// Paints a disc (pixel centres within the radius).
    pub fn disc(&mut self, cx: f32, cy: f32, r: f32, id: u32, rgb: [u8; 3], depth_mm: f32) {
        for y in 0..self.height {
            for x in 0..self.width {
                let (dx, dy) = (x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
                if dx * dx + dy * dy <= r * r {
                    self.set(x, y, id, rgb, depth_mm);
                }
            }
        }
    }

    pub fn set(&mut self, x: u32, y: u32, id: u32, rgb: [u8; 3], depth_mm: f32) {
        let i = (y * self.width + x) as usize;
        self.rgb[i * 3..i * 3 + 3].copy_from_slice(&rgb);
        self.depth_mm[i] = depth_mm;
        self.object[i] = id;
    }
}

/// Every value of a slice is finite and in `[lo, hi]`.
pub fn all_in(values: &[f32], lo: f32, hi: f32) -> bool {
    values.iter().all(|v| v.is_finite() && *v >= lo && *v <= hi)
}
