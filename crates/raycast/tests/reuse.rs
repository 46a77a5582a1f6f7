//! Temporal reuse ([`Scratch::with_reuse`]) against fresh frames: along
//! gaze sequences with fixation jitter, saccades, repeated gazes and
//! changes of scene, camera, size and settings, a frame rendered with the
//! cache equals, byte for byte, the frame a fresh scratch renders for the
//! same gaze; and the cache is seen to be used, so the equality says
//! something.

mod common;

use std::path::Path;
use std::sync::OnceLock;

use common::{display, repo};
use foveation::{Display, GeislerPerry, Layout, SamplingModel};
use proptest::prelude::*;
use raycast::ray::TriangleTest;
use raycast::render::{render_with, Mode, ReuseStats, Scratch, Settings, Stats, Triggers};
use raycast::scene::{Effect, Light, MeshSource, Object};
use raycast::{Camera, Frame, Scene, SceneFile};

/// Scene, camera, model and settings of one frame.
#[derive(Clone)]
struct View<'a> {
    scene: &'a Scene,
    cam: Camera,
    model: SamplingModel,
    settings: Settings,
    surface: bool,
}

impl<'a> View<'a> {
    fn new(scene: &'a Scene, d: &Display) -> Self {
        let g = d.geometry().expect("geometry");
        Self {
            scene,
            cam: Camera::new(&g),
            model: SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model"),
            settings: Settings {
                mode: Mode::Hybrid,
                layout: Layout::Nyquist,
                triggers: Triggers::from_scene(scene),
                test: TriangleTest::Watertight,
                check_coverage: false,
            },
            surface: true,
        }
    }
}

/// Renders with `scratch` into `frame`.
fn draw(
    v: &View<'_>,
    gaze: [f64; 2],
    frame: &mut Frame,
    scratch: &mut Scratch,
) -> Result<Stats, foveation::ParamError> {
    render_with(
        v.scene,
        &v.cam,
        &v.model,
        &v.settings,
        gaze,
        v.surface,
        frame,
        scratch,
    )
}

/// The frame a fresh scratch renders (what no reuse gives).
fn fresh(v: &View<'_>, gaze: [f64; 2]) -> (Frame, Stats) {
    let mut frame = Frame::default();
    let stats = draw(v, gaze, &mut frame, &mut Scratch::default()).expect("fresh frame");
    (frame, stats)
}

/// Byte-identical frames: every buffer, floats by their bits.
fn assert_same(got: &Frame, want: &Frame, what: &str) {
    assert_eq!(
        (got.width_px, got.height_px),
        (want.width_px, want.height_px),
        "{what}: size"
    );
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let nbits = |v: &[[f32; 3]]| v.iter().map(|n| n.map(f32::to_bits)).collect::<Vec<_>>();
    let first = |a: &[u8], b: &[u8]| a.iter().zip(b).position(|(x, y)| x != y);
    assert!(
        got.rgb == want.rgb,
        "{what}: colour differs first at byte {:?}",
        first(&got.rgb, &want.rgb)
    );
    assert!(got.hit == want.hit, "{what}: hit flags differ");
    assert!(got.layer == want.layer, "{what}: layers differ");
    assert!(got.object == want.object, "{what}: object ids differ");
    assert!(
        bits(&got.depth_mm) == bits(&want.depth_mm),
        "{what}: depth differs"
    );
    assert!(
        nbits(&got.normal) == nbits(&want.normal),
        "{what}: normals differ"
    );
}

/// Equal counts (the time aside): with reuse the counts still say how many
/// samples of each kind the frame has.
fn assert_same_counts(got: Stats, want: Stats, what: &str) {
    let untimed = |s: Stats| Stats { time_ms: 0.0, ..s };
    assert_eq!(untimed(got), untimed(want), "{what}: stats");
}

/// Renders `gaze` with the kept scratch and frame, checks it against a fresh
/// frame, and returns what reuse did.
fn step(
    v: &View<'_>,
    gaze: [f64; 2],
    frame: &mut Frame,
    scratch: &mut Scratch,
    what: &str,
) -> ReuseStats {
    let stats = draw(v, gaze, frame, scratch).expect("frame with reuse");
    let (want, want_stats) = fresh(v, gaze);
    assert_same(frame, &want, what);
    assert_same_counts(stats, want_stats, what);
    scratch.reuse_stats()
}

