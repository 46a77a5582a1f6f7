//! Scene files (`config/scenes/*.ron`) and the world they describe: every
//! object's triangles in world space (millimetres, the display's frame: the
//! screen centre at the origin, x right, y up, z towards the viewer; objects
//! behind the screen have z < 0), with one BVH over all of them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{EulerRot, Mat3, Vec3};
use serde::{Deserialize, Serialize};

use crate::accel::{Bvh, Bvh4, UniformGrid};
use crate::error::SceneError;
use crate::mesh::TriangleMesh;
use crate::motion::{Motion, Pose};
use crate::ray::{moller_trumbore, watertight, Aabb, Ray, TriangleTest, WatertightRay};

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

/// Effects a scene asks for; the pipeline runs only these (DESIGN.md).
/// Each kind may appear once in a scene (a second is an error naming both).
///
/// An effect may carry parameters, written in the scene file as
/// `Name(field: value, …)` (RON's struct variants: the parentheses are
/// needed even when every field keeps its default, e.g. `PorOverlay()`);
/// an unknown effect or field is an error naming file, line and field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Effect {
    /// Cast the CSF ray mask instead of every pixel.
    FoveatedSampling,
    /// Refine cells whose corners disagree on hit/miss or object.
    SilhouetteRefinement,
    /// Refine cells whose corner normals differ by more than the crease angle.
    CreaseRefinement,
    /// Refine cells with a depth jump between corners.
    DepthRefinement,
    /// Draw the POR box (the seed's figures): a 2-px square outline of
    /// half-size `half_px` around the gaze; `PorOverlay()` gives the seed's
    /// 64-px box.
    PorOverlay {
        #[serde(default = "default_por_half_px")]
        half_px: u32,
    },
    /// Depth of field (Lee 2009, ch. 4 or 5): the eye as a thin lens of
    /// pupil diameter `pupil_mm` (0: no blur), focal length
    /// `focal_length_mm` and lens-to-retina distance `retina_distance_mm`,
    /// focused at `focus`, refocusing on a change of focus as `refocus`
    /// says, blurring by `method` (ch. 4 mipmaps by default, or ch. 5
    /// splatting). `DepthOfField()` gives Lee's adult eye (4 mm pupil,
    /// 16.7 mm, 24 mm) focused at the depth under the gaze, refocusing at
    /// once, by mipmaps.
    DepthOfField {
        #[serde(default = "default_dof_pupil_mm")]
        pupil_mm: f64,
        #[serde(default = "default_dof_focal_length_mm")]
        focal_length_mm: f64,
        #[serde(default = "default_dof_retina_distance_mm")]
        retina_distance_mm: f64,
        #[serde(default)]
        focus: DofFocus,
        #[serde(default)]
        refocus: DofRefocus,
        #[serde(default)]
        method: DofMethod,
        /// Lee §4.3's foreground smoothing (eqs. 4.10–4.11, mipmap method
        /// only): the degree of blur is read from a coarser level around
        /// blurred foreground objects, so their blurred edges spread over
        /// the sharp surface behind them instead of ending at the
        /// silhouette. Off by default: it blurs in-focus pixels next to a
        /// blurred foreground.
        #[serde(default)]
        smooth_foreground: bool,
        /// Lee §5.2's defocused highlights (eq. 5.5, splatting method
        /// only): a blurred bright colour is extrapolated beyond the 8-bit
        /// frame's white (λ₀ 0.8, β 3, γ 2), so a defocused highlight
        /// stays bright. Off by default.
        #[serde(default)]
        highlights: bool,
    },
}

/// How [`Effect::DepthOfField`] blurs (Lee 2009 offers two methods).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum DofMethod {
    /// Ch. 4: nonlinear mipmap interpolation (the default).
    #[default]
    Mipmap,
    /// Ch. 5: point splatting on per-pixel layers, the hidden surfaces
    /// cast by rays (CPU and GPU; slower, better partial occlusion).
    Splat,
}

/// Where [`Effect::DepthOfField`] focuses.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum DofFocus {
    /// At the depth under the point of regard (a small-window median that
    /// ignores the background).
    #[default]
    Gaze,
    /// At a fixed eye distance (mm): beyond the focal length, or `inf`.
    Fixed { depth_mm: f64 },
    /// At the eye distance of the binocular 3-D gaze point (vergence,
    /// Murphy & Duchowski 2001 eqs. 1–3) on frames whose tracker sample has
    /// both eyes valid and converging; on other frames (one eye, a blink,
    /// a mouse, parallel or diverging lines of sight) as `Gaze`.
    Vergence,
    /// At the depth of the object Lee's attention model (2009 ch. 3,
    /// `crates/attention`) predicts the viewer attends, from the rendered
    /// frame alone: no eye tracker needed. While no object is attended the
    /// last focus is kept (before any, the eye is relaxed, at infinity).
    Attention,
}

