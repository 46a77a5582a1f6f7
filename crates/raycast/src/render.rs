//! The hybrid renderer on the CPU (rayon): full resolution, or the CSF mask
//! with reconstruction from the intermediate mesh (Murphy 2007 ch. 4–6).
//!
//! Foveated frame:
//! 1. build the ray mask for the POR (`foveation::mask`);
//! 2. cast a ray through every mesh vertex (the "mask rays", including the
//!    few just off the screen that close edge cells);
//! 3. classify cells: *homogeneous* when all corners miss, or all hit the
//!    same object with normals within the crease angle and no depth jump;
//!    otherwise *heterogeneous*. The enabled triggers are the scene's
//!    effects. Cells touching a vertex of a heterogeneous cell are refined
//!    too (silhouette margin): a silhouette that bulges into a cell between
//!    its corners always comes from a neighbouring cell that sees it;
//! 4. give every pixel one owner — the fovea disc, or exactly one cell by an
//!    exact integer top-left rule — then cast the fovea pixels and every
//!    pixel of a refined cell (the seed's GPU variant, §6.2.3), and
//!    interpolate distance and normal over the pixels of homogeneous cells;
//! 5. shade every pixel with Blinn–Phong.
//!
//! Fovea and refined pixels use exactly the rays and shading of the full
//! mode, so they are identical to it.

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

use foveation::mask::{self, Layout, RayMask, NO_VERTEX};
use foveation::SamplingModel;
use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::frame::{Frame, Layer, Texel};
use crate::ray::TriangleTest;
use crate::scene::{Effect, Hit, Scene};
use crate::shade::{shade, to_rgb8};

/// Full resolution or foveated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    Full,
    #[default]
    Foveated,
}

/// What decides that a cell needs its pixels cast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triggers {
    /// Corners disagree on hit/miss or object.
    pub silhouette: bool,
    /// Corner normals differ by more than this angle (degrees).
    pub crease_deg: Option<f32>,
    /// max/min corner distance exceeds 1 + this.
    pub depth_jump: Option<f32>,
    /// Also refine cells that share a vertex with a refined cell.
    pub margin: bool,
}

impl Triggers {
    /// The triggers a scene's effect list turns on.
    pub fn from_scene(scene: &Scene) -> Self {
        Self {
            silhouette: scene.has(Effect::SilhouetteRefinement),
            crease_deg: scene
                .has(Effect::CreaseRefinement)
                .then_some(scene.crease_deg),
            depth_jump: scene
                .has(Effect::DepthRefinement)
                .then_some(scene.depth_jump),
            margin: scene.has(Effect::SilhouetteRefinement),
        }
    }

    pub const NONE: Triggers = Triggers {
        silhouette: false,
        crease_deg: None,
        depth_jump: None,
        margin: false,
    };
}

/// How to render one frame.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    pub mode: Mode,
    pub layout: Layout,
    pub triggers: Triggers,
    pub test: TriangleTest,
    /// Rasterise every cell, including homogeneous background cells, so
    /// that any pixel without an owner shows up as a `Gap` (tests use this).
    /// Off, background cells are not rasterised: their pixels keep the
    /// background, which is what the exact ownership rule gives them anyway.
    pub check_coverage: bool,
}

/// Counts and time of one frame (the `--stats` JSON of `gazecast render`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Hybrid: rays cast one per pixel in the fovea disc.
    pub rays_fovea: u64,
    /// Hybrid: rays through mesh vertices, including those just off the screen.
    pub rays_mask: u64,
    /// Hybrid: rays cast for the pixels of refined cells (and any gap).
    pub rays_refine: u64,
    /// Full resolution: one ray per pixel (0 in a hybrid frame).
    pub rays_full: u64,
    /// Every ray of the frame: `rays_fovea + rays_mask + rays_refine +
    /// rays_full`.
    pub rays_total: u64,
    pub cells_total: u64,
    pub cells_refined: u64,
    /// Pixels that no cell owned and were cast as a fallback (expected 0).
    pub pixels_uncovered: u64,
    pub time_ms: f64,
}

const FOVEA: u32 = u32::MAX;
const UNOWNED: u32 = u32::MAX - 1;
/// Fixed-point subpixel precision of the ownership raster: 1/65536 px keeps
/// the mesh's f32 vertex positions (and the fovea circle they are inscribed
/// in) distinct from pixel centres a thousandth of a pixel away; products of
/// coordinates up to 2^31 still fit in i64.
const SUB: f64 = 65536.0;

fn cast(scene: &Scene, cam: &Camera, p: [f32; 2], test: TriangleTest) -> Option<Hit> {
    scene.intersect(&cam.ray(p), 0.0, test)
}

