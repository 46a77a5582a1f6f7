//! The old form of a scene's effects: one list `effects: [FoveatedSampling,
//! SilhouetteRefinement, …, DepthOfField(…)]` mixing the sampling, its
//! refinement triggers and the post passes, with the refinement parameters
//! (`crease_deg`, `depth_jump`) at the scene's top level. Labs have files
//! in this form: it is still read, and translated into the new form
//! ([`Sampling`] and [`PostPass`]) when a scene is built.

use serde::{Deserialize, Serialize};

use super::pass::{
    default_dof_focal_length_mm, default_dof_pupil_mm, default_dof_retina_distance_mm,
    default_por_half_px, DofFocus, DofMethod, DofRefocus, PostPass,
};
use super::sampling::{Refinement, Sampling};
use crate::error::SceneError;

/// An entry of the old form's `effects` list. Each kind may appear once in
/// a scene (a second is an error naming both).
///
/// An effect may carry parameters, written in the scene file as
/// `Name(field: value, …)` (RON's struct variants: the parentheses are
/// needed even when every field keeps its default, e.g. `PorOverlay()`);
/// an unknown effect or field is an error naming file, line and field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Effect {
    /// Cast the CSF ray mask instead of every pixel.
    FoveatedSampling,
    /// Refine cells whose corners disagree on hit/miss or object.
    SilhouetteRefinement,
    /// Refine cells whose corner normals differ by more than the crease angle.
    CreaseRefinement,
    /// Refine cells with a depth jump between corners.
    DepthRefinement,
    /// Draw the POR box (the seed's figures): a 2-px square outline of
    /// half-size `half_px` around the gaze; `PorOverlay()` gives the seed's
    /// 64-px box.
    PorOverlay {
        /// Half-size of the box, pixels (default 32: the seed's 64-px box).
        #[serde(default = "default_por_half_px")]
        half_px: u32,
    },
    /// Depth of field (Lee 2009, ch. 4 or 5): the eye as a thin lens of
    /// pupil diameter `pupil_mm` (0: no blur), focal length
    /// `focal_length_mm` and lens-to-retina distance `retina_distance_mm`,
    /// focused at `focus`, refocusing on a change of focus as `refocus`
    /// says, blurring by `method` (ch. 4 mipmaps by default, or ch. 5
    /// splatting). `DepthOfField()` gives Lee's adult eye (4 mm pupil,
    /// 16.7 mm, 24 mm) focused at the depth under the gaze, refocusing at
    /// once, by mipmaps.
    DepthOfField {
        /// Pupil diameter, mm (default 4; 0: no blur).
        #[serde(default = "default_dof_pupil_mm")]
        pupil_mm: f64,
        /// The eye's focal length, mm (default 16.7).
        #[serde(default = "default_dof_focal_length_mm")]
        focal_length_mm: f64,
        /// Lens-to-retina distance, mm (default 24).
        #[serde(default = "default_dof_retina_distance_mm")]
        retina_distance_mm: f64,
        /// Where the eye focuses (default: the depth under the gaze).
        #[serde(default)]
        focus: DofFocus,
        /// How the focus follows a change of target (default: at once).
        #[serde(default)]
        refocus: DofRefocus,
        /// How the blur is made (default: ch. 4 mipmaps).
        #[serde(default)]
        method: DofMethod,
        /// Lee §4.3's foreground smoothing (eqs. 4.10–4.11, mipmap method
        /// only): the degree of blur is read from a coarser level around
        /// blurred foreground objects, so their blurred edges spread over
        /// the sharp surface behind them instead of ending at the
        /// silhouette. Off by default: it blurs in-focus pixels next to a
        /// blurred foreground.
        #[serde(default)]
        smooth_foreground: bool,
        /// Lee §5.2's defocused highlights (eq. 5.5, splatting method
        /// only): a blurred bright colour is extrapolated beyond the 8-bit
        /// frame's white (λ₀ 0.8, β 3, γ 2), so a defocused highlight
        /// stays bright. Off by default.
        #[serde(default)]
        highlights: bool,
    },
}

