//! Murphy 2007's hybrid: the CSF ray mask, reconstruction from the
//! intermediate mesh, refinement where the scene's effects ask. On the
//! CPU the ray caster's foveated mode; on the GPU the mask and pixel
//! ownership are built on the CPU and uploaded to the GPU core.

use raycast::gpu;
use raycast::render::{Mode, Settings, Stats};
use raycast::Frame;

use super::cast;
use crate::plan::{Channels, Side};
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodModule, MethodSetup};
use crate::RenderError;

/// The `hybrid` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "hybrid",
    aliases: &["foveated"],
    help: "Murphy 2007's hybrid: the CSF ray mask, reconstruction from the intermediate mesh, \
           refinement where the scene's effects ask",
    foveated: true,
    gpu: true,
    gpu_post: true,
    static_scene: false,
    make,
};

fn make(setup: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    Ok(Box::new(Hybrid {
        settings: cast::settings(Mode::Hybrid, setup),
    }))
}

/// The hybrid method's state: its ray-caster settings (the mask and
/// owners are in the renderer's scratch, kept across frames).
pub struct Hybrid {
    settings: Settings,
}

impl FrameMethod for Hybrid {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        cast::cast(input, &self.settings, frame)
    }

    fn writes(&self) -> Channels {
        Channels::COLOUR | Channels::HIT | Channels::LAYER
    }

    fn detail(&self, on: &MethodContext<'_>) -> String {
        let t = &self.settings.triggers;
        let mut out = Vec::new();
        let stages: Vec<&str> = match on.side {
            Side::Gpu => {
                out.push(
                    "per new mask: ray mask (CPU), uploaded; build pixel ownership (GPU)"
                        .to_string(),
                );
                gpu::foveated_stages(t).iter().map(|s| s.name()).collect()
            }
            Side::Cpu => {
                out.push("per new mask: ray mask".into());
                let mut v = vec!["cast vertices"];
                if t.silhouette || t.crease_deg.is_some() || t.depth_jump.is_some() {
                    v.push("classify cells");
                }
                if t.margin {
                    v.push("silhouette margin");
                }
                v.extend(["pixel ownership", "cast or interpolate pixels, and shade"]);
                v
            }
        };
        out.push(format!("per frame: {}", stages.join(" → ")));
        let tolerance = on.model.gaze_tolerance_deg;
        out.push(if tolerance > 0.0 {
            format!(
                "gaze tolerance {tolerance}°: masks dense enough for any gaze within {tolerance}° of theirs; a mask is kept while the gaze stays within it{}",
                if on.reuse && on.side == Side::Cpu {
                    " (its vertex rays, cells and owners kept; a second frame in a row copied)"
                } else {
                    ""
                }
            )
        } else {
            "gaze tolerance 0°: a new mask for every new gaze".to_string()
        });
        let mut triggers = Vec::new();
        if t.silhouette {
            triggers.push("silhouette (+ one-cell margin)".to_string());
        }
        if let Some(d) = t.crease_deg {
            triggers.push(format!("crease > {d}°"));
        }
        if let Some(j) = t.depth_jump {
            triggers.push(format!("depth jump > {:.0} %", 100.0 * j));
        }
        out.push(format!(
            "refinement triggers: {}",
            if triggers.is_empty() {
                "none (no cell is classified or refined)".to_string()
            } else {
                triggers.join(", ")
            }
        ));
        out.join("\n")
    }

    fn owns(&self, side: Side) -> String {
        match side {
            Side::Cpu => "the ray mask, vertex hits, cell classes and pixel owners".into(),
            Side::Gpu => {
                "the ray mask and pixel owners (CPU), uploaded; vertex and cell buffers (GPU)"
                    .into()
            }
        }
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