/// How [`Effect::DepthOfField`]'s focal depth follows a change of its focus
/// target (Lee 2009 §6.1, the eye's refocusing latency). The filtered
/// quantity is the accommodation in diopters (1/depth), not the depth.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum DofRefocus {
    /// The focal depth is the target's, frame by frame (no latency).
    #[default]
    Instant,
    /// Eq. 6.1: a linear transition over `ms` milliseconds (Lee: 300 ms,
    /// the 200–300 ms refocusing latency) from the focus shown when the
    /// target jumped to the (tracked) new target.
    Interpolate {
        #[serde(default = "default_dof_refocus_ms")]
        ms: f64,
    },
    /// A first-order low-pass filter of cut-off `hz` (Lee: below 2 Hz;
    /// 1 Hz in his Fig. 6.1).
    LowPass {
        #[serde(default = "default_dof_refocus_hz")]
        hz: f64,
    },
}

/// Longest refocusing transition a scene may give, ms.
pub const DOF_REFOCUS_MS_MAX: f64 = 10_000.0;
/// Highest refocusing low-pass cut-off a scene may give, Hz.
pub const DOF_REFOCUS_HZ_MAX: f64 = 100.0;

fn default_dof_refocus_ms() -> f64 {
    300.0
}
fn default_dof_refocus_hz() -> f64 {
    1.0
}

/// Largest pupil (aperture) diameter a scene may give, mm: far beyond an
/// eye's 8 mm, for exaggerated blur.
pub const DOF_PUPIL_MM_MAX: f64 = 100.0;
/// Largest focal length or lens-to-retina distance a scene may give, mm.
pub const DOF_LENS_MM_MAX: f64 = 1000.0;

fn default_dof_pupil_mm() -> f64 {
    4.0
}
fn default_dof_focal_length_mm() -> f64 {
    16.7
}
fn default_dof_retina_distance_mm() -> f64 {
    24.0
}

/// The seed's POR box: 64 px across.
pub const POR_HALF_PX: u32 = 32;

/// Largest POR box half-size a scene may ask for (a 8192-px box: larger
/// than any supported display).
pub const POR_HALF_PX_MAX: u32 = 4096;

fn default_por_half_px() -> u32 {
    POR_HALF_PX
}

impl Effect {
    /// The POR overlay with the seed's size.
    pub const POR_OVERLAY: Effect = Effect::PorOverlay {
        half_px: POR_HALF_PX,
    };

    /// Depth of field with its defaults (Lee's adult eye, focus at the gaze).
    pub const DEPTH_OF_FIELD: Effect = Effect::DepthOfField {
        pupil_mm: 4.0,
        focal_length_mm: 16.7,
        retina_distance_mm: 24.0,
        focus: DofFocus::Gaze,
        refocus: DofRefocus::Instant,
        method: DofMethod::Mipmap,
        smooth_foreground: false,
        highlights: false,
    };

    /// Whether `self` and `other` are the same effect, whatever their
    /// parameters.
    pub fn same_kind(&self, other: &Effect) -> bool {
        std::mem::discriminant(self) == std::mem::discriminant(other)
    }

