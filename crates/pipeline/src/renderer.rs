//! [`Renderer`]: the one entry that renders a frame.

use foveation::{Layout, SamplingModel};
use raycast::gpu::{GpuError, Traffic};
use raycast::ray::TriangleTest;
use raycast::render::{Scratch, StageTimes, Stats, Triggers};
use raycast::{Camera, Frame, Scene};

use crate::backend::{Backend, BackendChoice};
use crate::effects::depth_of_field::DepthOfField;
use crate::effects::dof_splat::DepthOfFieldSplat;
use crate::effects::por_overlay::PorOverlay;
use crate::effects::{pass_for, passes_for, GpuPass, Pass, PassInput};
use crate::frame_attention::AttentionGaze;
use crate::gpu::Chain;
use crate::image_foveation::{ImageFoveation, ImagePass};
use crate::method::Method;
use crate::model_based::{ModelBased, ModelBasedOptions};
use crate::plan::{Channels, FramePlan, Role, Side, Stage};
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodSetup};
use raycast::scene::PostPass;

/// Why a frame could not be rendered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RenderError {
    /// The gaze (or the sampling model) cannot give a ray mask.
    #[error("the point of regard: {0}")]
    Gaze(#[from] foveation::ParamError),
    /// The GPU backend failed ([`GpuError`] says how).
    #[error("the GPU backend: {0}")]
    Gpu(#[from] GpuError),
    /// The method, backend or scene asks for something the renderer cannot
    /// do; the message says what.
    #[error("{0}")]
    Unsupported(String),
}

/// How to render: what a command line chooses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The rendering method.
    pub method: Method,
    /// Where to render: CPU, GPU, or the GPU when there is one.
    pub backend: BackendChoice,
    /// The ray mask's layout (hybrid method).
    pub layout: Layout,
    /// The ray/triangle intersection test.
    pub test: TriangleTest,
    /// Refinement triggers; `None`: the scene's effects decide.
    pub triggers: Option<Triggers>,
    /// Rasterise every cell so that an unowned pixel shows as a gap (tests).
    pub check_coverage: bool,
    /// Draw the POR box even when the scene does not list `PorOverlay`.
    pub por_overlay: bool,
    /// Fill the G-buffer's surface buffers (depth, object id, normal) even
    /// when no pass reads them (tests, debug pictures). Off, they are filled
    /// exactly when a pass needs them.
    pub surface: bool,
    /// The model-based methods' budget and gaze options (checked against
    /// `method`: a budget is for `Method::Simplify` only).
    pub model_based: ModelBasedOptions,
    /// Temporal reuse during fixations (CPU hybrid frames): cast samples
    /// are kept across frames and a bit-identical mask keeps its vertex
    /// rays, classification and owners ([`Scratch::with_reuse`]). The
    /// frames are the same byte for byte; only their time changes. The live
    /// view turns it on; off, nothing of it is allocated.
    pub reuse: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            method: Method::Hybrid,
            backend: BackendChoice::Cpu,
            layout: Layout::Nyquist,
            test: TriangleTest::Watertight,
            triggers: None,
            check_coverage: false,
            por_overlay: false,
            surface: false,
            model_based: ModelBasedOptions::default(),
            reuse: false,
        }
    }
}

/// Eye distances (mm) a measured eye position may set
/// ([`Renderer::set_eye_distance_mm`]): `screen_geometry`'s plausible range.
pub use foveation::EYE_DISTANCE_RANGE_MM;

/// How far (relative) a measured eye distance must move from the one the
/// sampling model has before the model follows it: 1 % (6 mm at 60 cm),
/// so the tracker's noise does not make every frame's mask new.
pub const EYE_DISTANCE_STEP: f64 = 0.01;

/// `Method::Ulod`'s levels (`ULOD5`, Lee's largest set) and attention map size.
pub use crate::methods::ulod::{ULOD_LEVELS, ULOD_MAP_SIZE};

