//! The one frame entry: the method a scene's effects allow runs on both
//! backends, the G-buffer is complete, and an effect the scene does not list
//! runs no pass. The GPU runs on whatever adapter the machine has (Mesa's
//! lavapipe where there is none; `scripts/system-deps.sh` installs it).

use std::path::Path;

use foveation::Display;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::scene::{Effect, PostPass};
use raycast::{Camera, Frame, Layer, Scene, SceneFile, NO_OBJECT};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// The seed's 17" display at a reduced pixel count (same size and distance).
fn display(w: u32, h: u32) -> Display {
    Display::seed_17in(w, h)
}

/// A shipped scene with its effect list replaced.
fn scene(name: &str, effects: &[Effect]) -> Scene {
    let path = repo().join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    file.set_effects(effects.to_vec());
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

const ALL_SAMPLING: [Effect; 4] = [
    Effect::FoveatedSampling,
    Effect::SilhouetteRefinement,
    Effect::CreaseRefinement,
    Effect::DepthRefinement,
];

fn renderer<'s>(scene: &'s Scene, backend: BackendChoice, options: Options) -> Renderer<'s> {
    let g = display(W, H).geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            backend,
            ..options
        },
    )
    .unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

/// Large enough that the hybrid method's fovea does not cover the screen.
const W: u32 = 640;
const H: u32 = 512;

const BACKENDS: [BackendChoice; 2] = [BackendChoice::Cpu, BackendChoice::Gpu];

/// `view --backend gpu` once rendered foveated frames for a scene without
/// `FoveatedSampling`: through the one entry, neither backend does, and the
/// GPU never allocates the hybrid method's buffers for it.
#[test]
fn a_scene_without_foveated_sampling_renders_full_on_every_backend() {
    let plain = scene("bunny", &[]);
    let gaze = [200.0, 150.0];
    let mut frames = Vec::new();
    for backend in BACKENDS {
        let mut r = renderer(&plain, backend, Options::default());
        assert_eq!(r.method(), Method::Full, "{backend:?}");
        let (frame, stats) = r.render(gaze).expect("renders");
        assert!(frame.layer.iter().all(|l| *l == Layer::Full), "{backend:?}");
        assert_eq!(stats.rays_total, u64::from(W * H), "{backend:?}");
        assert!(!r.has_foveated_buffers(), "{backend:?}");
        frames.push(frame);
    }
    assert_eq!(frames[0].hit, frames[1].hit);
    // With the effect listed, both backends run the hybrid method.
    let foveated = scene("bunny", &ALL_SAMPLING);
    for backend in BACKENDS {
        let mut r = renderer(&foveated, backend, Options::default());
        assert_eq!(r.method(), Method::Hybrid, "{backend:?}");
        let (frame, stats) = r.render(gaze).expect("renders");
        assert!(!frame.layer.contains(&Layer::Full), "{backend:?}");
        assert!(frame.layer.contains(&Layer::Interpolated), "{backend:?}");
        assert!(stats.rays_total < u64::from(W * H), "{backend:?}");
        assert_eq!(r.has_foveated_buffers(), backend == BackendChoice::Gpu);
    }
}

/// Every buffer of the G-buffer agrees with the hit buffer, on both backends
/// and for both methods.
fn check_gbuffer(frame: &Frame, what: &str) {
    let n = (frame.width_px * frame.height_px) as usize;
    assert_eq!(frame.rgb.len(), 3 * n, "{what}");
    for buf in [
        frame.hit.len(),
        frame.depth_mm.len(),
        frame.object.len(),
        frame.normal.len(),
        frame.layer.len(),
    ] {
        assert_eq!(buf, n, "{what}");
    }
    let mut hits = 0;
    for i in 0..n {
        if frame.hit[i] {
            hits += 1;
            assert_ne!(frame.object[i], NO_OBJECT, "{what} pixel {i}");
            let d = frame.depth_mm[i];
            // The eye is 540 mm from the screen; the bunny lies just behind it.
            assert!(
                d.is_finite() && d > 400.0 && d < 1000.0,
                "{what} pixel {i}: depth {d}"
            );
            let len = frame.normal[i].iter().map(|c| c * c).sum::<f32>().sqrt();
            assert!((len - 1.0).abs() < 1e-3, "{what} pixel {i}: |n| = {len}");
        } else {
            assert_eq!(frame.object[i], NO_OBJECT, "{what} pixel {i}");
            assert_eq!(frame.depth_mm[i], f32::INFINITY, "{what} pixel {i}");
            assert_eq!(frame.normal[i], [0.0; 3], "{what} pixel {i}");
        }
    }
    assert!(
        hits > n / 20,
        "{what}: the bunny covers part of the screen ({hits} of {n})"
    );
}

