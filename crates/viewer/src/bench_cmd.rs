//! `gazecast bench`: what accuracy costs in time.
//!
//! - `accuracy`: sweeps the method's knobs (mask layout, CSF contrast,
//!   maximum ray spacing, refinement triggers, acceleration structure), and
//!   for every configuration and gaze measures the frame time and the error
//!   against the full-resolution frame of the same gaze
//!   ([`foveation::quality`]). Writes `results.csv`, `pareto.png`, `report.md`.
//! - `scaling`: frame time of full and foveated rendering against triangle
//!   count and against resolution (log–log), to show whether the cost
//!   follows the eye's ray budget. Writes `scaling.csv`,
//!   `scaling-triangles.png`, `scaling-resolution.png`, `scaling.md`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use foveation::quality::{self, GazeWeights, Image, Quality};
use foveation::{Display, GeislerPerry, Layout, SamplingModel, ScreenGeometry};
use indicatif::{ProgressBar, ProgressStyle};
use rand::{Rng, SeedableRng};
use raycast::render::{render, Frame, Mode, Settings, Stats, Triggers};
use raycast::scene::{Accel, Effect, Light, MeshSource, Object};
use raycast::{Camera, Scene, SceneFile};

use crate::config;
use crate::plots;
use crate::render_cmd::{load_scene, AccelArg, Backend};

#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub command: BenchCommand,
}

#[derive(Debug, Clone, clap::Subcommand)]
pub enum BenchCommand {
    /// Sweep layout, contrast, maximum spacing, refinement and acceleration;
    /// time each configuration and measure its error against full resolution.
    Accuracy(AccuracyArgs),
    /// Frame time of full and foveated rendering against triangle count and
    /// resolution (log–log plots).
    Scaling(ScalingArgs),
}

#[derive(Debug, Clone, clap::Args)]
pub struct AccuracyArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Output folder (created): results.csv, pareto.png, report.md.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Gaze positions per configuration: the centre, the four corners, then
    /// seeded uniform positions on the screen.
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub gazes: usize,
    /// Timed repeats per configuration and gaze (after one warm-up); the
    /// median is reported. Default 3, or 1 with --quick.
    #[arg(long, value_name = "N")]
    pub repeats: Option<u32>,
    /// Seed of the random gaze positions.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The sweep runs on the CPU backend (`gpu` is refused; `auto` = CPU).
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// Fewer configurations (8) and two gazes unless --gazes is given.
    #[arg(long)]
    pub quick: bool,
}

#[derive(Debug, Clone, clap::Args)]
pub struct ScalingArgs {
    /// Output folder (created).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Timed repeats per point (after one warm-up). Default 3, or 1 with --quick.
    #[arg(long, value_name = "N")]
    pub repeats: Option<u32>,
    /// As for `accuracy`: the CPU backend.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// 10^4–10^5 triangles and 640×360–1280×720 only.
    #[arg(long)]
    pub quick: bool,
}

/// Runs `gazecast bench …`.
pub fn run(args: &BenchArgs, out: &mut dyn Write) -> Result<(), String> {
    let backend = match &args.command {
        BenchCommand::Accuracy(a) => a.backend,
        BenchCommand::Scaling(a) => a.backend,
    };
    if backend == Backend::Gpu {
        return Err(
            "--backend gpu: the sweeps run on the CPU backend so far (the GPU core has no \
                    grid and no per-stage timers yet); use --backend cpu or auto"
                .into(),
        );
    }
    match &args.command {
        BenchCommand::Accuracy(a) => accuracy(a, out),
        BenchCommand::Scaling(a) => scaling(a, out),
    }
}

/// Which refinement triggers run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Refinement {
    None,
    Silhouette,
    SilhouetteCrease,
}

impl Refinement {
    fn name(self) -> &'static str {
        match self {
            Refinement::None => "none",
            Refinement::Silhouette => "silhouette",
            Refinement::SilhouetteCrease => "silhouette+crease",
        }
    }

    fn triggers(self, scene: &Scene) -> Triggers {
        let silhouette = self != Refinement::None;
        Triggers {
            silhouette,
            margin: silhouette,
            crease_deg: (self == Refinement::SilhouetteCrease).then_some(scene.crease_deg),
            depth_jump: None,
        }
    }
}