/// A scene on a backend, with the method and the effect passes chosen.
pub struct Renderer<'s> {
    scene: &'s Scene,
    /// A moving scene posed for the last frame's time (`Scene::posed`);
    /// `None` for a static scene, which is rendered as it was built.
    posed: Option<Scene>,
    camera: Camera,
    /// The sampling model the masks are built from: `nominal`, or
    /// `nominal` with a measured eye distance
    /// ([`Renderer::set_eye_distance_mm`]).
    model: SamplingModel,
    /// The model the renderer was made with (the display file's eye).
    nominal: SamplingModel,
    /// The triangle test every ray of the frame uses.
    test: TriangleTest,
    method: Method,
    backend: Backend,
    /// The passes that run on the CPU, after the read-back on the GPU
    /// backend, in order.
    passes: Vec<Box<dyn Pass>>,
    note: Option<String>,
    /// Fill the surface buffers whatever the passes need.
    surface: bool,
    /// A frame given back by [`Renderer::recycle`], whose buffers the next
    /// CPU frame reuses.
    spare: Option<Frame>,
    /// The ray caster's CPU buffers (the hybrid method's mask, vertex hits
    /// and pixel owners; the last frame's stage times), reused frame after
    /// frame; nothing in them is allocated until a method uses them.
    scratch: Scratch,
    /// The wall clock [`Renderer::render`] times frames by (its origin).
    clock: std::time::Instant,
    /// The method's own state, made by its module for it alone.
    state: Box<dyn FrameMethod>,
    /// The next frame's vergence depth ([`Renderer::set_vergence_mm`]).
    vergence_mm: Option<f64>,
    /// Whether the method's GPU frame takes passes between its cast and its
    /// read-back (the ray-cast methods on the GPU backend; the raster path
    /// has no such hook).
    gpu_hook: bool,
    /// The passes that run on the GPU between the cast and the read-back,
    /// in order: the longest run of passes from the first that have a GPU
    /// implementation ([`Pass::into_gpu`]); empty on the CPU backend.
    gpu_passes: Vec<Box<dyn GpuPass>>,
    /// [`Renderer::provenance`]: the plan in one line, rebuilt whenever
    /// the plan changes.
    provenance: String,
    /// Where the thresholds came from ([`Renderer::set_thresholds`]);
    /// `None`: the default Geisler–Perry model.
    thresholds_source: Option<String>,
    /// What the last frame moved between the CPU and the GPU (the GPU
    /// backend; default before the first frame).
    traffic: Traffic,
}

/// The passes split between the GPU (before the read-back) and the CPU.
type SplitPasses = (Vec<Box<dyn GpuPass>>, Vec<Box<dyn Pass>>);

/// Moves every pass it can to the GPU: the longest run from the first
/// whose passes have a GPU implementation; the first without one (and all
/// after it) stay on the CPU, after the read-back. With no GPU hook,
/// every pass stays on the CPU.
fn split_passes(passes: Vec<Box<dyn Pass>>, gpu_hook: bool) -> SplitPasses {
    let mut gpu = Vec::new();
    let mut cpu: Vec<Box<dyn Pass>> = Vec::new();
    for pass in passes {
        if gpu_hook && cpu.is_empty() {
            match pass.into_gpu() {
                Ok(g) => gpu.push(g),
                Err(p) => cpu.push(p),
            }
        } else {
            cpu.push(pass);
        }
    }
    (gpu, cpu)
}

impl<'s> Renderer<'s> {
    /// Chooses the backend (the GPU's scene upload happens here), the method
    /// the scene allows, and the passes its effects ask for.
    pub fn new(
        scene: &'s Scene,
        camera: Camera,
        model: SamplingModel,
        options: &Options,
    ) -> Result<Self, RenderError> {
        Self::new_on(scene, camera, model, options, None)
    }

    /// [`Renderer::new`], on the GPU device `gpu` when the backend chosen
    /// is the GPU (a device shared with a window that presents the frames,
    /// and with the renderers made before and after this one) instead of a
    /// device of its own.
    pub fn new_on(
        scene: &'s Scene,
        camera: Camera,
        model: SamplingModel,
        options: &Options,
        gpu: Option<&raycast::gpu::SharedDevice>,
    ) -> Result<Self, RenderError> {
        options
            .model_based
            .check(options.method)
            .map_err(RenderError::Unsupported)?;
        let method = options.method.for_scene(scene);
        let module = method.module();
        if scene.is_moving() && module.static_scene {
            return Err(RenderError::Unsupported(format!(
                "method {}: this scene moves (a camera path or object motion), and the \
                 model-based methods build their levels from the scene once; choose the \
                 full, hybrid or image method",
                method.name()
            )));
        }
        // The model-based methods rasterise on the backend chosen the same
        // way (on the GPU: its render pipeline, `GpuRenderer::rasterize`).
        let (backend, note) = if !module.gpu {
            if options.backend == BackendChoice::Gpu {
                return Err(RenderError::Unsupported(format!(
                    "method {} renders on the CPU only; choose the CPU backend or auto",
                    method.name()
                )));
            }
            let note = (options.backend == BackendChoice::Auto)
                .then(|| format!("auto: method {} renders on the CPU", method.name()));
            (Backend::Cpu, note)
        } else {
            // A moving scene is posed and its BVH rebuilt on the CPU every
            // frame; on the GPU the posed scene is uploaded for the frame
            // (`GpuRenderer::set_scene`).
            Backend::choose(options.backend, scene, options.test, gpu)?
        };
        let mut state = (module.make)(&MethodSetup {
            scene,
            camera: &camera,
            model: &model,
            options,
        })?;
        // The method's passes, then the scene's, in its file's order.
        let mut passes = state.own_passes();
        passes.extend(passes_for(scene, options.por_overlay));
        // The ray-cast methods' GPU frames take passes before their
        // read-back; the raster path and the modules' frames do not.
        let gpu_hook = matches!(backend, Backend::Gpu(_)) && module.gpu_post;
        let (mut gpu_passes, mut passes) = split_passes(passes, gpu_hook);
        // The passes know the model from the start (`explain` before the
        // first frame); each frame gives it again (the eye may move).
        gpu_passes.iter_mut().for_each(|p| p.prepare(&model));
        passes.iter_mut().for_each(|p| p.prepare(&model));
        let mut renderer = Self {
            state,
            scene,
            posed: None,
            camera,
            model,
            nominal: model,
            test: options.test,
            method,
            backend,
            passes,
            note,
            surface: options.surface,
            spare: None,
            scratch: if options.reuse {
                Scratch::with_reuse()
            } else {
                Scratch::default()
            },
            clock: std::time::Instant::now(),
            vergence_mm: None,
            gpu_hook,
            gpu_passes,
            provenance: String::new(),
            traffic: Traffic::default(),
            thresholds_source: None,
        };
        renderer.provenance = renderer.plan().provenance();
        Ok(renderer)
    }

