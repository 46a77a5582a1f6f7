//! Cost of the two depth-of-field passes (Lee 2009 ch. 4 mipmaps, ch. 5
//! splatting) against the mean circle of confusion, the layout of Lee's
//! Table 5.1: 8, 16 and 32 px.
//!
//! The scene: a wall of 30 bumpy balls 1.5 m behind the 17" screen, a ball
//! at the screen in focus, 640×512 px. The pupil is scaled so the mean
//! CoC over the blurred pixels (those with CoC ≥ 0.5 px) is the target (the
//! CoC is proportional to the pupil). Only the pass is timed, on a copy of
//! one rendered G-buffer. `cargo bench -p pipeline --bench dof`.

use std::path::Path;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use foveation::thin_lens::EyeLens;
use foveation::Display;
use pipeline::effects::depth_of_field::{coc_px, DepthOfField};
use pipeline::effects::dof_splat::DepthOfFieldSplat;
use pipeline::effects::{Pass, PassInput};
use pipeline::{BackendChoice, Options, Renderer};
use raycast::scene::DofFocus;
use raycast::{Camera, Frame, Scene, SceneFile};

const W: u32 = 640;
const H: u32 = 512;
/// The focused ball's front, eye distance (mm).
const FOCUS_MM: f64 = 480.0;

fn display() -> Display {
    Display::seed_17in(W, H)
}

fn scene() -> Scene {
    let mut objects = String::new();
    for j in 0..5 {
        for i in 0..6 {
            let x = -550.0 + 220.0 * i as f64;
            let y = -440.0 + 220.0 * j as f64;
            objects.push_str(&format!(
                "(mesh: \"ball\", material: Some(\"m{}\"), translate_mm: ({x}, {y}, -1500.0), scale_mm: 85.0),\n",
                (i + 2 * j) % 3
            ));
        }
    }
    let text = format!(
        r#"Scene(
    name: "dof-bench",
    background: (0.02, 0.03, 0.05),
    meshes: {{ "ball": Bumpy(triangles: 1500, amplitude: 0.15, seed: 7) }},
    materials: {{
        "m0": (diffuse: (0.9, 0.2, 0.1)),
        "m1": (diffuse: (0.1, 0.8, 0.2)),
        "m2": (diffuse: (0.2, 0.3, 0.9)),
    }},
    objects: [
        {objects}
        (mesh: "ball", translate_mm: (-30.0, 10.0, 0.0), scale_mm: 60.0),
    ],
)"#
    );
    let file: SceneFile = ron::from_str(&text).expect("the bench scene parses");
    Scene::build(&file, Path::new(".")).expect("the bench scene builds")
}

/// Mean CoC (px) over the pixels with CoC ≥ 0.5 px for `lens`.
fn mean_coc(frame: &Frame, cam: &Camera, lens: &EyeLens) -> f64 {
    let pitch = cam.pitch();
    let ppmm = 0.5 * (1.0 / f64::from(pitch[0]) + 1.0 / f64::from(pitch[1]));
    let ds = f64::from(cam.eye.z);
    let cocs: Vec<f64> = frame
        .depth_mm
        .iter()
        .filter(|d| d.is_finite())
        .map(|&d| coc_px(lens, f64::from(d), FOCUS_MM, ds, ppmm))
        .filter(|&c| c >= 0.5)
        .collect();
    cocs.iter().sum::<f64>() / cocs.len().max(1) as f64
}

fn bench(c: &mut Criterion) {
    let g = display().geometry().expect("geometry");
    let cam = Camera::new(&g);
    let scene = scene();
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let options = Options {
        backend: BackendChoice::Cpu,
        surface: true,
        ..Options::default()
    };
    let mut r = Renderer::new(&scene, cam, model, &options).expect("renderer");
    let gaze = [f64::from(W) / 2.0, f64::from(H) / 2.0];
    let (frame, _) = r.render(gaze).expect("renders");
    let unit = EyeLens {
        aperture_mm: 1.0,
        ..EyeLens::default()
    };
    let per_mm = mean_coc(&frame, &cam, &unit);
    let input = PassInput {
        scene: &scene,
        camera: &cam,
        gaze_px: gaze,
        time_s: None,
        vergence_mm: None,
    };
    let mut group = c.benchmark_group("dof_640x512");
    group.sample_size(10);
    for target in [8.0, 16.0, 32.0] {
        // The blurred set grows with the pupil: a few fixed-point steps
        // bring the measured mean to the target.
        let mut lens = EyeLens {
            aperture_mm: target / per_mm,
            ..EyeLens::default()
        };
        for _ in 0..6 {
            lens.aperture_mm *= target / mean_coc(&frame, &cam, &lens);
        }
        eprintln!(
            "mean CoC {target} px: pupil {:.2} mm (measured mean {:.2} px)",
            lens.aperture_mm,
            mean_coc(&frame, &cam, &lens)
        );
        let focus = DofFocus::Fixed { depth_mm: FOCUS_MM };
        let mut mipmap = DepthOfField::new(lens, focus);
        let mut splat = DepthOfFieldSplat::new(lens, focus);
        let passes: [(&str, &mut dyn Pass); 2] = [("mipmap", &mut mipmap), ("splat", &mut splat)];
        for (name, pass) in passes {
            group.bench_function(format!("{name}/coc_{target}px"), |b| {
                b.iter_batched_ref(
                    || frame.clone(),
                    |f| pass.run(f, &input),
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
