//! The GPU path of depth of field by splatting (Lee 2009 ch. 5) against the
//! CPU pass on the GPU's own cast: the same frame read back without post
//! passes and filtered by `DepthOfFieldSplat` (its hidden rays cast on the
//! CPU) must equal the GPU-filtered frame (hidden rays cast on the GPU)
//! within 1/255 on every channel. Plus pupil 0, pay per use, and the names
//! `gpu_pass_names` and `explain` give. Small frames (Mesa's lavapipe when
//! there is no GPU).

use std::path::Path;

use foveation::{Display, SamplingModel};
use pipeline::effects::dof_splat::DepthOfFieldSplat;
use pipeline::effects::{Pass, PassInput};
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::gpu::{wgpu, GpuError, GpuFrame, GpuPost, GpuRenderer, HIDDEN_HITS};
use raycast::layers::pixel_layers;
use raycast::ray::TriangleTest;
use raycast::render::Triggers;
use raycast::scene::PostPass;
use raycast::{Camera, Frame, Scene, SceneFile, NO_OBJECT};

const W: u32 = 160;
const H: u32 = 128;

const SPLAT: &str = "depth of field (Lee ch. 5, splatting)";

fn display() -> Display {
    Display::seed_17in(W, H)
}

fn model() -> SamplingModel {
    pipeline::sampling_model(display().geometry().expect("geometry"), 1.0).expect("model")
}

fn camera() -> Camera {
    Camera::new(&display().geometry().expect("geometry"))
}

/// The depth-of-field tests' three bumpy balls: at the screen (object 0),
/// halfway to the eye (1), 1.5 m behind the screen (2).
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

#[path = "common/dof_wall.rs"]
mod dof_wall;

/// The wall with a ball 270 mm from the eye in front of it: hidden
/// surfaces of other objects behind its rim.
fn wall_scene(effects: &str) -> Scene {
    dof_wall::wall(dof_wall::NEAR_BALL, effects).expect("the wall builds")
}

fn gpu(scene: &Scene) -> GpuRenderer {
    GpuRenderer::new(scene).unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

fn renderer(scene: &Scene, backend: BackendChoice) -> Renderer<'_> {
    Renderer::new(
        scene,
        camera(),
        model(),
        &Options {
            method: Method::Full,
            backend,
            ..Options::default()
        },
    )
    .expect("renderer")
}

/// The in-focus ball's centre on the screen (px).
const GAZE: [f64; 2] = [80.0 - 80.0 * 160.0 / 337.9, 64.0];

/// The largest difference of any channel, and how many channels differ.
fn max_diff(a: &Frame, b: &Frame) -> (u8, usize) {
    assert_eq!(a.hit, b.hit, "the hit mask is the cast's");
    fixtures::channel_diff(a, b)
}

fn changed(a: &Frame, b: &Frame) -> usize {
    a.rgb.iter().zip(&b.rgb).filter(|(x, y)| x != y).count()
}

