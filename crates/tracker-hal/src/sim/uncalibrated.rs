//! A simulated uncalibrated tracker for calibration sessions (`gazecast
//! simulate --script calibration`): what raw units it reports for a screen
//! point, and the stops of a person who follows a session's targets.

use super::fixation::Stop;
use crate::calibration::Plan;

/// Strength of the simulated tracker's second-order bow.
const BOW: f64 = 0.12;

/// Raw tracker units an uncalibrated tracker reports for screen point `px`
/// on a `screen_px` screen, in a tracker frame of `frame` units: the
/// screen seen in perspective in the tracker's frame (a homography, as a
/// camera off the screen's axis sees a plane; Hartley & Zisserman 2004,
/// *Multiple View Geometry*, §2.3) plus a bow that grows with the square of
/// the distance from the centre (the eye is a sphere, not a plane), which
/// a homography cannot follow and a second-order polynomial can. The
/// coefficients are invented, plausible values, not measured on a device.
pub fn uncalibrated_raw(px: [f64; 2], screen_px: (u32, u32), frame: (f64, f64)) -> [f64; 2] {
    let u = px[0] / f64::from(screen_px.0);
    let v = px[1] / f64::from(screen_px.1);
    let w = 1.0 + 0.08 * u - 0.05 * v;
    let (du, dv) = (u - 0.5, v - 0.5);
    [
        frame.0 * ((0.10 + 0.78 * u + 0.04 * v) / w + BOW * du * dv),
        frame.1 * ((0.12 + 0.03 * u + 0.70 * v) / w + BOW * du * du),
    ]
}

/// [`calibration_stops`] was asked to close a target that is not there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("closed target {index}: there are {targets} targets")]
pub struct NoSuchTarget {
    /// The target asked for.
    pub index: usize,
    /// The number of targets.
    pub targets: usize,
}

/// The stops of a simulated calibration session in raw units of the
/// [`uncalibrated_raw`] tracker: the calibration targets (the eyes closed
/// through `closed_target`, which is then shown again, as the session
/// does), then the validation targets, each for its plan's settle +
/// collect time.
pub fn calibration_stops(
    calibration: &Plan,
    validation: &Plan,
    screen_px: (u32, u32),
    frame: (f64, f64),
    closed_target: Option<usize>,
) -> Result<Vec<Stop>, NoSuchTarget> {
    let stop = |p: [f64; 2], plan: &Plan, closed| Stop {
        at: uncalibrated_raw(p, screen_px, frame),
        dwell_us: plan.dwell_us(),
        closed,
    };
    let mut stops: Vec<Stop> = calibration
        .targets_px
        .iter()
        .enumerate()
        .map(|(i, &p)| stop(p, calibration, Some(i) == closed_target))
        .collect();
    if let Some(index) = closed_target {
        let p = *calibration.targets_px.get(index).ok_or(NoSuchTarget {
            index,
            targets: calibration.targets_px.len(),
        })?;
        stops.push(stop(p, calibration, false));
    }
    stops.extend(
        validation
            .targets_px
            .iter()
            .map(|&p| stop(p, validation, false)),
    );
    Ok(stops)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::{Calibration, Model, Order};

    fn plans() -> (Plan, Plan) {
        crate::test_support::nine_and_four()
    }

    #[test]
    fn the_closed_target_comes_again_before_the_validation_targets() {
        let (cal, val) = plans();
        let stops =
            calibration_stops(&cal, &val, (1280, 1024), (512.0, 512.0), Some(4)).expect("stops");
        assert_eq!(stops.len(), 9 + 1 + 4);
        assert!(stops[4].closed && stops.iter().filter(|s| s.closed).count() == 1);
        assert_eq!(stops[9].at, stops[4].at);
        assert_eq!(
            stops[10].at,
            uncalibrated_raw(val.targets_px[0], (1280, 1024), (512.0, 512.0))
        );
        assert!(stops.iter().all(|s| s.dwell_us == 600_000));
        assert_eq!(
            calibration_stops(&cal, &val, (1280, 1024), (512.0, 512.0), Some(9)),
            Err(NoSuchTarget {
                index: 9,
                targets: 9
            })
        );
    }

    /// The bow is what a homography cannot follow and a second-order
    /// polynomial can: fitted on 16 targets, the homography is off by
    /// pixels, the polynomial by much less.
    #[test]
    fn only_the_polynomial_follows_the_bow() {
        let targets = Plan::grid(16, (1280, 1024), 0.1, Order::RowMajor)
            .expect("grid")
            .targets_px;
        let pairs: Vec<([f64; 2], [f64; 2])> = targets
            .iter()
            .map(|&t| (uncalibrated_raw(t, (1280, 1024), (512.0, 512.0)), t))
            .collect();
        let h = Calibration::fit(Model::Homography, &pairs).expect("fits");
        let p = Calibration::fit(Model::Polynomial2, &pairs).expect("fits");
        assert!(h.rms_residual_px > 2.0, "{}", h.rms_residual_px);
        assert!(
            p.rms_residual_px < h.rms_residual_px / 4.0,
            "{} vs {}",
            p.rms_residual_px,
            h.rms_residual_px
        );
    }
}
