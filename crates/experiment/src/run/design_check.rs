//! The one check of a design that `experiment plan` and `experiment run`
//! share, so that they cannot disagree, and what it derives: the trials,
//! the grid on the screen, the calibration and validation plans with the
//! fit they feed, and the drift check's target.

use screen_geometry::ScreenGeometry;
use tracker_hal::calibration::{Model, Order, Plan, SessionPlan};

use super::layout::Layout;
use super::on_display::{plan_on_display, RendererCheck};
use crate::design::Design;
use crate::Trial;

/// Calibration target timing (ms): as `gazecast calibrate`'s defaults.
pub const SETTLE_MS: u32 = 400;
/// How long each calibration target's samples are collected (ms).
pub const COLLECT_MS: u32 = 800;

/// What [`check_design`] derives from a design on a display: all that
/// `experiment run` needs from it before any folder or window exists.
#[derive(Debug, Clone)]
pub struct Checked {
    /// The participant's trials.
    pub trials: Vec<Trial>,
    /// The search grid on the screen.
    pub layout: Layout,
    /// The calibration fit: a second-order polynomial follows an eye's
    /// bow where there are points enough (9: the seed's); fewer points
    /// fit a homography.
    pub model: Model,
    /// (calibration, validation) targets and timing.
    pub cal_plans: (Plan, Plan),
    /// The drift check's single target at the centre (designs with one).
    pub drift_plan: Option<Plan>,
}

/// The one check of a design that `experiment plan` and `experiment run`
/// share, so that they cannot disagree: the design's own rules
/// ([`Design::validate`]), the trials on this display
/// ([`plan_on_display`], with the `renderer`'s own check), the calibration and validation grids
/// and the fit they feed, and the drift check's target. `Err((field,
/// message))` names the design field (the caller adds the file and line).
pub fn check_design(
    design: &Design,
    index: usize,
    geometry: &ScreenGeometry,
    renderer: RendererCheck<'_>,
) -> Result<Checked, (String, String)> {
    design.validate().map_err(|e| match e {
        crate::DesignError::Invalid { field, message } => (field, message),
        other => ("name".to_string(), other.to_string()),
    })?;
    let (trials, layout) = plan_on_display(design, index, geometry, renderer)?;
    let size = (geometry.width_px, geometry.height_px);
    let c = &design.calibration;
    let plan = SessionPlan {
        points: c.points as usize,
        validation_points: c.validation_points as usize,
        settle_ms: SETTLE_MS,
        collect_ms: COLLECT_MS,
        order: Order::RowMajor,
    };
    let cal_plans = plan.plans(size).map_err(|e| match e {
        tracker_hal::calibration::PlanError::Validation(m) => {
            ("calibration.validation_points".to_string(), m)
        }
        other => ("calibration.points".to_string(), other.to_string()),
    })?;
    let model = if c.points >= 9 {
        Model::Polynomial2
    } else {
        Model::Homography
    };
    if cal_plans.0.targets_px.len() < model.min_points() {
        return Err((
            "calibration.points".into(),
            format!(
                "{} targets: the {model:?} fit needs at least {}",
                cal_plans.0.targets_px.len(),
                model.min_points()
            ),
        ));
    }
    let drift_plan = design.drift_check.as_ref().map(|_| drift_plan(geometry));
    Ok(Checked {
        trials,
        layout,
        model,
        cal_plans,
        drift_plan,
    })
}

/// The drift check: one target at the screen's centre, timed as the
/// calibration targets. (The calibration grids start at 4 points; a drift
/// check is a single one.)
fn drift_plan(geometry: &ScreenGeometry) -> Plan {
    Plan {
        targets_px: vec![geometry.centre_px()],
        settle_ms: SETTLE_MS,
        collect_ms: COLLECT_MS,
        window_ms: 200.min(COLLECT_MS / 2),
        min_samples: 5,
        max_dispersion: f64::INFINITY,
    }
}