fn colour_of(scene: &Scene, cam: &Camera, p: [f32; 2], hit: Option<Hit>) -> Vec3 {
    match hit {
        None => scene.background,
        Some(h) => {
            // The hit point on the eye ray through p (no `Ray` needed: its
            // reciprocal direction would be wasted work per pixel).
            let position = cam.eye + (cam.screen_point(p) - cam.eye) * h.t;
            shade(scene, h.object, position, h.normal, cam.eye)
        }
    }
}

/// The G-buffer values of the sample at `p`: colour, and, when the frame
/// has surface buffers (`surface`), the eye distance (mm), object and
/// normal of what it hit.
fn texel(
    scene: &Scene,
    cam: &Camera,
    p: [f32; 2],
    hit: Option<Hit>,
    layer: Layer,
    surface: bool,
) -> Texel {
    Texel {
        rgb: rgb8(scene, colour_of(scene, cam, p, hit)),
        hit: hit.is_some(),
        surface: hit.filter(|_| surface).map(|h| {
            let depth_mm = h.t * (cam.screen_point(p) - cam.eye).length();
            (depth_mm, h.object, h.normal)
        }),
        layer,
    }
}

/// Renders one frame into a new frame with every G-buffer channel (the
/// surface buffers included). `model` gives the mask (foveated mode only).
pub fn render(
    scene: &Scene,
    cam: &Camera,
    model: &SamplingModel,
    settings: &Settings,
    gaze_px: [f64; 2],
) -> Result<(Frame, Stats), foveation::ParamError> {
    let mut frame = Frame::default();
    let stats = render_into(scene, cam, model, settings, gaze_px, true, &mut frame)?;
    Ok((frame, stats))
}

/// Renders one frame into `frame`, reusing its buffers (no allocation once
/// it has had this size); the surface buffers (depth, object id, normal)
/// are filled only when `surface` is set. Every pixel is written.
pub fn render_into(
    scene: &Scene,
    cam: &Camera,
    model: &SamplingModel,
    settings: &Settings,
    gaze_px: [f64; 2],
    surface: bool,
    frame: &mut Frame,
) -> Result<Stats, foveation::ParamError> {
    let start = Instant::now();
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    // The mask first: a bad gaze leaves the frame as it was.
    let m = if settings.mode == Mode::Full || !scene.has(Effect::FoveatedSampling) {
        None
    } else {
        Some(mask::build(model, settings.layout, gaze_px)?)
    };
    frame.reshape(cam.width_px, cam.height_px, surface);
    let frame = &mut *frame;
    let mut stats = Stats::default();
    match m {
        None => {
            full(scene, cam, settings.test, frame);
            stats.rays_full = (w * h) as u64;
            stats.rays_total = stats.rays_full;
        }
        Some(m) => foveated(scene, cam, &m, settings, frame, &mut stats),
    }
    stats.time_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok(stats)
}

/// `to_rgb8`, skipped for the background (most pixels of a sparse scene).
#[inline]
fn rgb8(scene: &Scene, colour: Vec3) -> [u8; 3] {
    if colour == scene.background {
        scene.background_rgb8
    } else {
        to_rgb8(colour)
    }
}

fn full(scene: &Scene, cam: &Camera, test: TriangleTest, frame: &mut Frame) {
    frame
        .rows_mut()
        .into_par_iter()
        .enumerate()
        .for_each(|(y, mut row)| {
            let surface = row.has_surface();
            for x in 0..row.hit.len() {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let hit = cast(scene, cam, p, test);
                row.put(x, texel(scene, cam, p, hit, Layer::Full, surface));
            }
        });
}

/// Is a cell with these corner hits homogeneous under `t`?
fn homogeneous(corners: &[Option<Hit>], t: &Triggers) -> bool {
    if corners.iter().all(Option::is_none) {
        return true;
    }
    let Some(a) = corners[0] else {
        return !t.silhouette;
    };
    if corners
        .iter()
        .any(|h| h.is_none_or(|h| h.object != a.object))
    {
        return !t.silhouette;
    }
    let hits = || corners.iter().flatten();
    if let Some(deg) = t.crease_deg {
        let cos = deg.to_radians().cos();
        for (i, p) in hits().enumerate() {
            if hits().skip(i + 1).any(|q| p.normal.dot(q.normal) < cos) {
                return false;
            }
        }
    }
    if let Some(jump) = t.depth_jump {
        let (lo, hi) = hits().fold((f32::INFINITY, 0.0f32), |(lo, hi), h| {
            (lo.min(h.t), hi.max(h.t))
        });
        if hi > lo * (1.0 + jump) {
            return false;
        }
    }
    true
}