#[test]
fn the_g_buffer_is_complete_and_consistent() {
    let s = scene("bunny", &ALL_SAMPLING);
    for backend in BACKENDS {
        for method in [Method::Full, Method::Hybrid] {
            let mut r = renderer(
                &s,
                backend,
                Options {
                    method,
                    surface: true,
                    ..Options::default()
                },
            );
            let (frame, _) = r.render([90.0, 70.0]).expect("renders");
            check_gbuffer(&frame, &format!("{backend:?} {method:?}"));
        }
    }
}

/// A scene that does not list an effect runs no pass for it (and builds
/// none); listing it runs it after the method.
#[test]
fn effects_run_as_passes_only_when_the_scene_lists_them() {
    let gaze = [100.0, 80.0];
    let without = scene("bunny", &ALL_SAMPLING);
    let mut with_list = ALL_SAMPLING.to_vec();
    with_list.push(Effect::POR_OVERLAY);
    let with = scene("bunny", &with_list);
    for backend in BACKENDS {
        let mut plain = renderer(&without, backend, Options::default());
        assert!(plain.pass_names().is_empty(), "{backend:?}");
        let (a, _) = plain.render(gaze).expect("renders");
        let mut por = renderer(&with, backend, Options::default());
        assert_eq!(por.pass_names(), ["POR box"], "{backend:?}");
        let (b, _) = por.render(gaze).expect("renders");
        // The box is drawn, 32 px from the gaze, and nothing else changes.
        let yellow = |f: &Frame, x: usize, y: usize| {
            let i = 3 * (y * f.width_px as usize + x);
            f.rgb[i..i + 3] == [255, 220, 0]
        };
        assert!(!yellow(&a, 132, 80) && yellow(&b, 132, 80), "{backend:?}");
        assert_eq!(a.hit, b.hit, "{backend:?}");
        assert_eq!(a.depth_mm, b.depth_mm, "{backend:?}");
        // The command line's overlay adds the pass; the viewer's key removes it.
        let mut forced = renderer(
            &without,
            backend,
            Options {
                por_overlay: true,
                ..Options::default()
            },
        );
        assert_eq!(forced.pass_names(), ["POR box"]);
        forced.set_por_overlay(false);
        assert!(forced.pass_names().is_empty());
        let (c, _) = forced.render(gaze).expect("renders");
        assert_eq!(a.rgb, c.rgb, "{backend:?}");
    }
}

#[test]
fn explain_names_the_method_stages_and_passes() {
    let s = scene("search-task", &ALL_SAMPLING);
    let r = renderer(
        &s,
        BackendChoice::Cpu,
        Options {
            por_overlay: true,
            ..Options::default()
        },
    );
    let text = r.explain().join("\n");
    assert!(text.contains("method: hybrid on cpu"), "{text}");
    assert!(
        text.contains("cast vertices → classify cells → silhouette margin"),
        "{text}"
    );
    assert!(text.contains("effect passes: POR box"), "{text}");
    let plain = scene("search-task", &[]);
    let r = renderer(&plain, BackendChoice::Cpu, Options::default());
    let text = r.explain().join("\n");
    assert!(text.contains("method: full on cpu"), "{text}");
    assert!(text.contains("effect passes: none"), "{text}");
}

/// Effects carry parameters in the scene file; bad ones are refused with
/// the field named.
#[test]
fn an_effect_takes_its_parameters_from_the_scene_file() {
    let path = repo().join("config/scenes/bunny.ron");
    let text = std::fs::read_to_string(&path).expect("bunny");
    let with = |effects: &str| {
        let t = text.replace(
            "sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),\n    passes: [],",
            &format!("effects: [FoveatedSampling, {effects}],"),
        );
        assert_ne!(t, text, "the bunny's effect line changed");
        ron::from_str::<SceneFile>(&t)
            .map_err(|e| e.to_string())
            .and_then(|f| Scene::build(&f, path.parent().expect("dir")).map_err(|e| e.to_string()))
    };
    let small = with("PorOverlay(half_px: 12)").expect("builds");
    let mut r = renderer(&small, BackendChoice::Cpu, Options::default());
    let (f, _) = r.render([300.0, 200.0]).expect("renders");
    let yellow = |x: usize, y: usize| {
        let i = 3 * (y * f.width_px as usize + x);
        f.rgb[i..i + 3] == [255, 220, 0]
    };
    assert!(yellow(312, 200) && !yellow(332, 200));
    // The default size: `PorOverlay()`.
    let seed = with("PorOverlay()").expect("builds");
    assert_eq!(
        seed.pass(&PostPass::POR_OVERLAY),
        Some(&PostPass::POR_OVERLAY)
    );
    let e = with("PorOverlay(half_px: 0)").expect_err("refused");
    assert!(e.contains("effects[1].half_px"), "{e}");
    let e = with("PorOverlay(half_px: 4294967295)").expect_err("refused");
    assert!(e.contains("effects[1].half_px"), "{e}");
    let e = with("PorOverlay(size: 3)").expect_err("refused");
    assert!(e.contains("size"), "{e}");
    let e = with("Sparkles").expect_err("refused");
    assert!(e.contains("Sparkles"), "{e}");
}

