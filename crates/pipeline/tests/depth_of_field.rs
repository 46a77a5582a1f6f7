//! Depth of field (Lee 2009 ch. 4) as an effect pass: built only when the
//! scene lists it, in-focus pixels untouched, near and far objects blurred,
//! and no NaN or panic for degenerate depths, focus or apertures.

use std::path::Path;

use foveation::thin_lens::EyeLens;
use foveation::Display;
use pipeline::effects::depth_of_field::{coc_px, level_for_coc, DepthOfField};
use pipeline::effects::{Pass, PassInput};
use pipeline::{BackendChoice, Method, Options, Renderer};
use proptest::prelude::*;
use raycast::scene::{DofFocus, Effect};
use raycast::{Camera, Frame, Layer, Scene, SceneFile};

const W: u32 = 640;
const H: u32 = 512;

/// The seed's 17" display at a reduced pixel count.
fn camera() -> Camera {
    let d = Display {
        name: "17in".into(),
        resolution_px: (W, H),
        size_mm: (337.9, 270.3),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    };
    Camera::new(&d.geometry().expect("geometry"))
}

/// Three bumpy spheres: one at the screen (object 0), one halfway to the
/// eye (object 1), one 1.5 m behind the screen (object 2).
fn scene_text(effects: &str) -> String {
    format!(
        r#"Scene(
    name: "dof",
    meshes: {{ "ball": Bumpy(triangles: 6000, amplitude: 0.12, seed: 3) }},
    objects: [
        (mesh: "ball", translate_mm: (-80.0, 0.0, 0.0), scale_mm: 35.0),
        (mesh: "ball", translate_mm: (30.0, 40.0, 270.0), scale_mm: 12.0),
        (mesh: "ball", translate_mm: (150.0, -100.0, -1500.0), scale_mm: 100.0),
    ],
    effects: [{effects}],
)"#
    )
}

fn build(effects: &str) -> Result<Scene, raycast::SceneError> {
    let file: SceneFile = ron::from_str(&scene_text(effects)).expect("parses");
    Scene::build(&file, Path::new("."))
}

fn renderer(scene: &Scene, surface: bool) -> Renderer<'_> {
    let d = Display {
        name: "17in".into(),
        resolution_px: (W, H),
        size_mm: (337.9, 270.3),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    };
    let g = d.geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            backend: BackendChoice::Cpu,
            surface,
            ..Options::default()
        },
    )
    .expect("renderer")
}

/// The in-focus ball's centre on the screen (px).
const GAZE: [f64; 2] = [320.0 - 80.0 * 640.0 / 337.9, 256.0];

/// Sum of squared luminance differences to the right and lower neighbours
/// over the pixels within 3 px of object `o` (in `ids`).
fn edge_energy(frame: &Frame, ids: &[u32], o: u32) -> f64 {
    let (w, h) = (W as usize, H as usize);
    let lum = |i: usize| -> f64 {
        frame.rgb[3 * i..3 * i + 3]
            .iter()
            .map(|&c| f64::from(c))
            .sum()
    };
    let mut e = 0.0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let near = (y.saturating_sub(3)..=(y + 3).min(h - 1)).any(|yy| {
                (x.saturating_sub(3)..=(x + 3).min(w - 1)).any(|xx| ids[yy * w + xx] == o)
            });
            if near {
                let i = y * w + x;
                e += (lum(i + 1) - lum(i)).powi(2) + (lum(i + w) - lum(i)).powi(2);
            }
        }
    }
    e
}

#[test]
fn a_scene_without_the_effect_builds_no_pass_and_no_surface_buffers() {
    let s = build("").expect("builds");
    let mut r = renderer(&s, false);
    assert!(r.pass_names().is_empty());
    let (frame, _) = r.render(GAZE).expect("renders");
    assert!(!frame.has_surface());
    assert!(frame.depth_mm.is_empty() && frame.object.is_empty() && frame.normal.is_empty());
}

