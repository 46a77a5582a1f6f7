//! The CPU triangle rasteriser: the raster path of the model-based methods
//! (perceptual simplification, level of detail), which draw a *selected
//! subset* of a scene's triangles into the same G-buffer ([`Frame`]) the ray
//! caster fills.
//!
//! [`rasterize`] draws a list of [`WorldTriangle`]s seen from the camera's
//! eye through the display. Drawn over `scene.triangles` it reproduces
//! [`crate::render()`] in full mode: the same hit mask up to pixels on
//! silhouette edges, the same depth, object and normal, and byte-identical
//! colours wherever both pick the same triangle at a pixel. It gets there
//! by splitting the work the way a rasteriser does, but taking every value
//! from the ray the caster would cast:
//!
//! 1. **Set-up.** Each triangle is clipped against the near plane
//!    `z = eye.z − ε` (ε = [`NEAR_FRACTION`] · `eye.z`): the eye looks
//!    towards −z, so geometry at or behind the eye plane would project
//!    through the eye and wrap around; the clipped polygon (a triangle or a
//!    quad, fanned into two triangles) is projected through the eye onto
//!    the screen plane z = 0 and into pixels (f64). Triangles with a
//!    non-finite corner, zero area (in the world or on the screen) or an
//!    object without a material are skipped, and so are those wholly behind
//!    the near plane or whose box holds no pixel centre of the screen;
//!    [`RasterStats`] counts each kind.
//!    Nothing is culled by facing: shading is two-sided.
//! 2. **Binning.** Each drawn triangle goes into every band of
//!    [`BAND_ROWS`] rows its clamped bounding box touches, in input order.
//! 3. **Coverage and visibility**, one rayon task per band. A pixel is
//!    covered when its centre `(x + 0.5, y + 0.5)` lies inside by the three
//!    edge functions with a top-left fill rule. Each edge is evaluated from
//!    its lexicographically smaller end, so the two triangles sharing an
//!    edge compute exactly opposite values and every pixel centre on a
//!    shared edge goes to exactly one of them: no holes, no double cover.
//!    For a covered pixel the ray from the eye through the pixel centre
//!    (exactly the ray the caster casts) meets the triangle's plane; the
//!    ray parameter `t` and the barycentrics come from the same arithmetic
//!    as the watertight test ([`crate::ray::watertight`], without its
//!    inside test, which the edge functions make), so `t` is bit-identical
//!    to the caster's and interpolation is perspective-correct by
//!    construction. The z-buffer keeps the smallest `t`; equal `t` goes to
//!    the lower triangle index, so the image never depends on the thread
//!    count.
//! 4. **Deferred shading.** Once a band's visibility is final, each covered
//!    pixel is shaded once, as the caster shades a hit: the normal is the
//!    normalised barycentric blend of the corner normals (the face normal
//!    when that vanishes), the point is `eye + (screen_point − eye)·t`,
//!    the colour [`shade`] then [`to_rgb8`], the depth
//!    `t·|screen_point − eye|` (mm), the layer [`Layer::Full`]. Uncovered
//!    pixels get the background: `background_rgb8`, no hit, depth +∞,
//!    [`NO_OBJECT`], normal 0.
//!
//! Where the two still differ: pixel centres within rounding of a
//! silhouette edge (the caster tests the f32 ray against closed edges, the
//! rasteriser the f64 projection against half-open ones), the rare pixel
//! where two triangles are at exactly the same `t` (the caster keeps the
//! first in BVH order, the rasteriser the lower index) and geometry closer
//! to the eye than ε, which the rasteriser clips away.
//!
//! A [`RasterScratch`] keeps the set-up, the bins and the z-buffer between
//! frames: once it has drawn a frame of this size and about this many
//! triangles, drawing another allocates nothing. The cost of a triangle is
//! its bounding box clamped to the screen, so a huge one costs at most a
//! screenful of pixels.
//!
//! Its GPU twin is `GpuRenderer::rasterize` (feature `gpu`): the same
//! triangles, near plane, skipped triangles, shading and G-buffer, drawn by
//! a wgpu render pipeline with a depth buffer; coverage there is the
//! hardware's, so silhouette pixels may differ
//! (`raycast/tests/gpu_raster.rs` measures it).

