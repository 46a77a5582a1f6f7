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
//!
//! [`render_with`] keeps the mask, vertex hits, refined flags and pixel
//! owners in a [`Scratch`] that the next frame reuses, and times each stage
//! ([`StageTimes`]; `gazecast bench stages` prints them).

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

use foveation::mask::{self, Layout, RayMask, NO_VERTEX};
use foveation::SamplingModel;
use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::frame::{Frame, Layer, RowMut, Texel, NO_OBJECT};
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

/// Wall time of each stage of one CPU frame (ms), in the order they run.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct StageTimes {
    /// Building the ray mask for the gaze.
    pub mask: f64,
    /// Casting a ray through every mesh vertex.
    pub vertex_rays: f64,
    /// Classifying cells homogeneous or heterogeneous.
    pub classify: f64,
    /// Widening the refined cells by the silhouette margin.
    pub margin: f64,
    /// Giving every pixel its owner (fovea or one cell).
    pub ownership: f64,
    /// Casting or interpolating every pixel, and shading it.
    pub pixels: f64,
    /// Of `pixels`: time spent casting and shading the fovea and refined
    /// pixels, summed over the threads (CPU ms, not wall time).
    pub pixel_casts_cpu: f64,
}

impl StageTimes {
    /// The stages by name, in the order they run.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        [
            ("mask", self.mask),
            ("vertex rays", self.vertex_rays),
            ("classify", self.classify),
            ("margin", self.margin),
            ("ownership", self.ownership),
            ("pixels", self.pixels),
            ("pixel casts (cpu)", self.pixel_casts_cpu),
        ]
    }
}

/// What a foveated frame needs besides the frame itself (the mask, the
/// vertex hits, the refined flags, the pixel owners), kept across frames so
/// that a renderer allocates nothing per frame once it has had one frame of
/// this size; and the stage times of the last frame.
#[derive(Debug, Default)]
pub struct Scratch {
    mask: Option<RayMask>,
    vertex_hits: Vec<Option<Hit>>,
    refined: Vec<bool>,
    touched: Vec<bool>,
    owner: Vec<AtomicU32>,
    stages: StageTimes,
}

impl Scratch {
    /// Wall time of each stage of the last frame rendered with it.
    pub fn stages(&self) -> &StageTimes {
        &self.stages
    }
}

/// Milliseconds since `t`, and resets `t` to now.
fn lap(t: &mut Instant) -> f64 {
    let now = Instant::now();
    let ms = (now - *t).as_secs_f64() * 1e3;
    *t = now;
    ms
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
    render_with(
        scene,
        cam,
        model,
        settings,
        gaze_px,
        surface,
        frame,
        &mut Scratch::default(),
    )
}

