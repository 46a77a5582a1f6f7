//! The ray caster's frame, shared by the methods that cast rays through
//! the display (full, hybrid, image-based): on the CPU
//! [`raycast::render::render_with`]; on the GPU the GPU core's full or
//! foveated frame, with the GPU passes encoded between its cast and its
//! read-back. Not a method of its own.

use raycast::render::{Mode, Settings, Stats, Triggers};
use raycast::Frame;

use crate::registry::{MethodFrame, MethodSetup};
use crate::RenderError;

/// The ray caster's settings for a method casting in `mode`: the layout,
/// triangle test and coverage check the options give, and the refinement
/// triggers they give or else the scene's effects.
pub(crate) fn settings(mode: Mode, setup: &MethodSetup<'_>) -> Settings {
    let options = setup.options;
    Settings {
        mode,
        layout: options.layout,
        triggers: options
            .triggers
            .unwrap_or_else(|| Triggers::from_scene(setup.scene)),
        test: options.test,
        check_coverage: options.check_coverage,
    }
}

/// Casts one frame under `settings` into `frame`.
pub(crate) fn cast(
    input: MethodFrame<'_>,
    settings: &Settings,
    frame: &mut Frame,
) -> Result<Stats, RenderError> {
    let Some(g) = input.gpu else {
        return Ok(raycast::render::render_with(
            input.scene,
            input.camera,
            input.model,
            settings,
            input.gaze_px,
            input.surface,
            frame,
            input.scratch,
        )?);
    };
    g.set_surface(input.surface);
    let (got, stats) = match settings.mode {
        Mode::Hybrid => {
            // The mask kept across frames (the same gaze, or one within
            // the model's tolerance): the GPU keeps its upload and pixel
            // owners too.
            let (_, generation) =
                input
                    .scratch
                    .mask_for(input.model, settings.layout, input.gaze_px)?;
            let mask = input
                .scratch
                .mask()
                .ok_or_else(|| RenderError::Unsupported("no ray mask was built".into()))?;
            g.render_foveated_kept(
                input.camera,
                mask,
                Some(generation),
                &settings.triggers,
                input.post,
            )?
        }
        Mode::Full => g.render_full_with(input.camera, input.post)?,
    };
    *frame = got;
    Ok(stats)
}