    /// Whether this frame's method must fill the surface buffers.
    fn wants_surface(&self) -> bool {
        // On the GPU backend this is what comes back: the GPU passes read
        // the frame's buffers where they are.
        self.surface || self.passes.iter().any(|p| p.needs_surface())
    }

    /// The eye distance of the binocular 3-D gaze point (mm) for the next
    /// frame, from the tracker sample it is rendered for (see
    /// `tracker_hal::events::vergence_point`); depth of field's `focus:
    /// Vergence` reads it. It holds for one frame: a frame rendered without
    /// a new call has none (falls back to the gaze's depth).
    pub fn set_vergence_mm(&mut self, depth_mm: Option<f64>) {
        self.vergence_mm = depth_mm.filter(|d| d.is_finite() && *d > 0.0);
    }

    /// The eye's measured distance from the screen (mm) for the next
    /// frames' ray masks (Murphy 2007 §8.2.2, "dynamic ray mask
    /// generation"): a nearer eye sees each pixel under a larger angle and
    /// needs more rays, a farther one fewer. The sampling model takes the
    /// distance when it differs by more than [`EYE_DISTANCE_STEP`] from
    /// the model's; `None` (no measurement) returns to the display file's
    /// distance; a distance outside [`EYE_DISTANCE_RANGE_MM`] or not finite
    /// is ignored. Only the masks follow: the camera, and so the picture,
    /// stay the display file's (the stimulus does not move with the head).
    /// Returns whether the model changed (the next mask is new).
    pub fn set_eye_distance_mm(&mut self, distance_mm: Option<f64>) -> bool {
        let target = match distance_mm {
            None => self.nominal,
            Some(d) if d.is_finite() && EYE_DISTANCE_RANGE_MM.contains(&d) => {
                let now = self.model.geometry.eye_distance_mm;
                if (d - now).abs() <= EYE_DISTANCE_STEP * now {
                    return false;
                }
                let mut m = self.nominal;
                m.geometry.eye_distance_mm = d;
                m
            }
            Some(_) => return false,
        };
        let changed = target != self.model;
        self.model = target;
        changed
    }

    /// The sampling model the next frame is rendered under.
    pub fn sampling_model(&self) -> &SamplingModel {
        &self.model
    }

    /// The eye distance (mm) the ray masks are built for.
    pub fn eye_distance_mm(&self) -> f64 {
        self.model.geometry.eye_distance_mm
    }

    /// Gives a frame back for the next one to reuse its buffers: a loop
    /// that renders frame after frame of one size then allocates nothing
    /// per frame on the CPU.
    pub fn recycle(&mut self, frame: Frame) {
        self.spare = Some(frame);
    }

    /// Renders one frame for the point of regard `gaze_px` (screen pixels):
    /// the method fills the G-buffer, then the effect passes run. `Stats`
    /// time the method. Passes with dynamics (depth of field's refocusing)
    /// are timed by the wall clock (seconds since the renderer was made).
    pub fn render(&mut self, gaze_px: [f64; 2]) -> Result<(Frame, Stats), RenderError> {
        let time_s = self.clock.elapsed().as_secs_f64();
        self.render_at(gaze_px, time_s)
    }

