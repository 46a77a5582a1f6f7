//! Attention-guided LOD (Lee 2009 ch. 7): quadric levels of 4^−l of the
//! triangles, levels from the previous frame's attention (eq. 7.3), and
//! ULOD's blend of two adjacent levels.

use std::path::Path;

use foveation::Display;
use pipeline::ulod::{scene_levels, Ulod};
use raycast::raster::{self, RasterScratch};
use raycast::{Camera, Frame, Scene, SceneFile};

fn display() -> Display {
    Display::seed_17in(200, 160)
}

/// Three spheres; the middle one bright red, the others dull grey; the
/// right one scenery (importance 0).
fn scene() -> Scene {
    let text = r#"Scene(
        name: "three",
        meshes: {"ball": Icosphere(subdivisions: 4)},
        materials: {"red": (diffuse: (0.9, 0.1, 0.1)), "grey": (diffuse: (0.3, 0.3, 0.3))},
        objects: [
            (mesh: "ball", material: Some("grey"), translate_mm: (-90.0, 0.0, -20.0), scale_mm: 30.0),
            (mesh: "ball", material: Some("red"), translate_mm: (0.0, 0.0, -20.0), scale_mm: 30.0),
            (mesh: "ball", material: Some("grey"), translate_mm: (90.0, 0.0, -20.0), scale_mm: 30.0, importance: 0.0),
        ],
    )"#;
    let file: SceneFile = ron::from_str(text).expect("scene");
    Scene::build(&file, Path::new(".")).expect("builds")
}

#[test]
fn levels_keep_a_quarter_each_and_attention_picks_them() {
    let scene = scene();
    let g = display().geometry().expect("geometry");
    let camera = Camera::new(&g);
    let objects = scene_levels(&scene, 5).expect("levels");
    assert_eq!(objects.len(), 3);
    for o in &objects {
        let full = o.levels[0].len();
        assert_eq!(full, 5120, "an icosphere of 4 subdivisions");
        for (l, level) in o.levels.iter().enumerate() {
            let target = (full as f64 / 4f64.powi(l as i32)).floor() as usize;
            assert!(
                level.len() <= target && level.len() + 8 >= target,
                "level {l}: {} for {target}",
                level.len()
            );
        }
    }
    let mut ulod = Ulod::new(objects, 4, 64).expect("ulod");
    // The first frame has no attention: everything at level 0, which is
    // the full mesh, so it equals the raster of the whole scene.
    let mut first = Frame::default();
    let s = ulod.render(&scene, &camera, None, Some(0.0), &mut first);
    assert_eq!(s.triangles_opaque, 3 * 5120);
    assert_eq!(s.triangles_blended, 0);
    let mut reference = Frame::default();
    raster::rasterize(
        &scene,
        &camera,
        &scene.triangles,
        true,
        &mut reference,
        &mut RasterScratch::default(),
    );
    assert_eq!(first.rgb, reference.rgb);
    // Then the levels follow the attention on the last frame.
    let mut frame = first.clone();
    let mut previous = first;
    for k in 1..6 {
        let s = ulod.render(
            &scene,
            &camera,
            Some(&previous),
            Some(k as f64 / 60.0),
            &mut frame,
        );
        assert!(s.triangles_opaque + s.triangles_blended < 3 * 5120, "{s:?}");
        assert!(frame.rgb.iter().any(|&c| c != 0));
        std::mem::swap(&mut previous, &mut frame);
    }
    let levels = ulod.levels().to_vec();
    // The scenery is never ranked and never simplified.
    assert_eq!(levels[2], 0.0, "{levels:?}");
    // The most attended object is at full detail; the other is coarser.
    let (best, other) = if levels[0] < levels[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    assert_eq!(levels[best], 0.0, "{levels:?}");
    assert!(levels[other] > 0.0 && levels[other] <= 3.0, "{levels:?}");
    assert!(levels.iter().all(|l| l.is_finite()));
}

#[test]
fn bad_level_counts_are_refused() {
    let scene = scene();
    assert!(scene_levels(&scene, 0).is_err());
    assert!(scene_levels(&scene, 9).is_err());
    let two = scene_levels(&scene, 2).expect("levels");
    assert!(
        Ulod::new(two.clone(), 3, 64).is_err(),
        "three levels asked of two"
    );
    assert!(Ulod::new(two.clone(), 2, 32).is_err(), "map size below 64");
    assert!(
        Ulod::new(Vec::new(), 2, 64).is_ok(),
        "an empty scene is fine"
    );
    let mut empty = Ulod::new(Vec::new(), 2, 64).expect("ulod");
    let g = display().geometry().expect("geometry");
    let mut f = Frame::default();
    let s = empty.render(&scene, &Camera::new(&g), None, None, &mut f);
    assert_eq!((s.triangles_opaque, s.mean_level), (0, 0.0));
    let prev = f.clone();
    let s = empty.render(
        &scene,
        &Camera::new(&g),
        Some(&prev),
        Some(f64::NAN),
        &mut f,
    );
    assert_eq!(s.triangles_opaque, 0);
}

#[test]
fn the_renderer_runs_ulod_and_builds_it_for_no_other_method() {
    use pipeline::{BackendChoice, Method, Options, Renderer};
    let scene = scene();
    let g = display().geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let make = |method, backend| {
        Renderer::new(
            &scene,
            Camera::new(&g),
            model,
            &Options {
                method,
                backend,
                ..Options::default()
            },
        )
    };
    let mut r = make(Method::Ulod, BackendChoice::Cpu).expect("renderer");
    assert!(r.model_based().is_none());
    let mut drawn = Vec::new();
    for k in 0..4 {
        let (frame, _) = r.render_at([100.0, 80.0], k as f64 / 60.0).expect("frame");
        assert!(frame.hit.iter().any(|&h| h));
        let s = r.ulod().expect("ulod state").last();
        drawn.push(s.triangles_opaque + s.triangles_blended);
        r.recycle(frame);
    }
    assert_eq!(drawn[0], 3 * 5120, "the first frame draws level 0");
    assert!(drawn[3] < drawn[0], "{drawn:?}");
    assert!(r.explain().join("\n").contains("ULOD"));
    // The GPU backend is refused by name; auto says it uses the CPU.
    let e = make(Method::Ulod, BackendChoice::Gpu)
        .err()
        .expect("refused");
    assert!(e.to_string().contains("method ulod"), "{e}");
    // Pay per use: no other method builds levels or an attention model.
    for m in [Method::Full, Method::Hybrid, Method::Image, Method::Lod] {
        let r = make(m, BackendChoice::Cpu).expect("renderer");
        assert!(r.ulod().is_none(), "{m:?}");
    }
}

#[test]
fn a_small_mesh_never_runs_out_of_triangles() {
    use glam::Vec3;
    use pipeline::ulod::ObjectLevels;
    // A quad: two triangles, so level 1 asks for 0.
    let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let levels =
        ObjectLevels::build(0, &p, &[Vec3::Z; 4], &[[0, 1, 2], [0, 2, 3]], 5).expect("levels");
    assert_eq!(levels.levels[0].len(), 2);
    for (l, level) in levels.levels.iter().enumerate() {
        assert!(!level.is_empty(), "level {l} is empty");
    }
}
