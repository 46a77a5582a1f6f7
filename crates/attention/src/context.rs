//! Top-down contexts: spatial (Lee §3.2.2, eq. 3.9) and temporal (§3.2.3,
//! eq. 3.10).

use crate::config::SpatialContextParams;

/// `c_x = L / 0.707` (Lee §3.2.2): the Weibull term `u·e^{−u²}`, `u = x/c_x`,
/// peaks at `u = 1/√2`, i.e. at `x = L`. The seed rounds `1/√2` to 0.707;
/// the exact value is used so that the peak is at `L`.
pub fn weibull_scale_mm(max_emphasis_distance_mm: f32) -> f32 {
    max_emphasis_distance_mm * std::f32::consts::SQRT_2
}

/// Eq. 3.9 for one object.
///
/// - `distance_mm`: `x`, observer to object (here the mean eye distance of
///   the object's visible pixels).
/// - `screen_offset`: `y`, distance of the object's screen centre from the
///   screen centre over half the screen diagonal (0 at the centre, 1 in a
///   corner).
/// - `receding`: `Δx > 0` (the object got farther since the last frame).
/// - `moving_forward`: `v · w > 0`.
///
/// Returns `T_s` in [0, 0.5] for a valid `params.scale`; 0 for non-finite
/// or negative distances.
pub fn spatial_context(
    params: &SpatialContextParams,
    distance_mm: f32,
    screen_offset: f32,
    receding: bool,
    moving_forward: bool,
) -> f32 {
    if moving_forward && receding {
        return 0.0;
    }
    if !(distance_mm.is_finite() && distance_mm > 0.0) {
        return 0.0;
    }
    let y = if screen_offset.is_finite() {
        screen_offset.max(0.0)
    } else {
        1.0
    };
    let u = f64::from(distance_mm) / f64::from(weibull_scale_mm(params.max_emphasis_distance_mm));
    let value = f64::from(params.scale)
        * u
        * (-u * u).exp()
        * (-f64::from(params.screen_centre_falloff) * f64::from(y) * f64::from(y)).exp();
    if value.is_finite() {
        value.clamp(0.0, 0.5) as f32
    } else {
        0.0
    }
}

/// Eq. 3.10: the mean of the last `λ` spatial contexts. Frames before the
/// object was first seen count as 0 (so a new object's `T_t` ramps up over
/// `λ` frames, which is the point of a long-term context).
#[derive(Clone, Debug)]
pub struct TemporalContext {
    history: Vec<f32>,
    next: usize,
    sum: f64,
}

impl TemporalContext {
    /// A window of `window_frames` (at least 1) zeros.
    pub fn new(window_frames: usize) -> Self {
        Self {
            history: vec![0.0; window_frames.max(1)],
            next: 0,
            sum: 0.0,
        }
    }

    /// Pushes this frame's `T_s` (non-finite counts as 0) and returns `T_t`.
    pub fn push(&mut self, spatial: f32) -> f32 {
        let spatial = if spatial.is_finite() {
            spatial.max(0.0)
        } else {
            0.0
        };
        let old = std::mem::replace(&mut self.history[self.next], spatial);
        self.next = (self.next + 1) % self.history.len();
        self.sum += f64::from(spatial) - f64::from(old);
        if self.next == 0 {
            // Once per window, drop the accumulated rounding.
            self.sum = self.history.iter().map(|&v| f64::from(v)).sum();
        }
        self.value()
    }

    /// The current `T_t`.
    pub fn value(&self) -> f32 {
        ((self.sum / self.history.len() as f64).max(0.0)) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spatial_context_peaks_at_half_at_distance_l_on_the_centre() {
        let p = SpatialContextParams::default();
        let peak = spatial_context(&p, p.max_emphasis_distance_mm, 0.0, false, false);
        assert!((peak - 0.5).abs() < 1e-4, "peak {peak}");
        for x in [0.3f32, 0.9, 1.1, 3.0] {
            let v = spatial_context(&p, x * p.max_emphasis_distance_mm, 0.0, false, false);
            assert!(v < peak);
        }
        let off = spatial_context(&p, p.max_emphasis_distance_mm, 1.0, false, false);
        assert!((off - 0.5 * (-3.0f32).exp()).abs() < 1e-4);
    }

    #[test]
    fn receding_objects_are_ignored_only_when_moving_forward() {
        let p = SpatialContextParams::default();
        assert_eq!(spatial_context(&p, 3000.0, 0.0, true, true), 0.0);
        assert!(spatial_context(&p, 3000.0, 0.0, true, false) > 0.4);
        assert!(spatial_context(&p, 3000.0, 0.0, false, true) > 0.4);
    }

    #[test]
    fn temporal_context_is_a_running_mean_over_the_window() {
        let mut t = TemporalContext::new(4);
        assert_eq!(t.push(0.4), 0.1);
        t.push(0.4);
        t.push(0.4);
        assert!((t.push(0.4) - 0.4).abs() < 1e-7);
        for _ in 0..4 {
            t.push(0.0);
        }
        assert_eq!(t.value(), 0.0);
        assert_eq!(t.push(f32::NAN), 0.0);
    }
}