    /// [`Renderer::render`] for a frame at `time_s` (seconds, any fixed
    /// origin) instead of the wall clock: scripted, deterministic frames.
    /// A NaN or infinite time is refused by the passes with dynamics (they
    /// hold their state).
    ///
    /// The frame walks the plan ([`Renderer::plan`]): the method, the GPU
    /// passes chained between its cast and its read-back, then the CPU
    /// passes. The passes that belong to the method (image-based
    /// foveation's blur) count in its time.
    pub fn render_at(
        &mut self,
        gaze_px: [f64; 2],
        time_s: f64,
    ) -> Result<(Frame, Stats), RenderError> {
        let surface = self.wants_surface();
        // A moving scene is posed for this frame's time (once per time).
        let mut posed_now = false;
        if self.scene.is_moving() {
            let posed_at = self.posed.as_ref().and_then(|s| s.pose()).map(|p| p.time_s);
            if posed_at.map(f64::to_bits) != Some(time_s.to_bits()) {
                self.posed = self.scene.posed(time_s);
                posed_now = true;
            }
        }
        let traffic_before = self.gpu_traffic_total();
        // On the GPU the pose is uploaded: the frame's traffic counts it.
        if let (true, Backend::Gpu(g)) = (posed_now, &mut self.backend) {
            g.set_scene(self.posed.as_ref().unwrap_or(self.scene))?;
        }
        let scene: &Scene = self.posed.as_ref().unwrap_or(self.scene);
        // The vergence depth holds for this frame only.
        let vergence_mm = self.vergence_mm.take();
        for pass in &mut self.gpu_passes {
            pass.prepare(&self.model);
        }
        for pass in &mut self.passes {
            pass.prepare(&self.model);
        }
        let input = PassInput {
            scene,
            camera: &self.camera,
            gaze_px,
            time_s: Some(time_s),
            vergence_mm,
        };
        let mut frame = self.spare.take().unwrap_or_default();
        let gpu = match &mut self.backend {
            Backend::Cpu => None,
            Backend::Gpu(g) => Some(g.as_mut()),
        };
        // The GPU passes, encoded between the cast and the read-back.
        let mut chain = Chain {
            passes: &mut self.gpu_passes,
            input: &input,
        };
        let post = (gpu.is_some() && self.gpu_hook && !chain.passes.is_empty())
            .then_some(&mut chain as &mut dyn raycast::gpu::GpuPost);
        let mut stats = self.state.render(
            MethodFrame {
                scene,
                camera: &self.camera,
                model: &self.model,
                test: self.test,
                gaze_px,
                time_s,
                vergence_mm,
                surface,
                scratch: &mut self.scratch,
                gpu,
                post,
            },
            &mut frame,
        )?;
        for pass in &mut self.passes {
            let started = std::time::Instant::now();
            pass.run(&mut frame, &input);
            if pass.role() == Role::MethodPass {
                // The method is the cast and its own passes (on the GPU
                // they are in the frame's time already).
                stats.time_ms += started.elapsed().as_secs_f64() * 1e3;
            }
        }
        if let (Some(before), Some(after)) = (traffic_before, self.gpu_traffic_total()) {
            self.traffic = after.since(before);
        }
        Ok((frame, stats))
    }

