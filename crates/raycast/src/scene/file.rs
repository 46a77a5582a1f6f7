//! The scene file's schema (`config/scenes/*.ron`): meshes, materials,
//! objects, lights, the sampling and post passes it asks for (or the old
//! form's effect list) and the camera's path, with the defaults a file may
//! leave out.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::effect::{self, Effect};
use super::pass::PostPass;
use super::sampling::{Sampling, DEFAULT_CREASE_DEG, DEFAULT_DEPTH_JUMP};
use crate::error::SceneError;
use crate::motion::Motion;

/// Where a mesh comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum MeshSource {
    /// A Wavefront OBJ file (relative paths are relative to the scene file).
    Obj {
        /// The file's path.
        path: String,
    },
    /// Unit icosphere, 20·4^subdivisions triangles.
    Icosphere {
        /// Times each face of the icosahedron is split in four.
        subdivisions: u32,
    },
    /// Torus around y with unit-scale radii.
    Torus {
        /// Radius of the ring, mesh units.
        major_radius: f32,
        /// Radius of the tube, mesh units.
        minor_radius: f32,
        /// Segments around the ring (at least 3).
        segments: u32,
        /// Sides around the tube (at least 3).
        sides: u32,
    },
    /// Unit sphere with smooth bumps, at least `triangles` triangles.
    Bumpy {
        /// Fewest triangles.
        triangles: u32,
        /// Height of the bumps relative to the radius (magnitude below 1).
        amplitude: f32,
        /// Seed of the bump pattern.
        seed: u64,
    },
    /// A head facing +z (unit scale) with one of the four facial
    /// expressions of Murphy 2007 §7.1.4 ([`FACE_EXPRESSIONS`]): the same
    /// topology and silhouette for all four, only the front differs
    /// ([`TriangleMesh::face`](crate::mesh::TriangleMesh::face)). 20·4^subdivisions triangles, at most
    /// [`crate::mesh::FACE_MAX_SUBDIVISIONS`] subdivisions.
    Face {
        /// Index into [`FACE_EXPRESSIONS`].
        expression: u32,
        /// Times each face of the base mesh is split in four.
        subdivisions: u32,
    },
    /// One triangle with the given corners (scene units).
    Triangle {
        /// First corner.
        a: (f32, f32, f32),
        /// Second corner.
        b: (f32, f32, f32),
        /// Third corner.
        c: (f32, f32, f32),
    },
}

/// The expressions of [`MeshSource::Face`], by index.
pub const FACE_EXPRESSIONS: [&str; 4] = ["neutral", "smile", "frown", "surprise"];

/// Blinn–Phong material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Diffuse colour, linear RGB (1 = white, up to [`MAX_COLOUR`]).
    pub diffuse: (f32, f32, f32),
    /// Specular colour, linear RGB (default 0.25 each, up to [`MAX_COLOUR`]).
    #[serde(default = "default_specular")]
    pub specular: (f32, f32, f32),
    /// Blinn–Phong exponent (default 32).
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
    /// Name of the mesh in the file's `meshes`.
    pub mesh: String,
    /// Name of the material in the file's `materials`; none: the default material (grey 0.7, Blinn–Phong).
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
    Headlight {
        /// Intensity (1 = the default headlight's).
        intensity: f32,
    },
    /// A point light at `position_mm` (screen centre = origin, z towards the viewer).
    Point {
        /// Position, mm.
        position_mm: (f32, f32, f32),
        /// Intensity (1 = the default headlight's).
        intensity: f32,
    },
    /// A light from infinitely far away, travelling along `direction`.
    Directional {
        /// Direction the light travels (towards the scene), display frame.
        direction: (f32, f32, f32),
        /// Intensity (1 = the default headlight's).
        intensity: f32,
    },
}