/// The search task with its centre object moved 6 mm right and 4 mm up.
fn moved_search_task() -> Scene {
    let path = repo().join("config/scenes/search-task.ron");
    let text = std::fs::read_to_string(&path).expect("search-task.ron");
    let mut file: SceneFile = ron::from_str(&text).expect("search-task");
    let centre = file
        .objects
        .iter_mut()
        .find(|o| o.translate_mm.0 == 0.0 && o.translate_mm.1 == 0.0)
        .expect("an object at the centre");
    centre.translate_mm.0 += 6.0;
    centre.translate_mm.1 += 4.0;
    Scene::build(&file, path.parent().expect("dir")).expect("moved scene")
}

fn search_task() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| common::load("search-task"))
}

#[test]
fn frames_with_reuse_equal_fresh_frames_through_fixations_saccades_and_changes() {
    let scene = search_task();
    let d = display(640, 512);
    let mut v = View::new(scene, &d);
    let mut scratch = Scratch::with_reuse();
    let mut frame = Frame::default();
    // Off the centre, so that the fovea (radius ≈ 140 px here) leaves most
    // of the screen to the cells.
    let c = [250.0, 300.0];
    let at = |dx: f64, dy: f64| [c[0] + dx, c[1] + dy];

    // First frame: the cache starts empty.
    let r = step(&v, c, &mut frame, &mut scratch, "first");
    assert!(r.invalidated && !r.mask_reused && r.pixels_reused == 0 && r.pixels_cast > 0);
    // Fixation jitter: sub-pixel and few-pixel moves reuse pixel centres.
    let jitter = [
        (0.3, -0.2),
        (-0.45, 0.1),
        (2.0, 1.0),
        (-3.0, 2.5),
        (0.01, 0.0),
        (1e-7, 0.0),
    ];
    let mut reused = 0;
    for (k, &(dx, dy)) in jitter.iter().enumerate() {
        let r = step(
            &v,
            at(dx, dy),
            &mut frame,
            &mut scratch,
            &format!("jitter {k}"),
        );
        assert!(!r.invalidated && !r.mask_reused, "jitter {k}: {r:?}");
        reused += r.pixels_reused;
    }
    assert!(reused > 0, "jitter took nothing from the cache");
    // The same gaze again, bit for bit: the whole mask is kept.
    let r = step(&v, at(1e-7, 0.0), &mut frame, &mut scratch, "repeat");
    assert!(r.mask_reused && r.pixels_cast == 0, "repeat: {r:?}");
    // Without surface buffers, then with them again (same gaze: kept).
    v.surface = false;
    let r = step(&v, at(1e-7, 0.0), &mut frame, &mut scratch, "no surface");
    assert!(r.mask_reused, "no surface: {r:?}");
    v.surface = true;
    step(&v, at(1e-7, 0.0), &mut frame, &mut scratch, "surface again");
    // Saccades: across the screen, off it, and back to the fixation.
    for (k, g) in [
        [40.0, 460.0],
        [600.0, 30.0],
        [-800.0, 200.0],
        [320.5, 1800.0],
        [251.0, 300.5],
    ]
    .into_iter()
    .enumerate()
    {
        step(&v, g, &mut frame, &mut scratch, &format!("saccade {k}"));
    }
    let r = step(&v, c, &mut frame, &mut scratch, "back");
    assert!(r.pixels_reused > 0 && !r.mask_reused, "back: {r:?}");
    // A full-resolution frame between two equal gazes keeps the cache.
    v.settings.mode = Mode::Full;
    let r = step(&v, c, &mut frame, &mut scratch, "full");
    assert_eq!(r, ReuseStats::default(), "a full frame uses no cache");
    v.settings.mode = Mode::Hybrid;
    let r = step(&v, c, &mut frame, &mut scratch, "after full");
    assert!(r.mask_reused, "after full: {r:?}");

    // A new scene revision (the centre object moved, under the fovea).
    let moved = moved_search_task();
    let mut w = v.clone();
    w.scene = &moved;
    let r = step(&w, c, &mut frame, &mut scratch, "moved scene");
    assert!(
        r.invalidated && !r.mask_reused && r.pixels_reused == 0,
        "moved: {r:?}"
    );
    step(
        &w,
        at(0.2, 0.2),
        &mut frame,
        &mut scratch,
        "moved scene, jitter",
    );
    // Back to the first scene: its samples were dropped, nothing is stale.
    let r = step(&v, c, &mut frame, &mut scratch, "first scene again");
    assert!(r.invalidated && r.pixels_reused == 0, "first again: {r:?}");
    // The same geometry traversed through the grid (a clone keeps the revision).
    let mut gridded = scene.clone();
    gridded.build_grid();
    let mut w = v.clone();
    w.scene = &gridded;
    let r = step(&w, c, &mut frame, &mut scratch, "grid");
    assert!(r.invalidated, "grid: {r:?}");
    step(&v, c, &mut frame, &mut scratch, "bvh again");

    // The eye moves (head tracking): a new camera.
    let mut w = v.clone();
    w.cam.eye.x += 3.0;
    w.cam.eye.z -= 10.0;
    let r = step(&w, c, &mut frame, &mut scratch, "eye moved");
    assert!(r.invalidated && r.pixels_reused == 0, "eye moved: {r:?}");
    step(
        &w,
        at(0.4, -0.1),
        &mut frame,
        &mut scratch,
        "eye moved, jitter",
    );
    // Another triangle test.
    let mut w = v.clone();
    w.settings.test = TriangleTest::MollerTrumbore;
    let r = step(&w, c, &mut frame, &mut scratch, "moller-trumbore");
    assert!(r.invalidated, "moller-trumbore: {r:?}");
    // Other triggers, then coverage checking: the mask is the same but the
    // classification and owners are not, so they are redone.
    let r = step(&v, c, &mut frame, &mut scratch, "watertight");
    assert!(r.invalidated, "watertight: {r:?}");
    let r = step(&v, c, &mut frame, &mut scratch, "watertight, repeat");
    assert!(r.mask_reused, "watertight, repeat: {r:?}");
    let refined = fresh(&v, c).1.rays_refine;
    assert!(refined > 0, "the scene's triggers refine cells here");
    let mut w = v.clone();
    w.settings.triggers = Triggers::NONE;
    let r = step(&w, c, &mut frame, &mut scratch, "no triggers");
    assert!(
        !r.invalidated && !r.mask_reused && r.pixels_reused > 0,
        "no triggers: {r:?}"
    );
    w.settings.check_coverage = true;
    let r = step(&w, c, &mut frame, &mut scratch, "check coverage");
    assert!(!r.mask_reused, "check coverage: {r:?}");
    // Another layout: another mask.
    w.settings.layout = Layout::Seed;
    let r = step(&w, c, &mut frame, &mut scratch, "seed layout");
    assert!(!r.mask_reused, "seed layout: {r:?}");

    // A resize: another display, model and camera.
    let small = display(512, 400);
    let s = View::new(scene, &small);
    let r = step(&s, [200.0, 230.0], &mut frame, &mut scratch, "resized");
    assert!(r.invalidated && r.pixels_reused == 0, "resized: {r:?}");
    step(
        &s,
        [200.5, 229.0],
        &mut frame,
        &mut scratch,
        "resized, jitter",
    );
    let r = step(&v, c, &mut frame, &mut scratch, "original size");
    assert!(r.invalidated, "original size: {r:?}");
}

