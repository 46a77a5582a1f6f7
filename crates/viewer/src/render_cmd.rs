//! `gazecast render`: one frame, headless, to a PNG.

use std::io::Write;
use std::path::PathBuf;

use foveation::Layout;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::render::Stats;
use raycast::{layers_rgb, Camera};
use serde::Serialize;

use crate::args::{
    parse_point, AccelArg, Intersector, ModelBasedArgs, Overlay, ThresholdsArg, ThresholdsReport,
};
use crate::config::{self, load_scene};
use crate::picture::{draw_text_lines, save_png};
use experiment::stats::nearest_rank::median;

/// `gazecast render`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON): resolution, size, eye distance.
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Point of regard in screen pixels, origin top-left. Default: the screen centre.
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
    /// Output image.
    #[arg(long, value_name = "FILE.png")]
    pub out: PathBuf,
    /// The rendering method (`foveated` is an alias of `hybrid`).
    #[arg(long, visible_alias = "method", value_parser = crate::args::method_parser(), default_value = "hybrid")]
    pub mode: Method,
    /// Where to render; `auto` says which it used.
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    /// The ray mask's layout (hybrid method).
    #[arg(long, value_name = "nyquist|seed", default_value = "nyquist")]
    pub layout: Layout,
    /// Michelson contrast C of the CSF cut-off.
    #[arg(
        long,
        value_name = "C",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub contrast: f64,
    /// Hybrid method: the ray mask is built dense enough for any point of
    /// regard within DEG degrees of the gaze (a larger fovea, more rays), so
    /// a live view keeps one mask while a fixation's jitter stays within it.
    #[arg(long, value_name = "DEG", default_value_t = 0.0,
          value_parser = crate::args::parse_gaze_tolerance)]
    pub gaze_tolerance: f64,
    /// Render this many times; `time_ms` is the median.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub repeat: u32,
    /// The time on the scene's clock, seconds: where a moving scene's
    /// camera path and object paths are (default 0). Also the time of
    /// every repeat (no refocusing between repeats).
    #[arg(long, value_name = "S", allow_negative_numbers = true,
          value_parser = finite_time)]
    pub time: Option<f64>,
    /// Write counts and time as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Write the three-layer picture (fovea red, interpolated green, refined blue).
    #[arg(long, value_name = "FILE.png")]
    pub layers: Option<PathBuf>,
    /// Write the depth-of-field pass's circle of confusion per pixel
    /// (black 0 px, through red and yellow, to white at 64 px and beyond, on
    /// a log scale); the scene must list `DepthOfField`.
    #[arg(long, value_name = "FILE.png")]
    pub coc: Option<PathBuf>,
    /// Write the depth-of-field pass's mip level per pixel (level 0, left
    /// as it is, black; levels 1–8 in a colour each, blended between); the
    /// scene must list `DepthOfField`.
    #[arg(long, value_name = "FILE.png")]
    pub dof_level: Option<PathBuf>,
    /// Write a registered debug map for the gaze as a picture: NAME=FILE.png
    /// (repeatable); a NAME that is not registered is answered with the
    /// list of those that are (`pipeline::registry::MAPS`).
    #[arg(long = "map", value_name = "NAME=FILE.png", value_parser = parse_map)]
    pub maps: Vec<(&'static pipeline::registry::DebugMap, PathBuf)>,
    /// Ray/triangle test.
    #[arg(long, value_enum, default_value = "watertight")]
    pub intersector: Intersector,
    /// Acceleration structure.
    #[arg(long, value_enum, default_value = "bvh")]
    pub accel: AccelArg,
    /// Draw the POR box even if the scene does not ask for it.
    #[arg(long, value_enum, value_name = "por")]
    pub overlay: Option<Overlay>,
    /// Model-based methods' options (budget, no gaze).
    #[command(flatten)]
    pub model_based: ModelBasedArgs,
    /// A participant's thresholds file instead of the default CSF model.
    #[command(flatten)]
    pub thresholds: ThresholdsArg,
    /// A degradation table (RON, `foveation::degradation::DegradationTable`:
    /// the `degradation-<ID>.ron` that `gazecast thresholds degradation`
    /// writes): `--method lod` selects its levels by it instead of Murphy &
    /// Duchowski's Table 1. Only with `--method lod`.
    #[arg(long, value_name = "FILE.ron")]
    pub degradation: Option<PathBuf>,
}

