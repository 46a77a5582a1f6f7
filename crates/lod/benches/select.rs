//! Selection time against triangle count (10⁴, 10⁵, 10⁶ and, with
//! `LOD_BENCH_10M=1`, 10⁷ triangles on a
//! torus 160 mm across, 500 mm from the eye, ~18° of visual angle), and the
//! incremental update when the gaze moves 1° or 20° between frames.
//!
//! `cargo bench --bench select -- --warm-up-time 1 --measurement-time 2`

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::{Quat, Vec3};
use lod::{Cut, Mode, View};

fn bench(c: &mut Criterion) {
    let table = common::table();
    let eye = Vec3::new(0.0, -450.0, 200.0);
    let centre = Vec3::ZERO;
    let to_centre = (centre - eye).normalize();
    // Rotate the gaze about the axis perpendicular to the view and z.
    let side = to_centre.cross(Vec3::Z).normalize();
    let gaze_at =
        |deg: f32| eye + Quat::from_axis_angle(side, deg.to_radians()) * to_centre * 490.0;
    let view = |gaze: Vec3| View {
        eye_mm: eye,
        gaze_point_mm: Some(gaze),
        thresholds: &table,
        scene_contrast: 0.9,
    };

    let mut group = c.benchmark_group("select");
    group.sample_size(10);
    // 10^7 triangles (a 2 GB tree build of about a minute) only on request:
    // LOD_BENCH_10M=1 cargo bench -p lod --bench select.
    let mut sizes = vec![(100u32, 50u32), (250, 200), (1000, 500)];
    if std::env::var_os("LOD_BENCH_10M").is_some() {
        sizes.push((3200, 1600));
    }
    for (nu, nv) in sizes {
        let mesh = common::torus(nu, nv, 60.0, 20.0, centre);
        let n_tri = mesh.triangles.len();
        let t0 = Instant::now();
        let tree = mesh.tree().expect("torus builds");
        let build_s = t0.elapsed().as_secs_f64();
        let mut cut = Cut::new(&tree);
        let t0 = Instant::now();
        let first = cut
            .select(&view(gaze_at(0.0)), &Mode::Imperceptible)
            .expect("view");
        eprintln!(
            "{n_tri} triangles: build {build_s:.3} s (depth {}), first select from full mesh {:.2} ms → {} triangles, {} visited",
            tree.max_depth(),
            t0.elapsed().as_secs_f64() * 1e3,
            first.triangles,
            first.nodes_visited
        );
        for (name, mode) in [
            ("imperceptible", Mode::Imperceptible),
            ("budget_20k", Mode::Budget { triangles: 20_000 }),
            ("murphy_duchowski", Mode::murphy_duchowski()),
        ] {
            if name != "imperceptible" && n_tri > 200_000 {
                continue;
            }
            cut.select(&view(gaze_at(0.0)), &mode).expect("view");
            group.bench_with_input(
                BenchmarkId::new(format!("{name}_steady"), n_tri),
                &mode,
                |b, mode| b.iter(|| cut.select(&view(gaze_at(0.0)), mode).expect("view")),
            );
            for step in [1.0f32, 20.0] {
                let mut flip = false;
                let mut last = None;
                group.bench_with_input(
                    BenchmarkId::new(format!("{name}_gaze_{step}deg"), n_tri),
                    &mode,
                    |b, mode| {
                        b.iter(|| {
                            flip = !flip;
                            let g = gaze_at(if flip { step } else { 0.0 });
                            last = Some(cut.select(&view(g), mode).expect("view"));
                        })
                    },
                );
                if let Some(r) = last {
                    eprintln!(
                        "  {name} gaze ±{step}°: {} triangles, {} visited, {} folds, {} unfolds per frame",
                        r.triangles, r.nodes_visited, r.folds, r.unfolds
                    );
                }
            }
        }
        cut.select(&view(gaze_at(0.0)), &Mode::Imperceptible)
            .expect("view");
        let mut out = Vec::new();
        // Writing out the imperceptible cut's triangles (what a renderer uploads).
        group.bench_function(BenchmarkId::new("triangles_into", n_tri), |b| {
            b.iter(|| cut.triangles_into(&mut out))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