#[test]
fn a_second_kept_frame_is_the_last_one_copied_unless_its_inputs_changed() {
    let scene = search_task();
    let d = display(320, 256);
    let mut v = View::new(scene, &d);
    let mut scratch = Scratch::with_reuse();
    let mut frame = Frame::default();
    let g = [120.0, 150.0];
    let r = step(&v, g, &mut frame, &mut scratch, "first");
    assert!(!r.mask_reused && !r.frame_reused, "first: {r:?}");
    let r = step(&v, g, &mut frame, &mut scratch, "second");
    assert!(r.mask_reused && !r.frame_reused, "second: {r:?}");
    for k in 0..3 {
        let r = step(&v, g, &mut frame, &mut scratch, &format!("copy {k}"));
        assert!(r.mask_reused && r.frame_reused, "copy {k}: {r:?}");
    }
    // Surface buffers asked for again: not a copy (they were not filled).
    v.surface = false;
    let r = step(&v, g, &mut frame, &mut scratch, "no surface");
    assert!(!r.frame_reused, "no surface: {r:?}");
    let r = step(&v, g, &mut frame, &mut scratch, "no surface, copy");
    assert!(r.frame_reused, "no surface, copy: {r:?}");
    v.surface = true;
    let r = step(&v, g, &mut frame, &mut scratch, "surface again");
    assert!(!r.frame_reused, "surface again: {r:?}");
    // Shading the cast cache does not key on: materials, lights and the
    // background change the pixels, so a copy would be stale.
    let mut shaded = scene.clone();
    for m in &mut shaded.object_materials {
        m.diffuse.0 *= 0.5;
    }
    let mut w = v.clone();
    w.scene = &shaded;
    step(&w, g, &mut frame, &mut scratch, "repainted");
    let r = step(&w, g, &mut frame, &mut scratch, "repainted, again");
    assert!(r.mask_reused, "repainted: {r:?}");
    let mut lit = shaded.clone();
    lit.lights.push(Light::Headlight { intensity: 0.3 });
    w.scene = &lit;
    let r = step(&w, g, &mut frame, &mut scratch, "relit");
    assert!(!r.frame_reused, "relit: {r:?}");
    let mut dark = lit.clone();
    dark.background = glam::Vec3::ZERO;
    dark.background_rgb8 = [0; 3];
    w.scene = &dark;
    let r = step(&w, g, &mut frame, &mut scratch, "dark");
    assert!(!r.frame_reused, "dark: {r:?}");
    // A gaze moved by a bit: a new mask, drawn afresh.
    let r = step(&w, [120.5, 150.0], &mut frame, &mut scratch, "moved");
    assert!(!r.mask_reused && !r.frame_reused, "moved: {r:?}");
}

