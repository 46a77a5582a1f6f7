//! Attention-guided level of detail (Lee 2009 ch. 7) with ULOD's blend of
//! two adjacent levels (Giegl & Wimmer 2007).
//!
//! - **Levels** (eq. 7.4): level `l` of an object keeps about `r(l) = 4^−l`
//!   of its triangles (at most `⌊4^−l·n⌋`; a level that would be empty
//!   repeats the last non-empty one), made by Garland–Heckbert quadric simplification: the vertex
//!   tree's edge collapses folded cheapest first until the count is met
//!   ([`lod::Cut::fold_to_triangles`]). `ULODn` has levels `0 … n−1`.
//! - **Attention** comes from Lee's model run on the *previous* frame's
//!   G-buffer (colour, eye distance, object id) — Lee's cheapest variant,
//!   which reuses the last frame's colour and needs no extra pass, so his
//!   `a` of eq. 7.2 is 0 here and `𝒯_a` is the model's own time. The first
//!   frame has no previous one and draws every object at level 0.
//! - **Level** (eq. 7.3): `L = M(1 − S_o)`, with `M = n − 1` and `S_o` the
//!   object's smoothed attention divided by the largest of the frame (Lee's
//!   `S_o` rarely reaches 1; *decision*: rescale by the maximum, so the
//!   most attended object is always at full detail). An object the model
//!   did not rank (not visible last frame) gets `S_o = 0`, the coarsest
//!   level; scenery (importance 0, never ranked) is not simplified. A
//!   frame the model cannot read keeps the last levels.
//! - **ULOD blend** (*decisions*; Lee defers the rules to Giegl & Wimmer):
//!   with `l = ⌊L⌋` and `α = L − l`, level `l` is drawn opaque and level
//!   `l + 1` over it with opacity `α`. The blended level shows where it is
//!   nearer than the opaque image, where the opaque pixel shows the same
//!   object (both levels are one surface), or where the opaque image is
//!   background. `α = 0` draws one level only.
//!
//! Everything is drawn by the CPU z-buffer rasteriser ([`raycast::raster`])
//! into the usual G-buffer; the blend changes colour only (depth, object
//! and normal stay the opaque level's).

use glam::Vec3;
use lod::{Cut, VertexTree};
use raycast::raster::{self, RasterScratch};
use raycast::scene::WorldTriangle;
use raycast::{Camera, Frame, Scene};

use crate::frame_attention::FrameAttention;

/// Most levels (`ULOD5` has five: 1, 1/4, 1/16, 1/64, 1/256).
pub const MAX_LEVELS: usize = 8;

/// One object's levels of detail, finest first (level 0 = the original).
#[derive(Debug, Clone)]
pub struct ObjectLevels {
    /// The object's id in the scene.
    pub object: u32,
    /// The object's triangles at each level, finest (the original) first.
    pub levels: Vec<Vec<WorldTriangle>>,
}

impl ObjectLevels {
    /// Levels `0 … count−1` of a mesh by quadric simplification, each with
    /// at most `⌊4^−l · n⌋` of its `n` triangles (a fold removes one to a
    /// few, so a level may fall a little short of that), as world
    /// triangles of `object`. A level that would be empty repeats the last
    /// non-empty one.
    pub fn build(
        object: u32,
        positions: &[Vec3],
        normals: &[Vec3],
        triangles: &[[u32; 3]],
        count: usize,
    ) -> Result<Self, String> {
        if !(1..=MAX_LEVELS).contains(&count) {
            return Err(format!("levels: {count} must be from 1 to {MAX_LEVELS}"));
        }
        let luminance = vec![0.0; positions.len()];
        let tree = VertexTree::build(positions, normals, &luminance, triangles)
            .map_err(|e| format!("object {object}: level of detail: {e}"))?;
        let mut cut = Cut::new(&tree);
        let full = cut.active_triangle_count();
        let (mut p, mut n) = (Vec::new(), Vec::new());
        let mut levels = Vec::with_capacity(count);
        for l in 0..count {
            let target = (full as f64 * 0.25f64.powi(l as i32)).floor() as usize;
            cut.fold_to_triangles(target);
            if cut.active_triangle_count() == 0 && full > 0 {
                // A small mesh runs out of triangles: its coarsest levels
                // repeat the last one that shows something (an object
                // that drew nothing could never be attended again).
                if let Some(last) = levels.last().cloned() {
                    levels.push(last);
                    continue;
                }
            }
            cut.triangles_into(&mut p);
            cut.normals_into(&mut n);
            levels.push(
                p.iter()
                    .zip(&n)
                    .map(|(&p, &n)| WorldTriangle { p, n, object })
                    .collect(),
            );
        }
        Ok(Self { object, levels })
    }