use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::frame::{Frame, Layer, NO_OBJECT};
use crate::ray::{plane_hit, WatertightRay};
use crate::scene::{Scene, WorldTriangle};
use crate::shade::{shade, to_rgb8};

/// Rows in one band, the unit of parallel work (each band is rasterised and
/// shaded by one task, with its own part of the z-buffer).
pub const BAND_ROWS: usize = 16;

/// The near plane lies this fraction of the eye distance in front of the
/// eye: `z = eye.z · (1 − NEAR_FRACTION)` (0.54 mm at 540 mm). Geometry
/// nearer the eye is clipped away.
pub const NEAR_FRACTION: f64 = 1e-3;

/// The z-buffer's "no triangle".
const NONE: u32 = u32::MAX;

/// Counts and time of one [`rasterize`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct RasterStats {
    /// Triangles passed in.
    pub triangles_in: u64,
    /// Triangles set up and binned (their clipped bounding box, clamped to
    /// the screen, holds a pixel centre); they may still cover none.
    pub drawn: u64,
    /// Triangles not drawn: `culled_invalid + culled_behind +
    /// culled_no_pixels`, so `triangles_in = drawn + culled`.
    pub culled: u64,
    /// Of `culled`: a non-finite corner, zero area in the world or on the
    /// screen (degenerate or edge-on), or an object id without a material.
    pub culled_invalid: u64,
    /// Of `culled`: wholly behind the near plane (at or behind the eye).
    pub culled_behind: u64,
    /// Of `culled`: the clipped bounding box holds no pixel centre of the
    /// screen (off the screen, or small enough to fall between centres).
    pub culled_no_pixels: u64,
    /// Pixel centres found inside a triangle (counted once per triangle, so
    /// overdraw counts several times).
    pub fragments: u64,
    /// Pixels of the frame that show a triangle.
    pub pixels_covered: u64,
    /// Wall time of the raster, ms.
    pub time_ms: f64,
}

/// What [`rasterize`] keeps between frames: the set-up of each triangle,
/// the bins of the bands and the z-buffer (ray parameter and triangle
/// index per pixel).
#[derive(Debug, Default)]
pub struct RasterScratch {
    prep: Vec<Prep>,
    bins: Vec<Vec<u32>>,
    z_t: Vec<f32>,
    z_tri: Vec<u32>,
}

/// The outcome of a triangle's set-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Prep {
    Invalid,
    Behind,
    NoPixels,
    /// Drawn; the first and last pixel rows its clamped box touches.
    Drawn {
        y0: u32,
        y1: u32,
    },
}