impl Effect {
    /// The POR overlay with the seed's size.
    pub const POR_OVERLAY: Effect = Effect::PorOverlay {
        half_px: super::pass::POR_HALF_PX,
    };

    /// Depth of field with its defaults (Lee's adult eye, focus at the gaze).
    pub const DEPTH_OF_FIELD: Effect = Effect::DepthOfField {
        pupil_mm: 4.0,
        focal_length_mm: 16.7,
        retina_distance_mm: 24.0,
        focus: DofFocus::Gaze,
        refocus: DofRefocus::Instant,
        method: DofMethod::Mipmap,
        smooth_foreground: false,
        highlights: false,
    };

    /// Whether `self` and `other` are the same effect, whatever their
    /// parameters.
    pub fn same_kind(&self, other: &Effect) -> bool {
        std::mem::discriminant(self) == std::mem::discriminant(other)
    }

    /// The effect's name as the scene file writes it (`DepthOfField`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Effect::FoveatedSampling => "FoveatedSampling",
            Effect::SilhouetteRefinement => "SilhouetteRefinement",
            Effect::CreaseRefinement => "CreaseRefinement",
            Effect::DepthRefinement => "DepthRefinement",
            Effect::PorOverlay { .. } => "PorOverlay",
            Effect::DepthOfField { .. } => "DepthOfField",
        }
    }

    /// The post pass this entry asks for; `None` for the sampling and its
    /// refinement triggers.
    pub fn pass(&self) -> Option<PostPass> {
        match *self {
            Effect::PorOverlay { half_px } => Some(PostPass::PorOverlay { half_px }),
            Effect::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                method,
                smooth_foreground,
                highlights,
            } => Some(PostPass::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                method,
                smooth_foreground,
                highlights,
            }),
            Effect::FoveatedSampling
            | Effect::SilhouetteRefinement
            | Effect::CreaseRefinement
            | Effect::DepthRefinement => None,
        }
    }
}

/// The old form's list checked (each entry's parameters, each kind once;
/// errors name `effects[i]…`) and translated: the sampling, with the
/// refinement triggers the list turns on and the top-level parameters
/// inside it, and the post passes in list order. Refinement triggers
/// without `FoveatedSampling` had no effect and are dropped.
pub(super) fn translate(
    effects: &[Effect],
    crease_deg: f32,
    depth_jump: f32,
) -> Result<(Sampling, Vec<PostPass>), SceneError> {
    let mut passes = Vec::new();
    for (i, e) in effects.iter().enumerate() {
        if let Some(pass) = e.pass() {
            pass.validate(&format!("effects[{i}]"))?;
            passes.push(pass);
        }
        // Each effect is a switch or one pass with one set of
        // parameters: a second of a kind would run twice or be ignored.
        if let Some(first) = effects[..i].iter().position(|x| x.same_kind(e)) {
            return Err(SceneError::field(
                format!("effects[{i}]"),
                format!(
                    "{} is listed twice (also effects[{first}]): each effect may appear once",
                    e.kind_name()
                ),
            ));
        }
    }
    let has = |kind: Effect| effects.iter().any(|e| e.same_kind(&kind));
    let sampling = if has(Effect::FoveatedSampling) {
        let mut refine = Vec::new();
        if has(Effect::SilhouetteRefinement) {
            refine.push(Refinement::Silhouette);
        }
        if has(Effect::CreaseRefinement) {
            refine.push(Refinement::Crease {
                angle_deg: crease_deg,
            });
        }
        if has(Effect::DepthRefinement) {
            refine.push(Refinement::Depth { jump: depth_jump });
        }
        Sampling::Foveated { refine }
    } else {
        Sampling::Full
    };
    Ok((sampling, passes))
}
