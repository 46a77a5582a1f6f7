//! Depth of field by splatting on per-pixel layers (Lee 2009 ch. 5) and the
//! hidden-surface layers it casts (`raycast::layers`): chosen from the scene
//! file, pupil 0 the identity, sharp pixels bit-exact, no NaN or panic for
//! degenerate inputs, and the PSNR against thin-lens distributed ray casting
//! (64 rays per pixel) next to the ch. 4 pass's and Lee's. The table prints
//! with `cargo test -p pipeline --test dof_splat -- --nocapture`.
//!
//! The scenes are `tests/dof_reference.rs`'s (copied: test binaries share
//! no module here).

use std::path::Path;

use foveation::thin_lens::EyeLens;
use foveation::Display;
use pipeline::effects::depth_of_field::DepthOfField;
use pipeline::effects::dof_reference::{psnr, render_reference, REFERENCE_SIDE};
use pipeline::effects::dof_splat::{signed_coc_px, DepthOfFieldSplat, MAX_COC_PX};
use pipeline::effects::{Pass, PassInput};
use pipeline::{BackendChoice, Options, Renderer};
use proptest::prelude::*;
use raycast::layers::{pixel_layers, render_layers, LayersError, MAX_LAYERS};
use raycast::ray::TriangleTest;
use raycast::scene::{DofFocus, DofMethod, PostPass};
use raycast::{Camera, Frame, Layer, Scene, SceneFile};

const W: u32 = 160;
const H: u32 = 128;
const PUPIL_MM: f64 = 16.0;
/// Lee 2009 §5.4: ch. 5 with the hidden image, foreground blur.
const LEE_CH5_FOREGROUND_DB: f64 = 36.33;
/// Lee 2009 §5.4: ch. 5 without the hidden image.
const LEE_CH5_NO_HIDDEN_DB: f64 = 32.84;

fn display(w: u32, h: u32) -> Display {
    Display::seed_17in(w, h)
}

fn camera() -> Camera {
    Camera::new(&display(W, H).geometry().expect("geometry"))
}

#[path = "common/dof_wall.rs"]
mod dof_wall;
use dof_wall::{NEAR_BALL, SCREEN_BALL};

fn scene(front: &str, effects: &str) -> Scene {
    dof_wall::wall(front, effects).expect("the wall builds")
}

/// The renderer's frame of `scene` (surface buffers filled), after its
/// effect passes.
fn render(scene: &Scene) -> Frame {
    let g = display(W, H).geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let mut r = Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            backend: BackendChoice::Cpu,
            surface: true,
            ..Options::default()
        },
    )
    .expect("renderer");
    r.render_at([80.0, 64.0], 0.0).expect("renders").0
}

fn lens(pupil_mm: f64) -> EyeLens {
    EyeLens {
        aperture_mm: pupil_mm,
        ..EyeLens::default()
    }
}

/// `pass` run once over a copy of `sharp`.
fn run(pass: &mut dyn Pass, sharp: &Frame, scene: &Scene, cam: &Camera, gaze: [f64; 2]) -> Frame {
    let mut f = sharp.clone();
    pass.run(
        &mut f,
        &PassInput {
            scene,
            camera: cam,
            gaze_px: gaze,
            time_s: None,
            vergence_mm: None,
        },
    );
    f
}

fn splat(focus_mm: f64) -> DepthOfFieldSplat {
    DepthOfFieldSplat::new(lens(PUPIL_MM), DofFocus::Fixed { depth_mm: focus_mm })
}

fn effect(pupil_mm: f64, focus_mm: f64) -> String {
    format!("DepthOfField(pupil_mm: {pupil_mm}, focus: Fixed(depth_mm: {focus_mm}), method: Splat)")
}

#[test]
fn the_scene_file_chooses_the_method_and_pupil_zero_is_the_identity() {
    let s = scene(NEAR_BALL, &effect(0.0, 1950.0));
    match s.passes.as_slice() {
        [PostPass::DepthOfField { method, .. }] => assert_eq!(*method, DofMethod::Splat),
        other => panic!("{other:?}"),
    }
    let d = scene("", "DepthOfField()");
    assert_eq!(d.passes, [PostPass::DEPTH_OF_FIELD]);
    let bad =
        "Scene(name: \"x\", meshes: {}, objects: [], effects: [DepthOfField(method: Gather)])";
    assert!(ron::from_str::<SceneFile>(bad).is_err());

    let g = display(W, H).geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let options = Options {
        backend: BackendChoice::Cpu,
        ..Options::default()
    };
    let r = Renderer::new(&s, Camera::new(&g), model, &options).expect("renderer");
    assert_eq!(r.pass_names(), ["depth of field (Lee ch. 5, splatting)"]);
    // Pupil 0: byte-identical to the frame without the effect.
    let sharp = render(&scene(NEAR_BALL, ""));
    let pinhole = render(&s);
    assert!(sharp.rgb == pinhole.rgb, "pupil 0 changed the frame");
}

