//! How a scene is sampled (`sampling: Full` or `sampling: Foveated(refine:
//! […])`): the method gate of foveated sampling and, inside it, the
//! hybrid's refinement triggers with their parameters.

use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// How the frame's pixels are cast. The default (a file that gives no
/// sampling) is the seed's: foveated, with every refinement trigger.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Sampling {
    /// Every pixel is cast.
    Full,
    /// The CSF ray mask is cast instead of every pixel, and the cells that
    /// `refine` triggers on are cast in full. Each trigger may appear once.
    Foveated {
        /// The refinement triggers (none: no cell is refined).
        #[serde(default)]
        refine: Vec<Refinement>,
    },
}

/// A trigger that makes the hybrid cast a cell's pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Refinement {
    /// The cell's corners disagree on hit/miss or object.
    Silhouette,
    /// The cell's corner normals differ by more than `angle_deg`;
    /// `Crease()` gives 30°.
    Crease {
        /// Crease angle, degrees (default 30).
        #[serde(default = "default_crease_deg")]
        angle_deg: f32,
    },
    /// The largest over the smallest hit distance across the cell's
    /// corners exceeds 1 + `jump`; `Depth()` gives 0.05.
    Depth {
        /// Relative depth jump (default 0.05).
        #[serde(default = "default_depth_jump")]
        jump: f32,
    },
}

/// The crease angle of `Crease()` and of the old form, degrees.
pub const DEFAULT_CREASE_DEG: f32 = 30.0;
/// The depth jump of `Depth()` and of the old form.
pub const DEFAULT_DEPTH_JUMP: f32 = 0.05;

pub(super) fn default_crease_deg() -> f32 {
    DEFAULT_CREASE_DEG
}
pub(super) fn default_depth_jump() -> f32 {
    DEFAULT_DEPTH_JUMP
}

impl Default for Sampling {
    fn default() -> Self {
        Sampling::Foveated {
            refine: vec![
                Refinement::Silhouette,
                Refinement::Crease {
                    angle_deg: DEFAULT_CREASE_DEG,
                },
                Refinement::Depth {
                    jump: DEFAULT_DEPTH_JUMP,
                },
            ],
        }
    }
}

impl Refinement {
    /// The trigger's name as the scene file writes it (`Crease`).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Refinement::Silhouette => "Silhouette",
            Refinement::Crease { .. } => "Crease",
            Refinement::Depth { .. } => "Depth",
        }
    }
}

impl Sampling {
    /// Whether the CSF ray mask is cast (the method gate of foveated
    /// sampling).
    pub fn is_foveated(&self) -> bool {
        matches!(self, Sampling::Foveated { .. })
    }

    /// The refinement triggers (none for full sampling).
    pub fn refinements(&self) -> &[Refinement] {
        match self {
            Sampling::Full => &[],
            Sampling::Foveated { refine } => refine,
        }
    }

    /// Whether the silhouette trigger is on.
    pub fn silhouette(&self) -> bool {
        self.refinements()
            .iter()
            .any(|r| matches!(r, Refinement::Silhouette))
    }

    /// The crease trigger's angle, degrees, when it is on.
    pub fn crease_deg(&self) -> Option<f32> {
        self.refinements().iter().find_map(|r| match r {
            Refinement::Crease { angle_deg } => Some(*angle_deg),
            _ => None,
        })
    }

    /// The depth trigger's jump, when it is on.
    pub fn depth_jump(&self) -> Option<f32> {
        self.refinements().iter().find_map(|r| match r {
            Refinement::Depth { jump } => Some(*jump),
            _ => None,
        })
    }

    /// Each trigger listed once; errors name `field.refine[i]` (the
    /// parameters are checked by [`Sampling::check_parameters`]).
    pub(super) fn check_triggers(&self, field: &str) -> Result<(), SceneError> {
        let refine = self.refinements();
        for (i, r) in refine.iter().enumerate() {
            let same = |x: &Refinement| std::mem::discriminant(x) == std::mem::discriminant(r);
            if let Some(first) = refine[..i].iter().position(same) {
                return Err(SceneError::field(
                    format!("{field}.refine[{i}]"),
                    format!(
                        "{} is listed twice (also refine[{first}]): each trigger may appear once",
                        r.kind_name()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The triggers' parameters zero or positive; errors name
    /// `field.refine[i].angle_deg` or `….jump`.
    pub(super) fn check_parameters(&self, field: &str) -> Result<(), SceneError> {
        for (i, r) in self.refinements().iter().enumerate() {
            let (name, v) = match *r {
                Refinement::Silhouette => continue,
                Refinement::Crease { angle_deg } => ("angle_deg", angle_deg),
                Refinement::Depth { jump } => ("jump", jump),
            };
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::field(
                    format!("{field}.refine[{i}].{name}"),
                    "must be zero or positive",
                ));
            }
        }
        Ok(())
    }
}
