//! Hidden-surface layers, exact with rays: the first `K` surfaces along a
//! primary ray, not only the visible one (`K` ≤ [`MAX_LAYERS`]). Lee 2009
//! §5.1.2 renders a "hidden image" of the second-nearest surfaces with a
//! special fragment shader; a ray caster has them exactly, by continuing
//! past the first hit.
//!
//! - **One traversal** of the scene's acceleration structure collects the
//!   `K` nearest hits (the BVH's `t_max` is the `K`-th nearest distance
//!   found so far, so the traversal prunes as for a closest hit once `K`
//!   are known), with the same ray/triangle test and `t > 0` as a primary
//!   ray ([`Scene::intersect`]): hit 0 is the visible surface.
//! - **One surface, one hit**: a ray through an edge or vertex shared by
//!   triangles of a watertight mesh may hit several at the same point.
//!   Hits whose distances differ by at most [`SAME_SURFACE_REL`] (relative)
//!   count once; of these the nearer is kept, then the lower triangle
//!   index, so the result does not depend on the traversal order.
//! - **Shaded like a primary hit**: each hit is shaded by
//!   [`crate::shade::shade`] at its point of the eye ray, seen from the eye,
//!   with its interpolated normal, and its depth is the eye distance (mm),
//!   exactly as the renderer fills the G-buffer for a visible surface. The
//!   colour is linear and not clamped (the renderer clamps when it encodes).
//! - **Sizes**: `K` is checked (1 to [`MAX_LAYERS`]) before anything is
//!   cast; [`render_layers`] checks `width × height × K` against
//!   [`MAX_LAYER_SAMPLES`] before it allocates. A single pixel's layers
//!   live on the stack.

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::ray::{moller_trumbore, watertight, Ray, TriangleTest, WatertightRay};
use crate::scene::{Accel, Hit, Scene};
use crate::shade::shade;
use crate::NO_OBJECT;

/// Most hits one ray returns.
pub const MAX_LAYERS: usize = 4;

/// Two hits whose ray distances `t` differ by at most this fraction of the
/// larger are one surface (a shared edge or vertex hit twice). At the
/// screen's 540 mm this is about 5 µm: far below any modelled gap, and
/// 80 single-precision ulps of `t`.
pub const SAME_SURFACE_REL: f32 = 1e-5;

/// Most samples (`width × height × K`) [`render_layers`] allocates: 2^24,
/// 4096 × 1024 pixels of 4 layers (about 0.8 GB of [`LayerHit`]s).
pub const MAX_LAYER_SAMPLES: usize = 1 << 24;

/// Why layers could not be cast.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LayersError {
    /// The layer count asked for is 0 or above [`MAX_LAYERS`].
    #[error("layers per ray must be 1 to {MAX_LAYERS}, found {0}")]
    BadLayerCount(usize),
    /// The samples would exceed [`MAX_LAYER_SAMPLES`].
    #[error("{width} × {height} pixels × {layers} layers exceed {MAX_LAYER_SAMPLES} samples")]
    TooLarge {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Layers per pixel asked for.
        layers: usize,
    },
}

/// One surface along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerHit {
    /// The ray hit (`t` = 1 at the screen for camera rays).
    pub hit: Hit,
    /// Eye distance of the hit point, mm (the G-buffer's depth).
    pub depth_mm: f32,
    /// Linear colour, shaded as a primary hit (not clamped).
    pub colour: Vec3,
}

impl LayerHit {
    /// A placeholder for unused slots.
    const NONE: LayerHit = LayerHit {
        hit: Hit {
            t: f32::INFINITY,
            object: NO_OBJECT,
            triangle: u32::MAX,
            normal: Vec3::ZERO,
        },
        depth_mm: f32::INFINITY,
        colour: Vec3::ZERO,
    };
}

/// The first hits along one ray, nearest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layers {
    len: usize,
    asked: usize,
    hits: [LayerHit; MAX_LAYERS],
}

impl Layers {
    /// The hits, nearest first (at most the `K` asked for).
    pub fn as_slice(&self) -> &[LayerHit] {
        &self.hits[..self.len]
    }

    /// Number of hits.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the ray hit nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Fewer hits than asked for: the ray leaves the scene after the last
    /// one (it sees the background there). With `K` hits, more surfaces
    /// may lie beyond.
    pub fn exhausted(&self) -> bool {
        self.len < self.asked
    }
}