#[test]
fn a_gaze_within_the_tolerance_keeps_the_mask_and_its_frame() {
    let scene = search_task();
    let d = display(320, 256);
    let mut v = View::new(scene, &d);
    v.model = v.model.with_gaze_tolerance_deg(1.0).expect("tolerance");
    let c = [150.0, 120.0];
    // One degree at the test display's distance, in pixels along x.
    let g = v.model.geometry;
    let one_deg_px = g.eye_distance_mm * 1f64.to_radians().tan() / g.pitch_x_mm;
    assert!(
        one_deg_px > 4.0,
        "the test needs a tolerance of a few pixels"
    );
    let (want, want_stats) = fresh(&v, c);
    for mut scratch in [Scratch::default(), Scratch::with_reuse()] {
        let reuse = scratch.reuse();
        let mut frame = Frame::default();
        draw(&v, c, &mut frame, &mut scratch).expect("first");
        // Jitter inside the tolerance: the frame stays the one for `c`.
        for (k, f) in [0.3, -0.5, 0.9, 0.0, -0.9].into_iter().enumerate() {
            let gaze = [c[0] + 0.8 * f * one_deg_px, c[1] - 0.6 * f * one_deg_px];
            assert!(v.model.within_tolerance(c, gaze), "jitter {k} is within 1°");
            let stats = draw(&v, gaze, &mut frame, &mut scratch).expect("held");
            let what = format!("reuse {reuse}, jitter {k}");
            assert_same(&frame, &want, &what);
            assert_same_counts(stats, want_stats, &what);
            if reuse {
                let r = scratch.reuse_stats();
                assert!(r.mask_reused && (k == 0 || r.frame_reused), "{what}: {r:?}");
            }
        }
        // Beyond it: a new mask for the new gaze.
        let far = [c[0] + 1.6 * one_deg_px, c[1]];
        let stats = draw(&v, far, &mut frame, &mut scratch).expect("moved");
        let (want_far, want_far_stats) = fresh(&v, far);
        assert_same(&frame, &want_far, &format!("reuse {reuse}, beyond"));
        assert_same_counts(stats, want_far_stats, "beyond");
        assert!(!scratch.reuse_stats().mask_reused);
        // The mask is now the new gaze's: back at `c`, 1.6° away, too.
        draw(&v, c, &mut frame, &mut scratch).expect("back");
        assert_same(&frame, &want, &format!("reuse {reuse}, back"));
    }
    // A tolerance of 0: the frame follows every gaze (no holding).
    let mut plain = v.clone();
    plain.model = plain.model.with_gaze_tolerance_deg(0.0).expect("none");
    let mut scratch = Scratch::default();
    let mut frame = Frame::default();
    draw(&plain, c, &mut frame, &mut scratch).expect("first");
    let moved = [c[0] + 0.3 * one_deg_px, c[1]];
    draw(&plain, moved, &mut frame, &mut scratch).expect("moved");
    assert_same(&frame, &fresh(&plain, moved).0, "no tolerance");
}

