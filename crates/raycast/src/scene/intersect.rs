//! Ray queries on a scene: the closest hit along a ray, through the BVH
//! (or the seed's uniform grid).

use glam::Vec3;

use super::{Accel, Scene, WorldTriangle};
use crate::accel::bvh4::{lanes, PACKET};
use crate::ray::{
    moller_trumbore, watertight, watertight_det, Aabb, Ray, TriHit, TriangleTest, WatertightRay,
};

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter (1 = the screen plane for camera rays).
    pub t: f32,
    /// The object hit (its id).
    pub object: u32,
    /// The triangle hit (its index in the scene's BVH-ordered list).
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
        best.map(|(i, t, u, v)| self.hit_of(i, t, u, v))
    }

    /// What a single ray's walk of the 4-wide BVH costs
    /// ([`Scene::intersect`] with the watertight test): the interior
    /// nodes whose four boxes it tests and the triangles it tests. `None`
    /// for a ray with a zero direction component (it walks the binary
    /// BVH). For measuring the hierarchy's quality (`trace_rays`).
    pub fn traversal_steps(&self, ray: &Ray) -> Option<(u32, u32)> {
        if ray.is_parallel() {
            return None;
        }
        let w = WatertightRay::new(ray);
        let (mut nodes, mut tris) = (0u32, 0u32);
        self.bvh4.traverse_counting(
            ray,
            f32::INFINITY,
            || nodes += 1,
            |first, count, mut t_max| {
                for tri in &self.triangles[first as usize..(first + count) as usize] {
                    tris += 1;
                    if let Some(h) = watertight(&w, tri.p[0], tri.p[1], tri.p[2], 0.0, t_max) {
                        t_max = h.t;
                    }
                }
                t_max
            },
        );
        Some((nodes, tris))
    }

    /// The hit on triangle `i` at `t` with barycentrics `u`, `v`.
    #[inline]
    fn hit_of(&self, i: u32, t: f32, u: f32, v: f32) -> Hit {
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
    }

    /// Closest hits of a packet of rays, `out[i]` for `rays[i]` (up to the
    /// shorter of the two slices): each bit for bit what
    /// [`Scene::intersect`] returns for that ray alone — the same
    /// triangle, `t` and normal.
    ///
    /// Coherent rays (neighbouring pixels) share one traversal of the
    /// 4-wide BVH ([`Bvh4::traverse_packet`]) in groups of [`PACKET`].
    /// Single-ray traversal visits leaves in its own ray's order and keeps
    /// the first of two hits at the same distance; a packet's order is the
    /// packet's. So each lane here tracks its two nearest hits and keeps
    /// looking slightly past the nearest (a relative margin of 2⁻¹⁷):
    /// when the nearest is ahead of every other hit by more than 2⁻¹⁸ of
    /// its distance — far more than the rounding of the range tests — the
    /// single-ray traversal finds the same triangle in any order, and its
    /// `t`, `u`, `v` come from the same arithmetic. A lane whose two
    /// nearest hits are closer than that (a ray through a shared edge or
    /// vertex), whose figures leave the normal range of `f32` (distances
    /// or determinants beyond 2^±40 and 2^±60, extents such that the range
    /// test's products could overflow), or whose ray has a zero direction
    /// component, is traced again alone. The grid, Möller–Trumbore and a
    /// negative `t_min` take the single-ray path for every ray.
    ///
    /// The renderer casts full frames, fovea and refined pixels and the
    /// mask's vertex rays this way (issue 34). A node's four boxes are
    /// tested against all eight lanes at once, eight lanes per instruction
    /// where the processor has AVX2 (`Bvh4::traverse_packet`); with a
    /// lane-by-lane box test instead, packets were 2–10 % slower than
    /// single rays. A leaf's triangles are tested against the lanes that
    /// reach it eight at once too (`tri_lanes`, the same arithmetic per
    /// lane) when at least two do and all share the watertight test's axis
    /// permutation: about 1.4× faster on the room than lane by lane.
    ///
    /// [`Bvh4::traverse_packet`]: crate::accel::Bvh4::traverse_packet
    pub fn intersect_packet(
        &self,
        rays: &[Ray],
        t_min: f32,
        test: TriangleTest,
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len().min(out.len());
        for start in (0..n).step_by(PACKET) {
            let end = (start + PACKET).min(n);
            self.intersect_packet8(&rays[start..end], t_min, test, &mut out[start..end]);
        }
    }

    /// [`Scene::intersect_packet`] for at most [`PACKET`] rays.
    fn intersect_packet8(
        &self,
        rays: &[Ray],
        t_min: f32,
        test: TriangleTest,
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len().min(out.len()).min(PACKET);
        let bounds = match self.bvh4.bounds {
            Some(b) if !self.triangles.is_empty() => b,
            _ => {
                out[..n].fill(None);
                return;
            }
        };
        let packet = test == TriangleTest::Watertight
            && !(self.accel == Accel::Grid && self.grid.is_some())
            && t_min >= 0.0
            && t_min.is_finite();
        let mut active = 0u32;
        if packet {
            for (i, ray) in rays[..n].iter().enumerate() {
                if !ray.is_parallel() && well_conditioned(ray, &bounds) {
                    active |= 1 << i;
                }
            }
        }
        if active == 0 {
            for (o, r) in out[..n].iter_mut().zip(rays) {
                *o = self.intersect(r, t_min, test);
            }
            return;
        }
        let mut wray: [Option<WatertightRay>; PACKET] = [None; PACKET];
        // Per lane: the nearest hit (triangle, t, u, v), the second
        // nearest distance, and whether a figure left the safe range.
        let mut st = LaneState {
            best: [(u32::MAX, f32::INFINITY, 0.0f32, 0.0f32); PACKET],
            second: [f32::INFINITY; PACKET],
            unsafe_lanes: 0,
        };
        let mut t_max = [f32::INFINITY; PACKET];
        // Set up the watertight rays only once a leaf is reached (most
        // rays of a sparse scene miss the root box). Lanes whose rays
        // share one axis permutation (all of a row's camera rays, nearly
        // always) test a leaf's triangles eight lanes at once
        // (`leaf_packet`) when more than one of them reaches the leaf;
        // otherwise lane by lane.
        let mut shared: Option<Option<TriLanes>> = None;
        self.bvh4
            .traverse_packet(&rays[..n], active, &mut t_max, |first, count, m, t_max| {
                let tris = &self.triangles[first as usize..(first + count) as usize];
                let shared = shared.get_or_insert_with(|| {
                    for lane in lanes(active) {
                        wray[lane] = Some(WatertightRay::new(&rays[lane]));
                    }
                    TriLanes::new(&wray, active)
                });
                match shared {
                    Some(l) if m.count_ones() > 1 => {
                        leaf_packet(tris, first, l, &wray, t_min, m, t_max, &mut st)
                    }
                    _ => {
                        for (k, tri) in tris.iter().enumerate() {
                            for lane in lanes(m) {
                                let Some(w) = &wray[lane] else { continue };
                                let h = watertight_det(
                                    w,
                                    tri.p[0],
                                    tri.p[1],
                                    tri.p[2],
                                    t_min,
                                    t_max[lane],
                                );
                                if let Some((h, det)) = h {
                                    st.record(lane, first + k as u32, h, det, t_max);
                                }
                            }
                        }
                    }
                }
            });
        let LaneState {
            best,
            second,
            unsafe_lanes,
        } = st;
        for lane in 0..n {
            let (i, t, u, v) = best[lane];
            let exact = active & (1 << lane) != 0
                && unsafe_lanes & (1 << lane) == 0
                && (i == u32::MAX
                    || ((T_MIN..=T_MAX).contains(&t) && second[lane] > t * (1.0 + TIE)));
            out[lane] = if !exact {
                self.intersect(&rays[lane], t_min, test)
            } else if i == u32::MAX {
                None
            } else {
                Some(self.hit_of(i, t, u, v))
            };
        }
    }
}

