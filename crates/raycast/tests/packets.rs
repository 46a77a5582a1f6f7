//! Packet casting (`Scene::intersect_packet`, issue 34) against single
//! rays: for every ray the same hit, bit for bit — the same triangle, `t`
//! and normal — or the same miss. Random triangle soups (degenerate
//! triangles included) with coherent and incoherent rays, directions with
//! zero, negative-zero, tiny and huge components, rays aimed exactly at
//! shared vertices and edges of closed meshes (where two triangles tie),
//! an empty scene, the shipped scenes' camera rays, and a full frame
//! rendered with packets against per-pixel single casts.

mod common;

use glam::Vec3;
use proptest::prelude::*;
use raycast::ray::{Ray, TriangleTest};
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::scene::{Hit, MeshSource, Object};
use raycast::{Camera, Scene, SceneFile};

/// The bits of a hit (or a miss).
fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, [u32; 3])> {
    h.map(|h| {
        (
            h.t.to_bits(),
            h.object,
            h.triangle,
            h.normal.to_array().map(f32::to_bits),
        )
    })
}

/// Casts `rays` as packets (one call, so the packet split is exercised)
/// and one by one, and compares.
fn assert_same(scene: &Scene, rays: &[Ray], t_min: f32) {
    for test in [TriangleTest::Watertight, TriangleTest::MollerTrumbore] {
        let mut packed = vec![None; rays.len()];
        scene.intersect_packet(rays, t_min, test, &mut packed);
        for (i, (r, p)) in rays.iter().zip(&packed).enumerate() {
            let single = scene.intersect(r, t_min, test);
            assert_eq!(
                bits(*p),
                bits(single),
                "ray {i} of {} ({:?} + t {:?}, {test:?}): packet {p:?}, single {single:?}",
                rays.len(),
                r.origin,
                r.dir
            );
        }
    }
}

fn object(mesh: &str, at: (f32, f32, f32), rotate_deg: (f32, f32, f32), scale: f32) -> Object {
    Object {
        mesh: mesh.into(),
        material: None,
        translate_mm: at,
        rotate_deg,
        scale_mm: scale,
        importance: 1.0,
        motion: None,
    }
}

fn scene_of(meshes: Vec<(String, MeshSource)>, objects: Vec<Object>) -> Scene {
    let file = SceneFile {
        name: "t".into(),
        background: (0.0, 0.0, 0.0),
        meshes: meshes.into_iter().collect(),
        materials: Default::default(),
        objects,
        lights: vec![],
        sampling: None,
        passes: None,
        effects: None,
        crease_deg: None,
        depth_jump: None,
        camera: None,
    };
    Scene::build(&file, std::path::Path::new(".")).expect("scene")
}

/// A soup of one-triangle meshes.
fn soup(tris: &[[(f32, f32, f32); 3]]) -> Scene {
    let meshes = tris
        .iter()
        .enumerate()
        .map(|(i, t)| {
            (
                format!("t{i}"),
                MeshSource::Triangle {
                    a: t[0],
                    b: t[1],
                    c: t[2],
                },
            )
        })
        .collect();
    let objects = (0..tris.len())
        .map(|i| object(&format!("t{i}"), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0))
        .collect();
    scene_of(meshes, objects)
}

fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -10.0f32..10.0,
        1 => Just(0.0f32),
        1 => (-3i32..=3).prop_map(|v| v as f32),
    ]
}

fn point() -> impl Strategy<Value = (f32, f32, f32)> {
    (coord(), coord(), coord())
}

/// A triangle; one in five repeats a corner (zero area).
fn triangle() -> impl Strategy<Value = [(f32, f32, f32); 3]> {
    (point(), point(), point(), 0..5u8).prop_map(|(a, b, c, k)| match k {
        0 => [a, b, a],
        _ => [a, b, c],
    })
}

