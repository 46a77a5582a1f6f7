//! The vertex tree: input validation, awkward meshes, and the structural
//! invariants every tree must satisfy.

mod common;

use common::{concat, grid, soup, torus, Mesh};
use glam::Vec3;
use lod::{BuildOptions, Cut, LodError, VertexTree};
use proptest::prelude::*;

/// Every property the crate docs promise of a tree.
fn check_invariants(mesh: &Mesh, tree: &VertexTree) {
    let n = mesh.positions.len();
    assert_eq!(tree.leaf_count(), n);
    assert_eq!(tree.node_count(), 2 * n - 1, "binary merges, one root");
    let root = tree.root();
    assert_eq!(tree.parent(root), None);
    assert_eq!(tree.depth(root), 0);
    assert_eq!(tree.leaves_below(root), n);
    for v in 0..tree.node_count() as u32 {
        if v != root {
            let p = tree.parent(v).expect("only the root has no parent");
            assert!(p < v, "pre-order: parents come before their children");
            assert!(tree.children(p).unwrap().contains(&v));
            assert_eq!(tree.depth(v), tree.depth(p) + 1);
            // Monotone node data: the parent's sphere holds the child's,
            // its luminance range and normal mask contain the child's, so
            // its fold contrast is at least the child's.
            let (ps, cs) = (tree.bounding_sphere(p), tree.bounding_sphere(v));
            assert!(
                ps.contains_sphere(&cs, 1e-6),
                "sphere of {p} ⊉ sphere of {v}"
            );
            let ((plo, phi), (clo, chi)) = (tree.luminance_range(p), tree.luminance_range(v));
            assert!(plo <= clo && phi >= chi);
            assert!(tree.normal_mask(p).contains(tree.normal_mask(v)));
            assert!(tree.fold_contrast(p) >= tree.fold_contrast(v));
        }
        if let Some([a, b]) = tree.children(v) {
            assert_eq!(
                tree.leaves_below(v),
                tree.leaves_below(a) + tree.leaves_below(b)
            );
        } else {
            let vertex = tree.vertex(v).expect("a leaf has a vertex");
            assert_eq!(tree.leaf(vertex), v);
            assert_eq!(tree.proxy_position(v), mesh.positions[vertex as usize]);
            assert_eq!(tree.fold_contrast(v), 0.0);
        }
        let (lo, hi) = tree.luminance_range(v);
        let c = tree.fold_contrast(v);
        let want = if lo + hi > 0.0 {
            (hi - lo) / (hi + lo)
        } else {
            0.0
        };
        assert!((c - want).abs() <= 1e-6, "Michelson contrast of {v}");
        assert!(tree
            .bounding_sphere(v)
            .contains_point(tree.proxy_position(v), 1e-6));
    }
    // Bounding spheres contain their region of support: every corner of
    // every triangle touching any leaf below.
    let mut sub_count = vec![0usize; mesh.triangles.len()];
    for v in 0..tree.node_count() as u32 {
        for &t in tree.subtris(v) {
            sub_count[t as usize] += 1;
            assert_eq!(tree.vanishing_node(t), Some(v));
        }
    }
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let distinct = tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2];
        assert_eq!(
            sub_count[t],
            usize::from(distinct),
            "triangle {t} in one subtri list"
        );
        if !distinct {
            assert_eq!(tree.vanishing_node(t as u32), None);
            continue;
        }
        for &corner in tri {
            let mut x = Some(tree.leaf(corner));
            while let Some(node) = x {
                let s = tree.bounding_sphere(node);
                for &w in tri {
                    assert!(
                        s.contains_point(mesh.positions[w as usize], 1e-6),
                        "sphere of node {node} misses corner {w} of triangle {t}"
                    );
                }
                x = tree.parent(node);
            }
        }
        // The vanishing node is where two corners first meet.
        let s = tree.vanishing_node(t as u32).unwrap();
        let held = |node| tri.iter().filter(|&&c| tree.supports(node, c)).count();
        assert!(held(s) >= 2);
        for c in tree.children(s).unwrap() {
            assert!(held(c) <= 1, "triangle {t} already degenerate in child {c}");
        }
    }
    // Normal masks: each leaf holds the cells of its triangles' normals.
    for tri in &mesh.triangles {
        let p = tri.map(|v| mesh.positions[v as usize].as_dvec3());
        let nrm = (p[1] - p[0]).cross(p[2] - p[0]);
        if nrm.length() > 1e-9 {
            let mut m = lod::NormalMask::default();
            m.insert(nrm.normalize());
            for &v in tri {
                assert!(tree.normal_mask(tree.leaf(v)).contains(&m));
            }
        }
    }
}

