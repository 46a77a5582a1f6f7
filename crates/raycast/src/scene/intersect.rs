//! Ray queries on a scene: the closest hit along a ray, through the BVH
//! (or the seed's uniform grid).

use glam::Vec3;

use super::{Accel, Scene};
use crate::ray::{moller_trumbore, watertight, Ray, TriangleTest, WatertightRay};

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter (1 = the screen plane for camera rays).
    pub t: f32,
    pub object: u32,
    pub triangle: u32,
    /// Interpolated shading normal, unit length.
    pub normal: Vec3,
}

impl Scene {
    /// Closest hit along `ray` with `t` in `(t_min, ∞)`.
    pub fn intersect(&self, ray: &Ray, t_min: f32, test: TriangleTest) -> Option<Hit> {
        if self.triangles.is_empty() {
            return None;
        }
        // Set up the watertight ray only once a triangle is reached: most
        // rays of a sparse scene miss the root box.
        let mut wray: Option<WatertightRay> = None;
        let mut best: Option<(u32, f32, f32, f32)> = None;
        let mut test_one = |i: u32, t_max: f32| -> Option<f32> {
            let tri = &self.triangles[i as usize];
            let h = match test {
                TriangleTest::Watertight => {
                    let w = wray.get_or_insert_with(|| WatertightRay::new(ray));
                    watertight(w, tri.p[0], tri.p[1], tri.p[2], t_min, t_max)
                }
                TriangleTest::MollerTrumbore => {
                    moller_trumbore(ray, tri.p[0], tri.p[1], tri.p[2], t_min, t_max)
                }
            }?;
            best = Some((i, h.t, h.u, h.v));
            Some(h.t)
        };
        match (self.accel, &self.grid) {
            (Accel::Grid, Some(grid)) => {
                let mut closest = f32::INFINITY;
                grid.traverse(ray, |tris, cell_exit| {
                    for &i in tris {
                        if let Some(t) = test_one(i, closest) {
                            closest = t;
                        }
                    }
                    closest <= cell_exit
                });
            }
            _ => {
                let leaf = |first: u32, count: u32, mut t_max: f32| {
                    for i in first..first + count {
                        if let Some(t) = test_one(i, t_max) {
                            t_max = t;
                        }
                    }
                    t_max
                };
                if ray.is_parallel() {
                    // A zero direction component needs the exact slab test.
                    self.bvh.traverse(ray, f32::INFINITY, leaf);
                } else {
                    self.bvh4.traverse(ray, f32::INFINITY, leaf);
                }
            }
        }
        best.map(|(i, t, u, v)| {
            let tri = &self.triangles[i as usize];
            let n = tri.n[0] * (1.0 - u - v) + tri.n[1] * u + tri.n[2] * v;
            let face = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
            let normal = n
                .try_normalize()
                .or_else(|| face.try_normalize())
                .unwrap_or(Vec3::Z);
            Hit {
                t,
                object: tri.object,
                triangle: i,
                normal,
            }
        })
    }
}
