//! The post passes a scene asks for (`passes: [DepthOfField(…),
//! PorOverlay(…)]`), run over the rendered frame, with the parameters of
//! each and their checks.
//!
//! The parameter types belong to the pipeline, which runs the passes; they
//! stay here because the scene loader parses and checks them (errors name
//! the file, line and field) and raycast cannot depend on the pipeline.

use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// A post pass a scene asks for; the pipeline runs only these (DESIGN.md).
/// Each kind may appear once in a scene (a second is an error naming both).
///
/// A pass may carry parameters, written in the scene file as
/// `Name(field: value, …)` (RON's struct variants: the parentheses are
/// needed even when every field keeps its default, e.g. `PorOverlay()`);
/// an unknown pass or field is an error naming file, line and field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum PostPass {
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

/// How [`PostPass::DepthOfField`] blurs (Lee 2009 offers two methods).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum DofMethod {
    /// Ch. 4: nonlinear mipmap interpolation (the default).
    #[default]
    Mipmap,
    /// Ch. 5: point splatting on per-pixel layers, the hidden surfaces
    /// cast by rays (CPU and GPU; slower, better partial occlusion).
    Splat,
}

/// Where [`PostPass::DepthOfField`] focuses.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum DofFocus {
    /// At the depth under the point of regard (a small-window median that
    /// ignores the background).
    #[default]
    Gaze,
    /// At a fixed eye distance (mm): beyond the focal length, or `inf`.
    Fixed {
        /// The focal eye distance, mm.
        depth_mm: f64,
    },
    /// At the eye distance of the binocular 3-D gaze point (vergence,
    /// Murphy & Duchowski 2001 eqs. 1–3) on frames whose tracker sample has
    /// both eyes valid and converging; on other frames (one eye, a blink,
    /// a mouse, parallel or diverging lines of sight) as `Gaze`.
    Vergence,
    /// At the depth of the object Lee's attention model (2009 ch. 3,
    /// `crates/attention`) predicts the viewer attends, from the rendered
    /// frame alone: no eye tracker needed. While no object is attended the
    /// last focus is kept (before any, the eye is relaxed, at infinity).
    Attention,
}

/// How [`PostPass::DepthOfField`]'s focal depth follows a change of its focus
/// target (Lee 2009 §6.1, the eye's refocusing latency). The filtered
/// quantity is the accommodation in diopters (1/depth), not the depth.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum DofRefocus {
    /// The focal depth is the target's, frame by frame (no latency).
    #[default]
    Instant,
    /// Eq. 6.1: a linear transition over `ms` milliseconds (Lee: 300 ms,
    /// the 200–300 ms refocusing latency) from the focus shown when the
    /// target jumped to the (tracked) new target.
    Interpolate {
        /// Duration of the transition, ms (default 300).
        #[serde(default = "default_dof_refocus_ms")]
        ms: f64,
    },
    /// A first-order low-pass filter of cut-off `hz` (Lee: below 2 Hz;
    /// 1 Hz in his Fig. 6.1).
    LowPass {
        /// Cut-off frequency, Hz (default 1).
        #[serde(default = "default_dof_refocus_hz")]
        hz: f64,
    },
}

/// Longest refocusing transition a scene may give, ms.
pub const DOF_REFOCUS_MS_MAX: f64 = 10_000.0;

/// Highest refocusing low-pass cut-off a scene may give, Hz.
pub const DOF_REFOCUS_HZ_MAX: f64 = 100.0;

fn default_dof_refocus_ms() -> f64 {
    300.0
}

fn default_dof_refocus_hz() -> f64 {
    1.0
}

/// Largest pupil (aperture) diameter a scene may give, mm: far beyond an
/// eye's 8 mm, for exaggerated blur.
pub const DOF_PUPIL_MM_MAX: f64 = 100.0;

/// Largest focal length or lens-to-retina distance a scene may give, mm.
pub const DOF_LENS_MM_MAX: f64 = 1000.0;

pub(super) fn default_dof_pupil_mm() -> f64 {
    4.0
}

pub(super) fn default_dof_focal_length_mm() -> f64 {
    16.7
}

pub(super) fn default_dof_retina_distance_mm() -> f64 {
    24.0
}

/// The seed's POR box: 64 px across.
pub const POR_HALF_PX: u32 = 32;

