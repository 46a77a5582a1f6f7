//! The GPU paths of depth of field and image-based foveation against their
//! CPU reference, on the GPU's own cast: the same frame is read back without
//! post passes and filtered by the CPU pass, and must equal the GPU-filtered
//! frame within 1/255 on every channel. Plus pay per use on both backends
//! and `explain`. Runs on whatever adapter the machine has (Mesa's lavapipe
//! without a GPU, which `scripts/system-deps.sh` installs); small frames.

use std::path::Path;

use foveation::{Display, SamplingModel};
use pipeline::effects::depth_of_field::DepthOfField;
use pipeline::effects::{Pass, PassInput};
use pipeline::image_foveation::ImageFoveation;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::gpu::GpuRenderer;
use raycast::render::Triggers;
use raycast::scene::PostPass;
use raycast::{Camera, Frame, Scene, SceneFile};

const W: u32 = 160;
const H: u32 = 128;

/// The seed's 17" display at a reduced pixel count (depth of field).
fn display() -> Display {
    Display::seed_17in(W, H)
}

/// Image-based foveation: the 17" display's 640×512 pixel pitch (at 160×128
/// its pixels are coarser than any ray spacing), the middle 320×256 of it.
fn image_display() -> Display {
    Display {
        name: "17in, middle quarter".into(),
        resolution_px: (320, 256),
        size_mm: (337.9 / 2.0, 270.3 / 2.0),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    }
}

fn model_on(d: &Display) -> SamplingModel {
    pipeline::sampling_model(d.geometry().expect("geometry"), 1.0).expect("model")
}

fn model() -> SamplingModel {
    model_on(&display())
}

fn camera_on(d: &Display) -> Camera {
    Camera::new(&d.geometry().expect("geometry"))
}

fn camera() -> Camera {
    camera_on(&display())
}

/// The depth-of-field tests' three bumpy balls: at the screen (object 0),
/// halfway to the eye (1), 1.5 m behind the screen (2); fewer triangles.
fn scene(effects: &str) -> Scene {
    let text = format!(
        r#"Scene(
    name: "dof",
    meshes: {{ "ball": Bumpy(triangles: 1500, amplitude: 0.12, seed: 3) }},
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

fn gpu(scene: &Scene) -> GpuRenderer {
    GpuRenderer::new(scene).unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

fn renderer<'s>(scene: &'s Scene, method: Method, backend: BackendChoice) -> Renderer<'s> {
    renderer_on(&display(), scene, method, backend)
}

fn renderer_on<'s>(
    d: &Display,
    scene: &'s Scene,
    method: Method,
    backend: BackendChoice,
) -> Renderer<'s> {
    Renderer::new(
        scene,
        camera_on(d),
        model_on(d),
        &Options {
            method,
            backend,
            ..Options::default()
        },
    )
    .expect("renderer")
}

/// The in-focus ball's centre on the screen (px).
/// The ch. 4 pass's name with its default focus.
const GAZE_DOF: &str = "depth of field (Lee ch. 4, focus at the gaze's depth)";

const GAZE: [f64; 2] = [80.0 - 80.0 * 160.0 / 337.9, 64.0];

/// The largest difference of any channel, and how many channels differ.
fn max_diff(a: &Frame, b: &Frame) -> (u8, usize) {
    assert_eq!(a.hit, b.hit, "the hit mask is the cast's");
    fixtures::channel_diff(a, b)
}

/// Channels that differ between two frames (how much a pass changed).
fn changed(a: &Frame, b: &Frame) -> usize {
    a.rgb.iter().zip(&b.rgb).filter(|(x, y)| x != y).count()
}

