//! The GPU core against the CPU reference, full resolution and foveated:
//! colour, hit and layer, and the G-buffer (depth, object id, normal), on
//! whatever adapter the machine has — Mesa's lavapipe where there is no GPU,
//! which `scripts/system-deps.sh` installs.

mod common;

use common::{display, load};

use std::path::Path;

use foveation::{Display, GeislerPerry, Layout, SamplingModel};
use raycast::gpu::GpuRenderer;
use raycast::ray::TriangleTest;
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::scene::{Light, MeshSource, Object, Refinement, Sampling};
use raycast::{Camera, Frame, Scene, SceneFile, NO_OBJECT};

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
    assert_eq!((a.width_px, a.height_px), (b.width_px, b.height_px));
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

/// Largest relative difference of the eye distance (depth) between the CPU
/// and the GPU where both hit. Both compute the same f32 formulas, but the
/// GPU may fuse multiply-adds and its division and square root may differ by
/// an ulp or two; over a ray/triangle test, an interpolation and a length
/// that is a few 1e-6 relative, so 1e-4 leaves two orders of magnitude
/// while still catching any wrong formula (a wrong `t` scale, a missing
/// length, the wrong corner's distance are all > 1e-3).
const DEPTH_REL_TOL: f32 = 1e-4;
/// Largest difference of any normal component (unit vectors) where both
/// hit; the same reasoning as [`DEPTH_REL_TOL`].
const NORMAL_TOL: f32 = 1e-4;

/// G-buffer differences between a CPU and a GPU frame of the same view.
#[derive(Debug, Default)]
struct GbufferDiff {
    /// Pixels where both hit but the object ids differ.
    object: usize,
    /// Pixels where both hit, with the same object, but depth or normal are
    /// beyond the tolerances (ties at an edge shared by two triangles with
    /// other vertex normals: as rare as the colour differences).
    surface: usize,
    worst_depth_rel: f32,
    worst_normal: f32,
}

fn compare_gbuffer(cpu: &Frame, gpu: &Frame) -> GbufferDiff {
    assert_eq!(gpu.depth_mm.len(), gpu.len());
    assert_eq!(gpu.object.len(), gpu.len());
    assert_eq!(gpu.normal.len(), gpu.len());
    let mut d = GbufferDiff::default();
    for i in 0..cpu.len() {
        // Background pixels carry the background values, hits real ones.
        if gpu.hit[i] {
            assert_ne!(gpu.object[i], NO_OBJECT, "pixel {i}");
            assert!(
                gpu.depth_mm[i].is_finite() && gpu.depth_mm[i] > 0.0,
                "pixel {i}: depth {}",
                gpu.depth_mm[i]
            );
            let len = gpu.normal[i].iter().map(|c| c * c).sum::<f32>().sqrt();
            assert!((len - 1.0).abs() < 1e-5, "pixel {i}: |normal| = {len}");
        } else {
            assert_eq!(gpu.depth_mm[i], f32::INFINITY, "pixel {i}");
            assert_eq!(gpu.object[i], NO_OBJECT, "pixel {i}");
            assert_eq!(gpu.normal[i], [0.0; 3], "pixel {i}");
        }
        if !(cpu.hit[i] && gpu.hit[i]) {
            continue;
        }
        if cpu.object[i] != gpu.object[i] {
            d.object += 1;
            continue;
        }
        let depth = (cpu.depth_mm[i] - gpu.depth_mm[i]).abs() / cpu.depth_mm[i];
        let normal = (0..3)
            .map(|k| (cpu.normal[i][k] - gpu.normal[i][k]).abs())
            .fold(0.0f32, f32::max);
        if depth > DEPTH_REL_TOL || normal > NORMAL_TOL {
            d.surface += 1;
        } else {
            d.worst_depth_rel = d.worst_depth_rel.max(depth);
            d.worst_normal = d.worst_normal.max(normal);
        }
    }
    d
}

