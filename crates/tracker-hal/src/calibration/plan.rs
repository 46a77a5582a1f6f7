//! The targets and timing of a calibration or validation run.

use serde::{Deserialize, Serialize};

/// Target order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Order {
    /// Row by row from the top left.
    RowMajor,
    /// A seeded shuffle (the person cannot anticipate the next target).
    Shuffled {
        /// Seed of the shuffle (same seed, same order).
        seed: u64,
    },
}

/// The targets and timing of a calibration or validation run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Target positions (screen px), in presentation order.
    pub targets_px: Vec<[f64; 2]>,
    /// Ignored at the start of each target (the saccade to it and settling).
    pub settle_ms: u32,
    /// Collected per target after settling.
    pub collect_ms: u32,
    /// Window of lowest dispersion used per target.
    pub window_ms: u32,
    /// Fewest valid samples in that window for the target to count.
    pub min_samples: usize,
    /// Largest dispersion (raw units) for the target to be accepted.
    pub max_dispersion: f64,
}

impl Plan {
    /// A `cols × rows` grid inset by `margin` (fraction of the screen) on a
    /// `w × h` px screen; 5 points = the centre and the four corners.
    pub fn grid(
        points: usize,
        screen_px: (u32, u32),
        margin: f64,
        order: Order,
    ) -> Result<Self, String> {
        let (w, h) = (f64::from(screen_px.0), f64::from(screen_px.1));
        if !(0.0..0.5).contains(&margin) || w <= 0.0 || h <= 0.0 {
            return Err(format!(
                "margin {margin} must be in [0, 0.5) and the screen non-empty"
            ));
        }
        let at = |fx: f64, fy: f64| {
            [
                w * (margin + (1.0 - 2.0 * margin) * fx),
                h * (margin + (1.0 - 2.0 * margin) * fy),
            ]
        };
        let mut targets: Vec<[f64; 2]> = match points {
            5 => vec![
                at(0.5, 0.5),
                at(0.0, 0.0),
                at(1.0, 0.0),
                at(0.0, 1.0),
                at(1.0, 1.0),
            ],
            n if n >= 4 && (n as f64).sqrt().fract() == 0.0 => {
                let k = (n as f64).sqrt() as usize;
                (0..n)
                    .map(|i| {
                        at(
                            (i % k) as f64 / (k - 1) as f64,
                            (i / k) as f64 / (k - 1) as f64,
                        )
                    })
                    .collect()
            }
            n => {
                return Err(format!(
                    "{n} points: use 5 or a square number (4, 9, 16, …)"
                ))
            }
        };
        if let Order::Shuffled { seed } = order {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            targets.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
        }
        Ok(Self {
            targets_px: targets,
            settle_ms: 400,
            collect_ms: 800,
            window_ms: 200,
            min_samples: 5,
            max_dispersion: f64::INFINITY,
        })
    }
}

/// Calibration targets are inset this far from the screen's edges
/// (fraction of the screen).
pub const CALIBRATION_MARGIN: f64 = 0.1;
/// Validation targets are inset this far: between the calibration targets.
pub const VALIDATION_MARGIN: f64 = 0.25;

/// What is wrong with a [`SessionPlan`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    /// The collect time is outside 100–10000 ms or the settle time above 10000 ms.
    #[error("the collect time {collect_ms} ms must be in [100, 10000] and the settle time {settle_ms} ms at most 10000")]
    Timing {
        /// The settle time asked for, ms.
        settle_ms: u32,
        /// The collect time asked for, ms.
        collect_ms: u32,
    },
    /// The calibration grid: [`Plan::grid`]'s reason.
    #[error("calibration targets: {0}")]
    Calibration(String),
    /// The validation grid: [`Plan::grid`]'s reason.
    #[error("validation targets: {0}")]
    Validation(String),
}

/// A calibration run and its validation as a session asks for them: how
/// many targets of each, how long each is shown, in which order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SessionPlan {
    /// Calibration targets: 5 or a square number, [`CALIBRATION_MARGIN`] in.
    pub points: usize,
    /// Validation targets: 5 or a square number, [`VALIDATION_MARGIN`] in.
    pub validation_points: usize,
    /// Ignored at the start of each target, ms (the saccade to it and settling).
    pub settle_ms: u32,
    /// Samples collected per target after settling, ms.
    pub collect_ms: u32,
    /// Target order.
    pub order: Order,
}

impl SessionPlan {
    /// (calibration plan, validation plan) on a `w × h` px screen, both with
    /// this timing; the stable window is at most half the collect time.
    pub fn plans(&self, screen_px: (u32, u32)) -> Result<(Plan, Plan), PlanError> {
        if self.collect_ms < 100 || self.collect_ms > 10_000 || self.settle_ms > 10_000 {
            return Err(PlanError::Timing {
                settle_ms: self.settle_ms,
                collect_ms: self.collect_ms,
            });
        }
        let timed = |mut p: Plan| {
            p.settle_ms = self.settle_ms;
            p.collect_ms = self.collect_ms;
            p.window_ms = p.window_ms.min(self.collect_ms / 2);
            p
        };
        let cal = Plan::grid(self.points, screen_px, CALIBRATION_MARGIN, self.order)
            .map_err(PlanError::Calibration)?;
        let val = Plan::grid(
            self.validation_points,
            screen_px,
            VALIDATION_MARGIN,
            self.order,
        )
        .map_err(PlanError::Validation)?;
        Ok((timed(cal), timed(val)))
    }
}

impl Plan {
    /// How long each target is shown (settle + collect), µs.
    pub fn dwell_us(&self) -> u64 {
        (u64::from(self.settle_ms) + u64::from(self.collect_ms)) * 1000
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_plan_checks_its_timing_and_grids() {
        let ok = SessionPlan {
            points: 9,
            validation_points: 4,
            settle_ms: 300,
            collect_ms: 300,
            order: Order::RowMajor,
        };
        let (cal, val) = ok.plans((1280, 1024)).expect("plans");
        assert_eq!((cal.targets_px.len(), val.targets_px.len()), (9, 4));
        assert_eq!(cal.targets_px[0], [128.0, 102.4]);
        assert_eq!(val.targets_px[0], [320.0, 256.0]);
        // The window shrinks to half the collect time; the dwell is shared.
        assert_eq!((cal.window_ms, val.window_ms), (150, 150));
        assert_eq!((cal.dwell_us(), val.dwell_us()), (600_000, 600_000));
        for (bad, is) in [
            (
                SessionPlan {
                    collect_ms: 10,
                    ..ok
                },
                "Timing",
            ),
            (SessionPlan { points: 7, ..ok }, "Calibration"),
            (
                SessionPlan {
                    validation_points: 7,
                    ..ok
                },
                "Validation",
            ),
        ] {
            let e = bad.plans((1280, 1024)).expect_err("refused");
            assert!(format!("{e:?}").starts_with(is), "{e:?}");
        }
    }
}