/// The `--stats` JSON.
#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    /// The frame's counts and median time.
    #[serde(flatten)]
    pub stats: Stats,
    /// Where it rendered: `cpu` or `gpu`.
    pub backend: &'static str,
    /// The GPU adapter (name, API, type, driver) when the GPU rendered.
    pub adapter: Option<String>,
    /// GPU time per stage of the last frame (ms), from timestamp queries,
    /// when the GPU rendered and the adapter has them.
    pub gpu_stages_ms: Vec<StageTime>,
    /// What the last frame moved between the CPU and the GPU (bytes
    /// uploaded and read back, dispatches, draws, submits, counted at the
    /// `wgpu` calls), when the GPU rendered.
    pub gpu_traffic: Option<raycast::gpu::Traffic>,
    /// Threads in the rayon pool.
    pub threads: usize,
    /// The rendering method's name.
    pub mode: &'static str,
    /// The scene's name.
    pub scene: String,
    /// Frame width, pixels.
    pub width_px: u32,
    /// Frame height, pixels.
    pub height_px: u32,
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// Triangles in the scene.
    pub triangles: usize,
    /// The acceleration structure's name.
    pub accel: &'static str,
    /// All repeat times, ms.
    pub times_ms: Vec<f64>,
    /// The model-based methods' last frame; `None` for other methods.
    pub model: Option<ModelBasedReport>,
    /// A moving scene's pose: the time on its clock and the velocities
    /// the attention model reads; `None` for a static scene.
    pub pose: Option<PoseReport>,
    /// The thresholds used: the default Geisler–Perry model or a
    /// participant's file (`--thresholds`), marked synthetic when it is.
    pub thresholds: ThresholdsReport,
}

/// A moving scene's pose (`--stats`).
#[derive(Debug, Clone, Serialize)]
pub struct PoseReport {
    /// The time on the scene's clock, s.
    pub time_s: f64,
    /// Each object's fastest corner's velocity, mm/s (display frame).
    pub object_velocity_mm_per_s: Vec<[f32; 3]>,
    /// The camera's velocity, mm/s (display frame).
    pub camera_velocity_mm_per_s: [f32; 3],
}

/// What a model-based frame drew (`--stats`).
#[derive(Debug, Clone, Serialize)]
pub struct ModelBasedReport {
    /// Triangles of the unsimplified scene.
    pub triangles_full: usize,
    /// Triangles drawn.
    pub triangles_drawn: usize,
    /// Selection time, ms.
    pub select_ms: f64,
    /// Raster time, ms.
    pub raster_ms: f64,
    /// Selection without the gaze (`--no-gaze`).
    pub no_gaze: bool,
    /// `--budget`, when given.
    pub budget: Option<usize>,
    /// Budget mode: why the greedy stopped (`budget`, `imperceptible`,
    /// `exhausted`).
    pub budget_stop: Option<&'static str>,
    /// Budget mode: the viewing distance (mm, eye to the node) beyond which
    /// the most perceptible fold left, and so every fold left, is
    /// imperceptible (Luebke & Hallen §5.3); 0 when nothing is folded.
    pub imperceptible_distance_mm: Option<f64>,
    /// Budget mode: that distance over the node's current distance (≤ 1:
    /// imperceptible from here).
    pub distance_factor: Option<f64>,
}