/// How far past its nearest hit a packet lane keeps looking (relative).
const LOOK_PAST: f32 = 1.0 / 131_072.0;
/// Two hits closer than this (relative) are a tie: the lane is traced alone.
const TIE: f32 = 1.0 / 262_144.0;
/// The range of distances and determinants within which the range test's
/// products stay normal `f32` numbers (see [`Scene::intersect_packet`]).
const T_MIN: f32 = 1.0 / 1_099_511_627_776.0; // 2^-40
const T_MAX: f32 = 1_099_511_627_776.0; // 2^40
const DET_MIN: f32 = 1.0 / 1_152_921_504_606_846_976.0; // 2^-60
const DET_MAX: f32 = 1_152_921_504_606_846_976.0; // 2^60

/// Whether a ray's products in the watertight range test stay finite for
/// every triangle in `bounds`: with `R` the largest coordinate of the box
/// relative to the origin, a determinant is at most 24·R² and a hit's
/// distance at most R over the largest direction component.
fn well_conditioned(ray: &Ray, bounds: &Aabb) -> bool {
    let lo = (bounds.min - ray.origin).abs().max_element();
    let hi = (bounds.max - ray.origin).abs().max_element();
    let r = lo.max(hi);
    let d = ray.dir.abs().max_element();
    let far = r * r * (r / d);
    (D_MIN..=D_MAX).contains(&d) && far.is_finite() && far < F_MAX
}

