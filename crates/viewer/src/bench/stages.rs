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

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::render::StageTimes;
use raycast::Camera;

use crate::config::{self, load_scene};
use experiment::stats::nearest_rank::median;

/// `--backend` of `bench stages`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StagesBackend {
    Cpu,
    Gpu,
}

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
    })
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
    for scene_path in &args.scene {
        let scene = load_scene(scene_path)?;
        for display_path in &args.display {
            let display = config::load_display(display_path).map_err(|e| e.to_string())?;
            let geometry = display.geometry().map_err(|e| e.to_string())?;
            let model = pipeline::sampling_model(geometry, 1.0)
                .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
            let gaze = geometry.centre_px();
            let make = |method| {
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
            let mut full = make(Method::Full)?;
            let mut fov = make(Method::Hybrid)?;
            adapter = adapter.or_else(|| fov.adapter().map(str::to_string));
            frame(&mut full, gaze)?;
            frame(&mut fov, gaze)?;
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for _ in 0..args.repeats.max(1) {
                a.push(frame(&mut full, gaze)?);
                b.push(frame(&mut fov, gaze)?);
            }
            let (f, v) = (medians(&a, args.backend), medians(&b, args.backend));
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
        }
    }
    match (args.backend, adapter) {
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
    Ok(())
}
