//! The CPU triangle rasteriser against the full-resolution ray caster, and
//! its edge cases (clipping, degenerate input, fill rule, determinism).
//!
//! `cargo test -p raycast --test raster -- --nocapture` prints the measured
//! agreement with the caster.

mod common;

use common::{display, load};

use std::path::Path;
use std::sync::OnceLock;

use foveation::{GeislerPerry, Layout, SamplingModel, ScreenGeometry};
use glam::Vec3;
use proptest::prelude::*;
use raycast::raster::{rasterize, RasterScratch, RasterStats};
use raycast::ray::TriangleTest;
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::scene::{Effect, Light, MeshSource, Object, WorldTriangle};
use raycast::{Camera, Frame, Layer, Scene, SceneFile, NO_OBJECT};

const W: u32 = 320;
const H: u32 = 256;

fn scene(name: &str) -> &'static Scene {
    static BUNNY: OnceLock<Scene> = OnceLock::new();
    static SEARCH: OnceLock<Scene> = OnceLock::new();
    match name {
        "bunny" => BUNNY.get_or_init(|| load("bunny")),
        "search-task" => SEARCH.get_or_init(|| load("search-task")),
        other => panic!("no scene {other}"),
    }
}

fn geometry(eye_point_px: Option<(f64, f64)>) -> ScreenGeometry {
    let mut d = display(W, H);
    d.eye_point_px = eye_point_px;
    d.geometry().expect("geometry")
}

/// The full-resolution ray-cast frame.
fn cast(scene: &Scene, g: &ScreenGeometry) -> Frame {
    let model = SamplingModel::new(*g, GeislerPerry::default(), 1.0, 17.0).expect("model");
    let settings = Settings {
        mode: Mode::Full,
        layout: Layout::Nyquist,
        triggers: Triggers::NONE,
        test: TriangleTest::Watertight,
        check_coverage: false,
    };
    let (frame, _) = render(scene, &Camera::new(g), &model, &settings, [0.0, 0.0]).expect("render");
    frame
}

fn raster(scene: &Scene, cam: &Camera, tris: &[WorldTriangle]) -> (Frame, RasterStats) {
    let mut frame = Frame::default();
    let stats = rasterize(
        scene,
        cam,
        tris,
        true,
        &mut frame,
        &mut RasterScratch::default(),
    );
    (frame, stats)
}

/// How closely two frames agree.
#[derive(Debug)]
struct Agreement {
    pixels: usize,
    hit_differs: usize,
    same_object: usize,
    rgb_exact: usize,
    rgb_within_2: usize,
    depth_within: usize,
    max_depth_rel: f32,
}

fn agreement(reference: &Frame, test: &Frame) -> Agreement {
    let mut a = Agreement {
        pixels: reference.len(),
        hit_differs: 0,
        same_object: 0,
        rgb_exact: 0,
        rgb_within_2: 0,
        depth_within: 0,
        max_depth_rel: 0.0,
    };
    for i in 0..reference.len() {
        if reference.hit[i] != test.hit[i] {
            a.hit_differs += 1;
        }
        if !reference.hit[i] || reference.object[i] != test.object[i] {
            continue;
        }
        a.same_object += 1;
        let (p, q) = (
            &reference.rgb[3 * i..3 * i + 3],
            &test.rgb[3 * i..3 * i + 3],
        );
        a.rgb_exact += usize::from(p == q);
        a.rgb_within_2 += usize::from(p.iter().zip(q).all(|(x, y)| x.abs_diff(*y) <= 2));
        let rel = (reference.depth_mm[i] - test.depth_mm[i]).abs() / reference.depth_mm[i];
        a.depth_within += usize::from(rel <= 1e-3);
        a.max_depth_rel = a.max_depth_rel.max(rel);
    }
    a
}

fn check_agreement(what: &str, a: &Agreement) {
    let pct = |n: usize, d: usize| 100.0 * n as f64 / d.max(1) as f64;
    println!(
        "{what}: hit mask differs at {} of {} px ({:.3} %); of {} px on the same object: \
         colour exact {:.3} %, within 2 levels {:.3} %, depth within 1e-3 {:.3} % (max rel {:.2e})",
        a.hit_differs,
        a.pixels,
        pct(a.hit_differs, a.pixels),
        a.same_object,
        pct(a.rgb_exact, a.same_object),
        pct(a.rgb_within_2, a.same_object),
        pct(a.depth_within, a.same_object),
        a.max_depth_rel,
    );
    assert!(
        a.same_object > a.pixels / 50,
        "{what}: too few hits to compare"
    );
    assert!(
        pct(a.hit_differs, a.pixels) < 0.2,
        "{what}: hit masks differ at {} px",
        a.hit_differs
    );
    assert!(
        pct(a.rgb_within_2, a.same_object) >= 99.0,
        "{what}: colours agree within 2 levels at {:.3} %",
        pct(a.rgb_within_2, a.same_object)
    );
    assert!(
        pct(a.depth_within, a.same_object) >= 99.9,
        "{what}: depth within 1e-3 at {:.3} %",
        pct(a.depth_within, a.same_object)
    );
}