/// Draws `triangles` (a subset of `scene.triangles`, or any list whose
/// object ids index `scene`'s materials) as seen by `camera` into `frame`,
/// which takes the camera's size (its buffers are reused); the surface
/// buffers (depth, object, normal) are filled when `surface` is set. Every
/// pixel is written. See the [module documentation](self) for how this
/// matches [`crate::render()`] in full mode.
pub fn rasterize(
    scene: &Scene,
    camera: &Camera,
    triangles: &[WorldTriangle],
    surface: bool,
    frame: &mut Frame,
    scratch: &mut RasterScratch,
) -> RasterStats {
    let start = Instant::now();
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    frame.reshape(camera.width_px, camera.height_px, surface);
    let mut stats = RasterStats {
        triangles_in: triangles.len() as u64,
        ..RasterStats::default()
    };
    // Indices must stay below the z-buffer's NONE; a longer list (hundreds
    // of GB) is not drawn past that.
    let drawable = &triangles[..triangles.len().min(NONE as usize)];
    let ctx = Ctx {
        scene,
        cam: camera,
        view: View::new(camera),
        tris: drawable,
    };

    // 1. Set-up, in parallel.
    drawable
        .par_iter()
        .map(|t| match setup(&ctx, t) {
            Ok(s) => Prep::Drawn { y0: s.y0, y1: s.y1 },
            Err(p) => p,
        })
        .collect_into_vec(&mut scratch.prep);

    // 2. Binning, in input order.
    let n_bands = h.div_ceil(BAND_ROWS);
    scratch.bins.resize_with(n_bands, Vec::new);
    for bin in &mut scratch.bins {
        bin.clear();
    }
    for (i, p) in scratch.prep.iter().enumerate() {
        match *p {
            Prep::Invalid => stats.culled_invalid += 1,
            Prep::Behind => stats.culled_behind += 1,
            Prep::NoPixels => stats.culled_no_pixels += 1,
            Prep::Drawn { y0, y1 } => {
                stats.drawn += 1;
                for b in y0 as usize / BAND_ROWS..=y1 as usize / BAND_ROWS {
                    scratch.bins[b].push(i as u32);
                }
            }
        }
    }
    stats.culled_invalid += (triangles.len() - drawable.len()) as u64;
    stats.culled = stats.culled_invalid + stats.culled_behind + stats.culled_no_pixels;

    // 3–4. Coverage, visibility and shading, one task per band.
    scratch.z_t.resize(w * h, f32::INFINITY);
    scratch.z_tri.resize(w * h, NONE);
    if w > 0 && h > 0 {
        let (fragments, covered) = bands(&ctx, frame, scratch, w, surface);
        stats.fragments = fragments;
        stats.pixels_covered = covered;
    }
    stats.time_ms = start.elapsed().as_secs_f64() * 1e3;
    stats
}

/// What every stage reads.
struct Ctx<'a> {
    scene: &'a Scene,
    cam: &'a Camera,
    /// None for a camera whose eye is not finite and in front of the screen
    /// (`z > 0`): nothing is drawn.
    view: Option<View>,
    tris: &'a [WorldTriangle],
}

/// The projection through the eye onto the screen, in f64.
#[derive(Debug, Clone, Copy)]
struct View {
    eye: DVec3,
    near_z: f64,
    pitch: [f64; 2],
    half: [f64; 2],
    size: [u32; 2],
}

impl View {
    fn new(cam: &Camera) -> Option<Self> {
        let eye = cam.eye.as_dvec3();
        let [px, py] = cam.pitch().map(f64::from);
        let ok = eye.is_finite() && eye.z > 0.0 && px.is_finite() && py.is_finite();
        (ok && px > 0.0 && py > 0.0).then(|| Self {
            eye,
            near_z: eye.z * (1.0 - NEAR_FRACTION),
            pitch: [px, py],
            half: [
                f64::from(cam.width_px) / 2.0,
                f64::from(cam.height_px) / 2.0,
            ],
            size: [cam.width_px, cam.height_px],
        })
    }

    /// Pixel coordinates of a world point in front of the near plane: the
    /// inverse of [`Camera::screen_point`] applied to its projection
    /// through the eye onto z = 0.
    fn project(&self, q: DVec3) -> [f64; 2] {
        let e = self.eye;
        let lambda = e.z / (e.z - q.z);
        let sx = e.x + (q.x - e.x) * lambda;
        let sy = e.y + (q.y - e.y) * lambda;
        [
            sx / self.pitch[0] + self.half[0],
            self.half[1] - sy / self.pitch[1],
        ]
    }
}

/// One edge function, evaluated from the edge's lexicographically smaller
/// end so that the triangle on the other side computes exactly its
/// negation.
#[derive(Debug, Clone, Copy)]
struct Edge {
    bx: f64,
    by: f64,
    dx: f64,
    dy: f64,
    /// ±1: the orientation of this triangle's edge relative to the
    /// canonical one.
    s: f64,
    /// Pixel centres exactly on the edge belong to this triangle.
    top_left: bool,
}

