//! The model-based methods: simplify the *geometry* by where the eye looks,
//! then rasterise it (Luebke & Hallen 2001; Murphy & Duchowski 2001), where
//! the hybrid method samples the image. Murphy 2007 §8.1 asks for the
//! comparison; this module puts both families in one frame pipeline.
//!
//! Per scene (once, in [`ModelBased::new`]):
//! - each object's world-space triangles are welded back into an indexed
//!   mesh (corners with bit-identical positions share a vertex: the scene
//!   transforms each mesh vertex once, so its corners agree exactly);
//! - each vertex's luminance is its Blinn–Phong colour under the scene's
//!   lights seen from the camera's eye (Rec. 709 weights of linear light);
//!   the scene contrast is the Michelson contrast of the brightest and
//!   darkest vertex and the background (Luebke & Hallen §5.2's silhouette
//!   contrast);
//! - a [`lod::VertexTree`] is built per object, and a cut on it starts
//!   fully unfolded.
//!
//! Per frame: the gaze's 3-D point is the surface under the gaze pixel (or
//! the screen point, when the gaze is on the background: the direction is
//! the same); for `Method::Lod` with a binocular vergence depth for the
//! frame ([`ModelBased::set_vergence_mm`], Murphy & Duchowski eqs 1–3,
//! `g = h + s·v`), it is the point at that eye distance along the gaze ray
//! instead. *Note*: the selection measures eccentricity as the angle at
//! the eye between the gaze direction and a node (M&D §5.4 use only the
//! gaze vector v), so any point on the gaze ray selects the same cut; the
//! vergence point changes the reported 3-D gaze point
//! ([`ModelBasedStats::gaze_point_mm`]), not the triangles. Every object's cut
//! is selected **incrementally** for the view (`Method::Simplify`:
//! Luebke–Hallen imperceptible mode with the Geisler–Perry threshold
//! table, or their best-effort mode under a triangle budget,
//! [`ModelBasedOptions::budget`]; `Method::Lod`: Murphy–Duchowski Table 1
//! levels); with [`ModelBasedOptions::ignore_gaze`] the view has no gaze (every
//! node foveal: Luebke–Hallen "without gaze"); the active triangles (proxy
//! positions and normals) are rasterised into the same G-buffer with the
//! same shading and gamma as the ray caster: by [`raycast::raster`] on the
//! CPU backend, by `GpuRenderer::rasterize` (a `wgpu` render pipeline with
//! a depth buffer) on the GPU backend ([`RasterOn`]).
//!
//! The control is `Method::Full` (every pixel cast), which the CPU
//! rasteriser reproduces exactly on the unsimplified mesh
//! (`raycast/tests/raster.rs`); the GPU one matches the CPU one up to
//! silhouette pixels and rounding (`raycast/tests/gpu_raster.rs`).

use foveation::perceptibility::ThresholdTable;
use foveation::GeislerPerry;
use glam::Vec3;
pub use lod::select::{BudgetOutcome, BudgetStop};
use lod::select::{Mode, SelectionReport, View};
use lod::{Cut, VertexTree};
use raycast::gpu::GpuRenderer;
use raycast::raster::{self, RasterScratch, RasterStats};
use raycast::ray::TriangleTest;
use raycast::render::Stats;
use raycast::scene::WorldTriangle;
use raycast::{Camera, Frame, Scene};

use crate::method::Method;
use crate::plan::Side;
use crate::registry::{FrameMethod, MethodContext, MethodFrame};
use crate::RenderError;

/// One object's tree and its cut (the cut borrows the tree).
struct ObjectLod {
    object: u32,
    cells: TreeCut,
}

self_cell::self_cell!(
    struct TreeCut {
        owner: VertexTree,
        #[covariant]
        dependent: Cut,
    }
);

/// Most triangles a budget may ask for: 10⁹, far above any
/// scene this renderer loads (a bound, so that a typo is an error rather
/// than "no limit").
pub const MAX_TRIANGLE_BUDGET: usize = 1_000_000_000;

