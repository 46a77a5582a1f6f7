//! One trial on the screen: its scenes (search display and target
//! preview), the search display's renderer with the condition's method,
//! the full-resolution reference drawn over its frames, the response
//! times and costs, and what is written when it ends; and the plain
//! screens (text, calibration targets).

use std::path::Path;

use experiment::run::flow::Phase;
use experiment::run::observer::cell_fidelity;
use experiment::run::stimulus;
use experiment::run::trial_result::{trial_events, trial_line, trial_row, Measured};
use experiment::session;
use experiment::Trial;
use pipeline::{BackendChoice, Method, Options, Renderer};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use raycast::{Camera, Frame, Scene};
use tracker_hal::events::TimedGaze;

use super::session_dir::SessionDir;
use super::setup::Setup;
use crate::picture::{register_font, save_png};
use crate::screen::OverlayBuf;

type SearchRenderer<'a> = Renderer<'a>;

self_cell::self_cell!(
    /// The search display's scene and the renderer that borrows it.
    struct SearchScene {
        owner: Scene,
        #[not_covariant]
        dependent: SearchRenderer,
    }
);

/// What an observer model needs of the search frames.
struct ObserverFrames {
    full_rgb: Vec<u8>,
    block_px: usize,
    radius_px: f64,
    centres_px: Vec<[f64; 2]>,
    size: (u32, u32),
    fresh: Option<([f64; 2], Vec<f64>)>,
}

/// A trial from its preview to its response.
pub struct TrialState {
    search: SearchScene,
    preview_rgb: Vec<u8>,
    /// What drew the preview (`Renderer::provenance` of the
    /// full-resolution CPU renderer).
    preview_plan: String,
    /// What drew the search frames, each plan once in the order they ran
    /// (one, unless the renderer's plan changed during the search).
    search_plans: Vec<String>,
    /// What drew the last search frame.
    last_plan: Option<String>,
    confirm_rgb: Option<Vec<u8>>,
    last: Option<Frame>,
    /// The gaze the last search frame was rendered for, its rays and
    /// render time (shown again within `tolerance`).
    last_render: Option<([f64; 2], u64, f64, Option<u64>)>,
    /// The last rendered search frame's GPU traffic (`None` on the CPU).
    last_traffic: Option<raycast::gpu::Traffic>,
    /// `Setup::gaze_tolerance_deg` with the display, to measure it.
    tolerance: Option<(f64, foveation::ScreenGeometry)>,
    /// Search frames shown again (gaze within the tolerance).
    kept_frames: u64,
    /// For an observer model: the search display at full resolution, the
    /// fidelity's block (px), and the newest rendered frame's gaze and
    /// per-cell fidelity.
    observer: Option<ObserverFrames>,
    onset_us: Option<u64>,
    response_us: Option<u64>,
    frames: u64,
    late: u64,
    rays: u64,
    /// The design's full-resolution reference (`ReferenceDetail::Full`),
    /// drawn over every search frame; `None` without one.
    reference: Option<ReferencePixels>,
    /// The last search frame's render time (ms) and triangles drawn,
    /// until it is presented.
    pending: Option<(f64, Option<u64>)>,
    /// Render time (ms) of each presented search frame.
    render_ms: Vec<f64>,
    /// Triangles drawn over the presented search frames (methods that
    /// draw triangles).
    triangles: Option<u64>,
    /// The gaze samples (times, px or invalid) from the preview on.
    samples: Vec<TimedGaze>,
}

/// Most samples a trial keeps for its events (an hour at 1 kHz); beyond,
/// the events cover the first hour and samples.tsv still has every one.
const MAX_TRIAL_SAMPLES: usize = 3_600_000;

/// `scene` at full resolution on the CPU (the preview, the stimulus
/// pictures): the same picture on every machine; with the renderer's
/// provenance line.
fn full_resolution(scene: &Scene, setup: &Setup) -> Result<(Frame, String), String> {
    let model = pipeline::sampling_model(setup.geometry, 1.0).map_err(|e| e.to_string())?;
    let options = Options {
        method: Method::Full,
        backend: BackendChoice::Cpu,
        ..Options::default()
    };
    let mut full = Renderer::new(scene, Camera::new(&setup.geometry), model, &options)
        .map_err(|e| e.to_string())?;
    let (frame, _) = full
        .render(setup.geometry.centre_px())
        .map_err(|e| e.to_string())?;
    Ok((frame, full.provenance()))
}

