//! Primary-ray throughput: every pixel's ray through a scene's BVH, closest
//! hit only (no shading), median of 5 passes. Prints one JSON line: the
//! packets' figures (`rays_per_s`: rows cast eight pixels a packet, as the
//! renderer does) and the single rays' (`rays_per_s_single`), and the
//! hierarchy's quality: the interior nodes (`nodes_per_ray`, four boxes
//! each) and triangles (`triangles_per_ray`) a single ray's walk tests,
//! per ray (`Scene::traversal_steps`).
//!
//! `cargo run --release -p raycast --example trace_rays -- SCENE.ron DISPLAY.ron [--grid] [--dump DIR]`
//!
//! `--grid` traces through the seed's uniform grid instead of the BVH.
//!
//! With `--dump`, also writes the world triangles (`triangles.f32`, 9 f32 per
//! triangle) and the rays (`rays.f32`, origin + direction, 6 f32 per ray) so
//! `bench/embree_compare.py` can trace exactly the same work with Embree.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use raycast::ray::TriangleTest;
use raycast::{Camera, Scene, SceneFile};
use rayon::prelude::*;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene_path, display_path, rest @ ..] = args.as_slice() else {
        return Err("usage: trace_rays SCENE.ron DISPLAY.ron [--dump DIR]".into());
    };
    let text = std::fs::read_to_string(scene_path).map_err(|e| format!("{scene_path}: {e}"))?;
    let file: SceneFile = ron::from_str(&text).map_err(|e| format!("{scene_path}: {e}"))?;
    let mut scene = Scene::build(
        &file,
        Path::new(scene_path).parent().unwrap_or(Path::new(".")),
    )
    .map_err(|e| e.to_string())?;
    let accel = if rest.iter().any(|a| a == "--grid") {
        scene.build_grid();
        "grid"
    } else {
        "bvh"
    };
    let text = std::fs::read_to_string(display_path).map_err(|e| format!("{display_path}: {e}"))?;
    let display: foveation::Display =
        ron::from_str(&text).map_err(|e| format!("{display_path}: {e}"))?;
    let g = display.geometry().map_err(|e| e.to_string())?;
    let cam = Camera::new(&g);
    let (w, h) = (g.width_px, g.height_px);
    let rays: Vec<raycast::ray::Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_ray(x, y))
        .collect();
    // Single rays, one by one; then packets of neighbouring pixels of a
    // row (`Scene::intersect_packet`, what the renderer casts), passes
    // alternating. The headline figure is the packets'.
    let width = w as usize;
    let mut single_times = Vec::new();
    let mut times = Vec::new();
    let mut hits = 0;
    let mut single_hits = 0;
    for _ in 0..5 {
        let start = Instant::now();
        single_hits = rays
            .par_iter()
            .filter(|r| scene.intersect(r, 0.0, TriangleTest::Watertight).is_some())
            .count();
        single_times.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        hits = rays
            .par_chunks(width.max(1))
            .map(|row| {
                let mut out = [None; raycast::bvh4::PACKET];
                row.chunks(raycast::bvh4::PACKET)
                    .map(|p| {
                        let out = &mut out[..p.len()];
                        scene.intersect_packet(p, 0.0, TriangleTest::Watertight, out);
                        out.iter().filter(|h| h.is_some()).count()
                    })
                    .sum::<usize>()
            })
            .sum();
        times.push(start.elapsed().as_secs_f64());
    }
    if hits != single_hits {
        return Err(format!(
            "packets hit {hits} rays, single rays {single_hits}"
        ));
    }
    // The hierarchy's quality: per ray, interior nodes (four boxes each)
    // and triangles tested by the single-ray walk.
    let (mut nodes, mut tris, mut walked) = (0u64, 0u64, 0u64);
    for r in &rays {
        if let Some((n, t)) = scene.traversal_steps(r) {
            nodes += u64::from(n);
            tris += u64::from(t);
            walked += 1;
        }
    }
    let per_ray = |x: u64| x as f64 / walked.max(1) as f64;
    times.sort_by(f64::total_cmp);
    single_times.sort_by(f64::total_cmp);
    let median = times[2];
    let single_median = single_times[2];
    if let Some(i) = rest.iter().position(|a| a == "--dump") {
        let dir = Path::new(rest.get(i + 1).ok_or("--dump needs a directory")?);
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
        let tris: Vec<f32> = scene
            .triangles
            .iter()
            .flat_map(|t| t.p.iter().flat_map(|p| p.to_array()))
            .collect();
        let r: Vec<f32> = rays
            .iter()
            .flat_map(|r| r.origin.to_array().into_iter().chain(r.dir.to_array()))
            .collect();
        for (name, data) in [("triangles.f32", &tris), ("rays.f32", &r)] {
            let mut f = std::fs::File::create(dir.join(name)).map_err(|e| e.to_string())?;
            f.write_all(bytemuck::cast_slice(data))
                .map_err(|e| e.to_string())?;
        }
    }
    println!(
        "{{\"scene\":\"{}\",\"accel\":\"{}\",\"triangles\":{},\"rays\":{},\"hits\":{},\"threads\":{},\"seconds\":{:.6},\"rays_per_s\":{:.0},\"rays_per_s_per_thread\":{:.0},\"seconds_single\":{:.6},\"rays_per_s_single\":{:.0},\"nodes_per_ray\":{:.2},\"triangles_per_ray\":{:.2}}}",
        scene.name,
        accel,
        scene.triangles.len(),
        rays.len(),
        hits,
        rayon::current_num_threads(),
        median,
        rays.len() as f64 / median,
        rays.len() as f64 / median / rayon::current_num_threads() as f64,
        single_median,
        rays.len() as f64 / single_median,
        per_ray(nodes),
        per_ray(tris)
    );
    Ok(())
}