/// The model-based methods' options.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ModelBasedOptions {
    /// Luebke & Hallen §5.3 best-effort mode (`Method::Simplify` only): at
    /// most this many triangles a frame, most perceptible fold undone
    /// first. `None`: imperceptible mode. 1 to [`MAX_TRIANGLE_BUDGET`].
    ///
    /// *Decision*: a scene of several objects shares the budget in
    /// proportion to each object's full triangle count (rounded down, so
    /// the sum never exceeds it); each object runs its own greedy (one
    /// queue per tree).
    pub budget: Option<usize>,
    /// Select without the gaze: eccentricity 0 everywhere (Luebke & Hallen's
    /// "without gaze"; for `Method::Lod` every node is then foveal).
    pub ignore_gaze: bool,
}

/// Which of [`ModelBasedOptions`] a [`ModelBasedOptionsError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelBasedSetting {
    /// [`ModelBasedOptions::budget`].
    Budget,
    /// [`ModelBasedOptions::ignore_gaze`].
    IgnoreGaze,
}

/// Model options that do not fit the method asked for. The message names
/// the setting; [`ModelBasedOptionsError::setting`] says which one, so that a
/// caller can name its own way of setting it (a command-line flag).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ModelBasedOptionsError {
    /// A triangle budget with another method than `Simplify`.
    #[error(
        "the triangle budget is Luebke & Hallen's best-effort mode, for the simplify \
         method only (not {method})"
    )]
    BudgetNeedsSimplify {
        /// The method asked for.
        method: &'static str,
    },
    /// A triangle budget outside 1 to [`MAX_TRIANGLE_BUDGET`].
    #[error(
        "the triangle budget must be from 1 to {max} triangles (not {budget})",
        max = MAX_TRIANGLE_BUDGET
    )]
    BudgetOutOfRange {
        /// The budget asked for, triangles.
        budget: usize,
    },
    /// Selecting without the gaze with a method that is not model-based.
    #[error(
        "selecting without the gaze is for the model-based methods only (simplify, lod), \
         not {method}"
    )]
    IgnoreGazeNeedsModelBased {
        /// The method asked for.
        method: &'static str,
    },
}

impl ModelBasedOptionsError {
    /// The setting at fault.
    pub fn setting(&self) -> ModelBasedSetting {
        match self {
            ModelBasedOptionsError::BudgetNeedsSimplify { .. }
            | ModelBasedOptionsError::BudgetOutOfRange { .. } => ModelBasedSetting::Budget,
            ModelBasedOptionsError::IgnoreGazeNeedsModelBased { .. } => {
                ModelBasedSetting::IgnoreGaze
            }
        }
    }
}

impl ModelBasedOptions {
    /// Checks the options against `method` (requested, before the scene
    /// decides).
    pub fn validate(&self, method: Method) -> Result<(), ModelBasedOptionsError> {
        if let Some(budget) = self.budget {
            if method != Method::Simplify {
                return Err(ModelBasedOptionsError::BudgetNeedsSimplify {
                    method: method.name(),
                });
            }
            if !(1..=MAX_TRIANGLE_BUDGET).contains(&budget) {
                return Err(ModelBasedOptionsError::BudgetOutOfRange { budget });
            }
        }
        if self.ignore_gaze && !method.is_model_based() {
            return Err(ModelBasedOptionsError::IgnoreGazeNeedsModelBased {
                method: method.name(),
            });
        }
        Ok(())
    }

    /// [`ModelBasedOptions::validate`] with the error as its message.
    pub fn check(&self, method: Method) -> Result<(), String> {
        self.validate(method).map_err(|e| e.to_string())
    }
}

/// Budget mode's outcome over the scene (Luebke & Hallen §5.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetReport {
    /// The budget asked for.
    pub budget: usize,
    /// Of every object's greedy, the outcome whose most perceptible fold
    /// left is the most perceptible (largest δ*/d): the viewing distance
    /// (δ*) beyond which the whole simplification should be imperceptible.
    pub outcome: BudgetOutcome,
}

