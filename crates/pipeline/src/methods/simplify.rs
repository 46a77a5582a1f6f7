//! Model-based: Luebke & Hallen 2001's perceptual simplification
//! (imperceptible mode, or best-effort under a triangle budget),
//! rasterised. The state is [`ModelBased`], shared with `lod`.

use crate::model_based::ModelBased;
use crate::registry::{FrameMethod, MethodModule, MethodSetup};
use crate::{Method, RenderError};

/// The `simplify` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "simplify",
    aliases: &["luebke-hallen"],
    help: "Model-based: Luebke & Hallen 2001's perceptual simplification (imperceptible mode: \
           every fold the Geisler–Perry table judges invisible at its eccentricity), rasterised \
           (CPU or GPU)",
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
        Method::Simplify,
        setup.options.model_based,
    )
    .map(|m| Box::new(m) as Box<dyn FrameMethod>)
    .map_err(RenderError::Unsupported)
}