const D_MIN: f32 = 1.0 / 1_048_576.0; // 2^-20
const D_MAX: f32 = 1_073_741_824.0; // 2^30
const F_MAX: f32 = 1.267_650_6e30; // 2^100

/// A packet's nearest hits so far, per lane.
struct LaneState {
    /// (triangle, t, u, v) of the nearest hit; triangle `u32::MAX` if none.
    best: [(u32, f32, f32, f32); PACKET],
    /// The second nearest hit's distance.
    second: [f32; PACKET],
    /// Lanes a hit's figures took out of the safe range.
    unsafe_lanes: u32,
}

impl LaneState {
    /// Takes lane `lane`'s hit on triangle `i` (with determinant `det`)
    /// into account and lowers the lane's `t_max`.
    #[inline(always)]
    fn record(&mut self, lane: usize, i: u32, h: TriHit, det: f32, t_max: &mut [f32; PACKET]) {
        let a = det.abs();
        if !((DET_MIN..=DET_MAX).contains(&a) && h.t.is_finite()) {
            self.unsafe_lanes |= 1 << lane;
        }
        let b = &mut self.best[lane];
        if h.t < b.1 {
            self.second[lane] = b.1;
            *b = (i, h.t, h.u, h.v);
            t_max[lane] = h.t * (1.0 + LOOK_PAST);
        } else if h.t < self.second[lane] {
            self.second[lane] = h.t;
        }
    }
}

/// The watertight test's per-ray figures for eight lanes whose rays share
/// one axis permutation `kx`, `ky`, `kz`: origin and shear per lane,
/// structure of arrays (each lane's figures exactly its
/// [`WatertightRay`]'s).
struct TriLanes {
    k: [usize; 3],
    o: [[f32; PACKET]; 3],
    s: [[f32; PACKET]; 3],
}

impl TriLanes {
    /// `None` unless every active lane's ray has the same permutation.
    fn new(wray: &[Option<WatertightRay>; PACKET], active: u32) -> Option<Self> {
        let mut out: Option<Self> = None;
        for lane in lanes(active) {
            let w = wray[lane].as_ref()?;
            let k = w.axes();
            let l = out.get_or_insert(Self {
                k,
                o: [[0.0; PACKET]; 3],
                s: [[0.0; PACKET]; 3],
            });
            if l.k != k {
                return None;
            }
            let (o, s) = (w.origin(), w.shear());
            for a in 0..3 {
                // Permuted: o[0] is the origin's kx, o[1] its ky, o[2] its kz.
                l.o[a][lane] = o[k[a]];
                l.s[a][lane] = s[a];
            }
        }
        out
    }
}

/// A leaf's triangles against the lanes set in `m`, eight lanes at once
/// ([`leaf_lanes`], with AVX2 where the processor has it); the rare lane
/// whose edge function is exactly 0 (the double-precision fallback) is
/// tested alone by [`watertight_det`].
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn leaf_packet(
    tris: &[WorldTriangle],
    first: u32,
    l: &TriLanes,
    wray: &[Option<WatertightRay>; PACKET],
    t_min: f32,
    m: u32,
    t_max: &mut [f32; PACKET],
    st: &mut LaneState,
) {
    for (k, tri) in tris.iter().enumerate() {
        let r = tri_lanes(tri, l, t_min, t_max);
        let i = first + k as u32;
        for lane in lanes(r.redo & m) {
            let Some(w) = &wray[lane] else { continue };
            if let Some((h, det)) =
                watertight_det(w, tri.p[0], tri.p[1], tri.p[2], t_min, t_max[lane])
            {
                st.record(lane, i, h, det, t_max);
            }
        }
        for lane in lanes(r.hit & !r.redo & m) {
            let h = TriHit {
                t: r.t[lane],
                u: r.u[lane],
                v: r.v[lane],
            };
            st.record(lane, i, h, r.det[lane], t_max);
        }
    }
}

