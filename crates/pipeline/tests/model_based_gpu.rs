//! The model-based methods on the GPU backend: `Renderer` with
//! `Method::Lod` and `Method::Simplify` on `--backend gpu` selects the same
//! triangles as on the CPU and rasterises them with the GPU's render
//! pipeline into an image within the raster tolerance of the CPU's; the
//! raster pipeline and buffers exist only when a model-based method runs on
//! the GPU. Runs on whatever adapter the machine has (Mesa's lavapipe
//! without a GPU, which `scripts/system-deps.sh` installs).
//!
//! `cargo test -p pipeline --test model_based_gpu -- --nocapture` prints
//! the measured differences.

use std::path::Path;

use foveation::Display;
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::scene::Effect;
use raycast::{Camera, Frame, Scene, SceneFile};

const W: u32 = 320;
const H: u32 = 256;

fn display() -> Display {
    Display::seed_17in(W, H)
}

fn scene(name: &str) -> Scene {
    scene_with(name, vec![Effect::FoveatedSampling])
}

fn scene_with(name: &str, effects: Vec<Effect>) -> Scene {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let path = repo.join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    file.set_effects(effects);
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn renderer(scene: &Scene, method: Method, backend: BackendChoice) -> Renderer<'_> {
    let g = display().geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            method,
            backend,
            surface: true,
            ..Options::default()
        },
    )
    .unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

/// (pixels whose hit differs, pixels both cover with one object, of those
/// within 2/255 on every channel, pixels both hit with different objects).
fn differences(c: &Frame, g: &Frame) -> (usize, usize, usize, usize) {
    let (mut hit, mut same, mut within, mut object) = (0, 0, 0, 0);
    for i in 0..c.len() {
        if c.hit[i] != g.hit[i] {
            hit += 1;
        } else if c.hit[i] && c.object[i] != g.object[i] {
            object += 1;
        } else if c.hit[i] {
            same += 1;
            within += usize::from((0..3).all(|k| c.rgb[3 * i + k].abs_diff(g.rgb[3 * i + k]) <= 2));
        }
    }
    (hit, same, within, object)
}

#[test]
fn lod_and_simplify_on_the_gpu_match_the_cpu() {
    let s = scene("bunny");
    for method in [Method::Lod, Method::Simplify] {
        let mut cpu = renderer(&s, method, BackendChoice::Cpu);
        let mut gpu = renderer(&s, method, BackendChoice::Gpu);
        assert_eq!(gpu.backend_name(), "gpu");
        assert!(!gpu.has_raster_buffers(), "nothing before the first frame");
        for gaze in [[160.0, 128.0], [5.0, 5.0], [300.0, 240.0]] {
            let (c, _) = cpu.render(gaze).expect("CPU frame");
            let (g, _) = gpu.render(gaze).expect("GPU frame");
            let mc = *cpu.model_based().expect("state").last();
            let mg = *gpu.model_based().expect("state").last();
            assert_eq!(
                mg.triangles_drawn, mc.triangles_drawn,
                "{method:?} {gaze:?}"
            );
            assert_eq!(mg.raster.triangles_in, mc.raster.triangles_in);
            assert_eq!(
                mg.raster.pixels_covered,
                g.hit.iter().filter(|h| **h).count() as u64
            );
            let (hit, same, within, object) = differences(&c, &g);
            let pct = |n: usize, d: usize| 100.0 * n as f64 / d.max(1) as f64;
            println!(
                "{} gaze {gaze:?}: {} triangles on both; GPU vs CPU raster: hit mask differs at {hit} of {} px \
                 ({:.3} %), object at {object} px, colour within 2/255 at {:.3} % of {same} px \
                 (raster {:.1} ms CPU, {:.1} ms GPU incl. upload and read-back)",
                method.name(),
                mg.triangles_drawn,
                c.len(),
                pct(hit, c.len()),
                pct(within, same),
                mc.raster_ms,
                mg.raster_ms,
            );
            assert!(pct(hit, c.len()) < 0.5, "{method:?} {gaze:?}: hit {hit}");
            assert_eq!(object, 0, "{method:?} {gaze:?}");
            assert!(pct(within, same) >= 99.0, "{method:?} {gaze:?}");
            assert!(same > c.len() / 50, "the bunny is seen");
        }
        assert!(gpu.has_raster_buffers());
        assert!(!cpu.has_raster_buffers());
        let explain = gpu.explain().join("\n");
        assert!(explain.contains("GPU render pipeline"), "{explain}");
        let explain = cpu.explain().join("\n");
        assert!(explain.contains("CPU z-buffer"), "{explain}");
    }
}

#[test]
fn the_raster_pipeline_is_made_only_for_a_model_based_method_on_the_gpu() {
    let s = scene("bunny");
    for method in [Method::Full, Method::Hybrid, Method::Image] {
        let mut r = renderer(&s, method, BackendChoice::Gpu);
        r.render([160.0, 128.0]).expect("frame");
        assert!(!r.has_raster_buffers(), "{method:?}");
    }
    // Auto picks the GPU only where a real one is; either way it renders.
    let mut r = renderer(&s, Method::Lod, BackendChoice::Auto);
    r.render([160.0, 128.0]).expect("frame");
    assert_eq!(r.has_raster_buffers(), r.backend_name() == "gpu");
    if r.backend_name() == "cpu" {
        println!("auto: {:?}", r.note());
    }
}

/// The raster path has no GPU post-pass hook: with a model-based method on
/// the GPU, depth of field runs on the CPU after the read-back.
#[test]
fn effect_passes_run_on_the_cpu_after_the_gpu_raster() {
    let text = "[FoveatedSampling, DepthOfField(pupil_mm: 8.0)]";
    let effects: Vec<Effect> = ron::from_str(text).expect("effects");
    let s = scene_with("bunny", effects);
    let mut r = renderer(&s, Method::Lod, BackendChoice::Gpu);
    assert!(r.gpu_pass_names().is_empty());
    assert_eq!(r.pass_names().len(), 1, "{:?}", r.pass_names());
    r.render([160.0, 128.0]).expect("frame");
    assert!(!r.has_dof_buffers());
    assert!(r.has_raster_buffers());
    assert!(r.depth_of_field().is_some(), "the CPU pass ran");
}