/// One point of the sweep. `layout: None` is full-resolution ray casting
/// (the reference; contrast, spacing and refinement do not apply).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    pub layout: Option<Layout>,
    pub contrast: f64,
    pub max_spacing_px: f64,
    pub refinement: Refinement,
    pub accel: AccelArg,
}

impl Config {
    pub fn name(&self) -> String {
        let accel = accel_name(self.accel);
        match self.layout {
            None => format!("full {accel}"),
            Some(l) => format!(
                "{} C={} n={} {} {accel}",
                l.name(),
                self.contrast,
                self.max_spacing_px,
                self.refinement.name()
            ),
        }
    }

    /// The configuration `gazecast render` uses by default.
    fn is_default(&self) -> bool {
        self.layout == Some(Layout::Nyquist)
            && self.contrast == 1.0
            && self.max_spacing_px == foveation::sampling::SEED_MAX_SPACING_PX
            && self.refinement == Refinement::SilhouetteCrease
            && self.accel == AccelArg::Bvh
    }
}

fn accel_name(a: AccelArg) -> &'static str {
    match a {
        AccelArg::Bvh => "bvh",
        AccelArg::Grid => "grid",
    }
}

/// The values of each knob the sweep takes.
type Axes = (
    &'static [Layout],
    &'static [f64],
    &'static [f64],
    &'static [Refinement],
    &'static [AccelArg],
);

/// The sweep: full resolution with each structure, then every combination
/// of the foveated knobs (144, or 8 in `--quick`).
pub fn configurations(quick: bool) -> Vec<Config> {
    let (layouts, contrasts, spacings, refinements, accels): Axes = if quick {
        (
            &[Layout::Seed, Layout::Nyquist],
            &[1.0, 0.25],
            &[17.0],
            &[Refinement::None, Refinement::SilhouetteCrease],
            &[AccelArg::Bvh],
        )
    } else {
        (
            &[Layout::Seed, Layout::Nyquist],
            &[1.0, 0.5, 0.25, 0.1],
            &[4.0, 8.0, 17.0],
            &[
                Refinement::None,
                Refinement::Silhouette,
                Refinement::SilhouetteCrease,
            ],
            &[AccelArg::Bvh, AccelArg::Grid],
        )
    };
    let mut out: Vec<Config> = accels
        .iter()
        .map(|&accel| Config {
            layout: None,
            contrast: 1.0,
            max_spacing_px: 1.0,
            refinement: Refinement::None,
            accel,
        })
        .collect();
    for &accel in accels {
        for &layout in layouts {
            for &contrast in contrasts {
                for &max_spacing_px in spacings {
                    for &refinement in refinements {
                        out.push(Config {
                            layout: Some(layout),
                            contrast,
                            max_spacing_px,
                            refinement,
                            accel,
                        });
                    }
                }
            }
        }
    }
    out
}

