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
//! Every stage casts its rays in packets of eight neighbours (a row's
//! pixels, a ring's vertices; `Scene::intersect_packet`, issue 34), whose
//! hits are bit for bit those of casting each ray alone.
//!
//! [`render_with`] keeps the mask, vertex hits, refined flags and pixel
//! owners in a [`Scratch`] that the next frame reuses, and times each stage
//! ([`StageTimes`]; `gazecast bench stages` prints them).
//!
//! ## Temporal reuse during fixations
//!
//! A [`Scratch::with_reuse`] also keeps cast samples for later frames
//! (Murphy 2007 §8.2.4; issue 15): the hit of every pixel centre cast since
//! the scene, camera or triangle test last changed (the fovea, refined and
//! gap pixels of any gaze are cast at pixel centres, fixed screen
//! positions), and, while the new mask is bit-identical to the last one
//! (the same gaze), the whole frame's vertex rays, classification, margin
//! and pixel owners. Mesh vertices themselves are not kept by position:
//! they sit at `POR + r·(cos, sin)` with radii that depend on the POR, and
//! for any gaze move of 0.001 px or more none of a new mask's 217 k vertices
//! (seed display) lands where an old one was (0 or 1 shared, measured), so
//! such a cache would never hit. Shading is not cached: it is redone from
//! the hit each frame. A frame rendered with reuse is the frame rendered
//! without it, byte for byte (colour, hit, depth, object, normal, layer and
//! the [`Stats`] counts; `tests/reuse.rs`); [`Scratch::reuse_stats`] says
//! what came from the cache.
//!
//! Measured with `cargo bench -p raycast --no-default-features --bench reuse
//! -- --rounds 5` (search task, 1280×1024, 2 threads, synthetic 120 Hz gaze
//! traces of 24 frames each from an empty cache, reuse on and off
//! alternating in one run; frames per second, on/off over the five rounds):
//!
//! | trace | off | on | on / off |
//! |---|---:|---:|---:|
//! | fixation (±0.5° noise) | 7.3 | 9.9 | 1.30–1.36 |
//! | saccades (≥ 5° a frame) | 8.1 | 13.0 | 1.58–1.61 |
//! | still (the same gaze) | 7.4 | 23.8 | 3.19–3.23 |
//! | head (eye moves a frame: emptied) | 7.3 | 7.3 | 0.98–1.01 |
//!
//! Reuse takes 95 % of the fixation's cast pixels (81 % along saccades: the
//! refined pixels around silhouettes recur wherever the gaze is) from the
//! cache and halves the pixel stage, but the vertex rays (47 ms), the
//! ownership raster (11 ms) and the interpolation and shading of every
//! other pixel remain, so a fixation runs at 10 fps, not the 60.
//!
//! ### Holding the mask through a fixation, and whole-frame reuse
//!
//! A model with a gaze tolerance ε
//! ([`SamplingModel::gaze_tolerance_deg`]) builds masks dense enough for
//! any POR within ε of theirs, and [`Scratch::mask_for`] keeps the mask
//! while the gaze stays within ε of the POR it was built for (with or
//! without reuse; without a tolerance only a bit-identical gaze keeps it).
//! The frame is then the one of the kept mask: a fixation's jitter no
//! longer changes it. With reuse on, such a frame skips stages 2–4; and
//! a second one in a row, with the same scene, shading inputs, camera,
//! settings and surface flag, is the last one copied
//! ([`ReuseStats::frame_reused`]). Only frames drawn with a kept mask are
//! kept for copying, so a saccade's frames do not pay for the copy; the
//! kept frame is one frame more of memory (5 bytes a pixel, 25 with the
//! surface buffers), made by the first frame drawn with a kept mask.
//!
//! **Off by default** ([`Scratch::default`]), although it is bit-identical
//! and never measurably slower: with it on, a repeated gaze (what
//! `gazecast bench stages` and `gazecast render --repeat` time) would
//! report the kept frame's cost instead of a frame's; [`render_into`] makes
//! a scratch per call, where a cache only costs; and the cache takes 28
//! bytes a pixel (37 MB at 1280×1024, 232 MB at 3840×2160). A caller that
//! renders a live view turns it on ([`Scratch::with_reuse`],
//! [`Scratch::set_reuse`]; `pipeline::Options::reuse`, which `gazecast
//! view`, `gazecast demo` and the experiment's search screens set).

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

