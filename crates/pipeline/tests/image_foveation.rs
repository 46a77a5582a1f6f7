//! Image-based foveation (`Method::Image`): the full frame where the ray
//! mask casts every pixel, blurred where it spaces its rays, silhouettes
//! exact, and nothing allocated by any other method.

use std::path::Path;

use foveation::{Display, SamplingModel};
use pipeline::image_foveation::ImageFoveation;
use pipeline::{BackendChoice, Method, Options, Renderer};
use proptest::prelude::*;
use raycast::scene::{Effect, Sampling};
use raycast::{Camera, Frame, Layer, Scene, SceneFile};

const W: u32 = 640;
const H: u32 = 512;

fn display(w: u32, h: u32) -> Display {
    Display::seed_17in(w, h)
}

fn scene(name: &str) -> Scene {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let path = repo.join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    file.set_effects(vec![Effect::FoveatedSampling]);
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn model() -> SamplingModel {
    pipeline::sampling_model(display(W, H).geometry().expect("geometry"), 1.0).expect("model")
}

fn render(scene: &Scene, method: Method, gaze: [f64; 2]) -> (Frame, Option<usize>) {
    let model = model();
    let mut r = Renderer::new(
        scene,
        Camera::new(&model.geometry),
        model,
        &Options {
            method,
            backend: BackendChoice::Cpu,
            ..Options::default()
        },
    )
    .expect("renderer");
    let (frame, _) = r.render(gaze).expect("frame");
    (frame, r.image_foveation().map(|i| i.allocated_levels()))
}

#[test]
fn the_fovea_is_the_full_frame_and_the_periphery_is_blurred() {
    let s = scene("search-task");
    let gaze = [200.0, 180.0];
    let (full, none) = render(&s, Method::Full, gaze);
    assert_eq!(none, None, "the full method allocates no pyramid");
    let (image, levels) = render(&s, Method::Image, gaze);
    assert!(levels.unwrap_or(0) >= 2, "a pyramid was built: {levels:?}");
    assert_eq!(image.hit, full.hit, "silhouettes are the full frame's");
    assert!(image.layer.iter().all(|&l| l == Layer::Full));

    let sampler = model().from_por(gaze);
    let (mut exact, mut changed, mut far) = (0usize, 0usize, 0usize);
    for y in 0..H as usize {
        for x in 0..W as usize {
            let i = y * W as usize + x;
            let s = sampler.spacing_at([x as f64 + 0.5, y as f64 + 0.5]);
            let same = image.rgb[3 * i..3 * i + 3] == full.rgb[3 * i..3 * i + 3];
            if s.spacing_px <= 1.0 {
                assert!(same, "pixel ({x}, {y}) at spacing 1 changed");
                exact += 1;
            } else if s.spacing_px >= 2.0 && x + 1 < W as usize {
                // An edge of the full frame: a step of 32+ levels to the
                // right-hand neighbour.
                let step =
                    (0..3).any(|k| full.rgb[3 * i + k].abs_diff(full.rgb[3 * i + 3 + k]) >= 32);
                if step {
                    far += 1;
                    changed += usize::from(!same);
                }
            }
        }
    }
    eprintln!("fovea {exact} px exact; {changed} of {far} peripheral edge px changed");
    assert!(exact > 1000, "a fovea of {exact} px");
    assert!(far > 100, "{far} peripheral edge pixels");
    // Where the mask spaces rays 2+ px apart, edges are blurred.
    assert!(
        changed * 10 > 9 * far,
        "{changed} of {far} peripheral edge pixels changed"
    );
}

#[test]
fn other_methods_build_no_pyramid_and_no_foveated_scene_falls_back() {
    let s = scene("bunny");
    for method in [Method::Full, Method::Hybrid] {
        assert_eq!(render(&s, method, [320.0, 256.0]).1, None, "{method:?}");
    }
    let mut plain = s.clone();
    plain.sampling = Sampling::Full;
    plain.passes.clear();
    assert_eq!(Method::Image.for_scene(&plain), Method::Full);
    assert_eq!(render(&plain, Method::Image, [320.0, 256.0]).1, None);
}

#[test]
fn a_non_finite_gaze_is_an_error() {
    let s = scene("bunny");
    let model = model();
    let mut r = Renderer::new(
        &s,
        Camera::new(&model.geometry),
        model,
        &Options {
            method: Method::Image,
            ..Options::default()
        },
    )
    .expect("renderer");
    for g in [[f64::NAN, 1.0], [1.0, f64::INFINITY]] {
        let e = r.render(g).expect_err("refused");
        assert!(e.to_string().contains("finite"), "{e}");
    }
}

/// A synthetic frame: a vertical luminance ramp with a hard edge.
fn synthetic(w: u32, h: u32) -> Frame {
    let mut f = Frame::blank(w, h, [0, 0, 0], Layer::Full, false);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let v = if x < w as usize / 2 {
                (y % 256) as u8
            } else {
                255
            };
            let i = 3 * (y * w as usize + x);
            f.rgb[i..i + 3].copy_from_slice(&[v, v / 2, 255 - v]);
        }
    }
    f
}

#[test]
fn a_constant_frame_stays_constant_and_spacing_one_is_the_identity() {
    let m = model();
    let mut f = Frame::blank(W, H, [37, 180, 3], Layer::Full, false);
    let before = f.clone();
    let mut image = ImageFoveation::default();
    image.apply(&mut f, &m, [0.0, 0.0]);
    assert!(image.allocated_levels() >= 2);
    assert_eq!(f, before, "blurring a constant colour gives it back");

    let sharp = SamplingModel::new(m.geometry, m.csf, m.contrast, 1.0).expect("model");
    let mut g = synthetic(W, H);
    let before = g.clone();
    let mut image = ImageFoveation::default();
    image.apply(&mut g, &sharp, [10.0, 10.0]);
    assert_eq!(g, before, "a maximum spacing of 1 px blurs nothing");
    assert_eq!(image.allocated_levels(), 0, "and builds no pyramid");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(24), ..ProptestConfig::default() })]

    /// Any gaze (on or far off the screen) and any small frame size: no
    /// panic, levels in range, pixels at spacing 1 untouched.
    #[test]
    fn any_gaze_and_size_is_safe(
        gx in prop_oneof![-1e9f64..1e9, -100f64..200.0],
        gy in prop_oneof![-1e9f64..1e9, -100f64..200.0],
        w in 1u32..96,
        h in 1u32..96,
        inset in prop_oneof![Just(0.0f64), 0.0f64..40.0],
    ) {
        let g = display(w, h).geometry().expect("geometry");
        let m = pipeline::sampling_model(g, 1.0).expect("model").with_inset_deg(inset).expect("inset");
        let mut f = synthetic(w, h);
        let before = f.clone();
        let mut image = ImageFoveation::default();
        image.apply(&mut f, &m, [gx, gy]);
        let levels = image.levels();
        prop_assert_eq!(levels.len(), (w * h) as usize);
        let max = m.max_spacing_px.log2() as f32 + 1e-6;
        prop_assert!(levels.iter().all(|&l| (0.0..=max).contains(&l)));
        for (i, &l) in levels.iter().enumerate() {
            if l == 0.0 {
                prop_assert_eq!(&f.rgb[3 * i..3 * i + 3], &before.rgb[3 * i..3 * i + 3]);
            }
        }
    }
}
