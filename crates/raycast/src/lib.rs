//! # raycast — the hybrid foveated ray caster (CPU reference)
//!
//! Scenes ([`scene`]), meshes ([`mesh`]), the BVH ([`bvh`], binary and flat
//! for the GPU; [`bvh4`], 4-wide for the CPU), the seed's uniform grid
//! ([`grid`]), robust ray/box and ray/triangle tests ([`ray`]), the eye-through-the-display
//! camera ([`camera`]), Blinn–Phong shading ([`shade`]) and the full and
//! foveated renderers ([`render`]) of Murphy 2007 ch. 4–6, and the GPU core
//! ([`gpu`], wgpu compute over the flat binary BVH; full resolution so far),
//! which must match these images.

pub mod bvh;
pub mod bvh4;
pub mod camera;
pub mod error;
pub mod gpu;
pub mod grid;
pub mod mesh;
pub mod ray;
pub mod render;
pub mod scene;
pub mod shade;

pub use camera::Camera;
pub use error::SceneError;
pub use render::{render, Frame, Layer, Mode, Settings, Stats, Triggers};
pub use scene::{Scene, SceneFile};