/// Pay per use: no pass reads depth, object id or normal today, so without
/// `surface` a frame carries none of those buffers, on either backend; a
/// recycled frame's buffers are reused.
#[test]
fn the_surface_buffers_cost_nothing_unless_asked_for() {
    let s = scene("bunny", &ALL_SAMPLING);
    for backend in BACKENDS {
        let mut r = renderer(&s, backend, Options::default());
        let (frame, _) = r.render([90.0, 70.0]).expect("renders");
        assert!(!frame.has_surface(), "{backend:?}");
        assert!(frame.depth_mm.is_empty() && frame.object.is_empty() && frame.normal.is_empty());
        let rgb = frame.rgb.as_ptr();
        r.recycle(frame);
        let (again, _) = r.render([95.0, 70.0]).expect("renders");
        if backend == BackendChoice::Cpu {
            assert_eq!(again.rgb.as_ptr(), rgb, "the recycled buffer is reused");
        }
        let mut with = renderer(
            &s,
            backend,
            Options {
                surface: true,
                ..Options::default()
            },
        );
        let (full, _) = with.render([95.0, 70.0]).expect("renders");
        assert!(full.has_surface(), "{backend:?}");
        // The colour, hit and layer buffers do not depend on it.
        assert_eq!(again.rgb, full.rgb, "{backend:?}");
        assert_eq!(again.hit, full.hit, "{backend:?}");
        assert_eq!(again.layer, full.layer, "{backend:?}");
    }
}

mod any_gaze {
    use super::*;
    use proptest::prelude::*;

    fn coordinate() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(f64::MAX),
            Just(-f64::MAX),
            Just(0.0),
            Just(-0.0),
            Just(1e-300),
            -1e300..1e300f64,
            -1e4..1e4f64,
            -1e9..1e9f64,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(48), ..ProptestConfig::default() })]

        /// A gaze at any f64 — NaN, ±∞, 1e300 — renders a frame or is an
        /// error naming the gaze; never a panic, and the work is bounded by
        /// the screen (the mask builder's cost does not grow with the POR's
        /// distance), so every case finishes quickly.
        #[test]
        fn any_gaze_renders_or_is_an_error(x in coordinate(), y in coordinate()) {
            static SCENE: std::sync::OnceLock<Scene> = std::sync::OnceLock::new();
            let s = SCENE.get_or_init(|| scene("search-task", &ALL_SAMPLING));
            let g = display(160, 128).geometry().expect("geometry");
            let model = pipeline::sampling_model(g, 1.0).expect("model");
            let mut r = Renderer::new(s, Camera::new(&g), model, &Options::default())
                .expect("cpu");
            match r.render([x, y]) {
                Ok((frame, stats)) => {
                    prop_assert!(x.is_finite() && y.is_finite());
                    prop_assert_eq!(frame.len(), 160 * 128);
                    // Fovea and refined pixels are at most the screen; mask
                    // vertices at most a few per on-screen pixel.
                    prop_assert!(stats.rays_fovea + stats.rays_refine <= 160 * 128);
                    prop_assert!(stats.rays_mask <= 4 * 160 * 128, "{}", stats.rays_mask);
                }
                Err(e) => {
                    prop_assert!(!(x.is_finite() && y.is_finite()), "{e}");
                    prop_assert!(e.to_string().contains("gaze"), "{e}");
                }
            }
        }
    }
}

