//! Flat objects under every method: one triangle, an OBJ quad and a planar
//! OBJ polygon, facing the viewer, tilted, edge-on and from behind, cover
//! the pixels `Method::Full` covers under every other method (hybrid,
//! image, simplify — imperceptible, under a budget and without the gaze —
//! lod, ulod), up to the pixels along the outline, on the CPU; and the
//! model-based methods draw them on the GPU backend too.
//!
//! `cargo test -p pipeline --test flat_objects -- --nocapture` prints the
//! counts.

use std::path::{Path, PathBuf};

use foveation::Display;
use pipeline::model_based::ModelBasedOptions;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::scene::{Effect, MeshSource, Object};
use raycast::{Camera, Frame, Scene, SceneFile};

const W: u32 = 320;
const H: u32 = 256;

fn display() -> Display {
    Display::seed_17in(W, H)
}

/// A folder for the test's OBJ files.
fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("flat_objects");
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// The flat meshes, unit size in the xy plane, facing +z.
fn meshes() -> Vec<(&'static str, MeshSource)> {
    let d = dir();
    let quad = d.join("quad.obj");
    std::fs::write(&quad, "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n").expect("write");
    let polygon = d.join("polygon.obj");
    let mut text = String::new();
    for i in 0..9 {
        let a = std::f32::consts::TAU * i as f32 / 9.0;
        text += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    text += "f 1 2 3 4 5 6 7 8 9\n";
    std::fs::write(&polygon, text).expect("write");
    vec![
        (
            "triangle",
            MeshSource::Triangle {
                a: (-1.0, -1.0, 0.0),
                b: (1.0, -1.0, 0.0),
                c: (0.0, 1.0, 0.0),
            },
        ),
        (
            "quad",
            MeshSource::Obj {
                path: quad.display().to_string(),
            },
        ),
        (
            "polygon",
            MeshSource::Obj {
                path: polygon.display().to_string(),
            },
        ),
    ]
}

/// One flat object 25 mm in half-size behind the screen centre, turned
/// `tilt_deg` about the x axis (0: facing the viewer, 90: edge-on).
fn scene(mesh: &MeshSource, tilt_deg: f32) -> Scene {
    let file = SceneFile {
        name: "flat".into(),
        background: (0.06, 0.06, 0.08),
        meshes: [("m".to_string(), mesh.clone())].into(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "m".into(),
            material: None,
            translate_mm: (0.0, 0.0, -20.0),
            rotate_deg: (tilt_deg, 0.0, 0.0),
            scale_mm: 25.0,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![raycast::scene::Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(vec![Effect::FoveatedSampling, Effect::SilhouetteRefinement]),
        crease_deg: Some(30.0),
        depth_jump: Some(0.5),
        camera: None,
    };
    Scene::build(&file, &dir()).unwrap_or_else(|e| panic!("{e}"))
}

fn render(
    scene: &Scene,
    method: Method,
    model: ModelBasedOptions,
    gaze: [f64; 2],
) -> (Frame, usize) {
    render_on(scene, method, model, gaze, BackendChoice::Cpu)
}

/// A frame and the model-based triangle count (0 for the other methods).
fn render_on(
    scene: &Scene,
    method: Method,
    model: ModelBasedOptions,
    gaze: [f64; 2],
    backend: BackendChoice,
) -> (Frame, usize) {
    let g = display().geometry().expect("geometry");
    let sampling = pipeline::sampling_model(g, 1.0).expect("model");
    let mut r = Renderer::new(
        scene,
        Camera::new(&g),
        sampling,
        &Options {
            method,
            backend,
            model_based: model,
            ..Options::default()
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", method.name()));
    // Ulod sets its levels from the previous frame: render twice.
    r.render(gaze).expect("frame");
    let (frame, _) = r.render(gaze).expect("frame");
    let drawn = r.model_based().map_or(0, |m| m.last().triangles_drawn);
    (frame, drawn)
}

/// Hit pixels, and those with a 4-neighbour that is not hit (the outline).
fn hits(f: &Frame) -> (usize, usize) {
    let (w, h) = (W as usize, H as usize);
    let (mut n, mut outline) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            if !f.hit[y * w + x] {
                continue;
            }
            n += 1;
            let edge = x == 0
                || y == 0
                || x + 1 == w
                || y + 1 == h
                || !f.hit[y * w + x - 1]
                || !f.hit[y * w + x + 1]
                || !f.hit[(y - 1) * w + x]
                || !f.hit[(y + 1) * w + x];
            outline += usize::from(edge);
        }
    }
    (n, outline)
}

#[test]
fn every_method_draws_flat_objects_at_every_tilt() {
    let mut cases = vec![
        (Method::Hybrid, ModelBasedOptions::default()),
        (Method::Image, ModelBasedOptions::default()),
    ];
    cases.extend(model_cases());
    cases.push((Method::Ulod, ModelBasedOptions::default()));
    let centre = [f64::from(W) / 2.0, f64::from(H) / 2.0];
    let away = [20.0, 20.0];
    let mut failures = Vec::new();
    for (name, mesh) in meshes() {
        for tilt in [0.0, 1.0, 45.0, 85.0, 89.0, 90.0, 135.0, 180.0] {
            let s = scene(&mesh, tilt);
            for gaze in [centre, away] {
                let (reference, _) = render(&s, Method::Full, ModelBasedOptions::default(), gaze);
                let (full_hits, _) = hits(&reference);
                if tilt == 0.0 {
                    assert!(full_hits > 1000, "{name}: {full_hits} px");
                }
                if tilt == 85.0 {
                    assert!(full_hits > 20, "{name} nearly edge-on: {full_hits} px");
                }
                for &(method, model) in &cases {
                    let (frame, drawn) = render(&s, method, model, gaze);
                    check(&mut failures, &reference, &frame, drawn, || {
                        format!(
                            "{name} tilt {tilt}° gaze {gaze:?}: {} {model:?}",
                            method.name()
                        )
                    });
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The same objects through the GPU's raster pipeline (lavapipe without a
/// GPU): the model-based methods cover what the CPU's full frame covers.
#[test]
fn the_model_based_methods_draw_flat_objects_on_the_gpu() {
    let centre = [f64::from(W) / 2.0, f64::from(H) / 2.0];
    let mut failures = Vec::new();
    for (name, mesh) in meshes() {
        for tilt in [0.0, 45.0] {
            let s = scene(&mesh, tilt);
            let (reference, _) = render(&s, Method::Full, ModelBasedOptions::default(), centre);
            for (method, model) in model_cases() {
                let (frame, drawn) = render_on(&s, method, model, centre, BackendChoice::Gpu);
                check(&mut failures, &reference, &frame, drawn, || {
                    format!("GPU {name} tilt {tilt}°: {} {model:?}", method.name())
                });
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A frame's hit mask against the full frame's: the outline may move by a
/// pixel, nothing else.
fn check(
    failures: &mut Vec<String>,
    reference: &Frame,
    frame: &Frame,
    drawn: usize,
    what: impl Fn() -> String,
) {
    let (full_hits, outline) = hits(reference);
    let differ = (0..reference.len())
        .filter(|&i| reference.hit[i] != frame.hit[i])
        .count();
    let line = format!(
        "{}: {differ} px differ of {full_hits} hit ({outline} on the outline), {drawn} triangles",
        what()
    );
    eprintln!("{line}");
    if differ > outline + full_hits / 50 {
        failures.push(line);
    }
}

/// Simplify (imperceptible, under a budget, without the gaze) and lod
/// (with and without the gaze).
fn model_cases() -> Vec<(Method, ModelBasedOptions)> {
    vec![
        (Method::Simplify, ModelBasedOptions::default()),
        (
            Method::Simplify,
            ModelBasedOptions {
                budget: Some(1000),
                ignore_gaze: false,
            },
        ),
        (
            Method::Simplify,
            ModelBasedOptions {
                budget: None,
                ignore_gaze: true,
            },
        ),
        (Method::Lod, ModelBasedOptions::default()),
        (
            Method::Lod,
            ModelBasedOptions {
                budget: None,
                ignore_gaze: true,
            },
        ),
    ]
}
