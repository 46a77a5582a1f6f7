//! Scenes that move (`raycast::motion`): paths in the scene file, poses at
//! a time, the velocities the attention model reads, and their limits.

use std::path::Path;

mod common;

use common::display;
use foveation::{GeislerPerry, Layout, SamplingModel, ScreenGeometry};
use glam::Vec3;
use proptest::prelude::*;
use raycast::ray::TriangleTest;
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::{Camera, Scene, SceneFile};

fn build(ron_text: &str) -> Result<Scene, String> {
    let file: SceneFile = ron::from_str(ron_text).map_err(|e| e.to_string())?;
    Scene::build(&file, Path::new(".")).map_err(|e| e.to_string())
}

/// Two spheres behind the screen; `motion` goes into the first object,
/// `camera` is the scene's camera field (both RON text, may be empty).
fn scene_text(motion: &str, camera: &str, lights: &str) -> String {
    format!(
        r#"Scene(
            name: "moving",
            meshes: {{ "ball": Icosphere(subdivisions: 2) }},
            objects: [
                (mesh: "ball", translate_mm: (-40.0, 10.0, -30.0), rotate_deg: (10.0, 20.0, 30.0), scale_mm: 25.0 {motion}),
                (mesh: "ball", translate_mm: (50.0, -20.0, -60.0), scale_mm: 30.0),
            ],
            {lights}
            {camera}
        )"#
    )
}

fn geometry() -> ScreenGeometry {
    display(160, 128).geometry().expect("a valid display")
}

fn full_frame(scene: &Scene) -> raycast::Frame {
    let g = geometry();
    let model = SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let settings = Settings {
        mode: Mode::Full,
        layout: Layout::Nyquist,
        triggers: Triggers::NONE,
        test: TriangleTest::Watertight,
        check_coverage: false,
    };
    render(scene, &Camera::new(&g), &model, &settings, g.centre_px())
        .expect("renders")
        .0
}

fn positions(scene: &Scene, object: u32) -> Vec<Vec3> {
    let mut p: Vec<Vec3> = scene
        .triangles
        .iter()
        .filter(|t| t.object == object)
        .flat_map(|t| t.p)
        .collect();
    p.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).expect("finite"));
    p
}

#[test]
fn a_static_scene_keeps_nothing_for_motion() {
    let scene = build(&scene_text("", "", "")).expect("builds");
    assert!(!scene.is_moving());
    assert!(scene.pose().is_none());
    assert!(scene.posed(1.0).is_none());
    assert!(scene.motion_summary().is_none());
}

#[test]
fn a_path_that_stays_at_rest_renders_the_static_scene_exactly() {
    let still = build(&scene_text("", "", "")).expect("builds");
    let rest = build(&scene_text(
        ", motion: Some((keys: [(t_s: 0.0), (t_s: 2.0)], repeat: Loop))",
        "camera: Some((keys: [(t_s: 0.0)])),",
        "",
    ))
    .expect("builds");
    assert!(rest.is_moving());
    for t in [0.0, 0.7, 5.0] {
        let posed = rest.posed(t).expect("a moving scene poses");
        assert_eq!(positions(&posed, 0), positions(&still, 0));
        assert_eq!(positions(&posed, 1), positions(&still, 1));
        let (a, b) = (full_frame(&posed), full_frame(&still));
        assert_eq!(a.rgb, b.rgb);
        assert_eq!(a.object, b.object);
        assert_eq!(a.depth_mm, b.depth_mm);
        let pose = posed.pose().expect("a pose");
        assert_eq!(pose.time_s, t);
        assert!(pose.object_velocity_mm_per_s.iter().all(|v| *v == [0.0; 3]));
        assert_eq!(pose.camera_velocity_mm_per_s, [0.0; 3]);
    }
}

