//! A scene's total size is checked before anything is generated: 2000
//! instances of a 1.3 M-triangle mesh (2.6 G triangles, ~790 GB) used to
//! abort on allocation; now they are refused with an error naming the
//! object that crosses the limit and the memory the scene would need.

use std::path::Path;

use raycast::scene::{BYTES_PER_TRIANGLE, MAX_TRIANGLES};
use raycast::{Scene, SceneError, SceneFile};

#[test]
fn too_many_instances_are_refused_before_generating() {
    let object = r#"(mesh: "ball", translate_mm: (0.0, 0.0, -100.0), scale_mm: 10.0),"#;
    let text = format!(
        r#"Scene(name: "many", meshes: {{ "ball": Icosphere(subdivisions: 8) }}, objects: [{}])"#,
        object.repeat(2000)
    );
    let file: SceneFile = ron::from_str(&text).expect("parses");
    let err = Scene::build(&file, Path::new(".")).expect_err("refused");
    let per_mesh = 20 * 4u64.pow(8); // 1 310 720
    let first_over = MAX_TRIANGLES / per_mesh; // objects[15]: 16 × 1.31 M > 20 M
    let total = 2000 * per_mesh;
    let SceneError::Field { field, message } = &err else {
        panic!("{err}");
    };
    assert_eq!(field, &format!("objects[{first_over}]"), "{err}");
    assert!(message.contains(&MAX_TRIANGLES.to_string()), "{err}");
    assert!(message.contains(&total.to_string()), "{err}");
    let gb = format!("{:.1} GB", (total * BYTES_PER_TRIANGLE) as f64 / 1e9);
    assert!(message.contains(&gb), "{err} lacks {gb}");
}