#[test]
fn matches_the_full_resolution_ray_caster() {
    for (name, eye) in [
        ("bunny", None),
        ("search-task", None),
        ("search-task", Some((40.0, 230.0))),
    ] {
        let s = scene(name);
        let g = geometry(eye);
        let reference = cast(s, &g);
        let (frame, stats) = raster(s, &Camera::new(&g), &s.triangles);
        println!("{name} (eye at {eye:?}): {stats:?}");
        assert_eq!(stats.triangles_in, s.triangles.len() as u64);
        assert_eq!(stats.triangles_in, stats.drawn + stats.culled);
        assert_eq!(stats.culled_invalid, 0, "{name}: a valid mesh");
        assert!(frame.layer.iter().all(|l| *l == Layer::Full));
        check_agreement(
            &format!("{name} eye {eye:?}"),
            &agreement(&reference, &frame),
        );
    }
}

#[test]
fn the_image_does_not_depend_on_the_thread_count() {
    let s = scene("search-task");
    let cam = Camera::new(&geometry(None));
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| raster(s, &cam, &s.triangles).0)
    };
    let one = run(1);
    let many = run(7);
    assert!(one.hit.iter().any(|h| *h));
    assert!(one == many, "1 thread and 7 threads disagree");
}

/// A scene of one triangle (object 0, the default material, a headlight):
/// the materials and lights for hand-made triangle lists.
fn triangle_scene(p: [Vec3; 3]) -> Scene {
    let file = SceneFile {
        name: "triangle".into(),
        background: (0.1, 0.2, 0.3),
        meshes: [(
            "t".to_string(),
            MeshSource::Triangle {
                a: p[0].into(),
                b: p[1].into(),
                c: p[2].into(),
            },
        )]
        .into_iter()
        .collect(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "t".into(),
            material: None,
            translate_mm: (0.0, 0.0, 0.0),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: 1.0,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(vec![Effect::FoveatedSampling]),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, Path::new(".")).expect("scene")
}

fn tri(p: [Vec3; 3]) -> WorldTriangle {
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    WorldTriangle {
        p,
        n: [n; 3],
        object: 0,
    }
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

fn assert_background(scene: &Scene, f: &Frame, what: &str) {
    assert!(f.has_surface());
    for i in 0..f.len() {
        assert!(
            !f.hit[i]
                && f.depth_mm[i] == f32::INFINITY
                && f.object[i] == NO_OBJECT
                && f.normal[i] == [0.0; 3]
                && f.layer[i] == Layer::Full
                && f.rgb[3 * i..3 * i + 3] == scene.background_rgb8,
            "{what}: pixel {i} is not background"
        );
    }
}

/// The caster and the rasteriser on a one-triangle scene: masks differ at
/// no more than `max_differ` pixels, depths agree where both hit.
fn compare_one(p: [Vec3; 3], max_differ: usize, what: &str) -> (Frame, RasterStats) {
    let s = triangle_scene(p);
    let g = geometry(None);
    let reference = cast(&s, &g);
    let (frame, stats) = raster(&s, &Camera::new(&g), &s.triangles);
    let a = agreement(&reference, &frame);
    println!("{what}: {stats:?}; {a:?}");
    assert!(
        a.hit_differs <= max_differ,
        "{what}: hit masks differ at {} px",
        a.hit_differs
    );
    assert!(a.depth_within == a.same_object, "{what}: depth differs");
    for i in 0..frame.len() {
        let d = frame.depth_mm[i];
        assert!(!d.is_nan() && d > 0.0, "{what}: depth {d} at {i}");
        assert_eq!(frame.hit[i], d.is_finite(), "{what}: pixel {i}");
        assert!(frame.normal[i].iter().all(|c| c.is_finite()));
    }
    (frame, stats)
}

#[test]
fn no_triangles_give_the_background_everywhere() {
    let s = triangle_scene([
        v(-50.0, -50.0, -10.0),
        v(50.0, -50.0, -10.0),
        v(0.0, 50.0, -10.0),
    ]);
    let cam = Camera::new(&geometry(None));
    let mut frame = Frame::default();
    let mut scratch = RasterScratch::default();
    // Draw something first: the empty frame must overwrite every pixel.
    let first = rasterize(&s, &cam, &s.triangles, true, &mut frame, &mut scratch);
    assert!(first.pixels_covered > 0);
    let stats = rasterize(&s, &cam, &[], true, &mut frame, &mut scratch);
    assert_eq!(
        (
            stats.triangles_in,
            stats.drawn,
            stats.culled,
            stats.fragments,
            stats.pixels_covered
        ),
        (0, 0, 0, 0, 0)
    );
    assert_eq!((frame.width_px, frame.height_px), (W, H));
    assert_background(&s, &frame, "no triangles");
}

#[test]
fn a_triangle_behind_the_eye_draws_nothing() {
    let s = triangle_scene([
        v(-50.0, -50.0, -10.0),
        v(50.0, -50.0, -10.0),
        v(0.0, 50.0, -10.0),
    ]);
    let cam = Camera::new(&geometry(None));
    // The eye is at z = 540: one triangle beyond it, one through the eye's
    // own plane.
    let behind = [
        tri([
            v(-50.0, -50.0, 600.0),
            v(50.0, -50.0, 600.0),
            v(0.0, 50.0, 600.0),
        ]),
        tri([
            v(-50.0, -50.0, 540.0),
            v(50.0, -50.0, 540.0),
            v(0.0, 50.0, 540.0),
        ]),
    ];
    let (frame, stats) = raster(&s, &cam, &behind);
    assert_eq!((stats.culled_behind, stats.drawn), (2, 0));
    assert_background(&s, &frame, "behind the eye");
}

#[test]
fn a_triangle_through_the_eye_plane_is_clipped_not_wrapped() {
    // One corner behind the eye (z > 540), two in front: the caster sees
    // the part in front; a wrapped projection would fill the top of the
    // screen too.
    let (frame, stats) = compare_one(
        [
            v(0.0, 0.0, 1000.0),
            v(-100.0, -50.0, -100.0),
            v(100.0, -50.0, -100.0),
        ],
        (W * H / 500) as usize,
        "one corner behind",
    );
    assert_eq!(stats.drawn, 1);
    let w = W as usize;
    assert!(
        frame.hit[(H as usize - 1) * w + w / 2],
        "the bottom centre is covered"
    );
    assert!(!frame.hit[w / 2], "the top centre is not");
    // Two corners behind, one in front.
    let (_, stats) = compare_one(
        [
            v(-80.0, 20.0, 900.0),
            v(80.0, 20.0, 900.0),
            v(0.0, -60.0, -50.0),
        ],
        (W * H / 500) as usize,
        "two corners behind",
    );
    assert_eq!(stats.drawn, 1);
}

#[test]
fn a_huge_triangle_covers_the_screen_and_costs_a_screenful() {
    let (frame, stats) = compare_one(
        [
            v(-1e6, -1e6, -50.0),
            v(1e6, -1e6, -80.0),
            v(0.0, 1e6, -20.0),
        ],
        0,
        "huge",
    );
    assert!(frame.hit.iter().all(|h| *h));
    assert_eq!(stats.fragments, u64::from(W * H));
    assert_eq!(stats.pixels_covered, u64::from(W * H));
}

#[test]
fn degenerate_and_non_finite_triangles_are_skipped_and_counted() {
    let s = triangle_scene([
        v(-50.0, -50.0, -10.0),
        v(50.0, -50.0, -10.0),
        v(0.0, 50.0, -10.0),
    ]);
    let cam = Camera::new(&geometry(None));
    let good = tri([
        v(-50.0, -50.0, -10.0),
        v(50.0, -50.0, -10.0),
        v(0.0, 50.0, -10.0),
    ]);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let mut bad_object = good;
    bad_object.object = 7;
    let mut nan_normals = good;
    nan_normals.n = [Vec3::splat(nan); 3];
    let bad = [
        // Collinear corners.
        tri([
            v(-50.0, 0.0, -10.0),
            v(0.0, 0.0, -10.0),
            v(50.0, 0.0, -10.0),
        ]),
        // A repeated corner.
        tri([
            v(-50.0, 0.0, -10.0),
            v(-50.0, 0.0, -10.0),
            v(50.0, 30.0, -10.0),
        ]),
        // All three corners equal.
        tri([v(1.0, 2.0, 3.0); 3]),
        // Edge-on: the plane x = 0 contains the eye (0, 0, 540).
        tri([
            v(0.0, -50.0, -10.0),
            v(0.0, 50.0, -10.0),
            v(0.0, 0.0, -200.0),
        ]),
        // Non-finite corners.
        tri([v(nan, 0.0, -10.0), v(50.0, 0.0, -10.0), v(0.0, 50.0, -10.0)]),
        tri([v(-50.0, 0.0, inf), v(50.0, 0.0, -10.0), v(0.0, 50.0, -10.0)]),
        tri([
            v(-50.0, 0.0, -10.0),
            v(50.0, -inf, -10.0),
            v(0.0, 50.0, -10.0),
        ]),
        // An object without a material.
        bad_object,
    ];
    let (frame, stats) = raster(&s, &cam, &bad);
    assert_eq!(stats.culled_invalid, bad.len() as u64, "{stats:?}");
    assert_eq!((stats.drawn, stats.culled), (0, bad.len() as u64));
    assert_background(&s, &frame, "degenerate");

    // Mixed with good ones, the good are drawn as alone.
    let mut mixed = bad.to_vec();
    mixed.insert(3, good);
    let (alone, _) = raster(&s, &cam, &[good]);
    let (frame, stats) = raster(&s, &cam, &mixed);
    assert_eq!((stats.drawn, stats.culled_invalid), (1, bad.len() as u64));
    assert_eq!(frame.rgb, alone.rgb);
    assert_eq!(frame.depth_mm, alone.depth_mm);
    // Finite but extreme corners (f32 products overflow): no panic, no NaN.
    let extreme = [
        tri([
            v(-3e38, -3e38, -1e30),
            v(3e38, -3e38, -1e30),
            v(0.0, 3e38, -1e30),
        ]),
        tri([
            v(-1e20, -1e20, 539.9),
            v(1e20, -1e20, 539.9),
            v(0.0, 1e20, 539.9),
        ]),
    ];
    let (frame, _) = raster(&s, &cam, &extreme);
    for i in 0..frame.len() {
        assert!(!frame.depth_mm[i].is_nan() && frame.normal[i].iter().all(|c| c.is_finite()));
        assert_eq!(frame.hit[i], frame.object[i] != NO_OBJECT);
    }
    // Non-finite normals fall back to the face normal, as the caster does.
    let (frame, stats) = raster(&s, &cam, &[nan_normals]);
    assert_eq!(stats.drawn, 1);
    let face = good.n[0].to_array();
    for i in 0..frame.len() {
        if frame.hit[i] {
            assert_eq!(frame.normal[i], face);
        }
    }
}

#[test]
fn a_frame_and_scratch_of_another_size_are_reused() {
    let s = scene("search-task");
    let mut frame = Frame::default();
    let mut scratch = RasterScratch::default();
    for (w, h, surface) in [
        (W, H, true),
        (97, 61, true),
        (200, 150, false),
        (W, H, true),
    ] {
        let mut d = display(w, h);
        d.size_mm = (
            337.9 * f64::from(w) / f64::from(W),
            270.3 * f64::from(h) / f64::from(H),
        );
        let cam = Camera::new(&d.geometry().expect("geometry"));
        rasterize(s, &cam, &s.triangles, surface, &mut frame, &mut scratch);
        let (fresh, _) = raster(s, &cam, &s.triangles);
        assert_eq!((frame.width_px, frame.height_px), (w, h));
        assert_eq!(frame.has_surface(), surface);
        assert_eq!(frame.rgb, fresh.rgb, "{w}x{h}");
        assert_eq!(frame.hit, fresh.hit, "{w}x{h}");
        if surface {
            assert!(frame == fresh, "{w}x{h}");
        } else {
            assert!(frame.depth_mm.is_empty() && frame.object.is_empty());
        }
    }
}

/// A display of 0.25 mm pixels, so that points on the screen plane have
/// exact pixel coordinates.
fn exact_camera() -> Camera {
    Camera::new(&ScreenGeometry {
        width_px: W,
        height_px: H,
        pitch_x_mm: 0.25,
        pitch_y_mm: 0.25,
        eye_point_px: [f64::from(W) / 2.0, f64::from(H) / 2.0],
        eye_distance_mm: 540.0,
    })
}

/// The world point on the screen plane z = 0 at pixel coordinates (x, y).
fn at_px(x: f32, y: f32) -> Vec3 {
    v(
        (x - W as f32 / 2.0) * 0.25,
        (H as f32 / 2.0 - y) * 0.25,
        0.0,
    )
}

#[test]
fn triangles_sharing_edges_cover_each_pixel_exactly_once() {
    let s = triangle_scene([
        v(-50.0, -50.0, -10.0),
        v(50.0, -50.0, -10.0),
        v(0.0, 50.0, -10.0),
    ]);
    let cam = exact_camera();
    // A grid of quads on the screen plane whose edges run through pixel
    // centres (x.5): each split into two triangles along a diagonal that
    // passes through pixel centres too, in alternating directions.
    let (x0, y0, step, n) = (20.5f32, 10.5f32, 28.0f32, 8);
    let mut grid = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (ax, ay) = (x0 + step * i as f32, y0 + step * j as f32);
            let (a, b, c, d) = (
                at_px(ax, ay),
                at_px(ax + step, ay),
                at_px(ax + step, ay + step),
                at_px(ax, ay + step),
            );
            if (i + j) % 2 == 0 {
                grid.push(tri([a, b, c]));
                grid.push(tri([a, c, d]));
            } else {
                grid.push(tri([a, b, d]));
                grid.push(tri([d, b, c]));
            }
        }
    }
    let (frame, stats) = raster(&s, &cam, &grid);
    // Top and left boundaries are in, bottom and right out: exactly the
    // pixels with x0 <= x + 0.5 < x0 + n·step, and the same in y.
    let side = (step * n as f32) as u64;
    assert_eq!(stats.fragments, side * side, "{stats:?}");
    assert_eq!(stats.pixels_covered, side * side);
    for y in 0..H as usize {
        for x in 0..W as usize {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let inside =
                cx >= x0 && cx < x0 + step * n as f32 && cy >= y0 && cy < y0 + step * n as f32;
            assert_eq!(frame.hit[y * W as usize + x], inside, "pixel ({x}, {y})");
        }
    }

    // A fan of thin triangles round a centre on a tilted plane (no exact
    // coordinates): the union is convex, so every row is one unbroken span,
    // and no pixel is covered twice.
    let centre = v(3.3, -2.1, -40.0);
    let k = 37;
    let rim = |i: usize| {
        let a = std::f32::consts::TAU * i as f32 / k as f32 + 0.1;
        centre
            + v(
                30.0 * a.cos(),
                25.0 * a.sin(),
                20.0 * a.cos() + 10.0 * a.sin(),
            )
    };
    let fan: Vec<_> = (0..k).map(|i| tri([centre, rim(i), rim(i + 1)])).collect();
    for cam in [exact_camera(), Camera::new(&geometry(Some((300.0, 20.0))))] {
        let (frame, stats) = raster(&s, &cam, &fan);
        assert_eq!(stats.fragments, stats.pixels_covered, "overlap: {stats:?}");
        assert!(stats.pixels_covered > 1000);
        for y in 0..H as usize {
            let row = &frame.hit[y * W as usize..(y + 1) * W as usize];
            let first = row.iter().position(|h| *h);
            let last = row.iter().rposition(|h| *h);
            if let (Some(a), Some(b)) = (first, last) {
                assert!(row[a..=b].iter().all(|h| *h), "a hole in row {y}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(32), ..ProptestConfig::default() })]

    #[test]
    fn random_triangles_near_the_camera_never_break_the_frame(
        corners in prop::collection::vec(
            (-400.0f32..400.0, -400.0f32..400.0, -900.0f32..1100.0),
            3..60,
        ),
        eye_x in 0.0f64..64.0,
    ) {
        let s = triangle_scene([v(-50.0, -50.0, -10.0), v(50.0, -50.0, -10.0), v(0.0, 50.0, -10.0)]);
        let mut d = display(64, 48);
        d.eye_point_px = Some((eye_x, 20.0));
        let cam = Camera::new(&d.geometry().expect("geometry"));
        let tris: Vec<WorldTriangle> = corners
            .chunks_exact(3)
            .map(|c| tri([0, 1, 2].map(|k| v(c[k].0, c[k].1, c[k].2))))
            .collect();
        let (frame, stats) = raster(&s, &cam, &tris);
        prop_assert_eq!(stats.triangles_in, stats.drawn + stats.culled);
        prop_assert_eq!(
            stats.culled,
            stats.culled_invalid + stats.culled_behind + stats.culled_no_pixels
        );
        prop_assert!(stats.pixels_covered <= stats.fragments);
        prop_assert_eq!(frame.len(), 64 * 48);
        for i in 0..frame.len() {
            let depth = frame.depth_mm[i];
            prop_assert!(depth == f32::INFINITY || (depth.is_finite() && depth > 0.0));
            prop_assert_eq!(frame.hit[i], frame.object[i] != NO_OBJECT);
            prop_assert_eq!(frame.hit[i], depth.is_finite());
            prop_assert!(frame.normal[i].iter().all(|c| c.is_finite()));
        }
    }
}
