//! `gazecast bench accuracy`: every configuration at every gaze, timed and
//! compared with the full-resolution frame of the same gaze.

use std::io::Write;

use foveation::quality::{self, GazeWeights, Image};
use foveation::{GeislerPerry, SamplingModel};
use pipeline::Renderer;
use raycast::scene::Sampling;
use raycast::{Camera, Frame};

use crate::args::AccelArg;
use crate::bench::configs::{budget_configurations, configurations, gaze_positions, options_for};
use crate::bench::measure::{progress, timed};
use crate::bench::report::{accuracy_report, create_dir, fmt_db, results_csv, write_file};
use crate::bench::summary::{summarise, Row};
use crate::bench::{AccuracyArgs, MAX_GAZES, MAX_REPEATS};
use crate::config::{self, load_scene};
use crate::plots;

/// What each gaze keeps for the whole sweep, per pixel: its full-resolution
/// reference frame (colour 3 B, hit 1, depth 4, object 4, normal 12, layer 1)
/// and its weights (eccentricity and visibility, 4 + 4).
const REFERENCE_BYTES_PER_PIXEL: u64 = 33;
/// Memory the references may take: 8 GB (184 gazes at 1280×1024).
const REFERENCE_BUDGET_BYTES: u64 = 8_000_000_000;

/// Runs `gazecast bench accuracy`.
pub fn run(args: &AccuracyArgs, out: &mut dyn Write) -> Result<(), String> {
    crate::output::Inputs::new()
        .scene("--scene", &args.scene)
        .file("--display", &args.display)
        .refuse_in(
            "--out",
            &args.out,
            &["results.csv", "pareto.png", "report.md"],
        )?;
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let n_gazes = if args.quick && args.gazes == 5 {
        2
    } else {
        args.gazes
    };
    // The command line bounds both (clap); checked again for other callers,
    // and against memory: every gaze keeps its reference frame and weights.
    if !(1..=MAX_GAZES).contains(&n_gazes) {
        return Err(format!("--gazes {n_gazes}: must be from 1 to {MAX_GAZES}"));
    }
    let repeats = args.repeats.unwrap_or(if args.quick { 1 } else { 3 });
    if !(1..=MAX_REPEATS).contains(&repeats) {
        return Err(format!(
            "--repeats {repeats}: must be from 1 to {MAX_REPEATS}"
        ));
    }
    let pixels = u64::from(geometry.width_px) * u64::from(geometry.height_px);
    let needed = (n_gazes as u64)
        .saturating_mul(pixels)
        .saturating_mul(REFERENCE_BYTES_PER_PIXEL);
    if needed > REFERENCE_BUDGET_BYTES {
        return Err(format!(
            "--gazes {n_gazes}: the reference frames at {}x{} would need about {:.1} GB \
             ({REFERENCE_BYTES_PER_PIXEL} bytes a pixel a gaze); at most {} gazes fit in {} GB",
            geometry.width_px,
            geometry.height_px,
            needed as f64 / 1e9,
            REFERENCE_BUDGET_BYTES / pixels.saturating_mul(REFERENCE_BYTES_PER_PIXEL).max(1),
            REFERENCE_BUDGET_BYTES / 1_000_000_000,
        ));
    }
    let mut scene = load_scene(&args.scene)?;
    // The sweep decides the passes, whatever the scene file lists.
    if !scene.sampling.is_foveated() {
        scene.sampling = Sampling::Foveated { refine: Vec::new() };
    }
    let camera = Camera::new(&geometry);
    let mut configs = configurations(args.quick);
    configs.extend(budget_configurations(&args.budget));
    if configs.iter().any(|c| c.accel == AccelArg::Grid) {
        scene.build_grid();
    }
    let gazes = gaze_positions(&geometry, n_gazes, args.seed);
    // A participant's fitted CSF drives the masks and weights the error
    // (`--thresholds`); `simplify` judges its folds by their table.
    let thresholds = args.thresholds.load()?;
    let csf = thresholds
        .as_ref()
        .map_or_else(GeislerPerry::default, |t| t.file.geisler_perry);
    let bar = progress((gazes.len() * (configs.len() + 1)) as u64, "accuracy sweep");

    // The reference of each gaze: full resolution, BVH.
    scene.accel = AccelArg::Bvh.into();
    let full_model = SamplingModel::new(geometry, csf, 1.0, 1.0).map_err(|e| e.to_string())?;
    let mut full = Renderer::new(
        &scene,
        camera,
        full_model,
        &options_for(&configs[0], &scene),
    )
    .map_err(|e| e.to_string())?;
    let mut references = Vec::new();
    for &g in &gazes {
        let (frame, _) = full.render(g).map_err(|e| e.to_string())?;
        // The gaze's per-pixel eccentricity and visibility: computed once,
        // shared by every configuration.
        let weights = GazeWeights::new(&geometry, &csf, g).map_err(|e| e.to_string())?;
        references.push((frame, weights));
        bar.inc(1);
    }

    let mut rows = Vec::new();
    for config in &configs {
        scene.accel = config.accel.into();
        let model = SamplingModel::new(geometry, csf, config.contrast, config.max_spacing_px)
            .map_err(|e| format!("{}: {e}", config.name()))?;
        let mut renderer = Renderer::new(&scene, camera, model, &options_for(config, &scene))
            .map_err(|e| e.to_string())?;
        if let Some(t) = &thresholds {
            t.apply(&mut renderer);
        }
        for (k, (&g, (reference, weights))) in gazes.iter().zip(&references).enumerate() {
            let (frame, stats) = timed(&mut renderer, g, repeats)?;
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
        .find(|s| s.config.method == pipeline::Method::Full && s.config.accel == AccelArg::Bvh);
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
        width: f.width_px,
        height: f.height_px,
        rgb: &f.rgb,
        hit: &f.hit,
    }
}
