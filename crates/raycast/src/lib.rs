//! # raycast — the hybrid ray caster (not yet implemented)
//!
//! This crate will hold scenes, the BVH, the CPU reference caster, the wgpu
//! compute core and the reconstruction from the intermediate mesh (issues 5
//! and 6). It is empty on purpose: nothing here pretends to work yet. The ray
//! mask it will cast is built by `foveation::mask`.
