//! Where a depth-of-field pass focuses, frame after frame (the focus
//! search, the last focus held, the refocusing dynamics and the attention
//! model of `focus: Attention`); shared by the ch. 4 and ch. 5 passes and
//! their GPU paths.

use raycast::scene::DofFocus;
use raycast::Frame;

use super::window::{gaze_depth_mm, vergence_or};
use crate::effects::refocus::Refocus;
use crate::effects::PassInput;

/// Saliency map side of the attention focus (Lee's smallest, 64²: the
/// attended object, not a fine map, is what the focus needs).
pub const ATTENTION_MAP_SIZE: u32 = 64;

/// `focus: Attention`'s model.
type AttentionModel = crate::frame_attention::FrameAttention;

/// Where a depth-of-field pass focuses, frame after frame: the search for
/// the focus target its [`DofFocus`] names, the last focus found (held
/// while a frame finds none), the refocusing dynamics and, for `focus:
/// Attention` only, Lee's attention model. Shared by the ch. 4 and ch. 5
/// passes.
#[derive(Debug, Default)]
pub(crate) struct Focuser {
    /// The focus of the last frame whose search found one.
    last_focus_mm: Option<f64>,
    /// How the focal depth follows the focus target.
    pub(crate) refocus: Refocus,
    /// Lee's attention model, for `focus: Attention` only.
    attention: Option<Box<AttentionModel>>,
}

impl Focuser {
    pub(crate) fn new(focus: DofFocus) -> Self {
        Self {
            attention: if focus == DofFocus::Attention {
                AttentionModel::new(ATTENTION_MAP_SIZE).ok().map(Box::new)
            } else {
                None
            },
            ..Self::default()
        }
    }

    pub(crate) fn attended_object(&self) -> Option<u32> {
        self.attention.as_ref().and_then(|a| a.attended())
    }

    /// `focus: Attention`'s model, for a pass whose focus search runs
    /// elsewhere (the GPU path); `None` for other focuses.
    pub(crate) fn attention_model(&mut self) -> Option<&mut AttentionModel> {
        self.attention.as_deref_mut()
    }

    pub(crate) fn attention(&self) -> Option<&AttentionModel> {
        self.attention.as_deref()
    }

    /// The focus distance for `frame`, mm (may be infinite), after the
    /// refocusing dynamics.
    pub(crate) fn focus_mm(
        &mut self,
        focus: DofFocus,
        frame: &Frame,
        input: &PassInput<'_>,
    ) -> f64 {
        let found = match focus {
            DofFocus::Fixed { .. } => None,
            DofFocus::Gaze => gaze_depth_mm(frame, input.gaze_px),
            DofFocus::Vergence => {
                vergence_or(input.vergence_mm, || gaze_depth_mm(frame, input.gaze_px))
            }
            DofFocus::Attention => match &mut self.attention {
                Some(a) => a.depth_mm(frame, input.scene, input.time_s),
                None => None,
            },
        };
        self.settle(focus, found, input.time_s)
    }

    /// The focal depth for a frame whose search `found` a depth (or none:
    /// the last one holds; before any, infinity), after the refocusing
    /// dynamics. A fixed focus is fixed.
    pub(crate) fn settle(
        &mut self,
        focus: DofFocus,
        found: Option<f64>,
        time_s: Option<f64>,
    ) -> f64 {
        let target = match focus {
            DofFocus::Fixed { depth_mm } => depth_mm,
            _ => {
                if let Some(d) = found {
                    self.last_focus_mm = Some(d);
                }
                self.last_focus_mm.unwrap_or(f64::INFINITY)
            }
        };
        if target > 0.0 {
            self.refocus.update(target, time_s)
        } else {
            target // only an unvalidated fixed focus: `coc_px` clamps it
        }
    }
}
