//! Test helpers shared across tracker-hal's modules.

use screen_geometry::ScreenGeometry;

use crate::calibration::{Order, Plan, SessionPlan};

/// The seed's 17" 1280×1024 display (Murphy 2007 ch. 7.1) with the eye at
/// `eye_distance_mm`.
pub fn seed_display(eye_distance_mm: f64) -> ScreenGeometry {
    screen_geometry::Display {
        eye_distance_mm,
        ..screen_geometry::Display::seed_17in(1280, 1024)
    }
    .geometry()
    .expect("display")
}

/// 9 calibration targets and 4 validation targets on that display, 200 +
/// 400 ms each, row by row.
pub fn nine_and_four() -> (Plan, Plan) {
    SessionPlan {
        points: 9,
        validation_points: 4,
        settle_ms: 200,
        collect_ms: 400,
        order: Order::RowMajor,
    }
    .plans((1280, 1024))
    .expect("plans")
}