impl ModelBasedReport {
    /// The report of `m`; `no_gaze` when the selection ignored the gaze.
    pub fn new(m: &pipeline::model_based::ModelBasedStats, no_gaze: bool) -> Self {
        Self {
            triangles_full: m.triangles_full,
            triangles_drawn: m.triangles_drawn,
            select_ms: m.select_ms,
            raster_ms: m.raster_ms,
            no_gaze,
            budget: m.budget.map(|b| b.budget),
            budget_stop: m.budget.map(|b| budget_stop_name(b.outcome.stopped_by)),
            imperceptible_distance_mm: m.budget.map(|b| b.outcome.imperceptible_distance_mm),
            distance_factor: m.budget.map(|b| b.outcome.distance_factor),
        }
    }

    /// The line `render` prints.
    pub fn line(&self) -> String {
        let mut s = format!(
            "model-based: {} of {} triangles drawn{} (select {:.1} ms, raster {:.1} ms)",
            self.triangles_drawn,
            self.triangles_full,
            if self.no_gaze { ", without gaze" } else { "" },
            self.select_ms,
            self.raster_ms
        );
        if let (Some(b), Some(stop), Some(d), Some(f)) = (
            self.budget,
            self.budget_stop,
            self.imperceptible_distance_mm,
            self.distance_factor,
        ) {
            s.push_str(&format!("; budget {b}: stopped by {stop}; "));
            if d > 0.0 {
                s.push_str(&format!(
                    "the folds left are imperceptible from {d:.0} mm ({f:.2} x the current distance)"
                ));
            } else {
                s.push_str("nothing left folded");
            }
        }
        s
    }
}

/// The report's name of a budget stop.
pub fn budget_stop_name(s: pipeline::model_based::BudgetStop) -> &'static str {
    match s {
        pipeline::model_based::BudgetStop::Budget => "budget",
        pipeline::model_based::BudgetStop::Imperceptible => "imperceptible",
        pipeline::model_based::BudgetStop::Exhausted => "exhausted",
    }
}

/// One GPU stage's time.
#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    /// The stage's name.
    pub stage: &'static str,
    /// Its time, ms.
    pub ms: f64,
}