/// The centre, the four corner pixels, then seeded uniform positions.
pub fn gaze_positions(geometry: &ScreenGeometry, n: usize, seed: u64) -> Vec<[f64; 2]> {
    let [w, h] = geometry.size_px();
    let mut fixed = vec![
        geometry.centre_px(),
        [0.5, 0.5],
        [w - 0.5, h - 0.5],
        [w - 0.5, 0.5],
        [0.5, h - 0.5],
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    while fixed.len() < n {
        fixed.push([rng.random_range(0.0..w), rng.random_range(0.0..h)]);
    }
    fixed.truncate(n);
    fixed
}

/// One frame's timing: median of `repeats` after one warm-up, with the last
/// frame and its counts.
fn timed(
    scene: &Scene,
    camera: &Camera,
    model: &SamplingModel,
    settings: &Settings,
    gaze: [f64; 2],
    repeats: u32,
) -> Result<(Frame, Stats), String> {
    let mut times = Vec::new();
    let mut last = render(scene, camera, model, settings, gaze).map_err(|e| e.to_string())?;
    for _ in 0..repeats.max(1) {
        last = render(scene, camera, model, settings, gaze).map_err(|e| e.to_string())?;
        times.push(last.1.time_ms);
    }
    times.sort_by(f64::total_cmp);
    last.1.time_ms = times[times.len() / 2];
    Ok(last)
}

fn settings_for(config: &Config, scene: &Scene) -> Settings {
    Settings {
        mode: if config.layout.is_some() {
            Mode::Foveated
        } else {
            Mode::Full
        },
        layout: config.layout.unwrap_or_default(),
        triggers: config.refinement.triggers(scene),
        test: raycast::ray::TriangleTest::Watertight,
        check_coverage: false,
    }
}

fn use_accel(scene: &mut Scene, accel: AccelArg) {
    scene.accel = match accel {
        AccelArg::Bvh => Accel::Bvh,
        AccelArg::Grid => Accel::Grid,
    };
}

fn progress(total: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// One row of `results.csv`.
#[derive(Debug, Clone)]
pub struct Row {
    pub config: Config,
    pub gaze_index: usize,
    pub gaze_px: [f64; 2],
    pub stats: Stats,
    pub quality: Quality,
}

/// A configuration's figures over all gazes.
#[derive(Debug, Clone)]
pub struct Summary {
    pub config: Config,
    /// Mean over gazes of the per-gaze median frame time.
    pub time_ms: f64,
    pub rays: f64,
    pub quality: Quality,
    pub pareto: bool,
}

/// Per configuration, in sweep order; marks the Pareto front (no other
/// configuration is at least as fast and at least as good in foveated PSNR,
/// and strictly better in one).
pub fn summarise(rows: &[Row], configs: &[Config]) -> Vec<Summary> {
    let mut out: Vec<Summary> = configs
        .iter()
        .map(|c| {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.config == *c).collect();
            let n = mine.len().max(1) as f64;
            let mut quality = Quality::default();
            mine.iter().for_each(|r| quality.merge(&r.quality));
            Summary {
                config: *c,
                time_ms: mine.iter().map(|r| r.stats.time_ms).sum::<f64>() / n,
                rays: mine.iter().map(|r| r.stats.rays_total as f64).sum::<f64>() / n,
                quality,
                pareto: false,
            }
        })
        .collect();
    let score = |s: &Summary| s.quality.foveated.psnr_db().unwrap_or(f64::NEG_INFINITY);
    for i in 0..out.len() {
        let dominated = out.iter().any(|o| {
            o.time_ms <= out[i].time_ms
                && score(o) >= score(&out[i])
                && (o.time_ms < out[i].time_ms || score(o) > score(&out[i]))
        });
        out[i].pareto = !dominated;
    }
    out
}

fn create_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create: {e}", dir.display()))
}