/// What the last model-based frame did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ModelBasedStats {
    /// Triangles of the unsimplified scene.
    pub triangles_full: usize,
    /// Triangles drawn this frame.
    pub triangles_drawn: usize,
    /// Folds and unfolds this frame, over every object.
    pub folds: usize,
    /// Unfolds this frame, over every object.
    pub unfolds: usize,
    /// Nodes the selection visited.
    pub nodes_visited: usize,
    /// Wall time of the selection and of the raster, ms.
    pub select_ms: f64,
    /// Wall time of the raster, ms.
    pub raster_ms: f64,
    /// The raster's counts.
    pub raster: RasterStats,
    /// Budget mode only.
    pub budget: Option<BudgetReport>,
    /// The 3-D point of regard the selection used (world mm): the surface
    /// under the gaze pixel, or (`Method::Lod`) the vergence point.
    pub gaze_point_mm: Option<Vec3>,
    /// Whether `gaze_point_mm` came from the frame's vergence depth.
    pub gaze_from_vergence: bool,
}

/// Where [`ModelBased::render`] rasterises the active triangles.
pub enum RasterOn<'a> {
    /// [`raster::rasterize`], the CPU z-buffer.
    Cpu,
    /// `GpuRenderer::rasterize`, the GPU's render pipeline (the renderer
    /// must hold this scene).
    Gpu(&'a mut GpuRenderer),
}

/// [`ModelBased`]'s threshold source until [`ModelBased::set_thresholds`].
pub const DEFAULT_THRESHOLDS: &str =
    "the default Geisler–Perry model (CT0 1/64, α 0.106, e2 2.3°), as a table";

/// The model-based method's state for one scene.
pub struct ModelBased {
    /// `Method::Simplify` or `Method::Lod`.
    method: Method,
    objects: Vec<ObjectLod>,
    mode: Mode,
    options: ModelBasedOptions,
    /// The next frame's vergence depth (eye distance, mm), `Method::Lod` only.
    vergence_mm: Option<f64>,
    thresholds: ThresholdTable,
    /// Where `thresholds` came from, for `explain`.
    thresholds_source: String,
    scene_contrast: f64,
    /// Triangles of the unsimplified scene (fixed at set-up).
    triangles_full: usize,
    triangles: Vec<WorldTriangle>,
    positions: Vec<[Vec3; 3]>,
    normals: Vec<[Vec3; 3]>,
    scratch: RasterScratch,
    last: ModelBasedStats,
}