/// Runs `gazecast render`.
pub fn run(args: &RenderArgs, out: &mut dyn Write) -> Result<(), String> {
    args.model_based.check(args.mode)?;
    let mut outputs = vec![("--out", args.out.as_path())];
    outputs.extend(args.layers.as_deref().map(|p| ("--layers", p)));
    outputs.extend(args.stats.as_deref().map(|p| ("--stats", p)));
    outputs.extend(args.coc.as_deref().map(|p| ("--coc", p)));
    outputs.extend(args.dof_level.as_deref().map(|p| ("--dof-level", p)));
    outputs.extend(args.maps.iter().map(|(_, p)| ("--map", p.as_path())));
    let mut inputs = crate::output::Inputs::new()
        .scene("--scene", &args.scene)
        .file("--display", &args.display);
    if let Some(p) = &args.thresholds.thresholds {
        inputs = inputs.file("--thresholds", p);
    }
    if let Some(p) = &args.degradation {
        inputs = inputs.file("--degradation", p);
        if args.mode != pipeline::Method::Lod {
            return Err(format!(
                "--degradation {}: a degradation table drives --method lod only, not {}",
                p.display(),
                args.mode.name()
            ));
        }
    }
    inputs.refuse(&outputs)?;
    let degradation = args
        .degradation
        .as_deref()
        .map(config::load_degradation)
        .transpose()
        .map_err(|e| e.to_string())?;
    let thresholds = args.thresholds.load()?;
    let mut scene = load_scene(&args.scene)?;
    if args.accel == AccelArg::Grid {
        scene.build_grid();
    }
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let model = crate::args::sampling_model_for(
        geometry,
        args.contrast,
        args.gaze_tolerance,
        thresholds.as_ref(),
    )?;
    let gaze = args.gaze.unwrap_or_else(|| geometry.centre_px());
    let maps = args.coc.is_some() || args.dof_level.is_some();
    // The maps are the CPU pass's: with them, `auto` renders on the CPU.
    let backend = match args.backend {
        BackendChoice::Auto if maps => BackendChoice::Cpu,
        BackendChoice::Gpu if maps => {
            return Err(
                "--coc and --dof-level come from the CPU depth-of-field pass; use --backend cpu (or auto)"
                    .into(),
            )
        }
        b => b,
    };
    let options = Options {
        method: args.mode,
        backend,
        layout: args.layout,
        test: args.intersector.into(),
        por_overlay: args.overlay == Some(Overlay::Por),
        model_based: args.model_based.into(),
        ..Options::default()
    };
    let mut renderer = Renderer::new(&scene, Camera::new(&geometry), model, &options)
        .map_err(|e| e.to_string())?;
    if let Some(t) = &thresholds {
        t.apply(&mut renderer);
    }
    if let Some(t) = &degradation {
        renderer
            .model_based_mut()
            .ok_or("--degradation: the lod method has no model-based state")?
            .set_degradation(Some(t.extents_deg))?;
        writeln!(
            out,
            "lod degradation table: {}{}",
            t.source,
            if t.synthetic && !t.source.contains("SYNTHETIC") {
                " (SYNTHETIC)"
            } else {
                ""
            }
        )
        .map_err(|e| e.to_string())?;
    }
    if renderer.depth_of_field().is_none() {
        let why = match scene.pass(&raycast::scene::PostPass::DEPTH_OF_FIELD) {
            Some(_) => "its DepthOfField uses method Splat, which has no mip levels (the maps are the mipmap method's)",
            None => "it lists no DepthOfField effect, so there is no map to write",
        };
        for (flag, path) in [("--coc", &args.coc), ("--dof-level", &args.dof_level)] {
            if path.is_some() {
                return Err(format!("{flag}: scene {}: {why}", args.scene.display()));
            }
        }
    }
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..args.repeat.max(1) {
        // A moving scene is rendered at a stated time (0 by default), not
        // at the wall clock's, so the same command gives the same picture.
        let rendered = match (args.time, scene.is_moving()) {
            (Some(t), _) => renderer.render_at(gaze, t),
            (None, true) => renderer.render_at(gaze, 0.0),
            (None, false) => renderer.render(gaze),
        };
        let (frame, stats) = rendered.map_err(|e| e.to_string())?;
        times.push(stats.time_ms);
        // The previous frame's buffers serve the next one (no allocation
        // per repeat).
        if let Some((old, _)) = last.replace((frame, stats)) {
            renderer.recycle(old);
        }
    }
    let Some((frame, mut stats)) = last else {
        return Err("nothing rendered".into());
    };
    stats.time_ms = median(&times);
    save_png(&args.out, (frame.width_px, frame.height_px), &frame.rgb)
        .map_err(|e| format!("{}: {e}", args.out.display()))?;
    if let Some(path) = &args.layers {
        save_png(path, (frame.width_px, frame.height_px), &layers_rgb(&frame))
            .map_err(|e| format!("{}: {e}", path.display()))?;
    }
    write_dof_maps(&renderer, args, (frame.width_px, frame.height_px))?;
    for (map, path) in &args.maps {
        write_debug_map(map, path, renderer.sampling_model(), gaze, &geometry)?;
    }
    let report = RenderReport {
        stats,
        backend: renderer.backend_name(),
        adapter: renderer.adapter().map(str::to_string),
        gpu_stages_ms: renderer
            .stage_ms()
            .iter()
            .map(|&(stage, ms)| StageTime { stage, ms })
            .collect(),
        gpu_traffic: renderer.gpu_traffic(),
        threads: rayon::current_num_threads(),
        mode: renderer.method().name(),
        scene: scene.name.clone(),
        width_px: frame.width_px,
        height_px: frame.height_px,
        gaze_px: gaze,
        triangles: scene.triangles.len(),
        accel: args.accel.name(),
        times_ms: times,
        model: renderer
            .model_based()
            .map(|m| ModelBasedReport::new(m.last(), args.model_based.no_gaze)),
        pose: renderer.scene().pose().map(|p| PoseReport {
            time_s: p.time_s,
            object_velocity_mm_per_s: p.object_velocity_mm_per_s.clone(),
            camera_velocity_mm_per_s: p.camera_velocity_mm_per_s,
        }),
        thresholds: thresholds
            .as_ref()
            .map_or_else(ThresholdsReport::default_model, |t| t.report()),
    };
    if let Some(path) = &args.stats {
        let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        crate::output::write_whole(path, json.as_bytes())
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    }
    if let Some(n) = renderer.note() {
        writeln!(out, "{n}").map_err(|e| e.to_string())?;
    }
    if let Some(t) = thresholds.as_ref().filter(|t| t.file.synthetic) {
        writeln!(
            out,
            "SYNTHETIC thresholds: {} came from a simulated observer, not a person",
            t.path.display()
        )
        .map_err(|e| e.to_string())?;
    }
    let on = match &report.adapter {
        Some(a) => format!("gpu ({a})"),
        None => format!("cpu ({} threads)", report.threads),
    };
    if let Some(m) = &report.model {
        writeln!(out, "{}", m.line()).map_err(|e| e.to_string())?;
    }
    if let Some(u) = renderer.ulod() {
        writeln!(out, "{}", u.last().line()).map_err(|e| e.to_string())?;
    }
    let rays = if report.model.is_some() || renderer.ulod().is_some() {
        "rasterised".to_string()
    } else if stats.rays_full > 0 {
        format!("{} rays (one per pixel)", stats.rays_total)
    } else {
        format!(
            "{} rays (fovea {}, mask {}, refine {}), {} of {} cells refined",
            stats.rays_total,
            stats.rays_fovea,
            stats.rays_mask,
            stats.rays_refine,
            stats.cells_refined,
            stats.cells_total
        )
    };
    writeln!(
        out,
        "{} {}x{} {} on {on}: {rays}, {:.1} ms; wrote {}",
        report.scene,
        report.width_px,
        report.height_px,
        report.mode,
        stats.time_ms,
        args.out.display()
    )
    .map_err(|e| e.to_string())
}