/// A direction component: ordinary, or one of the awkward values.
fn component() -> impl Strategy<Value = f32> {
    prop_oneof![
        12 => -1.0f32..1.0,
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(1e-30f32),
        1 => Just(-1e-38f32),
        1 => Just(1e30f32),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(300), failure_persistence: None, ..ProptestConfig::default() })]

    /// Rays fanning out from one eye through a small patch (what a row of
    /// pixels casts), some with awkward components, through a soup.
    #[test]
    fn coherent_packets_match_single_rays(
        tris in prop::collection::vec(triangle(), 1..40),
        eye in point(),
        towards in point(),
        spread in 0.0f32..0.3,
        n in 1usize..30,
        odd in prop::collection::vec((0usize..30, 0usize..3, component()), 0..4),
        t_min in prop_oneof![4 => Just(0.0f32), 1 => 0.0f32..3.0, 1 => Just(-1.0f32)],
    ) {
        let scene = soup(&tris);
        let eye = Vec3::from(eye);
        let base = Vec3::from(towards) - eye;
        let mut rays: Vec<Ray> = (0..n)
            .map(|k| Ray::new(eye, base + Vec3::new(spread * k as f32 / n as f32, 0.0, 0.0)))
            .collect();
        for (k, axis, v) in odd {
            if let Some(r) = rays.get_mut(k) {
                let mut d = r.dir;
                d[axis] = v;
                *r = Ray::new(r.origin, d);
            }
        }
        assert_same(&scene, &rays, t_min);
    }

    /// Unrelated rays (origins and directions at random) in one packet.
    #[test]
    fn incoherent_packets_match_single_rays(
        tris in prop::collection::vec(triangle(), 1..40),
        rays in prop::collection::vec((point(), (component(), component(), component())), 1..20),
    ) {
        let scene = soup(&tris);
        let rays: Vec<Ray> = rays
            .into_iter()
            .map(|(o, d)| Ray::new(Vec3::from(o), Vec3::from(d)))
            .collect();
        assert_same(&scene, &rays, 0.0);
    }

    /// Rays from one eye aimed exactly at corners and edge points of a
    /// closed mesh's triangles: two or more triangles meet there at the
    /// same distance, so the first found would win — the packets' ties
    /// go to the single-ray path.
    #[test]
    fn rays_through_shared_vertices_and_edges_match(
        torus in any::<bool>(),
        rot in (0.0f32..360.0, 0.0f32..360.0),
        eye in ((-3.0f32..3.0), (-3.0f32..3.0), (3.0f32..8.0)),
        picks in prop::collection::vec((any::<prop::sample::Index>(), 0usize..3, prop_oneof![Just(0.0f32), Just(0.5f32), 0.0f32..1.0]), 8..40),
    ) {
        let mesh = if torus {
            MeshSource::Torus { major_radius: 0.7, minor_radius: 0.3, segments: 24, sides: 12 }
        } else {
            MeshSource::Icosphere { subdivisions: 2 }
        };
        let scene = scene_of(
            vec![("m".into(), mesh)],
            vec![object("m", (0.0, 0.0, 0.0), (rot.0, rot.1, 0.0), 1.0)],
        );
        let eye = Vec3::from(eye);
        let rays: Vec<Ray> = picks
            .iter()
            .map(|(i, k, s)| {
                let t = &scene.triangles[i.index(scene.triangles.len())];
                let target = t.p[*k].lerp(t.p[(*k + 1) % 3], *s);
                Ray::new(eye, target - eye)
            })
            .collect();
        assert_same(&scene, &rays, 0.0);
    }
}

#[test]
fn an_empty_scene_misses_every_ray_of_a_packet() {
    let scene = scene_of(vec![], vec![]);
    let rays: Vec<Ray> = (0..11)
        .map(|k| Ray::new(Vec3::ZERO, Vec3::new(k as f32 - 5.0, 0.3, -1.0)))
        .collect();
    let mut out = vec![
        Some(Hit {
            t: 1.0,
            object: 0,
            triangle: 0,
            normal: Vec3::Z
        });
        rays.len()
    ];
    scene.intersect_packet(&rays, 0.0, TriangleTest::Watertight, &mut out);
    assert!(out.iter().all(Option::is_none));
    assert_same(&scene, &rays, 0.0);
}

