//! Rays and the two ray/primitive tests everything else is built on.

use glam::{Vec3, Vec3A};

/// A ray `origin + t·dir`, with the reciprocal direction precomputed for the
/// slab test. `dir` need not be normalised.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Start of the ray (world mm).
    pub origin: Vec3,
    /// Direction; need not be unit length.
    pub dir: Vec3,
    /// 1/dir; ±∞ for a zero (or negative zero) component.
    pub inv_dir: Vec3A,
    origin_a: Vec3A,
    /// Some direction component is ±0: `Aabb::hit` takes its exact path.
    parallel: bool,
}

impl Ray {
    /// The ray from `origin` along `dir`, with its reciprocal direction.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        let parallel = dir.x == 0.0 || dir.y == 0.0 || dir.z == 0.0;
        Self {
            origin,
            dir,
            inv_dir: Vec3A::ONE / Vec3A::from(dir),
            origin_a: origin.into(),
            parallel,
        }
    }

    /// Some direction component is ±0.
    pub fn is_parallel(&self) -> bool {
        self.parallel
    }

    /// The point at parameter `t`: `origin + t·dir`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min +∞, max −∞): the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Whether the box holds no point (as [`Aabb::EMPTY`]).
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Surface area (0 for an empty box), the SAH's cost measure.
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.max - self.min;
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The box's centre.
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Slab test: the entry distance if the ray meets the box within
    /// `[0, t_max]`, boundary included.
    ///
    /// Correct for direction components that are zero or negative zero. A
    /// ray parallel to a pair of slabs meets the box only if its origin lies
    /// between them (boundary included); the seed's Algorithm 4.1, as
    /// printed, never rejects such a ray. Rays with a zero component take an
    /// exact per-axis path that tests the origin directly, so `0·∞ = NaN`
    /// never reaches a comparison; all other rays take a branch-free SIMD path.
    #[inline]
    pub fn hit(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let (lo, hi) = (Vec3A::from(self.min), Vec3A::from(self.max));
        if ray.parallel {
            return self.hit_parallel(ray, t_max);
        }
        let t1 = (lo - ray.origin_a) * ray.inv_dir;
        let t2 = (hi - ray.origin_a) * ray.inv_dir;
        let near = t1.min(t2).max_element().max(0.0);
        // Widen `far` by 2 ulps (Ize 2013), so rounding never rejects a
        // ray that grazes the box.
        let far = (t1.max(t2).min_element() * (1.0 + 2.0 * f32::EPSILON)).min(t_max);
        (near <= far).then_some(near)
    }

    #[cold]
    fn hit_parallel(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let mut t0 = 0.0f32;
        let mut t1 = t_max;
        for a in 0..3 {
            let (o, d, inv) = (ray.origin[a], ray.dir[a], ray.inv_dir[a]);
            if d == 0.0 {
                if o < self.min[a] || o > self.max[a] {
                    return None;
                }
                continue;
            }
            let (mut near, mut far) = ((self.min[a] - o) * inv, (self.max[a] - o) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            t0 = t0.max(near);
            t1 = t1.min(far * (1.0 + 2.0 * f32::EPSILON));
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }
}

/// Which ray/triangle test to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum TriangleTest {
    /// Woop, Benthin & Wald 2013: no ray slips between triangles sharing an edge.
    #[default]
    Watertight,
    /// Möller–Trumbore (Murphy 2007, Algorithm 4.2), for comparison.
    MollerTrumbore,
}

/// Ray data precomputed once per ray for the watertight test.
#[derive(Debug, Clone, Copy)]
pub struct WatertightRay {
    origin: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl WatertightRay {
    /// Woop et al. 2013, §3: permute the axes so the largest direction
    /// component is z, then shear the ray onto +z.
    pub fn new(ray: &Ray) -> Self {
        let a = ray.dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if ray.dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = ray.dir[kz];
        Self {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: ray.dir[kx] / dz,
            sy: ray.dir[ky] / dz,
            sz: 1.0 / dz,
        }
    }

    /// The permutation `[kx, ky, kz]`.
    pub fn axes(&self) -> [usize; 3] {
        [self.kx, self.ky, self.kz]
    }

    /// The ray's origin.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// The shear `[sx, sy, sz]`.
    pub fn shear(&self) -> [f32; 3] {
        [self.sx, self.sy, self.sz]
    }
}

/// A hit on one triangle: distance and barycentrics of vertices 1 and 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

/// The sheared edge functions `(u, v, w)` of triangle `p0 p1 p2` for
/// the ray, with the paper's double-precision fallback when one is exactly
/// 0, and the sheared z of each corner (Woop, Benthin & Wald 2013, §3):
/// the one arithmetic the watertight test and the raster's plane hit share.
#[inline]
fn sheared_edges(r: &WatertightRay, p0: Vec3, p1: Vec3, p2: Vec3) -> ([f32; 3], [f32; 3]) {
    let a = p0 - r.origin;
    let b = p1 - r.origin;
    let c = p2 - r.origin;
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    let ax = a[kx] - r.sx * a[kz];
    let ay = a[ky] - r.sy * a[kz];
    let bx = b[kx] - r.sx * b[kz];
    let by = b[ky] - r.sy * b[kz];
    let cx = c[kx] - r.sx * c[kz];
    let cy = c[ky] - r.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = (f64::from(cx) * f64::from(by) - f64::from(cy) * f64::from(bx)) as f32;
        v = (f64::from(ax) * f64::from(cy) - f64::from(ay) * f64::from(cx)) as f32;
        w = (f64::from(bx) * f64::from(ay) - f64::from(by) * f64::from(ax)) as f32;
    }
    ([u, v, w], [r.sz * a[kz], r.sz * b[kz], r.sz * c[kz]])
}