#[test]
fn an_object_follows_its_path_and_reports_its_velocity() {
    let still = build(&scene_text("", "", "")).expect("builds");
    let moving = build(&scene_text(
        ", motion: Some((keys: [(t_s: 0.0), (t_s: 2.0, translate_mm: (20.0, 0.0, -10.0))]))",
        "",
        "",
    ))
    .expect("builds");
    let posed = moving.posed(1.0).expect("poses");
    let offset = Vec3::new(10.0, 0.0, -5.0);
    for (a, b) in positions(&posed, 0).iter().zip(positions(&still, 0)) {
        assert!((*a - (b + offset)).length() < 1e-3, "{a} vs {b} + {offset}");
    }
    assert_eq!(positions(&posed, 1), positions(&still, 1));
    let v = posed.pose().expect("a pose").object_velocity_mm_per_s[0];
    assert!((v[0] - 10.0).abs() < 0.05 && v[1].abs() < 0.05 && (v[2] + 5.0).abs() < 0.05);
    assert_eq!(
        posed.pose().expect("a pose").object_velocity_mm_per_s[1],
        [0.0; 3]
    );
    // Held after the last key: at rest there.
    let held = moving.posed(10.0).expect("poses");
    assert_eq!(
        held.pose().expect("a pose").object_velocity_mm_per_s[0],
        [0.0; 3]
    );
    // The picture changes where the object went.
    assert_ne!(full_frame(&posed).object, full_frame(&still).object);
    assert_ne!(posed.revision(), moving.revision());
    assert_ne!(
        posed.revision(),
        moving.posed(1.0).expect("poses").revision()
    );
}

#[test]
fn a_spinning_object_moves_its_corners() {
    // 90°/s about z: a corner at distance r moves at r·π/2 mm/s.
    let spinning = build(&scene_text(
        ", motion: Some((keys: [(t_s: 0.0), (t_s: 4.0, rotate_deg: (0.0, 0.0, 360.0))], repeat: Loop))",
        "",
        "",
    ))
    .expect("builds");
    let posed = spinning.posed(0.5).expect("poses");
    let speed = Vec3::from(posed.pose().expect("a pose").object_velocity_mm_per_s[0]).length();
    // The fastest bounding-box corner lies between 25 and 25·√3 mm from
    // the axis's point (an icosphere of radius 25 mm, turned by the base
    // rotation): its speed between those radii times π/2.
    let w = std::f32::consts::FRAC_PI_2;
    assert!(
        speed > 25.0 * w * 0.99 && speed < 25.0 * 3f32.sqrt() * w * 1.01,
        "{speed}"
    );
}

#[test]
fn the_camera_path_moves_the_world_the_other_way() {
    let still = build(&scene_text(
        "",
        "",
        "lights: [Point(position_mm: (0.0, 100.0, 200.0), intensity: 1.0)],",
    ))
    .expect("builds");
    let moving = build(&scene_text(
        "",
        "camera: Some((keys: [(t_s: 0.0), (t_s: 1.0, translate_mm: (0.0, 0.0, -100.0))])),",
        "lights: [Point(position_mm: (0.0, 100.0, 200.0), intensity: 1.0)],",
    ))
    .expect("builds");
    let posed = moving.posed(0.5).expect("poses");
    let offset = Vec3::new(0.0, 0.0, 50.0);
    for k in 0..2 {
        for (a, b) in positions(&posed, k).iter().zip(positions(&still, k)) {
            assert!((*a - (b + offset)).length() < 1e-3);
        }
    }
    match posed.lights[0] {
        raycast::scene::Light::Point { position_mm, .. } => {
            assert!((Vec3::from(position_mm) - Vec3::new(0.0, 100.0, 250.0)).length() < 1e-3)
        }
        other => panic!("the light changed kind: {other:?}"),
    }
    let pose = posed.pose().expect("a pose");
    // The viewer walks forward (−z) at 100 mm/s; every object comes
    // towards the viewer at that speed.
    let c = pose.camera_velocity_mm_per_s;
    assert!(
        c[0].abs() < 0.05 && c[1].abs() < 0.05 && (c[2] + 100.0).abs() < 0.05,
        "{c:?}"
    );
    for v in &pose.object_velocity_mm_per_s {
        assert!((v[2] - 100.0).abs() < 0.05, "{v:?}");
    }
    assert!(moving
        .motion_summary()
        .expect("moves")
        .contains("camera path of 2 keys"));
}

#[test]
fn a_turned_camera_reports_its_velocity_in_the_display_frame() {
    // Turned 90° about y (looking along world −x), moving along world −x:
    // forward for the viewer (display −z).
    let moving = build(&scene_text(
        "",
        "camera: Some((keys: [(t_s: 0.0, rotate_deg: (0.0, 90.0, 0.0)), (t_s: 1.0, translate_mm: (-100.0, 0.0, 0.0), rotate_deg: (0.0, 90.0, 0.0))])),",
        "",
    ))
    .expect("builds");
    let c = moving
        .posed(0.5)
        .expect("poses")
        .pose()
        .expect("a pose")
        .camera_velocity_mm_per_s;
    assert!(
        c[0].abs() < 0.05 && c[1].abs() < 0.05 && (c[2] + 100.0).abs() < 0.05,
        "{c:?}"
    );
}