fn write_file(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

fn fmt_db(v: Option<f64>) -> String {
    match v {
        None => String::new(),
        Some(x) if x.is_infinite() => "inf".into(),
        Some(x) => format!("{x:.3}"),
    }
}

/// The header of `results.csv`.
pub const RESULTS_HEADER: &str = "scene,width_px,height_px,backend,threads,config,layout,contrast,max_spacing_px,refinement,accel,gaze_index,gaze_x_px,gaze_y_px,time_ms,rays_total,rays_fovea,rays_mask,rays_refine,cells_total,cells_refined,psnr_db,psnr_2deg_db,psnr_5deg_db,psnr_10deg_db,foveated_psnr_db,silhouette_error";

fn accuracy(args: &AccuracyArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut scene = load_scene(&args.scene)?;
    // The sweep decides the passes, whatever the scene file lists.
    if !scene.has(Effect::FoveatedSampling) {
        scene.effects.push(Effect::FoveatedSampling);
    }
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let camera = Camera::new(&geometry);
    let configs = configurations(args.quick);
    if configs.iter().any(|c| c.accel == AccelArg::Grid) {
        scene.build_grid();
    }
    let n_gazes = if args.quick && args.gazes == 5 {
        2
    } else {
        args.gazes
    };
    if n_gazes == 0 {
        return Err("--gazes: must be at least 1".into());
    }
    let repeats = args.repeats.unwrap_or(if args.quick { 1 } else { 3 });
    let gazes = gaze_positions(&geometry, n_gazes, args.seed);
    let csf = GeislerPerry::default();
    let bar = progress((gazes.len() * (configs.len() + 1)) as u64, "accuracy sweep");

    // The reference of each gaze: full resolution, BVH.
    use_accel(&mut scene, AccelArg::Bvh);
    let full_model = SamplingModel::new(geometry, csf, 1.0, 1.0).map_err(|e| e.to_string())?;
    let full_settings = settings_for(&configs[0], &scene);
    let mut references = Vec::new();
    for &g in &gazes {
        let (frame, _) =
            render(&scene, &camera, &full_model, &full_settings, g).map_err(|e| e.to_string())?;
        // The gaze's per-pixel eccentricity and visibility: computed once,
        // shared by every configuration.
        let weights = GazeWeights::new(&geometry, &csf, g).map_err(|e| e.to_string())?;
        references.push((frame, weights));
        bar.inc(1);
    }

    let mut rows = Vec::new();
    for config in &configs {
        use_accel(&mut scene, config.accel);
        let model = SamplingModel::new(geometry, csf, config.contrast, config.max_spacing_px)
            .map_err(|e| format!("{}: {e}", config.name()))?;
        let settings = settings_for(config, &scene);
        for (k, (&g, (reference, weights))) in gazes.iter().zip(&references).enumerate() {
            let (frame, stats) = timed(&scene, &camera, &model, &settings, g, repeats)?;
            let quality = quality::compare_with(weights, &image(reference), &image(&frame))
                .map_err(|e| e.to_string())?;
            rows.push(Row {
                config: *config,
                gaze_index: k,
                gaze_px: g,
                stats,
                quality,
            });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();

    create_dir(&args.out)?;
    let threads = rayon::current_num_threads();
    let csv = results_csv(&rows, &scene.name, &geometry, threads);
    write_file(&args.out.join("results.csv"), &csv)?;
    let summaries = summarise(&rows, &configs);
    let pareto_png = args.out.join("pareto.png");
    plots::draw_pareto(
        &pareto_png,
        &format!(
            "{} at {}x{}, {} gazes, cpu ({} threads)",
            scene.name, geometry.width_px, geometry.height_px, n_gazes, threads
        ),
        &summaries
            .iter()
            .map(|s| plots::ParetoPoint {
                label: s.config.name(),
                time_ms: s.time_ms,
                quality_db: s.quality.foveated.psnr_db().unwrap_or(f64::NAN),
                pareto: s.pareto,
                highlight: s.config.is_default(),
                grid: s.config.accel == AccelArg::Grid,
            })
            .collect::<Vec<_>>(),
    )
    .map_err(|e| format!("{}: {e}", pareto_png.display()))?;
    let report = accuracy_report(args, &scene, &display, &gazes, repeats, &summaries);
    write_file(&args.out.join("report.md"), &report)?;

    let full = summaries
        .iter()
        .find(|s| s.config.layout.is_none() && s.config.accel == AccelArg::Bvh);
    let default = summaries.iter().find(|s| s.config.is_default());
    if let (Some(f), Some(d)) = (full, default) {
        writeln!(
            out,
            "{}: full {:.1} ms; default ({}) {:.1} ms = {:.2}x faster, PSNR {} dB, foveated PSNR {} dB",
            scene.name,
            f.time_ms,
            d.config.name(),
            d.time_ms,
            f.time_ms / d.time_ms,
            fmt_db(d.quality.screen.psnr_db()),
            fmt_db(d.quality.foveated.psnr_db()),
        )
        .map_err(|e| e.to_string())?;
    }
    writeln!(
        out,
        "{} configurations x {} gazes; {} on the Pareto front; wrote {}",
        configs.len(),
        gazes.len(),
        summaries.iter().filter(|s| s.pareto).count(),
        args.out.display()
    )
    .map_err(|e| e.to_string())
}

fn image(f: &Frame) -> Image<'_> {
    Image {
        width: f.width,
        height: f.height,
        rgb: &f.rgb,
        hit: &f.hit,
    }
}

fn results_csv(rows: &[Row], scene: &str, g: &ScreenGeometry, threads: usize) -> String {
    let mut s = String::from(RESULTS_HEADER);
    s.push('\n');
    for r in rows {
        let c = &r.config;
        let q = &r.quality;
        let _ = writeln!(
            s,
            "{scene},{},{},cpu,{threads},{},{},{},{},{},{},{},{:.2},{:.2},{:.3},{},{},{},{},{},{},{},{},{},{},{},{}",
            g.width_px,
            g.height_px,
            c.name(),
            c.layout.map_or("full", |l| l.name()),
            c.contrast,
            c.max_spacing_px,
            c.refinement.name(),
            accel_name(c.accel),
            r.gaze_index,
            r.gaze_px[0],
            r.gaze_px[1],
            r.stats.time_ms,
            r.stats.rays_total,
            r.stats.rays_fovea,
            r.stats.rays_mask,
            r.stats.rays_refine,
            r.stats.cells_total,
            r.stats.cells_refined,
            fmt_db(q.screen.psnr_db()),
            fmt_db(q.within[0].psnr_db()),
            fmt_db(q.within[1].psnr_db()),
            fmt_db(q.within[2].psnr_db()),
            fmt_db(q.foveated.psnr_db()),
            q.silhouette_error().map_or(String::new(), |e| format!("{e:.6}")),
        );
    }
    s
}

/// The processor, as the OS names it (Linux), and the thread count.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!(
        "{cpu}, {} rayon threads, CPU backend",
        rayon::current_num_threads()
    )
}