    /// The effect's name as the scene file writes it (`DepthOfField`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Effect::FoveatedSampling => "FoveatedSampling",
            Effect::SilhouetteRefinement => "SilhouetteRefinement",
            Effect::CreaseRefinement => "CreaseRefinement",
            Effect::DepthRefinement => "DepthRefinement",
            Effect::PorOverlay { .. } => "PorOverlay",
            Effect::DepthOfField { .. } => "DepthOfField",
        }
    }

    /// Checks the parameters; the error names the field under `field`.
    fn validate(&self, field: &str) -> Result<(), SceneError> {
        match *self {
            Effect::PorOverlay { half_px } if !(1..=POR_HALF_PX_MAX).contains(&half_px) => {
                Err(SceneError::field(
                    format!("{field}.half_px"),
                    format!("must be 1 to {POR_HALF_PX_MAX} pixels, found {half_px}"),
                ))
            }
            Effect::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                // Every method takes every lens; serde refuses an unknown
                // method, naming the line.
                method,
                smooth_foreground,
                highlights,
            } => {
                let bad = |name: &str, msg: String| {
                    Err(SceneError::field(format!("{field}.{name}"), msg))
                };
                if highlights && method == DofMethod::Mipmap {
                    return bad(
                        "highlights",
                        "applies to method Splat only (the mipmap method has no per-sample colours to extrapolate)".into(),
                    );
                }
                if smooth_foreground && method == DofMethod::Splat {
                    return bad(
                        "smooth_foreground",
                        "applies to method Mipmap only: Splat renders partial occlusion with the hidden surface".into(),
                    );
                }
                if !(0.0..=DOF_PUPIL_MM_MAX).contains(&pupil_mm) {
                    return bad(
                        "pupil_mm",
                        format!("must be 0 to {DOF_PUPIL_MM_MAX} mm, found {pupil_mm}"),
                    );
                }
                for (name, v) in [
                    ("focal_length_mm", focal_length_mm),
                    ("retina_distance_mm", retina_distance_mm),
                ] {
                    if !(v > 0.0 && v <= DOF_LENS_MM_MAX) {
                        return bad(
                            name,
                            format!("must be above 0 and at most {DOF_LENS_MM_MAX} mm, found {v}"),
                        );
                    }
                }
                if let DofFocus::Fixed { depth_mm } = focus {
                    if depth_mm.is_nan() || depth_mm <= focal_length_mm {
                        return bad(
                            "focus.depth_mm",
                            format!("must be beyond the focal length ({focal_length_mm} mm) or inf, found {depth_mm}"),
                        );
                    }
                }
                match refocus {
                    DofRefocus::Interpolate { ms } if !(ms > 0.0 && ms <= DOF_REFOCUS_MS_MAX) => {
                        bad(
                            "refocus.ms",
                            format!(
                                "must be above 0 and at most {DOF_REFOCUS_MS_MAX} ms, found {ms}"
                            ),
                        )
                    }
                    DofRefocus::LowPass { hz } if !(hz > 0.0 && hz <= DOF_REFOCUS_HZ_MAX) => bad(
                        "refocus.hz",
                        format!("must be above 0 and at most {DOF_REFOCUS_HZ_MAX} Hz, found {hz}"),
                    ),
                    _ => Ok(()),
                }
            }
            _ => Ok(()),
        }
    }
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
fn check_colour(field: &str, c: (f32, f32, f32)) -> Result<(), SceneError> {
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

/// One world-space triangle: corners, corner normals, object.
#[derive(Debug, Clone, Copy)]
pub struct WorldTriangle {
    pub p: [Vec3; 3],
    pub n: [Vec3; 3],
    pub object: u32,
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter (1 = the screen plane for camera rays).
    pub t: f32,
    pub object: u32,
    pub triangle: u32,
    /// Interpolated shading normal, unit length.
    pub normal: Vec3,
}

/// A loaded scene, ready to trace.
#[derive(Debug, Clone)]
pub struct Scene {
    pub name: String,
    pub background: Vec3,
    /// The background as the renderer writes it.
    pub background_rgb8: [u8; 3],
    /// The material of each object, indexed by object id (`Hit::object`,
    /// `WorldTriangle::object`): the scene file's named materials resolved
    /// per object.
    pub object_materials: Vec<Material>,
    /// Each object's task importance (`Object::importance`), indexed by
    /// object id like `object_materials`.
    pub object_importance: Vec<f32>,
    pub lights: Vec<Light>,
    pub effects: Vec<Effect>,
    pub crease_deg: f32,
    pub depth_jump: f32,
    /// Triangles in BVH leaf order.
    pub triangles: Vec<WorldTriangle>,
    pub bvh: Bvh,
    /// The same hierarchy 4 wide, traversed by the CPU caster.
    pub bvh4: Bvh4,
    /// The seed's uniform grid over the same triangles, when asked for
    /// ([`Scene::build_grid`]); used when `accel` is `Grid`.
    pub grid: Option<UniformGrid>,
    pub accel: Accel,
    /// Names this geometry: a number no other build (or pose of a moving
    /// scene) in the process has. Caches of cast samples key on it.
    revision: u64,
    /// What a moving scene needs to pose itself at any time; `None` for a
    /// static scene (which then keeps nothing more than its triangles).
    motion: Option<std::sync::Arc<SceneMotion>>,
    /// The time of this pose (s on the scene's clock) and, at that time,
    /// each object's fastest corner's velocity and the camera's velocity
    /// (mm/s, display frame); `None` for a static scene.
    pose: Option<PoseState>,
}

/// A moving scene's state at the time it was posed.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseState {
    /// Seconds on the scene's clock.
    pub time_s: f64,
    /// Per object id: the velocity (mm/s, display frame) of the corner of
    /// the object's bounding box that moves fastest (Lee eq. 3.3's
    /// "outermost vertex"), relative to the viewer.
    pub object_velocity_mm_per_s: Vec<[f32; 3]>,
    /// The viewer's velocity through the world, in the display's frame
    /// (x right, y up, z towards the viewer; moving forward is z < 0).
    pub camera_velocity_mm_per_s: [f32; 3],
}

/// One object of a moving scene: its mesh and pose.
#[derive(Debug)]
struct MovingObject {
    mesh: usize,
    scale_mm: f32,
    base: Pose,
    motion: Option<Motion>,
    /// The scaled mesh's bounding-box corners (object frame, mm).
    corners: [Vec3; 8],
}

/// What a moving scene keeps to pose itself.
#[derive(Debug)]
struct SceneMotion {
    meshes: Vec<TriangleMesh>,
    objects: Vec<MovingObject>,
    camera: Option<Motion>,
    /// The scene file's lights, in world coordinates.
    lights: Vec<Light>,
}

/// Time step of the velocities' central differences, s.
const VELOCITY_STEP_S: f64 = 1e-3;

impl SceneMotion {
    /// The viewer's pose at `t_s` (identity without a camera path).
    fn camera(&self, t_s: f64) -> Pose {
        self.camera.as_ref().map_or(Pose::IDENTITY, |m| m.pose(t_s))
    }

    /// Object `o`'s pose in the display frame at `t_s`, given the viewer's
    /// inverse pose `view`.
    fn object(&self, o: &MovingObject, view: &Pose, t_s: f64) -> Pose {
        let world = match &o.motion {
            Some(m) => {
                let (t, r) = m.sample(t_s);
                Pose {
                    rotation: crate::motion::euler_deg(r) * o.base.rotation,
                    translation: o.base.translation + t,
                }
            }
            None => o.base,
        };
        view.after(&world)
    }