#[test]
fn the_scene_file_parses_defaults_and_validates_naming_the_field() {
    let s = build("DepthOfField()").expect("builds");
    assert_eq!(s.effects, [Effect::DEPTH_OF_FIELD]);
    let s =
        build("DepthOfField(pupil_mm: 6.0, focal_length_mm: 17.0, focus: Fixed(depth_mm: 800.0))")
            .expect("builds");
    assert_eq!(
        s.effects,
        [Effect::DepthOfField {
            pupil_mm: 6.0,
            focal_length_mm: 17.0,
            retina_distance_mm: 24.0,
            focus: DofFocus::Fixed { depth_mm: 800.0 },
        }]
    );
    assert!(build("DepthOfField(focus: Fixed(depth_mm: inf))").is_ok());
    assert!(build("DepthOfField(pupil_mm: 0.0)").is_ok());
    for (text, field) in [
        ("DepthOfField(pupil_mm: -1.0)", "effects[0].pupil_mm"),
        ("DepthOfField(pupil_mm: NaN)", "effects[0].pupil_mm"),
        ("DepthOfField(pupil_mm: 1000.0)", "effects[0].pupil_mm"),
        (
            "DepthOfField(focal_length_mm: 0.0)",
            "effects[0].focal_length_mm",
        ),
        (
            "DepthOfField(focal_length_mm: inf)",
            "effects[0].focal_length_mm",
        ),
        (
            "DepthOfField(retina_distance_mm: -24.0)",
            "effects[0].retina_distance_mm",
        ),
        (
            "DepthOfField(focus: Fixed(depth_mm: 10.0))",
            "effects[0].focus.depth_mm",
        ),
        (
            "DepthOfField(focus: Fixed(depth_mm: NaN))",
            "effects[0].focus.depth_mm",
        ),
    ] {
        match build(text) {
            Err(raycast::SceneError::Field { field: f, .. }) => assert_eq!(f, field, "{text}"),
            other => panic!("{text}: {other:?}"),
        }
    }
}

#[test]
fn near_and_far_objects_are_blurred_and_the_focused_one_is_not() {
    let plain = build("").expect("builds");
    let (reference, _) = renderer(&plain, true).render(GAZE).expect("renders");
    let dof = build("DepthOfField(pupil_mm: 8.0)").expect("builds");
    let mut r = renderer(&dof, false);
    assert_eq!(r.method(), Method::Full);
    assert_eq!(r.pass_names(), ["depth of field (Lee ch. 4)"]);
    let (blurred, _) = r.render(GAZE).expect("renders");
    assert!(
        blurred.has_surface(),
        "the pass asks for the surface buffers"
    );
    assert_eq!(blurred.object, reference.object);
    assert!(blurred.layer.iter().all(|l| *l == Layer::Full));
    // Every pixel of the focused ball is untouched (its CoC is < 1 px).
    for (i, &o) in reference.object.iter().enumerate() {
        if o == 0 {
            assert_eq!(
                blurred.rgb[3 * i..3 * i + 3],
                reference.rgb[3 * i..3 * i + 3],
                "pixel {i}"
            );
        }
    }
    let ratio = |o: u32| {
        edge_energy(&blurred, &reference.object, o) / edge_energy(&reference, &reference.object, o)
    };
    let (focused, near, far) = (ratio(0), ratio(1), ratio(2));
    eprintln!("edge energy after/before: focused {focused:.3}, near {near:.3}, far {far:.3}");
    // The focused ball keeps most of its edges (only the blurred background
    // around it changes); the near and far balls lose most of theirs.
    assert!(focused > 0.7, "focused {focused}");
    assert!(near < 0.5 * focused, "near {near}, focused {focused}");
    assert!(far < 0.5 * focused, "far {far}, focused {focused}");
    // A second frame reuses the pass's buffers and gives the same picture.
    let (again, _) = r.render(GAZE).expect("renders");
    assert_eq!(again.rgb, blurred.rgb);
}

#[test]
fn pupil_zero_is_the_identity() {
    let plain = build("").expect("builds");
    let (reference, _) = renderer(&plain, true).render(GAZE).expect("renders");
    let dof = build("DepthOfField(pupil_mm: 0.0)").expect("builds");
    let (frame, _) = renderer(&dof, false).render(GAZE).expect("renders");
    assert_eq!(frame.rgb, reference.rgb);
}

/// A small frame with the given depths and a colour pattern.
fn frame_with(depths: &[f32], w: u32) -> Frame {
    let h = depths.len() as u32 / w;
    let mut f = Frame::blank(w, h, [0, 0, 0], Layer::Full, true);
    for (i, d) in depths.iter().enumerate() {
        f.depth_mm[i] = *d;
        f.hit[i] = d.is_finite();
        f.rgb[3 * i..3 * i + 3].copy_from_slice(&[
            (i * 37 % 256) as u8,
            (i * 91 % 256) as u8,
            (i * 13 % 256) as u8,
        ]);
    }
    f
}