/// The GPU's G-buffer equals the CPU's: object ids exactly wherever both
/// hit, depth and normal within the tolerances except at as many tie pixels
/// as the colour comparison allows.
fn assert_gbuffer_matches(what: &str, cpu: &Frame, gpu: &Frame) {
    let d = compare_gbuffer(cpu, gpu);
    eprintln!("{what}: G-buffer {d:?}");
    assert_eq!(d.object, 0, "{what}: object ids differ");
    assert!(d.surface <= 4, "{what}: {d:?}");
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
            assert_gbuffer_matches(&format!("{name} {w}x{h}"), &cpu, &frame);
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
            importance: 1.0,
            motion: None,
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
        sampling: None,
        passes: None,
        effects: Some(vec![
            raycast::scene::Effect::FoveatedSampling,
            raycast::scene::Effect::SilhouetteRefinement,
            raycast::scene::Effect::CreaseRefinement,
        ]),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, Path::new(".")).expect("builds")
}

#[test]
#[ignore = "slow tier: lavapipe at 3840x2160"]
fn hard_cases_one_pixel_4k_and_an_empty_scene() {
    let scene = sphere_scene(120.0);
    let mut g = gpu(&scene);
    for (w, h) in [(1, 1), (3840, 2160), (7, 3)] {
        let d = display(w, h);
        let (frame, _) = g
            .render_full(&Camera::new(&d.geometry().expect("geometry")))
            .expect("renders");
        let cpu = cpu_full(&scene, &d);
        let (hit, colour, _) = compare(&cpu, &frame);
        assert!(hit <= 4 && colour <= 4, "{w}x{h}: {hit} / {colour}");
        assert_gbuffer_matches(&format!("sphere {w}x{h}"), &cpu, &frame);
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
    assert_gbuffer_matches("empty", &cpu_full(&empty, &d), &frame);
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
#[ignore = "slow tier: soak test (100 frames on lavapipe, memory watched)"]
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

fn cpu_foveated(scene: &Scene, d: &Display, gaze: [f64; 2]) -> (Frame, raycast::Stats) {
    let g = d.geometry().expect("geometry");
    let model = SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let s = Settings {
        mode: Mode::Hybrid,
        layout: Layout::Nyquist,
        triggers: Triggers::from_scene(scene),
        test: TriangleTest::Watertight,
        check_coverage: false,
    };
    render(scene, &Camera::new(&g), &model, &s, gaze).expect("renders")
}

fn gpu_foveated(
    g: &mut GpuRenderer,
    scene: &Scene,
    d: &Display,
    gaze: [f64; 2],
) -> (Frame, raycast::Stats) {
    let geo = d.geometry().expect("geometry");
    let model = SamplingModel::new(geo, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let mask = foveation::mask::build(&model, Layout::Nyquist, gaze).expect("mask");
    g.render_foveated(&Camera::new(&geo), &mask, &Triggers::from_scene(scene))
        .expect("gpu renders")
}

#[test]
fn gpu_foveated_frames_match_the_cpu_reference() {
    for name in ["search-task", "bunny", "stress"] {
        let scene = load(name);
        let mut g = gpu(&scene);
        let d = display(320, 256);
        // Centre, a corner, partly off the screen.
        for gaze in [[160.0, 128.0], [2.0, 3.0], [-40.0, 200.0]] {
            let (cpu, cs) = cpu_foveated(&scene, &d, gaze);
            let (frame, gs) = gpu_foveated(&mut g, &scene, &d, gaze);
            let (hit, colour, worst) = compare(&cpu, &frame);
            eprintln!(
                "{name} gaze {gaze:?}: {hit} hit/miss, {colour} colour > 1, worst {worst}; rays cpu {} gpu {}, refined cells cpu {} gpu {}",
                cs.rays_total, gs.rays_total, cs.cells_refined, gs.cells_refined
            );
            assert!(hit <= 4, "{name} {gaze:?}: {hit} hit/miss differences");
            assert!(colour <= 4, "{name} {gaze:?}: {colour} colour differences");
            assert_eq!(
                (
                    gs.rays_fovea,
                    gs.rays_mask,
                    gs.rays_refine,
                    gs.cells_refined
                ),
                (
                    cs.rays_fovea,
                    cs.rays_mask,
                    cs.rays_refine,
                    cs.cells_refined
                ),
                "{name} {gaze:?}: ray counts"
            );
            assert_eq!(frame.layer, cpu.layer, "{name} {gaze:?}: layers");
            assert_gbuffer_matches(&format!("{name} gaze {gaze:?}"), &cpu, &frame);
            // Per-stage GPU times, where the adapter has timestamp queries.
            let stages = g.stage_ms();
            let want = raycast::gpu::foveated_stages(&Triggers::from_scene(&scene));
            if g.has_timestamps() {
                // A new mask: its ownership is built first, on the GPU.
                let ran: Vec<&str> = stages.iter().map(|(s, _)| *s).collect();
                let want: Vec<&str> = std::iter::once("build pixel ownership")
                    .chain(want.iter().map(|s| s.name()))
                    .collect();
                assert_eq!(ran, want, "{name}: timed stages");
            } else {
                assert!(stages.is_empty(), "{name}: times without timestamps");
            }
            assert!(stages.iter().all(|(_, ms)| ms.is_finite() && *ms >= 0.0));
        }
    }
}

#[test]
fn gpu_foveated_hard_cases() {
    // A POR that moves every frame (buffers reused), 1×1, and a scene where
    // no cell is refined (nothing hits) or every object cell is (noise).
    let scene = load("stress");
    let mut g = gpu(&scene);
    let d = display(96, 72);
    for k in 0..12 {
        let gaze = [8.0 * f64::from(k), 6.0 * f64::from(k)];
        let (cpu, cs) = cpu_foveated(&scene, &d, gaze);
        let (frame, gs) = gpu_foveated(&mut g, &scene, &d, gaze);
        let (hit, colour, _) = compare(&cpu, &frame);
        assert!(hit <= 4 && colour <= 4, "gaze {gaze:?}");
        assert_eq!(gs.rays_total, cs.rays_total, "gaze {gaze:?}");
    }
    // 3840×2160, the sphere scene (cheap rays, many pixels).
    let sphere = sphere_scene(120.0);
    let mut gs4k = gpu(&sphere);
    let big = display(3840, 2160);
    let (cpu, cs) = cpu_foveated(&sphere, &big, [1000.0, 700.0]);
    let (frame, gs) = gpu_foveated(&mut gs4k, &sphere, &big, [1000.0, 700.0]);
    let (hit, colour, _) = compare(&cpu, &frame);
    assert!(hit <= 4 && colour <= 4, "4K: {hit} / {colour}");
    assert_gbuffer_matches("foveated 4K", &cpu, &frame);
    assert_eq!(gs.rays_total, cs.rays_total, "4K ray counts");
    assert!(cs.rays_mask > 0 && cs.rays_total < 8_294_400 / 4, "{cs:?}");
    let one = display(1, 1);
    let (cpu, _) = cpu_foveated(&scene, &one, [0.5, 0.5]);
    let (frame, _) = gpu_foveated(&mut g, &scene, &one, [0.5, 0.5]);
    assert_eq!(compare(&cpu, &frame).0, 0);
    let mut empty = sphere_scene(1.0);
    empty.triangles.clear();
    empty.bvh = raycast::bvh::Bvh::build(&[]);
    let mut ge = gpu(&empty);
    let (frame, stats) = gpu_foveated(&mut ge, &empty, &d, [48.0, 36.0]);
    assert_eq!(stats.cells_refined, 0);
    assert!(frame.hit.iter().all(|h| !h));
    assert_gbuffer_matches("empty foveated", &frame.clone(), &frame);
    // Noise: a rough sphere filling the screen with a 0.5° crease angle,
    // so (nearly) every cell is refined.
    let noise = noise_scene();
    let mut gn = gpu(&noise);
    let (cpu, cs) = cpu_foveated(&noise, &d, [48.0, 36.0]);
    let (frame, gs) = gpu_foveated(&mut gn, &noise, &d, [48.0, 36.0]);
    assert!(
        cs.cells_refined * 10 >= cs.cells_total * 9,
        "{} of {} cells refined",
        cs.cells_refined,
        cs.cells_total
    );
    assert_eq!(
        (gs.cells_refined, gs.rays_total),
        (cs.cells_refined, cs.rays_total)
    );
    let (hit, colour, _) = compare(&cpu, &frame);
    assert!(hit <= 4 && colour <= 4, "noise: {hit} / {colour}");
    assert_gbuffer_matches("noise", &cpu, &frame);
}

fn noise_scene() -> Scene {
    let file = SceneFile {
        name: "noise".into(),
        background: (0.1, 0.1, 0.12),
        meshes: [(
            "n".to_string(),
            MeshSource::Bumpy {
                triangles: 20_000,
                amplitude: 0.3,
                seed: 3,
            },
        )]
        .into(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "n".into(),
            material: None,
            translate_mm: (0.0, 0.0, -200.0),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: 400.0,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(vec![
            raycast::scene::Effect::FoveatedSampling,
            raycast::scene::Effect::SilhouetteRefinement,
            raycast::scene::Effect::CreaseRefinement,
        ]),
        crease_deg: Some(0.5),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, Path::new(".")).expect("builds")
}

#[test]
fn a_frame_beyond_the_storage_binding_limit_is_a_clear_error() {
    let scene = sphere_scene(10.0);
    let mut g = gpu(&scene);
    let limit = g.max_binding_bytes();
    let w = 4096u32;
    let Ok(h) = u32::try_from(limit / (4 * u64::from(w)) + 1) else {
        eprintln!("this adapter's limit ({limit} bytes) allows any frame");
        return;
    };
    let e = g
        .render_full(&Camera::new(&display(w, h).geometry().expect("geometry")))
        .expect_err("too large");
    let msg = e.to_string();
    assert!(
        msg.contains("max_storage_buffer_binding_size") && msg.contains(&limit.to_string()),
        "{msg}"
    );
    // The renderer is still usable afterwards.
    let d = display(16, 12);
    assert!(g
        .render_full(&Camera::new(&d.geometry().expect("geometry")))
        .is_ok());
}

#[test]
fn passes_follow_the_scene_effects() {
    use raycast::gpu::{foveated_stages, Stage};
    let names = |scene: &Scene| -> Vec<&str> {
        foveated_stages(&Triggers::from_scene(scene))
            .iter()
            .map(|s| s.name())
            .collect()
    };
    // Every stage, in pass order, with distinct names.
    let all: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
    assert_eq!(
        all,
        [
            "build pixel ownership",
            "cast vertices",
            "classify cells",
            "silhouette margin",
            "count refined cells",
            "interpolate or list pixels",
            "prepare dispatch",
            "cast listed pixels"
        ]
    );
    // Every refinement effect: every stage.
    let mut every = sphere_scene(120.0);
    every.sampling = Sampling::default();
    // (The ownership pass runs only in a frame whose mask is new.)
    assert_eq!(names(&every), all[1..]);
    // No refinement effects: no classification, no margin.
    let mut plain = sphere_scene(120.0);
    plain.sampling = Sampling::Foveated { refine: vec![] };
    assert_eq!(
        names(&plain),
        [
            "cast vertices",
            "interpolate or list pixels",
            "prepare dispatch",
            "cast listed pixels"
        ]
    );
    let mut crease_only = sphere_scene(120.0);
    crease_only.sampling = Sampling::Foveated {
        refine: vec![Refinement::Crease { angle_deg: 30.0 }],
    };
    assert!(!names(&crease_only).contains(&"silhouette margin"));
    assert!(names(&crease_only).contains(&"classify cells"));
    // Rendering without refinement matches the CPU, and the GPU ran exactly
    // the listed passes: where the adapter reports timestamp queries the
    // timed passes are exactly those (the list is checked above through
    // `foveated_stages` either way); without them no times may appear.
    let d = display(160, 128);
    let mut g = gpu(&plain);
    let (cpu, cs) = cpu_foveated(&plain, &d, [80.0, 64.0]);
    let (frame, gs) = gpu_foveated(&mut g, &plain, &d, [80.0, 64.0]);
    assert_eq!(compare(&cpu, &frame).0, 0);
    assert_eq!(
        (gs.cells_refined, gs.rays_total),
        (cs.cells_refined, cs.rays_total)
    );
    let ran: Vec<&str> = g.stage_ms().iter().map(|(s, _)| *s).collect();
    eprintln!("{}: timestamps {}", g.adapter(), g.has_timestamps());
    if g.has_timestamps() {
        let mut want = vec!["build pixel ownership"];
        want.extend(names(&plain));
        assert_eq!(ran, want);
    } else {
        assert!(ran.is_empty(), "{ran:?}");
    }
    // And a full-resolution frame times its one pass.
    g.render_full(&Camera::new(&d.geometry().expect("geometry")))
        .expect("renders");
    let ran: Vec<&str> = g.stage_ms().iter().map(|(s, _)| *s).collect();
    if g.has_timestamps() {
        assert_eq!(ran, ["cast and shade"]);
    } else {
        assert!(ran.is_empty(), "{ran:?}");
    }
    // A foveated frame allocated the foveated stages' buffers. That a
    // full-resolution scene never does is checked through the one frame
    // entry, where the method is chosen (crates/pipeline/tests/pipeline.rs).
    assert!(g.has_foveated_buffers());
}

/// A mask the GPU already holds (the same generation, kept within the gaze
/// tolerance) is neither built into owners again nor uploaded, and
/// its frame is the one the upload gave; a new generation uploads again.
#[test]
fn a_kept_mask_is_not_uploaded_again_and_renders_the_same_frame() {
    let scene = load("search-task");
    let d = display(320, 256);
    let geo = d.geometry().expect("geometry");
    let model = SamplingModel::new(geo, GeislerPerry::default(), 1.0, 17.0)
        .expect("model")
        .with_gaze_tolerance_deg(1.0)
        .expect("tolerance");
    let cam = Camera::new(&geo);
    let triggers = Triggers::from_scene(&scene);
    let mut g = gpu(&scene);
    let mut scratch = raycast::render::Scratch::default();
    let mut frame_at = |g: &mut GpuRenderer, gaze: [f64; 2]| {
        let (kept, generation) = scratch
            .mask_for(&model, Layout::Nyquist, gaze)
            .expect("mask");
        let mask = scratch.mask().expect("a mask");
        let (frame, _) = g
            .render_foveated_kept(&cam, mask, Some(generation), &triggers, None)
            .expect("gpu renders");
        (frame, kept, g.mask_upload_bytes())
    };
    // A new mask uploads itself, not its pixel owners (built on the GPU).
    let (first, kept, bytes) = frame_at(&mut g, [150.0, 120.0]);
    assert!(!kept && bytes > 0 && bytes < 4 * 320 * 256, "{bytes} bytes");
    // Half a degree away: within the tolerance.
    let (second, kept, bytes) = frame_at(&mut g, [155.0, 122.0]);
    assert!(kept, "within 1°");
    assert_eq!(bytes, 0);
    assert!(first == second, "the kept mask's frame");
    // Far away: a new mask, uploaded.
    let (_, kept, bytes) = frame_at(&mut g, [20.0, 230.0]);
    assert!(!kept && bytes > 0);
    // Without a generation the upload always happens.
    let mask = foveation::mask::build(&model, Layout::Nyquist, [20.0, 230.0]).expect("mask");
    g.render_foveated(&cam, &mask, &triggers)
        .expect("gpu renders");
    assert!(g.mask_upload_bytes() > 0);
}

/// Bytes of uniforms a foveated frame writes: `Params` (80 B: four u32
/// and four vec4), `FovParams` (32 B) and the reset of its four atomic
/// counters (16 B). A full-resolution frame writes `Params` alone.
const FOVEATED_UNIFORM_BYTES: u64 = 80 + 32 + 16;
const FULL_UNIFORM_BYTES: u64 = 80;
/// Bytes per pixel the read-back maps: the packed colour word, and with
/// the surface buffers the eye distance, object id and normal (4 + 4 + 4 + 12).
const READ_BACK_PER_PIXEL: u64 = 24;
const READ_BACK_PER_PIXEL_COLOUR_ONLY: u64 = 4;

/// The bytes a timed frame of `passes` passes reads back for its
/// timestamps (two u64 per pass), where the adapter has them.
fn timestamp_bytes(g: &GpuRenderer, passes: u64) -> u64 {
    if g.has_timestamps() {
        16 * passes
    } else {
        0
    }
}

/// Issue 35's traffic, counted at the `wgpu` calls: what a fresh foveated
/// frame, a frame of a kept mask and a full frame upload, read back,
/// dispatch and submit, exactly. A new mask uploads itself (vertices,
/// cells, fovea spans) and the GPU builds its pixel owners (3 more
/// dispatches in one more pass), never 4 B a pixel; a kept mask uploads
/// only the uniforms; every frame reads the frame back (there is no frame
/// without a read-back yet).
#[test]
fn every_frame_counts_its_uploads_read_backs_dispatches_and_submits() {
    let scene = load("search-task");
    let (w, h) = (320u64, 256u64);
    let d = display(w as u32, h as u32);
    let geo = d.geometry().expect("geometry");
    let model = SamplingModel::new(geo, GeislerPerry::default(), 1.0, 17.0)
        .expect("model")
        .with_gaze_tolerance_deg(1.0)
        .expect("tolerance");
    let cam = Camera::new(&geo);
    let triggers = Triggers::from_scene(&scene);
    let stages = raycast::gpu::foveated_stages(&triggers).len() as u64;
    let mut g = gpu(&scene);
    assert_eq!(g.frame_traffic(), raycast::gpu::Traffic::default());
    // The scene's upload is counted too (once, when the renderer is made).
    let at_start = g.traffic_total();
    assert!(at_start.uploaded_bytes > 0 && at_start.submits == 0);

    let mut scratch = raycast::render::Scratch::default();
    let mut frame_at = |g: &mut GpuRenderer, gaze: [f64; 2]| {
        let (kept, generation) = scratch
            .mask_for(&model, Layout::Nyquist, gaze)
            .expect("mask");
        let mask = scratch.mask().expect("a mask");
        let mask_bytes = (std::mem::size_of_val(&mask.vertices[..])
            + std::mem::size_of_val(&mask.cells[..])) as u64
            + raycast::gpu::ownership::SPAN_BYTES * mask.fovea.len() as u64
            + raycast::gpu::ownership::UNIFORM_BYTES;
        g.render_foveated_kept(&cam, mask, Some(generation), &triggers, None)
            .expect("gpu renders");
        (kept, mask_bytes, g.frame_traffic())
    };
    // A new mask: the uniforms, the mask's vertices, cells and fovea
    // spans with the ownership pass's uniforms; no pixel owners.
    let (kept, mask_bytes, t) = frame_at(&mut g, [150.0, 120.0]);
    assert!(!kept);
    assert!(mask_bytes > 0 && mask_bytes < 4 * w * h);
    assert_eq!(
        t.uploaded_bytes,
        FOVEATED_UNIFORM_BYTES + mask_bytes,
        "{t:?}"
    );
    assert_eq!(g.mask_upload_bytes(), mask_bytes);
    // The whole G-buffer, the four counters, the timestamps (one more
    // pass: the ownership).
    assert_eq!(
        t.read_back_bytes,
        READ_BACK_PER_PIXEL * w * h + 16 + timestamp_bytes(&g, stages + 1),
        "{t:?}"
    );
    assert_eq!(
        (t.dispatches, t.draws, t.submits),
        (stages + raycast::gpu::ownership::DISPATCHES, 0, 1),
        "{t:?}"
    );
    // A kept mask (within the 1° tolerance): the uniforms alone, ≤ 1 KiB.
    let (kept, _, t) = frame_at(&mut g, [155.0, 122.0]);
    assert!(kept);
    assert_eq!(t.uploaded_bytes, FOVEATED_UNIFORM_BYTES, "{t:?}");
    assert!(t.uploaded_bytes <= 1024);
    assert_eq!((t.dispatches, t.submits), (stages, 1), "{t:?}");
    // Without the surface buffers the read-back is the colour words only;
    // it is never nothing: every frame comes back to the CPU today.
    g.set_surface(false);
    let (_, _, t) = frame_at(&mut g, [155.0, 122.0]);
    assert_eq!(
        t.read_back_bytes,
        READ_BACK_PER_PIXEL_COLOUR_ONLY * w * h + 16 + timestamp_bytes(&g, stages),
        "{t:?}"
    );
    // A full-resolution frame: its params, one dispatch, one submission.
    g.set_surface(true);
    g.render_full(&cam).expect("gpu renders");
    let t = g.frame_traffic();
    assert_eq!(t.uploaded_bytes, FULL_UNIFORM_BYTES, "{t:?}");
    assert_eq!(
        t.read_back_bytes,
        READ_BACK_PER_PIXEL * w * h + timestamp_bytes(&g, 1),
        "{t:?}"
    );
    assert_eq!((t.dispatches, t.draws, t.submits), (1, 0, 1), "{t:?}");
    // The totals are the sum of the frames and the scene's upload.
    let total = g.traffic_total().since(at_start);
    assert_eq!(total.submits, 4);
}

/// Issue 35: the pixel ownership a new mask's frame builds on the GPU
/// (`ownership.wgsl`, exact integer edge functions) equals the CPU's
/// `render::ownership` pixel for pixel: gazes at the centre, at corners,
/// on an edge, off the screen and far off it, at fractional positions, on
/// several frame sizes (1×1 and odd sizes included), at two contrasts.
#[test]
fn gpu_pixel_ownership_equals_the_cpu_bit_for_bit() {
    let scene = load("search-task");
    let mut g = gpu(&scene);
    let triggers = Triggers::from_scene(&scene);
    let mut compared = 0usize;
    for (w, h) in [(1, 1), (7, 5), (97, 61), (320, 256), (640, 480)] {
        let d = display(w, h);
        let geo = d.geometry().expect("geometry");
        let (wf, hf) = (f64::from(w), f64::from(h));
        for contrast in [1.0, 0.25] {
            let model =
                SamplingModel::new(geo, GeislerPerry::default(), contrast, 17.0).expect("model");
            for gaze in [
                [wf / 2.0, hf / 2.0],
                [0.0, 0.0],
                [wf - 0.5, hf - 0.5],
                [wf / 3.0 + 0.371, 0.0],
                [-25.25, hf / 2.0],
                [wf + 4000.0, -3000.0],
                [wf * 0.77 + 0.123_456, hf * 0.31 + 0.987],
            ] {
                let mask = foveation::mask::build(&model, Layout::Nyquist, gaze).expect("mask");
                assert!(raycast::gpu::ownership::fits(&mask, w, h));
                g.render_foveated(&Camera::new(&geo), &mask, &triggers)
                    .expect("gpu renders");
                let gpu_owners = g.pixel_owners(w, h).expect("owners read back");
                let cpu_owners = raycast::render::ownership(&mask, w as usize, h as usize);
                let differ = gpu_owners
                    .iter()
                    .zip(&cpu_owners)
                    .filter(|(a, b)| a != b)
                    .count();
                assert_eq!(
                    (gpu_owners.len(), differ),
                    (cpu_owners.len(), 0),
                    "{w}x{h} C {contrast} gaze {gaze:?}: {} cells",
                    mask.cells.len()
                );
                compared += cpu_owners.len();
            }
        }
    }
    eprintln!("{compared} pixel owners compared");
    // A frame 8192 px or more wide is beyond the shader's exact range: the
    // CPU builds the owners and uploads them (4 B a pixel), and the frame
    // is the CPU's still.
    let d = display(8200, 6);
    let geo = d.geometry().expect("geometry");
    let model = SamplingModel::new(geo, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let mask = foveation::mask::build(&model, Layout::Nyquist, [4100.0, 3.0]).expect("mask");
    assert!(!raycast::gpu::ownership::fits(&mask, 8200, 6));
    let (frame, _) = g
        .render_foveated(&Camera::new(&geo), &mask, &triggers)
        .expect("gpu renders");
    assert!(g.mask_upload_bytes() >= 4 * 8200 * 6);
    assert_eq!(
        g.pixel_owners(8200, 6).expect("owners"),
        raycast::render::ownership(&mask, 8200, 6)
    );
    let (cpu, _) = cpu_foveated(&scene, &d, [4100.0, 3.0]);
    assert!(compare(&cpu, &frame).0 <= 4);
}
