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
use raycast::scene::{DofFocus, DofMethod, DofRefocus, PostPass};
use raycast::{Camera, Frame, Layer, Scene, SceneFile};

const W: u32 = 640;
const H: u32 = 512;

/// The seed's 17" display at a reduced pixel count.
fn camera() -> Camera {
    let d = Display::seed_17in(W, H);
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
    let d = Display::seed_17in(W, H);
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
    assert_eq!(s.passes, [PostPass::DEPTH_OF_FIELD]);
    let s =
        build("DepthOfField(pupil_mm: 6.0, focal_length_mm: 17.0, focus: Fixed(depth_mm: 800.0))")
            .expect("builds");
    assert_eq!(
        s.passes,
        [PostPass::DepthOfField {
            pupil_mm: 6.0,
            focal_length_mm: 17.0,
            retina_distance_mm: 24.0,
            focus: DofFocus::Fixed { depth_mm: 800.0 },
            refocus: DofRefocus::Instant,
            method: DofMethod::Mipmap,
            smooth_foreground: false,
            highlights: false,
        }]
    );
    assert!(build("DepthOfField(focus: Fixed(depth_mm: inf))").is_ok());
    assert!(build("DepthOfField(pupil_mm: 0.0)").is_ok());
    for (text, field) in [
        (
            "DepthOfField(method: Splat, smooth_foreground: true)",
            "effects[0].smooth_foreground",
        ),
        ("DepthOfField(highlights: true)", "effects[0].highlights"),
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
    assert_eq!(
        r.pass_names(),
        ["depth of field (Lee ch. 4, focus at the gaze's depth)"]
    );
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
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

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
        let input = PassInput { scene: &scene, camera: &cam, gaze_px: gaze, time_s: None, vergence_mm: None };
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
        time_s: None,
        vergence_mm: None,
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

// ---- Refocusing dynamics (Lee §6.1) ----

/// Near and far halves of the refocusing frames, mm.
const NEAR_MM: f32 = 300.0;
const FAR_MM: f32 = 2000.0;
/// Gaze on the near half, the far half, the background strip, and nowhere.
const ON_NEAR: [f64; 2] = [5.5, 8.5];
const ON_FAR: [f64; 2] = [26.5, 8.5];
const ON_BACKGROUND: [f64; 2] = [44.5, 8.5];
const NOWHERE: [f64; 2] = [f64::NAN, f64::NAN];

/// 48×16: columns 0–15 near, 16–31 far, 32–47 background.
fn two_depth_frame() -> Frame {
    let depths: Vec<f32> = (0..48 * 16)
        .map(|i| match i % 48 {
            0..=15 => NEAR_MM,
            16..=31 => FAR_MM,
            _ => f32::INFINITY,
        })
        .collect();
    frame_with(&depths, 48)
}

fn diopters(mm: f64) -> f64 {
    1000.0 / mm
}

/// A pass with `refocus`, and a closure running one frame at (`gaze`,
/// `time`) that gives the focal depth it used.
fn scripted(refocus: DofRefocus) -> impl FnMut([f64; 2], Option<f64>) -> f64 {
    let scene = build("").expect("builds");
    let cam = camera();
    let mut pass = DepthOfField::new(EyeLens::default(), DofFocus::Gaze).with_refocus(refocus);
    assert_eq!(pass.refocus(), refocus);
    let base = two_depth_frame();
    move |gaze, time_s| {
        let mut f = base.clone();
        let input = PassInput {
            scene: &scene,
            camera: &cam,
            gaze_px: gaze,
            time_s,
            vergence_mm: None,
        };
        pass.run(&mut f, &input);
        pass.focal_depth_mm().expect("a focus after a frame")
    }
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn refocus_parses_defaults_and_validates_naming_the_field() {
    let refocus = |text: &str| -> Option<DofRefocus> {
        match build(text).ok()?.passes.first()? {
            PostPass::DepthOfField { refocus, .. } => Some(*refocus),
            _ => None,
        }
    };
    assert_eq!(refocus("DepthOfField()"), Some(DofRefocus::Instant));
    assert_eq!(
        refocus("DepthOfField(refocus: Instant)"),
        Some(DofRefocus::Instant)
    );
    assert_eq!(
        refocus("DepthOfField(refocus: Interpolate())"),
        Some(DofRefocus::Interpolate { ms: 300.0 })
    );
    assert_eq!(
        refocus("DepthOfField(refocus: Interpolate(ms: 250.0))"),
        Some(DofRefocus::Interpolate { ms: 250.0 })
    );
    assert_eq!(
        refocus("DepthOfField(refocus: LowPass(hz: 2.0))"),
        Some(DofRefocus::LowPass { hz: 2.0 })
    );
    assert_eq!(
        refocus("DepthOfField(refocus: LowPass())"),
        Some(DofRefocus::LowPass { hz: 1.0 })
    );
    for (text, field) in [
        ("Interpolate(ms: 0.0)", "effects[0].refocus.ms"),
        ("Interpolate(ms: -300.0)", "effects[0].refocus.ms"),
        ("Interpolate(ms: NaN)", "effects[0].refocus.ms"),
        ("Interpolate(ms: inf)", "effects[0].refocus.ms"),
        ("LowPass(hz: 0.0)", "effects[0].refocus.hz"),
        ("LowPass(hz: NaN)", "effects[0].refocus.hz"),
        ("LowPass(hz: inf)", "effects[0].refocus.hz"),
        ("LowPass(hz: 1000.0)", "effects[0].refocus.hz"),
    ] {
        let text = format!("DepthOfField(refocus: {text})");
        match build(&text) {
            Err(raycast::SceneError::Field { field: f, .. }) => assert_eq!(f, field, "{text}"),
            other => panic!("{text}: {other:?}"),
        }
    }
    assert!(
        ron::from_str::<SceneFile>(&scene_text("DepthOfField(refocus: Interpolate(hz: 2.0))"))
            .is_err()
    );
}

#[test]
fn instant_refocus_switches_at_once() {
    let mut frame = scripted(DofRefocus::Instant);
    assert_eq!(frame(ON_NEAR, Some(0.0)), f64::from(NEAR_MM));
    assert_eq!(frame(ON_FAR, Some(0.01)), f64::from(FAR_MM));
    assert_eq!(frame(ON_NEAR, Some(0.02)), f64::from(NEAR_MM));
    // No clock: at once too.
    assert_eq!(frame(ON_FAR, None), f64::from(FAR_MM));
}

#[test]
fn interpolated_refocus_is_halfway_in_diopters_at_150_ms_and_done_at_300() {
    let mut frame = scripted(DofRefocus::Interpolate { ms: 300.0 });
    let (near, far) = (diopters(f64::from(NEAR_MM)), diopters(f64::from(FAR_MM)));
    let dt = 0.01;
    for k in 0..10 {
        assert_eq!(frame(ON_NEAR, Some(k as f64 * dt)), f64::from(NEAR_MM));
    }
    // The jump is seen at t = 0.1 s: the transition begins there.
    let t0 = 0.1;
    let mut seen = Vec::new();
    for k in 0..=40 {
        let t = t0 + k as f64 * dt;
        let d = diopters(frame(ON_FAR, Some(t)));
        seen.push((k, d));
        let expect = if k >= 30 {
            far
        } else {
            near + (far - near) * (k as f64 / 30.0)
        };
        assert!(
            close(d, expect, 1e-9),
            "{k}0 ms: {d} D, expected {expect} D"
        );
    }
    let half = seen[15].1;
    assert!(
        close(half, 0.5 * (near + far), 1e-9),
        "150 ms: {half} D, halfway {}",
        0.5 * (near + far)
    );
    // Monotone, and never past the target.
    assert!(seen.windows(2).all(|w| w[1].1 <= w[0].1 && w[1].1 >= far));
    // Back to near: a new 300-ms transition.
    let t1 = t0 + 0.5;
    assert!(close(diopters(frame(ON_NEAR, Some(t1))), far, 1e-12));
    let d = diopters(frame(ON_NEAR, Some(t1 + 0.15)));
    assert!(close(d, 0.5 * (near + far), 1e-9), "{d}");
    assert!(close(diopters(frame(ON_NEAR, Some(t1 + 0.3))), near, 1e-9));
}

#[test]
fn interpolated_refocus_restarts_from_the_shown_focus_on_a_jump_mid_transition() {
    let mut frame = scripted(DofRefocus::Interpolate { ms: 300.0 });
    let (near, far) = (diopters(f64::from(NEAR_MM)), diopters(f64::from(FAR_MM)));
    frame(ON_NEAR, Some(0.0));
    frame(ON_FAR, Some(0.1));
    let mid = diopters(frame(ON_FAR, Some(0.2))); // a third of the way
    assert!(close(mid, near + (far - near) / 3.0, 1e-9), "{mid}");
    // Back to near at 0.25 s: starts from what was shown, continuous.
    let at_jump = diopters(frame(ON_NEAR, Some(0.25)));
    let expect = near + (far - near) * (0.15 / 0.3);
    assert!(close(at_jump, expect, 1e-9), "{at_jump} vs {expect}");
    let d = diopters(frame(ON_NEAR, Some(0.40)));
    assert!(close(d, 0.5 * (expect + near), 1e-9), "{d}");
    assert!(close(diopters(frame(ON_NEAR, Some(0.55))), near, 1e-9));
}

#[test]
fn low_pass_refocus_decays_as_exp_minus_two_pi_f_t() {
    for hz in [0.5, 1.0, 2.0] {
        for dt in [1.0 / 60.0, 1.0 / 144.0, 0.037] {
            let mut frame = scripted(DofRefocus::LowPass { hz });
            let (near, far) = (diopters(f64::from(NEAR_MM)), diopters(f64::from(FAR_MM)));
            assert_eq!(frame(ON_NEAR, Some(0.0)), f64::from(NEAR_MM));
            let t0 = 0.5;
            let mut k = 0;
            loop {
                let t = t0 + k as f64 * dt;
                if t > t0 + 2.0 {
                    break;
                }
                let d = diopters(frame(ON_FAR, Some(t)));
                let left = (d - far) / (near - far);
                let expect = (-2.0 * std::f64::consts::PI * hz * (t - t0)).exp();
                assert!(
                    (left - expect).abs() <= 0.01 * expect,
                    "{hz} Hz, dt {dt}, t − t0 = {}: left {left}, exp {expect}",
                    t - t0
                );
                k += 1;
            }
        }
    }
}

#[test]
fn refocus_holds_through_background_infinity_and_invalid_gaze_without_nan() {
    for refocus in [
        DofRefocus::Instant,
        DofRefocus::Interpolate { ms: 300.0 },
        DofRefocus::LowPass { hz: 2.0 },
    ] {
        let mut frame = scripted(refocus);
        // Gaze on the background first: relaxed eye, infinity (0 D).
        assert_eq!(
            frame(ON_BACKGROUND, Some(0.0)),
            f64::INFINITY,
            "{refocus:?}"
        );
        assert_eq!(frame(NOWHERE, Some(0.1)), f64::INFINITY, "{refocus:?}");
        // To near from infinity: finite throughout, reaching near.
        let mut last = f64::INFINITY;
        for k in 0..=200 {
            let d = frame(ON_NEAR, Some(0.2 + k as f64 * 0.01));
            assert!(d >= f64::from(NEAR_MM) && d <= last, "{refocus:?} {k}: {d}");
            last = d;
        }
        assert!(close(last, f64::from(NEAR_MM), 1e-6), "{refocus:?} {last}");
        // Background, off-screen and NaN gaze hold the near focus.
        for (k, g) in [
            ON_BACKGROUND,
            NOWHERE,
            [-1e300, 1e300],
            [f64::INFINITY, 3.0],
        ]
        .into_iter()
        .enumerate()
        {
            let d = frame(g, Some(3.0 + k as f64));
            assert!(close(d, f64::from(NEAR_MM), 1e-6), "{refocus:?} {g:?}: {d}");
        }
    }
    // A fixed focus at infinity is 0 D throughout.
    let scene = build("").expect("builds");
    let cam = camera();
    let mut pass = DepthOfField::new(
        EyeLens::default(),
        DofFocus::Fixed {
            depth_mm: f64::INFINITY,
        },
    )
    .with_refocus(DofRefocus::LowPass { hz: 1.0 });
    for t in [0.0, 0.5, f64::NAN, 1.0] {
        let mut f = two_depth_frame();
        let input = PassInput {
            scene: &scene,
            camera: &cam,
            gaze_px: ON_NEAR,
            time_s: Some(t),
            vergence_mm: None,
        };
        pass.run(&mut f, &input);
        assert_eq!(pass.focal_depth_mm(), Some(f64::INFINITY));
    }
}

/// Through the renderer: `render_at` times the pass, and the transition's
/// end points are Instant's frames.
#[test]
fn render_at_times_the_refocus_of_a_rendered_scene() {
    // The far ball's centre on the screen (px).
    const FAR_GAZE: [f64; 2] = [395.7, 306.4];
    let instant = build("DepthOfField(pupil_mm: 8.0)").expect("builds");
    let lerp =
        build("DepthOfField(pupil_mm: 8.0, refocus: Interpolate(ms: 300.0))").expect("builds");
    let mut ri = renderer(&instant, false);
    let mut rl = renderer(&lerp, false);
    let (near_i, _) = ri.render_at(GAZE, 0.0).expect("renders");
    let (far_i, _) = ri.render_at(FAR_GAZE, 0.1).expect("renders");
    assert_ne!(near_i.rgb, far_i.rgb, "the far ball is in focus");
    let (first, _) = rl.render_at(GAZE, 0.0).expect("renders");
    assert_eq!(first.rgb, near_i.rgb);
    let (jump, _) = rl.render_at(FAR_GAZE, 1.0).expect("renders");
    assert_eq!(
        jump.rgb, near_i.rgb,
        "the transition starts at the old focus"
    );
    let (mid, _) = rl.render_at(FAR_GAZE, 1.15).expect("renders");
    assert!(mid.rgb != near_i.rgb && mid.rgb != far_i.rgb);
    let (end, _) = rl.render_at(FAR_GAZE, 1.3).expect("renders");
    assert_eq!(end.rgb, far_i.rgb, "done after 300 ms");
    // A refused time holds the frame's focus.
    let (held, _) = rl.render_at(GAZE, f64::NAN).expect("renders");
    assert_eq!(held.rgb, far_i.rgb);
    // `render` (wall clock) still renders a scene without dynamics as before.
    let (wall, _) = ri.render(GAZE).expect("renders");
    assert_eq!(wall.rgb, near_i.rgb);
}

/// One scripted frame: where the gaze is and the time step to it.
fn gaze_step() -> impl Strategy<Value = [f64; 2]> {
    prop_oneof![
        Just(ON_NEAR),
        Just(ON_FAR),
        Just(ON_BACKGROUND),
        Just(NOWHERE),
        ((-10.0f64..60.0), (-10.0f64..30.0)).prop_map(|(x, y)| [x, y]),
    ]
}

fn time_step() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(1e-9),
        Just(1e12),
        Just(f64::MAX),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(-0.5),
        0.0f64..0.1,
        0.1f64..5.0,
    ]
}

fn refocus_mode() -> impl Strategy<Value = DofRefocus> {
    prop_oneof![
        Just(DofRefocus::Instant),
        (1.0f64..2000.0).prop_map(|ms| DofRefocus::Interpolate { ms }),
        (0.01f64..100.0).prop_map(|hz| DofRefocus::LowPass { hz }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(128)))]

    /// Random jump sequences and time steps (0, huge, NaN, negative, …):
    /// the focus is never NaN, stays between the targets seen (in
    /// diopters, infinity = 0 D), and a refused (non-finite) time holds it.
    #[test]
    fn refocus_is_never_nan_and_stays_between_its_targets(
        mode in refocus_mode(),
        script in prop::collection::vec((gaze_step(), time_step()), 1..40),
        start in prop_oneof![Just(0.0f64), -1e6f64..1e6],
    ) {
        let mut frame = scripted(mode);
        let mut t = start;
        let mut prev: Option<f64> = None;
        let (lo, hi) = (0.0, diopters(f64::from(NEAR_MM)));
        for (gaze, step) in script {
            let time = t + step;
            let d = frame(gaze, Some(time));
            prop_assert!(!d.is_nan() && d > 0.0, "{mode:?}: {d}");
            let dd = diopters(d);
            prop_assert!(dd >= lo && dd <= hi * (1.0 + 1e-12), "{mode:?}: {dd} D");
            if !time.is_finite() {
                if let Some(p) = prev {
                    prop_assert_eq!(d, p, "a refused time holds the focus");
                }
            } else {
                t = time;
            }
            prev = Some(d);
        }
    }
}