    /// Whether this renderer's frames can stay on the GPU for a window on
    /// the same device to present ([`Renderer::set_stay_on_gpu`]): `Ok` on
    /// the GPU backend for a ray-cast method whose passes all run on the
    /// GPU; otherwise why not (a CPU pass reads the frame, the raster path
    /// reads back, the CPU backend renders on the CPU).
    pub fn can_stay_on_gpu(&self) -> Result<(), String> {
        match &self.backend {
            Backend::Cpu => Err("the CPU backend renders on the CPU".into()),
            Backend::Gpu(_) if !self.gpu_hook => Err(format!(
                "the {} method's GPU frame (the raster path) is read back",
                self.method.name()
            )),
            Backend::Gpu(_) if !self.passes.is_empty() => Err(format!(
                "the pass(es) {} run on the CPU and read the frame",
                self.passes
                    .iter()
                    .map(|p| p.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            Backend::Gpu(_) => Ok(()),
        }
    }

    /// Keeps each frame on the GPU (`on`) or reads it back (the default).
    /// On, [`Renderer::render`] returns a [`Frame::on_device`] (its size, no
    /// pixels) and [`Renderer::gpu_frame_pixels`] is the frame to present;
    /// refused with [`Renderer::can_stay_on_gpu`]'s reason where it cannot.
    pub fn set_stay_on_gpu(&mut self, on: bool) -> Result<(), String> {
        if on {
            self.can_stay_on_gpu()?;
        }
        if let Backend::Gpu(g) = &mut self.backend {
            g.set_read_back(!on);
        }
        self.rebuild_provenance();
        Ok(())
    }

    /// Whether frames stay on the GPU ([`Renderer::set_stay_on_gpu`]).
    pub fn stays_on_gpu(&self) -> bool {
        matches!(&self.backend, Backend::Gpu(g) if !g.reads_back())
    }

    /// The GPU device the frames are rendered on (the GPU backend), for a
    /// window that presents them there.
    pub fn gpu_device(&self) -> Option<raycast::gpu::SharedDevice> {
        match &self.backend {
            Backend::Gpu(g) => Some(g.shared()),
            Backend::Cpu => None,
        }
    }

    /// The last frame's pixel words on the GPU and its size (the GPU
    /// backend, after a frame): what a window on the same device presents.
    pub fn gpu_frame_pixels(&self) -> Option<(&raycast::gpu::wgpu::Buffer, (u32, u32))> {
        match &self.backend {
            Backend::Gpu(g) => g.frame_pixels(),
            Backend::Cpu => None,
        }
    }

    /// Reads the last GPU frame back now (a screenshot of a frame that
    /// stayed on the GPU); the passes' output included, since they ran on
    /// the GPU before it.
    pub fn read_last_gpu_frame(&self) -> Result<Frame, RenderError> {
        match &self.backend {
            Backend::Gpu(g) => Ok(g.read_last_frame()?),
            Backend::Cpu => Err(RenderError::Unsupported(
                "the CPU backend's frames are on the CPU already".into(),
            )),
        }
    }

    /// The method that runs (the one asked for, or `Full` when the scene
    /// does not sample `Foveated`).
    pub fn method(&self) -> Method {
        self.method
    }

    /// The scene being rendered: for a moving scene, as posed for the last
    /// frame (as built before the first).
    pub fn scene(&self) -> &Scene {
        self.posed.as_ref().unwrap_or(self.scene)
    }

    /// The camera (the eye through the display).
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// `"cpu"` or `"gpu"`.
    pub fn backend_name(&self) -> &'static str {
        match self.backend {
            Backend::Cpu => "cpu",
            Backend::Gpu(_) => "gpu",
        }
    }

    /// The GPU adapter (name, API, type, driver) when the GPU renders.
    pub fn adapter(&self) -> Option<&str> {
        match &self.backend {
            Backend::Cpu => None,
            Backend::Gpu(g) => Some(g.adapter()),
        }
    }

    /// Everything the GPU backend has moved so far (`None` on the CPU).
    fn gpu_traffic_total(&self) -> Option<Traffic> {
        match &self.backend {
            Backend::Cpu => None,
            Backend::Gpu(g) => Some(g.traffic_total()),
        }
    }

    /// What the last frame moved between the CPU and the GPU, when the GPU
    /// renders (`None` on the CPU backend): bytes uploaded
    /// (`write_buffer`, buffers made with contents) and read back (ranges
    /// mapped for reading), compute dispatches, draws and queue
    /// submissions of the method's frame and of every GPU pass chained in
    /// it, counted at the `wgpu` calls (`raycast::gpu::TrafficCounter`).
    /// A frame that failed leaves the last good frame's figures. All zero
    /// before the first frame.
    pub fn gpu_traffic(&self) -> Option<Traffic> {
        match &self.backend {
            Backend::Cpu => None,
            Backend::Gpu(_) => Some(self.traffic),
        }
    }

    /// GPU time per stage of the last frame (ms), when the GPU renders and
    /// its adapter has timestamp queries; empty otherwise.
    pub fn stage_ms(&self) -> &[(&'static str, f64)] {
        match &self.backend {
            Backend::Cpu => &[],
            Backend::Gpu(g) => g.stage_ms(),
        }
    }

    /// CPU wall time per stage of the last CPU frame (ms): mask, vertex
    /// rays, classification, margin, ownership, pixels (all zero before the
    /// first CPU frame; a full-resolution frame spends it all in pixels).
    pub fn cpu_stages(&self) -> &StageTimes {
        self.scratch.stages()
    }

    /// What temporal reuse did in the last CPU frame (all zero with
    /// [`Options::reuse`] off).
    pub fn reuse_stats(&self) -> raycast::render::ReuseStats {
        self.scratch.reuse_stats()
    }

    /// The method's state (downcast with [`FrameMethod::as_any`] to the
    /// module's type).
    pub fn method_state(&self) -> &dyn FrameMethod {
        self.state.as_ref()
    }

    /// `Method::Ulod`'s state (levels, attention, last frame's counts), when
    /// it runs; `None` otherwise (nothing of it is built for other methods).
    pub fn ulod(&self) -> Option<&crate::ulod::Ulod> {
        self.state
            .as_any()
            .downcast_ref::<crate::methods::ulod::UlodMethod>()
            .map(|u| &u.ulod)
    }

    /// Gives the renderer a participant's thresholds: `table` is what
    /// `Method::Simplify` judges its folds by (the other methods do not
    /// read a table), `source` names them in [`Renderer::explain`]. The
    /// ray-cast methods' CSF is the sampling model's: build it with the
    /// participant's fitted parameters ([`crate::sampling_model_with`]).
    pub fn set_thresholds(
        &mut self,
        table: foveation::perceptibility::ThresholdTable,
        source: String,
    ) {
        if let Some(m) = self.state.model_based_mut() {
            m.set_thresholds(
                table,
                "the participant's table, the fitted model outside its grid (see `thresholds:`)"
                    .into(),
            );
        }
        self.thresholds_source = Some(source);
        self.rebuild_provenance();
    }

    /// [`Renderer::provenance`] from the plan; it (a frame's `plan` in an
    /// experiment) names the thresholds when they are not the default.
    fn rebuild_provenance(&mut self) {
        self.provenance = self.plan().provenance();
        if let Some(s) = &self.thresholds_source {
            self.provenance = format!("{}; thresholds: {s}", self.provenance);
        }
    }

    /// Where the thresholds came from, as `explain` says it.
    pub fn thresholds_source(&self) -> String {
        match &self.thresholds_source {
            Some(s) => s.clone(),
            None => {
                let m = self.nominal.csf;
                format!(
                    "the default Geisler–Perry model (CT0 {:.4}, α {:.3}, e2 {:.1}°)",
                    m.ct0, m.alpha, m.e2_deg
                )
            }
        }
    }

    /// The model-based method's state (trees, cuts, last frame's counts),
    /// when a model-based method runs; `None` otherwise.
    pub fn model_based(&self) -> Option<&ModelBased> {
        self.state.as_any().downcast_ref()
    }

    /// The model-based method's state, to change how it selects (e.g.
    /// [`ModelBased::set_degradation`]); `None` for the other methods.
    pub fn model_based_mut(&mut self) -> Option<&mut ModelBased> {
        self.state.model_based_mut()
    }

    /// Every pass in the plan's order, as its CPU reference: the GPU
    /// passes' references, then the CPU passes.
    fn all_passes(&self) -> impl Iterator<Item = &dyn Pass> {
        self.gpu_passes
            .iter()
            .map(|p| p.reference())
            .chain(self.passes.iter().map(|p| p.as_ref()))
    }

    /// The GPU pass whose CPU reference is a `P`.
    fn gpu_pass<P: 'static>(&self) -> Option<&dyn GpuPass> {
        self.gpu_passes
            .iter()
            .find(|p| p.reference().as_any().is::<P>())
            .map(|p| p.as_ref())
    }

    /// The image-based method's pass (on either side), when it runs.
    fn image_pass(&self) -> Option<&ImagePass> {
        self.all_passes().find_map(|p| p.as_any().downcast_ref())
    }

    /// Wall time of the last frame's image-based blur (ms), after the full
    /// frame the method casts first (on the GPU backend: the CPU's level
    /// map only, the blur runs in the frame); 0 for other methods.
    pub fn image_ms(&self) -> f64 {
        self.image_pass().map_or(0.0, |p| p.ms())
    }

    /// The image-based method's filter (its pyramid and level map), when
    /// that method runs; `None` otherwise: no other method allocates it.
    pub fn image_foveation(&self) -> Option<&ImageFoveation> {
        self.image_pass().map(|p| p.filter())
    }

    /// Whether the GPU backend holds depth of field's buffers (the colour
    /// pyramid and its depth and blur mips; false on the CPU backend): only
    /// a scene that lists `DepthOfField` makes them, with its first frame.
    pub fn has_dof_buffers(&self) -> bool {
        self.gpu_pass::<DepthOfField>()
            .is_some_and(|p| p.has_buffers())
    }

    /// Whether the GPU backend holds the splat pass's buffers (V and H
    /// samples, the hidden image, the fixed-point layers; false on the CPU
    /// backend): only a scene that lists `DepthOfField(method: Splat)` makes
    /// them, with its first frame.
    pub fn has_splat_buffers(&self) -> bool {
        self.gpu_pass::<DepthOfFieldSplat>()
            .is_some_and(|p| p.has_buffers())
    }

    /// Whether the GPU backend holds the attention model's shader and
    /// buffers (false on the CPU backend, whose model reads the frame read
    /// back): only depth of field with `focus: Attention` makes them, with
    /// its first frame.
    pub fn has_attention_buffers(&self) -> bool {
        self.gpu_passes.iter().any(|p| p.has_attention_buffers())
    }

    /// Whether the GPU backend holds image-based foveation's pyramid and
    /// level-map buffers (false on the CPU backend, whose pyramid is
    /// [`Renderer::image_foveation`]'s): only `Method::Image` makes them.
    pub fn has_image_pyramid_buffers(&self) -> bool {
        self.gpu_pass::<ImagePass>()
            .is_some_and(|p| p.has_buffers())
    }

    /// The passes that run on the GPU between the cast and the read-back,
    /// in order (empty on the CPU backend).
    pub fn gpu_pass_names(&self) -> Vec<&'static str> {
        self.gpu_passes
            .iter()
            .map(|p| p.reference().name())
            .collect()
    }

    /// The focal depth of the last frame depth of field blurred (mm, after
    /// the refocusing dynamics), when it runs on the GPU; `None` otherwise.
    pub fn gpu_focal_depth_mm(&self) -> Option<f64> {
        self.gpu_passes.iter().find_map(|p| p.focal_depth_mm())
    }

    /// Whether the GPU backend holds the raster path's pipelines and
    /// buffers (false on the CPU): only a model-based method on the GPU
    /// makes them, with its first frame.
    pub fn has_raster_buffers(&self) -> bool {
        match &self.backend {
            Backend::Cpu => false,
            Backend::Gpu(g) => g.has_raster_buffers(),
        }
    }

    /// Whether the GPU backend holds the hybrid method's buffers (false on
    /// the CPU): a full-resolution scene must never allocate them.
    pub fn has_foveated_buffers(&self) -> bool {
        match &self.backend {
            Backend::Cpu => false,
            Backend::Gpu(g) => g.has_foveated_buffers(),
        }
    }

    /// Why `auto` chose the backend it did, when that needs saying.
    pub fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// Turns the POR box on or off (the viewer's `P` key), whether or not
    /// the scene lists `PorOverlay`. It goes last in the plan: on the GPU
    /// when every pass before it is there.
    pub fn set_por_overlay(&mut self, on: bool) {
        let is_por = |p: &dyn Pass| p.as_any().is::<PorOverlay>();
        self.passes.retain(|p| !is_por(p.as_ref()));
        self.gpu_passes.retain(|p| !is_por(p.reference()));
        if on {
            let pass = match self.scene.pass(&PostPass::POR_OVERLAY) {
                Some(e) => pass_for(e),
                None => Some(Box::new(PorOverlay::default()) as Box<dyn Pass>),
            };
            let (gpu, cpu) = split_passes(
                pass.into_iter().collect(),
                self.gpu_hook && self.passes.is_empty(),
            );
            self.gpu_passes.extend(gpu);
            self.passes.extend(cpu);
        }
        self.rebuild_provenance();
    }

    /// Runs Lee's attention model as the gaze source on every frame
    /// (`Some`), a pass after every other ([`AttentionGaze`]: on the GPU
    /// backend on the GPU frame, when every pass before it is there), or
    /// stops it (`None`). The surface buffers it reads are filled.
    pub fn set_attention_gaze(&mut self, model: Option<crate::frame_attention::FrameAttention>) {
        let is_it = |p: &dyn Pass| p.as_any().is::<AttentionGaze>();
        self.passes.retain(|p| !is_it(p.as_ref()));
        self.gpu_passes.retain(|p| !is_it(p.reference()));
        if let Some(model) = model {
            let pass: Box<dyn Pass> = Box::new(AttentionGaze::new(model));
            let (gpu, cpu) = split_passes(vec![pass], self.gpu_hook && self.passes.is_empty());
            self.gpu_passes.extend(gpu);
            self.passes.extend(cpu);
        }
        self.rebuild_provenance();
    }

    /// The attention gaze source's point of regard from the last frame
    /// (screen px): `None` without the source, before its first frame, or
    /// when nothing was attended.
    pub fn attention_gaze_px(&self) -> Option<[f64; 2]> {
        self.all_passes()
            .find_map(|p| p.as_any().downcast_ref::<AttentionGaze>())
            .and_then(AttentionGaze::gaze_px)
    }

    /// Whether the POR box is drawn.
    pub fn por_overlay(&self) -> bool {
        self.all_passes().any(|p| p.as_any().is::<PorOverlay>())
    }

    /// The depth-of-field pass, when the scene lists it and it runs on the
    /// CPU (its focus and the last frame's CoC and mip-level maps).
    pub fn depth_of_field(&self) -> Option<&crate::effects::depth_of_field::DepthOfField> {
        self.passes.iter().find_map(|p| p.as_any().downcast_ref())
    }

    /// The effect passes that run after the method, in order, on either
    /// side ([`Renderer::gpu_pass_names`] names those on the GPU).
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.all_passes()
            .filter(|p| p.role() == Role::Effect)
            .map(|p| p.name())
            .collect()
    }

