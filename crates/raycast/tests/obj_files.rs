//! OBJ files a careless hand gives: a face of two vertices, a directory, a
//! binary file, a byte-order mark, indices that name no vertex — each gets
//! the real reason (file and line), never "read error" or "index out of
//! bounds"; and a scene lists each effect at most once.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use raycast::mesh::TriangleMesh;
use raycast::scene::{Effect, MeshSource, Object};
use raycast::{Scene, SceneError, SceneFile};

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("obj_files");
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, bytes).expect("write");
    p
}

fn error(path: &Path) -> String {
    TriangleMesh::load_obj(path)
        .expect_err("must be refused")
        .to_string()
}

const QUAD: &str = "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

#[test]
fn a_face_of_fewer_than_three_vertices_names_its_line() {
    for (face, n) in [("f 1 2", 2), ("f 3", 1), ("f", 0), ("f 1/1 2/2", 2)] {
        let p = write("short.obj", format!("{QUAD}{face}\nf 1 2 3\n").as_bytes());
        let e = error(&p);
        assert!(
            e.contains("short.obj:7:") && e.contains(&format!("a face of {n} vertices")),
            "{face}: {e}"
        );
    }
    // `l` and `p` statements are points and lines, not faces: they draw
    // nothing and are no error (they used to become degenerate triangles).
    let p = write("lines.obj", format!("{QUAD}l 1 2\np 3\n").as_bytes());
    let m = TriangleMesh::load_obj(&p).expect("lines and points are valid OBJ");
    assert_eq!(m.indices.len(), 2);
}

#[test]
fn a_face_naming_no_vertex_names_its_line() {
    for face in [
        "f 1 2 9",
        "f 0 1 2",
        "f -5 1 2",
        "f 1 2 x",
        "f 1//1 2 3",
        "f 1/1 2/1 3/1",
        "f 1/1/1/1 2 3",
    ] {
        let p = write("index.obj", format!("{QUAD}{face}\n").as_bytes());
        let e = error(&p);
        assert!(e.contains("index.obj:7:"), "{face}: {e}");
        assert!(!e.contains("out of bounds"), "{face}: {e}");
    }
    // Negative indices count back from the last vertex so far, positive
    // ones may name a vertex further down.
    let p = write(
        "relative.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//1 -2//-1 -1//1\nf 1 2 4\nv 1 1 0\n",
    );
    assert_eq!(TriangleMesh::load_obj(&p).expect("valid").indices.len(), 2);
}

#[test]
fn a_directory_is_not_an_obj_file() {
    let d = dir().join("a-folder.obj");
    std::fs::create_dir_all(&d).expect("dir");
    let e = error(&d);
    assert!(
        e.contains("a-folder.obj") && e.contains("is a directory"),
        "{e}"
    );
}

#[test]
fn binary_files_are_refused_as_binary_naming_the_line() {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend_from_slice(&[0, 0, 0, 13]);
    let e = error(&write("picture.obj", &png));
    assert!(
        e.contains("picture.obj:1:") && e.contains("not a text file"),
        "{e}"
    );
    let e = error(&write("nul.obj", format!("{QUAD}v 0 0\0 1\n").as_bytes()));
    assert!(e.contains("nul.obj:7:") && e.contains("NUL"), "{e}");
}