#[test]
fn the_splat_pass_on_the_gpu_is_the_cpu_pass() {
    let cam = camera();
    let cases = [
        (
            "background blur, gaze focus",
            false,
            "DepthOfField(pupil_mm: 8.0, method: Splat)",
            false,
        ),
        (
            "foreground blur, fixed focus (hidden samples)",
            false,
            "DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0), method: Splat)",
            true,
        ),
        (
            "foreground blur over the wall (hidden surfaces)",
            true,
            "DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 1950.0), method: Splat)",
            true,
        ),
    ];
    for (what, wall, effect, needs_hidden) in cases {
        let build = |e: &str| if wall { wall_scene(e) } else { scene(e) };
        let plain = build("");
        let mut reference = gpu(&plain);
        reference.set_surface(true);
        let (cast, _) = reference.render_full(&cam).expect("cast");
        let s = build(effect);
        let e = s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed");
        let mut cpu = DepthOfFieldSplat::from_effect(e).expect("splat");
        let mut expected = cast.clone();
        let started = std::time::Instant::now();
        cpu.run(
            &mut expected,
            &PassInput {
                scene: &s,
                camera: &cam,
                gaze_px: GAZE,
                time_s: Some(0.0),
                vergence_mm: None,
            },
        );
        let cpu_ms = started.elapsed().as_secs_f64() * 1e3;
        let mut r = renderer(&s, BackendChoice::Gpu);
        assert_eq!(r.gpu_pass_names(), [SPLAT], "{what}");
        assert!(!r.has_splat_buffers(), "buffers come with the first frame");
        let started = std::time::Instant::now();
        let (got, _) = r.render_at(GAZE, 0.0).expect("renders");
        let gpu_ms = started.elapsed().as_secs_f64() * 1e3;
        assert!(r.has_splat_buffers() && !r.has_dof_buffers(), "{what}");
        assert_eq!(r.gpu_focal_depth_mm(), cpu.focal_depth_mm(), "{what}");
        let (worst, n) = max_diff(&got, &expected);
        let blurred = changed(&cast, &expected);
        eprintln!(
            "{what}: max channel difference GPU vs CPU {worst} ({n} channels differ); \
             the pass changed {blurred} channels, {} hidden samples, focus {:?} mm \
             (CPU pass {cpu_ms:.0} ms, GPU frame {gpu_ms:.0} ms)",
            cpu.hidden_samples(),
            cpu.focal_depth_mm()
        );
        assert!(blurred > 1000, "{what}: the set-up must blur ({blurred})");
        if needs_hidden {
            assert!(
                cpu.hidden_samples() > 100,
                "{what}: {}",
                cpu.hidden_samples()
            );
            // The hidden image matters here: without it the frame differs.
            let mut without = DepthOfFieldSplat::from_effect(e).expect("splat");
            without.hidden = false;
            let mut v_only = cast.clone();
            without.run(
                &mut v_only,
                &PassInput {
                    scene: &s,
                    camera: &cam,
                    gaze_px: GAZE,
                    time_s: Some(0.0),
                    vergence_mm: None,
                },
            );
            let (h_worst, h_n) = max_diff(&v_only, &expected);
            eprintln!("{what}: without H the CPU pass differs by up to {h_worst} ({h_n} channels)");
            assert!(h_worst > 8 && h_n > 100, "{what}: {h_worst} {h_n}");
        }
        assert!(worst <= 1, "{what}: {worst}");
    }
}

#[test]
fn the_splat_pass_after_the_foveated_gpu_frame_is_the_cpu_pass() {
    let s = scene(
        "FoveatedSampling, SilhouetteRefinement, \
         DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0), method: Splat)",
    );
    let cam = camera();
    let gaze = [100.0, 70.0];
    let mut reference = gpu(&s);
    reference.set_surface(true);
    let mask = foveation::mask::build(&model(), foveation::Layout::Nyquist, gaze).expect("mask");
    let (cast, _) = reference
        .render_foveated(&cam, &mask, &Triggers::from_scene(&s))
        .expect("cast");
    let e = s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed");
    let mut cpu = DepthOfFieldSplat::from_effect(e).expect("splat");
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
    let mut r = Renderer::new(
        &s,
        cam,
        model(),
        &Options {
            method: Method::Hybrid,
            backend: BackendChoice::Gpu,
            ..Options::default()
        },
    )
    .expect("renderer");
    assert_eq!(r.gpu_pass_names(), [SPLAT]);
    let (got, _) = r.render_at(gaze, 0.0).expect("renders");
    let (worst, n) = max_diff(&got, &expected);
    eprintln!(
        "hybrid + splat, foreground blur: max channel difference {worst} ({n} differ); \
         the pass changed {}, {} hidden samples",
        changed(&cast, &expected),
        cpu.hidden_samples()
    );
    assert!(changed(&cast, &expected) > 1000);
    assert!(worst <= 1, "{worst}");
}