#[test]
fn depth_of_field_on_the_gpu_is_the_cpu_pass() {
    let plain = scene("");
    let mut reference = gpu(&plain);
    reference.set_surface(true);
    let cam = camera();
    let (cast, _) = reference.render_full(&cam).expect("cast");
    // The far ball's centre on the screen, from the cast.
    let far: Vec<usize> = (0..cast.object.len())
        .filter(|&i| cast.object[i] == 2)
        .collect();
    assert!(!far.is_empty(), "the far ball is on the screen");
    let mean = |f: &dyn Fn(usize) -> usize| {
        far.iter().map(|&i| f(i) as f64 + 0.5).sum::<f64>() / far.len() as f64
    };
    let far_gaze = [mean(&|i| i % W as usize), mean(&|i| i / W as usize)];
    let cases = [
        // Focus on the ball at the screen: the far ball and the background blur.
        (
            "background blur, gaze focus",
            "DepthOfField(pupil_mm: 8.0)",
            GAZE,
        ),
        (
            "background blur, fixed focus",
            "DepthOfField(pupil_mm: 6.0, focus: Fixed(depth_mm: 560.0))",
            GAZE,
        ),
        // Focus far: the near balls blur over what is behind them.
        (
            "foreground blur, fixed focus",
            "DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0))",
            GAZE,
        ),
        (
            "foreground blur, gaze focus on the far ball",
            "DepthOfField(pupil_mm: 8.0)",
            far_gaze,
        ),
        // Lee §4.3's foreground smoothing (eqs. 4.10–4.11) on the GPU.
        (
            "foreground blur smoothed, fixed focus",
            "DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0), smooth_foreground: true)",
            GAZE,
        ),
        (
            "foreground blur smoothed, gaze focus on the far ball",
            "DepthOfField(pupil_mm: 8.0, smooth_foreground: true)",
            far_gaze,
        ),
        (
            "background blur smoothed (nothing in front of the focus)",
            "DepthOfField(pupil_mm: 8.0, smooth_foreground: true)",
            GAZE,
        ),
    ];
    // The smoothed frames, to show below that smoothing changed them.
    let mut smoothed = Vec::new();
    for (what, effect, gaze) in cases {
        let s = scene(effect);
        let e = s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed");
        let mut cpu = DepthOfField::from_effect(e).expect("dof");
        let mut expected = cast.clone();
        cpu.run(
            &mut expected,
            &PassInput {
                scene: &s,
                camera: &cam,
                gaze_px: gaze,
                time_s: Some(0.0),
                vergence_mm: None,
            },
        );
        let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
        let names = r.gpu_pass_names();
        assert!(
            names.len() == 1 && names[0].starts_with("depth of field (Lee ch. 4"),
            "{names:?}"
        );
        let (got, _) = r.render_at(gaze, 0.0).expect("renders");
        assert!(r.has_dof_buffers());
        assert_eq!(r.gpu_focal_depth_mm(), cpu.focal_depth_mm(), "{what}");
        let (worst, n) = max_diff(&got, &expected);
        let blurred = changed(&cast, &expected);
        eprintln!(
            "{what}: max channel difference GPU vs CPU {worst} ({n} channels differ); \
             the pass changed {blurred} channels, focus {:?} mm",
            cpu.focal_depth_mm()
        );
        assert!(blurred > 1000, "{what}: the set-up must blur ({blurred})");
        assert!(worst <= 1, "{what}: {worst}");
        if effect.contains("smooth_foreground: true") {
            smoothed.push((
                what,
                effect.replace(", smooth_foreground: true", ""),
                gaze,
                got,
            ));
        }
    }
    // Smoothing changed the frames it was on for where something blurred
    // lies in front of the focus (the CPU's reference agrees, above).
    for (what, plain_effect, gaze, got) in smoothed {
        let s = scene(&plain_effect);
        let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
        let (unsmoothed, _) = r.render_at(gaze, 0.0).expect("renders");
        let n = changed(&unsmoothed, &got);
        eprintln!("{what}: smoothing changed {n} channels");
        if what.starts_with("foreground") {
            assert!(n > 100, "{what}: smoothing changed only {n} channels");
        }
    }
}

