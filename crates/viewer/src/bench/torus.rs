//! The benches' procedural scene: one tilted torus, built from a scene
//! file in memory (`bench lod` and `bench scaling` place it differently).

use std::collections::BTreeMap;
use std::path::Path;

use raycast::scene::{Effect, Light, MeshSource, Object};
use raycast::{Scene, SceneFile};

/// Where the torus sits (world mm; the screen is at z = 0).
pub struct Placement {
    /// Position of the torus's centre, mm.
    pub translate_mm: (f32, f32, f32),
    /// Mesh units to mm.
    pub scale_mm: f32,
}

/// A torus of `2·segments·sides` faces (major radius 1, minor 0.35,
/// rotated 60° and 20°), placed as asked, lit by a headlight, with the
/// scene's `effects` (the old form's list).
pub fn torus_scene(
    segments: u32,
    sides: u32,
    at: Placement,
    effects: Vec<Effect>,
) -> Result<Scene, String> {
    let file = SceneFile {
        name: format!("torus-{}", 2 * u64::from(segments) * u64::from(sides)),
        background: (0.07, 0.07, 0.09),
        meshes: BTreeMap::from([(
            "torus".to_string(),
            MeshSource::Torus {
                major_radius: 1.0,
                minor_radius: 0.35,
                segments,
                sides,
            },
        )]),
        materials: BTreeMap::new(),
        objects: vec![Object {
            mesh: "torus".into(),
            material: None,
            translate_mm: at.translate_mm,
            rotate_deg: (60.0, 20.0, 0.0),
            scale_mm: at.scale_mm,
            importance: 1.0,
            motion: None,
        }],
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(effects),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    Scene::build(&file, Path::new(".")).map_err(|e| e.to_string())
}
