//! The hybrid foveated ray caster: loads scenes and casts their frames,
//! every pixel or Murphy 2007's gaze-dependent ray mask with
//! reconstruction and refinement, on the CPU or (feature `gpu`) the GPU.
//!
//! Modules:
//! - [`scene`]: scene files and the world they describe ([`Scene`]);
//! - [`mesh`]: triangle meshes, loaded from OBJ or generated;
//! - [`accel`]: acceleration structures — the binary BVH ([`bvh`], flat for
//!   the GPU), the 4-wide BVH the CPU traverses ([`bvh4`]) and the seed's
//!   uniform grid ([`grid`]); `raycast::bvh`, `raycast::bvh4` and
//!   `raycast::grid` are re-exports of `raycast::accel::*`;
//! - [`ray`]: robust ray/box and ray/triangle tests;
//! - [`layers`]: the first K surfaces along a primary ray (hidden-surface
//!   layers, exact with rays);
//! - [`camera`]: the eye-through-the-display camera;
//! - [`shade`]: Blinn–Phong shading and the gamma table;
//! - [`frame`]: the G-buffer a frame fills ([`Frame`]: colour, hit, depth,
//!   object id, normal, layer);
//! - [`render`](mod@render): the CPU reference renderers, full resolution and foveated
//!   (Murphy 2007 ch. 4–6);
//! - [`raster`]: the CPU triangle rasteriser (a chosen subset of triangles, same G-buffer);
//! - `gpu` (feature `gpu`, on by default): the GPU core (wgpu compute over the flat binary BVH): the
//!   full-resolution frame and the foveated stages (mask vertices, cell
//!   classification, silhouette margin, interpolation, compacted refined
//!   pixels cast by an indirect dispatch), timed with timestamp queries
//!   where the adapter has them, and the raster path of the model-based
//!   methods (a render pipeline); it fills the same G-buffer as the CPU;
//! - [`error`]: scene and mesh errors.

#![warn(missing_docs)]

pub mod accel;
pub mod camera;
pub mod error;
pub mod frame;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod layers;
pub mod mesh;
pub mod motion;
pub mod raster;
pub mod ray;
pub mod render;
pub mod scene;
pub mod shade;

pub use accel::{bvh, bvh4, grid};
pub use camera::Camera;
pub use error::SceneError;
pub use frame::{layers_rgb, Frame, Layer, NO_OBJECT};
pub use render::{render, Mode, Settings, Stats, Triggers};
pub use scene::{Scene, SceneFile};