impl ModelBased {
    /// Builds a tree per object of `scene` for `method` (`Simplify` or
    /// `Lod`; any other method is an error) and `options` (checked by
    /// [`ModelBasedOptions::check`]).
    pub fn new(
        scene: &Scene,
        camera: &Camera,
        method: Method,
        options: ModelBasedOptions,
    ) -> Result<Self, String> {
        options.check(method)?;
        let mode = match method {
            Method::Simplify => match options.budget {
                Some(triangles) => Mode::Budget { triangles },
                None => Mode::Imperceptible,
            },
            Method::Lod => Mode::murphy_duchowski(),
            other => return Err(format!("{} is not a model-based method", other.name())),
        };
        let eye = camera.eye;
        let lum = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        let bg = lum(scene.background).max(0.0);
        let (mut lo, mut hi) = (bg, bg);
        let mut objects = Vec::new();
        let mut triangles_full = 0;
        for (object, mesh) in weld(scene).into_iter().enumerate() {
            let object = object as u32;
            if mesh.triangles.is_empty() {
                continue;
            }
            let luminance: Vec<f32> = mesh
                .positions
                .iter()
                .zip(&mesh.normals)
                .map(|(&p, &n)| lum(raycast::shade::shade(scene, object, p, n, eye)).max(0.0))
                .collect();
            for &l in &luminance {
                lo = lo.min(l);
                hi = hi.max(l);
            }
            let tree =
                VertexTree::build(&mesh.positions, &mesh.normals, &luminance, &mesh.triangles)
                    .map_err(|e| format!("object {object}: level of detail: {e}"))?;
            triangles_full += tree.triangles().len();
            objects.push(ObjectLod {
                object,
                cells: TreeCut::new(tree, |t| Cut::new(t)),
            });
        }
        let scene_contrast = if hi + lo > 0.0 {
            f64::from((hi - lo) / (hi + lo)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Ok(Self {
            method,
            objects,
            mode,
            options,
            vergence_mm: None,
            thresholds: ThresholdTable::from_model(&GeislerPerry::default()),
            thresholds_source: DEFAULT_THRESHOLDS.to_string(),
            scene_contrast,
            triangles_full,
            triangles: Vec::new(),
            positions: Vec::new(),
            normals: Vec::new(),
            scratch: RasterScratch::default(),
            last: ModelBasedStats::default(),
        })
    }

    /// Replaces the threshold table `Method::Simplify` judges folds by (a
    /// participant's, `psychophysics::participant`); `source` says where
    /// it came from in `explain`. `Method::Lod`'s Murphy–Duchowski levels
    /// are fixed angles and do not read it. The next frame selects anew.
    pub fn set_thresholds(&mut self, table: ThresholdTable, source: String) {
        self.thresholds = table;
        self.thresholds_source = source;
    }

    /// `Method::Lod` only: selects by `extents_deg` (rows = depths 0..=4,
    /// columns = levels 5 … 1, degrees; a participant's degradation table,
    /// `foveation::degradation::DegradationTable`) in place of Murphy &
    /// Duchowski's Table 1, with the same level allowances; `None` goes back
    /// to Table 1. Extents must be finite and ≥ 0. The next frame selects
    /// anew.
    pub fn set_degradation(&mut self, extents_deg: Option<[[f64; 5]; 5]>) -> Result<(), String> {
        let level_angle_deg = match self.mode {
            Mode::MurphyDuchowski { level_angle_deg }
            | Mode::MurphyDuchowskiTable {
                level_angle_deg, ..
            } => level_angle_deg,
            _ => {
                return Err(format!(
                    "{}: a degradation table drives the lod method only",
                    self.method.name()
                ))
            }
        };
        if let Some(t) = &extents_deg {
            if let Some(x) = t.iter().flatten().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(format!(
                    "degradation extents must be finite and ≥ 0 degrees, got {x}"
                ));
            }
        }
        self.mode = match extents_deg {
            Some(extents_deg) => Mode::MurphyDuchowskiTable {
                level_angle_deg,
                extents_deg,
            },
            None => Mode::MurphyDuchowski { level_angle_deg },
        };
        Ok(())
    }

    /// The threshold table in use.
    pub fn thresholds(&self) -> &ThresholdTable {
        &self.thresholds
    }

    /// The Michelson contrast of the scene's brightest and darkest vertex
    /// and its background.
    pub fn scene_contrast(&self) -> f64 {
        self.scene_contrast
    }

    /// The eye distance (mm) of the binocular 3-D gaze point for the next
    /// frame (Murphy & Duchowski eqs 1–3); `Method::Lod` places the gaze
    /// point there along the gaze ray. Holds for one frame; a non-finite or
    /// non-positive depth counts as none.
    pub fn set_vergence_mm(&mut self, depth_mm: Option<f64>) {
        self.vergence_mm = depth_mm.filter(|d| d.is_finite() && *d > 0.0);
    }

    /// The options this state was built with.
    pub fn options(&self) -> ModelBasedOptions {
        self.options
    }

    /// What the last frame did.
    pub fn last(&self) -> &ModelBasedStats {
        &self.last
    }

    /// Selects every object's cut for the gaze and rasterises the result
    /// into `frame`, on the CPU or the GPU (`on`).
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        gaze_px: [f64; 2],
        surface: bool,
        frame: &mut Frame,
        on: RasterOn<'_>,
    ) -> Result<Stats, String> {
        let started = std::time::Instant::now();
        if !(gaze_px[0].is_finite() && gaze_px[1].is_finite()) {
            return Err(format!(
                "the point of regard must be finite, got ({}, {})",
                gaze_px[0], gaze_px[1]
            ));
        }
        let p = [gaze_px[0] as f32, gaze_px[1] as f32];
        let ray = camera.ray(p);
        let vergence = self.vergence_mm.take().filter(|_| {
            matches!(
                self.mode,
                Mode::MurphyDuchowski { .. } | Mode::MurphyDuchowskiTable { .. }
            )
        });
        let gaze_point = match (
            vergence,
            scene.intersect(&ray, 0.0, TriangleTest::Watertight),
        ) {
            (Some(d), _) => ray.origin + ray.dir.normalize() * d as f32,
            (None, Some(h)) => ray.at(h.t),
            (None, None) => camera.screen_point(p),
        };
        let view = View {
            eye_mm: camera.eye,
            gaze_point_mm: (!self.options.ignore_gaze).then_some(gaze_point),
            thresholds: &self.thresholds,
            scene_contrast: self.scene_contrast,
        };
        let mut stats = ModelBasedStats {
            triangles_full: self.triangles_full,
            gaze_point_mm: view.gaze_point_mm,
            gaze_from_vergence: vergence.is_some(),
            ..ModelBasedStats::default()
        };
        self.triangles.clear();
        let shares = self.options.budget.map(|b| budget_shares(b, &self.objects));
        let mut worst: Option<BudgetOutcome> = None;
        for (k, o) in self.objects.iter_mut().enumerate() {
            let mode = match (&shares, self.mode) {
                (Some(s), Mode::Budget { .. }) => Mode::Budget { triangles: s[k] },
                (_, m) => m,
            };
            let report: SelectionReport = o
                .cells
                .with_dependent_mut(|_, cut| cut.select(&view, &mode))
                .map_err(|e| format!("object {}: selection: {e}", o.object))?;
            stats.folds += report.folds;
            stats.unfolds += report.unfolds;
            stats.nodes_visited += report.nodes_visited;
            if let Some(b) = report.budget {
                if worst.is_none_or(|w| b.distance_factor > w.distance_factor) {
                    worst = Some(b);
                }
            }
            o.cells.with_dependent(|_, cut| {
                cut.triangles_into(&mut self.positions);
                cut.normals_into(&mut self.normals);
            });
            let object = o.object;
            self.triangles.extend(
                self.positions
                    .iter()
                    .zip(&self.normals)
                    .map(|(&p, &n)| WorldTriangle { p, n, object }),
            );
        }
        stats.triangles_drawn = self.triangles.len();
        stats.budget = self
            .options
            .budget
            .zip(worst)
            .map(|(budget, outcome)| BudgetReport { budget, outcome });
        stats.select_ms = started.elapsed().as_secs_f64() * 1e3;
        let r = match on {
            RasterOn::Cpu => raster::rasterize(
                scene,
                camera,
                &self.triangles,
                surface,
                frame,
                &mut self.scratch,
            ),
            RasterOn::Gpu(g) => g
                .rasterize(camera, &self.triangles, surface, frame)
                .map_err(|e| format!("the GPU backend: {e}"))?,
        };
        stats.raster_ms = r.time_ms;
        stats.raster = r;
        self.last = stats;
        Ok(Stats {
            time_ms: started.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        })
    }
}