    /// The frame plan: the method's stage, then every pass in the order
    /// they run, each with what it reads, writes and owns and its side;
    /// [`FramePlan::readback`] says where the GPU frame comes back. Built
    /// from the lists `render_at` walks.
    pub fn plan(&self) -> FramePlan {
        let side = match self.backend {
            Backend::Cpu => Side::Cpu,
            Backend::Gpu(_) => Side::Gpu,
        };
        let surface = if self.wants_surface()
            || self
                .gpu_passes
                .iter()
                .any(|p| p.reference().needs_surface())
        {
            Channels::SURFACE
        } else {
            Channels::NONE
        };
        let on = MethodContext {
            model: &self.model,
            side,
            reuse: self.scratch.reuse(),
        };
        let mut stages = vec![Stage {
            name: self.method.name().to_string(),
            role: Role::Method,
            side,
            reads: Channels::NONE,
            writes: self.state.writes() | surface,
            owns: self.state.owns(side),
            detail: self.state.detail(&on),
        }];
        for p in &self.gpu_passes {
            let r = p.reference();
            stages.push(Stage {
                name: r.name().to_string(),
                role: r.role(),
                side: Side::Gpu,
                reads: r.reads(),
                writes: r.writes(),
                owns: p.owns(),
                detail: p.detail(),
            });
        }
        for p in &self.passes {
            stages.push(Stage {
                name: p.name().to_string(),
                role: p.role(),
                side: Side::Cpu,
                reads: p.reads(),
                writes: p.writes(),
                owns: p.owns(),
                detail: p.name().to_string(),
            });
        }
        FramePlan {
            method: self.method.name(),
            backend: side,
            stages,
            stays_on_gpu: self.stays_on_gpu(),
        }
    }

