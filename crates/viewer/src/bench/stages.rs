//! `gazecast bench stages`: where a foveated frame's time goes, next to a
//! full-resolution frame of the same scene, display and gaze (the screen
//! centre). Full and foveated frames alternate, so that both see the same
//! machine load; each figure is the median over the repeats.
//!
//! On the CPU the stages are the renderer's wall times
//! (`raycast::render::StageTimes`); on the GPU (`--backend gpu`) they are
//! the GPU core's timestamp queries per pass, where the adapter has them
//! (`pipeline::Renderer::stage_ms`; on a software adapter such as Mesa's
//! lavapipe they say where a software rasteriser spends its time, not what
//! a GPU costs). `effects` is the frame's wall time beyond its method: the
//! effect passes the scene lists, run after the method.
//!
//! On the GPU it also counts what each frame moves between the CPU and the
//! GPU (`pipeline::Renderer::gpu_traffic`: bytes uploaded and read back,
//! dispatches, submissions, counted at the `wgpu` calls, so exact on any
//! adapter) for three kinds of frame — full resolution, foveated with a
//! new mask every frame, foveated with the mask kept (0.5° gaze
//! tolerance, the live view's default) — as the median (p50) and the
//! maximum over every frame of that kind, the warm-up included; and the
//! rate of the headless frame loop: foveated frames rendered back to back
//! with the gaze jumping between two points (a new mask each frame), and
//! at one gaze with the mask kept. `--json FILE` writes every figure.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::gpu::Traffic;
use raycast::render::StageTimes;
use raycast::Camera;
use serde::Serialize;

use crate::config::{self, load_scene};
use experiment::stats::nearest_rank::median;

/// `--backend` of `bench stages`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StagesBackend {
    /// The CPU backend (stage times are wall times).
    Cpu,
    /// The GPU backend (stage times from timestamp queries).
    Gpu,
}

/// `gazecast bench stages`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct StagesArgs {
    /// Scene files (RON), comma-separated.
    #[arg(long, value_name = "FILE,…", value_delimiter = ',', required = true)]
    pub scene: Vec<PathBuf>,
    /// Display files (RON), comma-separated.
    #[arg(long, value_name = "FILE,…", value_delimiter = ',', required = true)]
    pub display: Vec<PathBuf>,
    /// Timed frames of each mode (1 to 1000, after one warm-up each).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: u32,
    /// Where to render (the GPU's stages come from its timestamp queries).
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: StagesBackend,
    /// Also write every figure as JSON (with `--backend gpu`: the traffic
    /// per frame and the frame loop's rate too).
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
}

/// One frame's figures.
struct Run {
    /// The method's time (`Stats::time_ms`).
    ms: f64,
    /// Wall time beyond the method: the effect passes.
    effects_ms: f64,
    rays: u64,
    cpu: StageTimes,
    gpu: Vec<(&'static str, f64)>,
    /// What the frame moved (the GPU backend).
    traffic: Option<Traffic>,
}

fn frame(renderer: &mut Renderer<'_>, gaze: [f64; 2]) -> Result<Run, String> {
    let t0 = Instant::now();
    let (frame, stats) = renderer.render(gaze).map_err(|e| e.to_string())?;
    let wall = t0.elapsed().as_secs_f64() * 1e3;
    renderer.recycle(frame);
    Ok(Run {
        ms: stats.time_ms,
        effects_ms: (wall - stats.time_ms).max(0.0),
        rays: stats.rays_total,
        cpu: *renderer.cpu_stages(),
        gpu: renderer.stage_ms().to_vec(),
        traffic: renderer.gpu_traffic(),
    })
}

/// The median (p50, nearest rank) and maximum of one traffic figure over
/// frames.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct P50Max {
    /// Median (nearest rank).
    pub p50: u64,
    /// Maximum.
    pub max: u64,
}

impl P50Max {
    fn of(values: &[u64]) -> Self {
        let as_f64: Vec<f64> = values.iter().map(|&v| v as f64).collect();
        let p50 = median(&as_f64);
        Self {
            p50: if p50.is_finite() { p50 as u64 } else { 0 },
            max: values.iter().copied().max().unwrap_or(0),
        }
    }
}

