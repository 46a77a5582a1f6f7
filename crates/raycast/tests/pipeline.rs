//! The hybrid pipeline against the full-resolution reference.

mod common;

use common::{display, load};

use std::path::Path;

use foveation::{Display, GeislerPerry, Layout, SamplingModel};
use raycast::ray::TriangleTest;
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::scene::{Effect, Light, MeshSource, Object};
use raycast::Layer;
use raycast::{Camera, Scene, SceneFile};

fn frames(
    scene: &Scene,
    d: &Display,
    gaze: [f64; 2],
    triggers: Triggers,
) -> (raycast::Frame, raycast::Frame, raycast::Stats) {
    frames_with(scene, d, gaze, triggers, false)
}

/// `check_coverage` rasterises background cells too, so unowned pixels show.
fn frames_with(
    scene: &Scene,
    d: &Display,
    gaze: [f64; 2],
    triggers: Triggers,
    check_coverage: bool,
) -> (raycast::Frame, raycast::Frame, raycast::Stats) {
    let g = d.geometry().expect("geometry");
    let model = SamplingModel::new(g, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let cam = Camera::new(&g);
    let s = |mode| Settings {
        mode,
        layout: Layout::Nyquist,
        triggers,
        test: TriangleTest::Watertight,
        check_coverage,
    };
    let (full, _) = render(scene, &cam, &model, &s(Mode::Full), gaze).expect("full");
    let (fov, stats) = render(scene, &cam, &model, &s(Mode::Hybrid), gaze).expect("foveated");
    (full, fov, stats)
}

#[test]
fn fovea_and_refined_pixels_equal_the_full_resolution_image_exactly() {
    let d = display(640, 512);
    for name in ["search-task", "stress"] {
        let scene = load(name);
        for gaze in [[320.0, 256.0], [5.0, 500.0], [700.0, -30.0]] {
            let (full, fov, stats) = frames(&scene, &d, gaze, Triggers::from_scene(&scene));
            let mut checked = 0;
            for (i, layer) in fov.layer.iter().enumerate() {
                if matches!(layer, Layer::Fovea | Layer::Refined | Layer::Gap) {
                    assert_eq!(
                        fov.rgb[3 * i..3 * i + 3],
                        full.rgb[3 * i..3 * i + 3],
                        "{name} gaze {gaze:?} pixel {i}"
                    );
                    checked += 1;
                }
            }
            assert_eq!(
                checked as u64,
                stats.rays_fovea + stats.rays_refine,
                "{name}"
            );
            assert!(
                stats.rays_total < (640 * 512) as u64,
                "{name} {gaze:?}: foveation cast {} rays",
                stats.rays_total
            );
        }
    }
}

/// Large smooth spheres: every feature is far larger than the ray spacing.
fn big_spheres() -> Scene {
    let file = SceneFile {
        name: "big-spheres".into(),
        background: (0.0, 0.0, 0.0),
        meshes: [("s".to_string(), MeshSource::Icosphere { subdivisions: 4 })]
            .into_iter()
            .collect(),
        materials: Default::default(),
        objects: [
            (-90.0, 40.0, -60.0, 55.0),
            (70.0, -30.0, -150.0, 80.0),
            (10.0, 90.0, 20.0, 30.0),
            (110.0, 95.0, -300.0, 60.0),
        ]
        .iter()
        .map(|&(x, y, z, s)| Object {
            mesh: "s".into(),
            material: None,
            translate_mm: (x, y, z),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: s,
            importance: 1.0,
            motion: None,
        })
        .collect(),
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(vec![Effect::FoveatedSampling, Effect::SilhouetteRefinement]),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, Path::new(".")).expect("scene")
}

#[test]
fn silhouettes_match_full_resolution_at_every_pixel_when_features_exceed_the_spacing() {
    let scene = big_spheres();
    let d = display(640, 512);
    for gaze in [[320.0, 256.0], [0.5, 0.5], [600.0, 100.0], [-200.0, 300.0]] {
        let (full, fov, _) = frames(&scene, &d, gaze, Triggers::from_scene(&scene));
        let diff = full
            .hit
            .iter()
            .zip(&fov.hit)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(diff, 0, "gaze {gaze:?}: {diff} pixels disagree on hit/miss");
    }
}

#[test]
fn the_silhouette_margin_recovers_edge_pixels_the_seed_rule_loses() {
    // The corner test alone (the seed's rule) misses silhouettes that bulge
    // into a cell between its corners; on the stress scene, where some
    // features are smaller than the spacing, the margin recovers most of them.
    let scene = load("stress");
    let d = display(640, 512);
    let seed_rule = Triggers {
        silhouette: true,
        crease_deg: None,
        depth_jump: None,
        margin: false,
    };
    let mut total = 0;
    let mut with_margin = 0;
    for gaze in [[320.0, 256.0], [0.5, 0.5], [600.0, 100.0]] {
        let (full, fov, _) = frames(&scene, &d, gaze, seed_rule);
        total += full
            .hit
            .iter()
            .zip(&fov.hit)
            .filter(|(a, b)| a != b)
            .count();
        let (full, fov, _) = frames(
            &scene,
            &d,
            gaze,
            Triggers {
                margin: true,
                ..seed_rule
            },
        );
        with_margin += full
            .hit
            .iter()
            .zip(&fov.hit)
            .filter(|(a, b)| a != b)
            .count();
    }

    // Few either way; the test with the margin above demands zero.
    assert!(
        total > 0,
        "the seed rule lost no pixel here: pick a harder scene"
    );
    assert!(
        with_margin < total,
        "margin {with_margin} vs seed rule {total}"
    );
}

#[test]
fn every_pixel_has_exactly_one_owner() {
    let scene = load("search-task");
    for (d, gaze) in [
        (display(640, 512), [320.0, 256.0]),
        (display(640, 512), [0.0, 511.9]),
        (display(401, 333), [133.3, 77.7]),
    ] {
        let (_, fov, stats) = frames_with(&scene, &d, gaze, Triggers::from_scene(&scene), true);
        // Skipping background cells (the default) changes no pixel.
        let (_, fast, _) = frames_with(&scene, &d, gaze, Triggers::from_scene(&scene), false);
        assert!(
            fov.rgb == fast.rgb && fov.hit == fast.hit,
            "{gaze:?}: skipping background cells changed the image"
        );
        let gaps: Vec<(usize, usize)> = fov
            .layer
            .iter()
            .enumerate()
            .filter(|(_, l)| **l == Layer::Gap)
            .map(|(i, _)| (i % fov.width_px as usize, i / fov.width_px as usize))
            .collect();
        assert_eq!(
            stats.pixels_uncovered, 0,
            "{gaze:?}: pixels no cell owned: {gaps:?}"
        );
        assert!(fov.layer.iter().all(|l| *l != Layer::Full));
    }
}

#[test]
fn no_triggers_means_only_silhouette_free_interpolation_and_fewer_rays() {
    let scene = load("search-task");
    let d = display(640, 512);
    let (_, _, with) = frames(&scene, &d, [320.0, 256.0], Triggers::from_scene(&scene));
    let (_, _, without) = frames(&scene, &d, [320.0, 256.0], Triggers::NONE);
    assert_eq!(without.cells_refined, 0);
    assert!(with.cells_refined > 0 && with.rays_total > without.rays_total);
}

#[test]
fn the_shipped_scenes_render_in_both_modes() {
    let d = display(320, 256);
    for name in ["search-task", "bunny", "stress"] {
        let scene = load(name);
        let (full, fov, stats) = frames(&scene, &d, [160.0, 128.0], Triggers::from_scene(&scene));
        let hits = full.hit.iter().filter(|h| **h).count();
        assert!(
            hits > 1000,
            "{name}: only {hits} pixels hit geometry: is the scene in view?"
        );
        let agree = full
            .hit
            .iter()
            .zip(&fov.hit)
            .filter(|(a, b)| a == b)
            .count();
        assert!(
            agree as f64 > 0.99 * full.hit.len() as f64,
            "{name}: {agree} of {} pixels agree",
            full.hit.len()
        );
        assert!(stats.rays_total > 0);
    }
}

#[test]
fn the_eye_inside_a_mesh_and_extreme_gazes_stay_finite() {
    let mut file: SceneFile = ron::from_str(
        r#"Scene(name: "inside", meshes: {"s": Icosphere(subdivisions: 3)}, objects: [(mesh: "s", translate_mm: (0.0, 0.0, 540.0), scale_mm: 100.0)])"#,
    )
    .expect("scene");
    let scene = Scene::build(&file, Path::new(".")).expect("build");
    let d = display(160, 128);
    for gaze in [[0.0, 0.0], [159.9, 127.9], [-1e6, 1e6], [80.0, 64.0]] {
        let (full, fov, _) = frames(&scene, &d, gaze, Triggers::from_scene(&scene));
        assert!(
            full.hit.iter().all(|h| *h),
            "inside a closed sphere every ray hits"
        );
        assert!(fov.hit.iter().all(|h| *h));
    }
    // An empty scene: everything is background, no cell is refined.
    file.objects.clear();
    let empty = Scene::build(&file, Path::new(".")).expect("build");
    let (full, fov, stats) = frames(&empty, &d, [80.0, 64.0], Triggers::from_scene(&empty));
    assert!(full.hit.iter().chain(&fov.hit).all(|h| !*h));
    assert_eq!(stats.cells_refined, 0);
}
