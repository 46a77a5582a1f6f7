//! Open meshes: flat objects (one triangle, a quad, a planar polygon, a
//! planar grid) at any orientation — facing the eye, tilted, edge-on, seen
//! from behind — keep what they cover under the Luebke–Hallen modes. An
//! open mesh's outline is its border, whatever its normals, so folding the
//! border exposes the background (a silhouette fold, L&H §5.2).

mod common;

use common::{table, Mesh};
use glam::{Mat3, Vec2, Vec3};
use lod::{Cut, Mode, VertexTree, View};
use proptest::prelude::*;

/// A planar shape in its own (u, v) plane: its 2-D corners and triangles.
#[derive(Debug, Clone)]
enum Shape {
    /// k corners on a circle, fanned from corner 0 (k = 3: one triangle,
    /// k = 4: a quad).
    Polygon(u32),
    /// An n × n grid of squares, two triangles each.
    Grid(u32),
}

fn shape_2d(shape: &Shape) -> (Vec<Vec2>, Vec<[u32; 3]>) {
    match *shape {
        Shape::Polygon(k) => {
            let p = (0..k)
                .map(|i| {
                    let a = std::f32::consts::TAU * i as f32 / k as f32;
                    Vec2::new(a.cos(), a.sin())
                })
                .collect();
            let t = (1..k - 1).map(|i| [0, i, i + 1]).collect();
            (p, t)
        }
        Shape::Grid(n) => {
            let mut p = Vec::new();
            for j in 0..=n {
                for i in 0..=n {
                    p.push(Vec2::new(i as f32, j as f32) * (2.0 / n as f32) - Vec2::ONE);
                }
            }
            let id = |i: u32, j: u32| j * (n + 1) + i;
            let mut t = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                    t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
            (p, t)
        }
    }
}

/// The shape placed `distance_mm` in front of an eye at the origin looking
/// down −z, `half_mm` from its centre to a corner, turned `tilt_deg` about
/// the x axis (0: facing the eye, 90: edge-on, 180: its back to the eye),
/// uniform luminance. Returns the mesh and the plane's 2-D frame.
fn place(shape: &Shape, distance_mm: f32, half_mm: f32, tilt_deg: f32, lum: f32) -> (Mesh, Mat3) {
    let (p2, tris) = shape_2d(shape);
    let rot = Mat3::from_rotation_x(tilt_deg.to_radians());
    let centre = Vec3::new(0.0, 0.0, -distance_mm);
    let normal = rot * Vec3::Z;
    let mut m = Mesh::default();
    for p in &p2 {
        let local = Vec3::new(p.x, p.y, 0.0) * half_mm;
        m.push_vertex(centre + rot * local, normal, lum);
    }
    m.triangles = tris;
    (m, rot)
}

/// Barycentric sample points of the full mesh's triangles, in the plane's
/// 2-D coordinates, and the fraction of them that the cut's triangles cover.
fn coverage(full: &[[Vec3; 3]], drawn: &[[Vec3; 3]], rot: Mat3, centre: Vec3) -> f64 {
    let to_2d = |p: Vec3| {
        let l = rot.transpose() * (p - centre);
        Vec2::new(l.x, l.y)
    };
    let drawn: Vec<[Vec2; 3]> = drawn.iter().map(|t| t.map(to_2d)).collect();
    let inside = |q: Vec2, t: &[Vec2; 3]| {
        let s = |a: Vec2, b: Vec2| (b - a).perp_dot(q - a);
        let (d0, d1, d2) = (s(t[0], t[1]), s(t[1], t[2]), s(t[2], t[0]));
        let tol = 1e-4 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        (d0 >= -tol && d1 >= -tol && d2 >= -tol) || (d0 <= tol && d1 <= tol && d2 <= tol)
    };
    let (mut covered, mut total) = (0usize, 0usize);
    for t in full {
        let t = t.map(to_2d);
        for (a, b) in [(0.2, 0.2), (0.6, 0.2), (0.2, 0.6), (1.0 / 3.0, 1.0 / 3.0)] {
            let q = t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b;
            total += 1;
            covered += usize::from(drawn.iter().any(|d| inside(q, d)));
        }
    }
    covered as f64 / total as f64
}

fn tree_of(m: &Mesh) -> VertexTree {
    m.tree().expect("tree")
}

#[test]
fn a_single_triangle_facing_the_eye_is_drawn_in_every_mode() {
    // 10° across at 500 mm, uniform luminance: no interior contrast at all,
    // so only the outline (the border against the background) can keep it.
    let (m, _) = place(&Shape::Polygon(3), 500.0, 44.0, 0.0, 40.0);
    let tree = tree_of(&m);
    assert!(tree.on_outline(tree.root()));
    let t = table();
    for gaze in [None, Some(Vec3::new(0.0, 0.0, -500.0))] {
        let view = View {
            eye_mm: Vec3::ZERO,
            gaze_point_mm: gaze,
            thresholds: &t,
            scene_contrast: 0.8,
        };
        for mode in [
            Mode::Imperceptible,
            Mode::Budget { triangles: 1 },
            Mode::Budget { triangles: 1000 },
            Mode::murphy_duchowski(),
        ] {
            let mut cut = Cut::new(&tree);
            let r = cut.select(&view, &mode).expect("select");
            assert_eq!(r.triangles, 1, "{mode:?}, gaze {gaze:?}");
        }
    }
}

