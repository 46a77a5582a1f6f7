//! The calibration state machine: shows the targets in order on the
//! samples' own clock, keeps each target's samples, accepts it or asks for
//! it again.

use super::fit::{Calibration, CalibrationError, Model};
use super::plan::Plan;
use super::window::{stable_window, StableWindow, TimedPoint};

/// A target's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetResult {
    /// The target's position, screen px.
    pub target_px: [f64; 2],
    /// The samples taken while it was shown (after settling).
    pub samples: Vec<TimedPoint>,
    /// The stable fixation found in them, or why there is none.
    pub window: Result<StableWindow, String>,
}

impl TargetResult {
    /// Whether the target is usable: a stable window whose dispersion is
    /// within the plan's `max_dispersion`.
    pub fn accepted(&self, plan: &Plan) -> bool {
        self.window
            .as_ref()
            .is_ok_and(|w| w.dispersion <= plan.max_dispersion)
    }
}

/// A target ends with the first sample at least settle + collect − 1 ms
/// after it began (the millisecond keeps a sample that arrives a hair early
/// on the boundary from holding the target one more period).
pub const CHANGE_TOLERANCE_US: u64 = 1000;

/// The calibration state machine: show target i for settle + collect ms
/// (time from the samples' clock), keep the collect-phase samples, move on;
/// redo any target on request. The viewer asks [`Procedure::target`] what to
/// draw and feeds every sample.
///
/// Targets follow a schedule: the first starts with the first sample, each
/// next one exactly settle + collect later (not at the next sample), so
/// sample-arrival jitter never accumulates into drift between the screen's
/// targets and the samples' clock. A target whose whole time passes without
/// a sample (a tracker that sends nothing while the eyes are closed, or went
/// silent) is closed empty and so rejected. [`Procedure::restart`] starts
/// the schedule again at the next sample (after a pause).
#[derive(Debug, Clone)]
pub struct Procedure {
    /// The targets and timing.
    pub plan: Plan,
    results: Vec<Option<TargetResult>>,
    /// Targets still to show, in order.
    queue: std::collections::VecDeque<usize>,
    shown_since_us: Option<u64>,
    /// When the next target is due on the schedule.
    next_since_us: Option<u64>,
    current: Vec<TimedPoint>,
}

impl Procedure {
    /// A run of `plan`'s targets in order, waiting for its first sample.
    pub fn new(plan: Plan) -> Self {
        let n = plan.targets_px.len();
        Self {
            plan,
            results: vec![None; n],
            queue: (0..n).collect(),
            shown_since_us: None,
            next_since_us: None,
            current: Vec::new(),
        }
    }

    /// The target to draw now (index, px); `None` when all are done.
    pub fn target(&self) -> Option<(usize, [f64; 2])> {
        self.queue.front().map(|&i| (i, self.plan.targets_px[i]))
    }

    /// Whether no target is left to show (each one closed, accepted or not).
    pub fn done(&self) -> bool {
        self.queue.is_empty()
    }

    /// Feeds one sample (raw coordinates, or `None` when invalid).
    pub fn feed(&mut self, sample: TimedPoint) {
        let settle = u64::from(self.plan.settle_ms) * 1000;
        let total = settle + u64::from(self.plan.collect_ms) * 1000;
        // A sample past the current target's end closes it, and any target
        // whose whole time passed without data (closed empty, so rejected).
        while let Some(&i) = self.queue.front() {
            // Due on the schedule, or now when there is none.
            let since = match self.shown_since_us {
                Some(t) => t,
                None => *self
                    .shown_since_us
                    .insert(self.next_since_us.take().unwrap_or(sample.t_us)),
            };
            let t = sample.t_us.saturating_sub(since);
            if t + CHANGE_TOLERANCE_US < total {
                if t >= settle {
                    self.current.push(sample);
                }
                return;
            }
            let samples = std::mem::take(&mut self.current);
            let window = stable_window(
                &samples,
                u64::from(self.plan.window_ms) * 1000,
                self.plan.min_samples,
            );
            self.results[i] = Some(TargetResult {
                target_px: self.plan.targets_px[i],
                samples,
                window,
            });
            self.queue.pop_front();
            self.shown_since_us = None;
            self.next_since_us = Some(since + total);
        }
    }

    /// Shows target `index` again (after the current queue), on the
    /// schedule; after a pause (waiting for a key) call [`Self::restart`].
    pub fn redo(&mut self, index: usize) {
        if index < self.results.len() && !self.queue.contains(&index) {
            self.queue.push_back(index);
        }
    }

    /// The next target starts with the next sample (after a pause).
    pub fn restart(&mut self) {
        self.next_since_us = None;
    }

    /// Continues `previous`'s schedule: this procedure's first target is
    /// due when `previous` would have shown its next one (a validation run
    /// straight after the calibration run).
    pub fn follow(&mut self, previous: &Procedure) {
        self.next_since_us = previous.next_since_us;
    }

    /// Targets that were not accepted (to offer a redo).
    pub fn rejected(&self) -> Vec<usize> {
        self.results
            .iter()
            .enumerate()
            .filter(|(_, r)| r.as_ref().is_some_and(|r| !r.accepted(&self.plan)))
            .map(|(i, _)| i)
            .collect()
    }

    /// Every finished target's outcome, in target order.
    pub fn results(&self) -> impl Iterator<Item = &TargetResult> {
        self.results.iter().flatten()
    }

    /// Fits `model` on the accepted targets.
    pub fn fit(&self, model: Model) -> Result<Calibration, CalibrationError> {
        let pairs: Vec<([f64; 2], [f64; 2])> = self
            .results()
            .filter(|r| r.accepted(&self.plan))
            .filter_map(|r| r.window.as_ref().ok().map(|w| (w.raw, r.target_px)))
            .collect();
        Calibration::fit(model, &pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::Order;
    use rand::SeedableRng;

    /// Arrival jitter must not drift the targets off the samples: the
    /// schedule keeps every target on its own stop for a long run, and a
    /// target with no data at all is closed empty (rejected).
    #[test]
    fn the_schedule_does_not_drift_with_jittered_arrivals_or_gaps() {
        use rand::Rng;
        let plan = Plan::grid(16, (1280, 1024), 0.1, Order::RowMajor).expect("plan");
        let total = u64::from(plan.settle_ms + plan.collect_ms) * 1000;
        let mut p = Procedure::new(plan.clone());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        // 60 Hz (1.2 s is exactly 72 periods), arrivals 0–3 ms late; stop k
        // is where the eye is; target 5 sends nothing at all.
        for k in 0..(16 * 72 + 2) {
            let truth = (f64::from(k) * 1e6 / 60.0).round() as u64;
            let stop = (truth / total) as usize;
            if stop == 5 {
                continue;
            }
            let at = plan.targets_px[stop.min(15)];
            p.feed(TimedPoint {
                t_us: truth + rng.random_range(0..3_000),
                raw: Some(at),
            });
        }
        assert!(p.done());
        assert_eq!(p.rejected(), vec![5]);
        for r in p.results() {
            for s in &r.samples {
                assert_eq!(s.raw, Some(r.target_px), "a sample of another stop");
            }
        }
    }
}