use foveation::mask::{self, Layout, RayMask, NO_VERTEX};
use foveation::SamplingModel;
use glam::Vec3;
use rayon::iter::Either;
use rayon::prelude::*;

use crate::accel::bvh4::PACKET;
use crate::camera::Camera;
use crate::frame::{Frame, Layer, RowMut, Texel, NO_OBJECT};
use crate::ray::TriangleTest;
use crate::scene::{Hit, Scene};
use crate::shade::{shade, to_rgb8};

/// What the ray caster casts: every pixel, or Murphy 2007's hybrid (the
/// CSF ray mask, reconstruction, refinement). The caller decides, once,
/// for the scene (`pipeline::Method::for_scene`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Every pixel is cast.
    Full,
    /// Murphy 2007's hybrid: the ray mask, reconstruction and refinement.
    #[default]
    Hybrid,
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
    /// The triggers a scene's sampling turns on.
    pub fn from_scene(scene: &Scene) -> Self {
        let s = &scene.sampling;
        Self {
            silhouette: s.silhouette(),
            crease_deg: s.crease_deg(),
            depth_jump: s.depth_jump(),
            margin: s.silhouette(),
        }
    }

    /// No trigger: no cell is refined.
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
    /// Every pixel or the hybrid.
    pub mode: Mode,
    /// The ray mask's layout (hybrid).
    pub layout: Layout,
    /// What makes the hybrid cast a cell's pixels.
    pub triggers: Triggers,
    /// The ray/triangle intersection test.
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
    /// Hybrid: cells of the intermediate mesh.
    pub cells_total: u64,
    /// Hybrid: of those, cells refined (their pixels cast).
    pub cells_refined: u64,
    /// Pixels that no cell owned and were cast as a fallback (expected 0).
    pub pixels_uncovered: u64,
    /// Wall time of the frame, ms.
    pub time_ms: f64,
}

mod hybrid;
mod ownership;
mod reuse;
mod scratch;

use hybrid::*;
use ownership::*;
pub use ownership::{ownership, OWNER_FOVEA, OWNER_NONE};
pub use reuse::ReuseStats;
use reuse::*;
use scratch::lap;
pub use scratch::{Scratch, StageTimes};

