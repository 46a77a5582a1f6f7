//! Selection: Luebke–Hallen imperceptible and budget modes, Murphy–
//! Duchowski levels; bad views; monotone error; incremental = from scratch.

mod common;

use common::{table, torus, Mesh};
use foveation::perceptibility::ThresholdTable;
use glam::Vec3;
use lod::{judge, BudgetStop, Cut, LodError, Mode, NodeState, VertexTree, View};
use proptest::prelude::*;

fn mesh() -> Mesh {
    torus(40, 20, 60.0, 20.0, Vec3::ZERO)
}

fn view(t: &ThresholdTable, eye: Vec3, gaze: Option<Vec3>) -> View<'_> {
    View {
        eye_mm: eye,
        gaze_point_mm: gaze,
        thresholds: t,
        scene_contrast: 0.9,
    }
}

/// The cut as comparable data: active nodes, and drawn triangles with their
/// corner nodes, both sorted.
fn snapshot(cut: &Cut) -> (Vec<u32>, Vec<(u32, [u32; 3])>) {
    let mut tris: Vec<_> = cut
        .active_triangle_ids()
        .iter()
        .map(|&t| (t, cut.corner_nodes(t)))
        .collect();
    tris.sort_unstable();
    (cut.active_nodes(), tris)
}

fn descendants(tree: &VertexTree, v: u32) -> Vec<u32> {
    let mut out = Vec::new();
    let mut stack = vec![v];
    while let Some(x) = stack.pop() {
        if let Some(c) = tree.children(x) {
            out.extend(c);
            stack.extend(c);
        }
    }
    out
}

#[test]
fn bad_views_are_errors_and_leave_the_cut_alone() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let mut cut = Cut::new(&tree);
    cut.select(
        &view(&t, Vec3::new(0.0, -400.0, 100.0), None),
        &Mode::Imperceptible,
    )
    .unwrap();
    let before = snapshot(&cut);
    let eye = Vec3::new(0.0, -400.0, 0.0);
    let bad = [
        view(&t, Vec3::new(f32::NAN, 0.0, 0.0), None),
        view(&t, Vec3::new(0.0, f32::INFINITY, 0.0), None),
        view(&t, eye, Some(Vec3::new(0.0, 0.0, f32::NAN))),
        view(&t, eye, Some(Vec3::splat(f32::NEG_INFINITY))),
        view(&t, eye, Some(eye)),
        View {
            scene_contrast: f64::NAN,
            ..view(&t, eye, None)
        },
        View {
            scene_contrast: 1.5,
            ..view(&t, eye, None)
        },
    ];
    for v in &bad {
        for mode in [
            Mode::Imperceptible,
            Mode::Budget { triangles: 100 },
            Mode::murphy_duchowski(),
        ] {
            let e = cut.select(v, &mode).unwrap_err();
            assert!(matches!(e, LodError::InvalidView { .. }), "{e}");
        }
        assert!(judge(&tree, v, tree.root()).is_err());
    }
    assert_eq!(snapshot(&cut), before);
    assert!(cut.triangles().iter().flatten().all(|p| p.is_finite()));
    let bad_mode = Mode::MurphyDuchowski {
        level_angle_deg: [1.0, 2.0, 0.5, 0.2, 0.0],
    };
    assert!(matches!(
        cut.select(&view(&t, eye, None), &bad_mode),
        Err(LodError::InvalidMode { .. })
    ));
}

#[test]
fn a_node_whose_sphere_holds_the_eye_is_never_folded() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    // The eye just above the tube's top, looking along it: inside many spheres.
    let eye = Vec3::new(60.0, 0.0, 21.0);
    let inside: Vec<u32> = (0..tree.node_count() as u32)
        .filter(|&v| {
            let s = tree.bounding_sphere(v);
            s.center.distance(eye) <= s.radius
        })
        .collect();
    assert!(inside.len() > 3, "{}", inside.len());
    for mode in [
        Mode::Imperceptible,
        Mode::murphy_duchowski(),
        Mode::MurphyDuchowski {
            level_angle_deg: [180.0; 5],
        },
        Mode::Budget {
            triangles: usize::MAX,
        },
    ] {
        for gaze in [None, Some(Vec3::new(-60.0, 0.0, 0.0))] {
            let mut cut = Cut::new(&tree);
            let v = View {
                scene_contrast: 0.0,
                ..view(&t, eye, gaze)
            };
            cut.select(&v, &mode).unwrap();
            for &n in &inside {
                if !tree.is_leaf(n) {
                    assert_eq!(cut.state(n), NodeState::Expanded, "{mode:?}: node {n}");
                }
            }
            assert!(judge(&tree, &v, tree.root()).unwrap().eye_inside);
        }
    }
}

