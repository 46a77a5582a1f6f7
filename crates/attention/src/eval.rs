//! Prediction accuracy against recorded gaze (Lee §3.5.2): `A_k` is the
//! fraction of frames in which the object the participant looked at is
//! among the `k` most attended, over frames that show at least one
//! foreground object.

use crate::tracker::Attention;

/// Largest `k` the accumulator keeps (Lee reports `A_1` to `A_3`).
pub const MAX_K: usize = 3;

/// Whether `looked_at` is among the first `k` ids of `ranking` (best
/// first). False when nothing was looked at or `k` is 0.
pub fn top_k_hit(ranking: &[u32], looked_at: Option<u32>, k: usize) -> bool {
    match looked_at {
        Some(id) => ranking.iter().take(k).any(|&r| r == id),
        None => false,
    }
}

/// Counts hits for `A_1`, `A_2`, `A_3`.
///
/// A frame whose ranking is empty shows only background (or importance-0)
/// objects and is skipped, as in Lee §3.5.2. A frame with foreground
/// objects where the gaze fell on background (`looked_at = None`) counts
/// as a miss. Eye-movement filtering (Lee keeps fixations and drifts only)
/// is the caller's: record only the frames it keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccuracyAccumulator {
    frames: u64,
    skipped: u64,
    hits: [u64; MAX_K],
}

impl AccuracyAccumulator {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records one frame; returns whether it counted (ranking non-empty).
    pub fn record(&mut self, ranking: &[u32], looked_at: Option<u32>) -> bool {
        self.record_frame(!ranking.is_empty(), ranking, looked_at)
    }

    /// Records one frame whose foreground is known from the frame itself
    /// (whether any object worth attending is visible) rather than from
    /// the ranking: a predictor that may rank nothing on a frame with
    /// objects (Lee's random-pixel baseline hitting the background) counts
    /// a miss there. Returns whether the frame counted.
    pub fn record_frame(
        &mut self,
        has_foreground: bool,
        ranking: &[u32],
        looked_at: Option<u32>,
    ) -> bool {
        if !has_foreground {
            self.skipped += 1;
            return false;
        }
        self.frames += 1;
        for (k, hits) in self.hits.iter_mut().enumerate() {
            if top_k_hit(ranking, looked_at, k + 1) {
                *hits += 1;
            }
        }
        true
    }

    /// Records one frame from a tracker result.
    pub fn record_attention(&mut self, attention: &Attention, looked_at: Option<u32>) -> bool {
        self.record(&attention.ranking_ids(), looked_at)
    }

    /// Adds another accumulator's counts (e.g. another participant).
    pub fn merge(&mut self, other: &Self) {
        self.frames += other.frames;
        self.skipped += other.skipped;
        for (a, b) in self.hits.iter_mut().zip(other.hits) {
            *a += b;
        }
    }

    /// Frames counted.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Frames skipped as background-only.
    pub fn skipped_frames(&self) -> u64 {
        self.skipped
    }

    /// Hits within the top `k` (1 to 3); `None` for other `k`.
    pub fn hits(&self, k: usize) -> Option<u64> {
        (1..=MAX_K).contains(&k).then(|| self.hits[k - 1])
    }

    /// `A_k` for `k` in 1 to 3; `None` for other `k` or before any frame counted.
    pub fn accuracy(&self, k: usize) -> Option<f64> {
        let hits = self.hits(k)?;
        (self.frames > 0).then(|| hits as f64 / self.frames as f64)
    }

    /// `[A_1, A_2, A_3]`, 0 before any frame counted.
    pub fn accuracies(&self) -> [f64; MAX_K] {
        std::array::from_fn(|i| self.accuracy(i + 1).unwrap_or(0.0))
    }
}

/// Gaze speed below which a frame is a fixation: Lee's velocity thresholds
/// are in normalised screen units (screen sizes) per 60-Hz frame.
pub const FIXATION_BELOW: f64 = 0.03;
/// Gaze speed above which a frame is a saccade (same units as [`FIXATION_BELOW`]).
pub const SACCADE_ABOVE: f64 = 0.1;