#[test]
fn a_nan_gaze_leaves_the_frame_and_the_cache_usable() {
    let scene = search_task();
    let v = View::new(scene, &display(160, 128));
    let mut scratch = Scratch::with_reuse();
    let mut frame = Frame::default();
    let g = [80.0, 64.0];
    step(&v, g, &mut frame, &mut scratch, "before");
    let before = frame.clone();
    for bad in [[f64::NAN, 64.0], [80.0, f64::NAN], [f64::INFINITY, 0.0]] {
        assert!(
            draw(&v, bad, &mut frame, &mut scratch).is_err(),
            "{bad:?} refused"
        );
        assert_same(&frame, &before, "the frame after a refused gaze");
    }
    // The cache is still valid: the same gaze keeps the whole mask.
    let r = step(&v, g, &mut frame, &mut scratch, "same gaze after NaN");
    assert!(r.mask_reused && !r.invalidated, "{r:?}");
    let r = step(
        &v,
        [80.3, 64.2],
        &mut frame,
        &mut scratch,
        "jitter after NaN",
    );
    assert!(!r.invalidated && r.pixels_reused > 0, "{r:?}");
}

#[test]
fn reuse_can_be_turned_off_and_on_and_the_cache_emptied() {
    let scene = search_task();
    let v = View::new(scene, &display(160, 128));
    let mut scratch = Scratch::default();
    assert!(!scratch.reuse());
    let mut frame = Frame::default();
    let g = [70.0, 60.0];
    let r = step(&v, g, &mut frame, &mut scratch, "off");
    assert_eq!(r, ReuseStats::default());
    scratch.set_reuse(true);
    assert!(scratch.reuse());
    let r = step(&v, g, &mut frame, &mut scratch, "on");
    assert!(r.invalidated && !r.mask_reused, "on: {r:?}");
    let r = step(&v, g, &mut frame, &mut scratch, "on, repeat");
    assert!(r.mask_reused, "on, repeat: {r:?}");
    scratch.invalidate();
    let r = step(&v, g, &mut frame, &mut scratch, "emptied");
    assert!(
        r.invalidated && !r.mask_reused && r.pixels_reused == 0,
        "emptied: {r:?}"
    );
    scratch.set_reuse(false);
    let r = step(&v, g, &mut frame, &mut scratch, "off again");
    assert_eq!(r, ReuseStats::default());
}