/// The full-resolution reference's pixels: where its frame hit the mesh,
/// with their colours.
struct ReferencePixels {
    width_px: u32,
    height_px: u32,
    /// Pixel indices (row-major) where the reference frame hit its mesh.
    pixels: Vec<usize>,
    /// Their colours (sRGB bytes).
    rgb: Vec<[u8; 3]>,
}

impl ReferencePixels {
    /// The pixels of `frame` (the reference mesh alone, at full
    /// resolution) that hit the mesh: its object-id buffer where the frame
    /// has one, its hit buffer otherwise (the scene has one object).
    fn of(frame: &Frame) -> Self {
        let n = frame.width_px as usize * frame.height_px as usize;
        let on = |i: usize| match frame.object.get(i) {
            Some(&o) => o == 0,
            None => frame.hit.get(i).copied().unwrap_or(false),
        };
        let pixels: Vec<usize> = (0..n).filter(|&i| on(i)).collect();
        let rgb = pixels
            .iter()
            .map(|&i| {
                let c = frame.rgb.get(3 * i..3 * i + 3).unwrap_or(&[0, 0, 0]);
                [c[0], c[1], c[2]]
            })
            .collect();
        Self {
            width_px: frame.width_px,
            height_px: frame.height_px,
            pixels,
            rgb,
        }
    }

    /// The reference as an overlay: the RGBA words of its bounding box
    /// (alpha 255 on its pixels, 0 around them), the box's size and top
    /// left; `None` when it has no pixel.
    fn overlay(&self) -> Option<OverlayBuf> {
        let w = self.width_px as usize;
        if w == 0 {
            return None;
        }
        let xs = self.pixels.iter().map(|&i| i % w);
        let ys = self.pixels.iter().map(|&i| i / w);
        let (x0, x1) = (xs.clone().min()?, xs.max()?);
        let (y0, y1) = (ys.clone().min()?, ys.max()?);
        let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);
        let mut words = vec![0u32; bw * bh];
        for (&i, c) in self.pixels.iter().zip(&self.rgb) {
            let (x, y) = (i % w - x0, i / w - y0);
            words[y * bw + x] =
                0xff00_0000 | u32::from(c[2]) << 16 | u32::from(c[1]) << 8 | u32::from(c[0]);
        }
        Some(OverlayBuf {
            words,
            size: (u32::try_from(bw).ok()?, u32::try_from(bh).ok()?),
            origin: (u32::try_from(x0).ok()?, u32::try_from(y0).ok()?),
        })
    }

    /// Draws the reference over `frame` (the condition's, after its
    /// passes).
    fn draw(&self, frame: &mut Frame) -> Result<(), String> {
        if (frame.width_px, frame.height_px) != (self.width_px, self.height_px)
            || frame.rgb.len() < 3 * self.width_px as usize * self.height_px as usize
        {
            return Err(format!(
                "the search frame is {}×{} px, the reference's {}×{}",
                frame.width_px, frame.height_px, self.width_px, self.height_px
            ));
        }
        for (&i, c) in self.pixels.iter().zip(&self.rgb) {
            frame.rgb[3 * i..3 * i + 3].copy_from_slice(c);
        }
        Ok(())
    }
}

/// Triangles the renderer's method drew in its last frame: the
/// model-based methods' and ULOD's; `None` for the ray-cast methods.
fn triangles_drawn(r: &Renderer<'_>) -> Option<u64> {
    r.model_based()
        .map(|m| m.last().triangles_drawn as u64)
        .or_else(|| {
            r.ulod()
                .map(|u| (u.last().triangles_opaque + u.last().triangles_blended) as u64)
        })
}

fn build(file: &raycast::SceneFile) -> Result<Scene, String> {
    Scene::build(file, Path::new(".")).map_err(|e| format!("stimulus scene {}: {e}", file.name))
}