/// Largest POR box half-size a scene may ask for (a 8192-px box: larger
/// than any supported display).
pub const POR_HALF_PX_MAX: u32 = 4096;

pub(super) fn default_por_half_px() -> u32 {
    POR_HALF_PX
}

impl PostPass {
    /// The POR overlay with the seed's size.
    pub const POR_OVERLAY: PostPass = PostPass::PorOverlay {
        half_px: POR_HALF_PX,
    };

    /// Depth of field with its defaults (Lee's adult eye, focus at the gaze).
    pub const DEPTH_OF_FIELD: PostPass = PostPass::DepthOfField {
        pupil_mm: 4.0,
        focal_length_mm: 16.7,
        retina_distance_mm: 24.0,
        focus: DofFocus::Gaze,
        refocus: DofRefocus::Instant,
        method: DofMethod::Mipmap,
        smooth_foreground: false,
        highlights: false,
    };

    /// Whether `self` and `other` are the same pass, whatever their
    /// parameters.
    pub fn same_kind(&self, other: &PostPass) -> bool {
        std::mem::discriminant(self) == std::mem::discriminant(other)
    }

    /// The pass's name as the scene file writes it (`DepthOfField`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            PostPass::PorOverlay { .. } => "PorOverlay",
            PostPass::DepthOfField { .. } => "DepthOfField",
        }
    }

    /// Checks the parameters; the error names the field under `field`.
    pub(super) fn validate(&self, field: &str) -> Result<(), SceneError> {
        match *self {
            PostPass::PorOverlay { half_px } if !(1..=POR_HALF_PX_MAX).contains(&half_px) => {
                Err(SceneError::field(
                    format!("{field}.half_px"),
                    format!("must be 1 to {POR_HALF_PX_MAX} pixels, found {half_px}"),
                ))
            }
            PostPass::PorOverlay { .. } => Ok(()),
            PostPass::DepthOfField {
                pupil_mm,
                focal_length_mm,
                retina_distance_mm,
                focus,
                refocus,
                // Every method takes every lens; serde refuses an unknown
                // method, naming the line.
                method,
                smooth_foreground,
                highlights,
            } => {
                let bad = |name: &str, msg: String| {
                    Err(SceneError::field(format!("{field}.{name}"), msg))
                };
                if highlights && method == DofMethod::Mipmap {
                    return bad(
                        "highlights",
                        "applies to method Splat only (the mipmap method has no per-sample colours to extrapolate)".into(),
                    );
                }
                if smooth_foreground && method == DofMethod::Splat {
                    return bad(
                        "smooth_foreground",
                        "applies to method Mipmap only: Splat renders partial occlusion with the hidden surface".into(),
                    );
                }
                if !(0.0..=DOF_PUPIL_MM_MAX).contains(&pupil_mm) {
                    return bad(
                        "pupil_mm",
                        format!("must be 0 to {DOF_PUPIL_MM_MAX} mm, found {pupil_mm}"),
                    );
                }
                for (name, v) in [
                    ("focal_length_mm", focal_length_mm),
                    ("retina_distance_mm", retina_distance_mm),
                ] {
                    if !(v > 0.0 && v <= DOF_LENS_MM_MAX) {
                        return bad(
                            name,
                            format!("must be above 0 and at most {DOF_LENS_MM_MAX} mm, found {v}"),
                        );
                    }
                }
                if let DofFocus::Fixed { depth_mm } = focus {
                    if depth_mm.is_nan() || depth_mm <= focal_length_mm {
                        return bad(
                            "focus.depth_mm",
                            format!("must be beyond the focal length ({focal_length_mm} mm) or inf, found {depth_mm}"),
                        );
                    }
                }
                match refocus {
                    DofRefocus::Interpolate { ms } if !(ms > 0.0 && ms <= DOF_REFOCUS_MS_MAX) => {
                        bad(
                            "refocus.ms",
                            format!(
                                "must be above 0 and at most {DOF_REFOCUS_MS_MAX} ms, found {ms}"
                            ),
                        )
                    }
                    DofRefocus::LowPass { hz } if !(hz > 0.0 && hz <= DOF_REFOCUS_HZ_MAX) => bad(
                        "refocus.hz",
                        format!("must be above 0 and at most {DOF_REFOCUS_HZ_MAX} Hz, found {hz}"),
                    ),
                    _ => Ok(()),
                }
            }
        }
    }
}