impl Edge {
    /// The edge from `a` to `b` of a triangle whose inside is where the
    /// function is positive (clockwise on the screen, y down).
    fn new(a: [f64; 2], b: [f64; 2]) -> Self {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        // y down: a top edge runs in +x with the inside below it; a left
        // edge runs up (−y) with the inside to its right.
        let top_left = dy < 0.0 || (dy == 0.0 && dx > 0.0);
        let (base, d, s) = if (a[0], a[1]) < (b[0], b[1]) {
            (a, [dx, dy], 1.0)
        } else {
            (b, [a[0] - b[0], a[1] - b[1]], -1.0)
        };
        Self {
            bx: base[0],
            by: base[1],
            dx: d[0],
            dy: d[1],
            s,
            top_left,
        }
    }

    #[inline]
    fn eval(&self, px: f64, py: f64) -> f64 {
        self.s * (self.dx * (py - self.by) - self.dy * (px - self.bx))
    }

    #[inline]
    fn inside(&self, e: f64) -> bool {
        e > 0.0 || (e == 0.0 && self.top_left)
    }
}

/// One screen triangle of a (clipped) world triangle: its edges and its
/// pixel box (inclusive, clamped to the screen).
#[derive(Debug, Clone, Copy)]
struct Part {
    e: [Edge; 3],
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
}

/// A triangle ready to rasterise: one part, or two for a quad left by the
/// near plane.
#[derive(Debug, Clone, Copy)]
struct Setup {
    parts: [Option<Part>; 2],
    y0: u32,
    y1: u32,
}

/// Pixels whose centre `i + 0.5` lies in `[lo, hi]`, clamped to `0..n`.
fn pixel_span(lo: f64, hi: f64, n: u32) -> Option<(u32, u32)> {
    let a = (lo - 0.5).ceil().max(0.0);
    let b = (hi - 0.5).floor().min(f64::from(n) - 1.0);
    (a <= b).then_some((a as u32, b as u32))
}

/// Where the edge `a`–`b` crosses the near plane, the same whichever way
/// round the edge is given (so a shared edge is cut at one point).
fn cut(a: DVec3, b: DVec3, near_z: f64) -> DVec3 {
    let (a, b) = if a.to_array() <= b.to_array() {
        (a, b)
    } else {
        (b, a)
    };
    let s = (near_z - a.z) / (b.z - a.z);
    let mut q = a + (b - a) * s;
    q.z = near_z;
    q
}