    /// The same levels moved by `f` (positions) and `g` (normals), as
    /// object `object`: instances of one mesh share one simplification.
    pub fn placed(&self, object: u32, f: impl Fn(Vec3) -> Vec3, g: impl Fn(Vec3) -> Vec3) -> Self {
        Self {
            object,
            levels: self
                .levels
                .iter()
                .map(|l| {
                    l.iter()
                        .map(|t| WorldTriangle {
                            p: t.p.map(&f),
                            n: t.n.map(&g),
                            object,
                        })
                        .collect()
                })
                .collect(),
        }
    }
}

/// Levels `0 … count−1` of every object of `scene` (each welded back into
/// an indexed mesh and simplified on its own).
pub fn scene_levels(scene: &Scene, count: usize) -> Result<Vec<ObjectLevels>, String> {
    crate::model_based::weld(scene)
        .into_iter()
        .enumerate()
        .filter(|(_, m)| !m.triangles.is_empty())
        .map(|(k, m)| ObjectLevels::build(k as u32, &m.positions, &m.normals, &m.triangles, count))
        .collect()
}

/// What the last frame did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct UlodStats {
    /// Triangles of every object at level 0.
    pub triangles_full: usize,
    /// Triangles drawn opaque and blended.
    pub triangles_opaque: usize,
    /// Triangles drawn blended (the second level of a blended object).
    pub triangles_blended: usize,
    /// Objects drawn with a blended second level.
    pub blended_objects: usize,
    /// Mean level `L` over the objects.
    pub mean_level: f64,
    /// Time of the attention model, of the rasters and of the blend, ms.
    pub attention_ms: f64,
    /// Time of the rasters, ms.
    pub raster_ms: f64,
    /// Time of the blend, ms.
    pub blend_ms: f64,
}

impl UlodStats {
    /// One line for a command's output.
    pub fn line(&self) -> String {
        format!(
            "ulod: {} of {} triangles drawn ({} opaque, {} blended on {} objects), mean level {:.2}, attention {:.1} ms, raster {:.1} ms",
            self.triangles_opaque + self.triangles_blended,
            self.triangles_full,
            self.triangles_opaque,
            self.triangles_blended,
            self.blended_objects,
            self.mean_level,
            self.attention_ms,
            self.raster_ms
        )
    }
}

/// Attention-guided LOD over a set of objects.
pub struct Ulod {
    objects: Vec<ObjectLevels>,
    levels: usize,
    attention: FrameAttention,
    /// Per object id: its level `L` for the coming frame.
    level: Vec<f64>,
    opaque: Vec<WorldTriangle>,
    blended: Vec<WorldTriangle>,
    alpha: Vec<f32>,
    scratch: RasterScratch,
    overlay: Frame,
    last: UlodStats,
}

impl std::fmt::Debug for Ulod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ulod")
            .field("objects", &self.objects.len())
            .field("levels", &self.levels)
            .field("last", &self.last)
            .finish_non_exhaustive()
    }
}

impl Ulod {
    /// `ULODn` with `levels` = n (1 to [`MAX_LEVELS`]; every object must
    /// have that many) and attention maps of `map_size`².
    pub fn new(objects: Vec<ObjectLevels>, levels: usize, map_size: u32) -> Result<Self, String> {
        if !(1..=MAX_LEVELS).contains(&levels) {
            return Err(format!("levels: {levels} must be from 1 to {MAX_LEVELS}"));
        }
        if let Some(o) = objects.iter().find(|o| o.levels.len() < levels) {
            return Err(format!(
                "object {} has {} levels, ULOD{levels} needs {levels}",
                o.object,
                o.levels.len()
            ));
        }
        let ids = objects
            .iter()
            .map(|o| o.object as usize + 1)
            .max()
            .unwrap_or(0);
        Ok(Self {
            objects,
            levels,
            attention: FrameAttention::new(map_size)?,
            level: vec![0.0; ids],
            opaque: Vec::new(),
            blended: Vec::new(),
            alpha: vec![0.0; ids],
            scratch: RasterScratch::default(),
            overlay: Frame::default(),
            last: UlodStats::default(),
        })
    }

    /// What the last frame did.
    pub fn last(&self) -> &UlodStats {
        &self.last
    }

    /// Each object's level `L` for the next frame, by object id.
    pub fn levels(&self) -> &[f64] {
        &self.level
    }