impl TrialState {
    /// Builds the trial's scenes and renders the preview (full resolution).
    /// On the GPU backend the search renderer renders on `gpu` when given
    /// (the window's device), and with `stay_on_gpu` its frames stay there
    /// for the window to draw, where nothing on the CPU reads them (an
    /// observer model does).
    pub fn new(
        setup: &Setup,
        trial: &Trial,
        gpu: Option<&raycast::gpu::SharedDevice>,
        stay_on_gpu: bool,
    ) -> Result<Self, String> {
        let design = &setup.design;
        let condition = &design.conditions[trial.condition];
        let camera = Camera::new(&setup.geometry);
        let preview_file = stimulus::preview_scene(design, trial, &setup.layout);
        let preview = build(&preview_file)?;
        let (frame, preview_plan) = full_resolution(&preview, setup)?;
        // The full-resolution reference: at the centre it is the preview
        // (same mesh, same place), whose frame is reused.
        let reference = match stimulus::reference_scene(design, trial, &setup.layout) {
            None => None,
            Some(file) if file.objects == preview_file.objects => Some(ReferencePixels::of(&frame)),
            Some(file) => {
                let (f, _) = full_resolution(&build(&file)?, setup)?;
                Some(ReferencePixels::of(&f))
            }
        };
        // The condition's contrast, or the design's.
        let csf = setup
            .thresholds
            .as_ref()
            .map_or_else(foveation::GeislerPerry::default, |t| t.file.geisler_perry);
        let search_model = pipeline::sampling_model_with(
            setup.geometry,
            csf,
            condition.contrast_or(design.contrast),
        )
        .map_err(|e| match condition.contrast {
            Some(_) => format!("conditions[{}].contrast: {e}", trial.condition),
            None => format!("contrast: {e}"),
        })?
        .with_inset_deg(condition.inset_deg.unwrap_or(0.0))
        .map_err(|e| format!("conditions[{}].inset_deg: {e}", trial.condition))?;
        let scene = build(&stimulus::search_scene(design, trial, &setup.layout))?;
        let options = Options {
            method: condition_method(&condition.method)
                .map_err(|e| format!("conditions[{}].method: {e}", trial.condition))?,
            backend: setup.backend,
            // Fixations re-cast only what the cache lacks (same frames).
            reuse: true,
            // Luebke & Hallen's best-effort mode (simplify), when the
            // condition gives a budget.
            model_based: pipeline::model_based::ModelBasedOptions {
                budget: condition
                    .triangle_budget
                    .map(|b| usize::try_from(b).unwrap_or(usize::MAX)),
                ..Default::default()
            },
            ..Options::default()
        };
        let search = SearchScene::try_new(scene, |s| {
            let mut r = Renderer::new_on(s, camera, search_model, &options, gpu)
                .map_err(|e| e.to_string())?;
            if let Some(t) = &setup.thresholds {
                t.apply(&mut r);
            }
            if stay_on_gpu && setup.observer.is_none() && r.can_stay_on_gpu().is_ok() {
                r.set_stay_on_gpu(true)?;
            }
            Ok::<_, String>(r)
        })?;
        // Pay per use: the full-resolution search display only for an
        // observer that compares what it sees with it.
        let observer = match &setup.observer {
            Some(m) => Some(ObserverFrames {
                full_rgb: full_resolution(search.borrow_owner(), setup)?.0.rgb,
                block_px: m.block_px(setup.geometry.local_ppd(setup.geometry.centre_px())),
                radius_px: setup.layout.radius_px,
                // Aligned with the participant's objects: the reference
                // is not one.
                centres_px: setup.layout.search_centres(trial.reference_cell),
                size: (setup.geometry.width_px, setup.geometry.height_px),
                fresh: None,
            }),
            None => None,
        };
        Ok(Self {
            search,
            preview_rgb: frame.rgb,
            preview_plan,
            search_plans: Vec::new(),
            last_plan: None,
            confirm_rgb: None,
            last: None,
            last_render: None,
            last_traffic: None,
            tolerance: setup.gaze_tolerance_deg.map(|t| (t, setup.geometry)),
            kept_frames: 0,
            observer,
            onset_us: None,
            response_us: None,
            frames: 0,
            late: 0,
            rays: 0,
            reference,
            pending: None,
            render_ms: Vec::new(),
            triangles: None,
            samples: Vec::new(),
        })
    }

    /// The search frame shown's gaze and each search cell's visible
    /// fidelity in it (row-major, the reference left out), for an
    /// observer model.
    pub fn fidelity(&self) -> Option<([f64; 2], Vec<f64>)> {
        self.observer.as_ref().and_then(|o| o.fresh.clone())
    }

    /// Search frames shown again within the gaze tolerance, of the search
    /// frames presented; `None` without a tolerance.
    pub fn kept_frames(&self) -> Option<(u64, u64, f64)> {
        self.tolerance
            .map(|(t, _)| (self.kept_frames.min(self.frames), self.frames, t))
    }

    /// A gaze sample during the trial (kept until the trial is written:
    /// samples captured before the response may arrive after it).
    pub fn sample(&mut self, s: TimedGaze) {
        if self.samples.len() < MAX_TRIAL_SAMPLES {
            self.samples.push(s);
        }
    }