#[test]
fn without_gaze_everything_is_foveal() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let v = view(&t, Vec3::new(100.0, -500.0, 200.0), None);
    for n in (0..tree.node_count() as u32).step_by(7) {
        assert_eq!(judge(&tree, &v, n).unwrap().eccentricity_deg, 0.0);
    }
}

#[test]
fn the_test_is_the_tables_is_perceptible_for_the_model_table() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let v = view(
        &t,
        Vec3::new(30.0, -250.0, 90.0),
        Some(Vec3::new(-60.0, 0.0, 0.0)),
    );
    let mut both = [0, 0];
    for n in (0..tree.node_count() as u32).filter(|&n| !tree.is_leaf(n)) {
        let j = judge(&tree, &v, n).unwrap();
        let want =
            j.eye_inside || t.is_perceptible(j.contrast, j.frequency_cpd, j.eccentricity_deg);
        assert_eq!(j.perceptible, want, "node {n}: {j:?}");
        both[usize::from(j.perceptible)] += 1;
    }
    assert!(both[0] > 0 && both[1] > 0, "{both:?}");
}

#[test]
fn silhouettes_are_found_at_the_rim_and_not_facing_the_eye() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    // Looking down the z axis at the torus lying in the xy plane.
    let v = view(&t, Vec3::new(0.0, 0.0, 800.0), None);
    let (mut rim, mut facing) = (0, 0);
    for n in (0..tree.node_count() as u32).filter(|&n| !tree.is_leaf(n)) {
        if tree.leaves_below(n) > 6 {
            continue;
        }
        let j = judge(&tree, &v, n).unwrap();
        let c = tree.bounding_sphere(n).center;
        if c.z > 18.0 {
            // Small patches on the top of the tube face the eye.
            assert!(!j.silhouette, "node {n} at {c}");
            facing += 1;
        }
        let radial = (c.x * c.x + c.y * c.y).sqrt();
        if (radial - 80.0).abs() < 3.0 && c.z.abs() < 4.0 {
            // The outer equator is edge-on.
            assert!(j.silhouette, "node {n} at {c}");
            rim += 1;
        }
    }
    assert!(rim > 0 && facing > 0, "{rim} {facing}");
}

#[test]
fn farther_and_more_peripheral_means_fewer_triangles() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let count = |eye: Vec3, gaze: Option<Vec3>| {
        let mut cut = Cut::new(&tree);
        cut.select(&view(&t, eye, gaze), &Mode::Imperceptible)
            .unwrap()
            .triangles
    };
    let near = count(Vec3::new(0.0, -300.0, 150.0), None);
    let far = count(Vec3::new(0.0, -30000.0, 15000.0), None);
    let away = count(
        Vec3::new(0.0, -300.0, 150.0),
        Some(Vec3::new(2000.0, 0.0, 150.0)),
    );
    assert!(
        far < near && away < near,
        "near {near} far {far} away {away}"
    );
    assert!(near <= tree.drawable_triangle_count());
}

