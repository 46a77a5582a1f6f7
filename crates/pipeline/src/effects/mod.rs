//! Effects: passes over a filled G-buffer, assembled from the scene's effect
//! list. An effect the scene does not list is never constructed: it
//! allocates nothing and runs nothing.
//!
//! Adding an effect: a variant of `raycast::scene::Effect` (with its
//! parameters, parsed from the scene file), a module here implementing
//! [`Pass`], and one arm in [`pass_for`].

pub mod depth_of_field;
pub mod dof_reference;
pub mod dof_splat;
pub mod por_overlay;
pub mod refocus;

use raycast::scene::{DofMethod, Effect};
use raycast::{Camera, Frame, Scene};

/// What a pass may read besides the frame.
#[derive(Debug, Clone, Copy)]
pub struct PassInput<'a> {
    pub scene: &'a Scene,
    pub camera: &'a Camera,
    /// The point of regard the frame was rendered for (screen px).
    pub gaze_px: [f64; 2],
    /// The frame's time, s (any fixed origin), for passes with dynamics
    /// (depth of field's refocusing); `None`: no clock, such passes act at
    /// once. `Renderer::render` gives the wall clock, `render_at` the
    /// caller's time.
    pub time_s: Option<f64>,
    /// The eye distance of the binocular 3-D gaze point for this frame, mm
    /// (Murphy & Duchowski eqs. 1–3), when the tracker's sample had both
    /// eyes valid and converging; `None` otherwise. Read by depth of
    /// field's `focus: Vergence`.
    pub vergence_mm: Option<f64>,
}

/// One pass over a rendered frame.
pub trait Pass: Send {
    /// The name `--explain` prints.
    fn name(&self) -> &'static str;
    /// Reads and writes the frame in place.
    fn run(&mut self, frame: &mut Frame, input: &PassInput<'_>);

    /// The pass itself, for callers that inspect a known pass (debug maps).
    fn as_any(&self) -> &dyn std::any::Any;

    /// Whether the pass reads the frame's surface buffers (depth, object
    /// id, normal); the method fills them only when some pass does.
    fn needs_surface(&self) -> bool {
        false
    }
}

/// The pass an effect of the scene file runs after the method, if any.
/// Sampling and refinement effects configure the hybrid method and run no
/// pass of their own.
pub fn pass_for(effect: &Effect) -> Option<Box<dyn Pass>> {
    match effect {
        Effect::PorOverlay { half_px } => Some(Box::new(por_overlay::PorOverlay {
            half_px: i64::from(*half_px),
        })),
        Effect::DepthOfField { method, .. } => match method {
            DofMethod::Mipmap => depth_of_field::DepthOfField::from_effect(effect)
                .map(|p| Box::new(p) as Box<dyn Pass>),
            DofMethod::Splat => dof_splat::DepthOfFieldSplat::from_effect(effect)
                .map(|p| Box::new(p) as Box<dyn Pass>),
        },
        Effect::FoveatedSampling
        | Effect::SilhouetteRefinement
        | Effect::CreaseRefinement
        | Effect::DepthRefinement => None,
    }
}

/// The passes for `scene`, in the order its file lists them, plus the POR
/// overlay when `por_overlay` asks for it and the scene does not.
pub fn passes_for(scene: &Scene, por_overlay: bool) -> Vec<Box<dyn Pass>> {
    let mut passes: Vec<Box<dyn Pass>> = scene.effects.iter().filter_map(pass_for).collect();
    if por_overlay && !scene.has(Effect::POR_OVERLAY) {
        passes.push(Box::new(por_overlay::PorOverlay::default()));
    }
    passes
}