const METRICS_DOC: &str = "\
- **time**: wall time of one whole frame on the CPU backend (mask build, all rays, \
reconstruction, shading), median of the repeats after one warm-up, then the mean over the gazes.
- **rays**: rays cast per frame (fovea + mask vertices + refined pixels), mean over the gazes.
- **PSNR**: `10·log10(255²/MSE)` against the full-resolution frame of the same gaze, over all \
pixels and channels (8-bit). Over several gazes the MSEs are averaged first, so ∞ means exact at every gaze.
- **≤2°, ≤5°, ≤10°**: the same over the pixels within that visual angle of the gaze.
- **foveated PSNR**: PSNR of the visibility-weighted MSE `Σ w·e² / Σ w`, where `e²` is a pixel's \
squared error and `w = min(1, f_c(e)/f_N)`: the Geisler–Perry cut-off frequency at full contrast \
(Murphy 2007 eq. 4.3, C = 1) at the pixel's eccentricity, over the display's Nyquist frequency there \
(half the conservative local pixels per degree). It is the fraction of the frequencies the display \
can show at that pixel that the eye can see there: 1 where single pixels are resolved, smaller in \
the periphery. An error spread evenly gives the plain PSNR; the same error moved away from the gaze \
scores higher.
- **silhouette error**: fraction of pixels whose hit/miss (geometry or background) differs from the \
reference.
- **Pareto**: no other configuration is at least as fast and at least as good in foveated PSNR.
- Configurations: layout (`seed`: the seed's integer spacing; `nyquist`: the default), contrast C of \
the CSF cut-off (lower = sparser), maximum spacing n in pixels, refinement triggers (none; silhouette \
= corners disagree on hit/miss or object, plus the one-cell margin; + crease = corner normals differ \
by more than the scene's crease angle), acceleration structure (`bvh`; `grid`: the seed's uniform \
grid, §6.1.1). `full` casts one ray per pixel (the reference).";

fn accuracy_report(
    args: &AccuracyArgs,
    scene: &Scene,
    display: &Display,
    gazes: &[[f64; 2]],
    repeats: u32,
    summaries: &[Summary],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Accuracy versus time: `{}` on {}\n",
        scene.name, display.name
    );
    let _ = writeln!(
        s,
        "Command: `gazecast bench accuracy --scene {} --display {} --out {} --gazes {}{}{}`\n",
        args.scene.display(),
        args.display.display(),
        args.out.display(),
        gazes.len(),
        args.repeats
            .map_or(String::new(), |r| format!(" --repeats {r}")),
        if args.quick { " --quick" } else { "" }
    );
    let _ = writeln!(s, "- Machine: {}", machine());
    let _ = writeln!(
        s,
        "- Resolution {}x{}, {} triangles, {} timed repeats per frame",
        display.resolution_px.0,
        display.resolution_px.1,
        scene.triangles.len(),
        repeats
    );
    let gz: Vec<String> = gazes
        .iter()
        .map(|g| format!("({:.0}, {:.0})", g[0], g[1]))
        .collect();
    let _ = writeln!(s, "- Gazes (px): {}\n", gz.join(", "));
    let _ = writeln!(s, "![quality against time](pareto.png)\n");
    let full = summaries
        .iter()
        .find(|x| x.config.layout.is_none() && x.config.accel == AccelArg::Bvh)
        .map_or(f64::NAN, |x| x.time_ms);
    let _ = writeln!(s, "## Results, fastest first\n");
    let _ = writeln!(
        s,
        "| configuration | time ms | speed-up vs full bvh | rays | PSNR dB | ≤2° | ≤5° | ≤10° | foveated PSNR dB | silhouette error % | Pareto |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|:-:|");
    let mut sorted: Vec<&Summary> = summaries.iter().collect();
    sorted.sort_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
    for x in &sorted {
        let q = &x.quality;
        let name = if x.config.is_default() {
            format!("**{}** (default)", x.config.name())
        } else {
            x.config.name()
        };
        let _ = writeln!(
            s,
            "| {name} | {:.1} | {:.2} | {:.0} | {} | {} | {} | {} | {} | {} | {} |",
            x.time_ms,
            full / x.time_ms,
            x.rays,
            fmt_db(q.screen.psnr_db()),
            fmt_db(q.within[0].psnr_db()),
            fmt_db(q.within[1].psnr_db()),
            fmt_db(q.within[2].psnr_db()),
            fmt_db(q.foveated.psnr_db()),
            q.silhouette_error()
                .map_or(String::new(), |e| format!("{:.3}", 100.0 * e)),
            if x.pareto { "●" } else { "" }
        );
    }
    let _ = writeln!(s, "\n## What the columns mean\n\n{METRICS_DOC}");
    s
}

