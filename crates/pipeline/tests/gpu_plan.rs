//! The frame plan on both backends: passes with a GPU implementation chain
//! on the GPU in the scene's order (a second GPU effect after the first —
//! depth of field, then the POR box — runs there too), and every pass a
//! scene can ask for has one; the raster path reads back before its passes,
//! and the plan says so; the GPU POR box equals the CPU's pixel for pixel;
//! a frame kept on the GPU reads nothing back. Runs on whatever
//! adapter the machine has (Mesa's lavapipe without a GPU); small frames.

use std::path::Path;

use foveation::{Display, SamplingModel};
use pipeline::effects::por_overlay::draw_box;
use pipeline::plan::{Channels, Role, Side};
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::{Camera, Scene, SceneFile};

const W: u32 = 160;
const H: u32 = 128;
const GAZE: [f64; 2] = [60.0, 70.0];
const DOF: &str = "depth of field (Lee ch. 4, focus at the gaze's depth)";

fn display() -> Display {
    fixtures::display_17in(W, H)
}

fn model() -> SamplingModel {
    pipeline::sampling_model(display().geometry().expect("geometry"), 1.0).expect("model")
}

fn camera() -> Camera {
    Camera::new(&display().geometry().expect("geometry"))
}

/// Three balls at different depths (the depth-of-field tests' scene).
fn scene(effects: &str) -> Scene {
    let text = format!(
        r#"Scene(
    name: "plan",
    meshes: {{ "ball": Bumpy(triangles: 800, amplitude: 0.12, seed: 3) }},
    objects: [
        (mesh: "ball", translate_mm: (-80.0, 0.0, 0.0), scale_mm: 35.0),
        (mesh: "ball", translate_mm: (30.0, 40.0, 270.0), scale_mm: 12.0),
        (mesh: "ball", translate_mm: (150.0, -100.0, -1500.0), scale_mm: 100.0),
    ],
    effects: [{effects}],
)"#
    );
    let file: SceneFile = ron::from_str(&text).expect("parses");
    Scene::build(&file, Path::new(".")).expect("builds")
}

fn renderer(scene: &Scene, method: Method, backend: BackendChoice) -> Renderer<'_> {
    Renderer::new(
        scene,
        camera(),
        model(),
        &Options {
            method,
            backend,
            ..Options::default()
        },
    )
    .unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

#[test]
fn a_second_gpu_effect_after_the_first_runs_on_the_gpu() {
    let s = scene("DepthOfField(pupil_mm: 8.0), PorOverlay(half_px: 20)");
    let mut gpu = renderer(&s, Method::Full, BackendChoice::Gpu);
    let mut cpu = renderer(&s, Method::Full, BackendChoice::Cpu);
    assert_eq!(gpu.gpu_pass_names(), [DOF, "POR box"]);
    assert_eq!(gpu.pass_names(), [DOF, "POR box"]);
    assert!(cpu.gpu_pass_names().is_empty());
    let plan = gpu.plan();
    let (at, carries) = plan.readback().expect("the GPU backend reads back");
    assert_eq!(at, plan.stages.len(), "every stage runs on the GPU");
    assert_eq!(carries, Channels::COLOUR | Channels::HIT, "{plan:?}");
    assert!(plan.stages.iter().all(|s| s.side == Side::Gpu));
    assert_eq!(
        gpu.provenance(),
        format!("full on gpu; passes: {DOF} (gpu) → POR box (gpu)")
    );
    let text = gpu.explain().join("\n");
    assert!(
        text.contains("GPU pass before the read-back: POR box"),
        "{text}"
    );
    assert!(
        text.contains("read-back of the finished frame (colour, hit)"),
        "{text}"
    );
    let (g, _) = gpu.render_at(GAZE, 0.0).expect("GPU frame");
    let (c, _) = cpu.render_at(GAZE, 0.0).expect("CPU frame");
    // Depth of field's GPU tolerance (tests/gpu_effects.rs): 1/255.
    assert!(
        fixtures::max_channel_diff(&g, &c) <= 1,
        "{}",
        fixtures::max_channel_diff(&g, &c)
    );
    // The box, drawn last, is exact on both.
    for (x, y) in [(40, 50), (80, 70), (60, 90), (41, 70)] {
        let i = 3 * (y * W as usize + x);
        assert_eq!(g.rgb[i..i + 3], [255, 220, 0], "({x}, {y})");
        assert_eq!(c.rgb[i..i + 3], [255, 220, 0], "({x}, {y})");
    }
    assert!(gpu.has_dof_buffers());
}