/// Lee's eye states (§3.5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EyeState {
    /// No gaze this frame (no valid sample).
    Blink,
    /// No velocity: the first frame, or the first after a blink.
    Start,
    /// Gaze speed above [`SACCADE_ABOVE`] (or not finite).
    Saccade,
    /// Gaze speed between [`FIXATION_BELOW`] and [`SACCADE_ABOVE`].
    Drift,
    /// Gaze speed below [`FIXATION_BELOW`].
    Fixation,
}

impl EyeState {
    /// The state's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Blink => "blink",
            Self::Start => "start",
            Self::Saccade => "saccade",
            Self::Drift => "drift",
            Self::Fixation => "fixation",
        }
    }

    /// Scored frames (Lee keeps fixations and drifts).
    pub fn scored(self) -> bool {
        matches!(self, Self::Drift | Self::Fixation)
    }
}

/// Classifies a frame's gaze from the last frame's (screen px, or `None`
/// when invalid) on a `size` px screen, frames at `rate_hz`.
pub fn eye_state(
    last: Option<[f64; 2]>,
    now: Option<[f64; 2]>,
    size: [f64; 2],
    rate_hz: f64,
) -> EyeState {
    match (last, now) {
        (_, None) => EyeState::Blink,
        (None, Some(_)) => EyeState::Start,
        (Some(a), Some(b)) => {
            // Lee's thresholds are per 60-Hz frame: the change per frame at
            // another rate is scaled to a 60-Hz frame's.
            let v = ((b[0] - a[0]) / size[0]).hypot((b[1] - a[1]) / size[1]) * rate_hz / 60.0;
            if !v.is_finite() || v > SACCADE_ABOVE {
                EyeState::Saccade
            } else if v < FIXATION_BELOW {
                EyeState::Fixation
            } else {
                EyeState::Drift
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eye_states_follow_lee_thresholds() {
        let size = [1000.0, 1000.0];
        assert_eq!(eye_state(None, None, size, 60.0), EyeState::Blink);
        assert_eq!(
            eye_state(None, Some([1.0, 1.0]), size, 60.0),
            EyeState::Start
        );
        assert_eq!(
            eye_state(Some([0.0, 0.0]), Some([10.0, 0.0]), size, 60.0),
            EyeState::Fixation
        );
        assert_eq!(
            eye_state(Some([0.0, 0.0]), Some([50.0, 0.0]), size, 60.0),
            EyeState::Drift
        );
        assert_eq!(
            eye_state(Some([0.0, 0.0]), Some([200.0, 0.0]), size, 60.0),
            EyeState::Saccade
        );
        assert!(!EyeState::Saccade.scored() && EyeState::Drift.scored());
    }

    #[test]
    fn top_k_hit_looks_only_at_the_first_k() {
        let r = [7, 3, 9];
        assert!(top_k_hit(&r, Some(7), 1));
        assert!(!top_k_hit(&r, Some(3), 1));
        assert!(top_k_hit(&r, Some(3), 2));
        assert!(top_k_hit(&r, Some(9), 10));
        assert!(!top_k_hit(&r, Some(4), 3));
        assert!(!top_k_hit(&r, None, 3));
        assert!(!top_k_hit(&r, Some(7), 0));
        assert!(!top_k_hit(&[], Some(7), 1));
    }

    #[test]
    fn accumulator_counts_a1_to_a3_and_skips_background_frames() {
        let mut acc = AccuracyAccumulator::new();
        assert_eq!(acc.accuracy(1), None);
        assert!(acc.record(&[1, 2, 3], Some(1)));
        assert!(acc.record(&[1, 2, 3], Some(2)));
        assert!(acc.record(&[1, 2, 3], Some(3)));
        assert!(acc.record(&[1, 2, 3], None));
        assert!(!acc.record(&[], Some(5)));
        assert_eq!(acc.frames(), 4);
        assert_eq!(acc.skipped_frames(), 1);
        assert_eq!(acc.accuracies(), [0.25, 0.5, 0.75]);
        assert_eq!(acc.accuracy(4), None);
        let mut total = acc;
        total.merge(&acc);
        assert_eq!(total.frames(), 8);
        assert_eq!(total.hits(3), Some(6));
        let mut base = AccuracyAccumulator::new();
        assert!(base.record_frame(true, &[], Some(1)));
        assert!(!base.record_frame(false, &[1], Some(1)));
        assert_eq!(
            (base.frames(), base.skipped_frames(), base.hits(1)),
            (1, 1, Some(0))
        );
    }
}