/// The `k` nearest hits along `ray` (distinct surfaces, `t > 0`), nearest
/// first, unshaded; an error for `k` outside 1..=[`MAX_LAYERS`].
pub fn nearest_hits(
    scene: &Scene,
    ray: &Ray,
    k: usize,
    test: TriangleTest,
) -> Result<([Hit; MAX_LAYERS], usize), LayersError> {
    if !(1..=MAX_LAYERS).contains(&k) {
        return Err(LayersError::BadLayerCount(k));
    }
    let mut set = Nearest::new(k);
    if scene.triangles.is_empty() {
        return Ok((set.hits(scene), 0));
    }
    let mut wray: Option<WatertightRay> = None;
    let mut test_one = |set: &mut Nearest, i: u32| {
        let tri = &scene.triangles[i as usize];
        let t_max = set.t_max();
        let h = match test {
            TriangleTest::Watertight => {
                let w = wray.get_or_insert_with(|| WatertightRay::new(ray));
                watertight(w, tri.p[0], tri.p[1], tri.p[2], 0.0, t_max)
            }
            TriangleTest::MollerTrumbore => {
                moller_trumbore(ray, tri.p[0], tri.p[1], tri.p[2], 0.0, t_max)
            }
        };
        if let Some(h) = h {
            set.offer(i, h.t, h.u, h.v);
        }
    };
    match (scene.accel, &scene.grid) {
        (Accel::Grid, Some(grid)) => grid.traverse(ray, |tris, cell_exit| {
            for &i in tris {
                test_one(&mut set, i);
            }
            // Go on while a nearer set could still be found beyond.
            set.t_max() > cell_exit
        }),
        _ => {
            let leaf = |first: u32, count: u32, _t_max: f32| {
                for i in first..first + count {
                    test_one(&mut set, i);
                }
                set.t_max()
            };
            if ray.is_parallel() {
                scene.bvh.traverse(ray, f32::INFINITY, leaf);
            } else {
                scene.bvh4.traverse(ray, f32::INFINITY, leaf);
            }
        }
    }
    let n = set.len;
    Ok((set.hits(scene), n))
}

/// The first `k` surfaces (1 to [`MAX_LAYERS`]) seen through the centre of
/// pixel (`x`, `y`) from `cam`'s eye, shaded and with their eye distances.
pub fn pixel_layers(
    scene: &Scene,
    cam: &Camera,
    x: u32,
    y: u32,
    k: usize,
    test: TriangleTest,
) -> Result<Layers, LayersError> {
    let p = [x as f32 + 0.5, y as f32 + 0.5];
    let dir = cam.screen_point(p) - cam.eye;
    let ray = Ray::new(cam.eye, dir);
    let (hits, n) = nearest_hits(scene, &ray, k, test)?;
    let length = dir.length();
    let mut out = Layers {
        len: n,
        asked: k,
        hits: [LayerHit::NONE; MAX_LAYERS],
    };
    for (slot, h) in out.hits.iter_mut().zip(&hits[..n]) {
        // The hit point as the renderer computes it (`render::colour_of`).
        let position = cam.eye + dir * h.t;
        *slot = LayerHit {
            hit: *h,
            depth_mm: h.t * length,
            colour: shade(scene, h.object, position, h.normal, cam.eye),
        };
    }
    Ok(out)
}

/// Every pixel's first `k` surfaces: row-major, `k` slots a pixel.
#[derive(Debug, Clone, Default)]
pub struct LayerFrame {
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// Slots per pixel.
    pub layers: usize,
    /// `width × height × layers` slots; pixel `i`'s hits are
    /// `hits[i·layers .. i·layers + count[i]]`.
    pub hits: Vec<LayerHit>,
    /// Hits found per pixel.
    pub count: Vec<u8>,
    /// Whether the pixel's ray left the scene after its last hit.
    pub exhausted: Vec<bool>,
}

impl LayerFrame {
    /// Pixel (`x`, `y`)'s hits, nearest first; empty off the frame.
    pub fn at(&self, x: u32, y: u32) -> &[LayerHit] {
        if x >= self.width_px || y >= self.height_px {
            return &[];
        }
        let i = y as usize * self.width_px as usize + x as usize;
        let start = i * self.layers;
        &self.hits[start..start + self.count[i] as usize]
    }
}

