//! Acceleration structures over a scene's triangles: the binary BVH
//! ([`bvh`], binned SAH, stored flat so the GPU core uploads it as is), the
//! 4-wide BVH collapsed from it ([`bvh4`], what the CPU caster traverses)
//! and the seed's uniform grid ([`grid`], Murphy 2007 §6.1.1, for
//! comparison). `raycast::bvh`, `raycast::bvh4` and `raycast::grid` name
//! these same modules.

pub mod bvh;
pub mod bvh4;
pub mod grid;

pub use bvh::{Bvh, BvhNode};
pub use bvh4::{Bvh4, Bvh4Node};
pub use grid::UniformGrid;
