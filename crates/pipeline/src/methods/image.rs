//! Image-based foveation (Geisler & Perry 1998): every pixel cast, then
//! blurred by a Gaussian pyramid to the level the CSF allows at its
//! eccentricity — the blur is the method's own pass
//! ([`ImagePass`], on the GPU when the backend is), first in the plan.

use raycast::render::{Mode, Settings, Stats};
use raycast::Frame;

use super::cast;
use crate::effects::Pass;
use crate::image_foveation::ImagePass;
use crate::plan::Side;
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodModule, MethodSetup};
use crate::RenderError;

/// The `image` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "image",
    aliases: &["image-based"],
    help: "Image-based foveation (Geisler & Perry 1998): every pixel cast, then blurred by a \
           Gaussian pyramid to the level the CSF allows at its eccentricity",
    foveated: true,
    gpu: true,
    gpu_post: true,
    static_scene: false,
    make,
};

fn make(setup: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    Ok(Box::new(Image {
        settings: cast::settings(Mode::Full, setup),
    }))
}

/// The image-based method's state: its ray-caster settings (the filter
/// is its pass's).
pub struct Image {
    settings: Settings,
}

impl FrameMethod for Image {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        // The blur needs a gaze; refused before anything is cast.
        for (name, v) in [("gaze.x", input.gaze_px[0]), ("gaze.y", input.gaze_px[1])] {
            if !v.is_finite() {
                return Err(RenderError::Gaze(foveation::ParamError::new(
                    name,
                    v,
                    "the point of regard must be finite",
                )));
            }
        }
        cast::cast(input, &self.settings, frame)
    }

    fn detail(&self, on: &MethodContext<'_>) -> String {
        match on.side {
            Side::Gpu => "per frame: cast and shade every pixel, then image-based foveation on \
                          the GPU (its pass below)"
                .to_string(),
            Side::Cpu => format!(
                "per frame: cast and shade every pixel, then image-based foveation (CPU): \
                 level log2(ray spacing) per pixel (spacing ≤ {} px), Gaussian pyramid, \
                 blend of adjacent levels",
                on.model.max_spacing_px
            ),
        }
    }

    fn owns(&self, _: Side) -> String {
        "nothing besides the frame".into()
    }

    fn own_passes(&mut self) -> Vec<Box<dyn Pass>> {
        vec![Box::<ImagePass>::default()]
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