/// Each object's share of a scene's triangle budget: in proportion to its
/// full triangle count, rounded down (the shares never sum above `budget`).
fn budget_shares(budget: usize, objects: &[ObjectLod]) -> Vec<usize> {
    let counts: Vec<usize> = objects
        .iter()
        .map(|o| o.cells.borrow_owner().triangles().len())
        .collect();
    proportional_shares(budget, &counts)
}

/// The model-based methods as the renderer runs them (`methods::simplify`
/// and `methods::lod` make this state).
impl FrameMethod for ModelBased {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        self.set_vergence_mm(input.vergence_mm);
        let on = match input.gpu {
            None => RasterOn::Cpu,
            Some(g) => RasterOn::Gpu(g),
        };
        ModelBased::render(
            self,
            input.scene,
            input.camera,
            input.gaze_px,
            input.surface,
            frame,
            on,
        )
        .map_err(RenderError::Unsupported)
    }

    fn detail(&self, on: &MethodContext<'_>) -> String {
        let options = self.options;
        let mode = match (self.method, options.budget) {
            (Method::Simplify, Some(b)) => format!(
                "Luebke–Hallen best-effort mode under a budget of {b} triangles, thresholds: {}",
                self.thresholds_source
            ),
            (Method::Simplify, None) => format!(
                "Luebke–Hallen imperceptible mode, thresholds: {}",
                self.thresholds_source
            ),
            _ if matches!(self.mode, Mode::MurphyDuchowskiTable { .. }) => {
                "Murphy–Duchowski levels by a degradation table in place of Table 1 (fixed \
                 angles: no threshold table)"
                    .to_string()
            }
            _ => "Murphy–Duchowski Table 1 levels (fixed angles: no threshold table)".to_string(),
        };
        let mode = if options.ignore_gaze {
            format!("{mode}, without the gaze: every node foveal")
        } else {
            mode
        };
        format!(
            "per frame: select each object's vertex-tree cut incrementally ({mode}, CPU), \
             then rasterise the active triangles with the ray caster's shading ({})",
            match on.side {
                Side::Cpu => "CPU z-buffer",
                Side::Gpu => {
                    "GPU render pipeline: triangles uploaded per frame, off-axis frustum, \
                     depth buffer; effect passes on the CPU (the raster path has no \
                     GPU pass hook)"
                }
            }
        )
    }

    fn owns(&self, _: Side) -> String {
        "each object's vertex tree and cut".into()
    }

    fn model_based_mut(&mut self) -> Option<&mut ModelBased> {
        Some(self)
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// `budget` split in proportion to `counts`, rounded down; all of it to a
/// single entry.
pub fn proportional_shares(budget: usize, counts: &[usize]) -> Vec<usize> {
    let total: u128 = counts.iter().map(|&c| c as u128).sum();
    if counts.len() == 1 {
        return vec![budget];
    }
    counts
        .iter()
        // u128: budget · count cannot overflow; no triangles at all: 0 each.
        .map(|&c| {
            (budget as u128 * c as u128)
                .checked_div(total)
                .map_or(0, |s| s as usize)
        })
        .collect()
}

/// An object's triangles as an indexed mesh.
pub struct Welded {
    /// Vertex positions, world millimetres.
    pub positions: Vec<Vec3>,
    /// Vertex normals, one per position.
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// Every object's world triangles as an indexed mesh (index = object id),
/// welded by exact corner position, in one pass over the scene.
pub fn weld(scene: &Scene) -> Vec<Welded> {
    let n = scene.object_materials.len();
    let mut index: Vec<std::collections::HashMap<[u32; 3], u32>> = vec![Default::default(); n];
    let mut out: Vec<Welded> = (0..n)
        .map(|_| Welded {
            positions: Vec::new(),
            normals: Vec::new(),
            triangles: Vec::new(),
        })
        .collect();
    for t in &scene.triangles {
        let o = t.object as usize;
        let (Some(mesh), Some(index)) = (out.get_mut(o), index.get_mut(o)) else {
            continue;
        };
        let mut tri = [0u32; 3];
        for (slot, (&p, &n)) in tri.iter_mut().zip(t.p.iter().zip(&t.n)) {
            let key = p.to_array().map(f32::to_bits);
            *slot = *index.entry(key).or_insert_with(|| {
                mesh.positions.push(p);
                mesh.normals.push(n);
                (mesh.positions.len() - 1) as u32
            });
        }
        mesh.triangles.push(tri);
    }
    out
}
