//! Validation in degrees of visual angle, as labs report it: accuracy (the
//! angle between the target and the mean gaze), precision as RMS of
//! sample-to-sample angles (RMS-S2S) and as the standard deviation (the
//! root mean square angular distance of the samples from their mean), per
//! point and overall. These are the measures of Holmqvist, Nyström &
//! Mulvey 2012 ("Eye tracker data quality: what it is and how to measure
//! it", ETRA), with angles at the eye from the display geometry
//! ([`ScreenGeometry::eccentricity_deg`]).

use screen_geometry::ScreenGeometry;
use serde::Serialize;

use super::fit::{Calibration, CalibrationError};
use super::window::TimedPoint;

/// Accuracy and precision at one validation target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointValidation {
    /// The validation target, screen px.
    pub target_px: [f64; 2],
    /// Mean mapped gaze (px).
    pub mean_gaze_px: [f64; 2],
    /// Angle between the target and the mean gaze (degrees).
    pub accuracy_deg: f64,
    /// RMS of the angles between successive samples (degrees).
    pub precision_rms_deg: f64,
    /// Root mean square angular distance of the samples from their mean (degrees).
    pub precision_std_deg: f64,
    /// Samples used.
    pub samples: usize,
}

/// A validation run's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// Each target's measures, in target order.
    pub points: Vec<PointValidation>,
    /// Means over the points.
    pub accuracy_deg: f64,
    /// Mean sample-to-sample RMS precision, degrees.
    pub precision_rms_deg: f64,
    /// Mean precision as spread around the mean gaze, degrees.
    pub precision_std_deg: f64,
}

/// Validates `calibration` on separate targets: `runs` holds, per target,
/// its position and the raw samples taken while it was shown (the collect
/// phase). Angles use the display geometry (eye position and distance).
pub fn validate(
    calibration: &Calibration,
    geometry: &ScreenGeometry,
    runs: &[([f64; 2], Vec<TimedPoint>)],
) -> Result<Validation, CalibrationError> {
    let mut points = Vec::new();
    for (index, (target, samples)) in runs.iter().enumerate() {
        let gaze: Vec<[f64; 2]> = samples
            .iter()
            .filter_map(|s| s.raw.and_then(|r| calibration.map(r)))
            .collect();
        if gaze.len() < 2 {
            return Err(CalibrationError::Target {
                index,
                reason: format!("{} valid samples; at least 2 are needed", gaze.len()),
            });
        }
        let n = gaze.len() as f64;
        let mean = [
            gaze.iter().map(|p| p[0]).sum::<f64>() / n,
            gaze.iter().map(|p| p[1]).sum::<f64>() / n,
        ];
        let angle = |a: [f64; 2], b: [f64; 2]| geometry.eccentricity_deg(a, b);
        let s2s: f64 = gaze
            .windows(2)
            .map(|w| angle(w[0], w[1]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        let std: f64 = gaze.iter().map(|p| angle(mean, *p).powi(2)).sum::<f64>() / n;
        points.push(PointValidation {
            target_px: *target,
            mean_gaze_px: mean,
            accuracy_deg: angle(*target, mean),
            precision_rms_deg: s2s.sqrt(),
            precision_std_deg: std.sqrt(),
            samples: gaze.len(),
        });
    }
    if points.is_empty() {
        return Err(CalibrationError::TooFewPoints {
            model: calibration.model,
            need: 1,
            got: 0,
        });
    }
    let m = points.len() as f64;
    let mean = |f: fn(&PointValidation) -> f64| points.iter().map(f).sum::<f64>() / m;
    Ok(Validation {
        accuracy_deg: mean(|p| p.accuracy_deg),
        precision_rms_deg: mean(|p| p.precision_rms_deg),
        precision_std_deg: mean(|p| p.precision_std_deg),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::testing::{distort, grid, procedure_on};
    use crate::calibration::Model;

    #[test]
    fn validation_reports_degrees() {
        let g = crate::test_support::seed_display(600.0);
        let p = procedure_on(Model::Affine, &grid(9), 0.0, 3);
        let c = p.fit(Model::Affine).expect("fits");
        // A validation target where the person looks 20 px right of it,
        // with ±2 px alternating jitter.
        let target = [400.0, 300.0];
        let samples: Vec<TimedPoint> = (0..50)
            .map(|i| {
                let dx = if i % 2 == 0 { 22.0 } else { 18.0 };
                TimedPoint {
                    t_us: i * 4_000,
                    raw: Some(distort(Model::Affine, [target[0] + dx, target[1]])),
                }
            })
            .collect();
        let v = validate(&c, &g, &[(target, samples)]).expect("validates");
        let px_deg = g.eccentricity_deg(target, [target[0] + 20.0, target[1]]);
        assert!(
            (v.accuracy_deg - px_deg).abs() < 1e-3,
            "{} vs {px_deg}",
            v.accuracy_deg
        );
        let four = g.eccentricity_deg([target[0] + 18.0, target[1]], [target[0] + 22.0, target[1]]);
        assert!(
            (v.precision_rms_deg - four).abs() < 1e-3,
            "{}",
            v.precision_rms_deg
        );
        assert!(
            (v.precision_std_deg - four / 2.0).abs() < 1e-3,
            "{}",
            v.precision_std_deg
        );
        assert!(validate(&c, &g, &[(target, vec![])]).is_err());
    }
}