#[test]
fn imperceptible_error_is_monotone_down_the_tree() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    for (eye, gaze) in [
        (Vec3::new(0.0, -300.0, 150.0), None),
        (
            Vec3::new(0.0, -300.0, 150.0),
            Some(Vec3::new(60.0, 0.0, 20.0)),
        ),
        (
            Vec3::new(400.0, 10.0, 30.0),
            Some(Vec3::new(-60.0, 0.0, 0.0)),
        ),
    ] {
        let v = view(&t, eye, gaze);
        let mut cut = Cut::new(&tree);
        cut.select(&v, &Mode::Imperceptible).unwrap();
        for n in cut.active_nodes() {
            for d in descendants(&tree, n) {
                if !tree.is_leaf(d) {
                    assert!(
                        !judge(&tree, &v, d).unwrap().perceptible,
                        "{d} under folded {n}"
                    );
                }
            }
        }
        // And across the whole tree: a perceptible child has a perceptible parent.
        for n in (0..tree.node_count() as u32).filter(|&n| !tree.is_leaf(n)) {
            if let Some(p) = tree.parent(n) {
                let (jc, jp) = (judge(&tree, &v, n).unwrap(), judge(&tree, &v, p).unwrap());
                assert!(
                    !jc.perceptible || jp.perceptible,
                    "child {n} {jc:?} parent {p} {jp:?}"
                );
                assert!(jp.angular_extent_deg >= jc.angular_extent_deg);
                assert!(jp.eccentricity_deg <= jc.eccentricity_deg);
                assert!(jp.contrast >= jc.contrast);
            }
        }
    }
}

#[test]
fn the_budget_is_kept_and_the_reported_distance_falls_as_it_grows() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let v = view(
        &t,
        Vec3::new(0.0, -150.0, 80.0),
        Some(Vec3::new(0.0, -60.0, 20.0)),
    );
    let mut last = f64::INFINITY;
    let mut cut = Cut::new(&tree);
    for budget in [0, 10, 100, 400, 1000, 1600] {
        let r = cut.select(&v, &Mode::Budget { triangles: budget }).unwrap();
        let b = r.budget.unwrap();
        assert!(r.triangles <= budget, "{} > {budget}", r.triangles);
        assert!(b.distance_factor <= last, "{budget}: {b:?}");
        last = b.distance_factor;
        if b.stopped_by == BudgetStop::Budget {
            assert!(
                b.distance_factor > 1.0 && b.imperceptible_distance_mm > 0.0,
                "{b:?}"
            );
        }
    }
    let r = cut
        .select(
            &v,
            &Mode::Budget {
                triangles: usize::MAX,
            },
        )
        .unwrap();
    assert_ne!(r.budget.unwrap().stopped_by, BudgetStop::Budget);
    assert!(r.budget.unwrap().distance_factor <= 1.0);
}

#[test]
fn murphy_duchowski_picks_the_row_by_the_objects_angular_size() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let r = tree.bounding_sphere(tree.root()).radius as f64;
    let at = |deg: f64| {
        let d = r / (deg.to_radians() / 2.0).sin();
        Vec3::new(0.0, -(d as f32), 0.0)
    };
    let mut cut = Cut::new(&tree);
    let mut tris = Vec::new();
    for (deg, row) in [
        (40.0, 0),
        (26.0, 0),
        (24.0, 1),
        (22.0, 2),
        (20.0, 3),
        (18.0, 4),
        (5.0, 4),
    ] {
        let rep = cut
            .select(
                &view(&t, at(deg), Some(Vec3::ZERO)),
                &Mode::murphy_duchowski(),
            )
            .unwrap();
        assert_eq!(rep.md_depth_row, Some(row), "{deg}°");
        tris.push(rep.triangles);
    }
    assert!(tris.windows(2).all(|w| w[1] <= w[0]), "{tris:?}");
    // A finer allowance never draws fewer triangles.
    let v = view(&t, at(24.0), Some(Vec3::new(80.0, 0.0, 0.0)));
    let coarse = cut
        .select(
            &v,
            &Mode::MurphyDuchowski {
                level_angle_deg: [8.0, 4.0, 2.0, 1.0, 0.5],
            },
        )
        .unwrap();
    let fine = cut.select(&v, &Mode::murphy_duchowski()).unwrap();
    assert!(fine.triangles >= coarse.triangles);
}

