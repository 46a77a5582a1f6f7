//! `gazecast render`: one frame, headless, to a PNG.

use std::io::Write;
use std::path::{Path, PathBuf};

use foveation::{GeislerPerry, Layout, SamplingModel};
use raycast::gpu::GpuRenderer;
use raycast::ray::TriangleTest;
use raycast::render::{layers_rgb, render, Mode, Settings, Stats, Triggers};
use raycast::scene::Effect;
use raycast::{Camera, Scene, SceneError, SceneFile};
use serde::Serialize;

use crate::config;
use crate::plots::save_png;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RenderMode {
    Foveated,
    Full,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// rayon on the CPU: every mode, structure and intersector.
    Cpu,
    /// wgpu compute: full resolution, BVH, watertight test (the foveated
    /// stages are not on the GPU yet).
    Gpu,
    /// The GPU where it can render the frame, else the CPU; says which.
    Auto,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelArg {
    /// Binned-SAH BVH.
    Bvh,
    /// The seed's uniform grid (Murphy 2007 §6.1.1), for comparison.
    Grid,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Intersector {
    Watertight,
    MollerTrumbore,
}

#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON): resolution, size, eye distance.
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Point of regard in screen pixels, origin top-left. Default: the screen centre.
    #[arg(long, value_name = "X,Y", value_parser = crate::mask_cmd::parse_point)]
    pub gaze: Option<[f64; 2]>,
    /// Output image.
    #[arg(long, value_name = "FILE.png")]
    pub out: PathBuf,
    #[arg(long, value_enum, default_value = "foveated")]
    pub mode: RenderMode,
    /// Where to render; `auto` says which it used.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    #[arg(long, value_name = "nyquist|seed", default_value = "nyquist")]
    pub layout: Layout,
    /// Michelson contrast C of the CSF cut-off.
    #[arg(long, value_name = "C", default_value_t = 1.0)]
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
    #[arg(long, value_name = "por")]
    pub overlay: Option<String>,
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

/// The sampling model the commands use: the Geisler–Perry CSF at contrast
/// `contrast`, spacing up to the seed's n_max (17 px).
pub fn sampling_model(
    geometry: foveation::ScreenGeometry,
    contrast: f64,
) -> Result<SamplingModel, foveation::ParamError> {
    SamplingModel::new(
        geometry,
        GeislerPerry::default(),
        contrast,
        foveation::sampling::SEED_MAX_SPACING_PX,
    )
}

/// The default foveated settings for a scene: nyquist layout, the scene's
/// refinement triggers, the watertight test.
pub fn foveated_settings(scene: &Scene) -> Settings {
    Settings {
        mode: Mode::Foveated,
        layout: Layout::Nyquist,
        triggers: Triggers::from_scene(scene),
        test: TriangleTest::Watertight,
        check_coverage: false,
    }
}

/// Loads and builds a scene; errors name the file, line and field.
pub fn load_scene(path: &Path) -> Result<Scene, String> {
    let (file, text): (SceneFile, String) = config::load(path).map_err(|e| e.to_string())?;
    let dir = path.parent().unwrap_or(Path::new("."));
    Scene::build(&file, dir).map_err(|e| match e {
        SceneError::Field { field, message } => {
            config::invalid_field(path, &text, &field, message).to_string()
        }
        mesh @ SceneError::Mesh { .. } => format!("{}: {mesh}", path.display()),
    })
}

/// Runs `gazecast render`.
pub fn run(args: &RenderArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut scene = load_scene(&args.scene)?;
    if args.accel == AccelArg::Grid {
        scene.build_grid();
    }
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let model = sampling_model(geometry, args.contrast)
        .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
    let gaze = args.gaze.unwrap_or_else(|| geometry.centre_px());
    let camera = Camera::new(&geometry);
    let settings = Settings {
        mode: match args.mode {
            RenderMode::Full => Mode::Full,
            RenderMode::Foveated => Mode::Foveated,
        },
        layout: args.layout,
        triggers: Triggers::from_scene(&scene),
        test: match args.intersector {
            Intersector::Watertight => TriangleTest::Watertight,
            Intersector::MollerTrumbore => TriangleTest::MollerTrumbore,
        },
        check_coverage: false,
    };
    if let Some(o) = &args.overlay {
        if o != "por" {
            return Err(format!("--overlay {o}: the only overlay is `por`"));
        }
    }
    let full = settings.mode == Mode::Full || !scene.has(Effect::FoveatedSampling);
    let gpu_able = args.accel == AccelArg::Bvh && args.intersector == Intersector::Watertight;
    let mut gpu = None;
    let mut note = None;
    match (args.backend, gpu_able) {
        (Backend::Cpu, _) => {}
        (Backend::Gpu, false) => {
            return Err(
                "--backend gpu: the GPU core has the BVH and the watertight test only; \
                        use --backend cpu for --accel grid or --intersector moller-trumbore"
                    .into(),
            )
        }
        (Backend::Gpu, true) => {
            gpu = Some(GpuRenderer::new(&scene).map_err(|e| format!("--backend gpu: {e}"))?)
        }
        (Backend::Auto, false) => {
            note = Some(
                "auto: the CPU renders this (the grid and Möller–Trumbore are CPU-only)".into(),
            )
        }
        (Backend::Auto, true) => match raycast::gpu::probe() {
            Ok((name, true)) => {
                note = Some(format!(
                    "auto: the only adapter is a software one ({name}), slower than the CPU \
                     backend; rendering on the CPU (--backend gpu forces it)"
                ))
            }
            Ok(_) => match GpuRenderer::new(&scene) {
                Ok(g) => gpu = Some(g),
                Err(e) => note = Some(format!("auto: {e}; rendering on the CPU")),
            },
            Err(e) => note = Some(format!("auto: {e}; rendering on the CPU")),
        },
    }
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..args.repeat.max(1) {
        let (frame, stats) = match gpu.as_mut() {
            Some(g) if full => g
                .render_full(&camera)
                .map_err(|e| format!("--backend gpu: {e}"))?,
            Some(g) => {
                let mask = foveation::mask::build(&model, settings.layout, gaze)
                    .map_err(|e| format!("--gaze: {e}"))?;
                g.render_foveated(&camera, &mask, &settings.triggers)
                    .map_err(|e| format!("--backend gpu: {e}"))?
            }
            None => render(&scene, &camera, &model, &settings, gaze)
                .map_err(|e| format!("--gaze: {e}"))?,
        };
        times.push(stats.time_ms);
        last = Some((frame, stats));
    }
    let Some((mut frame, mut stats)) = last else {
        return Err("nothing rendered".into());
    };
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    stats.time_ms = sorted[sorted.len() / 2];
    let overlay = args.overlay.is_some() || scene.has(Effect::PorOverlay);
    if overlay {
        draw_por_box(&mut frame.rgb, frame.width, frame.height, gaze);
    }
    save_png(&args.out, (frame.width, frame.height), &frame.rgb)
        .map_err(|e| format!("{}: {e}", args.out.display()))?;
    if let Some(path) = &args.layers {
        save_png(path, (frame.width, frame.height), &layers_rgb(&frame))
            .map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let report = RenderReport {
        stats,
        backend: if gpu.is_some() { "gpu" } else { "cpu" },
        adapter: gpu.as_ref().map(|g| g.adapter().to_string()),
        gpu_stages_ms: gpu.as_ref().map_or_else(Vec::new, |g| {
            g.stage_ms()
                .iter()
                .map(|&(stage, ms)| StageTime { stage, ms })
                .collect()
        }),
        threads: rayon::current_num_threads(),
        mode: if full { "full" } else { "foveated" },
        scene: scene.name.clone(),
        width_px: frame.width,
        height_px: frame.height,
        gaze_px: gaze,
        triangles: scene.triangles.len(),
        accel: if args.accel == AccelArg::Grid {
            "grid"
        } else {
            "bvh"
        },
        times_ms: times,
    };
    if let Some(path) = &args.stats {
        let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        std::fs::write(path, json).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    }
    if let Some(n) = &note {
        writeln!(out, "{n}").map_err(|e| e.to_string())?;
    }
    let on = match &report.adapter {
        Some(a) => format!("gpu ({a})"),
        None => format!("cpu ({} threads)", report.threads),
    };
    writeln!(
        out,
        "{} {}x{} {} on {on}: {} rays (fovea {}, mask {}, refine {}), {} of {} cells refined, {:.1} ms; wrote {}",
        report.scene,
        report.width_px,
        report.height_px,
        report.mode,
        stats.rays_total,
        stats.rays_fovea,
        stats.rays_mask,
        stats.rays_refine,
        stats.cells_refined,
        stats.cells_total,
        stats.time_ms,
        args.out.display()
    )
    .map_err(|e| e.to_string())
}

/// The seed's POR box: a 2-px yellow square, 64 px across, around the gaze.
pub fn draw_por_box(rgb: &mut [u8], w: u32, h: u32, gaze: [f64; 2]) {
    draw_box(rgb, w, h, gaze, 32);
}

/// A 2-px yellow square of half-size `r` px around `centre`.
pub fn draw_box(rgb: &mut [u8], w: u32, h: u32, centre: [f64; 2], r: i64) {
    let (cx, cy) = (centre[0].round() as i64, centre[1].round() as i64);
    let mut put = |x: i64, y: i64| {
        if (0..i64::from(w)).contains(&x) && (0..i64::from(h)).contains(&y) {
            let i = 3 * (y as usize * w as usize + x as usize);
            rgb[i..i + 3].copy_from_slice(&[255, 220, 0]);
        }
    };
    for d in -r..=r {
        for t in [-r, -r + 1, r - 1, r] {
            put(cx + d, cy + t);
            put(cx + t, cy + d);
        }
    }
}