/// A kind of frame's traffic over its frames.
#[derive(Debug, Clone, Serialize)]
pub struct TrafficSummary {
    /// `full`, `foveated, new mask` or `foveated, kept mask`.
    pub frame: &'static str,
    /// Frames counted (the warm-up included).
    pub frames: usize,
    /// Bytes uploaded per frame.
    pub uploaded_bytes: P50Max,
    /// Bytes read back per frame.
    pub read_back_bytes: P50Max,
    /// Compute dispatches per frame.
    pub dispatches: P50Max,
    /// Draw calls per frame.
    pub draws: P50Max,
    /// Queue submits per frame.
    pub submits: P50Max,
}

impl TrafficSummary {
    fn of(frame: &'static str, runs: &[Traffic]) -> Self {
        let of = |f: &dyn Fn(&Traffic) -> u64| P50Max::of(&runs.iter().map(f).collect::<Vec<_>>());
        Self {
            frame,
            frames: runs.len(),
            uploaded_bytes: of(&|t| t.uploaded_bytes),
            read_back_bytes: of(&|t| t.read_back_bytes),
            dispatches: of(&|t| t.dispatches),
            draws: of(&|t| t.draws),
            submits: of(&|t| t.submits),
        }
    }
}

/// One pass's median GPU time (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct PassTime {
    /// The pass's name.
    pub pass: &'static str,
    /// Its median time, ms.
    pub ms: f64,
}

/// One scene and display (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct StagesRow {
    /// The scene's name.
    pub scene: String,
    /// Display width, pixels.
    pub width_px: u32,
    /// Display height, pixels.
    pub height_px: u32,
    /// Median full-resolution frame time (the method's), ms.
    pub full_ms: f64,
    /// Median foveated frame time (the method's), ms.
    pub foveated_ms: f64,
    /// `full_ms / foveated_ms`.
    pub full_over_foveated: f64,
    /// Million rays per second, full resolution.
    pub mrays_per_s_full: f64,
    /// Million rays per second, foveated.
    pub mrays_per_s_foveated: f64,
    /// The foveated frame's stages (CPU wall times or GPU timestamps).
    pub foveated_stages_ms: Vec<PassTime>,
    /// The full frame's passes (GPU timestamps; empty on the CPU).
    pub full_stages_ms: Vec<PassTime>,
    /// Median wall time beyond the method (the effect passes), ms.
    pub effects_ms: f64,
    /// The GPU backend: full, foveated with a new mask, foveated kept.
    pub traffic: Vec<TrafficSummary>,
    /// The GPU backend: foveated frames per second back to back, a new
    /// mask each frame.
    pub loop_fps_new_mask: Option<f64>,
    /// The GPU backend: foveated frames per second back to back at one
    /// gaze, the mask kept.
    pub loop_fps_kept_mask: Option<f64>,
    /// Frames in each back-to-back loop.
    pub loop_frames: u32,
}

/// The `--json` document.
#[derive(Debug, Clone, Serialize)]
pub struct StagesReport {
    /// The backend's name (`cpu` or `gpu`).
    pub backend: &'static str,
    /// The adapter in words (the GPU backend).
    pub adapter: Option<String>,
    /// Whether the adapter is a CPU implementation (lavapipe, llvmpipe):
    /// its times say nothing about a GPU's speed.
    pub software_adapter: Option<bool>,
    /// Whether the stage times come from timestamp queries.
    pub timestamps: bool,
    /// Timed frames per mode.
    pub repeats: u32,
    /// One row per scene and display.
    pub rows: Vec<StagesRow>,
}

/// Renders `frames` foveated frames back to back at the gazes `gazes`
/// (cycled), each frame's buffers recycled; returns frames per second and
/// the frames' traffic.
fn frame_loop(
    renderer: &mut Renderer<'_>,
    gazes: &[[f64; 2]],
    frames: u32,
) -> Result<(f64, Vec<Traffic>), String> {
    let mut traffic = Vec::with_capacity(frames as usize);
    let t0 = Instant::now();
    for k in 0..frames as usize {
        let gaze = gazes[k % gazes.len()];
        let (frame, _) = renderer.render(gaze).map_err(|e| e.to_string())?;
        renderer.recycle(frame);
        traffic.extend(renderer.gpu_traffic());
    }
    let s = t0.elapsed().as_secs_f64();
    Ok((f64::from(frames) / s.max(1e-9), traffic))
}

