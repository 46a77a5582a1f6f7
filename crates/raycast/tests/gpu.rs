//! The GPU core against the CPU reference (full resolution), on whatever
//! adapter the machine has — Mesa's lavapipe where there is no GPU, which
//! `scripts/system-deps.sh` installs.

use std::path::Path;

use foveation::{Display, GeislerPerry, Layout, SamplingModel};
use raycast::gpu::GpuRenderer;
use raycast::ray::TriangleTest;
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::scene::{Light, MeshSource, Object};
use raycast::{Camera, Frame, Scene, SceneFile};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn display(w: u32, h: u32) -> Display {
    Display {
        name: "17in".into(),
        resolution_px: (w, h),
        size_mm: (337.9, 270.3),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    }
}

fn load(name: &str) -> Scene {
    let path = repo().join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn gpu(scene: &Scene) -> GpuRenderer {
    GpuRenderer::new(scene).unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

fn cpu_full(scene: &Scene, d: &Display) -> Frame {
    let g = d.geometry().expect("geometry");
    let model = SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let s = Settings {
        mode: Mode::Full,
        layout: Layout::Nyquist,
        triggers: Triggers::NONE,
        test: TriangleTest::Watertight,
        check_coverage: false,
    };
    render(scene, &Camera::new(&g), &model, &s, g.centre_px())
        .expect("renders")
        .0
}

/// (hit/miss mismatches, pixels with a colour difference above 1, largest
/// difference where both hit or both miss).
fn compare(a: &Frame, b: &Frame) -> (usize, usize, u8) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (mut hit, mut colour, mut worst) = (0, 0, 0u8);
    for i in 0..a.hit.len() {
        if a.hit[i] != b.hit[i] {
            hit += 1;
            continue;
        }
        let d = (0..3)
            .map(|c| a.rgb[3 * i + c].abs_diff(b.rgb[3 * i + c]))
            .max()
            .unwrap_or(0);
        worst = worst.max(d);
        if d > 1 {
            colour += 1;
        }
    }
    (hit, colour, worst)
}

#[test]
fn gpu_frames_match_the_cpu_reference_on_every_shipped_scene() {
    for name in ["search-task", "bunny", "stress"] {
        let scene = load(name);
        let mut g = gpu(&scene);
        for (w, h) in [(160, 128), (321, 257)] {
            let d = display(w, h);
            let cam = Camera::new(&d.geometry().expect("geometry"));
            let (frame, stats) = g.render_full(&cam).expect("gpu renders");
            let cpu = cpu_full(&scene, &d);
            let (hit, colour, worst) = compare(&cpu, &frame);
            eprintln!(
                "{name} {w}x{h} on {}: {hit} hit/miss differences, {colour} colour differences > 1, worst {worst}",
                g.adapter()
            );
            // Grazing edges may go either way in f32 (the CPU re-tests
            // exactly-zero edge functions in f64, the GPU cannot).
            assert!(hit <= 4, "{name}: {hit} hit/miss differences");
            // Ties between two triangles at a shared edge may pick the
            // other triangle (other vertex normals): a handful of pixels.
            assert!(
                colour <= 4,
                "{name}: {colour} pixels differ by more than 1/255"
            );
            assert_eq!(stats.rays_total, u64::from(w) * u64::from(h));
        }
    }
}

fn sphere_scene(radius_mm: f32) -> Scene {
    let file = SceneFile {
        name: "sphere".into(),
        background: (0.1, 0.1, 0.12),
        meshes: [("s".to_string(), MeshSource::Icosphere { subdivisions: 3 })].into(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "s".into(),
            material: None,
            translate_mm: (0.0, 0.0, -100.0),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: radius_mm,
        }],
        lights: vec![
            Light::Headlight { intensity: 0.7 },
            Light::Point {
                position_mm: (200.0, 300.0, 400.0),
                intensity: 0.5,
            },
            Light::Directional {
                direction: (0.0, -1.0, -1.0),
                intensity: 0.3,
            },
        ],
        effects: vec![],
        crease_deg: 30.0,
        depth_jump: 0.05,
    };
    Scene::build(&file, Path::new(".")).expect("builds")
}

#[test]
fn hard_cases_one_pixel_4k_and_an_empty_scene() {
    let scene = sphere_scene(120.0);
    let mut g = gpu(&scene);
    for (w, h) in [(1, 1), (3840, 2160), (7, 3)] {
        let d = display(w, h);
        let (frame, _) = g
            .render_full(&Camera::new(&d.geometry().expect("geometry")))
            .expect("renders");
        let (hit, colour, _) = compare(&cpu_full(&scene, &d), &frame);
        assert!(hit <= 4 && colour <= 4, "{w}x{h}: {hit} / {colour}");
    }
    // Nothing in the scene: every pixel is background.
    let mut empty = sphere_scene(1.0);
    empty.triangles.clear();
    empty.bvh = raycast::bvh::Bvh::build(&[]);
    let mut g = gpu(&empty);
    let d = display(40, 30);
    let (frame, _) = g
        .render_full(&Camera::new(&d.geometry().expect("geometry")))
        .expect("renders");
    assert!(frame.hit.iter().all(|h| !h));
    assert!(frame.rgb.chunks(3).all(|p| p == empty.background_rgb8));
}

/// Resident memory of this process (lavapipe's "GPU memory" is host memory).
fn rss_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    pages * 4096
}

#[test]
fn rendering_many_frames_reuses_its_buffers() {
    // 512×384: a frame's output and readback buffers are 1.5 MiB, so
    // allocating them per frame would grow memory by ~150 MiB over 100 frames.
    let scene = sphere_scene(120.0);
    let d = display(512, 384);
    let cam = Camera::new(&d.geometry().expect("geometry"));
    // Creating the pipeline twice must not break anything either.
    let _first = gpu(&scene);
    let mut g = gpu(&scene);
    for _ in 0..10 {
        g.render_full(&cam).expect("renders");
    }
    let before = rss_bytes();
    for _ in 0..100 {
        g.render_full(&cam).expect("renders");
    }
    let grown = rss_bytes().saturating_sub(before);
    assert!(
        grown < 16 << 20,
        "100 frames grew resident memory by {} MiB",
        grown >> 20
    );
}