/// `focus: Vergence` and `focus: Attention` parse.
#[test]
fn vergence_and_attention_focus_parse() {
    for (text, focus) in [
        ("DepthOfField(focus: Vergence)", DofFocus::Vergence),
        ("DepthOfField(focus: Attention)", DofFocus::Attention),
    ] {
        let s = build(text).expect("builds");
        assert!(
            matches!(s.passes[0], PostPass::DepthOfField { focus: f, .. } if f == focus),
            "{text}: {:?}",
            s.passes
        );
    }
}

fn input_with<'a>(scene: &'a Scene, cam: &'a Camera, vergence_mm: Option<f64>) -> PassInput<'a> {
    PassInput {
        scene,
        camera: cam,
        gaze_px: GAZE,
        time_s: None,
        vergence_mm,
    }
}

/// The vergence depth is the focus where the frame has one; without one
/// (or a NaN, zero or negative one) the gaze's depth is.
#[test]
fn vergence_focus_follows_the_binocular_depth_and_falls_back_to_the_gaze() {
    let plain = build("").expect("builds");
    let (frame, _) = renderer(&plain, true).render(GAZE).expect("renders");
    let cam = camera();
    let at_gaze = pipeline::effects::depth_of_field::gaze_depth_mm(&frame, GAZE).expect("depth");
    let mut pass = DepthOfField::new(EyeLens::default(), DofFocus::Vergence);
    assert!(!pass.has_attention_model());
    for (vergence, want) in [
        (Some(2100.0), 2100.0),
        (None, at_gaze),
        (Some(f64::NAN), at_gaze),
        (Some(-5.0), at_gaze),
        (Some(900.0), 900.0),
        (Some(0.0), at_gaze),
    ] {
        let mut f = frame.clone();
        pass.run(&mut f, &input_with(&plain, &cam, vergence));
        let got = pass.focal_depth_mm().expect("a focus");
        assert!((got - want).abs() < 1e-9, "{vergence:?}: {got} ≠ {want}");
    }
}