/// [`pixel_layers`] for every pixel of `cam`'s frame, in parallel; the
/// size is checked against [`MAX_LAYER_SAMPLES`] before allocating.
pub fn render_layers(
    scene: &Scene,
    cam: &Camera,
    k: usize,
    test: TriangleTest,
) -> Result<LayerFrame, LayersError> {
    if !(1..=MAX_LAYERS).contains(&k) {
        return Err(LayersError::BadLayerCount(k));
    }
    let (w, h) = (cam.width_px, cam.height_px);
    let too_large = LayersError::TooLarge {
        width: w,
        height: h,
        layers: k,
    };
    let pixels = (w as usize).checked_mul(h as usize).ok_or(too_large)?;
    let samples = pixels.checked_mul(k).ok_or(too_large)?;
    if samples > MAX_LAYER_SAMPLES {
        return Err(too_large);
    }
    let mut out = LayerFrame {
        width_px: w,
        height_px: h,
        layers: k,
        hits: vec![LayerHit::NONE; samples],
        count: vec![0; pixels],
        exhausted: vec![false; pixels],
    };
    if pixels == 0 {
        return Ok(out);
    }
    let row_slots = w as usize * k;
    out.hits
        .par_chunks_mut(row_slots)
        .zip(out.count.par_chunks_mut(w as usize))
        .zip(out.exhausted.par_chunks_mut(w as usize))
        .enumerate()
        .try_for_each(|(y, ((hits, count), exhausted))| {
            for x in 0..w as usize {
                let l = pixel_layers(scene, cam, x as u32, y as u32, k, test)?;
                hits[x * k..x * k + l.len()].copy_from_slice(l.as_slice());
                count[x] = l.len() as u8;
                exhausted[x] = l.exhausted();
            }
            Ok::<(), LayersError>(())
        })?;
    Ok(out)
}

/// The `k` nearest distinct hits offered so far, sorted by (t, triangle).
struct Nearest {
    k: usize,
    len: usize,
    /// (t, triangle, u, v)
    slots: [(f32, u32, f32, f32); MAX_LAYERS],
}

impl Nearest {
    fn new(k: usize) -> Self {
        Self {
            k: k.clamp(1, MAX_LAYERS),
            len: 0,
            slots: [(f32::INFINITY, u32::MAX, 0.0, 0.0); MAX_LAYERS],
        }
    }

    /// Farthest distance still worth testing: the `k`-th hit's once full.
    fn t_max(&self) -> f32 {
        if self.len == self.k {
            self.slots[self.k - 1].0
        } else {
            f32::INFINITY
        }
    }

    fn offer(&mut self, tri: u32, t: f32, u: f32, v: f32) {
        if t.is_nan() {
            return;
        }
        let key = |a: &(f32, u32, f32, f32)| (a.0, a.1);
        let better = |a: (f32, u32), b: (f32, u32)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
        let cand = (t, tri, u, v);
        // The same surface as a kept hit: keep the better of the two.
        if let Some(j) = (0..self.len).find(|&j| same_surface(self.slots[j].0, t)) {
            if better(key(&cand), key(&self.slots[j])) {
                self.slots[j] = cand;
                self.slots[..self.len]
                    .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            }
            return;
        }
        if self.len == self.k {
            if !better(key(&cand), key(&self.slots[self.k - 1])) {
                return;
            }
            self.len -= 1; // drop the farthest
        }
        let mut j = self.len;
        while j > 0 && better(key(&cand), key(&self.slots[j - 1])) {
            self.slots[j] = self.slots[j - 1];
            j -= 1;
        }
        self.slots[j] = cand;
        self.len += 1;
    }

    /// The kept hits with their interpolated normals, as `Scene::intersect`
    /// gives them.
    fn hits(&self, scene: &Scene) -> [Hit; MAX_LAYERS] {
        let mut out = [LayerHit::NONE.hit; MAX_LAYERS];
        for (o, &(t, i, u, v)) in out.iter_mut().zip(&self.slots[..self.len]) {
            let tri = &scene.triangles[i as usize];
            let n = tri.n[0] * (1.0 - u - v) + tri.n[1] * u + tri.n[2] * v;
            let face = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
            let normal = n
                .try_normalize()
                .or_else(|| face.try_normalize())
                .unwrap_or(Vec3::Z);
            *o = Hit {
                t,
                object: tri.object,
                triangle: i,
                normal,
            };
        }
        out
    }
}

/// Whether ray distances `a` and `b` are one surface ([`SAME_SURFACE_REL`]).
fn same_surface(a: f32, b: f32) -> bool {
    (a - b).abs() <= SAME_SURFACE_REL * a.abs().max(b.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_set_keeps_k_distinct_sorted_hits() {
        let mut s = Nearest::new(3);
        for (tri, t) in [
            (5, 4.0),
            (1, 2.0),
            (9, 2.0 + 1e-6),
            (2, 3.0),
            (3, 1.0),
            (4, 5.0),
        ] {
            s.offer(tri, t, 0.0, 0.0);
        }
        let kept: Vec<(f32, u32)> = s.slots[..s.len].iter().map(|a| (a.0, a.1)).collect();
        assert_eq!(kept, [(1.0, 3), (2.0, 1), (3.0, 2)]);
        assert_eq!(s.t_max(), 3.0);
        // A duplicate offered later at a nearer distance replaces the kept one.
        s.offer(7, 2.0 - 1e-6, 0.0, 0.0);
        assert_eq!(s.slots[1].1, 7);
        s.offer(8, f32::NAN, 0.0, 0.0);
        assert_eq!(s.len, 3);
    }
}
