//! Model-based: Murphy & Duchowski 2001's gaze-contingent level of detail
//! (Table 1's levels by eccentricity), rasterised. The state is
//! [`ModelBased`], shared with `simplify`.

use crate::model_based::ModelBased;
use crate::registry::{FrameMethod, MethodModule, MethodSetup};
use crate::{Method, RenderError};

/// The `lod` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "lod",
    aliases: &["murphy-duchowski"],
    help: "Model-based: Murphy & Duchowski 2001's gaze-contingent level of detail (Table 1's \
           levels by eccentricity), rasterised (CPU or GPU)",
    foveated: true,
    gpu: true,
    gpu_post: false,
    static_scene: true,
    make,
};

fn make(setup: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    ModelBased::new(
        setup.scene,
        setup.camera,
        Method::Lod,
        setup.options.model_based,
    )
    .map(|m| Box::new(m) as Box<dyn FrameMethod>)
    .map_err(RenderError::Unsupported)
}
