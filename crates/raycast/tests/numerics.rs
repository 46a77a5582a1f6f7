//! Watertightness and numerically hard cases of the intersection code.

use std::collections::HashMap;

use glam::Vec3;
use proptest::prelude::*;
use raycast::mesh::TriangleMesh;
use raycast::ray::{moller_trumbore, watertight, Aabb, Ray, TriangleTest, WatertightRay};
use raycast::scene::{MeshSource, Object};
use raycast::{Scene, SceneFile};

/// For each vertex, the triangles around it.
fn fans(m: &TriangleMesh) -> HashMap<u32, Vec<usize>> {
    let mut f: HashMap<u32, Vec<usize>> = HashMap::new();
    for (t, tri) in m.indices.iter().enumerate() {
        for &v in tri {
            f.entry(v).or_default().push(t);
        }
    }
    f
}

fn scene_of(
    mesh: MeshSource,
    scale: f32,
    at: (f32, f32, f32),
    rotate_deg: (f32, f32, f32),
) -> Scene {
    let file = SceneFile {
        name: "t".into(),
        background: (0.0, 0.0, 0.0),
        meshes: [("m".to_string(), mesh)].into_iter().collect(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "m".into(),
            material: None,
            translate_mm: at,
            rotate_deg,
            scale_mm: scale,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![],
        sampling: None,
        passes: None,
        effects: Some(vec![]),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, std::path::Path::new(".")).expect("scene")
}

/// Rays through points on shared edges (or exactly at vertices) of a
/// closed mesh, from 5 units away. Only rays that cross the surface there are
/// kept: every triangle around the edge's two ends faces the ray at more than
/// ~6° from grazing. (A ray that only touches a silhouette vertex or edge may
/// be reported either way; watertightness is about rays that cross.)
fn edge_rays(m: &TriangleMesh, n: usize, seed: u64) -> Vec<(Vec3, Vec3, u32, u32)> {
    let fan = fans(m);
    let face = |t: usize| {
        let [a, b, c] = m.triangle(t);
        (b - a).cross(c - a).normalize_or_zero()
    };
    let mut x = seed | 1;
    let mut rnd = move || {
        for _ in 0..2 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
        }
        (x >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let t = (rnd() * m.indices.len() as f32) as usize % m.indices.len();
        let tri = m.indices[t];
        let k = (rnd() * 3.0) as usize % 3;
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let s = if rnd() < 0.2 { 0.0 } else { rnd() };
        let target = m.positions[a as usize].lerp(m.positions[b as usize], s);
        let dir = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize_or_zero();
        let dots: Vec<f32> = fan[&a]
            .iter()
            .chain(&fan[&b])
            .map(|&f| face(f).dot(dir))
            .collect();
        let crossing = dots.iter().all(|d| *d > 0.1) || dots.iter().all(|d| *d < -0.1);
        if crossing {
            out.push((target + dir * 5.0, target, a, b));
        }
    }
    out
}

proptest! {
    // 1000 cases × 1000 rays = 10^6 rays at shared edges and vertices.
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(1000), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn rays_at_shared_edges_and_vertices_never_slip_through(seed in any::<u64>(), torus in any::<bool>()) {
        let m = if torus { TriangleMesh::torus(1.0, 0.35, 40, 20, "torus").expect("torus") } else { TriangleMesh::icosphere(3) };
        let fan = fans(&m);
        for (origin, target, a, b) in edge_rays(&m, 1000, seed) {
            let ray = Ray::new(origin, target - origin);
            let w = WatertightRay::new(&ray);
            // Every triangle around either end of the edge.
            let hit = fan[&a].iter().chain(&fan[&b]).any(|&i| {
                let [p0, p1, p2] = m.triangle(i);
                watertight(&w, p0, p1, p2, 0.0, 2.0).is_some()
            });
            prop_assert!(hit, "ray from {:?} to {:?} slipped through", origin, target);
        }
    }
}

#[test]
fn rays_through_the_bvh_at_edges_hit_closed_meshes_even_near_1e6() {
    for (mesh, source, scale, at) in [
        (
            TriangleMesh::icosphere(4),
            MeshSource::Icosphere { subdivisions: 4 },
            1.0,
            (0.0, 0.0, 0.0),
        ),
        (
            TriangleMesh::torus(1.0, 0.3, 64, 24, "torus").expect("torus"),
            MeshSource::Torus {
                major_radius: 1.0,
                minor_radius: 0.3,
                segments: 64,
                sides: 24,
            },
            500.0,
            (1e6, -1e6, 5e5),
        ),
    ] {
        let scene = scene_of(source, scale, at, (0.0, 0.0, 0.0));
        let offset = Vec3::new(at.0, at.1, at.2);
        let world = |p: Vec3| p * scale + offset;
        let mut misses = 0;
        for (origin, target, _, _) in edge_rays(&mesh, 100_000, 99) {
            let (o, t) = (world(origin), world(target));
            if scene
                .intersect(&Ray::new(o, t - o), 0.0, TriangleTest::Watertight)
                .is_none()
            {
                misses += 1;
            }
        }
        assert_eq!(misses, 0, "mesh at {at:?}");
    }
}

#[test]
fn rays_parallel_to_slabs_and_planes_are_handled() {
    let b = Aabb {
        min: Vec3::splat(-1.0),
        max: Vec3::splat(1.0),
    };
    for (o, d, hit) in [
        (Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 1.0), true),
        (Vec3::new(2.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 1.0), false),
        (
            Vec3::new(-2.0, 0.0, -5.0),
            Vec3::new(-0.0, -0.0, 1.0),
            false,
        ),
        (Vec3::new(1.0, 1.0, -5.0), Vec3::new(0.0, 0.0, 1.0), true),
        (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), true),
    ] {
        assert_eq!(
            b.hit(&Ray::new(o, d), f32::INFINITY).is_some(),
            hit,
            "{o:?} {d:?}"
        );
    }
    // A ray in the plane of a triangle never hits it and never yields NaN.
    let (p0, p1, p2) = (Vec3::ZERO, Vec3::X, Vec3::Y);
    let ray = Ray::new(Vec3::new(-1.0, 0.2, 0.0), Vec3::X);
    assert!(watertight(&WatertightRay::new(&ray), p0, p1, p2, 0.0, 10.0).is_none());
    assert!(moller_trumbore(&ray, p0, p1, p2, 0.0, 10.0).is_none());
}

