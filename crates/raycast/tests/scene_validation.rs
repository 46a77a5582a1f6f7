//! Scene validation against what the mesh builder and the placement can
//! represent in f32: any scene file either builds, with every triangle
//! finite, or is refused with an error naming the field — never a panic.

use std::path::Path;

use proptest::prelude::*;
use raycast::scene::{MeshSource, Object};
use raycast::{Scene, SceneError, SceneFile};

/// The awkward values — zero, negative, NaN, ±∞, near the top of f32, at
/// the bottom of the normal range — half of the time, ordinary ones the
/// other half, so that whole scenes also build.
fn awkward() -> impl Strategy<Value = f32> {
    prop_oneof![
        prop::sample::select(vec![
            0.0,
            -0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e38,
            -1e38,
            f32::MAX,
            f32::MIN,
            1e-38,
        ]),
        prop::sample::select(vec![0.3, 1.0, 100.0, -2.0]),
    ]
}

fn awkward3() -> impl Strategy<Value = (f32, f32, f32)> {
    (awkward(), awkward(), awkward())
}

fn mesh() -> impl Strategy<Value = MeshSource> {
    prop_oneof![
        (awkward(), awkward(), 0u32..8, 0u32..8).prop_map(|(major, minor, segments, sides)| {
            MeshSource::Torus {
                major_radius: major,
                minor_radius: minor,
                segments,
                sides,
            }
        }),
        (0u32..3).prop_map(|subdivisions| MeshSource::Icosphere { subdivisions }),
        (0u32..200, awkward(), any::<u64>()).prop_map(|(triangles, amplitude, seed)| {
            MeshSource::Bumpy {
                triangles,
                amplitude,
                seed,
            }
        }),
        (awkward3(), awkward3(), awkward3()).prop_map(|(a, b, c)| MeshSource::Triangle { a, b, c }),
    ]
}

fn scene_file(
    mesh: MeshSource,
    scale_mm: f32,
    translate_mm: (f32, f32, f32),
    rotate_deg: (f32, f32, f32),
) -> SceneFile {
    SceneFile {
        name: "awkward".into(),
        background: (0.1, 0.1, 0.1),
        meshes: [("m".to_string(), mesh)].into(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "m".into(),
            material: None,
            translate_mm,
            rotate_deg,
            scale_mm,
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
    }
}

/// Ok with finite triangles and unit normals, or a field/mesh error that
/// names something.
fn check(file: &SceneFile) -> Result<(), TestCaseError> {
    let built = Scene::build(file, Path::new("."));
    // `Scene::check` (no hierarchy) gives the same answer, the same error.
    prop_assert_eq!(
        Scene::check(file, Path::new(".")).err(),
        built.as_ref().err().cloned()
    );
    match built {
        Ok(scene) => {
            for t in &scene.triangles {
                prop_assert!(
                    t.p.iter().all(|p| p.is_finite()),
                    "non-finite corner {:?}",
                    t.p
                );
                prop_assert!(
                    t.n.iter()
                        .all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-4),
                    "bad normal {:?}",
                    t.n
                );
            }
            prop_assert_eq!(scene.object_materials.len(), file.objects.len());
        }
        Err(SceneError::Field { field, message }) => {
            prop_assert!(!field.is_empty() && !message.is_empty());
        }
        Err(SceneError::Mesh {
            origin, message, ..
        }) => {
            prop_assert!(!origin.is_empty() && !message.is_empty());
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(10_000), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_mesh_and_placement_builds_finite_or_is_refused(
        mesh in mesh(),
        scale in awkward(),
        translate in awkward3(),
        rotate in awkward3(),
    ) {
        check(&scene_file(mesh, scale, translate, rotate))?;
    }
}

#[test]
fn a_torus_near_f32_max_is_refused_naming_the_radius() {
    let torus = |major_radius, minor_radius| MeshSource::Torus {
        major_radius,
        minor_radius,
        segments: 8,
        sides: 6,
    };
    let build = |mesh| {
        Scene::build(
            &scene_file(mesh, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            Path::new("."),
        )
    };
    for (major, minor, field) in [
        (f32::MAX, f32::MAX, "meshes.m.major_radius"),
        (3e38, 1e38, "meshes.m.major_radius"),
        (f32::NAN, 1.0, "meshes.m.major_radius"),
        (1.0, 0.0, "meshes.m.minor_radius"),
        (1.0, f32::INFINITY, "meshes.m.minor_radius"),
    ] {
        match build(torus(major, minor)) {
            Err(SceneError::Field { field: f, .. }) => assert_eq!(f, field, "{major} {minor}"),
            other => panic!("{major} {minor}: {other:?}"),
        }
    }
    // Representable radii build; placing them larger overflows and names
    // the scale.
    assert!(build(torus(2e38, 1e38)).is_ok());
    let big = Scene::build(
        &scene_file(torus(2e38, 1e38), 10.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        Path::new("."),
    );
    assert!(
        matches!(&big, Err(SceneError::Field { field, .. }) if field == "objects[0].scale_mm"),
        "{big:?}"
    );
    let moved = Scene::build(
        &scene_file(torus(2e38, 1e38), 1.0, (3e38, 0.0, 0.0), (0.0, 0.0, 0.0)),
        Path::new("."),
    );
    assert!(
        matches!(&moved, Err(SceneError::Field { field, .. }) if field == "objects[0].translate_mm"),
        "{moved:?}"
    );
}

#[test]
fn task_importance_is_kept_per_object_and_checked() {
    let ball = MeshSource::Icosphere { subdivisions: 1 };
    let mut file = scene_file(ball, 10.0, (0.0, 0.0, -20.0), (0.0, 0.0, 0.0));
    file.objects.push(file.objects[0].clone());
    file.objects[1].importance = 0.25;
    let scene = Scene::build(&file, Path::new(".")).expect("builds");
    assert_eq!(scene.object_importance, vec![1.0, 0.25]);
    for bad in [-0.1, 1.5, f32::NAN, f32::INFINITY] {
        file.objects[1].importance = bad;
        let r = Scene::build(&file, Path::new("."));
        assert!(
            matches!(&r, Err(SceneError::Field { field, .. }) if field == "objects[1].importance"),
            "{bad}: {r:?}"
        );
    }
}