/// Largest CoC the `--coc` picture tells apart, px (white beyond).
pub const COC_PICTURE_MAX_PX: f64 = 64.0;

/// The `--coc` and `--dof-level` pictures of the last frame.
fn write_dof_maps(
    renderer: &Renderer<'_>,
    args: &RenderArgs,
    size: (u32, u32),
) -> Result<(), String> {
    if args.coc.is_none() && args.dof_level.is_none() {
        return Ok(());
    }
    let n = size.0 as usize * size.1 as usize;
    let maps = renderer.depth_of_field().and_then(|d| d.maps());
    // A pass that blurred nothing (pupil 0) has no maps: all zero.
    let zeros = vec![0.0f32; n];
    let (sigma, level) = match maps {
        Some(m) if m.sigma_px.len() == n => (m.sigma_px, m.level),
        _ => (zeros.as_slice(), zeros.as_slice()),
    };
    let write = |path: &PathBuf, mut rgb: Vec<u8>, legend: &str| -> Result<(), String> {
        draw_text_lines(&mut rgb, size, &[legend]).map_err(|e| e.to_string())?;
        save_png(path, size, &rgb).map_err(|e| format!("{}: {e}", path.display()))
    };
    if let Some(path) = &args.coc {
        let rgb = sigma
            .iter()
            .flat_map(|&s| coc_colour(2.0 * f64::from(s)))
            .collect();
        write(
            path,
            rgb,
            "circle of confusion: black 0 px, red 3, yellow 15, white >= 64 px (log)",
        )?;
    }
    if let Some(path) = &args.dof_level {
        let rgb = level
            .iter()
            .flat_map(|&m| level_colour(f64::from(m)))
            .collect();
        write(
            path,
            rgb,
            "mip level: black 0 (unchanged), blue 1, cyan 2, green 3, yellow 4, orange 5, red 6, magenta 7, white 8",
        )?;
    }
    Ok(())
}