#[test]
fn a_ray_starting_on_a_surface_reports_the_next_surface_with_t_min() {
    let scene = scene_of(
        MeshSource::Icosphere { subdivisions: 3 },
        10.0,
        (0.0, 0.0, 0.0),
        (10.0, 20.0, 30.0),
    );
    let first = scene
        .intersect(
            &Ray::new(Vec3::new(0.0, 0.0, 50.0), Vec3::new(0.0, 0.0, -1.0)),
            0.0,
            TriangleTest::Watertight,
        )
        .expect("front");
    let on = Vec3::new(0.0, 0.0, 50.0 - first.t);
    let ray = Ray::new(on, Vec3::new(0.0, 0.0, -1.0));
    let next = scene
        .intersect(&ray, 1e-3, TriangleTest::Watertight)
        .expect("back wall");
    assert!(
        next.t.is_finite() && next.t > 15.0 && next.t < 20.5,
        "{}",
        next.t
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(2000), failure_persistence: None, ..ProptestConfig::default() })]

    /// Tiny triangles (1e-6), huge coordinates (1e6), degenerate and random
    /// rays: results are finite, within range, and both tests agree on clear hits.
    #[test]
    fn intersection_is_finite_for_tiny_huge_and_degenerate_input(
        scale in prop_oneof![Just(1e-6f32), Just(1.0f32), Just(1e3f32)],
        offset in prop_oneof![Just(0.0f32), Just(1e6f32), Just(-1e6f32)],
        a in (-1.0f32..1.0, -1.0f32..1.0), b in (-1.0f32..1.0, -1.0f32..1.0), c in (-1.0f32..1.0, -1.0f32..1.0),
        o in (-1.0f32..1.0, -1.0f32..1.0), dz in prop_oneof![Just(0.0f32), -1.0f32..-0.1],
    ) {
        let base = Vec3::new(offset, offset, offset);
        let v = |p: (f32, f32)| base + Vec3::new(p.0, p.1, 0.0) * scale;
        let (p0, p1, p2) = (v(a), v(b), v(c));
        let ray = Ray::new(base + Vec3::new(o.0 * scale, o.1 * scale, 10.0 * scale), Vec3::new(0.0, 0.0, dz));
        let w = watertight(&WatertightRay::new(&ray), p0, p1, p2, 0.0, f32::INFINITY);
        let m = moller_trumbore(&ray, p0, p1, p2, 0.0, f32::INFINITY);
        for h in [w, m].into_iter().flatten() {
            prop_assert!(h.t.is_finite() && h.t > 0.0 && h.u.is_finite() && h.v.is_finite());
        }
        if dz == 0.0 {
            prop_assert!(w.is_none(), "a ray parallel to the plane hit it");
        }
    }
}

#[test]
fn the_seeds_uniform_grid_finds_the_same_hits_as_the_bvh() {
    let file: SceneFile = ron::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/scenes/search-task.ron"
        ))
        .expect("scene"),
    )
    .expect("parse");
    let bvh_scene = Scene::build(&file, std::path::Path::new(".")).expect("build");
    let mut grid_scene = bvh_scene.clone();
    grid_scene.build_grid();
    let grid = grid_scene.grid.as_ref().expect("grid built");
    assert!(
        grid.max_bin <= raycast::grid::BIN_SIZE,
        "max bin {} over the seed's 40",
        grid.max_bin
    );
    let mut x = 0xDEAD_BEEFu64;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32
    };
    let eye = Vec3::new(0.0, 0.0, 540.0);
    let (mut hits, mut disagree) = (0, 0);
    for _ in 0..50_000 {
        let target = Vec3::new((rnd() - 0.5) * 240.0, (rnd() - 0.5) * 240.0, 0.0);
        let ray = Ray::new(eye, target - eye);
        let a = bvh_scene.intersect(&ray, 0.0, TriangleTest::Watertight);
        let b = grid_scene.intersect(&ray, 0.0, TriangleTest::Watertight);
        match (a, b) {
            (Some(a), Some(b)) => {
                hits += 1;
                if (a.t - b.t).abs() > 1e-5 * a.t {
                    disagree += 1;
                }
            }
            (None, None) => {}
            _ => disagree += 1,
        }
    }
    assert!(hits > 5_000, "{hits}");
    assert_eq!(disagree, 0);
}