const FOVEA: u32 = u32::MAX;
const UNOWNED: u32 = u32::MAX - 1;
/// Fixed-point subpixel precision of the ownership raster: 1/65536 px keeps
/// the mesh's f32 vertex positions (and the fovea circle they are inscribed
/// in) distinct from pixel centres a thousandth of a pixel away; products of
/// coordinates up to 2^31 still fit in i64.
const SUB: f64 = 65536.0;

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
    // The method is chosen once, for the scene, by the caller
    // (`pipeline::Method::for_scene`): the mode is what runs.
    let foveated_mode = settings.mode == Mode::Hybrid;
    // The mask first: a bad gaze leaves the frame (and the cache) as it was.
    let mut mask_generation = (0, 0);
    let kept = if foveated_mode {
        let (held, generation) = scratch.mask_for(model, settings.layout, gaze_px)?;
        mask_generation = generation;
        match scratch.reuse.as_deref_mut() {
            None => false,
            Some(r) => {
                r.stats = ReuseStats::default();
                r.stats.invalidated = r.begin(CastKey::new(scene, cam, settings.test), w, h);
                let now = FrameKey {
                    triggers: settings.triggers,
                    check_coverage: settings.check_coverage,
                };
                let kept = held && r.frame == Some(now);
                // Until this frame has finished, nothing is kept.
                r.frame = None;
                r.stats.mask_reused = kept;
                kept
            }
        }
    } else {
        if let Some(r) = scratch.reuse.as_deref_mut() {
            r.stats = ReuseStats::default();
        }
        false
    };
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
        // A second frame in a row with the kept mask and nothing else
        // changed: the last one's pixels, copied.
        let copied = kept
            && scratch.reuse.as_deref_mut().is_some_and(|r| {
                let Some(k) = r.last.as_deref().filter(|k| {
                    k.generation == mask_generation
                        && k.key
                            .as_ref()
                            .is_some_and(|key| key.matches(scene, surface))
                        && k.frame.width_px == frame.width_px
                        && k.frame.height_px == frame.height_px
                }) else {
                    return false;
                };
                frame.clone_from(&k.frame);
                stats = k.stats;
                r.stats.frame_reused = true;
                r.stats.pixels_reused = stats.rays_fovea + stats.rays_refine;
                true
            });
        if copied {
            scratch.stages.pixels = lap(&mut t);
        } else {
            foveated(scene, cam, settings, frame, &mut stats, scratch, kept, t);
        }
        if let Some(r) = scratch.reuse.as_deref_mut() {
            r.frame = Some(FrameKey {
                triggers: settings.triggers,
                check_coverage: settings.check_coverage,
            });
            // A frame drawn with a kept mask is kept in turn (a frame with
            // a new mask is not: a saccade's frames would pay the copy for
            // nothing).
            if kept && !copied {
                let k = r.last.get_or_insert_with(Box::default);
                k.frame.clone_from(frame);
                k.stats = stats;
                k.generation = mask_generation;
                OutKey::set(&mut k.key, scene, surface);
            }
        }
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
    map_rows::<(), ()>(
        frame,
        None,
        |y, mut row, _| {
            let surface = row.has_surface();
            let py = y as f32 + 0.5;
            // Eight neighbouring pixels a packet (bit-identical to casting
            // each alone: `Scene::intersect_packet`).
            let mut rays = [cam.ray([0.5, py]); PACKET];
            let mut hits = [None; PACKET];
            let w = row.hit.len();
            for x0 in (0..w).step_by(PACKET) {
                let n = PACKET.min(w - x0);
                for (k, r) in rays[..n].iter_mut().enumerate() {
                    *r = cam.ray([(x0 + k) as f32 + 0.5, py]);
                }
                scene.intersect_packet(&rays[..n], 0.0, test, &mut hits[..n]);
                for (k, &hit) in hits[..n].iter().enumerate() {
                    let p = [(x0 + k) as f32 + 0.5, py];
                    row.put(x0 + k, texel(scene, cam, p, hit, Layer::Full, surface));
                }
            }
        },
        |(), ()| (),
    );
}

/// Runs `f(y, row, extra_row)` on every row of `frame` in parallel and
/// folds the results with `op` (`T::default()` for none); `extra_row` is
/// row `y` of `extra` (a per-pixel buffer of the frame's size) when there is
/// one. The rows are split off the buffers in place: nothing is allocated
/// per frame.
fn map_rows<T: Default + Send, C: Send>(
    frame: &mut Frame,
    extra: Option<&mut [C]>,
    f: impl Fn(usize, RowMut<'_>, Option<&mut [C]>) -> T + Sync + Send,
    op: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    let w = frame.width_px as usize;
    let h = frame.height_px as usize;
    if w == 0 || h == 0 {
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
    let extra = match extra {
        Some(e) => Either::Left(e[..w * h].par_chunks_mut(w).map(Some)),
        None => Either::Right((0..h).into_par_iter().map(|_| None)),
    };
    let rows = rgb
        .par_chunks_mut(3 * w)
        .zip(hit.par_chunks_mut(w))
        .zip(layer.par_chunks_mut(w))
        .zip(extra)
        .enumerate();
    if surface {
        rows.zip(
            depth_mm
                .par_chunks_mut(w)
                .zip(object.par_chunks_mut(w))
                .zip(normal.par_chunks_mut(w)),
        )
        .map(
            |((y, (((rgb, hit), layer), extra)), ((depth_mm, object), normal))| {
                let row = RowMut {
                    rgb,
                    hit,
                    depth_mm,
                    object,
                    normal,
                    layer,
                };
                f(y, row, extra)
            },
        )
        .reduce(T::default, &op)
    } else {
        rows.map(|(y, (((rgb, hit), layer), extra))| {
            let row = RowMut {
                rgb,
                hit,
                depth_mm: &mut [],
                object: &mut [],
                normal: &mut [],
                layer,
            };
            f(y, row, extra)
        })
        .reduce(T::default, &op)
    }
}