// ---------------------------------------------------------------- scaling

/// The procedural scene of the scaling sweep: a torus of about `triangles`
/// triangles, tilted, filling the middle of the view.
pub fn scaling_scene(triangles: u64) -> Result<Scene, String> {
    // segments × sides × 2 triangles, sides ≈ segments / 1.25.
    let segments = ((triangles as f64 / 2.0 * 1.25).sqrt().round() as u32).max(3);
    let sides = ((triangles as f64 / 2.0 / f64::from(segments)).round() as u32).max(3);
    let file = SceneFile {
        name: format!("torus-{}", 2 * u64::from(segments) * u64::from(sides)),
        background: (0.07, 0.07, 0.09),
        meshes: BTreeMap::from([(
            "torus".to_string(),
            MeshSource::Torus {
                major_radius: 1.0,
                minor_radius: 0.35,
                segments,
                sides,
            },
        )]),
        materials: BTreeMap::new(),
        objects: vec![Object {
            mesh: "torus".into(),
            material: None,
            translate_mm: (40.0, 0.0, -150.0),
            rotate_deg: (60.0, 20.0, 0.0),
            scale_mm: 150.0,
        }],
        lights: vec![Light::Headlight { intensity: 1.0 }],
        effects: vec![
            Effect::FoveatedSampling,
            Effect::SilhouetteRefinement,
            Effect::CreaseRefinement,
        ],
        crease_deg: 30.0,
        depth_jump: 0.05,
    };
    Scene::build(&file, Path::new(".")).map_err(|e| e.to_string())
}

/// A 27" 16:9 panel at 60 cm with `w×h` pixels: the physical size (and so
/// the eye's ray budget) stays, the pixel count changes.
pub fn scaling_display(w: u32, h: u32) -> Display {
    Display {
        name: format!("27\" {w}x{h} at 60 cm"),
        resolution_px: (w, h),
        size_mm: (596.7, 335.7),
        eye_distance_mm: 600.0,
        eye_point_px: None,
    }
}

/// One point of the scaling sweep.
#[derive(Debug, Clone, Copy)]
pub struct ScalingPoint {
    pub axis: &'static str,
    pub triangles: usize,
    pub width_px: u32,
    pub height_px: u32,
    pub full_ms: f64,
    pub foveated_ms: f64,
    pub full_rays: u64,
    pub foveated_rays: u64,
}

fn scaling_point(
    axis: &'static str,
    scene: &Scene,
    display: &Display,
    repeats: u32,
) -> Result<ScalingPoint, String> {
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let camera = Camera::new(&geometry);
    let model = crate::render_cmd::sampling_model(geometry, 1.0).map_err(|e| e.to_string())?;
    let gaze = geometry.centre_px();
    let mut settings = Settings {
        mode: Mode::Full,
        layout: Layout::Nyquist,
        triggers: Triggers::from_scene(scene),
        test: raycast::ray::TriangleTest::Watertight,
        check_coverage: false,
    };
    let (_, full) = timed(scene, &camera, &model, &settings, gaze, repeats)?;
    settings.mode = Mode::Foveated;
    let (_, fov) = timed(scene, &camera, &model, &settings, gaze, repeats)?;
    Ok(ScalingPoint {
        axis,
        triangles: scene.triangles.len(),
        width_px: geometry.width_px,
        height_px: geometry.height_px,
        full_ms: full.time_ms,
        foveated_ms: fov.time_ms,
        full_rays: full.rays_total,
        foveated_rays: fov.rays_total,
    })
}

/// Least-squares slope of log(y) against log(x): the exponent `k` of
/// `y ∝ x^k`. `None` with fewer than two distinct x.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (logs.len() >= 2 && sxx > 0.0).then(|| sxy / sxx)
}

