//! Renders a frame for a point of regard: the one entry every command
//! goes through, which runs the chosen rendering method on the CPU or the
//! GPU and then the scene's effect passes ([`Renderer`]).
//!
//! Every command that renders (`render`, `view`, `demo`, `bench`, the
//! experiment runner) goes through [`Renderer`]:
//!
//! ```text
//! gaze ──► Renderer::render ──► the frame plan, decided once in Renderer::new:
//!          1. the method (a module in methods/: full, hybrid, image,
//!             simplify, lod, ulod, layers) fills the G-buffer Frame on a
//!             backend (CPU | GPU)
//!          2. the GPU passes, chained between the cast and the read-back
//!          3. the CPU passes, after it ──► Frame
//! ```
//!
//! - A **method** ([`Method`]) is chosen in one place,
//!   [`Method::for_scene`]. Each is one module in [`methods`]: its
//!   [`registry::MethodModule`] (names, help, whether it follows the gaze,
//!   runs on the GPU, takes GPU passes before its read-back) and its state,
//!   a [`registry::FrameMethod`] made for it alone, which the renderer
//!   calls without knowing which method it is.
//! - The **G-buffer** is [`raycast::Frame`]: colour, hit, depth (eye distance,
//!   mm), object id, normal and layer per pixel, filled identically by both
//!   backends ([`plan::Channels`] names them).
//! - **Passes** ([`effects::Pass`]) are assembled from the scene's effect
//!   list by [`effects::passes_for`] (a new effect is one module and one
//!   registration arm there); a method's own pass (image-based foveation's
//!   blur) goes first. Each declares what it reads and writes and what it
//!   owns. An effect the scene does not list allocates nothing and runs no
//!   pass. The scene's sampling (`Foveated(refine:
//!   [Silhouette, …])`, the old form's `FoveatedSampling`,
//!   `SilhouetteRefinement`, …) is not a pass: it gates and configures the
//!   hybrid method.
//! - **The frame plan** ([`plan::FramePlan`], [`Renderer::plan`]): on the
//!   GPU backend every pass from the first on that has a GPU implementation
//!   ([`effects::Pass::into_gpu`]: image-based foveation, both depth-of-field
//!   passes without foreground smoothing, the POR box) runs on the GPU in
//!   order; the first pass with only a CPU implementation forces the
//!   read-back, and it and the passes after it run on the CPU. The plan is
//!   built from the lists `Renderer::render` walks, `explain` prints it,
//!   and [`Renderer::provenance`] puts it in one line for every frame's
//!   record. The GPU implementations (`gpu`, WGSL twins of the CPU passes,
//!   which stay the reference) include the per-pixel part of Lee's
//!   attention model when depth of field focuses on the attended object
//!   ([`gpu_attention`] states the split and its tolerance).

#![warn(missing_docs)]

pub mod backend;
pub mod colour;
pub mod effects;
pub mod frame_attention;
mod gpu;
pub mod gpu_attention;
pub mod image_foveation;
pub mod maps;
pub mod method;
pub mod methods;
pub mod model_based;
pub mod plan;
mod pyramid;
pub mod registry;
pub mod renderer;
pub mod sampling;
pub mod ulod;

pub use backend::BackendChoice;
pub use method::Method;
pub use plan::FramePlan;
pub use renderer::{Options, RenderError, Renderer, EYE_DISTANCE_RANGE_MM, EYE_DISTANCE_STEP};
pub use sampling::{sampling_model, sampling_model_with};
