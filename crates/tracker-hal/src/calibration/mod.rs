//! Calibration and validation: from raw tracker coordinates to screen
//! pixels, fitted on targets the person looked at, and checked on other
//! targets in degrees of visual angle, as labs report it. One module per
//! concept, all re-exported here:
//!
//! - [`Plan`] (`plan`): the targets (5 or 9 points, or any grid), their
//!   order, and the timing of each (settle, then collect); [`SessionPlan`]
//!   builds a calibration plan and its validation plan.
//! - [`Procedure`] (`procedure`): the state machine that shows the targets
//!   in order, takes the samples, accepts a target or asks for it again.
//! - [`stable_window`] (`window`): per target, the window of lowest
//!   dispersion (e.g. the 200 ms in which the eye was stillest), outliers
//!   rejected (median ± 3 scaled MAD), averaged.
//! - [`Calibration::fit`] (`fit`): affine (6 parameters), homography (8,
//!   projective) or second-order polynomial (12), by least squares on
//!   Hartley-normalised coordinates.
//! - [`validate`] (`validation`): accuracy, precision (RMS sample to sample
//!   and standard deviation), per point and overall, in degrees.
//! - [`Session`] (`session`): the policy of a whole calibration session —
//!   what happens to rejected targets, when to fit, validation, which
//!   targets to show again after bad validation points, when to save. The
//!   calibration window draws what it says and turns keys into its actions.
//!
//! Degenerate input — too few distinct targets for the model, collinear
//! targets, all samples invalid, non-finite values — is an error that says
//! so, never NaN and never a silently wrong mapping. Every calibration,
//! fitted or read from a file, passes one test, [`Calibration::check`]: it
//! maps the tracker's whole range onto finite points near the screen, and
//! onto a region of non-trivial area — over a grid of the range the
//! Jacobian keeps its orientation, its smallest singular value is at least
//! [`MIN_STRETCH`] of the targets' diagonal per tracker range, and its
//! condition number is at most [`MAX_CONDITION`], with the targets spread
//! over at least [`MIN_TARGET_SPREAD_PX`] each way.

mod fit;
mod plan;
mod procedure;
mod session;
mod validation;
mod window;

#[cfg(test)]
mod testing;

pub use fit::{
    Calibration, CalibrationError, Model, Normaliser, MAX_CONDITION, MIN_STRETCH,
    MIN_TARGET_SPREAD_PX,
};
pub use plan::{Order, Plan, PlanError, SessionPlan, CALIBRATION_MARGIN, VALIDATION_MARGIN};
pub use procedure::{Procedure, TargetResult, CHANGE_TOLERANCE_US};
pub use session::{
    nearest_targets, PointResult, Session, SessionPhase, SessionRequest, ValidationSummary,
};
pub use validation::{validate, PointValidation, Validation};
pub use window::{stable_window, StableWindow, TimedPoint};