fn depth() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(f32::INFINITY),
        Just(16.7f32),
        Just(f32::NAN),
        -10.0f32..10.0,
        10.0f32..100_000.0,
    ]
}

fn focus() -> impl Strategy<Value = DofFocus> {
    prop_oneof![
        Just(DofFocus::Gaze),
        Just(DofFocus::Fixed {
            depth_mm: f64::INFINITY
        }),
        Just(DofFocus::Fixed { depth_mm: 0.0 }),
        Just(DofFocus::Fixed { depth_mm: 16.7 }),
        (1.0f64..100_000.0).prop_map(|depth_mm| DofFocus::Fixed { depth_mm }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// No panic for any depth, focus, aperture or gaze; every pixel whose
    /// CoC is under 0.5 px (and every one at level 0) keeps its bytes.
    #[test]
    fn degenerate_inputs_neither_panic_nor_touch_sharp_pixels(
        depths in prop::collection::vec(depth(), 24 * 16),
        pupil in prop_oneof![Just(0.0f64), 0.0f64..10.0, Just(1e4), Just(1e9)],
        focus in focus(),
        gaze in prop_oneof![
            Just([f64::NAN, 3.0]),
            Just([f64::INFINITY, -1e300]),
            ((-50.0f64..80.0), (-50.0f64..80.0)).prop_map(|(x, y)| [x, y]),
        ],
    ) {
        let scene = build("").expect("builds");
        let cam = camera();
        let lens = EyeLens { aperture_mm: pupil, ..EyeLens::default() };
        let mut pass = DepthOfField::new(lens, focus);
        prop_assert!(pass.needs_surface());
        let before = frame_with(&depths, 24);
        let mut frame = before.clone();
        let input = PassInput { scene: &scene, camera: &cam, gaze_px: gaze };
        pass.run(&mut frame, &input);
        pass.run(&mut frame.clone(), &input);
        prop_assert_eq!(frame.depth_mm.len(), before.depth_mm.len());
        if pupil == 0.0 {
            prop_assert_eq!(&frame.rgb, &before.rgb);
        }
        if let DofFocus::Fixed { depth_mm } = focus {
            let pitch = cam.pitch();
            let ppmm = 0.5 * (1.0 / f64::from(pitch[0]) + 1.0 / f64::from(pitch[1]));
            for (i, d) in depths.iter().enumerate() {
                let c = coc_px(&lens, f64::from(*d), depth_mm, f64::from(cam.eye.z), ppmm);
                prop_assert!(!c.is_nan());
                if c < 0.5 || level_for_coc(c, 8.0) == 0.0 {
                    prop_assert_eq!(&frame.rgb[3 * i..3 * i + 3], &before.rgb[3 * i..3 * i + 3]);
                }
            }
        }
    }
}

/// Eq. 4.9: the anisotropic pyramid keeps the sharp, in-focus ball's colour
/// out of the blurred background around it (intensity leakage).
#[test]
fn the_anisotropic_pyramid_reduces_leakage_into_the_background() {
    let plain = build("").expect("builds");
    let (reference, _) = renderer(&plain, true).render(GAZE).expect("renders");
    let cam = camera();
    let input = PassInput {
        scene: &plain,
        camera: &cam,
        gaze_px: GAZE,
    };
    let bg = plain.background_rgb8;
    let (w, h) = (W as usize, H as usize);
    let leak = |anisotropic: bool| -> f64 {
        let mut pass = DepthOfField::new(
            EyeLens {
                aperture_mm: 8.0,
                ..EyeLens::default()
            },
            DofFocus::Gaze,
        );
        pass.anisotropic = anisotropic;
        let mut f = reference.clone();
        pass.run(&mut f, &input);
        let mut sum = 0.0;
        for y in 4..h - 4 {
            for x in 4..w - 4 {
                let i = y * w + x;
                let near_focused = (y - 4..=y + 4)
                    .any(|yy| (x - 4..=x + 4).any(|xx| reference.object[yy * w + xx] == 0));
                if reference.object[i] == raycast::NO_OBJECT && near_focused {
                    sum += (0..3)
                        .map(|k| (f64::from(f.rgb[3 * i + k]) - f64::from(bg[k])).abs())
                        .sum::<f64>();
                }
            }
        }
        sum
    };
    let (aniso, iso) = (leak(true), leak(false));
    eprintln!("leakage around the focused ball: anisotropic {aniso:.0}, isotropic {iso:.0}");
    assert!(aniso < 0.5 * iso, "anisotropic {aniso}, isotropic {iso}");
}