#[test]
fn an_index_out_of_range_names_the_triangle_and_the_vertex_count() {
    let mut m = grid(6, 3, 10.0); // 28 vertices, 36 triangles
    m.positions.extend([Vec3::ONE; 22]);
    m.normals.extend([Vec3::Z; 22]);
    m.luminance.extend([1.0; 22]);
    m.triangles[12][1] = 99;
    let e = m.tree().unwrap_err();
    assert_eq!(
        e.to_string(),
        "triangle 12 has index 99 ≥ 50 vertices (corner 1)"
    );
}

#[test]
fn bad_inputs_are_errors_that_say_where() {
    let m = grid(2, 2, 1.0);
    let mut bad = m.clone();
    bad.positions[4].y = f32::NAN;
    assert!(matches!(
        bad.tree(),
        Err(LodError::NonFinite {
            what: "position",
            index: 4,
            ..
        })
    ));
    let mut bad = m.clone();
    bad.normals[2] = Vec3::splat(f32::INFINITY);
    assert!(matches!(
        bad.tree(),
        Err(LodError::NonFinite {
            what: "normal",
            index: 2,
            ..
        })
    ));
    let mut bad = m.clone();
    bad.luminance[3] = -1.0;
    assert!(matches!(
        bad.tree(),
        Err(LodError::NegativeLuminance { index: 3, .. })
    ));
    let mut bad = m.clone();
    bad.luminance[3] = f32::NAN;
    assert!(matches!(
        bad.tree(),
        Err(LodError::NonFinite {
            what: "luminance",
            ..
        })
    ));
    let mut bad = m.clone();
    bad.normals.pop();
    let e = bad.tree().unwrap_err();
    assert_eq!(
        e,
        LodError::LengthMismatch {
            what: "normals",
            expected: 9,
            got: 8
        }
    );
    assert!(e
        .to_string()
        .contains("normals has 8 entries but there are 9 vertices"));
    assert_eq!(
        VertexTree::build(&[], &[], &[], &[]).unwrap_err(),
        LodError::EmptyMesh
    );
}

#[test]
fn the_size_cap_is_checked_before_building() {
    let m = grid(3, 3, 1.0); // 16 vertices, 18 triangles
    let small = BuildOptions {
        max_vertices: 15,
        max_triangles: 100,
    };
    let e = VertexTree::build_with(&m.positions, &m.normals, &m.luminance, &m.triangles, &small)
        .unwrap_err();
    assert!(
        matches!(
            e,
            LodError::TooLarge {
                what: "vertices",
                count: 16,
                max: 15,
                ..
            }
        ),
        "{e}"
    );
    let small = BuildOptions {
        max_vertices: 100,
        max_triangles: 17,
    };
    let e = VertexTree::build_with(&m.positions, &m.normals, &m.luminance, &m.triangles, &small)
        .unwrap_err();
    assert!(e.to_string().contains("max_triangles"), "{e}");
}

#[test]
fn a_single_triangle_folds_away_at_one_node() {
    let mut m = Mesh::default();
    m.push_vertex(Vec3::ZERO, Vec3::Z, 10.0);
    m.push_vertex(Vec3::X, Vec3::Z, 20.0);
    m.push_vertex(Vec3::Y, Vec3::Z, 30.0);
    m.triangles.push([0, 1, 2]);
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
    assert_eq!(tree.node_count(), 5);
    let s = tree.vanishing_node(0).unwrap();
    assert_eq!(tree.subtris(s), &[0]);
    let root = tree.root();
    assert_eq!(tree.luminance_range(root), (10.0, 30.0));
    assert!((tree.fold_contrast(root) - 0.5).abs() < 1e-6);
}

#[test]
fn degenerate_and_zero_area_triangles() {
    let mut m = grid(3, 3, 4.0);
    let n = m.positions.len() as u32;
    // Repeated indices: dropped, never drawn.
    m.triangles.push([0, 0, 5]);
    m.triangles.push([7, 7, 7]);
    // Three collinear vertices: zero area but a real triangle, kept.
    let a = m.push_vertex(Vec3::new(10.0, 0.0, 0.0), Vec3::Z, 5.0);
    let b = m.push_vertex(Vec3::new(11.0, 0.0, 0.0), Vec3::Z, 5.0);
    let c = m.push_vertex(Vec3::new(12.0, 0.0, 0.0), Vec3::Z, 5.0);
    assert_eq!(a, n);
    m.triangles.push([a, b, c]);
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
    assert_eq!(tree.drawable_triangle_count(), m.triangles.len() - 2);
    assert_eq!(tree.vanishing_node(18), None);
    assert_eq!(tree.vanishing_node(19), None);
    assert!(tree.vanishing_node(20).is_some());
    let cut = Cut::new(&tree);
    assert_eq!(cut.active_triangle_count(), tree.drawable_triangle_count());
    // A zero-area triangle sets no normal-mask bit.
    assert!(tree.normal_mask(tree.leaf(b)).is_empty());
}

