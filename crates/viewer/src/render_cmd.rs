//! `gazecast render`: one frame, headless, to a PNG.

use std::io::Write;
use std::path::PathBuf;

use foveation::Layout;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::render::Stats;
use raycast::{layers_rgb, Camera};
use serde::Serialize;

use crate::args::{parse_point, AccelArg, Intersector, Overlay};
use crate::config::{self, load_scene};
use crate::picture::save_png;
use crate::stats::median;

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
    #[arg(long, visible_alias = "method", value_enum, default_value = "hybrid")]
    pub mode: Method,
    /// Where to render; `auto` says which it used.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendChoice,
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
    /// Render this many times; `time_ms` is the median.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub repeat: u32,
    /// Write counts and time as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Write the three-layer picture (fovea red, interpolated green, refined blue).
    #[arg(long, value_name = "FILE.png")]
    pub layers: Option<PathBuf>,
    /// Ray/triangle test.
    #[arg(long, value_enum, default_value = "watertight")]
    pub intersector: Intersector,
    /// Acceleration structure.
    #[arg(long, value_enum, default_value = "bvh")]
    pub accel: AccelArg,
    /// Draw the POR box even if the scene does not ask for it.
    #[arg(long, value_enum, value_name = "por")]
    pub overlay: Option<Overlay>,
}

/// The `--stats` JSON.
#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    #[serde(flatten)]
    pub stats: Stats,
    pub backend: &'static str,
    /// The GPU adapter (name, API, type, driver) when the GPU rendered.
    pub adapter: Option<String>,
    /// GPU time per stage of the last frame (ms), from timestamp queries,
    /// when the GPU rendered and the adapter has them.
    pub gpu_stages_ms: Vec<StageTime>,
    pub threads: usize,
    pub mode: &'static str,
    pub scene: String,
    pub width_px: u32,
    pub height_px: u32,
    pub gaze_px: [f64; 2],
    pub triangles: usize,
    pub accel: &'static str,
    /// All repeat times, ms.
    pub times_ms: Vec<f64>,
}

/// One GPU stage's time.
#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    pub stage: &'static str,
    pub ms: f64,
}

/// Runs `gazecast render`.
pub fn run(args: &RenderArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut outputs = vec![("--out", args.out.as_path())];
    outputs.extend(args.layers.as_deref().map(|p| ("--layers", p)));
    outputs.extend(args.stats.as_deref().map(|p| ("--stats", p)));
    crate::output::refuse_inputs(
        &outputs,
        &[("--scene", &args.scene), ("--display", &args.display)],
    )?;
    let mut scene = load_scene(&args.scene)?;
    if args.accel == AccelArg::Grid {
        scene.build_grid();
    }
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let model = pipeline::sampling_model(geometry, args.contrast)
        .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
    let gaze = args.gaze.unwrap_or_else(|| geometry.centre_px());
    let options = Options {
        method: args.mode,
        backend: args.backend,
        layout: args.layout,
        test: args.intersector.into(),
        por_overlay: args.overlay == Some(Overlay::Por),
        ..Options::default()
    };
    let mut renderer = Renderer::new(&scene, Camera::new(&geometry), model, &options)
        .map_err(|e| e.to_string())?;
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..args.repeat.max(1) {
        let (frame, stats) = renderer.render(gaze).map_err(|e| e.to_string())?;
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
    let report = RenderReport {
        stats,
        backend: renderer.backend_name(),
        adapter: renderer.adapter().map(str::to_string),
        gpu_stages_ms: renderer
            .stage_ms()
            .iter()
            .map(|&(stage, ms)| StageTime { stage, ms })
            .collect(),
        threads: rayon::current_num_threads(),
        mode: renderer.method().name(),
        scene: scene.name.clone(),
        width_px: frame.width_px,
        height_px: frame.height_px,
        gaze_px: gaze,
        triangles: scene.triangles.len(),
        accel: args.accel.name(),
        times_ms: times,
    };
    if let Some(path) = &args.stats {
        let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        crate::output::write_whole(path, json.as_bytes())
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    }
    if let Some(n) = renderer.note() {
        writeln!(out, "{n}").map_err(|e| e.to_string())?;
    }
    let on = match &report.adapter {
        Some(a) => format!("gpu ({a})"),
        None => format!("cpu ({} threads)", report.threads),
    };
    let rays = if stats.rays_full > 0 {
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