/// `--map NAME=FILE.png`: a registered map and where to write it.
fn parse_map(s: &str) -> Result<(&'static pipeline::registry::DebugMap, PathBuf), String> {
    let known = || {
        pipeline::registry::MAPS
            .iter()
            .map(|m| m.name)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (name, file) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected NAME=FILE.png (maps: {})", known()))?;
    let map = pipeline::registry::map(name)
        .ok_or_else(|| format!("unknown map {name:?}; known: {}", known()))?;
    if file.is_empty() {
        return Err(format!("{s:?}: no file after '='"));
    }
    Ok((map, PathBuf::from(file)))
}

/// Writes a debug map: its values from black (the smallest) through the
/// blue–green–yellow ramp to white (the largest), with a legend naming
/// both ends and the unit.
fn write_debug_map(
    map: &pipeline::registry::DebugMap,
    path: &std::path::Path,
    model: &foveation::SamplingModel,
    gaze: [f64; 2],
    geometry: &foveation::ScreenGeometry,
) -> Result<(), String> {
    let input = pipeline::registry::MapInput {
        model,
        gaze_px: gaze,
        width_px: geometry.width_px,
        height_px: geometry.height_px,
    };
    let values = (map.make)(&input).map_err(|e| format!("--map {}: {e}", map.name))?;
    let finite = values.values.iter().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let span = if hi > lo { hi - lo } else { 1.0 };
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.12, 0.24, 0.8],
        [0.16, 0.7, 0.47],
        [0.94, 0.86, 0.16],
        [1.0, 1.0, 1.0],
    ];
    let mut rgb: Vec<u8> = values
        .values
        .iter()
        .flat_map(|&v| ramp(&STOPS, 4.0 * f64::from((v - lo) / span)))
        .collect();
    let size = (values.width_px, values.height_px);
    let legend = format!(
        "{}: black {lo:.2} to white {hi:.2} {} (gaze {:.0}, {:.0})",
        map.name, values.unit, gaze[0], gaze[1]
    );
    draw_text_lines(&mut rgb, size, &[&legend]).map_err(|e| e.to_string())?;
    save_png(path, size, &rgb).map_err(|e| format!("{}: {e}", path.display()))
}

/// Linear blend of RGB stops at `t` in 0..=stops−1.
fn ramp(stops: &[[f64; 3]], t: f64) -> [u8; 3] {
    let last = (stops.len() - 1) as f64;
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, last) };
    let i = (t.floor() as usize).min(stops.len() - 2);
    let f = t - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    [0, 1, 2].map(|k| (255.0 * (a[k] + (b[k] - a[k]) * f)).round() as u8)
}

/// CoC (px) to colour: log scale, black at 0, white at [`COC_PICTURE_MAX_PX`].
pub fn coc_colour(coc_px: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 4] = [[0.0; 3], [0.85, 0.1, 0.05], [1.0, 0.9, 0.1], [1.0; 3]];
    let t = (1.0 + coc_px.max(0.0)).ln() / (1.0 + COC_PICTURE_MAX_PX).ln();
    ramp(&STOPS, 3.0 * t)
}

/// Mip level to colour: a colour per integer level 0–8, blended between.
pub fn level_colour(level: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 9] = [
        [0.0; 3],
        [0.1, 0.2, 0.9],
        [0.1, 0.8, 0.9],
        [0.1, 0.8, 0.2],
        [0.95, 0.9, 0.1],
        [1.0, 0.55, 0.05],
        [0.9, 0.1, 0.1],
        [0.85, 0.2, 0.85],
        [1.0; 3],
    ];
    ramp(&STOPS, level)
}

/// `--time`: a finite number of seconds within the scene paths' range.
fn finite_time(s: &str) -> Result<f64, String> {
    let t: f64 = s.parse().map_err(|e| format!("{s}: {e}"))?;
    let max = raycast::motion::MAX_KEY_TIME_S;
    if t.is_finite() && t.abs() <= max {
        Ok(t)
    } else {
        Err(format!(
            "{s}: must be finite seconds, at most {max} in size"
        ))
    }
}