/// Where the ray meets the plane of `p0 p1 p2`: `(t, u, v)` with the
/// barycentrics `u`, `v` of corners 1 and 2, by [`watertight`]'s
/// arithmetic (bit for bit, the same function) without its inside test;
/// `None` when the ray runs along the plane or meets it behind the origin.
#[inline]
pub fn plane_hit(r: &WatertightRay, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
    let ([u, v, w], [az, bz, cz]) = sheared_edges(r, p0, p1, p2);
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    (t > 0.0 && t.is_finite()).then_some((t, v * inv, w * inv))
}

/// Watertight ray/triangle intersection (Woop, Benthin & Wald 2013), with
/// the paper's double-precision fallback when an edge function is exactly 0.
/// Edges are closed on both sides, so a ray through a shared edge or vertex
/// hits at least one of the triangles. Returns hits with `t_min < t < t_max`.
#[inline]
pub fn watertight(
    r: &WatertightRay,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<TriHit> {
    watertight_det(r, p0, p1, p2, t_min, t_max).map(|(h, _)| h)
}

/// [`watertight`] (the same arithmetic, bit for bit) that also returns the
/// hit's determinant `u + v + w`: the packet caster checks it to know that
/// the range test's products stayed in the normal range of `f32`.
#[inline(always)]
pub fn watertight_det(
    r: &WatertightRay,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(TriHit, f32)> {
    let ([u, v, w], [az, bz, cz]) = sheared_edges(r, p0, p1, p2);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None; // degenerate (zero-area in projection)
    }
    let t_scaled = u * az + v * bz + w * cz;
    // Compare t·det against the range without dividing (sign-aware).
    let (lo, hi) = if det > 0.0 {
        (t_min * det, t_max * det)
    } else {
        (t_max * det, t_min * det)
    };
    if !(t_scaled > lo && t_scaled < hi) {
        return None;
    }
    let inv = 1.0 / det;
    Some((
        TriHit {
            t: t_scaled * inv,
            u: v * inv,
            v: w * inv,
        },
        det,
    ))
}

/// Möller–Trumbore (Murphy 2007, Algorithm 4.2; Möller & Trumbore 1997).
#[inline]
pub fn moller_trumbore(
    ray: &Ray,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<TriHit> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < f32::MIN_POSITIVE {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - p0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(TriHit { t, u, v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_rays_are_rejected_outside_the_slab_and_kept_inside() {
        let b = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        // Parallel to the x slabs (dir.x = 0), origin outside in x: must miss.
        let outside = Ray::new(Vec3::new(2.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(b.hit(&outside, f32::INFINITY), None);
        let outside_neg = Ray::new(Vec3::new(2.0, 0.5, -1.0), Vec3::new(-0.0, 0.0, 1.0));
        assert_eq!(b.hit(&outside_neg, f32::INFINITY), None);
        // Inside the x slab, and exactly on its boundary plane: hit.
        let inside = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::new(0.0, -0.0, 1.0));
        assert_eq!(b.hit(&inside, f32::INFINITY), Some(1.0));
        let on_plane = Ray::new(Vec3::new(1.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(b.hit(&on_plane, f32::INFINITY), Some(1.0));
    }

    #[test]
    fn both_triangle_tests_agree_on_a_plain_hit() {
        let (p0, p1, p2) = (
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        let ray = Ray::new(Vec3::new(0.1, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let a = watertight(&WatertightRay::new(&ray), p0, p1, p2, 0.0, f32::INFINITY).unwrap();
        let b = moller_trumbore(&ray, p0, p1, p2, 0.0, f32::INFINITY).unwrap();
        assert!((a.t - 5.0).abs() < 1e-6 && (b.t - 5.0).abs() < 1e-6);
        assert!((a.u - b.u).abs() < 1e-6 && (a.v - b.v).abs() < 1e-6);
    }

    #[test]
    fn a_ray_through_a_shared_edge_hits_one_of_the_two_triangles() {
        let (a, b) = (Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let (l, r) = (Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0));
        let ray = Ray::new(Vec3::new(0.0, 0.3, 3.0), Vec3::new(0.0, 0.0, -1.0));
        let w = WatertightRay::new(&ray);
        let hits = [
            watertight(&w, a, b, l, 0.0, 10.0),
            watertight(&w, b, a, r, 0.0, 10.0),
        ];
        assert!(hits.iter().any(Option::is_some));
    }

    #[test]
    fn zero_area_triangles_never_hit() {
        let p = Vec3::new(0.0, 0.0, 0.0);
        let q = Vec3::new(1.0, 1.0, 0.0);
        let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(
            watertight(&WatertightRay::new(&ray), p, q, q * 2.0, 0.0, 10.0),
            None
        );
        assert_eq!(moller_trumbore(&ray, p, q, q * 2.0, 0.0, 10.0), None);
    }
}