/// [`render_into`] with the foveated method's buffers in `scratch`, which
/// the next frame reuses (and which records the stage times).
#[allow(clippy::too_many_arguments)]
pub fn render_with(
    scene: &Scene,
    cam: &Camera,
    model: &SamplingModel,
    settings: &Settings,
    gaze_px: [f64; 2],
    surface: bool,
    frame: &mut Frame,
    scratch: &mut Scratch,
) -> Result<Stats, foveation::ParamError> {
    let start = Instant::now();
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let foveated_mode = settings.mode == Mode::Foveated && scene.has(Effect::FoveatedSampling);
    // The mask first: a bad gaze leaves the frame as it was.
    if foveated_mode {
        match &mut scratch.mask {
            Some(m) => mask::rebuild(m, model, settings.layout, gaze_px)?,
            None => scratch.mask = Some(mask::build(model, settings.layout, gaze_px)?),
        }
    }
    let mut stats = Stats::default();
    scratch.stages = StageTimes::default();
    let mut t = start;
    scratch.stages.mask = lap(&mut t);
    frame.reshape(cam.width_px, cam.height_px, surface);
    let frame = &mut *frame;
    if !foveated_mode {
        full(scene, cam, settings.test, frame);
        scratch.stages.pixels = lap(&mut t);
        stats.rays_full = (w * h) as u64;
        stats.rays_total = stats.rays_full;
    } else {
        foveated(scene, cam, settings, frame, &mut stats, scratch, t);
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

/// Runs `f(y, row)` on every row of `frame` in parallel and folds the
/// results with `op` (`T::default()` for none). The rows are split off the
/// buffers in place: nothing is allocated per frame.
fn map_rows<T: Default + Send>(
    frame: &mut Frame,
    f: impl Fn(usize, RowMut<'_>) -> T + Sync + Send,
    op: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    let w = frame.width_px as usize;
    if w == 0 || frame.height_px == 0 {
        return T::default();
    }
    let surface = frame.has_surface();
    let Frame {
        rgb,
        hit,
        depth_mm,
        object,
        normal,
        layer,
        ..
    } = frame;
    let rows = rgb
        .par_chunks_mut(3 * w)
        .zip(hit.par_chunks_mut(w))
        .zip(layer.par_chunks_mut(w))
        .enumerate();
    if surface {
        rows.zip(
            depth_mm
                .par_chunks_mut(w)
                .zip(object.par_chunks_mut(w))
                .zip(normal.par_chunks_mut(w)),
        )
        .map(|((y, ((rgb, hit), layer)), ((depth_mm, object), normal))| {
            let row = RowMut {
                rgb,
                hit,
                depth_mm,
                object,
                normal,
                layer,
            };
            f(y, row)
        })
        .reduce(T::default, &op)
    } else {
        rows.map(|(y, ((rgb, hit), layer))| {
            let row = RowMut {
                rgb,
                hit,
                depth_mm: &mut [],
                object: &mut [],
                normal: &mut [],
                layer,
            };
            f(y, row)
        })
        .reduce(T::default, &op)
    }
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
    settings: &Settings,
    frame: &mut Frame,
    stats: &mut Stats,
    scratch: &mut Scratch,
    mut t: Instant,
) {
    let Scratch {
        mask,
        vertex_hits,
        refined,
        touched,
        owner,
        stages,
    } = scratch;
    let Some(m) = mask.as_ref() else {
        return;
    };
    let (w, h) = (frame.width_px as usize, frame.height_px as usize);
    let test = settings.test;
    // 2. Mask rays.
    m.vertices
        .par_iter()
        .map(|v| cast(scene, cam, *v, test))
        .collect_into_vec(vertex_hits);
    let vertex_hits: &[Option<Hit>] = vertex_hits;
    stages.vertex_rays = lap(&mut t);
    // 3. Classify, then widen by one vertex ring.
    m.cells
        .par_iter()
        .map(|c| {
            let corners = corners_of(c);
            let mut hits = [None; 4];
            for (k, &v) in corners.iter().enumerate() {
                hits[k] = vertex_hits[v as usize];
            }
            !homogeneous(&hits[..corners.len()], &settings.triggers)
        })
        .collect_into_vec(refined);
    stages.classify = lap(&mut t);
    if settings.triggers.margin {
        touched.clear();
        touched.resize(m.vertices.len(), false);
        for (c, r) in m.cells.iter().zip(refined.iter()) {
            if *r {
                corners_of(c)
                    .iter()
                    .for_each(|&v| touched[v as usize] = true);
            }
        }
        let touched: &[bool] = touched;
        refined
            .par_iter_mut()
            .zip(&m.cells)
            .for_each(|(r, c)| *r = *r || corners_of(c).iter().any(|&v| touched[v as usize]));
    }
    let refined: &[bool] = refined;
    stages.margin = lap(&mut t);
    // 4. Ownership: fovea spans, then cells by an exact top-left rule.
    // A homogeneous cell whose corners all miss is background: unless
    // coverage is being checked, it is not rasterised at all.
    let background = |c: &[u32; 4]| {
        corners_of(c)
            .iter()
            .all(|&v| vertex_hits[v as usize].is_none())
    };
    owners_into(owner, m, w, h, |ci| {
        !settings.check_coverage && !refined[ci] && background(&m.cells[ci])
    });
    let owner: &[AtomicU32] = owner;
    stages.ownership = lap(&mut t);
    // 5. Cast or interpolate, and shade.
    let counts: (u64, u64, u64, f64) = map_rows(
        frame,
        |y, mut row| {
            let surface = row.has_surface();
            let mut n = (0u64, 0u64, 0u64, 0f64); // fovea, refine, gap, cast ms
            let owners = &owner[y * w..(y + 1) * w];
            let py = y as f32 + 0.5;
            // The sample of a pixel whose owner sees nothing: the same
            // wherever it is.
            let empty = texel(scene, cam, [0.5, py], None, Layer::Interpolated, surface);
            // Runs of pixels with one owner.
            let mut x = 0;
            while x < w {
                let o = owners[x].load(Ordering::Relaxed);
                let mut end = x + 1;
                while end < w && owners[end].load(Ordering::Relaxed) == o {
                    end += 1;
                }
                if o == UNOWNED && !settings.check_coverage {
                    fill(&mut row, x..end, empty);
                } else if o == FOVEA || o == UNOWNED || refined[o as usize] {
                    let layer = match o {
                        FOVEA => {
                            n.0 += (end - x) as u64;
                            Layer::Fovea
                        }
                        UNOWNED => {
                            n.2 += (end - x) as u64;
                            Layer::Gap
                        }
                        _ => {
                            n.1 += (end - x) as u64;
                            Layer::Refined
                        }
                    };
                    let t0 = Instant::now();
                    for x in x..end {
                        let p = [x as f32 + 0.5, py];
                        let hit = cast(scene, cam, p, test);
                        row.put(x, texel(scene, cam, p, hit, layer, surface));
                    }
                    n.3 += t0.elapsed().as_secs_f64() * 1e3;
                } else {
                    let s = CellSetup::new(m, &m.cells[o as usize], vertex_hits);
                    if s.first.is_none() {
                        fill(&mut row, x..end, empty);
                    } else {
                        for x in x..end {
                            let p = [x as f32 + 0.5, py];
                            let t = texel(
                                scene,
                                cam,
                                p,
                                s.interpolate(p),
                                Layer::Interpolated,
                                surface,
                            );
                            row.put(x, t);
                        }
                    }
                }
                x = end;
            }
            n
        },
        |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3),
    );
    stats.rays_fovea = counts.0;
    stats.rays_mask = m.vertices.len() as u64;
    stats.rays_refine = counts.1 + counts.2;
    stats.pixels_uncovered = counts.2;
    stats.rays_total = stats.rays_fovea + stats.rays_mask + stats.rays_refine;
    stats.cells_total = m.cells.len() as u64;
    stats.cells_refined = refined.iter().filter(|r| **r).count() as u64;
    stages.pixels = lap(&mut t);
    stages.pixel_casts_cpu = counts.3;
}

/// Writes the one sample `t` to the pixels `xs` of `row`.
fn fill(row: &mut RowMut<'_>, xs: std::ops::Range<usize>, t: Texel) {
    for px in row.rgb[3 * xs.start..3 * xs.end].chunks_exact_mut(3) {
        px.copy_from_slice(&t.rgb);
    }
    row.hit[xs.clone()].fill(t.hit);
    row.layer[xs.clone()].fill(t.layer);
    if row.has_surface() {
        let (d, o, n) = match t.surface {
            Some((d, o, n)) => (d, o, n.to_array()),
            None => (f32::INFINITY, NO_OBJECT, [0.0; 3]),
        };
        row.depth_mm[xs.clone()].fill(d);
        row.object[xs.clone()].fill(o);
        row.normal[xs].fill(n);
    }
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
    let mut owner = Vec::new();
    owners_into(&mut owner, m, w, h, skip);
    owner.into_par_iter().map(AtomicU32::into_inner).collect()
}

/// [`owners`] into `owner`, reusing its buffer. A pixel is claimed only while
/// unowned; the exact rule gives every pixel at most one cell, so plain
/// (relaxed) loads and stores do, with no read-modify-write per pixel.
fn owners_into(
    owner: &mut Vec<AtomicU32>,
    m: &RayMask,
    w: usize,
    h: usize,
    skip: impl Fn(usize) -> bool + Sync,
) {
    owner.resize_with(w * h, || AtomicU32::new(UNOWNED));
    owner.par_iter_mut().for_each(|o| *o.get_mut() = UNOWNED);
    for s in &m.fovea {
        let row = s.y as usize * w;
        for o in &mut owner[row + s.x_start as usize..row + s.x_end as usize] {
            *o.get_mut() = FOVEA;
        }
    }
    let owner: &[AtomicU32] = owner;
    m.cells.par_iter().enumerate().for_each(|(ci, c)| {
        if skip(ci) {
            return;
        }
        rasterise(m, corners_of(c), w, h, |i| {
            if owner[i].load(Ordering::Relaxed) == UNOWNED {
                owner[i].store(ci as u32, Ordering::Relaxed);
            }
        })
    });
}

/// Calls `own` for the index of every pixel whose centre lies in the cell.
/// Coordinates are snapped to 1/65536 px and edge functions evaluated exactly
/// in integers; a centre on an edge belongs to the cell for which that edge
/// runs "down or left" (a top-left style rule), so cells sharing an edge never
/// both claim a pixel and never both miss it. Along a row each edge function
/// steps by an exact integer, so it is evaluated incrementally.
fn rasterise(m: &RayMask, corners: &[u32], w: usize, h: usize, mut own: impl FnMut(usize)) {
    let n = corners.len();
    let mut all = [(0i64, 0i64); 4];
    for (k, &v) in corners.iter().enumerate() {
        let p = m.vertices[v as usize];
        all[k] = (
            (f64::from(p[0]) * SUB).round() as i64,
            (f64::from(p[1]) * SUB).round() as i64,
        );
    }
    let pts = &mut all[..n];
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
    if px0 > px1 {
        return;
    }
    // Per edge: start point, direction, and whether a centre on it is inside.
    let mut edges = [((0i64, 0i64), (0i64, 0i64), false); 4];
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        edges[i] = (a, (dx, dy), dy > 0 || (dy == 0 && dx < 0));
    }
    let edges = &edges[..n];
    let cx0 = px0 * sub + sub / 2;
    for py in py0..=py1 {
        let cy = py * sub + sub / 2;
        let mut e = [0i64; 4];
        for (e, &(a, (dx, dy), _)) in e.iter_mut().zip(edges) {
            *e = dx * (cy - a.1) - dy * (cx0 - a.0);
        }
        let row = py as usize * w;
        for px in px0..=px1 {
            let inside = e
                .iter()
                .zip(edges)
                .all(|(&e, &(_, _, on))| e > 0 || (e == 0 && on));
            if inside {
                own(row + px as usize);
            }
            if px < px1 {
                for (e, &(_, (_, dy), _)) in e.iter_mut().zip(edges) {
                    *e -= dy * sub;
                }
            }
        }
    }
}

/// A homogeneous cell's corners, prepared once for interpolating at the
/// pixels it owns (the same arithmetic as per pixel, so the same bits).
struct CellSetup {
    /// Hits at the corners; `None` for a cell whose first corner misses.
    hits: [Option<Hit>; 4],
    first: Option<Hit>,
    /// Per triangle: corner indices, `a`, `b - a`, `c - a` and the doubled
    /// signed area `d` (`None` when zero: the triangle is skipped).
    tris: [Option<Tri>; 2],
    last: usize,
}

#[derive(Clone, Copy)]
struct Tri {
    idx: [usize; 3],
    a: [f32; 2],
    ba: [f32; 2],
    ca: [f32; 2],
    d: f32,
}

impl CellSetup {
    fn new(m: &RayMask, cell: &[u32; 4], hits: &[Option<Hit>]) -> Self {
        let corners = corners_of(cell);
        let mut h = [None; 4];
        for (k, &v) in corners.iter().enumerate() {
            h[k] = hits[v as usize];
        }
        let first = h[0];
        let pos = |v: u32| m.vertices[v as usize];
        let tris: &[[usize; 3]] = if corners.len() == 4 {
            &[[0, 1, 2], [0, 2, 3]]
        } else {
            &[[0, 1, 2]]
        };
        let mut out = [None; 2];
        if first.is_some() {
            for (k, t) in tris.iter().enumerate() {
                let (a, b, c) = (pos(corners[t[0]]), pos(corners[t[1]]), pos(corners[t[2]]));
                let ba = [b[0] - a[0], b[1] - a[1]];
                let ca = [c[0] - a[0], c[1] - a[1]];
                let d = ba[0] * ca[1] - ba[1] * ca[0];
                if d != 0.0 {
                    out[k] = Some(Tri {
                        idx: *t,
                        a,
                        ba,
                        ca,
                        d,
                    });
                }
            }
        }
        Self {
            hits: h,
            first,
            tris: out,
            last: tris.len() - 1,
        }
    }

    /// Distance and normal at `p`, interpolated from the corners (quads as
    /// two triangles): the hit the interpolated sample stands for.
    #[inline]
    fn interpolate(&self, p: [f32; 2]) -> Option<Hit> {
        let first = self.first?;
        let mut weights = None;
        for (k, t) in self.tris.iter().enumerate() {
            let Some(t) = t else { continue };
            let (pa0, pa1) = (p[0] - t.a[0], p[1] - t.a[1]);
            let wb = (pa0 * t.ca[1] - pa1 * t.ca[0]) / t.d;
            let wc = (t.ba[0] * pa1 - t.ba[1] * pa0) / t.d;
            let wa = 1.0 - wb - wc;
            let inside = wa >= -1e-4 && wb >= -1e-4 && wc >= -1e-4;
            if inside || k == self.last {
                weights = Some((t.idx, [wa, wb, wc]));
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
            let h = self.hits[idx].unwrap_or(first);
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
}