/// Medians of one mode's frames.
struct Timing {
    ms: f64,
    effects_ms: f64,
    rays: u64,
    stages: Vec<(&'static str, f64)>,
}

fn medians(runs: &[Run], backend: StagesBackend) -> Timing {
    let of = |f: &dyn Fn(&Run) -> f64| median(&runs.iter().map(f).collect::<Vec<_>>());
    let stages = match backend {
        StagesBackend::Cpu => StageTimes::default()
            .named()
            .iter()
            .enumerate()
            .map(|(k, &(name, _))| (name, of(&|r: &Run| r.cpu.named()[k].1)))
            .collect(),
        StagesBackend::Gpu => runs
            .last()
            .map(|last| {
                last.gpu
                    .iter()
                    .enumerate()
                    .map(|(k, &(name, _))| {
                        (name, of(&|r: &Run| r.gpu.get(k).map_or(f64::NAN, |s| s.1)))
                    })
                    .collect()
            })
            .unwrap_or_default(),
    };
    Timing {
        ms: of(&|r| r.ms),
        effects_ms: of(&|r| r.effects_ms),
        rays: runs.last().map_or(0, |r| r.rays),
        stages,
    }
}

/// Runs `gazecast bench stages`.
pub fn run(args: &StagesArgs, out: &mut dyn Write) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    let mut header_written = false;
    let mut adapter = None;
    let mut timed = false;
    let mut rows = Vec::new();
    let mut traffic_lines = Vec::new();
    for scene_path in &args.scene {
        let scene = load_scene(scene_path)?;
        for display_path in &args.display {
            let display = config::load_display(display_path).map_err(|e| e.to_string())?;
            let geometry = display.geometry().map_err(|e| e.to_string())?;
            let model = pipeline::sampling_model(geometry, 1.0)
                .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
            let gaze = geometry.centre_px();
            let make_with = |method, model| {
                let options = Options {
                    method,
                    backend: match args.backend {
                        StagesBackend::Cpu => BackendChoice::Cpu,
                        StagesBackend::Gpu => BackendChoice::Gpu,
                    },
                    ..Options::default()
                };
                Renderer::new(&scene, Camera::new(&geometry), model, &options)
                    .map_err(|e| e.to_string())
            };
            let make = |method| make_with(method, model);
            let mut full = make(Method::Full)?;
            let mut fov = make(Method::Hybrid)?;
            adapter = adapter.or_else(|| fov.adapter().map(str::to_string));
            let warm_full = frame(&mut full, gaze)?;
            let warm_fov = frame(&mut fov, gaze)?;
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for _ in 0..args.repeats.max(1) {
                a.push(frame(&mut full, gaze)?);
                b.push(frame(&mut fov, gaze)?);
            }
            let (f, v) = (medians(&a, args.backend), medians(&b, args.backend));
            let mut traffic = Vec::new();
            let (mut loop_new, mut loop_kept) = (None, None);
            if args.backend == StagesBackend::Gpu {
                let all = |warm: &Run, runs: &[Run]| -> Vec<Traffic> {
                    std::iter::once(warm)
                        .chain(runs)
                        .filter_map(|r| r.traffic)
                        .collect()
                };
                traffic.push(TrafficSummary::of("full", &all(&warm_full, &a)));
                traffic.push(TrafficSummary::of(
                    "foveated, new mask",
                    &all(&warm_fov, &b),
                ));
                // The headless loop: a new mask every frame (the gaze jumps
                // a quarter of the screen), then one gaze with the mask kept.
                let [cx, cy] = gaze;
                let away = [cx + geometry.width_px as f64 / 4.0, cy];
                let (fps, _) = frame_loop(&mut fov, &[away, gaze], args.repeats.max(1))?;
                loop_new = Some(fps);
                let kept_model = model
                    .with_gaze_tolerance_deg(crate::args::LIVE_GAZE_TOLERANCE_DEG)
                    .map_err(|e| e.to_string())?;
                let mut kept = make_with(Method::Hybrid, kept_model)?;
                // Its first frame builds the mask; the loop keeps it.
                frame(&mut kept, gaze)?;
                let (fps, kept_traffic) = frame_loop(&mut kept, &[gaze], args.repeats.max(1))?;
                loop_kept = Some(fps);
                traffic.push(TrafficSummary::of("foveated, kept mask", &kept_traffic));
            }
            timed |= !v.stages.is_empty();
            if !header_written {
                let names: Vec<&str> = v.stages.iter().map(|s| s.0).collect();
                writeln!(
                    out,
                    "| scene | display | full ms | foveated ms | full / foveated | Mrays/s full | Mrays/s foveated | {} | effects |",
                    names.join(" | ")
                )
                .map_err(io)?;
                writeln!(out, "|---|---|{}", "---:|".repeat(names.len() + 6)).map_err(io)?;
                header_written = true;
            }
            let mrays = |t: &Timing| t.rays as f64 / t.ms / 1e3;
            let stages: Vec<String> = v.stages.iter().map(|s| format!("{:.1}", s.1)).collect();
            writeln!(
                out,
                "| {} | {}x{} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {} | {:.1} |",
                scene.name,
                geometry.width_px,
                geometry.height_px,
                f.ms,
                v.ms,
                f.ms / v.ms,
                mrays(&f),
                mrays(&v),
                stages.join(" | "),
                v.effects_ms,
            )
            .map_err(io)?;
            for t in &traffic {
                traffic_lines.push(format!(
                    "| {} | {}x{} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    scene.name,
                    geometry.width_px,
                    geometry.height_px,
                    t.frame,
                    t.frames,
                    t.uploaded_bytes.p50,
                    t.uploaded_bytes.max,
                    t.read_back_bytes.p50,
                    t.read_back_bytes.max,
                    t.dispatches.p50,
                    t.dispatches.max,
                    t.submits.p50,
                    t.submits.max,
                ));
            }
            if let (Some(n), Some(k)) = (loop_new, loop_kept) {
                traffic_lines.push(format!(
                    "| {} | {}x{} | loop fps: {n:.1} new mask, {k:.1} kept mask | | | | | | | | | |",
                    scene.name, geometry.width_px, geometry.height_px,
                ));
            }
            let pass_times = |t: &[(&'static str, f64)]| -> Vec<PassTime> {
                t.iter().map(|&(pass, ms)| PassTime { pass, ms }).collect()
            };
            rows.push(StagesRow {
                scene: scene.name.clone(),
                width_px: geometry.width_px,
                height_px: geometry.height_px,
                full_ms: f.ms,
                foveated_ms: v.ms,
                full_over_foveated: f.ms / v.ms,
                mrays_per_s_full: mrays(&f),
                mrays_per_s_foveated: mrays(&v),
                foveated_stages_ms: pass_times(&v.stages),
                full_stages_ms: match args.backend {
                    StagesBackend::Cpu => Vec::new(),
                    StagesBackend::Gpu => pass_times(&f.stages),
                },
                effects_ms: v.effects_ms,
                traffic,
                loop_fps_new_mask: loop_new,
                loop_fps_kept_mask: loop_kept,
                loop_frames: args.repeats.max(1),
            });
        }
    }
    if !traffic_lines.is_empty() {
        writeln!(
            out,
            "\nper frame, between the CPU and the GPU (counted at the wgpu calls; p50 and max over the frames, the warm-up included):\n\n\
             | scene | display | frame | frames | uploaded B p50 | uploaded B max | read back B p50 | read back B max | dispatches p50 | dispatches max | submits p50 | submits max |\n\
             |---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        )
        .map_err(io)?;
        for l in &traffic_lines {
            writeln!(out, "{l}").map_err(io)?;
        }
    }
    match (args.backend, adapter.clone()) {
        (StagesBackend::Cpu, _) => {
            writeln!(out, "\ncpu, threads: {}", rayon::current_num_threads()).map_err(io)?
        }
        (StagesBackend::Gpu, a) => writeln!(
            out,
            "\ngpu: {}; {}",
            a.unwrap_or_else(|| "unknown adapter".into()),
            if timed {
                "stage times from the adapter's timestamp queries"
            } else {
                "the adapter has no timestamp queries: no stage times"
            }
        )
        .map_err(io)?,
    }
    if let Some(path) = &args.json {
        let software = match args.backend {
            StagesBackend::Cpu => None,
            StagesBackend::Gpu => raycast::gpu::probe().ok().map(|(_, sw)| sw),
        };
        let report = StagesReport {
            backend: match args.backend {
                StagesBackend::Cpu => "cpu",
                StagesBackend::Gpu => "gpu",
            },
            adapter,
            software_adapter: software,
            timestamps: timed,
            repeats: args.repeats.max(1),
            rows,
        };
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        std::fs::write(path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}