    /// One line that says what this renderer draws, for every frame's
    /// record (`frames.tsv`, `trials.tsv`, the live view's log): the method
    /// that runs, the backend, and the passes in order with where each
    /// runs, e.g. `image on gpu; passes: image-based foveation (gpu)
    /// → POR box (cpu)`. No tabs or line breaks.
    /// Built when the plan is (at set-up and by
    /// [`Renderer::set_por_overlay`]), not per frame.
    pub fn provenance(&self) -> String {
        self.provenance.clone()
    }

    /// What runs for one frame, as `view --explain` prints it: the method,
    /// what it does, each GPU pass, the effect passes, then the frame plan
    /// itself (every stage with what it reads, writes and owns, and the
    /// read-back).
    pub fn explain(&self) -> Vec<String> {
        let s = self.scene;
        let on = match &self.backend {
            Backend::Cpu => "cpu".to_string(),
            Backend::Gpu(g) => format!("gpu ({})", g.adapter()),
        };
        let plan = self.plan();
        let mut out = vec![
            format!(
                "scene {}: sampling {:?}, passes {:?}",
                s.name, s.sampling, s.passes
            ),
            format!("method: {} on {on}", self.method.name()),
            format!("thresholds: {}", self.thresholds_source()),
        ];
        if let Some(m) = s.motion_summary() {
            out.push(format!(
                "scene moves: {m}; posed for each frame's time, every vertex placed and the BVH rebuilt on the CPU"
            ));
        }
        for stage in &plan.stages {
            match (stage.role, stage.side) {
                (Role::Method, _) => out.extend(stage.detail.lines().map(str::to_string)),
                (_, Side::Gpu) => {
                    out.push(format!("GPU pass before the read-back: {}", stage.detail))
                }
                (_, Side::Cpu) => {}
            }
        }
        let passes: Vec<String> = plan
            .passes()
            .filter(|p| p.role == Role::Effect)
            .map(|p| match p.side {
                Side::Gpu => format!("{} (GPU)", p.name),
                Side::Cpu => p.name.clone(),
            })
            .collect();
        out.push(format!(
            "effect passes: {}",
            if passes.is_empty() {
                "none".to_string()
            } else {
                passes.join(" → ")
            }
        ));
        out.extend(plan.lines());
        out
    }
}