    /// Sets every level from Lee's model run on `previous` (eq. 7.3).
    fn update_levels(&mut self, scene: &Scene, previous: &Frame, time_s: Option<f64>) {
        let m = (self.levels - 1) as f64;
        let result = self.attention.update(previous, scene, time_s);
        // A frame the model cannot read keeps the last levels.
        let Some(result) = result else {
            return;
        };
        let ranked = &result.ranking[..];
        let max = ranked
            .iter()
            .map(|o| o.attention)
            .filter(|a| a.is_finite())
            .fold(0.0f32, f32::max);
        // Scenery (importance 0: floors, walls) is never attended and is
        // not simplified; everything else unranked (not visible in the
        // last frame) goes to the coarsest level.
        for (l, &i) in self.level.iter_mut().zip(
            scene
                .object_importance
                .iter()
                .chain(std::iter::repeat(&1.0)),
        ) {
            *l = if i > 0.0 { m } else { 0.0 };
        }
        for o in ranked {
            if let Some(l) = self.level.get_mut(o.id as usize) {
                let s = if max > 0.0 && o.attention.is_finite() {
                    f64::from((o.attention / max).clamp(0.0, 1.0))
                } else {
                    0.0
                };
                *l = m * (1.0 - s);
            }
        }
    }

    /// Draws a frame into `frame`. `previous` (the last frame drawn, with
    /// its surface buffers) drives the levels; `None` draws level 0.
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        previous: Option<&Frame>,
        time_s: Option<f64>,
        frame: &mut Frame,
    ) -> UlodStats {
        let attention_ms = match previous {
            Some(p) => self.observe(scene, p, time_s),
            None => {
                self.level.fill(0.0);
                0.0
            }
        };
        self.draw(scene, camera, attention_ms, frame)
    }

    /// Sets the levels the next [`Ulod::draw`] uses from Lee's model on
    /// `frame` (eq. 7.3); returns the model's time, ms. A caller that
    /// observes each frame as soon as it is drawn needs no copy of it.
    pub fn observe(&mut self, scene: &Scene, frame: &Frame, time_s: Option<f64>) -> f64 {
        let started = std::time::Instant::now();
        self.update_levels(scene, frame, time_s);
        started.elapsed().as_secs_f64() * 1e3
    }

    /// Draws a frame with the current levels (level 0 everywhere before
    /// any [`Ulod::observe`]); `attention_ms` is reported in the stats.
    pub fn draw(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        attention_ms: f64,
        frame: &mut Frame,
    ) -> UlodStats {
        let top = self.levels - 1;
        self.opaque.clear();
        self.blended.clear();
        self.alpha.fill(0.0);
        let mut stats = UlodStats {
            attention_ms,
            ..UlodStats::default()
        };
        let mut level_sum = 0.0;
        for o in &self.objects {
            stats.triangles_full += o.levels[0].len();
            let l = self.level.get(o.object as usize).copied().unwrap_or(0.0);
            let l = if l.is_finite() {
                l.clamp(0.0, top as f64)
            } else {
                0.0
            };
            level_sum += l;
            let fine = (l.floor() as usize).min(top);
            let a = (l - fine as f64) as f32;
            self.opaque.extend_from_slice(&o.levels[fine]);
            if a > 0.0 && fine < top {
                self.blended.extend_from_slice(&o.levels[fine + 1]);
                if let Some(slot) = self.alpha.get_mut(o.object as usize) {
                    *slot = a;
                }
                stats.blended_objects += 1;
            }
        }
        stats.mean_level = if self.objects.is_empty() {
            0.0
        } else {
            level_sum / self.objects.len() as f64
        };
        stats.triangles_opaque = self.opaque.len();
        stats.triangles_blended = self.blended.len();
        let r = raster::rasterize(scene, camera, &self.opaque, true, frame, &mut self.scratch);
        stats.raster_ms = r.time_ms;
        if !self.blended.is_empty() {
            let r = raster::rasterize(
                scene,
                camera,
                &self.blended,
                true,
                &mut self.overlay,
                &mut self.scratch,
            );
            stats.raster_ms += r.time_ms;
            let t = std::time::Instant::now();
            blend(frame, &self.overlay, &self.alpha);
            stats.blend_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        self.last = stats;
        stats
    }
}

/// Blends `overlay` over `frame` with each overlay object's opacity (see
/// the module docs for where it shows).
fn blend(frame: &mut Frame, overlay: &Frame, alpha: &[f32]) {
    let n = frame.object.len().min(overlay.object.len());
    for i in 0..n {
        let id = overlay.object[i];
        let Some(&a) = alpha.get(id as usize) else {
            continue;
        };
        if a <= 0.0 {
            continue;
        }
        let shows =
            !frame.hit[i] || frame.object[i] == id || overlay.depth_mm[i] < frame.depth_mm[i];
        if !shows {
            continue;
        }
        for c in 0..3 {
            let (x, y) = (
                f32::from(frame.rgb[3 * i + c]),
                f32::from(overlay.rgb[3 * i + c]),
            );
            frame.rgb[3 * i + c] = (x + (y - x) * a).round().clamp(0.0, 255.0) as u8;
        }
    }
}
