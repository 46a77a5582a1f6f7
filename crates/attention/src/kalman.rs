//! The per-object smoothing filter (Lee §3.2.1, §3.3: "a discrete Kalman
//! filter \[98\], based on the position and velocity state model").
//!
//! State `[s, ṡ]` (attention and its rate), constant-velocity transition
//! `F = [[1, dt], [0, 1]]`, measurement `H = [1, 0]`, process noise of a
//! white-noise rate change `Q = q·[[dt³/3, dt²/2], [dt²/2, dt]]`,
//! measurement variance `r`.

use crate::config::KalmanParams;

/// Longest step the filter predicts over, seconds; a longer pause is
/// treated as this long (the covariance is then large enough that the next
/// measurement dominates).
pub const MAX_PREDICT_S: f64 = 10.0;

/// One object's filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalarKalman {
    value: f64,
    rate: f64,
    p: [[f64; 2]; 2],
}

impl ScalarKalman {
    /// Starts at `measurement` with rate 0; the value's variance is the
    /// measurement variance, the rate's is 1 /s².
    pub fn new(measurement: f32, params: &KalmanParams) -> Self {
        let z = if measurement.is_finite() {
            f64::from(measurement)
        } else {
            0.0
        };
        Self {
            value: z,
            rate: 0.0,
            p: [[params.measurement_noise, 0.0], [0.0, 1.0]],
        }
    }

    /// Predicts over `dt_s` and corrects with `measurement`; returns the
    /// filtered value (unclamped). Non-finite measurements skip the
    /// correction.
    pub fn step(&mut self, measurement: f32, dt_s: f64, params: &KalmanParams) -> f64 {
        let dt = if dt_s.is_finite() {
            dt_s.clamp(0.0, MAX_PREDICT_S)
        } else {
            0.0
        };
        let q = params.process_noise;
        // Predict.
        self.value += self.rate * dt;
        let [[p00, p01], [p10, p11]] = self.p;
        let pp00 = p00 + dt * (p10 + p01) + dt * dt * p11 + q * dt * dt * dt / 3.0;
        let pp01 = p01 + dt * p11 + q * dt * dt / 2.0;
        let pp10 = p10 + dt * p11 + q * dt * dt / 2.0;
        let pp11 = p11 + q * dt;
        self.p = [[pp00, pp01], [pp10, pp11]];
        // Correct.
        if measurement.is_finite() {
            let innovation = f64::from(measurement) - self.value;
            let s = pp00 + params.measurement_noise;
            if s > 0.0 && s.is_finite() {
                let (k0, k1) = (pp00 / s, pp10 / s);
                self.value += k0 * innovation;
                self.rate += k1 * innovation;
                self.p = [
                    [(1.0 - k0) * pp00, (1.0 - k0) * pp01],
                    [pp10 - k1 * pp00, pp11 - k1 * pp01],
                ];
            }
        }
        if !(self.value.is_finite()
            && self.rate.is_finite()
            && self.p.iter().flatten().all(|v| v.is_finite()))
        {
            // Cannot happen for validated parameters; restart rather than spread NaN.
            *self = Self::new(measurement, params);
        }
        self.value
    }

    /// The filtered value (unclamped).
    pub fn value(&self) -> f64 {
        self.value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converges_to_a_constant_measurement() {
        let params = KalmanParams::default();
        let mut k = ScalarKalman::new(0.0, &params);
        let mut v = 0.0;
        for _ in 0..120 {
            v = k.step(0.6, 1.0 / 60.0, &params);
        }
        assert!((v - 0.6).abs() < 1e-3, "value {v}");
    }

    #[test]
    fn a_step_settles_within_about_ten_frames_at_60_hz() {
        let params = KalmanParams::default();
        let mut k = ScalarKalman::new(0.0, &params);
        // Let the covariance reach its steady state first.
        for _ in 0..300 {
            k.step(0.0, 1.0 / 60.0, &params);
        }
        let trace: Vec<f64> = (0..30).map(|_| k.step(1.0, 1.0 / 60.0, &params)).collect();
        assert!(trace[0] > 0.05 && trace[0] < 0.5, "no jump: {}", trace[0]);
        assert!(trace[11] > 0.9, "settled by frame 12: {:?}", &trace[..12]);
        assert!(trace.iter().all(|v| *v < 1.3), "bounded overshoot");
    }

    #[test]
    fn smooths_alternating_noise() {
        let params = KalmanParams::default();
        let mut k = ScalarKalman::new(0.5, &params);
        let mut worst = 0.0f64;
        for i in 0..600 {
            let z = if i % 2 == 0 { 0.45 } else { 0.55 };
            let v = k.step(z, 1.0 / 60.0, &params);
            if i > 60 {
                worst = worst.max((v - 0.5).abs());
            }
        }
        assert!(worst < 0.02, "ripple {worst}");
    }
}