#[test]
fn the_gpu_box_is_the_cpu_box_pixel_for_pixel() {
    let plain = scene("");
    let mut bare = renderer(&plain, Method::Full, BackendChoice::Gpu);
    let cases = [
        (1i64, [80.4, 63.6]),
        (2, [0.0, 0.0]),
        (32, [10.0, 10.0]),
        (32, [-33.0, 40.0]),
        (32, [159.5, 127.5]),
        (32, [-35.0, 40.0]),
        (32, [f64::NAN, 40.0]),
        (500, [80.0, 64.0]),
        (4096, [80.0, 64.0]),
        (4096, [-4000.0, 64.0]),
    ];
    for (half, gaze) in cases {
        let s = scene(&format!("PorOverlay(half_px: {half})"));
        let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
        assert_eq!(r.gpu_pass_names(), ["POR box"], "{half}");
        let (got, _) = r.render_at(gaze, 0.0).expect("boxed");
        let (mut expected, _) = bare.render_at(gaze, 0.0).expect("bare");
        draw_box(&mut expected.rgb, W, H, gaze, half);
        assert_eq!(got.rgb, expected.rgb, "half {half}, gaze {gaze:?}");
        assert_eq!(got.hit, expected.hit, "the hit flags are kept");
    }
}

/// Every pass a scene can ask for has a GPU implementation (foreground
/// smoothing was the last without one): with depth of field smoothing its
/// foreground and the POR box, the whole plan runs on the GPU and the
/// read-back carries colour and hit only. The P key turns the box off and
/// on again: it comes back last, on the GPU. (The rule that the first pass
/// without a GPU implementation forces the read-back is tested on the
/// split itself, `renderer::tests`.) The raster path has no pass hook: it
/// reads back before every pass.
#[test]
fn every_scene_pass_runs_on_the_gpu_and_the_raster_path_reads_back_first() {
    let s = scene("PorOverlay(half_px: 8), DepthOfField(pupil_mm: 8.0, smooth_foreground: true)");
    let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
    assert_eq!(r.gpu_pass_names(), ["POR box", DOF]);
    let plan = r.plan();
    let sides: Vec<Side> = plan.stages.iter().map(|s| s.side).collect();
    assert_eq!(sides, [Side::Gpu, Side::Gpu, Side::Gpu]);
    let (at, carries) = plan.readback().expect("GPU");
    assert_eq!(at, 3);
    assert_eq!(carries, Channels::COLOUR | Channels::HIT, "{plan:?}");
    let text = r.explain().join("\n");
    assert!(
        text.contains("foreground smoothing (eqs. 4.10–4.11"),
        "{text}"
    );
    let (frame, _) = r.render_at(GAZE, 0.0).expect("frame");
    assert!(!frame.has_surface(), "no CPU pass reads the surface");
    r.set_por_overlay(false);
    assert_eq!(r.gpu_pass_names(), [DOF]);
    r.set_por_overlay(true);
    assert_eq!(r.gpu_pass_names(), [DOF, "POR box"]);
    // The model-based raster has no GPU pass hook: everything on the CPU.
    let s = scene("FoveatedSampling, PorOverlay(half_px: 8)");
    let r = renderer(&s, Method::Lod, BackendChoice::Gpu);
    assert!(r.gpu_pass_names().is_empty());
    assert_eq!(r.plan().readback().map(|(at, _)| at), Some(1));
}