    /// The triangles (object ids in order), lights and velocities at `t_s`.
    fn place(&self, t_s: f64) -> (Vec<WorldTriangle>, Vec<Light>, PoseState) {
        let view = self.camera(t_s).inverse();
        let mut triangles = Vec::new();
        for (k, o) in self.objects.iter().enumerate() {
            let Some(mesh) = self.meshes.get(o.mesh) else {
                continue;
            };
            let pose = self.object(o, &view, t_s);
            let placed: Vec<Vec3> = mesh
                .positions
                .iter()
                .map(|p| pose.apply(*p * o.scale_mm))
                .collect();
            triangles.extend(mesh.indices.iter().map(|tri| WorldTriangle {
                p: tri.map(|i| placed[i as usize]),
                n: tri.map(|i| pose.rotation * mesh.normals[i as usize]),
                object: k as u32,
            }));
        }
        let lights = self
            .lights
            .iter()
            .map(|l| match *l {
                Light::Point {
                    position_mm,
                    intensity,
                } => {
                    let p = view.apply(Vec3::new(position_mm.0, position_mm.1, position_mm.2));
                    Light::Point {
                        position_mm: (p.x, p.y, p.z),
                        intensity,
                    }
                }
                Light::Directional {
                    direction,
                    intensity,
                } => {
                    let d = view.rotation * Vec3::new(direction.0, direction.1, direction.2);
                    Light::Directional {
                        direction: (d.x, d.y, d.z),
                        intensity,
                    }
                }
                headlight => headlight,
            })
            .collect();
        (triangles, lights, self.velocities(t_s))
    }

    /// Velocities at `t_s` by central differences over ±1 ms.
    fn velocities(&self, t_s: f64) -> PoseState {
        let h = VELOCITY_STEP_S;
        let t = if t_s.is_finite() { t_s } else { 0.0 };
        let (before, after) = (t - h, t + h);
        let (view_a, view_b) = (self.camera(before).inverse(), self.camera(after).inverse());
        let object_velocity_mm_per_s = self
            .objects
            .iter()
            .map(|o| {
                let (a, b) = (
                    self.object(o, &view_a, before),
                    self.object(o, &view_b, after),
                );
                let fastest = o
                    .corners
                    .iter()
                    .map(|c| (b.apply(*c) - a.apply(*c)) / (2.0 * h) as f32)
                    .filter(|v| v.is_finite())
                    .fold(Vec3::ZERO, |m, v| {
                        if v.length_squared() > m.length_squared() {
                            v
                        } else {
                            m
                        }
                    });
                fastest.to_array()
            })
            .collect();
        let (ca, cb) = (self.camera(before), self.camera(after));
        let world_velocity = (cb.translation - ca.translation) / (2.0 * h) as f32;
        let camera = self.camera(t).rotation.transpose() * world_velocity;
        PoseState {
            time_s: t,
            object_velocity_mm_per_s,
            camera_velocity_mm_per_s: if camera.is_finite() {
                camera.to_array()
            } else {
                [0.0; 3]
            },
        }
    }
}

/// The next [`Scene::revision`].
fn next_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Which acceleration structure `intersect` uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Accel {
    #[default]
    Bvh,
    /// Murphy 2007 §6.1.1, for comparison.
    Grid,
}

/// Most triangles a scene may have, all objects together (each object
/// counts its mesh's triangles).
pub const MAX_TRIANGLES: u64 = 20_000_000;

/// Peak memory per triangle while a scene is built: the triangles in file
/// order and again in BVH order (2 × 76 B), their boxes (24 B), the BVH
/// build's centres and order (12 + 4 B), at most two 32-byte BVH nodes and
/// a third of a 128-byte 4-wide node (64 + 43 B): 299 B. At
/// [`MAX_TRIANGLES`], about 6 GB.
pub const BYTES_PER_TRIANGLE: u64 = 300;

/// Triangles in BVH leaf order and the BVH over them.
fn hierarchy(triangles: Vec<WorldTriangle>) -> (Vec<WorldTriangle>, Bvh) {
    let bounds: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let mut b = Aabb::EMPTY;
            t.p.iter().for_each(|p| b.grow(*p));
            b
        })
        .collect();
    let bvh = Bvh::build(&bounds);
    let triangles = bvh.order.iter().map(|&i| triangles[i as usize]).collect();
    (triangles, bvh)
}

/// Largest coordinate (mm) any pose of a moving scene may reach: far
/// inside `f32` so that placing, differencing and intersecting stay finite.
const MAX_POSED_MM: f32 = 1e15;