#[test]
fn the_layers_are_the_visible_surface_then_those_behind() {
    let s = scene(NEAR_BALL, "");
    let cam = camera();
    let sharp = render(&s);
    let layers = render_layers(&s, &cam, MAX_LAYERS, TriangleTest::Watertight).expect("layers");
    let mut behind_near_ball = 0;
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let hits = layers.at(x, y);
            assert_eq!(hits.is_empty(), !sharp.hit[i], "({x}, {y})");
            if let Some(first) = hits.first() {
                // Hit 0 is the renderer's visible surface.
                assert_eq!(first.hit.object, sharp.object[i]);
                let d = sharp.depth_mm[i];
                assert!(
                    (first.depth_mm - d).abs() <= 1e-4 * d,
                    "{} vs {d}",
                    first.depth_mm
                );
                // Shaded as the renderer shades it (a shared edge may give
                // the other triangle's normal: a byte of rounding).
                let c = raycast::shade::to_rgb8(first.colour);
                for (a, b) in c.iter().zip(&sharp.rgb[3 * i..3 * i + 3]) {
                    assert!(a.abs_diff(*b) <= 1, "({x}, {y})");
                }
            }
            for pair in hits.windows(2) {
                assert!(pair[0].depth_mm < pair[1].depth_mm);
            }
            // Through the near ball (object 30): its back, then the wall.
            if hits.len() >= 3 && hits[0].hit.object == 30 && hits[2].hit.object != 30 {
                behind_near_ball += 1;
            }
        }
    }
    assert!(behind_near_ball > 20, "{behind_near_ball}");
    let one = pixel_layers(&s, &cam, 80, 64, 2, TriangleTest::Watertight).expect("layers");
    assert_eq!(one.as_slice(), &layers.at(80, 64)[..one.len()]);
    for k in [0, MAX_LAYERS + 1] {
        assert_eq!(
            render_layers(&s, &cam, k, TriangleTest::Watertight).err(),
            Some(LayersError::BadLayerCount(k))
        );
    }
    // A huge frame is refused before anything is allocated.
    let huge = Camera::new(&display(8192, 8192).geometry().expect("geometry"));
    assert!(matches!(
        render_layers(&s, &huge, 4, TriangleTest::Watertight),
        Err(LayersError::TooLarge { .. })
    ));
}

#[test]
fn sharp_pixels_far_from_blur_are_bit_exact() {
    let s = scene(NEAR_BALL, "");
    let cam = camera();
    let sharp = render(&s);
    let focus = 1950.0;
    let out = run(&mut splat(focus), &sharp, &s, &cam, [0.0; 2]);
    let pitch = cam.pitch();
    let ppmm = 0.5 * (1.0 / f64::from(pitch[0]) + 1.0 / f64::from(pitch[1]));
    let ds = f64::from(cam.eye.z);
    let l = lens(PUPIL_MM);
    let coc: Vec<f32> = sharp
        .depth_mm
        .iter()
        .map(|&d| signed_coc_px(&l, f64::from(d), focus, ds, ppmm).abs())
        .collect();
    // A sprite reaches at most C/2 + 1/2 px; a hidden surface lies between
    // its visible one and infinity, so its CoC is at most the larger of
    // theirs.
    let far = signed_coc_px(&l, f64::INFINITY, focus, ds, ppmm).abs();
    let max_c = coc.iter().copied().fold(far, f32::max);
    assert!(max_c < MAX_COC_PX);
    let r = (max_c / 2.0 + 1.0).ceil() as i64;
    let (w, h) = (W as i64, H as i64);
    let mut checked = 0;
    let mut changed_elsewhere = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let calm = (-r..=r).all(|dy| {
                (-r..=r).all(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    !(0..w).contains(&nx)
                        || !(0..h).contains(&ny)
                        || coc[(ny * w + nx) as usize] < 0.5
                })
            });
            let same = out.rgb[3 * i..3 * i + 3] == sharp.rgb[3 * i..3 * i + 3];
            if calm {
                checked += 1;
                assert!(same, "({x}, {y}) changed");
            } else if !same {
                changed_elsewhere += 1;
            }
        }
    }
    assert!(checked > 150, "only {checked} calm pixels");
    assert!(changed_elsewhere > 300, "{changed_elsewhere}");
}