/// One triangle against eight lanes ([`tri_lanes`]).
struct LaneHits {
    /// Lanes that hit within their range (valid where `redo` is clear).
    hit: u32,
    /// Lanes with an edge function exactly 0: test alone.
    redo: u32,
    t: [f32; PACKET],
    u: [f32; PACKET],
    v: [f32; PACKET],
    det: [f32; PACKET],
}

/// [`watertight_det`] for one triangle and eight lanes, per lane the same
/// arithmetic in the same order (so the same bits), written lane-wise so
/// the compiler vectorises across the lanes; a lane with an edge function
/// exactly 0 is flagged in `redo` instead of taking the double-precision
/// fallback.
#[inline(always)]
fn tri_lanes_generic(
    tri: &WorldTriangle,
    l: &TriLanes,
    t_min: f32,
    t_max: &[f32; PACKET],
) -> LaneHits {
    let [kx, ky, kz] = l.k;
    let p = &tri.p;
    let (p0x, p0y, p0z) = (p[0][kx], p[0][ky], p[0][kz]);
    let (p1x, p1y, p1z) = (p[1][kx], p[1][ky], p[1][kz]);
    let (p2x, p2y, p2z) = (p[2][kx], p[2][ky], p[2][kz]);
    let mut out = LaneHits {
        hit: 0,
        redo: 0,
        t: [0.0; PACKET],
        u: [0.0; PACKET],
        v: [0.0; PACKET],
        det: [0.0; PACKET],
    };
    let mut hit = [false; PACKET];
    let mut redo = [false; PACKET];
    for i in 0..PACKET {
        let (ox, oy, oz) = (l.o[0][i], l.o[1][i], l.o[2][i]);
        let (sx, sy, sz) = (l.s[0][i], l.s[1][i], l.s[2][i]);
        let (akx, aky, akz) = (p0x - ox, p0y - oy, p0z - oz);
        let (bkx, bky, bkz) = (p1x - ox, p1y - oy, p1z - oz);
        let (ckx, cky, ckz) = (p2x - ox, p2y - oy, p2z - oz);
        let ax = akx - sx * akz;
        let ay = aky - sy * akz;
        let bx = bkx - sx * bkz;
        let by = bky - sy * bkz;
        let cx = ckx - sx * ckz;
        let cy = cky - sy * ckz;
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        redo[i] = (u == 0.0) | (v == 0.0) | (w == 0.0);
        let outside = ((u < 0.0) | (v < 0.0) | (w < 0.0)) & ((u > 0.0) | (v > 0.0) | (w > 0.0));
        let det = u + v + w;
        let t_scaled = u * (sz * akz) + v * (sz * bkz) + w * (sz * ckz);
        let pos = det > 0.0;
        let lo = if pos { t_min * det } else { t_max[i] * det };
        let hi = if pos { t_max[i] * det } else { t_min * det };
        let inside = (t_scaled > lo) & (t_scaled < hi);
        hit[i] = !outside & (det != 0.0) & inside;
        let inv = 1.0 / det;
        out.t[i] = t_scaled * inv;
        out.u[i] = v * inv;
        out.v[i] = w * inv;
        out.det[i] = det;
    }
    for i in 0..PACKET {
        out.hit |= u32::from(hit[i]) << i;
        out.redo |= u32::from(redo[i]) << i;
    }
    out
}

/// [`tri_lanes_generic`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tri_lanes_avx2(
    tri: &WorldTriangle,
    l: &TriLanes,
    t_min: f32,
    t_max: &[f32; PACKET],
) -> LaneHits {
    tri_lanes_generic(tri, l, t_min, t_max)
}

/// [`tri_lanes_generic`], with AVX2 where the processor has it.
#[inline(always)]
fn tri_lanes(tri: &WorldTriangle, l: &TriLanes, t_min: f32, t_max: &[f32; PACKET]) -> LaneHits {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above), the only
        // requirement of a `target_feature(enable = "avx2")` function.
        return unsafe { tri_lanes_avx2(tri, l, t_min, t_max) };
    }
    tri_lanes_generic(tri, l, t_min, t_max)
}
