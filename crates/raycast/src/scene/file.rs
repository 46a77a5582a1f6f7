//! The scene file's schema (`config/scenes/*.ron`): meshes, materials,
//! objects, lights, the effects it asks for and the camera's path, with
//! the defaults a file may leave out.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::effect::Effect;
use crate::error::SceneError;
use crate::motion::Motion;

/// Where a mesh comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum MeshSource {
    /// A Wavefront OBJ file (relative paths are relative to the scene file).
    Obj { path: String },
    /// Unit icosphere, 20·4^subdivisions triangles.
    Icosphere { subdivisions: u32 },
    /// Torus around y with unit-scale radii.
    Torus {
        major_radius: f32,
        minor_radius: f32,
        segments: u32,
        sides: u32,
    },
    /// Unit sphere with smooth bumps, at least `triangles` triangles.
    Bumpy {
        triangles: u32,
        amplitude: f32,
        seed: u64,
    },
    /// A head facing +z (unit scale) with one of the four facial
    /// expressions of Murphy 2007 §7.1.4 ([`FACE_EXPRESSIONS`]): the same
    /// topology and silhouette for all four, only the front differs
    /// ([`TriangleMesh::face`]). 20·4^subdivisions triangles, at most
    /// [`crate::mesh::FACE_MAX_SUBDIVISIONS`] subdivisions.
    Face { expression: u32, subdivisions: u32 },
    /// One triangle with the given corners (scene units).
    Triangle {
        a: (f32, f32, f32),
        b: (f32, f32, f32),
        c: (f32, f32, f32),
    },
}

/// The expressions of [`MeshSource::Face`], by index.
pub const FACE_EXPRESSIONS: [&str; 4] = ["neutral", "smile", "frown", "surprise"];

/// Blinn–Phong material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub diffuse: (f32, f32, f32),
    #[serde(default = "default_specular")]
    pub specular: (f32, f32, f32),
    #[serde(default = "default_shininess")]
    pub shininess: f32,
}

fn default_specular() -> (f32, f32, f32) {
    (0.25, 0.25, 0.25)
}

fn default_shininess() -> f32 {
    32.0
}

impl Default for Material {
    fn default() -> Self {
        Self {
            diffuse: (0.7, 0.7, 0.7),
            specular: default_specular(),
            shininess: default_shininess(),
        }
    }
}

/// One placed instance of a mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Object {
    pub mesh: String,
    #[serde(default)]
    pub material: Option<String>,
    /// Position in mm (screen centre = origin, z towards the viewer).
    pub translate_mm: (f32, f32, f32),
    /// Rotation in degrees about x, then y, then z.
    #[serde(default)]
    pub rotate_deg: (f32, f32, f32),
    /// Uniform scale: mesh units to mm.
    pub scale_mm: f32,
    /// Task importance `T_i` of Lee's attention model (eq. 3.7), 0 to 1:
    /// how much the task makes this object worth looking at. 0 marks
    /// scenery (floor, walls) that the model never attends; the default 1
    /// treats every object alike.
    #[serde(default = "default_importance")]
    pub importance: f32,
    /// A keyframed path the object follows, as an offset from its own pose
    /// (`crate::motion`); none: the object stands still.
    #[serde(default)]
    pub motion: Option<Motion>,
}

fn default_importance() -> f32 {
    1.0
}

/// A light.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Light {
    /// A point light at the eye (the default).
    Headlight { intensity: f32 },
    Point {
        position_mm: (f32, f32, f32),
        intensity: f32,
    },
    Directional {
        direction: (f32, f32, f32),
        intensity: f32,
    },
}

/// The scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Scene", deny_unknown_fields)]
pub struct SceneFile {
    pub name: String,
    #[serde(default = "default_background")]
    pub background: (f32, f32, f32),
    pub meshes: BTreeMap<String, MeshSource>,
    #[serde(default)]
    pub materials: BTreeMap<String, Material>,
    pub objects: Vec<Object>,
    #[serde(default = "default_lights")]
    pub lights: Vec<Light>,
    #[serde(default = "default_effects")]
    pub effects: Vec<Effect>,
    /// Crease angle for `CreaseRefinement`, degrees.
    #[serde(default = "default_crease")]
    pub crease_deg: f32,
    /// Depth ratio for `DepthRefinement`: refine when max/min hit distance
    /// across a cell's corners exceeds 1 + this.
    #[serde(default = "default_depth_jump")]
    pub depth_jump: f32,
    /// A keyframed path of the viewer (eye and display together) through
    /// the world (`crate::motion`); none: the camera stands still.
    #[serde(default)]
    pub camera: Option<Motion>,
}

fn default_background() -> (f32, f32, f32) {
    (0.08, 0.08, 0.1)
}

fn default_lights() -> Vec<Light> {
    vec![Light::Headlight { intensity: 1.0 }]
}

fn default_effects() -> Vec<Effect> {
    vec![
        Effect::FoveatedSampling,
        Effect::SilhouetteRefinement,
        Effect::CreaseRefinement,
        Effect::DepthRefinement,
    ]
}

fn default_crease() -> f32 {
    30.0
}

fn default_depth_jump() -> f32 {
    0.05
}

/// Largest colour component and light intensity a scene may give: far
/// above white (1) for over-exposure, small enough that shading sums stay
/// finite in `f32`.
pub const MAX_COLOUR: f32 = 1e6;

/// A linear RGB colour: each component finite, from 0 to [`MAX_COLOUR`].
pub(super) fn check_colour(field: &str, c: (f32, f32, f32)) -> Result<(), SceneError> {
    for v in [c.0, c.1, c.2] {
        if !(v.is_finite() && (0.0..=MAX_COLOUR).contains(&v)) {
            return Err(SceneError::field(
                field,
                format!(
                    "({}, {}, {}): components must be from 0 to {MAX_COLOUR}",
                    c.0, c.1, c.2
                ),
            ));
        }
    }
    Ok(())
}