fn arb_view() -> impl Strategy<Value = (Vec3, Option<Vec3>)> {
    (
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, 100.0f32..2000.0),
        prop::option::of((-80.0f32..80.0, -80.0f32..80.0, -20.0f32..20.0)),
    )
        .prop_map(|((x, y, z, d), g)| {
            let dir = Vec3::new(x, y, z + 0.01).normalize_or(Vec3::Y);
            (dir * d, g.map(|(a, b, c)| Vec3::new(a, b, c)))
        })
}

fn arb_mode() -> impl Strategy<Value = Mode> {
    prop_oneof![
        Just(Mode::Imperceptible),
        (0usize..2000).prop_map(|triangles| Mode::Budget { triangles }),
        Just(Mode::murphy_duchowski()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(32)))]

    /// Whatever the cut went through, a view gives the cut a fresh cut
    /// would get from it.
    #[test]
    fn incremental_selection_equals_selection_from_scratch(
        steps in prop::collection::vec((arb_view(), arb_mode()), 1..6),
    ) {
        let m = torus(24, 12, 60.0, 20.0, Vec3::ZERO);
        let tree = m.tree().unwrap();
        let t = table();
        let mut cut = Cut::new(&tree);
        let mut last = None;
        for ((eye, gaze), mode) in &steps {
            let r = cut.select(&view(&t, *eye, *gaze), mode).unwrap();
            prop_assert_eq!(r.triangles, cut.active_triangle_count());
            last = Some(r);
        }
        let ((eye, gaze), mode) = steps.last().unwrap();
        let mut fresh = Cut::new(&tree);
        let r = fresh.select(&view(&t, *eye, *gaze), mode).unwrap();
        prop_assert_eq!(snapshot(&cut), snapshot(&fresh));
        prop_assert_eq!(cut.triangles().len(), fresh.triangles().len());
        prop_assert_eq!(last.unwrap().budget, r.budget);
        // Selecting the same view again changes nothing.
        let again = cut.select(&view(&t, *eye, *gaze), mode).unwrap();
        prop_assert_eq!((again.folds, again.unfolds), (0, 0));
        for p in cut.triangles().iter().flatten() {
            prop_assert!(p.is_finite());
        }
    }
}

/// `Mode::MurphyDuchowskiTable`: a table whose extents are all 0 draws
/// level 1 everywhere, one whose extents reach everything draws the
/// original mesh, a step at an eccentricity lies between; Table 1 itself
/// gives what `Mode::MurphyDuchowski` gives; a bad extent is refused and
/// leaves the cut alone.
#[test]
fn a_degradation_table_in_place_of_table_1() {
    let m = mesh();
    let tree = m.tree().unwrap();
    let t = table();
    let eye = Vec3::new(0.0, -400.0, 0.0);
    let v = view(&t, eye, Some(Vec3::new(-60.0, 0.0, 0.0)));
    let angles = lod::MD_DEFAULT_LEVEL_ANGLE_DEG;
    let count = |extents_deg: [[f64; 5]; 5]| {
        let mut cut = Cut::new(&tree);
        cut.select(
            &v,
            &Mode::MurphyDuchowskiTable {
                level_angle_deg: angles,
                extents_deg,
            },
        )
        .unwrap()
        .triangles
    };
    let coarse = count([[0.0; 5]; 5]);
    let full = count([[180.0; 5]; 5]);
    let step = count([[10.0, 10.0, 10.0, 10.0, 180.0]; 5]);
    assert_eq!(full, tree.triangles().len());
    assert!(coarse < step && step < full, "{coarse} {step} {full}");
    let mut cut = Cut::new(&tree);
    let md = cut.select(&v, &Mode::murphy_duchowski()).unwrap().triangles;
    assert_eq!(count(foveation::degradation::TABLE_1_DEG), md);
    let before = snapshot(&cut);
    let mut bad = foveation::degradation::TABLE_1_DEG;
    bad[3][1] = f64::NAN;
    let e = cut
        .select(
            &v,
            &Mode::MurphyDuchowskiTable {
                level_angle_deg: angles,
                extents_deg: bad,
            },
        )
        .unwrap_err();
    assert!(
        matches!(
            e,
            LodError::InvalidMode {
                field: "extents_deg",
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(snapshot(&cut), before);
}
