//! Scene files (`config/scenes/*.ron`) and the world they describe: every
//! object's triangles in world space (millimetres, the display's frame: the
//! screen centre at the origin, x right, y up, z towards the viewer; objects
//! behind the screen have z < 0), with one BVH over all of them.
//!
//! The file's schema is in [`file`]: the sampling and its refinement
//! triggers in `sampling`, the post passes and their parameters in
//! `pass`, the old form's effect list in `effect`. Building, checking
//! and placing a scene is `build`; moving scenes pose themselves with
//! `motion`; ray queries are in `intersect`.

mod build;
mod effect;
mod file;
mod intersect;
mod motion;
mod pass;
mod sampling;

use crate::accel::{Bvh, Bvh4, UniformGrid};
use crate::ray::Aabb;
use build::hierarchy;

pub use build::{BYTES_PER_TRIANGLE, MAX_TRIANGLES};
pub use effect::Effect;
pub use file::{Light, Material, MeshSource, Object, SceneFile, FACE_EXPRESSIONS, MAX_COLOUR};
pub use intersect::Hit;
pub use motion::PoseState;
pub use pass::{
    DofFocus, DofMethod, DofRefocus, PostPass, DOF_LENS_MM_MAX, DOF_PUPIL_MM_MAX,
    DOF_REFOCUS_HZ_MAX, DOF_REFOCUS_MS_MAX, POR_HALF_PX, POR_HALF_PX_MAX,
};
pub use sampling::{Refinement, Sampling, DEFAULT_CREASE_DEG, DEFAULT_DEPTH_JUMP};

use glam::Vec3;
use motion::SceneMotion;

/// One world-space triangle: corners, corner normals, object.
#[derive(Debug, Clone, Copy)]
pub struct WorldTriangle {
    /// Corners, world mm.
    pub p: [Vec3; 3],
    /// Unit normals at the corners.
    pub n: [Vec3; 3],
    /// The object the triangle belongs to (its id).
    pub object: u32,
}

/// A loaded scene, ready to trace.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene's name (from the file).
    pub name: String,
    /// Background colour, linear RGB (1 = white).
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
    /// The lights.
    pub lights: Vec<Light>,
    /// How the frame is sampled, with the hybrid's refinement triggers.
    pub sampling: Sampling,
    /// The post passes, in order.
    pub passes: Vec<PostPass>,
    /// Triangles in BVH leaf order.
    pub triangles: Vec<WorldTriangle>,
    /// The binary BVH over `triangles`.
    pub bvh: Bvh,
    /// The same hierarchy 4 wide, traversed by the CPU caster.
    pub bvh4: Bvh4,
    /// The seed's uniform grid over the same triangles, when asked for
    /// ([`Scene::build_grid`]); used when `accel` is `Grid`.
    pub grid: Option<UniformGrid>,
    /// Which structure rays are traced through.
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

/// The next [`Scene::revision`].
fn next_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Which acceleration structure `intersect` uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Accel {
    /// The BVH (the default).
    #[default]
    Bvh,
    /// Murphy 2007 §6.1.1, for comparison.
    Grid,
}

impl Scene {
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
            sampling: self.sampling.clone(),
            passes: self.passes.clone(),
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

    /// The post passes, in order.
    pub fn passes(&self) -> &[PostPass] {
        &self.passes
    }

    /// The scene's pass of `kind`'s kind, with its parameters.
    pub fn pass(&self, kind: &PostPass) -> Option<&PostPass> {
        self.passes.iter().find(|x| x.same_kind(kind))
    }

    /// Whether the scene asks for a pass of `kind`'s kind.
    pub fn has_pass(&self, kind: &PostPass) -> bool {
        self.pass(kind).is_some()
    }
}