/// Clips, projects and sets up one triangle.
fn setup(ctx: &Ctx<'_>, tri: &WorldTriangle) -> Result<Setup, Prep> {
    let Some(view) = ctx.view else {
        return Err(Prep::Behind);
    };
    if tri.object as usize >= ctx.scene.object_materials.len()
        || !tri.p.iter().all(|p| p.is_finite())
    {
        return Err(Prep::Invalid);
    }
    let p = tri.p.map(|v| v.as_dvec3());
    if (p[1] - p[0]).cross(p[2] - p[0]) == DVec3::ZERO {
        return Err(Prep::Invalid);
    }
    // Sutherland–Hodgman against z <= near_z.
    let mut poly = [DVec3::ZERO; 4];
    let mut n = 0;
    for i in 0..3 {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        let (a_in, b_in) = (a.z <= view.near_z, b.z <= view.near_z);
        if a_in {
            poly[n] = a;
            n += 1;
        }
        if a_in != b_in {
            poly[n] = cut(a, b, view.near_z);
            n += 1;
        }
    }
    if n < 3 {
        return Err(Prep::Behind);
    }
    let mut s = [[0.0f64; 2]; 4];
    for (si, q) in s.iter_mut().zip(&poly[..n]) {
        *si = view.project(*q);
        if !(si[0].is_finite() && si[1].is_finite()) {
            return Err(Prep::Invalid);
        }
    }
    let mut parts = [None, None];
    let mut any_area = false;
    let (mut y0, mut y1) = (u32::MAX, 0);
    for (k, part) in parts.iter_mut().enumerate().take(n - 2) {
        let (a, mut b, mut c) = (s[0], s[k + 1], s[k + 2]);
        let area = Edge::new(a, b).eval(c[0], c[1]);
        if area.is_nan() || area == 0.0 {
            continue;
        }
        any_area = true;
        if area < 0.0 {
            std::mem::swap(&mut b, &mut c);
        }
        let xs = [a[0], b[0], c[0]];
        let ys = [a[1], b[1], c[1]];
        let min = |v: [f64; 3]| v[0].min(v[1]).min(v[2]);
        let max = |v: [f64; 3]| v[0].max(v[1]).max(v[2]);
        let (Some((px0, px1)), Some((py0, py1))) = (
            pixel_span(min(xs), max(xs), view.size[0]),
            pixel_span(min(ys), max(ys), view.size[1]),
        ) else {
            continue;
        };
        y0 = y0.min(py0);
        y1 = y1.max(py1);
        *part = Some(Part {
            e: [Edge::new(a, b), Edge::new(b, c), Edge::new(c, a)],
            x0: px0,
            x1: px1,
            y0: py0,
            y1: py1,
        });
    }
    if !any_area {
        return Err(Prep::Invalid);
    }
    if parts.iter().all(Option::is_none) {
        return Err(Prep::NoPixels);
    }
    Ok(Setup { parts, y0, y1 })
}

/// The eye ray through the centre of pixel (x, y), set up as the caster
/// sets up its ray through it, and its direction `screen_point − eye`.
#[inline]
fn pixel_ray(cam: &Camera, x: usize, y: usize) -> (WatertightRay, Vec3) {
    let ray = cam.ray([x as f32 + 0.5, y as f32 + 0.5]);
    (WatertightRay::new(&ray), ray.dir)
}

/// One band's part of the frame's buffers (the surface ones empty when the
/// frame has none).
struct BandOut<'a> {
    rgb: &'a mut [u8],
    hit: &'a mut [bool],
    layer: &'a mut [Layer],
    depth: &'a mut [f32],
    object: &'a mut [u32],
    normal: &'a mut [[f32; 3]],
}

/// Runs every band in parallel; returns (fragments, pixels covered).
fn bands(
    ctx: &Ctx<'_>,
    frame: &mut Frame,
    scratch: &mut RasterScratch,
    w: usize,
    surface: bool,
) -> (u64, u64) {
    let chunk = BAND_ROWS * w;
    let Frame {
        rgb,
        hit,
        depth_mm,
        object,
        normal,
        layer,
        ..
    } = frame;
    let add = |a: (u64, u64), b: (u64, u64)| (a.0 + b.0, a.1 + b.1);
    let common = rgb
        .par_chunks_mut(3 * chunk)
        .zip(hit.par_chunks_mut(chunk))
        .zip(layer.par_chunks_mut(chunk))
        .zip(scratch.z_t.par_chunks_mut(chunk))
        .zip(scratch.z_tri.par_chunks_mut(chunk))
        .zip(scratch.bins.par_iter())
        .enumerate();
    if surface {
        common
            .zip(
                depth_mm
                    .par_chunks_mut(chunk)
                    .zip(object.par_chunks_mut(chunk))
                    .zip(normal.par_chunks_mut(chunk)),
            )
            .map(
                |((b, (((((rgb, hit), layer), zt), zi), bin)), ((depth, object), normal))| {
                    let out = BandOut {
                        rgb,
                        hit,
                        layer,
                        depth,
                        object,
                        normal,
                    };
                    band(ctx, b * BAND_ROWS, w, bin, zt, zi, out)
                },
            )
            .reduce(|| (0, 0), add)
    } else {
        common
            .map(|(b, (((((rgb, hit), layer), zt), zi), bin))| {
                let out = BandOut {
                    rgb,
                    hit,
                    layer,
                    depth: &mut [],
                    object: &mut [],
                    normal: &mut [],
                };
                band(ctx, b * BAND_ROWS, w, bin, zt, zi, out)
            })
            .reduce(|| (0, 0), add)
    }
}