    /// The trial has its response, but the tracker has not yet delivered a
    /// sample captured after it (the events need every sample up to it).
    pub fn awaits_samples(&self) -> bool {
        self.response_us.is_some_and(|r| {
            self.samples.len() < MAX_TRIAL_SAMPLES
                && self
                    .samples
                    .iter()
                    .rev()
                    .find(|s| s.order.is_timed())
                    .is_none_or(|s| s.mapped_us < r)
        })
    }

    /// Renders the search display for `gaze`, with the full-resolution
    /// reference drawn over the condition's frame: (rays, render ms, GPU
    /// traffic — `None` on the CPU backend). Within the gaze tolerance of
    /// the last rendered frame's gaze, that frame is shown again with its
    /// rays, render time and triangles (the cost of the picture shown); no
    /// renderer runs, so it moves nothing to or from the GPU.
    pub fn render_search(
        &mut self,
        gaze: [f64; 2],
    ) -> Result<(u64, f64, Option<raycast::gpu::Traffic>), String> {
        if let (Some((g, rays, ms, triangles)), Some((tol, geometry)), Some(_)) =
            (self.last_render, self.tolerance, &self.last)
        {
            if geometry.eccentricity_deg(g, gaze) <= tol {
                self.kept_frames += 1;
                self.pending = Some((ms, triangles));
                let nothing = self.last_traffic.map(|_| raycast::gpu::Traffic::default());
                return Ok((rays, ms, nothing));
            }
        }
        let old = self.last.take();
        let (mut frame, stats, plan, triangles, traffic) = self
            .search
            .with_dependent_mut(|_, r| {
                if let Some(f) = old {
                    r.recycle(f);
                }
                r.render(gaze)
                    .map(|(f, s)| (f, s, r.provenance(), triangles_drawn(r), r.gpu_traffic()))
            })
            .map_err(|e| e.to_string())?;
        self.last_traffic = traffic;
        let started = std::time::Instant::now();
        // A frame on the GPU gets the reference as the window's overlay.
        if let (Some(reference), false) = (&self.reference, frame.is_on_device()) {
            reference.draw(&mut frame)?;
        }
        let ms = stats.time_ms + started.elapsed().as_secs_f64() * 1e3;
        self.pending = Some((ms, triangles));
        self.last = Some(frame);
        if !self.search_plans.contains(&plan) {
            self.search_plans.push(plan.clone());
        }
        self.last_plan = Some(plan);
        self.last_render = Some((gaze, stats.rays_total, ms, triangles));
        if let (Some(o), Some(f)) = (&mut self.observer, &self.last) {
            let q = cell_fidelity(
                &f.rgb,
                &o.full_rgb,
                o.size,
                &o.centres_px,
                o.radius_px,
                o.block_px,
            );
            o.fresh = Some((gaze, q));
        }
        Ok((stats.rays_total, ms, traffic))
    }

    /// What drew the picture of `phase` ([`TrialState::rgb`]): the search
    /// renderer's plan for its frames (also under the confirm overlay),
    /// the full-resolution renderer's for the preview.
    pub fn plan(&self, phase: Phase) -> &str {
        let search = self.last_plan.as_deref();
        match phase {
            Phase::Confirm if self.confirm_rgb.is_some() => search,
            Phase::Search if self.last.is_some() => search,
            _ => None,
        }
        .unwrap_or(&self.preview_plan)
    }

    /// What drew the search frames: their plan, or each plan they had in
    /// order joined by ` | ` (`trials.tsv`'s `plan`); `None` before any.
    pub fn search_plan(&self) -> Option<String> {
        (!self.search_plans.is_empty()).then(|| self.search_plans.join(" | "))
    }

    /// The picture of `phase`.
    pub fn rgb(&self, phase: Phase) -> &[u8] {
        match phase {
            Phase::Confirm => self
                .confirm_rgb
                .as_deref()
                .unwrap_or(self.preview_rgb.as_slice()),
            Phase::Search => self
                .last
                .as_ref()
                .map_or(self.preview_rgb.as_slice(), |f| f.rgb.as_slice()),
            _ => &self.preview_rgb,
        }
    }

    /// The last search frame as shown, on the CPU: read back (with the
    /// reference drawn over it) when it stayed on the GPU; `None` before
    /// the first.
    fn last_shown(&self) -> Result<Option<Frame>, String> {
        let Some(f) = &self.last else {
            return Ok(None);
        };
        if !f.is_on_device() {
            return Ok(Some(f.clone()));
        }
        let mut frame = self
            .search
            .with_dependent(|_, r| r.read_last_gpu_frame())
            .map_err(|e| e.to_string())?;
        if let Some(reference) = &self.reference {
            reference.draw(&mut frame)?;
        }
        Ok(Some(frame))
    }