/// (splat, splat without H, ch. 4, unblurred) PSNR against the reference,
/// and the number of hidden samples splatted.
fn compare(front: &str, focus_mm: f64) -> ([f64; 4], usize) {
    let s = scene(front, "");
    let cam = camera();
    let sharp = render(&s);
    let mut with_h = splat(focus_mm);
    let splatted = run(&mut with_h, &sharp, &s, &cam, [0.0; 2]);
    let mut no_h = splat(focus_mm);
    no_h.hidden = false;
    let splatted_no_h = run(&mut no_h, &sharp, &s, &cam, [0.0; 2]);
    let mut ch4 = DepthOfField::new(lens(PUPIL_MM), DofFocus::Fixed { depth_mm: focus_mm });
    let mipmapped = run(&mut ch4, &sharp, &s, &cam, [0.0; 2]);
    let reference = render_reference(&s, &cam, &lens(PUPIL_MM), focus_mm, REFERENCE_SIDE, 1);
    (
        [
            psnr(&splatted.rgb, &reference),
            psnr(&splatted_no_h.rgb, &reference),
            psnr(&mipmapped.rgb, &reference),
            psnr(&sharp.rgb, &reference),
        ],
        with_h.hidden_samples(),
    )
}

/// The splat pass is closer to the ground truth than the unblurred frame
/// on both scenes; the table compares it with the ch. 4 pass and Lee.
#[test]
fn the_splat_pass_against_the_reference() {
    let (fg, fg_hidden) = compare(NEAR_BALL, 1950.0);
    let (bg, bg_hidden) = compare(SCREEN_BALL, 480.0);
    eprintln!(
        "DOF vs thin-lens reference ({W}×{H}, pupil {PUPIL_MM} mm, N = 64), PSNR dB:\n\
         | scene | ch. 5 splat | ch. 5 without H | ch. 4 mipmap | unblurred | Lee ch. 5 |\n\
         |---|---|---|---|---|---|\n\
         | foreground blur | {:.2} | {:.2} | {:.2} | {:.2} | {LEE_CH5_FOREGROUND_DB} (without H {LEE_CH5_NO_HIDDEN_DB}) |\n\
         | background blur | {:.2} | {:.2} | {:.2} | {:.2} | — |\n\
         hidden samples splatted: foreground {fg_hidden}, background {bg_hidden}",
        fg[0], fg[1], fg[2], fg[3], bg[0], bg[1], bg[2], bg[3]
    );
    assert!(fg[0] > fg[3], "foreground: {fg:?}");
    assert!(bg[0] > bg[3], "background: {bg:?}");
    assert!(fg_hidden > 0);
}

/// The renderer runs the scene's `method: Splat` pass: the same frame as
/// the pass run by hand.
#[test]
fn the_renderer_runs_the_splat_pass() {
    let with = render(&scene(NEAR_BALL, &effect(PUPIL_MM, 1950.0)));
    let s = scene(NEAR_BALL, "");
    let by_hand = run(&mut splat(1950.0), &render(&s), &s, &camera(), [80.0, 64.0]);
    assert!(with.rgb == by_hand.rgb);
    assert!(with.rgb != render(&s).rgb);
}

/// A tiny scene that no ray hits (its one ball is behind the eye), whose
/// background is `grey`.
fn empty_scene(grey: f32) -> Scene {
    let text = format!(
        r#"Scene(
    name: "empty",
    background: ({grey}, {grey}, {grey}),
    meshes: {{ "ball": Bumpy(triangles: 80, amplitude: 0.1, seed: 1) }},
    objects: [(mesh: "ball", translate_mm: (0.0, 0.0, 5000.0), scale_mm: 10.0)],
)"#
    );
    let file: SceneFile = ron::from_str(&text).expect("parses");
    Scene::build(&file, Path::new(".")).expect("builds")
}