#[cfg(test)]
mod tests {
    use super::split_passes;
    use crate::effects::por_overlay::PorOverlay;
    use crate::effects::{GpuPass, Pass, PassInput};
    use raycast::Frame;

    /// A pass with no GPU implementation (every pass a scene can ask for
    /// has one today).
    struct CpuOnly;

    impl Pass for CpuOnly {
        fn name(&self) -> &'static str {
            "cpu only"
        }
        fn run(&mut self, _: &mut Frame, _: &PassInput<'_>) {}
        fn as_any(&self) -> &dyn std::any::Any {
            self
        }
        fn into_gpu(self: Box<Self>) -> Result<Box<dyn GpuPass>, Box<dyn Pass>> {
            Err(self)
        }
    }

    fn passes() -> Vec<Box<dyn Pass>> {
        vec![
            Box::new(PorOverlay::default()),
            Box::new(CpuOnly),
            Box::new(PorOverlay::default()),
        ]
    }

    /// The passes before the first without a GPU implementation run on the
    /// GPU; it and every pass after it (even one with a GPU twin) run on
    /// the CPU, after the read-back; without a GPU hook all stay.
    #[test]
    fn the_first_pass_without_a_gpu_implementation_forces_the_read_back() {
        let (gpu, cpu) = split_passes(passes(), true);
        let names = |v: &[Box<dyn Pass>]| v.iter().map(|p| p.name()).collect::<Vec<_>>();
        assert_eq!(gpu.len(), 1);
        assert_eq!(gpu[0].reference().name(), "POR box");
        assert_eq!(names(&cpu), ["cpu only", "POR box"]);
        let (gpu, cpu) = split_passes(passes(), false);
        assert!(gpu.is_empty());
        assert_eq!(names(&cpu), ["POR box", "cpu only", "POR box"]);
    }
}
