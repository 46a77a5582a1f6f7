//! A deterministic synthetic scene — coloured discs at different depths in
//! front of a sky and a floor — for tests, benchmarks and demos.

use crate::frame::{FrameView, ObjectInfo, BACKGROUND_ID, MAX_FRAME_PIXELS, MAX_FRAME_SIDE};

/// Id of the floor (importance 0, like Lee's floor and walls).
pub const FLOOR_ID: u32 = 10_000;

/// One disc of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// Object id (1, 2, …).
    pub id: u32,
    /// Centre, frame pixels.
    pub centre_px: [f32; 2],
    /// Radius, pixels.
    pub radius_px: f32,
    /// Screen velocity, px/s (bounces off the frame edges).
    pub velocity_px_per_s: [f32; 2],
    /// Eye distance, mm.
    pub depth_mm: f32,
    /// Colour.
    pub rgb: [u8; 3],
    /// Task importance.
    pub importance: f32,
}

/// A scene and its rendered buffers.
#[derive(Clone, Debug)]
pub struct SyntheticScene {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The discs.
    pub discs: Vec<Disc>,
    /// Whether the floor (bottom fifth, importance 0) is drawn.
    pub floor: bool,
    rgb: Vec<u8>,
    depth_mm: Vec<f32>,
    object: Vec<u32>,
}

/// SplitMix64: small, deterministic, no dependency.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// Seeded generator.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

impl SyntheticScene {
    /// `discs` random discs (ids 1 to `discs`) on a `width × height` frame,
    /// with a floor. `None` if the frame is empty or larger than the
    /// tracker accepts.
    pub fn new(width: u32, height: u32, discs: usize, seed: u64) -> Option<Self> {
        if width == 0
            || height == 0
            || width > MAX_FRAME_SIDE
            || height > MAX_FRAME_SIDE
            || u64::from(width) * u64::from(height) > MAX_FRAME_PIXELS
        {
            return None;
        }
        let mut rng = SplitMix64::new(seed);
        let short = width.min(height) as f32;
        let discs = (0..discs)
            .map(|i| Disc {
                id: i as u32 + 1,
                centre_px: [rng.range(0.0, width as f32), rng.range(0.0, height as f32)],
                radius_px: rng.range(0.02, 0.1) * short + 1.0,
                velocity_px_per_s: [rng.range(-200.0, 200.0), rng.range(-200.0, 200.0)],
                depth_mm: rng.range(1_000.0, 20_000.0),
                rgb: [
                    (rng.unit() * 255.0) as u8,
                    (rng.unit() * 255.0) as u8,
                    (rng.unit() * 255.0) as u8,
                ],
                importance: rng.range(0.5, 1.0),
            })
            .collect();
        let pixels = width as usize * height as usize;
        let mut scene = Self {
            width,
            height,
            discs,
            floor: true,
            rgb: vec![0; pixels * 3],
            depth_mm: vec![f32::INFINITY; pixels],
            object: vec![BACKGROUND_ID; pixels],
        };
        scene.render();
        Some(scene)
    }

    /// Re-renders the buffers from `discs` and `floor`.
    pub fn render(&mut self) {
        let (w, h) = (self.width as usize, self.height as usize);
        let floor_top = h - h / 5;
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if self.floor && y >= floor_top {
                    let checker = ((x / 32) + (y / 32)) % 2 == 0;
                    self.rgb[i * 3..i * 3 + 3].copy_from_slice(if checker {
                        &[90, 80, 70]
                    } else {
                        &[110, 100, 90]
                    });
                    self.depth_mm[i] = 2_000.0 + 30_000.0 * (h - y) as f32 / h as f32;
                    self.object[i] = FLOOR_ID;
                } else {
                    let sky = (150 + 80 * y / h.max(1)) as u8;
                    self.rgb[i * 3..i * 3 + 3].copy_from_slice(&[sky / 2, sky / 2 + 20, sky]);
                    self.depth_mm[i] = f32::INFINITY;
                    self.object[i] = BACKGROUND_ID;
                }
            }
        }
        let mut order: Vec<&Disc> = self.discs.iter().collect();
        order.sort_by(|a, b| b.depth_mm.total_cmp(&a.depth_mm));
        for d in order {
            let r = d.radius_px;
            let x_lo = (d.centre_px[0] - r).floor().max(0.0) as usize;
            let x_hi = ((d.centre_px[0] + r).ceil().max(0.0) as usize).min(w);
            let y_lo = (d.centre_px[1] - r).floor().max(0.0) as usize;
            let y_hi = ((d.centre_px[1] + r).ceil().max(0.0) as usize).min(h);
            for y in y_lo..y_hi {
                for x in x_lo..x_hi {
                    let dx = x as f32 + 0.5 - d.centre_px[0];
                    let dy = y as f32 + 0.5 - d.centre_px[1];
                    if dx * dx + dy * dy <= r * r {
                        let i = y * w + x;
                        self.rgb[i * 3..i * 3 + 3].copy_from_slice(&d.rgb);
                        self.depth_mm[i] = d.depth_mm;
                        self.object[i] = d.id;
                    }
                }
            }
        }
    }

    /// Moves the discs by `dt_s` (bouncing at the edges) and re-renders.
    pub fn advance(&mut self, dt_s: f32) {
        let size = [self.width as f32, self.height as f32];
        for d in &mut self.discs {
            for ((c, v), &limit) in d
                .centre_px
                .iter_mut()
                .zip(&mut d.velocity_px_per_s)
                .zip(&size)
            {
                *c += *v * dt_s;
                if *c < 0.0 || *c > limit {
                    *v = -*v;
                    *c = c.clamp(0.0, limit);
                }
            }
        }
        self.render();
    }

    /// The rendered frame.
    pub fn view(&self) -> FrameView<'_> {
        FrameView {
            width: self.width,
            height: self.height,
            rgb: &self.rgb,
            depth_mm: &self.depth_mm,
            object: &self.object,
        }
    }

    /// The object list: the discs (screen velocity reported as mm/s at 1 mm
    /// per pixel) and the floor.
    pub fn objects(&self) -> Vec<ObjectInfo> {
        let mut list: Vec<ObjectInfo> = self
            .discs
            .iter()
            .map(|d| ObjectInfo {
                id: d.id,
                importance: d.importance,
                motion_mm_per_s: [d.velocity_px_per_s[0], d.velocity_px_per_s[1], 0.0],
            })
            .collect();
        if self.floor {
            list.push(ObjectInfo::still(FLOOR_ID, 0.0));
        }
        list
    }
}