    /// The last search frame on the GPU (its pixel words and size) when it
    /// stayed there: the window draws it, with [`TrialState::reference_overlay`].
    pub fn gpu_frame(&self) -> Option<(&raycast::gpu::wgpu::Buffer, (u32, u32))> {
        self.last
            .as_ref()
            .filter(|f| f.is_on_device())
            .and(self.search.with_dependent(|_, r| r.gpu_frame_pixels()))
    }

    /// The reference object as the window's overlay over frames on the
    /// GPU: its bounding box (alpha 0 around the object); `None` without a
    /// reference.
    pub fn reference_overlay(&self) -> Option<OverlayBuf> {
        self.reference.as_ref().and_then(ReferencePixels::overlay)
    }

    /// The picture of `phase` as shown, on the CPU (a search frame on the
    /// GPU is read back): what `--screenshots` saves.
    pub fn shown_rgb(&self, phase: Phase) -> Result<std::borrow::Cow<'_, [u8]>, String> {
        if phase == Phase::Search && self.gpu_frame().is_some() {
            if let Some(f) = self.last_shown()? {
                return Ok(std::borrow::Cow::Owned(f.rgb));
            }
        }
        Ok(std::borrow::Cow::Borrowed(self.rgb(phase)))
    }

    /// The frozen search display with the click instruction (once).
    pub fn confirm_overlay(&mut self) {
        if self.confirm_rgb.is_some() {
            return;
        }
        if let Ok(Some(f)) = self.last_shown() {
            let mut rgb = f.rgb;
            let _ = crate::picture::draw_text_lines(
                &mut rgb,
                (f.width_px, f.height_px),
                &["Click on the face you found."],
            );
            self.confirm_rgb = Some(rgb);
        }
    }

    /// A search frame was presented at `present_us`; true for the first
    /// (the search's onset).
    pub fn presented(&mut self, present_us: u64, rays: u64, late: bool) -> bool {
        if self.response_us.is_some() {
            return false;
        }
        self.frames += 1;
        self.late += u64::from(late);
        self.rays += rays;
        if let Some((ms, triangles)) = self.pending.take() {
            self.render_ms.push(ms);
            if let Some(t) = triangles {
                *self.triangles.get_or_insert(0) += t;
            }
        }
        if self.onset_us.is_none() {
            self.onset_us = Some(present_us);
            return true;
        }
        false
    }

    /// The participant pressed Space at `host_us`: the search ends if it
    /// had begun (a key before the first search frame is ignored).
    pub fn respond(&mut self, host_us: u64) -> bool {
        match (self.onset_us, self.response_us) {
            (Some(onset), None) if host_us >= onset => {
                self.response_us = Some(host_us);
                true
            }
            _ => false,
        }
    }

    /// More than `limit_s` since the onset without a response, at `now_us`.
    pub fn timed_out(&self, limit_s: f64, now_us: u64) -> bool {
        self.response_us.is_none()
            && self
                .onset_us
                .is_some_and(|o| now_us.saturating_sub(o) as f64 > limit_s * 1e6)
    }

    /// Writes the trial: its eye-movement events, its row (then the files
    /// are flushed and the table synced), the stimulus picture. The log's
    /// line.
    pub fn finish(
        self,
        setup: &Setup,
        trial: &Trial,
        participant: &str,
        click: Option<Option<(u32, u32)>>,
        synthetic: bool,
        dir: &mut SessionDir,
    ) -> Result<String, String> {
        let (Some(onset), Some(response)) = (self.onset_us, self.response_us) else {
            return Err(format!("trial {}: ended without a search", trial.index + 1));
        };
        let sitting = dir.sitting();
        for row in trial_events(&self.samples, response, &setup.geometry, sitting, trial) {
            dir.event(&row);
        }
        let measured = Measured {
            onset_us: onset,
            response_us: response,
            click,
            frames: self.frames,
            frames_late: self.late,
            rays: self.rays,
            triangles: self.triangles,
            render_ms: self.render_ms.clone(),
            plan: self.search_plan(),
        };
        let row = trial_row(
            &setup.design,
            trial,
            participant,
            sitting,
            &measured,
            synthetic,
        );
        dir.trial(&row)?;
        if setup.stimulus_pictures {
            self.stimulus_picture(setup, trial, dir.path())?;
        }
        Ok(trial_line(&row))
    }

    /// The search display at full resolution, for the scanpath pictures:
    /// written to a temporary file and renamed.
    fn stimulus_picture(&self, setup: &Setup, trial: &Trial, dir: &Path) -> Result<(), String> {
        let (f, _) = full_resolution(self.search.borrow_owner(), setup)?;
        let path = session::stimulus_path(dir, trial.index);
        let tmp = path.with_extension("png.part");
        save_png(&tmp, (f.width_px, f.height_px), &f.rgb)
            .map_err(|e| format!("{}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &path).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// Background of the plain screens (the scenes' background).
const BACKGROUND: RGBColor = RGBColor(15, 15, 20);

fn clear(canvas: &mut Vec<u8>, (w, h): (u32, u32), c: RGBColor) {
    let n = w as usize * h as usize * 3;
    canvas.resize(n, 0);
    for px in canvas.chunks_exact_mut(3) {
        px.copy_from_slice(&[c.0, c.1, c.2]);
    }
}

/// Text lines centred on the screen.
pub fn text_screen(canvas: &mut Vec<u8>, (w, h): (u32, u32), lines: &[String]) {
    clear(canvas, (w, h), BACKGROUND);
    register_font();
    let size = (f64::from(h) / 36.0).clamp(10.0, 40.0);
    let root = BitMapBackend::with_buffer(canvas, (w, h)).into_drawing_area();
    let step = size * 1.6;
    let top = f64::from(h) / 2.0 - step * (lines.len() as f64 - 1.0) / 2.0;
    for (k, line) in lines.iter().enumerate() {
        let style = ("sans-serif", size)
            .into_font()
            .color(&WHITE)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let _ = root.draw(&Text::new(
            line.clone(),
            ((w / 2) as i32, (top + step * k as f64) as i32),
            style,
        ));
    }
    let _ = root.present();
}

/// A calibration target (a white disc with a dark centre) and optional
/// text lines at the bottom.
pub fn target_screen(
    canvas: &mut Vec<u8>,
    (w, h): (u32, u32),
    target: Option<[f64; 2]>,
    lines: &[String],
) {
    clear(canvas, (w, h), RGBColor(40, 40, 44));
    register_font();
    let root = BitMapBackend::with_buffer(canvas, (w, h)).into_drawing_area();
    if let Some([x, y]) = target.filter(|t| t[0].is_finite() && t[1].is_finite()) {
        let r = (f64::from(h.min(w)) / 70.0).max(4.0) as i32;
        let c = (x.round() as i32, y.round() as i32);
        let _ = root.draw(&Circle::new(c, r, WHITE.filled()));
        let _ = root.draw(&Circle::new(c, (r / 4).max(1), BLACK.filled()));
    }
    for (k, line) in lines.iter().enumerate() {
        let style = ("sans-serif", 16.0)
            .into_font()
            .color(&WHITE)
            .pos(Pos::new(HPos::Center, VPos::Center));
        let y = h as i32 - 30 * (lines.len() - k) as i32;
        let _ = root.draw(&Text::new(line.clone(), ((w / 2) as i32, y), style));
    }
    let _ = root.present();
}

/// The renderer's method for a condition's `method`: a method
/// `pipeline` knows by that key or alias (built in or a registered
/// module); any other name is an error, never the full-resolution control
/// in disguise.
pub fn condition_method(name: &str) -> Result<Method, String> {
    Method::from_name(name).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::ReferencePixels;

    /// The reference's overlay is its bounding box: its pixels opaque in
    /// their colours, the rest clear; a reference without pixels has none.
    #[test]
    fn the_reference_overlay_is_its_bounding_box() {
        // 10 px wide; pixels (3, 2), (5, 2) and (4, 4).
        let r = ReferencePixels {
            width_px: 10,
            height_px: 6,
            pixels: vec![23, 25, 44],
            rgb: vec![[1, 2, 3], [4, 5, 6], [7, 8, 9]],
        };
        let o = r.overlay().expect("an overlay");
        assert_eq!((o.size, o.origin), ((3, 3), (3, 2)));
        assert_eq!(
            o.words,
            [0xff03_0201, 0, 0xff06_0504, 0, 0, 0, 0, 0xff09_0807, 0]
        );
        let empty = ReferencePixels {
            width_px: 10,
            height_px: 6,
            pixels: Vec::new(),
            rgb: Vec::new(),
        };
        assert!(empty.overlay().is_none());
    }
}