/// The scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Scene", deny_unknown_fields)]
pub struct SceneFile {
    /// The scene's name, shown in reports.
    pub name: String,
    /// Background colour, linear RGB (1 = white, up to [`MAX_COLOUR`];
    /// default a dark blue-grey).
    #[serde(default = "default_background")]
    pub background: (f32, f32, f32),
    /// The meshes, by name.
    pub meshes: BTreeMap<String, MeshSource>,
    /// The materials, by name.
    #[serde(default)]
    pub materials: BTreeMap<String, Material>,
    /// The objects placed in the scene.
    pub objects: Vec<Object>,
    /// The lights (default one headlight of intensity 1).
    #[serde(default = "default_lights")]
    pub lights: Vec<Light>,
    /// How the frame is sampled (`Full`, or `Foveated(refine: […])` with
    /// the hybrid's refinement triggers); none given: the seed's, foveated
    /// with every trigger ([`Sampling::default`]).
    #[serde(default, skip_serializing_if = "Option::is_none", with = "present")]
    pub sampling: Option<Sampling>,
    /// The post passes, run in this order; none given: none.
    #[serde(default, skip_serializing_if = "Option::is_none", with = "present")]
    pub passes: Option<Vec<PostPass>>,
    /// The old form's effect list (sampling, triggers and passes in one
    /// list), read for older files; a file gives either this form or
    /// `sampling`/`passes`, not both.
    #[serde(default, skip_serializing_if = "Option::is_none", with = "present")]
    pub effects: Option<Vec<Effect>>,
    /// The old form's crease angle for `CreaseRefinement`, degrees (30
    /// when not given).
    #[serde(default, skip_serializing_if = "Option::is_none", with = "present")]
    pub crease_deg: Option<f32>,
    /// The old form's depth ratio for `DepthRefinement`: refine when
    /// max/min hit distance across a cell's corners exceeds 1 + this (0.05
    /// when not given).
    #[serde(default, skip_serializing_if = "Option::is_none", with = "present")]
    pub depth_jump: Option<f32>,
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

impl SceneFile {
    /// Replaces the file's sampling and passes, in whichever form it gave
    /// them, by the old form's effect list (the refinement parameters
    /// taken as the file gave them in the old form, else the defaults):
    /// for code that composes scenes from such a list.
    pub fn set_effects(&mut self, effects: Vec<Effect>) {
        self.sampling = None;
        self.passes = None;
        self.effects = Some(effects);
    }

    /// Whether the file uses the old form (`effects`, `crease_deg`,
    /// `depth_jump`).
    pub fn is_old_form(&self) -> bool {
        self.effects.is_some() || self.crease_deg.is_some() || self.depth_jump.is_some()
    }

    /// The sampling and post passes the file asks for, in either form: the
    /// old form translated, defaults filled in. Errors name the field: a
    /// file that mixes the forms (at its first old-form field), a kind
    /// listed twice, a pass's bad parameter. The refinement parameters are
    /// checked where the scene is built.
    pub fn sampling_and_passes(&self) -> Result<(Sampling, Vec<PostPass>), SceneError> {
        if self.is_old_form() {
            if self.sampling.is_some() || self.passes.is_some() {
                let old = if self.effects.is_some() {
                    "effects"
                } else if self.crease_deg.is_some() {
                    "crease_deg"
                } else {
                    "depth_jump"
                };
                let new = if self.sampling.is_some() {
                    "sampling"
                } else {
                    "passes"
                };
                return Err(SceneError::field(
                    old,
                    format!(
                        "`{old}` is the old form and `{new}` the new: give either `effects` (with `crease_deg`, `depth_jump`) or `sampling` and `passes`, not both"
                    ),
                ));
            }
            let seed = vec![
                Effect::FoveatedSampling,
                Effect::SilhouetteRefinement,
                Effect::CreaseRefinement,
                Effect::DepthRefinement,
            ];
            return effect::translate(
                self.effects.as_deref().unwrap_or(&seed),
                self.crease_deg.unwrap_or(DEFAULT_CREASE_DEG),
                self.depth_jump.unwrap_or(DEFAULT_DEPTH_JUMP),
            );
        }
        let sampling = self.sampling.clone().unwrap_or_default();
        sampling.check_triggers("sampling")?;
        let passes = self.passes.clone().unwrap_or_default();
        for (i, p) in passes.iter().enumerate() {
            p.validate(&format!("passes[{i}]"))?;
            if let Some(first) = passes[..i].iter().position(|x| x.same_kind(p)) {
                return Err(SceneError::field(
                    format!("passes[{i}]"),
                    format!(
                        "{} is listed twice (also passes[{first}]): each pass may appear once",
                        p.kind_name()
                    ),
                ));
            }
        }
        Ok((sampling, passes))
    }
}

/// An optional field written as its bare value (`sampling: Full`, not
/// `Some(Full)`): absent is `None`.
mod present {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<T: Serialize, S: Serializer>(
        value: &Option<T>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        match value {
            Some(v) => v.serialize(serializer),
            None => serializer.serialize_none(),
        }
    }

    pub fn deserialize<'de, T: Deserialize<'de>, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Option<T>, D::Error> {
        T::deserialize(deserializer).map(Some)
    }
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