#[test]
fn a_byte_order_mark_is_skipped() {
    let plain = TriangleMesh::load_obj(&write("plain.obj", QUAD.as_bytes())).expect("plain");
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(QUAD.replace("# a quad\n", "").as_bytes());
    let marked = TriangleMesh::load_obj(&write("bom.obj", &bom)).expect("BOM skipped");
    assert_eq!(plain, marked);
    // The line numbers of later errors still count the first line.
    let mut bad = b"\xEF\xBB\xBFv 0 0 0\nv nan 0 0\nv 0 1 0\n".to_vec();
    bad.extend_from_slice(b"f 1 2 3\n");
    let e = error(&write("bom-nan.obj", &bad));
    assert!(e.contains("bom-nan.obj:2:"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(256)))]

    /// Any bytes: a mesh, or an error that names the file and is not one
    /// of the reasonless messages; never a panic.
    #[test]
    fn any_bytes_load_or_give_a_reason(
        lines in prop::collection::vec(
            prop_oneof![
                Just("v 0 0 0".to_string()),
                Just("v 1 0 0".to_string()),
                Just("v 0 1 0".to_string()),
                (-4i32..6, -4i32..6, -4i32..6).prop_map(|(a, b, c)| format!("f {a} {b} {c}")),
                (-4i32..6, -4i32..6).prop_map(|(a, b)| format!("f {a} {b}")),
                Just("\u{feff}v 0 0 1".to_string()),
                prop::collection::vec(any::<u8>(), 0..12)
                    .prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
            ],
            0..12,
        ),
        raw in prop::option::of(prop::collection::vec(any::<u8>(), 0..64)),
        bom in any::<bool>(),
    ) {
        let mut bytes = if bom { b"\xEF\xBB\xBF".to_vec() } else { Vec::new() };
        bytes.extend_from_slice(lines.join("\n").as_bytes());
        if let Some(raw) = raw {
            bytes.extend_from_slice(&raw);
        }
        let p = write("any.obj", &bytes);
        match TriangleMesh::load_obj(&p) {
            Ok(m) => {
                prop_assert!(!m.indices.is_empty());
                let n = m.positions.len() as u32;
                prop_assert!(m.indices.iter().flatten().all(|&i| i < n));
            }
            Err(e) => {
                let e = e.to_string();
                prop_assert!(e.contains("any.obj"), "{}", e);
                prop_assert!(!e.contains("out of bounds") && !e.contains("read error"), "{}", e);
            }
        }
    }
}

fn scene_with_effects(effects: Vec<Effect>) -> SceneFile {
    SceneFile {
        name: "effects".into(),
        background: (0.1, 0.1, 0.1),
        meshes: [("m".to_string(), MeshSource::Icosphere { subdivisions: 0 })].into(),
        materials: Default::default(),
        objects: vec![Object {
            mesh: "m".into(),
            material: None,
            translate_mm: (0.0, 0.0, -50.0),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: 10.0,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![],
        sampling: None,
        passes: None,
        effects: Some(effects),
        crease_deg: Some(30.0),
        depth_jump: Some(0.5),
        camera: None,
    }
}

fn every_kind() -> Vec<Effect> {
    vec![
        Effect::FoveatedSampling,
        Effect::SilhouetteRefinement,
        Effect::CreaseRefinement,
        Effect::DepthRefinement,
        Effect::POR_OVERLAY,
        Effect::DEPTH_OF_FIELD,
    ]
}

#[test]
fn two_depth_of_field_effects_are_refused_naming_both() {
    let mut other = Effect::DEPTH_OF_FIELD;
    if let Effect::DepthOfField { pupil_mm, .. } = &mut other {
        *pupil_mm = 8.0;
    }
    let file = scene_with_effects(vec![
        Effect::DEPTH_OF_FIELD,
        Effect::FoveatedSampling,
        other,
    ]);
    match Scene::build(&file, &dir()) {
        Err(SceneError::Field { field, message }) => {
            assert_eq!(field, "effects[2]");
            assert!(
                message.contains("DepthOfField") && message.contains("effects[0]"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

proptest! {
    /// A list of effects builds iff no kind appears twice.
    #[test]
    fn each_effect_may_appear_once(picks in prop::collection::vec(0usize..6, 0..9)) {
        let kinds = every_kind();
        let effects: Vec<Effect> = picks.iter().map(|&i| kinds[i]).collect();
        let mut seen = [false; 6];
        let duplicate = picks.iter().any(|&i| std::mem::replace(&mut seen[i], true));
        let r = Scene::build(&scene_with_effects(effects), &dir());
        prop_assert_eq!(r.is_err(), duplicate, "{:?}", r.err());
    }
}