/// `Options::reuse` (what the live view, the demo and the experiment turn
/// on) renders the frames of a fresh renderer byte for byte along a gaze
/// that fixates, jumps and returns, and on a scene that moves; during a
/// fixation it re-casts fewer pixels than it shows. Off, it does nothing.
#[test]
fn temporal_reuse_keeps_the_frames_and_saves_casts_during_a_fixation() {
    let effects = [Effect::FoveatedSampling, Effect::SilhouetteRefinement];
    let still = scene("search-task", &effects);
    let moving = scene("moving", &effects);
    let gazes = [
        [300.0, 250.0],
        [300.4, 250.2],
        [300.4, 250.2],
        [120.0, 400.0],
        [300.0, 250.0],
    ];
    for (what, s) in [("still", &still), ("moving", &moving)] {
        let mut off = renderer(s, BackendChoice::Cpu, Options::default());
        let mut on = renderer(
            s,
            BackendChoice::Cpu,
            Options {
                reuse: true,
                ..Options::default()
            },
        );
        let mut reused = 0;
        for (k, &gaze) in gazes.iter().enumerate() {
            let t = 0.05 * k as f64;
            let (a, sa) = off.render_at(gaze, t).expect("renders");
            let (b, sb) = on.render_at(gaze, t).expect("renders");
            assert_eq!(off.reuse_stats(), Default::default(), "{what}: reuse off");
            assert!(a == b, "{what} frame {k}: reuse changed the frame");
            assert_eq!(sa.rays_total, sb.rays_total, "{what} frame {k}");
            let r = on.reuse_stats();
            if k == 2 && what == "still" {
                // The same gaze again: the mask and every pixel are kept.
                assert!(r.mask_reused && r.pixels_cast == 0, "{what}: {r:?}");
            }
            if what == "moving" {
                // Every pose is a new scene: nothing carries over.
                assert_eq!(r.pixels_reused, 0, "{what} frame {k}: {r:?}");
            }
            reused += r.pixels_reused;
        }
        assert_eq!(reused > 0, what == "still", "{what}");
    }
}

/// Issue 35's traffic through the one frame entry, counted at the `wgpu`
/// calls: the GPU backend reports each frame's bytes and calls, the CPU
/// backend none. A new mask uploads the uniforms (128 B: `Params`,
/// `FovParams`, the counters' reset) and the mask itself (vertices, cells,
/// fovea spans, the ownership pass's uniforms; the GPU builds the pixel
/// owners); a mask kept within the gaze tolerance only the uniforms. Every
/// frame reads its colour words back (4 B a pixel with no pass that needs
/// the surface buffers), the four counters (16 B) and the timestamps.
#[test]
fn the_gpu_backend_reports_each_frames_traffic() {
    let s = scene("search-task", &ALL_SAMPLING);
    let (w, h) = (320u32, 256u32);
    let g = display(w, h).geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0)
        .expect("model")
        .with_gaze_tolerance_deg(0.5)
        .expect("tolerance");
    let options = |backend| Options {
        method: Method::Hybrid,
        backend,
        ..Options::default()
    };
    let mut cpu =
        Renderer::new(&s, Camera::new(&g), model, &options(BackendChoice::Cpu)).expect("cpu");
    cpu.render_at([150.0, 120.0], 0.0).expect("renders");
    assert_eq!(cpu.gpu_traffic(), None);
    let mut gpu = Renderer::new(&s, Camera::new(&g), model, &options(BackendChoice::Gpu))
        .unwrap_or_else(|e| panic!("{e} — install Mesa's software Vulkan"));
    assert_eq!(gpu.gpu_traffic(), Some(raycast::gpu::Traffic::default()));
    let gaze = [150.0, 120.0];
    gpu.render_at(gaze, 0.0).expect("renders");
    let t = gpu.gpu_traffic().expect("the GPU backend counts");
    let mask = foveation::mask::build(&model, foveation::Layout::Nyquist, gaze).expect("mask");
    // The mask itself goes up (vertices, cells, fovea spans and the
    // ownership pass's uniforms); the GPU builds the pixel owners.
    let own = |n: usize| raycast::gpu::ownership::SPAN_BYTES * n as u64;
    let mask_bytes = (std::mem::size_of_val(&mask.vertices[..])
        + std::mem::size_of_val(&mask.cells[..])) as u64
        + own(mask.fovea.len())
        + raycast::gpu::ownership::UNIFORM_BYTES;
    let pixels = u64::from(w) * u64::from(h);
    assert_eq!(t.uploaded_bytes, 128 + mask_bytes, "{t:?}");
    assert!(mask_bytes < 4 * pixels);
    let stages = raycast::gpu::foveated_stages(&raycast::render::Triggers::from_scene(&s)).len();
    let timestamps = 16 * gpu.stage_ms().len() as u64;
    assert_eq!(t.read_back_bytes, 4 * pixels + 16 + timestamps, "{t:?}");
    assert_eq!(
        (t.dispatches, t.submits),
        (stages as u64 + raycast::gpu::ownership::DISPATCHES, 1),
        "{t:?}"
    );
    // Within the tolerance: the mask is kept, only the uniforms go up (and
    // the ownership pass does not run).
    gpu.render_at([152.0, 121.0], 0.1).expect("renders");
    let t = gpu.gpu_traffic().expect("the GPU backend counts");
    assert_eq!(t.uploaded_bytes, 128, "{t:?}");
    let timestamps = 16 * gpu.stage_ms().len() as u64;
    assert_eq!(t.read_back_bytes, 4 * pixels + 16 + timestamps, "{t:?}");
}