#[test]
fn a_closed_mesh_has_no_outline_and_an_open_one_has_it_only_at_its_border() {
    let closed = common::torus(12, 8, 60.0, 20.0, Vec3::ZERO);
    let tree = tree_of(&closed);
    assert!((0..tree.node_count() as u32).all(|v| !tree.on_outline(v)));
    // A flat 6×6 grid: the 24 border vertices and every node above one.
    let (m, _) = place(&Shape::Grid(6), 500.0, 50.0, 0.0, 40.0);
    let tree = tree_of(&m);
    let border = |v: u32| {
        let p = m.positions[v as usize];
        let l = Vec2::new(p.x, p.y) / 50.0;
        l.x.abs() > 0.999 || l.y.abs() > 0.999
    };
    for v in 0..m.positions.len() as u32 {
        assert_eq!(tree.on_outline(tree.leaf(v)), border(v), "vertex {v}");
    }
    for node in 0..tree.node_count() as u32 {
        let below = (0..m.positions.len() as u32).any(|v| tree.supports(node, v) && border(v));
        assert_eq!(tree.on_outline(node), below, "node {node}");
    }
    // Welding: the same grid as a soup of separate triangles has the same
    // outline (duplicated corners are welded before edges are counted): a
    // node holding every copy of a border vertex is on it, a node holding
    // no border vertex is not.
    let soup = common::soup(&m);
    let tree = tree_of(&soup);
    let soup_border = |v: u32| {
        let p = soup.positions[v as usize];
        let l = Vec2::new(p.x, p.y) / 50.0;
        l.x.abs() > 0.999 || l.y.abs() > 0.999
    };
    let n = soup.positions.len() as u32;
    for node in 0..tree.node_count() as u32 {
        let held: Vec<u32> = (0..n).filter(|&v| tree.supports(node, v)).collect();
        if !held.iter().any(|&v| soup_border(v)) {
            assert!(!tree.on_outline(node), "node {node}");
        }
        let holds_a_whole_border_vertex = held.iter().any(|&v| {
            soup_border(v)
                && (0..n)
                    .filter(|&w| soup.positions[w as usize] == soup.positions[v as usize])
                    .all(|w| tree.supports(node, w))
        });
        if holds_a_whole_border_vertex {
            assert!(tree.on_outline(node), "node {node}");
        }
    }
}

fn arb_shape() -> impl Strategy<Value = Shape> {
    prop_oneof![
        (3u32..=16).prop_map(Shape::Polygon),
        (1u32..=8).prop_map(Shape::Grid),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(96)))]

    /// A flat object of uniform luminance, 1° to 30° across, at any tilt
    /// (facing, tilted, exactly edge-on, from behind), with or without the
    /// gaze on it, keeps at least 90 % of what it covers in the plane
    /// under the imperceptible mode and under a budget that holds it.
    #[test]
    fn flat_objects_keep_what_they_cover(
        shape in arb_shape(),
        distance_mm in 200.0f32..3000.0,
        extent_deg in 1.0f32..30.0,
        tilt_deg in prop_oneof![Just(0.0f32), Just(90.0), Just(180.0), 0.0f32..180.0],
        lum in 1.0f32..200.0,
        scene_contrast in 0.3f64..1.0,
        gaze in prop::option::of((-3.0f32..3.0, -3.0f32..3.0)),
    ) {
        let half_mm = distance_mm * (extent_deg.to_radians() / 2.0).tan();
        let (m, rot) = place(&shape, distance_mm, half_mm, tilt_deg, lum);
        let tree = tree_of(&m);
        let t = table();
        let centre = Vec3::new(0.0, 0.0, -distance_mm);
        let view = View {
            eye_mm: Vec3::ZERO,
            // Gaze within a few degrees of the object's centre.
            gaze_point_mm: gaze.map(|(x, y)| {
                Vec3::new(x.to_radians().tan(), y.to_radians().tan(), -1.0) * distance_mm
            }),
            thresholds: &t,
            scene_contrast,
        };
        let full = Cut::new(&tree).triangles();
        for mode in [
            Mode::Imperceptible,
            Mode::Budget { triangles: m.triangles.len() },
        ] {
            let mut cut = Cut::new(&tree);
            cut.select(&view, &mode).expect("select");
            let c = coverage(&full, &cut.triangles(), rot, centre);
            prop_assert!(
                c >= 0.9,
                "{:?} {:?}: covers {:.1} % of the object ({} of {} triangles)",
                shape, mode, 100.0 * c, cut.active_triangle_count(), full.len()
            );
        }
    }
}