fn corners_of(cell: &[u32; 4]) -> &[u32] {
    if cell[3] == NO_VERTEX {
        &cell[..3]
    } else {
        &cell[..]
    }
}

fn foveated(
    scene: &Scene,
    cam: &Camera,
    m: &RayMask,
    settings: &Settings,
    frame: &mut Frame,
    stats: &mut Stats,
) {
    let (w, h) = (frame.width_px as usize, frame.height_px as usize);
    let test = settings.test;
    // 2. Mask rays.
    let vertex_hits: Vec<Option<Hit>> = m
        .vertices
        .par_iter()
        .map(|v| cast(scene, cam, *v, test))
        .collect();
    // 3. Classify, then widen by one vertex ring.
    let mut refined: Vec<bool> = m
        .cells
        .par_iter()
        .map(|c| {
            let hits: Vec<Option<Hit>> = corners_of(c)
                .iter()
                .map(|&v| vertex_hits[v as usize])
                .collect();
            !homogeneous(&hits, &settings.triggers)
        })
        .collect();
    if settings.triggers.margin {
        let mut touched = vec![false; m.vertices.len()];
        for (c, r) in m.cells.iter().zip(&refined) {
            if *r {
                corners_of(c)
                    .iter()
                    .for_each(|&v| touched[v as usize] = true);
            }
        }
        refined
            .par_iter_mut()
            .zip(&m.cells)
            .for_each(|(r, c)| *r = *r || corners_of(c).iter().any(|&v| touched[v as usize]));
    }
    // 4. Ownership: fovea spans, then cells by an exact top-left rule.
    // A homogeneous cell whose corners all miss is background: unless
    // coverage is being checked, it is not rasterised at all.
    let background = |c: &[u32; 4]| {
        corners_of(c)
            .iter()
            .all(|&v| vertex_hits[v as usize].is_none())
    };
    let owner = owners(m, w, h, |ci| {
        !settings.check_coverage && !refined[ci] && background(&m.cells[ci])
    });
    // 5. Cast or interpolate, and shade.
    let counts: (u64, u64, u64) = frame
        .rows_mut()
        .into_par_iter()
        .enumerate()
        .map(|(y, mut row)| {
            let surface = row.has_surface();
            let mut n = (0u64, 0u64, 0u64); // fovea, refine, gap
            for x in 0..w {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let o = owner[y * w + x];
                let t = if o == UNOWNED && !settings.check_coverage {
                    texel(scene, cam, p, None, Layer::Interpolated, surface)
                } else if o == FOVEA || o == UNOWNED || refined[o as usize] {
                    let hit = cast(scene, cam, p, test);
                    let layer = match o {
                        FOVEA => {
                            n.0 += 1;
                            Layer::Fovea
                        }
                        UNOWNED => {
                            n.2 += 1;
                            Layer::Gap
                        }
                        _ => {
                            n.1 += 1;
                            Layer::Refined
                        }
                    };
                    texel(scene, cam, p, hit, layer, surface)
                } else {
                    let hit = interpolate(m, &m.cells[o as usize], &vertex_hits, p);
                    texel(scene, cam, p, hit, Layer::Interpolated, surface)
                };
                row.put(x, t);
            }
            n
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
    stats.rays_fovea = counts.0;
    stats.rays_mask = m.vertices.len() as u64;
    stats.rays_refine = counts.1 + counts.2;
    stats.pixels_uncovered = counts.2;
    stats.rays_total = stats.rays_fovea + stats.rays_mask + stats.rays_refine;
    stats.cells_total = m.cells.len() as u64;
    stats.cells_refined = refined.iter().filter(|r| **r).count() as u64;
}

/// Owner of a pixel in the fovea disc ([`ownership`]).
pub const OWNER_FOVEA: u32 = FOVEA;
/// A pixel no cell claims ([`ownership`]).
pub const OWNER_NONE: u32 = UNOWNED;

/// Which part of the mask owns each pixel: [`OWNER_FOVEA`], the index of the
/// one cell whose exact top-left rule claims the pixel centre, or
/// [`OWNER_NONE`]. Depends on the gaze only (every cell is rasterised); the
/// GPU core uploads it.
pub fn ownership(m: &RayMask, w: usize, h: usize) -> Vec<u32> {
    owners(m, w, h, |_| false)
}

/// Fovea spans first, then every cell that `skip` does not exclude.
fn owners(m: &RayMask, w: usize, h: usize, skip: impl Fn(usize) -> bool + Sync) -> Vec<u32> {
    let owner: Vec<AtomicU32> = (0..w * h)
        .into_par_iter()
        .map(|_| AtomicU32::new(UNOWNED))
        .collect();
    for s in &m.fovea {
        for x in s.x_start..s.x_end {
            owner[s.y as usize * w + x as usize].store(FOVEA, Ordering::Relaxed);
        }
    }
    m.cells.par_iter().enumerate().for_each(|(ci, c)| {
        if skip(ci) {
            return;
        }
        rasterise(m, corners_of(c), w, h, |i| {
            let _ =
                owner[i].compare_exchange(UNOWNED, ci as u32, Ordering::Relaxed, Ordering::Relaxed);
        })
    });
    owner.into_par_iter().map(AtomicU32::into_inner).collect()
}

/// Calls `own` for the index of every pixel whose centre lies in the cell.
/// Coordinates are snapped to 1/65536 px and edge functions evaluated exactly
/// in integers; a centre on an edge belongs to the cell for which that edge
/// runs "down or left" (a top-left style rule), so cells sharing an edge never
/// both claim a pixel and never both miss it.
fn rasterise(m: &RayMask, corners: &[u32], w: usize, h: usize, mut own: impl FnMut(usize)) {
    let mut pts: Vec<(i64, i64)> = corners
        .iter()
        .map(|&v| {
            let p = m.vertices[v as usize];
            (
                (f64::from(p[0]) * SUB).round() as i64,
                (f64::from(p[1]) * SUB).round() as i64,
            )
        })
        .collect();
    let n = pts.len();
    let area2: i64 = (0..n)
        .map(|i| pts[i].0 * pts[(i + 1) % n].1 - pts[(i + 1) % n].0 * pts[i].1)
        .sum();
    if area2 == 0 {
        return;
    }
    if area2 < 0 {
        pts.reverse();
    }
    let sub = SUB as i64;
    let (x0, x1) = pts
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    // Pixel centres (x + 0.5)·SUB within the bounding box, clipped to the screen.
    let first = |lo: i64| ((lo - sub / 2) as f64 / SUB).ceil().max(0.0) as i64;
    let last = |hi: i64, limit: usize| {
        (((hi - sub / 2) as f64 / SUB).floor() as i64).min(limit as i64 - 1)
    };
    let (px0, px1, py0, py1) = (first(x0), last(x1, w), first(y0), last(y1, h));
    for py in py0..=py1 {
        let cy = py * sub + sub / 2;
        for px in px0..=px1 {
            let cx = px * sub + sub / 2;
            let inside = (0..n).all(|i| {
                let (a, b) = (pts[i], pts[(i + 1) % n]);
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let e = dx * (cy - a.1) - dy * (cx - a.0);
                e > 0 || (e == 0 && (dy > 0 || (dy == 0 && dx < 0)))
            });
            if inside {
                own(py as usize * w + px as usize);
            }
        }
    }
}

/// Interpolates distance and normal at `p` from a homogeneous cell's corners
/// (quads as two triangles): the hit the interpolated sample stands for.
fn interpolate(m: &RayMask, cell: &[u32; 4], hits: &[Option<Hit>], p: [f32; 2]) -> Option<Hit> {
    let corners = corners_of(cell);
    let first = hits[corners[0] as usize]?;
    let pos = |v: u32| m.vertices[v as usize];
    let tris: &[[usize; 3]] = if corners.len() == 4 {
        &[[0, 1, 2], [0, 2, 3]]
    } else {
        &[[0, 1, 2]]
    };
    let mut weights = None;
    for (k, t) in tris.iter().enumerate() {
        let (a, b, c) = (pos(corners[t[0]]), pos(corners[t[1]]), pos(corners[t[2]]));
        let d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if d == 0.0 {
            continue;
        }
        let wb = ((p[0] - a[0]) * (c[1] - a[1]) - (p[1] - a[1]) * (c[0] - a[0])) / d;
        let wc = ((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])) / d;
        let wa = 1.0 - wb - wc;
        let inside = wa >= -1e-4 && wb >= -1e-4 && wc >= -1e-4;
        if inside || k + 1 == tris.len() {
            weights = Some((t, [wa, wb, wc]));
            if inside {
                break;
            }
        }
    }
    let Some((t, wts)) = weights else {
        return Some(first);
    };
    let mut dist = 0.0;
    let mut normal = Vec3::ZERO;
    for (k, &idx) in t.iter().enumerate() {
        let h = hits[corners[idx] as usize].unwrap_or(first);
        dist += wts[k] * h.t;
        normal += wts[k] * h.normal;
    }
    Some(Hit {
        t: dist,
        object: first.object,
        triangle: first.triangle,
        normal: normal.try_normalize().unwrap_or(first.normal),
    })
}