/// Issue 35: depth of field's uniforms (2,304 B a frame) go up only when
/// they change; a frame of a kept mask whose focus did not move uploads
/// only the frame's own uniforms (≤ 1 KiB), and a frame whose focus moved
/// uploads them again.
#[test]
fn depth_of_field_uploads_its_uniforms_only_when_they_change() {
    let path = repo().join("config/scenes/stress-dof.ron");
    let text = std::fs::read_to_string(&path).expect("stress-dof");
    let file: SceneFile = ron::from_str(&text).expect("parses");
    let s = Scene::build(&file, path.parent().expect("dir")).expect("builds");
    let g = display(W, H).geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0)
        .expect("model")
        .with_gaze_tolerance_deg(0.5)
        .expect("tolerance");
    let options = Options {
        method: Method::Hybrid,
        backend: BackendChoice::Gpu,
        ..Options::default()
    };
    let mut gpu = Renderer::new(&s, Camera::new(&g), model, &options)
        .unwrap_or_else(|e| panic!("{e} — install Mesa's software Vulkan"));
    let gaze = [f64::from(W) / 2.0, f64::from(H) / 2.0];
    let mut uploads = Vec::new();
    // Long after the first frame the refocusing has settled: the focus,
    // and so the uniforms, stay as they are for the same gaze.
    for t in [0.0, 30.0, 30.1, 30.2] {
        gpu.render_at(gaze, t).expect("renders");
        uploads.push(gpu.gpu_traffic().expect("counted").uploaded_bytes);
    }
    assert!(uploads[0] > 2304, "{uploads:?}");
    assert!(
        uploads[2] <= 1024 && uploads[3] <= 1024,
        "a settled focus and a kept mask: {uploads:?}"
    );
}

/// A scene that moves renders on the GPU backend too (issue 35): each
/// frame's pose (its BVH rebuilt on the CPU) is uploaded before the frame,
/// and the GPU frames are the CPU's at every time — the hit mask exactly,
/// colour within 1/255 — full and foveated. The frame of a new pose
/// uploads the posed scene (its traffic counts it); a frame at the same
/// time again uploads no scene.
#[test]
fn a_moving_scene_renders_on_the_gpu_with_each_pose_uploaded() {
    for effects in [&[][..], &ALL_SAMPLING[..]] {
        let s = scene("moving", effects);
        assert!(s.is_moving());
        let mut gpu = renderer(&s, BackendChoice::Gpu, Options::default());
        let mut cpu = renderer(&s, BackendChoice::Cpu, Options::default());
        let gaze = [200.0, 150.0];
        let mut uploaded = Vec::new();
        let mut first: Option<Frame> = None;
        for (k, t) in [0.0, 0.4, 0.8, 0.8].into_iter().enumerate() {
            let what = format!("{effects:?} frame {k} at {t} s");
            let (g, _) = gpu.render_at(gaze, t).expect("gpu");
            let (c, _) = cpu.render_at(gaze, t).expect("cpu");
            assert_eq!(g.hit, c.hit, "{what}");
            let d = fixtures::max_channel_diff(&g, &c);
            assert!(d <= 1, "{what}: {d}");
            uploaded.push(gpu.gpu_traffic().expect("gpu").uploaded_bytes);
            match &first {
                None => first = Some(c),
                Some(f) if k == 2 => assert!(f.rgb != c.rgb, "{what}: the scene did not move"),
                Some(_) => {}
            }
        }
        eprintln!("{effects:?}: uploaded per frame {uploaded:?} B");
        // A new pose uploads the scene (805,728 B of BVH, triangles,
        // materials and lights here); the same time again does not (a
        // foveated frame still uploads its new mask).
        assert!(uploaded[2] >= uploaded[3] + 500_000, "{uploaded:?}");
    }
}