#[test]
fn depth_of_field_after_the_foveated_gpu_frame_is_the_cpu_pass() {
    let s = scene("FoveatedSampling, SilhouetteRefinement, DepthOfField(pupil_mm: 8.0)");
    let cam = camera();
    let m = model();
    let gaze = [100.0, 70.0];
    let mut reference = gpu(&s);
    reference.set_surface(true);
    let mask = foveation::mask::build(&m, foveation::Layout::Nyquist, gaze).expect("mask");
    let (cast, _) = reference
        .render_foveated(&cam, &mask, &Triggers::from_scene(&s))
        .expect("cast");
    let mut cpu =
        DepthOfField::from_effect(s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed")).expect("dof");
    let mut expected = cast.clone();
    cpu.run(
        &mut expected,
        &PassInput {
            scene: &s,
            camera: &cam,
            gaze_px: gaze,
            time_s: Some(0.0),
            vergence_mm: None,
        },
    );
    let mut r = renderer(&s, Method::Hybrid, BackendChoice::Gpu);
    let (got, _) = r.render_at(gaze, 0.0).expect("renders");
    let (worst, n) = max_diff(&got, &expected);
    eprintln!(
        "hybrid + depth of field, gaze focus: max channel difference {worst} ({n} differ); \
         the pass changed {}",
        changed(&cast, &expected)
    );
    assert!(changed(&cast, &expected) > 1000);
    assert!(worst <= 1, "{worst}");
}

#[test]
fn image_foveation_on_the_gpu_is_the_cpu_filter() {
    let s = scene("FoveatedSampling");
    let d = image_display();
    let cam = camera_on(&d);
    let m = model_on(&d);
    let mut reference = gpu(&s);
    let (cast, _) = reference.render_full(&cam).expect("cast");
    let mut r = renderer_on(&d, &s, Method::Image, BackendChoice::Gpu);
    assert_eq!(r.gpu_pass_names(), ["image-based foveation"]);
    for gaze in [[160.0, 128.0], [45.0, 202.0], [160.0, 128.0]] {
        let mut expected = cast.clone();
        let mut cpu = ImageFoveation::default();
        cpu.apply(&mut expected, &m, gaze);
        let (got, _) = r.render_at(gaze, 0.0).expect("renders");
        let (worst, n) = max_diff(&got, &expected);
        let blurred = changed(&cast, &expected);
        let top = cpu.levels().iter().fold(0.0f32, |a, &b| a.max(b));
        eprintln!(
            "image foveation at {gaze:?}: max channel difference {worst} ({n} differ); \
             the filter changed {blurred} channels, deepest level {top:.2}"
        );
        assert!(blurred > 1000, "{gaze:?}: the set-up must blur ({blurred})");
        assert!(worst <= 1, "{gaze:?}: {worst}");
        // The GPU path builds no CPU pyramid.
        let image = r.image_foveation().expect("image method");
        assert_eq!(image.allocated_levels(), 0);
        assert!(r.has_image_pyramid_buffers());
    }
}

#[test]
fn passes_are_paid_per_use_on_both_backends() {
    let plain = scene("FoveatedSampling");
    for method in [Method::Full, Method::Hybrid] {
        for backend in [BackendChoice::Cpu, BackendChoice::Gpu] {
            let mut r = renderer(&plain, method, backend);
            r.render_at(GAZE, 0.0).expect("renders");
            assert!(r.pass_names().is_empty(), "{method:?} {backend:?}");
            assert!(r.gpu_pass_names().is_empty(), "{method:?} {backend:?}");
            assert!(!r.has_dof_buffers(), "{method:?} {backend:?}");
            assert!(!r.has_image_pyramid_buffers(), "{method:?} {backend:?}");
            assert!(r.image_foveation().is_none(), "{method:?} {backend:?}");
            let text = r.explain().join("\n");
            assert!(!text.contains("GPU pass"), "{text}");
        }
    }
    // The CPU backend keeps its CPU passes: no GPU state, the CPU pyramid.
    let dof = scene("FoveatedSampling, DepthOfField(pupil_mm: 8.0)");
    let d = image_display();
    let mut r = renderer_on(&d, &dof, Method::Image, BackendChoice::Cpu);
    r.render_at(GAZE, 0.0).expect("renders");
    assert_eq!(r.pass_names(), [GAZE_DOF]);
    assert!(r.gpu_pass_names().is_empty());
    assert!(!r.has_dof_buffers() && !r.has_image_pyramid_buffers());
    assert!(r.image_foveation().expect("image").allocated_levels() > 0);
    // The GPU backend: both on the GPU, named by explain.
    let mut r = renderer_on(&d, &dof, Method::Image, BackendChoice::Gpu);
    assert!(!r.has_dof_buffers(), "buffers come with the first frame");
    r.render_at(GAZE, 0.0).expect("renders");
    assert_eq!(r.gpu_pass_names(), ["image-based foveation", GAZE_DOF]);
    assert_eq!(r.pass_names(), [GAZE_DOF]);
    assert!(r.has_dof_buffers() && r.has_image_pyramid_buffers());
    assert_eq!(r.image_foveation().expect("image").allocated_levels(), 0);
    let text = r.explain().join("\n");
    eprintln!("{text}");
    assert!(
        text.contains("GPU pass before the read-back: depth of field"),
        "{text}"
    );
    assert!(text.contains("image-based foveation on the GPU"), "{text}");
}

/// Odd and tiny frames (one pixel, a 1-px-high strip, odd sizes whose
/// levels round up): no panic, and still the CPU's output.
#[test]
fn odd_and_tiny_frames_match_too() {
    let s = scene("FoveatedSampling, DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0))");
    for (w, h) in [(1, 1), (7, 1), (75, 45)] {
        let d = Display::seed_17in(w, h);
        let cam = camera_on(&d);
        let gaze = [f64::from(w) / 2.0, f64::from(h) / 2.0];
        let mut reference = gpu(&s);
        reference.set_surface(true);
        let (cast, _) = reference.render_full(&cam).expect("cast");
        let mut expected = cast.clone();
        let mut image = ImageFoveation::default();
        image.apply(&mut expected, &model_on(&d), gaze);
        let mut dof = DepthOfField::from_effect(s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed"))
            .expect("dof");
        dof.run(
            &mut expected,
            &PassInput {
                scene: &s,
                camera: &cam,
                gaze_px: gaze,
                time_s: Some(0.0),
                vergence_mm: None,
            },
        );
        let mut r = renderer_on(&d, &s, Method::Image, BackendChoice::Gpu);
        let (got, _) = r.render_at(gaze, 0.0).expect("renders");
        let (worst, n) = max_diff(&got, &expected);
        eprintln!(
            "{w}×{h}: max channel difference {worst} ({n} differ); the passes changed {}",
            changed(&cast, &expected)
        );
        assert!(worst <= 1, "{w}×{h}: {worst}");
        if w > 8 {
            assert!(
                changed(&cast, &expected) > 100,
                "{w}×{h}: the set-up must blur"
            );
        }
    }
}

/// The focus state (gaze window, refocusing dynamics) is the CPU pass's
/// over a sequence of frames: the gaze jumps from the near-screen ball to
/// the far one and the focus follows by a 300-ms transition.
#[test]
fn refocusing_over_frames_follows_the_cpu_pass() {
    let s = scene("DepthOfField(pupil_mm: 8.0, refocus: Interpolate(ms: 300.0))");
    let cam = camera();
    let mut reference = gpu(&s);
    reference.set_surface(true);
    let (cast, _) = reference.render_full(&cam).expect("cast");
    let far: Vec<usize> = (0..cast.object.len())
        .filter(|&i| cast.object[i] == 2)
        .collect();
    let i = far[far.len() / 2];
    let far_gaze = [(i % W as usize) as f64 + 0.5, (i / W as usize) as f64 + 0.5];
    let mut cpu =
        DepthOfField::from_effect(s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed")).expect("dof");
    let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
    let mut focus = Vec::new();
    // The last frame's gaze is off the screen: its window holds nothing and
    // the focus is kept.
    let frames = [
        (GAZE, 0.0),
        (far_gaze, 0.1),
        (far_gaze, 0.25),
        (far_gaze, 0.5),
        ([-40.0, 300.0], 0.6),
    ];
    for (gaze, t) in frames {
        let mut expected = cast.clone();
        cpu.run(
            &mut expected,
            &PassInput {
                scene: &s,
                camera: &cam,
                gaze_px: gaze,
                time_s: Some(t),
                vergence_mm: None,
            },
        );
        let (got, _) = r.render_at(gaze, t).expect("renders");
        assert_eq!(r.gpu_focal_depth_mm(), cpu.focal_depth_mm(), "t = {t}");
        let (worst, n) = max_diff(&got, &expected);
        eprintln!(
            "refocus at t = {t} s: focus {:?} mm, max channel difference {worst} ({n} differ)",
            cpu.focal_depth_mm()
        );
        assert!(worst <= 1, "t = {t}: {worst}");
        focus.push(cpu.focal_depth_mm().expect("focused"));
    }
    // The focus moves towards the far ball over the transition, through
    // depths no pixel has.
    assert!(focus.windows(2).all(|f| f[0] <= f[1]), "{focus:?}");
    assert!(focus[0] < focus[2] && focus[2] < focus[3], "{focus:?}");
    assert_eq!(focus[4], focus[3]);
}

/// `focus: Vergence` on the GPU: the vergence depth where the frame has
/// one, the gaze window's depth where it has none, as on the CPU.
#[test]
fn vergence_focus_on_the_gpu_is_the_cpu_pass() {
    let plain = scene("");
    let mut reference = gpu(&plain);
    reference.set_surface(true);
    let cam = camera();
    let (cast, _) = reference.render_full(&cam).expect("cast");
    let s = scene("DepthOfField(pupil_mm: 8.0, focus: Vergence)");
    let mut cpu =
        DepthOfField::from_effect(s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed")).expect("dof");
    let mut r = renderer(&s, Method::Full, BackendChoice::Gpu);
    assert_eq!(
        r.gpu_pass_names().len(),
        1,
        "vergence focus runs on the GPU"
    );
    for (t, vergence) in [(0.0, Some(2100.0)), (0.1, None), (0.2, Some(300.0))] {
        let mut expected = cast.clone();
        cpu.run(
            &mut expected,
            &PassInput {
                scene: &s,
                camera: &cam,
                gaze_px: GAZE,
                time_s: Some(t),
                vergence_mm: vergence,
            },
        );
        r.set_vergence_mm(vergence);
        let (got, _) = r.render_at(GAZE, t).expect("renders");
        assert_eq!(r.gpu_focal_depth_mm(), cpu.focal_depth_mm(), "{vergence:?}");
        let (worst, _) = max_diff(&got, &expected);
        assert!(
            changed(&cast, &expected) > 500,
            "{vergence:?}: the set-up must blur"
        );
        assert!(worst <= 1, "{vergence:?}: {worst}");
    }
    // Attention focus runs on the GPU too, on the frame's own buffers
    // (tests/gpu_attention.rs compares it with the CPU pass).
    let s = scene("DepthOfField(focus: Attention)");
    let r = renderer(&s, Method::Full, BackendChoice::Gpu);
    assert_eq!(
        r.gpu_pass_names().len(),
        1,
        "attention focus runs on the GPU"
    );
    assert!(r.depth_of_field().is_none(), "no CPU pass is left");
    // So does foreground smoothing.
    let s = scene("DepthOfField(smooth_foreground: true)");
    let r = renderer(&s, Method::Full, BackendChoice::Gpu);
    assert_eq!(r.gpu_pass_names().len(), 1, "smoothing runs on the GPU");
    assert!(r.depth_of_field().is_none(), "no CPU pass is left");
}
