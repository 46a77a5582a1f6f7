//! Whether a calibration, validation or drift check is good enough for
//! the session to go on: its accuracy against the design's threshold, the
//! line that says so, and how many failures in a row before the
//! experimenter decides.

use screen_geometry::ScreenGeometry;
use tracker_hal::calibration::{validate, Calibration, TimedPoint, ValidationSummary};

use crate::design::Design;

/// Failed validations before the runner asks the experimenter.
pub const MAX_CALIBRATION_ATTEMPTS: u32 = 3;

/// A calibration session's own validation (`None`: no validation point
/// had data) against the design's threshold: `Ok(line)` accepted,
/// `Err(line)` not.
pub fn calibration_outcome(
    design: &Design,
    summary: Option<ValidationSummary>,
) -> Result<String, String> {
    let threshold = design.calibration.accuracy_threshold_deg;
    match summary {
        Some(v) if v.accuracy_deg <= threshold => Ok(format!(
            "calibrated: validation accuracy {:.2} deg (precision RMS {:.2} deg), threshold {threshold} deg",
            v.accuracy_deg, v.precision_rms_deg
        )),
        Some(v) => Err(format!(
            "calibration validated at {:.2} deg, above the threshold {threshold} deg",
            v.accuracy_deg
        )),
        None => Err("calibration: no validation point had data".into()),
    }
}

/// A validation of `calibration` (`None`: none yet), or with `drift` a
/// drift check, over `runs` (each target and its samples) on `geometry`,
/// against the design's threshold for it (a drift check's own where the
/// design has one): `Ok(line)` accepted, `Err(line)` not.
pub fn validation_outcome(
    design: &Design,
    drift: bool,
    calibration: Option<&Calibration>,
    geometry: &ScreenGeometry,
    runs: &[([f64; 2], Vec<TimedPoint>)],
) -> Result<String, String> {
    let threshold = match (drift, &design.drift_check) {
        (true, Some(d)) => d.threshold_deg,
        _ => design.calibration.accuracy_threshold_deg,
    };
    let what = if drift { "drift check" } else { "validation" };
    match calibration {
        Some(c) => match validate(c, geometry, runs) {
            Ok(v) if v.accuracy_deg <= threshold => Ok(format!(
                "{what}: accuracy {:.2} deg (threshold {threshold} deg)",
                v.accuracy_deg
            )),
            Ok(v) => Err(format!(
                "{what}: accuracy {:.2} deg, above the threshold {threshold} deg",
                v.accuracy_deg
            )),
            Err(e) => Err(format!("{what}: {e}")),
        },
        None => Err(format!("{what}: no calibration to validate")),
    }
}