/// The paths of a scene file, checked, with the meshes they move; `None`
/// when nothing moves. Every pose stays within [`MAX_POSED_MM`]: a rotation
/// keeps a point's distance from the origin, so an object's corners lie
/// within its scaled radius of base + path translation, and the camera's
/// inverse pose adds at most its own translation.
fn moving_scene(
    file: &SceneFile,
    meshes: &BTreeMap<String, TriangleMesh>,
) -> Result<Option<SceneMotion>, SceneError> {
    if file.camera.is_none() && file.objects.iter().all(|o| o.motion.is_none()) {
        return Ok(None);
    }
    let camera_reach = match &file.camera {
        Some(m) => {
            m.validate("camera")?;
            m.max_translation_mm() * 3f32.sqrt()
        }
        None => 0.0,
    };
    let names: Vec<&String> = meshes.keys().collect();
    let mut objects = Vec::with_capacity(file.objects.len());
    for (k, o) in file.objects.iter().enumerate() {
        let field = format!("objects[{k}].motion");
        let path_reach = match &o.motion {
            Some(m) => {
                m.validate(&field)?;
                m.max_translation_mm() * 3f32.sqrt()
            }
            None => 0.0,
        };
        let index = names.iter().position(|n| **n == o.mesh).ok_or_else(|| {
            SceneError::field(
                format!("objects[{k}].mesh"),
                format!("no mesh named `{}` in `meshes`", o.mesh),
            )
        })?;
        let mesh = &meshes[&o.mesh];
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &mesh.positions {
            lo = lo.min(*p * o.scale_mm);
            hi = hi.max(*p * o.scale_mm);
        }
        if mesh.positions.is_empty() {
            (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
        }
        let corners = std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let radius = lo.abs().max(hi.abs()).length();
        let base_t = Vec3::new(o.translate_mm.0, o.translate_mm.1, o.translate_mm.2);
        let reach = base_t.length() + path_reach + radius + camera_reach;
        if !(reach.is_finite() && reach <= MAX_POSED_MM) {
            return Err(SceneError::field(
                field,
                format!(
                    "the object's path with the camera's could take it {reach:e} mm from the screen, beyond {MAX_POSED_MM:e} mm"
                ),
            ));
        }
        let r = o.rotate_deg;
        objects.push(MovingObject {
            mesh: index,
            scale_mm: o.scale_mm,
            base: Pose::from_parts(base_t, Vec3::new(r.0, r.1, r.2)),
            motion: o.motion.clone(),
            corners,
        });
    }
    Ok(Some(SceneMotion {
        meshes: names.iter().map(|n| meshes[*n].clone()).collect(),
        objects,
        camera: file.camera.clone(),
        lights: file.lights.clone(),
    }))
}

/// A scene file checked and placed, before its hierarchy is built.
struct Checked {
    triangles: Vec<WorldTriangle>,
    materials: Vec<Material>,
    object_material: Vec<u32>,
    object_importance: Vec<f32>,
    motion: Option<SceneMotion>,
}

impl Scene {
    /// The files a scene reads besides its own: each OBJ mesh's field
    /// (`meshes.NAME`) and path, resolved as [`Scene::build`] resolves it.
    /// A command lists them among its inputs so that no output replaces one.
    pub fn mesh_files(file: &SceneFile, base_dir: &Path) -> Vec<(String, PathBuf)> {
        file.meshes
            .iter()
            .filter_map(|(name, src)| match src {
                MeshSource::Obj { path } => {
                    Some((format!("meshes.{name}"), obj_path(path, base_dir)))
                }
                _ => None,
            })
            .collect()
    }

    /// Builds the world. Relative OBJ paths are resolved against `base_dir`.
    /// Errors name the field (`objects[3].mesh`) or the mesh file and line.
    pub fn build(file: &SceneFile, base_dir: &Path) -> Result<Self, SceneError> {
        let Checked {
            triangles,
            materials,
            object_material,
            object_importance,
            motion,
        } = Self::checked(file, base_dir)?;
        let (triangles, lights, pose) = match &motion {
            Some(m) => {
                let (t, l, p) = m.place(0.0);
                (t, l, Some(p))
            }
            None => (triangles, file.lights.clone(), None),
        };
        let (triangles, bvh) = hierarchy(triangles);
        let object_materials = object_material
            .iter()
            .map(|&m| materials[m as usize])
            .collect();
        let c = file.background;
        Ok(Self {
            name: file.name.clone(),
            background: Vec3::new(c.0, c.1, c.2),
            background_rgb8: crate::shade::to_rgb8(Vec3::new(c.0, c.1, c.2)),
            object_materials,
            object_importance,
            lights,
            effects: file.effects.clone(),
            crease_deg: file.crease_deg,
            depth_jump: file.depth_jump,
            triangles,
            bvh4: Bvh4::collapse(&bvh),
            bvh,
            grid: None,
            accel: Accel::Bvh,
            revision: next_revision(),
            motion: motion.map(std::sync::Arc::new),
            pose,
        })
    }

    /// Every check [`Scene::build`] makes — meshes loaded or generated,
    /// the triangle limit, every field, every placed vertex finite — without
    /// building the hierarchy (the costly part): a scene that passes
    /// builds. For checking a scene before committing to it (the
    /// experiment checks its stimulus scenes before the window opens).
    pub fn check(file: &SceneFile, base_dir: &Path) -> Result<(), SceneError> {
        Self::checked(file, base_dir).map(|_| ())
    }

    fn checked(file: &SceneFile, base_dir: &Path) -> Result<Checked, SceneError> {
        let finite3 = |v: (f32, f32, f32)| v.0.is_finite() && v.1.is_finite() && v.2.is_finite();
        for (i, e) in file.effects.iter().enumerate() {
            e.validate(&format!("effects[{i}]"))?;
            // Each effect is a switch or one pass with one set of
            // parameters (`Scene::effect` reads the first): a second of a
            // kind would run twice or be ignored.
            if let Some(first) = file.effects[..i].iter().position(|x| x.same_kind(e)) {
                return Err(SceneError::field(
                    format!("effects[{i}]"),
                    format!(
                        "{} is listed twice (also effects[{first}]): each effect may appear once",
                        e.kind_name()
                    ),
                ));
            }
        }
        check_colour("background", file.background)?;
        let mut meshes = BTreeMap::new();
        for (name, src) in &file.meshes {
            let field = format!("meshes.{name}");
            let mesh = match src {
                MeshSource::Obj { path } => TriangleMesh::load_obj(&obj_path(path, base_dir))?,
                MeshSource::Icosphere { subdivisions } => {
                    if *subdivisions > 8 {
                        return Err(SceneError::field(
                            format!("{field}.subdivisions"),
                            "subdivisions above 8 (1.3 M triangles) are not supported",
                        ));
                    }
                    TriangleMesh::icosphere(*subdivisions)
                }
                MeshSource::Torus {
                    major_radius,
                    minor_radius,
                    segments,
                    sides,
                } => {
                    for (f, r) in [
                        ("major_radius", major_radius),
                        ("minor_radius", minor_radius),
                    ] {
                        if !(r.is_finite() && *r > 0.0) {
                            return Err(SceneError::field(
                                format!("{field}.{f}"),
                                "must be a positive number",
                            ));
                        }
                    }
                    // The outermost ring lies at major + minor.
                    if !(major_radius + minor_radius).is_finite() {
                        return Err(SceneError::field(
                            format!("{field}.major_radius"),
                            format!(
                                "major_radius + minor_radius ({major_radius} + {minor_radius}) overflows f32"
                            ),
                        ));
                    }
                    if u64::from(*segments) * u64::from(*sides) > 20_000_000 {
                        return Err(SceneError::field(
                            format!("{field}.segments"),
                            "segments × sides is too large (more than 20 M)",
                        ));
                    }
                    TriangleMesh::torus(*major_radius, *minor_radius, *segments, *sides, &field)?
                }
                MeshSource::Bumpy {
                    triangles,
                    amplitude,
                    seed,
                } => {
                    if *triangles > 20_000_000 {
                        return Err(SceneError::field(
                            format!("{field}.triangles"),
                            "more than 20 M triangles are not supported",
                        ));
                    }
                    if !(amplitude.is_finite() && amplitude.abs() < 1.0) {
                        return Err(SceneError::field(
                            format!("{field}.amplitude"),
                            "must be finite with |amplitude| < 1",
                        ));
                    }
                    TriangleMesh::bumpy(*triangles, *amplitude, *seed, &field)?
                }
                MeshSource::Face {
                    expression,
                    subdivisions,
                } => {
                    if *expression as usize >= FACE_EXPRESSIONS.len() {
                        let names: Vec<String> = FACE_EXPRESSIONS
                            .iter()
                            .enumerate()
                            .map(|(i, n)| format!("{i} {n}"))
                            .collect();
                        return Err(SceneError::field(
                            format!("{field}.expression"),
                            format!(
                                "must be 0 to {}, found {expression}: {}",
                                FACE_EXPRESSIONS.len() - 1,
                                names.join(", ")
                            ),
                        ));
                    }
                    let max = crate::mesh::FACE_MAX_SUBDIVISIONS;
                    if *subdivisions > max {
                        return Err(SceneError::field(
                            format!("{field}.subdivisions"),
                            format!(
                                "subdivisions above {max} ({} triangles) are not supported, found {subdivisions}",
                                20u64 << (2 * max)
                            ),
                        ));
                    }
                    TriangleMesh::face(*expression, *subdivisions, &field)?
                }
                MeshSource::Triangle { a, b, c } => {
                    for (f, p) in [("a", a), ("b", b), ("c", c)] {
                        if !finite3(*p) {
                            return Err(SceneError::field(
                                format!("{field}.{f}"),
                                "corners must be finite",
                            ));
                        }
                    }
                    let v = |t: (f32, f32, f32)| Vec3::new(t.0, t.1, t.2);
                    TriangleMesh::new(vec![v(*a), v(*b), v(*c)], vec![[0, 1, 2]], &field)?
                }
            };
            meshes.insert(name.clone(), mesh);
        }
        let mut material_index = BTreeMap::new();
        let mut materials = vec![Material::default()];
        for (name, m) in &file.materials {
            for (f, c) in [("diffuse", m.diffuse), ("specular", m.specular)] {
                check_colour(&format!("materials.{name}.{f}"), c)?;
            }
            if !(m.shininess.is_finite() && m.shininess >= 0.0) {
                return Err(SceneError::field(
                    format!("materials.{name}.shininess"),
                    format!("{} must be finite and zero or positive", m.shininess),
                ));
            }
            material_index.insert(name.clone(), materials.len() as u32);
            materials.push(*m);
        }
        // Size before generating anything: 2000 instances of a 1.3 M-triangle
        // mesh would otherwise abort on allocation.
        let mut total = 0u64;
        let mut first_over = None;
        for (k, o) in file.objects.iter().enumerate() {
            total += meshes.get(&o.mesh).map_or(0, |m| m.indices.len() as u64);
            if total > MAX_TRIANGLES && first_over.is_none() {
                first_over = Some(k);
            }
        }
        if let Some(k) = first_over {
            return Err(SceneError::field(
                format!("objects[{k}]"),
                format!(
                    "the objects up to here take the scene past {MAX_TRIANGLES} triangles; \
                     its {} objects have {total} triangles in all, about {:.1} GB to build \
                     ({BYTES_PER_TRIANGLE} bytes per triangle)",
                    file.objects.len(),
                    total as f64 * BYTES_PER_TRIANGLE as f64 / 1e9
                ),
            ));
        }
        let mut object_material = Vec::new();
        let mut object_importance = Vec::new();
        let mut triangles = Vec::new();
        for (k, o) in file.objects.iter().enumerate() {
            let field = |f: &str| format!("objects[{k}].{f}");
            let mesh = meshes.get(&o.mesh).ok_or_else(|| {
                SceneError::field(
                    field("mesh"),
                    format!("no mesh named `{}` in `meshes`", o.mesh),
                )
            })?;
            let material = match &o.material {
                None => 0,
                Some(m) => *material_index.get(m).ok_or_else(|| {
                    SceneError::field(field("material"), format!("no material named `{m}`"))
                })?,
            };
            if !finite3(o.translate_mm) {
                return Err(SceneError::field(field("translate_mm"), "must be finite"));
            }
            if !finite3(o.rotate_deg) {
                return Err(SceneError::field(field("rotate_deg"), "must be finite"));
            }
            if !(o.scale_mm.is_finite() && o.scale_mm > 0.0) {
                return Err(SceneError::field(
                    field("scale_mm"),
                    "must be a positive number",
                ));
            }
            if !(o.importance.is_finite() && (0.0..=1.0).contains(&o.importance)) {
                return Err(SceneError::field(
                    field("importance"),
                    format!("{} must be from 0 to 1", o.importance),
                ));
            }
            object_material.push(material);
            object_importance.push(o.importance);
            let r = o.rotate_deg;
            let rot = Mat3::from_euler(
                EulerRot::ZYX,
                r.2.to_radians(),
                r.1.to_radians(),
                r.0.to_radians(),
            );
            let t = Vec3::new(o.translate_mm.0, o.translate_mm.1, o.translate_mm.2);
            // Every placed vertex must be finite: scaling (and rotating)
            // may overflow f32, and so may translating.
            let mut placed = Vec::with_capacity(mesh.positions.len());
            for p in &mesh.positions {
                let turned = rot * (*p * o.scale_mm);
                if !turned.is_finite() {
                    return Err(SceneError::field(
                        field("scale_mm"),
                        "the scaled mesh overflows f32",
                    ));
                }
                let moved = turned + t;
                if !moved.is_finite() {
                    return Err(SceneError::field(
                        field("translate_mm"),
                        "the translated mesh overflows f32",
                    ));
                }
                placed.push(moved);
            }
            for tri in &mesh.indices {
                let p = tri.map(|i| placed[i as usize]);
                let n = tri.map(|i| rot * mesh.normals[i as usize]);
                if n.iter().any(|v| !v.is_finite()) {
                    return Err(SceneError::field(
                        field("rotate_deg"),
                        "the rotated normals are not finite",
                    ));
                }
                triangles.push(WorldTriangle {
                    p,
                    n,
                    object: k as u32,
                });
            }
        }
        for (i, l) in file.lights.iter().enumerate() {
            let (intensity, (f, ok)) = match l {
                Light::Headlight { intensity } => (intensity, ("intensity", true)),
                Light::Point {
                    position_mm,
                    intensity,
                } => (intensity, ("position_mm", finite3(*position_mm))),
                Light::Directional {
                    direction,
                    intensity,
                } => {
                    let d = Vec3::new(direction.0, direction.1, direction.2);
                    let usable = d.try_normalize().is_some();
                    (intensity, ("direction", finite3(*direction) && usable))
                }
            };
            if !ok {
                return Err(SceneError::field(
                    format!("lights[{i}].{f}"),
                    "must be finite (a direction also non-zero)",
                ));
            }
            if !(intensity.is_finite() && (0.0..=MAX_COLOUR).contains(intensity)) {
                return Err(SceneError::field(
                    format!("lights[{i}].intensity"),
                    format!("{intensity} must be from 0 to {MAX_COLOUR}"),
                ));
            }
        }
        for (name, v) in [
            ("crease_deg", file.crease_deg),
            ("depth_jump", file.depth_jump),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::field(name, "must be zero or positive"));
            }
        }
        let motion = moving_scene(file, &meshes)?;
        Ok(Checked {
            triangles,
            materials,
            object_material,
            object_importance,
            motion,
        })
    }

    /// Whether the scene file gives the camera or any object a path.
    pub fn is_moving(&self) -> bool {
        self.motion.is_some()
    }

    /// What moves, in words (`view --explain`); `None` for a static scene.
    pub fn motion_summary(&self) -> Option<String> {
        let m = self.motion.as_ref()?;
        let camera = match &m.camera {
            Some(c) => format!("a camera path of {} keys ({:?})", c.keys.len(), c.repeat),
            None => "a still camera".to_string(),
        };
        let moving = m.objects.iter().filter(|o| o.motion.is_some()).count();
        Some(format!(
            "{camera}; {moving} of {} objects on paths",
            m.objects.len()
        ))
    }

    /// A moving scene's time and velocities at its pose (`None` when
    /// static). A scene is built posed at time 0.
    pub fn pose(&self) -> Option<&PoseState> {
        self.pose.as_ref()
    }

    /// The scene at `t_s` seconds on its clock: every triangle and light
    /// placed for that time, a new BVH (and grid, if this scene uses one)
    /// and a new [`Scene::revision`]. `None` for a static scene. The cost
    /// is a placement of every vertex and a BVH build (see the README's
    /// *Scenes that move*).
    pub fn posed(&self, t_s: f64) -> Option<Scene> {
        let motion = self.motion.as_ref()?;
        let (triangles, lights, pose) = motion.place(t_s);
        let (triangles, bvh) = hierarchy(triangles);
        let mut scene = Scene {
            name: self.name.clone(),
            background: self.background,
            background_rgb8: self.background_rgb8,
            object_materials: self.object_materials.clone(),
            object_importance: self.object_importance.clone(),
            lights,
            effects: self.effects.clone(),
            crease_deg: self.crease_deg,
            depth_jump: self.depth_jump,
            triangles,
            bvh4: Bvh4::collapse(&bvh),
            bvh,
            grid: None,
            accel: Accel::Bvh,
            revision: next_revision(),
            motion: Some(motion.clone()),
            pose: Some(pose),
        };
        if self.accel == Accel::Grid {
            scene.build_grid();
        }
        Some(scene)
    }

    /// What this geometry is called by caches: unequal for any two builds
    /// (and any two poses of a moving scene); a clone keeps it.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Builds the seed's uniform grid and makes `intersect` use it.
    pub fn build_grid(&mut self) {
        let bounds: Vec<Aabb> = self
            .triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.p.iter().for_each(|p| b.grow(*p));
                b
            })
            .collect();
        self.grid = Some(UniformGrid::build(&bounds));
        self.accel = Accel::Grid;
    }

    /// Whether the scene lists an effect of `e`'s kind (parameters aside).
    pub fn has(&self, e: Effect) -> bool {
        self.effects.iter().any(|x| x.same_kind(&e))
    }

    /// The scene's effect of `e`'s kind, with its parameters.
    pub fn effect(&self, e: Effect) -> Option<&Effect> {
        self.effects.iter().find(|x| x.same_kind(&e))
    }

    /// Closest hit along `ray` with `t` in `(t_min, ∞)`.
    pub fn intersect(&self, ray: &Ray, t_min: f32, test: TriangleTest) -> Option<Hit> {
        if self.triangles.is_empty() {
            return None;
        }
        // Set up the watertight ray only once a triangle is reached: most
        // rays of a sparse scene miss the root box.
        let mut wray: Option<WatertightRay> = None;
        let mut best: Option<(u32, f32, f32, f32)> = None;
        let mut test_one = |i: u32, t_max: f32| -> Option<f32> {
            let tri = &self.triangles[i as usize];
            let h = match test {
                TriangleTest::Watertight => {
                    let w = wray.get_or_insert_with(|| WatertightRay::new(ray));
                    watertight(w, tri.p[0], tri.p[1], tri.p[2], t_min, t_max)
                }
                TriangleTest::MollerTrumbore => {
                    moller_trumbore(ray, tri.p[0], tri.p[1], tri.p[2], t_min, t_max)
                }
            }?;
            best = Some((i, h.t, h.u, h.v));
            Some(h.t)
        };
        match (self.accel, &self.grid) {
            (Accel::Grid, Some(grid)) => {
                let mut closest = f32::INFINITY;
                grid.traverse(ray, |tris, cell_exit| {
                    for &i in tris {
                        if let Some(t) = test_one(i, closest) {
                            closest = t;
                        }
                    }
                    closest <= cell_exit
                });
            }
            _ => {
                let leaf = |first: u32, count: u32, mut t_max: f32| {
                    for i in first..first + count {
                        if let Some(t) = test_one(i, t_max) {
                            t_max = t;
                        }
                    }
                    t_max
                };
                if ray.is_parallel() {
                    // A zero direction component needs the exact slab test.
                    self.bvh.traverse(ray, f32::INFINITY, leaf);
                } else {
                    self.bvh4.traverse(ray, f32::INFINITY, leaf);
                }
            }
        }
        best.map(|(i, t, u, v)| {
            let tri = &self.triangles[i as usize];
            let n = tri.n[0] * (1.0 - u - v) + tri.n[1] * u + tri.n[2] * v;
            let face = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
            let normal = n
                .try_normalize()
                .or_else(|| face.try_normalize())
                .unwrap_or(Vec3::Z);
            Hit {
                t,
                object: tri.object,
                triangle: i,
                normal,
            }
        })
    }
}

/// An OBJ path from a scene file: absolute as it is, relative to the
/// scene file's folder otherwise.
fn obj_path(path: &str, base_dir: &Path) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base_dir.join(p)
    }
}