#[test]
fn the_plan_is_what_runs_and_pays_per_use() {
    // A plain scene: one stage, the method; nothing else is made.
    let plain = scene("");
    for backend in [BackendChoice::Cpu, BackendChoice::Gpu] {
        let r = renderer(&plain, Method::Full, backend);
        let plan = r.plan();
        assert_eq!(plan.stages.len(), 1, "{backend:?}");
        assert_eq!(plan.stages[0].role, Role::Method);
        assert!(!plan.stages[0].writes.intersects(Channels::SURFACE));
    }
    // The image method: its blur is a stage of the method, first.
    let s = scene("FoveatedSampling, PorOverlay(half_px: 8)");
    for (backend, side) in [
        (BackendChoice::Cpu, Side::Cpu),
        (BackendChoice::Gpu, Side::Gpu),
    ] {
        let mut r = renderer(&s, Method::Image, backend);
        let plan = r.plan();
        let names: Vec<&str> = plan.stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["image", "image-based foveation", "POR box"]);
        assert_eq!(plan.stages[1].role, Role::MethodPass);
        let text = r.explain().join("\n");
        assert!(
            !text.contains("NaN"),
            "the model is known before the first frame: {text}"
        );
        assert!(plan.stages.iter().all(|s| s.side == side), "{backend:?}");
        assert_eq!(
            r.provenance(),
            format!(
                "image on {}; passes: image-based foveation ({0}) → POR box ({0})",
                side.name()
            )
        );
        r.render_at(GAZE, 0.0).expect("frame");
        // The P key moves the box out and back without touching the rest.
        r.set_por_overlay(false);
        assert!(r.pass_names().is_empty() && !r.por_overlay());
        r.set_por_overlay(true);
        assert_eq!(r.plan().stages.len(), 3);
        assert!(r.plan().stages.iter().all(|s| s.side == side));
    }
}

/// A frame kept on the GPU for a window on the same device: nothing of it
/// is read back (a foveated frame reads its 16 B of ray counters), the
/// frame returned has its size and no pixels, the plan and its one-line
/// provenance say so, and the frame read back on demand (a screenshot) is
/// the frame an ordinary GPU frame returns, passes included. On the CPU
/// backend and the raster path it is refused with the reason.
#[test]
fn a_frame_kept_on_the_gpu_reads_nothing_back_and_is_the_same_frame() {
    for (method, effects) in [
        (Method::Full, ""),
        (Method::Hybrid, "FoveatedSampling"),
        (
            Method::Hybrid,
            "FoveatedSampling, DepthOfField(pupil_mm: 8.0), PorOverlay(half_px: 20)",
        ),
        (Method::Image, "FoveatedSampling, PorOverlay(half_px: 12)"),
    ] {
        let s = scene(effects);
        let mut kept = renderer(&s, method, BackendChoice::Gpu);
        let mut read = renderer(&s, method, BackendChoice::Gpu);
        assert_eq!(kept.method(), method, "{effects}");
        kept.can_stay_on_gpu().expect("every pass on the GPU");
        kept.set_stay_on_gpu(true).expect("stays");
        assert!(kept.stays_on_gpu());
        assert!(kept.plan().readback().is_none());
        assert!(
            kept.provenance()
                .ends_with("; no read-back (drawn into the window on the GPU)"),
            "{}",
            kept.provenance()
        );
        for (k, gaze) in [GAZE, [100.0, 40.0]].into_iter().enumerate() {
            let (on_device, ks) = kept.render_at(gaze, k as f64).expect("kept");
            let (expected, rs) = read.render_at(gaze, k as f64).expect("read back");
            let what = format!("{method:?} [{effects}] frame {k}");
            assert!(on_device.is_on_device() && on_device.is_empty(), "{what}");
            assert_eq!((on_device.width_px, on_device.height_px), (W, H));
            assert_eq!(ks.rays_total, rs.rays_total, "{what}");
            let moved = kept.gpu_traffic().expect("gpu");
            let ordinary = read.gpu_traffic().expect("gpu");
            assert!(
                ordinary.read_back_bytes >= u64::from(4 * W * H),
                "{what}: {ordinary:?}"
            );
            // A foveated frame reads its 16 B of ray counters; with
            // passes, depth of field reads its focus window (a few words)
            // wherever the frame goes; no pass timestamps are read.
            let counters = if kept.method() == Method::Hybrid {
                16
            } else {
                0
            };
            if !effects.contains("DepthOfField") {
                assert_eq!(moved.read_back_bytes, counters, "{what}: {moved:?}");
            } else {
                assert!(moved.read_back_bytes < 1024, "{what}: {moved:?}");
            }
            let shown = kept.read_last_gpu_frame().expect("reads");
            assert_eq!(shown.rgb, expected.rgb, "{what}");
            assert_eq!(shown.hit, expected.hit, "{what}");
            assert_eq!(shown.layer, expected.layer, "{what}");
        }
        kept.set_stay_on_gpu(false).expect("back");
        let (again, _) = kept.render_at(GAZE, 2.0).expect("read back again");
        assert!(!again.is_on_device() && again.len() == (W * H) as usize);
    }
    let plain = scene("");
    let mut cpu = renderer(&plain, Method::Full, BackendChoice::Cpu);
    let why = cpu.set_stay_on_gpu(true).expect_err("the CPU backend");
    assert!(why.contains("CPU backend"), "{why}");
    // The raster path reads back.
    let s = scene("FoveatedSampling");
    let mut lod = renderer(&s, Method::Lod, BackendChoice::Gpu);
    let why = lod.set_stay_on_gpu(true).expect_err("raster");
    assert!(why.contains("raster"), "{why}");
}