/// A post pass that asks for every pixel's hidden surface and reads the
/// hidden image back.
struct HiddenProbe {
    out: Vec<u32>,
}

impl GpuPost for HiddenProbe {
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let n = u64::from(frame.width()) * u64::from(frame.height());
        let want = frame.storage_buffer("want", 4 * n, wgpu::BufferUsages::COPY_DST)?;
        frame
            .queue()
            .write_buffer(&want, 0, &vec![1u8; 4 * n as usize]);
        let out = frame.storage_buffer("hidden", 16 * n, wgpu::BufferUsages::COPY_SRC)?;
        frame.cast_hidden(&mut encoder, &want, &out)?;
        let (words, next) = frame.read_words(encoder, &[(&out, 0, 4 * n)])?;
        self.out = words.into_iter().next().unwrap_or_default();
        Ok(next)
    }
}

#[test]
fn the_hidden_image_on_the_gpu_is_the_cpu_rule() {
    let s = wall_scene("");
    let cam = camera();
    let mut g = gpu(&s);
    g.set_surface(true);
    let (plain, _) = g.render_full(&cam).expect("cast");
    assert!(
        !g.has_hidden_pipeline(),
        "made by the first frame that asks"
    );
    let mut probe = HiddenProbe { out: Vec::new() };
    let (cast, _) = g.render_full_with(&cam, Some(&mut probe)).expect("cast");
    assert!(g.has_hidden_pipeline());
    assert_eq!(
        cast.rgb, plain.rgb,
        "the hidden cast leaves the frame alone"
    );
    assert_eq!(probe.out.len(), 4 * (W * H) as usize);
    let (mut surfaces, mut backgrounds, mut mismatches) = (0, 0, 0);
    let (mut d_depth, mut d_rgb) = (0.0f32, 0.0f32);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            if !cast.hit[i] {
                continue;
            }
            let g = &probe.out[4 * i..4 * i + 4];
            let g = [0, 1, 2, 3].map(|k| f32::from_bits(g[k]));
            let layers =
                pixel_layers(&s, &cam, x, y, HIDDEN_HITS, TriangleTest::default()).expect("layers");
            let other = layers.as_slice().iter().skip(1).find(|l| {
                l.hit.object != cast.object[i]
                    && l.hit.object != NO_OBJECT
                    && l.depth_mm > cast.depth_mm[i]
            });
            match other {
                Some(l) => {
                    surfaces += 1;
                    let c = l.colour.to_array().map(|v| v.clamp(0.0, 1.0));
                    if g[3] < 0.0 {
                        mismatches += 1;
                        continue;
                    }
                    d_depth = d_depth.max((g[3] - l.depth_mm).abs() / l.depth_mm);
                    for k in 0..3 {
                        d_rgb = d_rgb.max((g[k] - c[k]).abs());
                    }
                }
                None if layers.exhausted() => {
                    backgrounds += 1;
                    if g[3] != -2.0 {
                        mismatches += 1;
                    }
                }
                None => {
                    if g[3] != -1.0 {
                        mismatches += 1;
                    }
                }
            }
        }
    }
    eprintln!(
        "hidden image: {surfaces} surfaces, {backgrounds} background, {mismatches} pixels \
         disagree; largest relative depth difference {d_depth:e}, colour {d_rgb:e}"
    );
    assert!(
        surfaces > 100 && backgrounds > 100,
        "{surfaces} {backgrounds}"
    );
    assert_eq!(mismatches, 0);
    assert!(d_depth < 1e-5 && d_rgb < 1e-4, "{d_depth} {d_rgb}");
}

#[test]
fn pupil_zero_is_the_identity_and_makes_no_buffers() {
    let plain = scene("");
    let (cast, _) = gpu(&plain).render_full(&camera()).expect("cast");
    let s = scene("DepthOfField(pupil_mm: 0.0, method: Splat)");
    let mut r = renderer(&s, BackendChoice::Gpu);
    assert_eq!(r.gpu_pass_names(), [SPLAT]);
    let (got, _) = r.render_at(GAZE, 0.0).expect("renders");
    assert_eq!(got.rgb, cast.rgb);
    assert!(!r.has_splat_buffers());
}