/// Eq. 5.5: a blurred bright patch spreads more light with highlights,
/// and a sharp frame is untouched by them.
#[test]
fn defocused_highlights_brighten_a_blurred_bright_patch() {
    let s = empty_scene(0.05);
    let (w, h) = (40u32, 32u32);
    let cam = Camera::new(&display(w, h).geometry().expect("geometry"));
    let dark = raycast::shade::to_rgb8(glam::Vec3::splat(0.05));
    let mut frame = Frame::blank(w, h, dark, Layer::Full, true);
    for y in 14..18 {
        for x in 18..22 {
            let i = (y * w + x) as usize;
            frame.rgb[3 * i..3 * i + 3].copy_from_slice(&[255; 3]);
        }
    }
    frame.depth_mm.fill(300.0);
    let focus = DofFocus::Fixed {
        depth_mm: f64::INFINITY,
    };
    // Linear light above the dark background (a 60-mm pupil: a CoC of
    // about 9 px at 300 mm).
    let lut = pipeline::colour::decode_lut();
    let energy = |f: &Frame| -> f64 {
        f.rgb
            .iter()
            .map(|&b| f64::from(lut[b as usize] - lut[dark[0] as usize]))
            .sum()
    };
    let mut plain = DepthOfFieldSplat::new(lens(60.0), focus);
    let mut bright = DepthOfFieldSplat::new(lens(60.0), focus);
    bright.highlights = Some(Default::default());
    let a = run(&mut plain, &frame, &s, &cam, [0.0; 2]);
    let b = run(&mut bright, &frame, &s, &cam, [0.0; 2]);
    assert!(a.rgb != frame.rgb);
    assert!(
        energy(&b) > energy(&a) * 1.5,
        "{} vs {}",
        energy(&b),
        energy(&a)
    );
    // Focused on the patch: nothing is blurred, nothing brightened.
    let at = DofFocus::Fixed { depth_mm: 300.0 };
    let mut sharp = DepthOfFieldSplat::new(lens(60.0), at);
    sharp.highlights = Some(Default::default());
    assert!(run(&mut sharp, &frame, &s, &cam, [0.0; 2]).rgb == frame.rgb);
}

fn depth_strategy() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(-5.0),
        Just(16.7),
        Just(f32::INFINITY),
        Just(f32::NAN),
        Just(1e30),
        1.0f32..1e5,
    ]
}

fn focus_strategy() -> impl Strategy<Value = DofFocus> {
    prop_oneof![
        Just(DofFocus::Gaze),
        Just(DofFocus::Fixed { depth_mm: 0.0 }),
        Just(DofFocus::Fixed { depth_mm: 16.7 }),
        Just(DofFocus::Fixed {
            depth_mm: f64::INFINITY
        }),
        Just(DofFocus::Fixed { depth_mm: f64::NAN }),
        (17.0f64..1e5).prop_map(|depth_mm| DofFocus::Fixed { depth_mm }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(48), ..ProptestConfig::default() })]

    /// Degenerate depths, foci, apertures and gazes: no panic, and a frame
    /// of one colour keeps it (within a byte), whatever the blur — which
    /// a NaN anywhere would break (it encodes as black).
    #[test]
    fn degenerate_inputs_neither_panic_nor_make_nan(
        (w, h, depths) in (1u32..20, 1u32..16).prop_flat_map(|(w, h)| {
            (Just(w), Just(h), proptest::collection::vec(depth_strategy(), (w * h) as usize))
        }),
        hits in proptest::collection::vec(any::<bool>(), 320),
        focus in focus_strategy(),
        pupil in prop_oneof![Just(0.0f64), Just(1e6), Just(f64::NAN), 0.1f64..100.0],
        gaze in prop_oneof![
            Just([f64::NAN, 3.0]),
            Just([1e300, -1e300]),
            Just([f64::INFINITY, 0.0]),
            (-5.0f64..25.0, -5.0f64..20.0).prop_map(|(x, y)| [x, y]),
        ],
        hidden in any::<bool>(),
        highlights in any::<bool>(),
    ) {
        let grey = 0.35f32;
        let s = empty_scene(grey);
        let byte = raycast::shade::to_rgb8(glam::Vec3::splat(grey));
        let cam = Camera::new(&display(w, h).geometry().expect("geometry"));
        let mut frame = Frame::blank(w, h, byte, Layer::Full, true);
        for (i, &d) in depths.iter().enumerate() {
            frame.depth_mm[i] = d;
            frame.hit[i] = hits[i % hits.len()] && d.is_finite();
            frame.object[i] = if frame.hit[i] { 0 } else { raycast::NO_OBJECT };
        }
        let mut pass = DepthOfFieldSplat::new(lens(pupil), focus);
        pass.hidden = hidden;
        pass.highlights = highlights.then(Default::default);
        for _ in 0..2 {
            let out = run(&mut pass, &frame, &s, &cam, gaze);
            prop_assert_eq!(out.rgb.len(), frame.rgb.len());
            for (i, (a, b)) in out.rgb.iter().zip(&frame.rgb).enumerate() {
                // Highlights may brighten a bright grey; this one is dark.
                prop_assert!(a.abs_diff(*b) <= 1, "sample {} {} vs {}", i, a, b);
            }
            if let Some(f) = pass.focal_depth_mm() {
                prop_assert!(!f.is_nan());
            }
        }
    }
}