#[test]
fn an_empty_packet_and_short_outputs_are_handled() {
    let scene = common::load("search-task");
    scene.intersect_packet(&[], 0.0, TriangleTest::Watertight, &mut []);
    let rays = [Ray::new(Vec3::new(0.0, 0.0, 540.0), Vec3::new(0.0, 0.01, -1.0)); 5];
    let mut out = [None; 3];
    scene.intersect_packet(&rays, 0.0, TriangleTest::Watertight, &mut out);
    let single = bits(scene.intersect(&rays[0], 0.0, TriangleTest::Watertight));
    assert!(out.iter().all(|h| bits(*h) == single));
}

/// Every camera ray of every 9th row of the shipped scenes, row by row
/// in packets as the renderer casts them.
#[test]
fn shipped_scenes_camera_rays_match() {
    for name in ["room", "search-task", "stress"] {
        let scene = common::load(name);
        let g = common::display(640, 512).geometry().expect("geometry");
        let cam = Camera::new(&g);
        for y in (0..g.height_px).step_by(9) {
            let rays: Vec<Ray> = (0..g.width_px).map(|x| cam.pixel_ray(x, y)).collect();
            let mut out = vec![None; rays.len()];
            scene.intersect_packet(&rays, 0.0, TriangleTest::Watertight, &mut out);
            for (x, (r, p)) in rays.iter().zip(&out).enumerate() {
                let single = scene.intersect(r, 0.0, TriangleTest::Watertight);
                assert_eq!(bits(*p), bits(single), "{name}: pixel ({x}, {y})");
            }
        }
    }
}

/// A full frame (cast in packets) holds, at every pixel, what a single
/// ray through the pixel centre hits: object, distance and normal.
#[test]
fn a_full_frame_is_the_single_rays_frame() {
    let scene = common::load("room");
    let g = common::display(320, 256).geometry().expect("geometry");
    let cam = Camera::new(&g);
    let model = foveation::SamplingModel::new(g, foveation::GeislerPerry::default(), 1.0, 17.0)
        .expect("model");
    let settings = Settings {
        mode: Mode::Full,
        layout: foveation::Layout::Nyquist,
        triggers: Triggers::from_scene(&scene),
        test: TriangleTest::Watertight,
        check_coverage: false,
    };
    let (frame, _) = render(&scene, &cam, &model, &settings, [160.0, 128.0]).expect("frame");
    for y in 0..g.height_px {
        for x in 0..g.width_px {
            let p = [x as f32 + 0.5, y as f32 + 0.5];
            let i = (y * g.width_px + x) as usize;
            let hit = scene
                .intersect(&cam.ray(p), 0.0, TriangleTest::Watertight)
                .expect("the room fills the screen");
            let depth = hit.t * (cam.screen_point(p) - cam.eye).length();
            assert_eq!(frame.object[i], hit.object, "({x}, {y})");
            assert_eq!(frame.depth_mm[i].to_bits(), depth.to_bits(), "({x}, {y})");
            assert_eq!(frame.normal[i], hit.normal.to_array(), "({x}, {y})");
        }
    }
}

/// `Scene::traversal_steps` (what `trace_rays` reports per ray): a ray
/// that hits the room walks at least one node and tests at least the
/// triangle it hits; a ray with a zero direction component walks the
/// binary BVH and is not counted; a ray that misses the root box costs no
/// node.
#[test]
fn traversal_steps_count_a_walk() {
    let scene = common::load("room");
    let g = common::display(64, 48).geometry().expect("geometry");
    let cam = Camera::new(&g);
    let ray = cam.pixel_ray(32, 24);
    assert!(scene
        .intersect(&ray, 0.0, TriangleTest::Watertight)
        .is_some());
    let (nodes, tris) = scene.traversal_steps(&ray).expect("not parallel");
    assert!(nodes >= 1 && tris >= 1, "{nodes} nodes, {tris} triangles");
    let parallel = Ray::new(ray.origin, Vec3::new(0.0, 0.0, -1.0));
    assert_eq!(scene.traversal_steps(&parallel), None);
    let away = Ray::new(Vec3::splat(1.0e6), Vec3::new(1.0, 1.0, 1.0));
    assert_eq!(scene.traversal_steps(&away), Some((0, 0)));
}