/// Lee's attention model as the gaze source is the plan's last pass: on
/// the GPU backend it runs on the GPU frame (the frame can then stay
/// there: it reads back the per-object statistics, not the frame), and
/// its point of regard is the CPU pass's on the same frames; on the CPU
/// backend it makes the method fill the depth and ids it reads. Stopped,
/// it is gone from the plan.
#[test]
fn the_attention_gaze_source_runs_on_the_gpu_frame_and_agrees_with_the_cpu() {
    use pipeline::frame_attention::FrameAttention;
    let s = scene("FoveatedSampling");
    let model = || FrameAttention::new(64).expect("model");
    let mut gpu = renderer(&s, Method::Hybrid, BackendChoice::Gpu);
    let mut cpu = renderer(&s, Method::Hybrid, BackendChoice::Cpu);
    assert_eq!(gpu.attention_gaze_px(), None);
    gpu.set_attention_gaze(Some(model()));
    cpu.set_attention_gaze(Some(model()));
    assert_eq!(gpu.gpu_pass_names(), ["attention gaze source (Lee ch. 3)"]);
    assert!(cpu.plan().stages[0]
        .writes
        .contains(Channels::DEPTH | Channels::ID));
    gpu.can_stay_on_gpu().expect("every pass on the GPU");
    gpu.set_stay_on_gpu(true).expect("stays");
    let mut attended = 0;
    for (k, gaze) in [GAZE, [100.0, 40.0], [20.0, 100.0]].into_iter().enumerate() {
        let t = 0.1 * k as f64;
        let (on_device, _) = gpu.render_at(gaze, t).expect("gpu");
        let (frame, _) = cpu.render_at(gaze, t).expect("cpu");
        assert!(on_device.is_on_device() && frame.has_surface());
        let moved = gpu.gpu_traffic().expect("gpu");
        assert!(moved.read_back_bytes < 64 * 1024, "{moved:?}");
        let (g, c) = (gpu.attention_gaze_px(), cpu.attention_gaze_px());
        eprintln!(
            "frame {k}: GPU {g:?}, CPU {c:?}, read back {} B",
            moved.read_back_bytes
        );
        assert_eq!(g.is_some(), c.is_some(), "frame {k}: {g:?} {c:?}");
        if let (Some(g), Some(c)) = (g, c) {
            attended += 1;
            assert!(
                (g[0] - c[0]).abs() < 1e-3 && (g[1] - c[1]).abs() < 1e-3,
                "frame {k}: {g:?} {c:?}"
            );
        }
    }
    assert!(attended >= 2, "the balls are attended");
    gpu.set_attention_gaze(None);
    assert!(gpu.gpu_pass_names().is_empty());
    assert_eq!(gpu.attention_gaze_px(), None);
}