/// Two small scenes (spheres and a torus near the centre, one a little
/// moved), cheap enough for many random sequences.
fn small_scenes() -> &'static [Scene; 2] {
    static S: OnceLock<[Scene; 2]> = OnceLock::new();
    S.get_or_init(|| {
        let scene = |dx: f32| {
            let file = SceneFile {
                name: "reuse".into(),
                background: (0.1, 0.1, 0.12),
                meshes: [
                    ("s".to_string(), MeshSource::Icosphere { subdivisions: 2 }),
                    (
                        "t".to_string(),
                        MeshSource::Torus {
                            major_radius: 0.7,
                            minor_radius: 0.3,
                            segments: 24,
                            sides: 12,
                        },
                    ),
                ]
                .into_iter()
                .collect(),
                materials: Default::default(),
                objects: [
                    ("s", -40.0 + dx, 20.0, -30.0, 25.0),
                    ("t", 10.0, -10.0, -60.0, 40.0),
                    ("s", 60.0, 50.0, 10.0, 12.0),
                    ("s", 5.0, 5.0, -200.0, 80.0),
                ]
                .iter()
                .map(|&(mesh, x, y, z, s)| Object {
                    mesh: mesh.into(),
                    material: None,
                    translate_mm: (x, y, z),
                    rotate_deg: (30.0, 20.0, 0.0),
                    scale_mm: s,
                    importance: 1.0,
                    motion: None,
                })
                .collect(),
                lights: vec![Light::Headlight { intensity: 1.0 }],
                sampling: None,
                passes: None,
                effects: Some(vec![
                    Effect::FoveatedSampling,
                    Effect::SilhouetteRefinement,
                    Effect::CreaseRefinement,
                    Effect::DepthRefinement,
                ]),
                crease_deg: Some(30.0),
                depth_jump: Some(0.05),
                camera: None,
            };
            Scene::build(&file, Path::new(".")).expect("scene")
        };
        [scene(0.0), scene(3.0)]
    })
}

/// One event of a random gaze sequence.
#[derive(Debug, Clone)]
enum Op {
    /// Tracker noise: a sub-pixel move.
    Jitter(f64, f64),
    /// A few pixels (drift, microsaccade).
    Drift(f64, f64),
    /// A saccade to anywhere on or near the screen.
    Saccade(f64, f64),
    /// The last gaze again, bit for bit.
    Repeat,
    /// A non-finite gaze (refused).
    Nan,
    /// Surface buffers on or off.
    Surface,
    /// The other scene revision.
    Scene,
    /// The eye moves 0.5 mm.
    Eye,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => (-0.5..0.5f64, -0.5..0.5f64).prop_map(|(x, y)| Op::Jitter(x, y)),
        3 => (-4.0..4.0f64, -4.0..4.0f64).prop_map(|(x, y)| Op::Drift(x, y)),
        2 => (-250.0..410.0f64, -250.0..380.0f64).prop_map(|(x, y)| Op::Saccade(x, y)),
        2 => Just(Op::Repeat),
        1 => Just(Op::Nan),
        1 => Just(Op::Surface),
        1 => Just(Op::Scene),
        1 => Just(Op::Eye),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(32), ..ProptestConfig::default() })]

    #[test]
    fn random_gaze_sequences_render_what_fresh_frames_render(
        // The fovea (radius ≈ 100 px) covers this small screen from its
        // centre, so gazes range well beyond it: there the cells do.
        start in (-250.0..410.0f64, -250.0..380.0f64),
        ops in prop::collection::vec(op(), 1..14),
    ) {
        let scenes = small_scenes();
        let d = display(160, 128);
        let mut v = View::new(&scenes[0], &d);
        let mut which = 0;
        let mut scratch = Scratch::with_reuse();
        let mut frame = Frame::default();
        let mut gaze = [start.0, start.1];
        step(&v, gaze, &mut frame, &mut scratch, "start");
        for (k, op) in ops.iter().enumerate() {
            let what = format!("op {k} {op:?}");
            match *op {
                Op::Jitter(x, y) | Op::Drift(x, y) => gaze = [gaze[0] + x, gaze[1] + y],
                Op::Saccade(x, y) => gaze = [x, y],
                Op::Repeat => {}
                Op::Nan => {
                    let before = frame.clone();
                    prop_assert!(draw(&v, [f64::NAN, gaze[1]], &mut frame, &mut scratch).is_err());
                    assert_same(&frame, &before, &what);
                    continue;
                }
                Op::Surface => v.surface = !v.surface,
                Op::Scene => {
                    which = 1 - which;
                    v.scene = &scenes[which];
                }
                Op::Eye => v.cam.eye.x += 0.5,
            }
            let r = step(&v, gaze, &mut frame, &mut scratch, &what);
            if matches!(op, Op::Repeat | Op::Surface) {
                prop_assert!(r.mask_reused, "{}: {:?}", what, r);
            }
            if matches!(op, Op::Scene | Op::Eye) {
                prop_assert!(r.invalidated, "{}: {:?}", what, r);
            }
        }
    }
}
