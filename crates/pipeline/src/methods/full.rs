//! The control condition: one ray per pixel, cast and shaded.

use raycast::render::{Mode, Settings, Stats};
use raycast::Frame;

use super::cast;
use crate::plan::Side;
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodModule, MethodSetup};
use crate::RenderError;

/// The `full` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "full",
    aliases: &[],
    help: "One ray per pixel (the control condition)",
    foveated: false,
    gpu: true,
    gpu_post: true,
    static_scene: false,
    make,
};

fn make(setup: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    Ok(Box::new(Full {
        settings: cast::settings(Mode::Full, setup),
    }))
}

/// The full method's state: its ray-caster settings.
pub struct Full {
    settings: Settings,
}

impl FrameMethod for Full {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        cast::cast(input, &self.settings, frame)
    }

    fn detail(&self, _: &MethodContext<'_>) -> String {
        "per frame: cast and shade every pixel (no mask, no foveated buffers)".into()
    }

    fn owns(&self, _: Side) -> String {
        "nothing besides the frame".into()
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
