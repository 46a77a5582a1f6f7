//! Moving scenes: what a scene with paths keeps to pose itself at any
//! time (meshes, object poses, the camera's path), the placing of its
//! triangles and lights, and the velocities at a pose.

use std::collections::BTreeMap;

use glam::Vec3;

use super::file::{Light, SceneFile};
use super::WorldTriangle;
use crate::error::SceneError;
use crate::mesh::TriangleMesh;
use crate::motion::{Motion, Pose};

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
pub(super) struct MovingObject {
    pub(super) mesh: usize,
    pub(super) scale_mm: f32,
    pub(super) base: Pose,
    pub(super) motion: Option<Motion>,
    /// The scaled mesh's bounding-box corners (object frame, mm).
    pub(super) corners: [Vec3; 8],
}

/// What a moving scene keeps to pose itself.
#[derive(Debug)]
pub(super) struct SceneMotion {
    pub(super) meshes: Vec<TriangleMesh>,
    pub(super) objects: Vec<MovingObject>,
    pub(super) camera: Option<Motion>,
    /// The scene file's lights, in world coordinates.
    pub(super) lights: Vec<Light>,
}

/// Time step of the velocities' central differences, s.
const VELOCITY_STEP_S: f64 = 1e-3;

impl SceneMotion {
    /// The viewer's pose at `t_s` (identity without a camera path).
    pub(super) fn camera(&self, t_s: f64) -> Pose {
        self.camera.as_ref().map_or(Pose::IDENTITY, |m| m.pose(t_s))
    }

    /// Object `o`'s pose in the display frame at `t_s`, given the viewer's
    /// inverse pose `view`.
    pub(super) fn object(&self, o: &MovingObject, view: &Pose, t_s: f64) -> Pose {
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
    pub(super) fn place(&self, t_s: f64) -> (Vec<WorldTriangle>, Vec<Light>, PoseState) {
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
    pub(super) fn velocities(&self, t_s: f64) -> PoseState {
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

/// Largest coordinate (mm) any pose of a moving scene may reach: far
/// inside `f32` so that placing, differencing and intersecting stay finite.
const MAX_POSED_MM: f32 = 1e15;

/// The paths of a scene file, checked, with the meshes they move; `None`
/// when nothing moves. Every pose stays within [`MAX_POSED_MM`]: a rotation
/// keeps a point's distance from the origin, so an object's corners lie
/// within its scaled radius of base + path translation, and the camera's
/// inverse pose adds at most its own translation.
pub(super) fn moving_scene(
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
