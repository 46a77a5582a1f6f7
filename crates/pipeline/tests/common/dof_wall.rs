//! The depth-of-field set-ups the PSNR and cost figures are reported on:
//! a wall of 6 × 5 coloured bumpy balls 1.5 m behind the 17" screen, the
//! background showing between them, plus a front object — [`SCREEN_BALL`]
//! (in focus, background blur) or [`NEAR_BALL`] (blurred in front of the
//! focused wall, foreground blur). Shared by the tests, the splat cost
//! example and nothing else (`#[path]`-included).
#![allow(dead_code)]

use std::path::Path;

use raycast::{Scene, SceneFile};

/// A ball at the screen (its front 480 mm from the eye): in focus for the
/// background-blur scene.
pub const SCREEN_BALL: &str =
    r#"(mesh: "ball", material: Some("front"), translate_mm: (-30.0, 10.0, 0.0), scale_mm: 60.0),"#;
/// A ball 270 mm from the eye: blurred in front of the focused wall.
pub const NEAR_BALL: &str = r#"(mesh: "ball", material: Some("front"), translate_mm: (10.0, -5.0, 270.0), scale_mm: 30.0),"#;
/// The wall's eye distance, mm (the foreground-blur scene's focus).
pub const WALL_FOCUS_MM: f64 = 1950.0;

/// The scene file's text: the wall, `front`'s objects and `effects`.
pub fn wall_text(front: &str, effects: &str) -> String {
    let mut objects = String::new();
    for j in 0..5 {
        for i in 0..6 {
            let x = -550.0 + 220.0 * i as f64;
            let y = -440.0 + 220.0 * j as f64;
            let m = (i + 2 * j) % 5;
            objects.push_str(&format!(
                "(mesh: \"ball\", material: Some(\"m{m}\"), translate_mm: ({x}, {y}, -1500.0), scale_mm: 85.0),\n"
            ));
        }
    }
    format!(
        r#"Scene(
    name: "dof-wall",
    background: (0.02, 0.03, 0.05),
    meshes: {{ "ball": Bumpy(triangles: 1500, amplitude: 0.15, seed: 7) }},
    materials: {{
        "m0": (diffuse: (0.9, 0.2, 0.1)),
        "m1": (diffuse: (0.1, 0.8, 0.2)),
        "m2": (diffuse: (0.2, 0.3, 0.9)),
        "m3": (diffuse: (0.9, 0.9, 0.2)),
        "m4": (diffuse: (0.8, 0.8, 0.8)),
        "front": (diffuse: (0.9, 0.5, 0.7)),
    }},
    objects: [
        {objects}
        {front}
    ],
    effects: [{effects}],
)"#
    )
}

/// The built scene.
pub fn wall(front: &str, effects: &str) -> Result<Scene, String> {
    let file: SceneFile = ron::from_str(&wall_text(front, effects)).map_err(|e| e.to_string())?;
    Scene::build(&file, Path::new(".")).map_err(|e| e.to_string())
}
