//! The G-buffer one frame fills (DESIGN.md, "One frame"): colour, hit,
//! depth (eye distance in mm), object id, shading normal and the layer that
//! produced each pixel. A rendering method fills it; effects read and write
//! it afterwards; CPU and GPU backends fill it identically.

use glam::Vec3;

/// [`Frame::object`] of a pixel whose sample hit nothing (the background).
pub const NO_OBJECT: u32 = u32::MAX;

/// Which path produced a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Layer {
    /// Cast in full-resolution mode.
    Full = 0,
    Fovea = 1,
    Interpolated = 2,
    Refined = 3,
    /// No owner found (numerically impossible in a correct mesh): cast.
    Gap = 4,
}

/// A rendered frame: one value per pixel in each buffer, row-major from the
/// top-left corner.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub width_px: u32,
    pub height_px: u32,
    /// 8-bit sRGB-encoded colour, three bytes a pixel.
    pub rgb: Vec<u8>,
    /// Did the (cast or reconstructed) sample hit geometry? Always
    /// `object[i] != NO_OBJECT`.
    pub hit: Vec<bool>,
    /// Distance from the eye to the visible surface in mm (world units);
    /// `f32::INFINITY` for the background.
    pub depth_mm: Vec<f32>,
    /// Index of the visible object in the scene's object list, or
    /// [`NO_OBJECT`].
    pub object: Vec<u32>,
    /// Unit shading normal of the visible surface (world space); zero for
    /// the background.
    pub normal: Vec<[f32; 3]>,
    pub layer: Vec<Layer>,
}

impl Frame {
    /// A frame of `width_px` × `height_px` background pixels of colour
    /// `background_rgb8`, every one in layer `layer`.
    pub fn blank(width_px: u32, height_px: u32, background_rgb8: [u8; 3], layer: Layer) -> Self {
        let n = width_px as usize * height_px as usize;
        Self {
            width_px,
            height_px,
            rgb: background_rgb8.repeat(n),
            hit: vec![false; n],
            depth_mm: vec![f32::INFINITY; n],
            object: vec![NO_OBJECT; n],
            normal: vec![[0.0; 3]; n],
            layer: vec![layer; n],
        }
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.hit.len()
    }

    /// True for a frame of zero pixels.
    pub fn is_empty(&self) -> bool {
        self.hit.is_empty()
    }

    /// Rows of every buffer, for filling in parallel.
    pub(crate) fn rows_mut(&mut self) -> Vec<RowMut<'_>> {
        let w = self.width_px as usize;
        if w == 0 {
            return Vec::new();
        }
        self.rgb
            .chunks_mut(3 * w)
            .zip(self.hit.chunks_mut(w))
            .zip(self.depth_mm.chunks_mut(w))
            .zip(self.object.chunks_mut(w))
            .zip(self.normal.chunks_mut(w))
            .zip(self.layer.chunks_mut(w))
            .map(
                |(((((rgb, hit), depth_mm), object), normal), layer)| RowMut {
                    rgb,
                    hit,
                    depth_mm,
                    object,
                    normal,
                    layer,
                },
            )
            .collect()
    }
}

/// One row of a [`Frame`]'s buffers.
pub(crate) struct RowMut<'a> {
    pub rgb: &'a mut [u8],
    pub hit: &'a mut [bool],
    pub depth_mm: &'a mut [f32],
    pub object: &'a mut [u32],
    pub normal: &'a mut [[f32; 3]],
    pub layer: &'a mut [Layer],
}

/// What one pixel's sample saw.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Texel {
    pub rgb: [u8; 3],
    /// Eye distance (mm), object and normal of the visible surface.
    pub surface: Option<(f32, u32, Vec3)>,
    pub layer: Layer,
}

impl RowMut<'_> {
    #[inline]
    pub fn put(&mut self, x: usize, t: Texel) {
        self.rgb[3 * x..3 * x + 3].copy_from_slice(&t.rgb);
        self.layer[x] = t.layer;
        match t.surface {
            Some((d, o, n)) => {
                self.hit[x] = true;
                self.depth_mm[x] = d;
                self.object[x] = o;
                self.normal[x] = n.to_array();
            }
            None => {
                self.hit[x] = false;
                self.depth_mm[x] = f32::INFINITY;
                self.object[x] = NO_OBJECT;
                self.normal[x] = [0.0; 3];
            }
        }
    }
}

/// The layers picture: the image blended with a colour per layer
/// (fovea red, interpolated green, refined blue, gaps magenta).
pub fn layers_rgb(frame: &Frame) -> Vec<u8> {
    let mut out = frame.rgb.clone();
    for (i, l) in frame.layer.iter().enumerate() {
        let tint: [u8; 3] = match l {
            Layer::Full => continue,
            Layer::Fovea => [230, 40, 40],
            Layer::Interpolated => [40, 200, 70],
            Layer::Refined => [40, 90, 240],
            Layer::Gap => [255, 0, 255],
        };
        for k in 0..3 {
            out[3 * i + k] = ((u16::from(out[3 * i + k]) + u16::from(tint[k])) / 2) as u8;
        }
    }
    out
}