fn scaling(args: &ScalingArgs, out: &mut dyn Write) -> Result<(), String> {
    let repeats = args.repeats.unwrap_or(if args.quick { 1 } else { 3 });
    let (triangle_counts, resolutions): (&[u64], &[(u32, u32)]) = if args.quick {
        (&[10_000, 100_000], &[(640, 360), (1280, 720)])
    } else {
        (
            &[10_000, 100_000, 1_000_000, 10_000_000],
            &[(1280, 720), (1920, 1080), (2560, 1440), (3840, 2160)],
        )
    };
    let base_res = if args.quick { (640, 360) } else { (1920, 1080) };
    let base_tris = 100_000;
    let bar = progress(
        (triangle_counts.len() + resolutions.len()) as u64,
        "scaling sweep",
    );
    let mut points = Vec::new();
    for &t in triangle_counts {
        let scene = scaling_scene(t)?;
        let d = scaling_display(base_res.0, base_res.1);
        points.push(scaling_point("triangles", &scene, &d, repeats)?);
        bar.inc(1);
    }
    let scene = scaling_scene(base_tris)?;
    for &(w, h) in resolutions {
        points.push(scaling_point(
            "resolution",
            &scene,
            &scaling_display(w, h),
            repeats,
        )?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    create_dir(&args.out)?;

    let mut csv = String::from(
        "axis,triangles,width_px,height_px,pixels,full_ms,foveated_ms,full_rays,foveated_rays\n",
    );
    for p in &points {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{:.3},{:.3},{},{}",
            p.axis,
            p.triangles,
            p.width_px,
            p.height_px,
            u64::from(p.width_px) * u64::from(p.height_px),
            p.full_ms,
            p.foveated_ms,
            p.full_rays,
            p.foveated_rays
        );
    }
    write_file(&args.out.join("scaling.csv"), &csv)?;

    let by =
        |axis: &str| -> Vec<&ScalingPoint> { points.iter().filter(|p| p.axis == axis).collect() };
    let tri = by("triangles");
    let res = by("resolution");
    let pixels = |p: &ScalingPoint| f64::from(p.width_px) * f64::from(p.height_px);
    let series = |pts: &[&ScalingPoint], x: &dyn Fn(&ScalingPoint) -> f64| {
        (
            pts.iter().map(|p| (x(p), p.full_ms)).collect::<Vec<_>>(),
            pts.iter()
                .map(|p| (x(p), p.foveated_ms))
                .collect::<Vec<_>>(),
        )
    };
    let (tri_full, tri_fov) = series(&tri, &|p| p.triangles as f64);
    let (res_full, res_fov) = series(&res, &pixels);
    let threads = rayon::current_num_threads();
    let tri_png = args.out.join("scaling-triangles.png");
    plots::draw_log_log(
        &tri_png,
        &format!(
            "Frame time vs triangles ({}x{}, cpu, {threads} threads)",
            base_res.0, base_res.1
        ),
        "triangles",
        &[("full resolution", &tri_full), ("foveated", &tri_fov)],
    )
    .map_err(|e| format!("{}: {e}", tri_png.display()))?;
    let res_png = args.out.join("scaling-resolution.png");
    plots::draw_log_log(
        &res_png,
        &format!(
            "Frame time vs pixels (27\" at 60 cm, {} triangles, cpu, {threads} threads)",
            res.first().map_or(0, |p| p.triangles)
        ),
        "pixels",
        &[("full resolution", &res_full), ("foveated", &res_fov)],
    )
    .map_err(|e| format!("{}: {e}", res_png.display()))?;

    let slope = |v: &[(f64, f64)]| log_log_slope(v).map_or("n/a".into(), |k| format!("{k:.2}"));
    let mut md = String::new();
    let _ = writeln!(md, "# Scaling: frame time against triangles and pixels\n");
    let _ = writeln!(
        md,
        "Command: `gazecast bench scaling --out {}{}`\n\n- Machine: {}\n- Scene: a tilted torus \
         (procedural), gaze at the screen centre, default configuration (nyquist, C = 1, n = 17, \
         silhouette + crease)\n- {} timed repeats after one warm-up, median\n",
        args.out.display(),
        if args.quick { " --quick" } else { "" },
        machine(),
        repeats
    );
    let _ = writeln!(
        md,
        "Exponent k of time ∝ x^k (least squares on the logs): triangles — full {}, foveated {}; \
         pixels — full {}, foveated {}.\n",
        slope(&tri_full),
        slope(&tri_fov),
        slope(&res_full),
        slope(&res_fov)
    );
    let _ = writeln!(md, "![time vs triangles](scaling-triangles.png)\n");
    let _ = writeln!(md, "![time vs pixels](scaling-resolution.png)\n");
    let _ = writeln!(
        md,
        "| axis | triangles | resolution | full ms | foveated ms | full/foveated | full rays | foveated rays |"
    );
    let _ = writeln!(md, "|---|---:|---|---:|---:|---:|---:|---:|");
    for p in &points {
        let _ = writeln!(
            md,
            "| {} | {} | {}x{} | {:.1} | {:.1} | {:.2} | {} | {} |",
            p.axis,
            p.triangles,
            p.width_px,
            p.height_px,
            p.full_ms,
            p.foveated_ms,
            p.full_ms / p.foveated_ms,
            p.full_rays,
            p.foveated_rays
        );
    }
    write_file(&args.out.join("scaling.md"), &md)?;
    writeln!(
        out,
        "time exponent vs triangles: full {}, foveated {}; vs pixels: full {}, foveated {}; wrote {}",
        slope(&tri_full),
        slope(&tri_fov),
        slope(&res_full),
        slope(&res_fov),
        args.out.display()
    )
    .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sweep_has_every_combination_once() {
        let all = configurations(false);
        assert_eq!(all.len(), 2 + 2 * 4 * 3 * 3 * 2);
        for (i, a) in all.iter().enumerate() {
            assert!(all[i + 1..].iter().all(|b| b != a), "{} twice", a.name());
        }
        assert_eq!(all.iter().filter(|c| c.is_default()).count(), 1);
        let quick = configurations(true);
        assert_eq!(quick.len(), 9);
        assert_eq!(quick.iter().filter(|c| c.is_default()).count(), 1);
    }

    #[test]
    fn gazes_start_with_centre_and_corners_and_are_seeded() {
        let g = scaling_display(100, 50).geometry().expect("valid");
        let a = gaze_positions(&g, 8, 3);
        assert_eq!(a[0], [50.0, 25.0]);
        assert_eq!(a[2], [99.5, 49.5]);
        assert_eq!(a, gaze_positions(&g, 8, 3));
        assert_ne!(a[5..], gaze_positions(&g, 8, 4)[5..]);
        assert!(a[5..]
            .iter()
            .all(|p| (0.0..100.0).contains(&p[0]) && (0.0..50.0).contains(&p[1])));
        assert_eq!(gaze_positions(&g, 1, 3).len(), 1);
    }

    fn row(config: Config, time_ms: f64, mse: f64) -> Row {
        let mut quality = Quality::default();
        quality.foveated.squared = mse;
        quality.foveated.weight = 1.0;
        Row {
            config,
            gaze_index: 0,
            gaze_px: [0.0, 0.0],
            stats: Stats {
                time_ms,
                ..Stats::default()
            },
            quality,
        }
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_configurations() {
        let c = configurations(true);
        // (time, mse): c1 fast and poor, c2 slow and good, c3 dominated by c2,
        // c4 equal to c1 in both (neither dominates the other).
        let rows = vec![
            row(c[1], 10.0, 100.0),
            row(c[2], 20.0, 10.0),
            row(c[3], 25.0, 20.0),
            row(c[4], 10.0, 100.0),
        ];
        let s = summarise(&rows, &c[1..5]);
        let front: Vec<bool> = s.iter().map(|x| x.pareto).collect();
        assert_eq!(front, [true, true, false, true]);
    }

    #[test]
    fn log_log_slope_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 1e5, 1e6]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(0.5)))
            .collect();
        let k = log_log_slope(&pts).expect("three points");
        assert!((k - 0.5).abs() < 1e-12, "{k}");
        assert_eq!(log_log_slope(&[(1.0, 2.0)]), None);
        assert_eq!(log_log_slope(&[(1.0, 2.0), (1.0, 3.0)]), None);
        assert_eq!(log_log_slope(&[]), None);
    }

    #[test]
    fn the_scaling_scene_has_about_the_asked_triangles() {
        for t in [10_000u64, 100_000] {
            let s = scaling_scene(t).expect("builds");
            let n = s.triangles.len() as f64;
            assert!((n / t as f64 - 1.0).abs() < 0.05, "{t}: {n}");
        }
    }
}
