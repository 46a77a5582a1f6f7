//! `gazecast bench scaling`: frame time of full and foveated rendering
//! against triangle count and against resolution, on a procedural scene
//! and display whose size stays while the pixels change.

use std::io::Write;

use foveation::Display;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::scene::Effect;
use raycast::{Camera, Scene};

use crate::bench::measure::{progress, timed};
use crate::bench::report::{create_dir, scaling_csv, scaling_report, write_file};
use crate::bench::torus::{torus_scene, Placement};
use crate::bench::ScalingArgs;
use crate::plots;
use experiment::stats::tradeoff::log_log_slope;

/// The procedural scene of the scaling sweep: a torus of about `triangles`
/// triangles, tilted, filling the middle of the view.
pub fn scaling_scene(triangles: u64) -> Result<Scene, String> {
    // segments × sides × 2 triangles, sides ≈ segments / 1.25.
    let segments = ((triangles as f64 / 2.0 * 1.25).sqrt().round() as u32).max(3);
    let sides = ((triangles as f64 / 2.0 / f64::from(segments)).round() as u32).max(3);
    let at = Placement {
        translate_mm: (40.0, 0.0, -150.0),
        scale_mm: 150.0,
    };
    let effects = vec![
        Effect::FoveatedSampling,
        Effect::SilhouetteRefinement,
        Effect::CreaseRefinement,
    ];
    torus_scene(segments, sides, at, effects)
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
    /// Which sweep the point is on: `triangles` or `pixels`.
    pub axis: &'static str,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Frame width, pixels.
    pub width_px: u32,
    /// Frame height, pixels.
    pub height_px: u32,
    /// Median full-resolution frame time, ms.
    pub full_ms: f64,
    /// Median foveated frame time, ms.
    pub foveated_ms: f64,
    /// Rays of the full-resolution frame.
    pub full_rays: u64,
    /// Rays of the foveated frame.
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
    let model = pipeline::sampling_model(geometry, 1.0).map_err(|e| e.to_string())?;
    let gaze = geometry.centre_px();
    let options = |method| Options {
        method,
        backend: BackendChoice::Cpu,
        ..Options::default()
    };
    let mut renderer =
        Renderer::new(scene, camera, model, &options(Method::Full)).map_err(|e| e.to_string())?;
    let (_, full) = timed(&mut renderer, gaze, repeats)?;
    let mut renderer =
        Renderer::new(scene, camera, model, &options(Method::Hybrid)).map_err(|e| e.to_string())?;
    let (_, fov) = timed(&mut renderer, gaze, repeats)?;
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

/// Runs `gazecast bench scaling`.
pub fn run(args: &ScalingArgs, out: &mut dyn Write) -> Result<(), String> {
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

    write_file(&args.out.join("scaling.csv"), &scaling_csv(&points))?;

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
    let exponents = [
        slope(&tri_full),
        slope(&tri_fov),
        slope(&res_full),
        slope(&res_fov),
    ];
    write_file(
        &args.out.join("scaling.md"),
        &scaling_report(args, repeats, &points, &exponents),
    )?;
    writeln!(
        out,
        "time exponent vs triangles: full {}, foveated {}; vs pixels: full {}, foveated {}; wrote {}",
        exponents[0],
        exponents[1],
        exponents[2],
        exponents[3],
        args.out.display()
    )
    .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scaling_scene_has_about_the_asked_triangles() {
        for t in [10_000u64, 100_000] {
            let s = scaling_scene(t).expect("builds");
            let n = s.triangles.len() as f64;
            assert!((n / t as f64 - 1.0).abs() < 0.05, "{t}: {n}");
        }
    }
}