#[test]
fn non_manifold_edges_are_fine() {
    // Three fins on the edge (0,1), plus a fourth sharing vertex 0 only.
    let mut m = Mesh::default();
    m.push_vertex(Vec3::ZERO, Vec3::X, 10.0);
    m.push_vertex(Vec3::Z, Vec3::X, 10.0);
    for (k, dir) in [Vec3::X, Vec3::Y, -Vec3::X, -Vec3::Y].iter().enumerate() {
        let v = m.push_vertex(*dir, *dir, 20.0 + k as f32);
        m.triangles.push(if k < 3 { [0, 1, v] } else { [0, v, 4] });
    }
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
}

#[test]
fn duplicated_vertices_are_welded_before_any_collapse() {
    let t = torus(8, 6, 30.0, 10.0, Vec3::ZERO);
    let s = soup(&t);
    let tree = s.tree().unwrap();
    check_invariants(&s, &tree);
    // Each torus vertex is shared by 6 triangles: 48 groups of 6 copies.
    assert_eq!(tree.welded_groups(), t.positions.len());
    let mut welds = 0;
    for v in 0..tree.node_count() as u32 {
        if let Some([a, b]) = tree.children(v) {
            if let (Some(a), Some(b)) = (tree.vertex(a), tree.vertex(b)) {
                if s.positions[a as usize] == s.positions[b as usize] {
                    assert_eq!(tree.proxy_position(v), s.positions[a as usize]);
                    welds += 1;
                }
            }
        }
    }
    assert!(welds >= t.positions.len(), "{welds}");
    // Welding made it one connected surface again: few roots.
    assert!(tree.forest_roots() <= 4, "{}", tree.forest_roots());
}

#[test]
fn an_open_mesh_satisfies_the_invariants() {
    let m = grid(12, 12, 100.0);
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
}

#[test]
fn disconnected_pieces_and_isolated_vertices_end_in_one_root() {
    let mut m = concat(
        &torus(10, 6, 30.0, 8.0, Vec3::ZERO),
        &torus(6, 4, 5.0, 2.0, Vec3::new(200.0, 0.0, 0.0)),
    );
    m.push_vertex(Vec3::new(-100.0, 50.0, 0.0), Vec3::Y, 3.0);
    m.push_vertex(Vec3::new(-100.0, 50.0, 1.0), Vec3::Y, 0.0);
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
    assert!(tree.forest_roots() >= 4);
}

#[test]
fn the_mesh_collapses_to_one_vertex() {
    let m = torus(12, 8, 30.0, 10.0, Vec3::ZERO);
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
    let mut cut = Cut::new(&tree);
    cut.fold_all();
    assert_eq!(cut.active_triangle_count(), 0);
    assert_eq!(cut.active_node_count(), 1);
    assert!(cut.is_active(tree.root()));
    for v in 0..tree.leaf_count() as u32 {
        assert_eq!(cut.representative(v), tree.root());
    }
}

#[test]
fn points_without_triangles_still_make_a_tree() {
    let mut m = Mesh::default();
    for i in 0..7 {
        m.push_vertex(Vec3::new(i as f32, (i * i) as f32, 0.0), Vec3::Z, i as f32);
    }
    let tree = m.tree().unwrap();
    check_invariants(&m, &tree);
    assert_eq!(tree.forest_roots(), 7);
    assert!(tree.max_depth() <= 3, "balanced spatial merge");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(32)))]

    /// Random soups of triangles over few vertices: duplicates, repeated
    /// indices, non-manifold edges and coincident points all show up.
    #[test]
    fn random_meshes_satisfy_the_invariants(
        pts in prop::collection::vec((0i32..4, 0i32..4, 0i32..3, 0.0f32..100.0), 1..24),
        tris in prop::collection::vec((0usize..64, 0usize..64, 0usize..64), 0..40),
    ) {
        let mut m = Mesh::default();
        for &(x, y, z, l) in &pts {
            m.push_vertex(Vec3::new(x as f32 * 10.0, y as f32 * 10.0, z as f32 * 5.0), Vec3::Z, l);
        }
        let n = m.positions.len();
        m.triangles = tris.iter().map(|&(a, b, c)| [(a % n) as u32, (b % n) as u32, (c % n) as u32]).collect();
        let tree = m.tree().unwrap();
        check_invariants(&m, &tree);
    }
}