#[test]
fn the_splat_pass_is_paid_per_use_and_named() {
    // The ch. 4 pass: no splat buffers.
    let mip = scene("DepthOfField(pupil_mm: 8.0)");
    let mut r = renderer(&mip, BackendChoice::Gpu);
    r.render_at(GAZE, 0.0).expect("renders");
    assert!(r.has_dof_buffers() && !r.has_splat_buffers());
    assert!(!r.explain().join("\n").contains("ch. 5"));
    // The CPU backend: the CPU pass, no GPU state.
    let s = scene("DepthOfField(pupil_mm: 8.0, method: Splat)");
    let mut r = renderer(&s, BackendChoice::Cpu);
    r.render_at(GAZE, 0.0).expect("renders");
    assert!(r.gpu_pass_names().is_empty() && !r.has_splat_buffers());
    assert_eq!(r.pass_names(), [SPLAT]);
    // The GPU backend names it.
    let r = renderer(&s, BackendChoice::Gpu);
    assert_eq!(r.pass_names(), [SPLAT]);
    let text = r.explain().join("\n");
    assert!(
        text.contains(&format!("GPU pass before the read-back: {SPLAT}"))
            && text.contains(&format!("{SPLAT} (GPU)"))
            && text.contains("hidden image cast on the GPU"),
        "{text}"
    );
    // Attention focus runs on the GPU too, on the frame's own buffers
    // (tests/gpu_attention.rs compares it with the CPU pass).
    let att = scene("DepthOfField(pupil_mm: 8.0, focus: Attention, method: Splat)");
    let r = renderer(&att, BackendChoice::Gpu);
    assert_eq!(r.gpu_pass_names(), [SPLAT]);
    assert_eq!(r.pass_names(), [SPLAT]);
}

/// `highlights: true` (eq. 5.5): the scene turns them on, they brighten
/// blurred bright samples on the CPU, and the GPU pass equals the CPU's.
#[test]
fn defocused_highlights_on_the_gpu_are_the_cpu_pass() {
    let cam = camera();
    let plain = scene("");
    let mut reference = gpu(&plain);
    reference.set_surface(true);
    let (cast, _) = reference.render_full(&cam).expect("cast");
    let s = scene("DepthOfField(pupil_mm: 8.0, focus: Fixed(depth_mm: 2100.0), method: Splat, highlights: true)");
    let e = s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed");
    let mut cpu = DepthOfFieldSplat::from_effect(e).expect("splat");
    assert!(cpu.highlights.is_some(), "the scene turns them on");
    let mut off = DepthOfFieldSplat::from_effect(e).expect("splat");
    off.highlights = None;
    let input = PassInput {
        scene: &s,
        camera: &cam,
        gaze_px: GAZE,
        time_s: Some(0.0),
        vergence_mm: None,
    };
    let (mut expected, mut plain_splat) = (cast.clone(), cast.clone());
    cpu.run(&mut expected, &input);
    off.run(&mut plain_splat, &input);
    let brighter = expected
        .rgb
        .iter()
        .zip(&plain_splat.rgb)
        .filter(|(a, b)| a > b)
        .count();
    let darker = expected
        .rgb
        .iter()
        .zip(&plain_splat.rgb)
        .filter(|(a, b)| a < b)
        .count();
    eprintln!("highlights: {brighter} channels brighter, {darker} darker than without");
    assert!(brighter > 20, "the highlights changed nothing ({brighter})");
    let mut r = renderer(&s, BackendChoice::Gpu);
    let (got, _) = r.render_at(GAZE, 0.0).expect("renders");
    let (worst, n) = max_diff(&got, &expected);
    eprintln!("highlights: max channel difference GPU vs CPU {worst} ({n} channels differ)");
    assert!(worst <= 1, "{worst}");
}