/// Rasterises and shades one band: rows `y_start ..` (as many as `zt`
/// holds). Returns (fragments, pixels covered).
fn band(
    ctx: &Ctx<'_>,
    y_start: usize,
    w: usize,
    bin: &[u32],
    zt: &mut [f32],
    zi: &mut [u32],
    out: BandOut<'_>,
) -> (u64, u64) {
    let rows = zt.len() / w;
    zt.fill(f32::INFINITY);
    zi.fill(NONE);
    let mut fragments = 0u64;
    // Visibility.
    for &i in bin {
        let tri = &ctx.tris[i as usize];
        let Ok(s) = setup(ctx, tri) else { continue };
        for part in s.parts.iter().flatten() {
            let y0 = (part.y0 as usize).max(y_start);
            let y1 = (part.y1 as usize).min(y_start + rows - 1);
            for y in y0..=y1 {
                let py = y as f64 + 0.5;
                let row = (y - y_start) * w;
                for x in part.x0 as usize..=part.x1 as usize {
                    let px = x as f64 + 0.5;
                    if !part.e.iter().all(|e| e.inside(e.eval(px, py))) {
                        continue;
                    }
                    fragments += 1;
                    let (ray, _) = pixel_ray(ctx.cam, x, y);
                    let Some((t, _, _)) = plane_hit(&ray, tri.p[0], tri.p[1], tri.p[2]) else {
                        continue;
                    };
                    let k = row + x;
                    if t < zt[k] || (t == zt[k] && i < zi[k]) {
                        zt[k] = t;
                        zi[k] = i;
                    }
                }
            }
        }
    }
    // Deferred shading: every pixel of the band, once.
    let scene = ctx.scene;
    let surface = !out.depth.is_empty();
    let mut covered = 0u64;
    for (k, &i) in zi.iter().enumerate() {
        let (x, y) = (k % w, y_start + k / w);
        let shaded = (i != NONE).then(|| &ctx.tris[i as usize]).and_then(|tri| {
            let (ray, dir) = pixel_ray(ctx.cam, x, y);
            let (t, u, v) = plane_hit(&ray, tri.p[0], tri.p[1], tri.p[2])?;
            // As `Scene::intersect` makes `Hit::normal`.
            let n = tri.n[0] * (1.0 - u - v) + tri.n[1] * u + tri.n[2] * v;
            let face = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
            let normal = n
                .try_normalize()
                .or_else(|| face.try_normalize())
                .unwrap_or(Vec3::Z);
            // As the caster's `colour_of` and `texel`.
            let position = ctx.cam.eye + dir * t;
            let colour = shade(scene, tri.object, position, normal, ctx.cam.eye);
            let rgb = if colour == scene.background {
                scene.background_rgb8
            } else {
                to_rgb8(colour)
            };
            Some((rgb, t * dir.length(), tri.object, normal))
        });
        out.layer[k] = Layer::Full;
        match shaded {
            Some((rgb, depth, object, normal)) => {
                covered += 1;
                out.rgb[3 * k..3 * k + 3].copy_from_slice(&rgb);
                out.hit[k] = true;
                if surface {
                    out.depth[k] = depth;
                    out.object[k] = object;
                    out.normal[k] = normal.to_array();
                }
            }
            None => {
                out.rgb[3 * k..3 * k + 3].copy_from_slice(&scene.background_rgb8);
                out.hit[k] = false;
                if surface {
                    out.depth[k] = f32::INFINITY;
                    out.object[k] = NO_OBJECT;
                    out.normal[k] = [0.0; 3];
                }
            }
        }
    }
    (fragments, covered)
}