#[test]
fn bad_paths_name_their_field() {
    let err = |motion: &str, camera: &str| build(&scene_text(motion, camera, "")).unwrap_err();
    let e = err(", motion: Some((keys: []))", "");
    assert!(e.contains("objects[0].motion.keys"), "{e}");
    let e = err(", motion: Some((keys: [(t_s: 1.0), (t_s: 0.5)]))", "");
    assert!(e.contains("objects[0].motion.keys[1].t_s"), "{e}");
    let e = err(
        "",
        "camera: Some((keys: [(t_s: 0.0, rotate_deg: (0.0, inf, 0.0))])),",
    );
    assert!(e.contains("camera.keys[0].rotate_deg"), "{e}");
    let e = err(", motion: Some((keys: [(t_s: 0.0)], speed: 3.0))", "");
    assert!(e.contains("speed"), "{e}");
}

#[test]
fn a_path_that_leaves_the_representable_world_is_refused() {
    let text = r#"Scene(
        name: "far",
        meshes: { "ball": Icosphere(subdivisions: 0) },
        objects: [(mesh: "ball", translate_mm: (0.0, 0.0, -30.0), scale_mm: 1e15,
                   motion: Some((keys: [(t_s: 0.0), (t_s: 1.0, translate_mm: (1e6, 0.0, 0.0))])))],
    )"#;
    let e = build(text).unwrap_err();
    assert!(e.contains("objects[0].motion"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(48)))]

    /// Any valid path, any time (NaN, infinities, huge, tiny steps): every
    /// posed vertex, normal and velocity is finite.
    #[test]
    fn every_pose_is_finite(
        keys in prop::collection::vec(
            (1e-6f64..1e3, -1e6f32..1e6, -1e6f32..1e6, -1e6f32..1e6, -1e5f32..1e5),
            1..6,
        ),
        camera_keys in prop::collection::vec((1e-6f64..1e3, -1e6f32..1e6, -720f32..720.0), 1..4),
        repeat in 0usize..3,
        time in prop_oneof![
            Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY),
            Just(0.0), Just(1e300), Just(-1e300), -1e4f64..1e4,
        ],
    ) {
        let repeat = ["Hold", "Loop", "Bounce"][repeat];
        let mut t = 0.0;
        let object_keys: Vec<String> = keys
            .iter()
            .map(|(dt, x, y, z, r)| {
                t += dt;
                format!("(t_s: {t:?}, translate_mm: ({x:?}, {y:?}, {z:?}), rotate_deg: ({r:?}, {r:?}, 0.0))")
            })
            .collect();
        let mut t = -10.0;
        let camera: Vec<String> = camera_keys
            .iter()
            .map(|(dt, x, r)| {
                t += dt;
                format!("(t_s: {t:?}, translate_mm: ({x:?}, 0.0, {x:?}), rotate_deg: (0.0, {r:?}, {r:?}))")
            })
            .collect();
        let text = scene_text(
            &format!(", motion: Some((keys: [{}], repeat: {repeat}))", object_keys.join(", ")),
            &format!("camera: Some((keys: [{}], repeat: {repeat})),", camera.join(", ")),
            "lights: [Point(position_mm: (0.0, 100.0, 200.0), intensity: 1.0), Directional(direction: (0.0, -1.0, -1.0), intensity: 0.5)],",
        );
        let scene = build(&text).expect("a valid moving scene builds");
        let posed = scene.posed(time).expect("poses");
        prop_assert_eq!(posed.triangles.len(), scene.triangles.len());
        for tri in &posed.triangles {
            prop_assert!(tri.p.iter().chain(&tri.n).all(|v| v.is_finite()));
        }
        let pose = posed.pose().expect("a pose");
        prop_assert!(pose.time_s.is_finite());
        prop_assert!(pose.object_velocity_mm_per_s.iter().flatten().all(|v| v.is_finite()));
        prop_assert!(pose.camera_velocity_mm_per_s.iter().all(|v| v.is_finite()));
        for l in &posed.lights {
            if let raycast::scene::Light::Point { position_mm: p, .. } = l {
                prop_assert!(Vec3::from(*p).is_finite());
            }
        }
    }
}
