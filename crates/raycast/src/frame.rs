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
    /// Cast one ray per pixel in the hybrid's fovea disc.
    Fovea = 1,
    /// Interpolated from the hybrid's mesh of vertex rays.
    Interpolated = 2,
    /// Cast because its cell was refined (a silhouette, crease or depth jump).
    Refined = 3,
    /// No owner found (numerically impossible in a correct mesh): cast.
    Gap = 4,
}

/// A rendered frame: one value per pixel in each buffer, row-major from the
/// top-left corner.
///
/// The *surface* buffers (`depth_mm`, `object`, `normal`) are filled only
/// when something asks for them (an effect pass that reads them, or a
/// caller that sets them up with [`Frame::blank`]`(…, true)`): otherwise
/// they are empty and cost nothing ([`Frame::has_surface`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// 8-bit sRGB-encoded colour, three bytes a pixel.
    pub rgb: Vec<u8>,
    /// Did the (cast or reconstructed) sample hit geometry?
    pub hit: Vec<bool>,
    /// Distance from the eye to the visible surface in mm (world units);
    /// `f32::INFINITY` for the background. Empty without surface buffers.
    pub depth_mm: Vec<f32>,
    /// Index of the visible object in the scene's object list, or
    /// [`NO_OBJECT`]; `object[i] != NO_OBJECT` exactly where `hit[i]`.
    /// Empty without surface buffers.
    pub object: Vec<u32>,
    /// Unit shading normal of the visible surface (world space); zero for
    /// the background. Empty without surface buffers.
    pub normal: Vec<[f32; 3]>,
    /// Which path produced each pixel.
    pub layer: Vec<Layer>,
}

impl Frame {
    /// A frame of `width_px` × `height_px` background pixels of colour
    /// `background_rgb8`, every one in layer `layer`, with the surface
    /// buffers when `surface` is set.
    pub fn blank(
        width_px: u32,
        height_px: u32,
        background_rgb8: [u8; 3],
        layer: Layer,
        surface: bool,
    ) -> Self {
        let n = width_px as usize * height_px as usize;
        let s = if surface { n } else { 0 };
        Self {
            width_px,
            height_px,
            rgb: background_rgb8.repeat(n),
            hit: vec![false; n],
            depth_mm: vec![f32::INFINITY; s],
            object: vec![NO_OBJECT; s],
            normal: vec![[0.0; 3]; s],
            layer: vec![layer; n],
        }
    }

    /// A frame of `width_px` × `height_px` pixels that stayed on the GPU
    /// (`GpuRenderer::set_read_back(false)`): its size and no pixels
    /// ([`Frame::len`] is 0, [`Frame::is_on_device`] is true).
    pub fn on_device(width_px: u32, height_px: u32) -> Self {
        Self {
            width_px,
            height_px,
            ..Self::default()
        }
    }

    /// Whether the frame's pixels stayed on the GPU ([`Frame::on_device`]):
    /// a size without pixels.
    pub fn is_on_device(&self) -> bool {
        self.rgb.is_empty() && self.width_px as u64 * self.height_px as u64 > 0
    }

    /// Gives the frame `width_px` × `height_px` pixels (with or without the
    /// surface buffers), reusing its allocations: a renderer that writes
    /// every pixel calls this instead of allocating a frame per frame. The
    /// pixel values are left as they were (new ones are background).
    pub fn reshape(&mut self, width_px: u32, height_px: u32, surface: bool) {
        let n = width_px as usize * height_px as usize;
        let s = if surface { n } else { 0 };
        self.width_px = width_px;
        self.height_px = height_px;
        self.rgb.resize(3 * n, 0);
        self.hit.resize(n, false);
        self.depth_mm.resize(s, f32::INFINITY);
        self.object.resize(s, NO_OBJECT);
        self.normal.resize(s, [0.0; 3]);
        self.layer.resize(n, Layer::Full);
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.hit.len()
    }

    /// True for a frame of zero pixels.
    pub fn is_empty(&self) -> bool {
        self.hit.is_empty()
    }

    /// Whether the surface buffers (depth, object id, normal) are filled.
    pub fn has_surface(&self) -> bool {
        self.depth_mm.len() == self.len()
            && self.object.len() == self.len()
            && self.normal.len() == self.len()
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
    pub hit: bool,
    /// Eye distance (mm), object and normal of the visible surface, when
    /// the frame has surface buffers and the sample hit.
    pub surface: Option<(f32, u32, Vec3)>,
    pub layer: Layer,
}

impl RowMut<'_> {
    /// Whether this row carries surface buffers.
    #[inline]
    pub fn has_surface(&self) -> bool {
        !self.depth_mm.is_empty()
    }

    #[inline]
    pub fn put(&mut self, x: usize, t: Texel) {
        self.rgb[3 * x..3 * x + 3].copy_from_slice(&t.rgb);
        self.layer[x] = t.layer;
        self.hit[x] = t.hit;
        if self.has_surface() {
            match t.surface {
                Some((d, o, n)) => {
                    self.depth_mm[x] = d;
                    self.object[x] = o;
                    self.normal[x] = n.to_array();
                }
                None => {
                    self.depth_mm[x] = f32::INFINITY;
                    self.object[x] = NO_OBJECT;
                    self.normal[x] = [0.0; 3];
                }
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