/// Through the renderer: a vergence depth on the near ball (270 mm from the
/// eye) blurs the ball at the screen that the gaze rests on; it holds for
/// one frame only.
#[test]
fn the_renderer_passes_the_vergence_depth_for_one_frame() {
    let s = build("DepthOfField(pupil_mm: 6.0, focus: Vergence)").expect("builds");
    let mut r = renderer(&s, false);
    let (gaze_focus, _) = r.render_at(GAZE, 0.0).expect("renders");
    r.set_vergence_mm(Some(270.0));
    let (far_focus, _) = r.render_at(GAZE, 0.1).expect("renders");
    let (again, _) = r.render_at(GAZE, 0.2).expect("renders");
    let ids = &far_focus.object;
    let sharp = edge_energy(&gaze_focus, ids, 0);
    let blurred = edge_energy(&far_focus, ids, 0);
    assert!(blurred < 0.5 * sharp, "{blurred} vs {sharp}");
    assert_eq!(
        again.rgb, gaze_focus.rgb,
        "the vergence depth held a second frame"
    );
}

/// `focus: Attention` runs Lee's model on the frame: an object is attended
/// and the focus is its mean eye distance; a frame of background only
/// keeps the last focus; no other focus builds the model.
#[test]
fn attention_focus_focuses_at_the_attended_objects_depth() {
    let plain = build("").expect("builds");
    let (frame, _) = renderer(&plain, true).render(GAZE).expect("renders");
    let cam = camera();
    let mut pass = DepthOfField::new(EyeLens::default(), DofFocus::Attention);
    assert!(pass.has_attention_model());
    assert!(!DepthOfField::new(EyeLens::default(), DofFocus::Gaze).has_attention_model());
    let mut f = frame.clone();
    pass.run(&mut f, &input_with(&plain, &cam, None));
    let id = pass.attended_object().expect("an object is attended");
    let depths: Vec<f64> = frame
        .object
        .iter()
        .zip(&frame.depth_mm)
        .filter(|(o, d)| **o == id && d.is_finite())
        .map(|(_, d)| f64::from(*d))
        .collect();
    assert!(!depths.is_empty());
    let mean = depths.iter().sum::<f64>() / depths.len() as f64;
    let got = pass.focal_depth_mm().expect("a focus");
    assert!(
        (got - mean).abs() < 1e-3 * mean,
        "focus {got} vs mean depth {mean}"
    );
    // Background only: nothing attended, the focus holds.
    let mut empty = frame.clone();
    empty.object.fill(raycast::NO_OBJECT);
    empty.depth_mm.fill(f32::INFINITY);
    empty.hit.fill(false);
    let bg = plain.background_rgb8;
    for px in empty.rgb.chunks_exact_mut(3) {
        px.copy_from_slice(&bg);
    }
    pass.run(&mut empty, &input_with(&plain, &cam, None));
    assert_eq!(pass.attended_object(), None);
    assert_eq!(pass.focal_depth_mm(), Some(got));
}
