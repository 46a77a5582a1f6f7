//! `gazecast bench stages`: where a foveated CPU frame's time goes, next to
//! a full-resolution frame of the same scene, display and gaze (the screen
//! centre). Full and foveated frames alternate, so that both see the same
//! machine load; each figure is the median over the repeats.

use std::io::Write;
use std::path::PathBuf;

use pipeline::{Method, Options, Renderer};
use raycast::render::StageTimes;
use raycast::Camera;

use crate::config::{self, load_scene};
use crate::stats::median;

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
}

/// Medians of one mode's frames.
struct Timing {
    ms: f64,
    rays: u64,
    stages: StageTimes,
}

fn frames(renderer: &mut Renderer<'_>, gaze: [f64; 2]) -> Result<(f64, u64, StageTimes), String> {
    let (frame, stats) = renderer.render(gaze).map_err(|e| e.to_string())?;
    renderer.recycle(frame);
    Ok((stats.time_ms, stats.rays_total, *renderer.cpu_stages()))
}

fn medians(runs: &[(f64, u64, StageTimes)]) -> Timing {
    let of =
        |f: &dyn Fn(&StageTimes) -> f64| median(&runs.iter().map(|r| f(&r.2)).collect::<Vec<_>>());
    Timing {
        ms: median(&runs.iter().map(|r| r.0).collect::<Vec<_>>()),
        rays: runs.last().map_or(0, |r| r.1),
        stages: StageTimes {
            mask: of(&|s| s.mask),
            vertex_rays: of(&|s| s.vertex_rays),
            classify: of(&|s| s.classify),
            margin: of(&|s| s.margin),
            ownership: of(&|s| s.ownership),
            pixels: of(&|s| s.pixels),
            pixel_casts_cpu: of(&|s| s.pixel_casts_cpu),
        },
    }
}

/// Runs `gazecast bench stages`.
pub fn run(args: &StagesArgs, out: &mut dyn Write) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    writeln!(
        out,
        "| scene | display | full ms | foveated ms | full / foveated | Mrays/s full | Mrays/s foveated | mask | vertex rays | classify | margin | ownership | pixels | pixel casts (cpu ms) |"
    )
    .map_err(io)?;
    writeln!(
        out,
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )
    .map_err(io)?;
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
                    ..Options::default()
                };
                Renderer::new(&scene, Camera::new(&geometry), model, &options)
                    .map_err(|e| e.to_string())
            };
            let mut full = make(Method::Full)?;
            let mut fov = make(Method::Hybrid)?;
            frames(&mut full, gaze)?;
            frames(&mut fov, gaze)?;
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for _ in 0..args.repeats.max(1) {
                a.push(frames(&mut full, gaze)?);
                b.push(frames(&mut fov, gaze)?);
            }
            let (f, v) = (medians(&a), medians(&b));
            let mrays = |t: &Timing| t.rays as f64 / t.ms / 1e3;
            let s = v.stages;
            writeln!(
                out,
                "| {} | {}x{} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
                scene.name,
                geometry.width_px,
                geometry.height_px,
                f.ms,
                v.ms,
                f.ms / v.ms,
                mrays(&f),
                mrays(&v),
                s.mask,
                s.vertex_rays,
                s.classify,
                s.margin,
                s.ownership,
                s.pixels,
                s.pixel_casts_cpu
            )
            .map_err(io)?;
        }
    }
    writeln!(out, "\nthreads: {}", rayon::current_num_threads()).map_err(io)
}
