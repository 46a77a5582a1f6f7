//! # pipeline — one entry for a frame
//!
//! Every command that renders (`render`, `view`, `demo`, `bench`, and what
//! comes) goes through [`Renderer`]:
//!
//! ```text
//! gaze ──► Renderer::render ──► method (Method::Full | Hybrid | Image) on a
//!          backend (CPU | GPU) fills the G-buffer Frame
//!          ──► the scene's effects run as passes over it ──► Frame
//! ```
//!
//! - A **method** ([`Method`]) is a value dispatched in exactly one place,
//!   [`Renderer::render`]. A new rendering method is one module and one arm
//!   there (and a variant of [`Method`]).
//! - The **G-buffer** is [`raycast::Frame`]: colour, hit, depth (eye distance,
//!   mm), object id, normal and layer per pixel, filled identically by both
//!   backends.
//! - **Effects** are passes ([`effects::Pass`]) assembled from the scene's
//!   effect list by [`effects::passes_for`]: a new effect is one module and
//!   one registration arm there. An effect the scene does not list
//!   allocates nothing and runs no pass. The refinement effects
//!   (`FoveatedSampling`, `SilhouetteRefinement`, …) are not passes: they
//!   configure the hybrid method.
//! - On the **GPU backend** depth of field and image-based foveation run on
//!   the GPU frame's buffers before the read-back (`gpu`, WGSL twins of the
//!   CPU passes, which stay the reference), and so does the per-pixel part
//!   of Lee's attention model when depth of field focuses on the attended
//!   object ([`gpu_attention`] states the split and its tolerance).

pub mod backend;
pub mod colour;
pub mod effects;
pub mod frame_attention;
mod gpu;
pub mod gpu_attention;
pub mod image_foveation;
pub mod method;
pub mod model;
pub mod model_based;
pub mod renderer;
pub mod ulod;

pub use backend::BackendChoice;
pub use method::Method;
pub use model::sampling_model;
pub use renderer::{Options, RenderError, Renderer, EYE_DISTANCE_RANGE_MM, EYE_DISTANCE_STEP};
