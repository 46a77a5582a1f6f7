//! The search behaviour of `gazecast simulate --script search`: fixations
//! anywhere in the frame, saccades, blinks, a lost eye, a vergence offset.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::saccade::{main_sequence_duration_ms, saccade_profile};
use super::TruthSample;

/// What to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Script {
    /// Length of the script, seconds.
    pub seconds: f64,
    /// Sampling rate, Hz.
    pub rate_hz: f64,
    /// Area the gaze moves in, (width, height) in tracker units.
    pub frame: (f64, f64),
    /// Tracker units per degree (for the main sequence).
    pub units_per_degree: f64,
    /// Seed of the random generator (same seed, same script).
    pub seed: u64,
}

/// Generates the gaze script: fixations (200–500 ms), saccades between them
/// (duration from the main sequence, [`main_sequence_duration_ms`], position
/// along [`saccade_profile`]), blinks after 10 % of fixations (80–180 ms), the
/// right eye lost for 150–400 ms after 8 %, a 2.5-unit vergence offset.
pub fn gaze_script(script: &Script) -> Vec<TruthSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(script.seed);
    let (w, h) = script.frame;
    let n = (script.seconds * script.rate_hz).round() as u64;
    let period_us = 1e6 / script.rate_hz;
    let t0 = 1_000_000u64; // one second after the epoch: times are never near 0
    let margin = 0.08;
    let mut target = || {
        [
            w * rng.random_range(margin..1.0 - margin),
            h * rng.random_range(margin..1.0 - margin),
        ]
    };
    let mut pos = target();
    let mut out = Vec::with_capacity(n as usize);
    // Events as (kind, start_us, end_us, from, to).
    let mut phase_end = 0u64;
    let mut saccade: Option<(u64, u64, [f64; 2], [f64; 2])> = None;
    let mut blink_until = 0u64;
    let mut lost_until = 0u64;
    let mut rng2 = ChaCha8Rng::seed_from_u64(script.seed ^ 0x5EED);
    for k in 0..n {
        let t = t0 + (k as f64 * period_us).round() as u64;
        if t >= phase_end {
            match saccade.take() {
                Some((_, _, _, to)) => {
                    pos = to;
                    phase_end = t + rng2.random_range(200_000..500_000);
                    let r: f64 = rng2.random();
                    if r < 0.10 {
                        blink_until = t + rng2.random_range(80_000..180_000);
                    } else if r < 0.18 {
                        lost_until = t + rng2.random_range(150_000..400_000);
                    }
                }
                None if k == 0 => phase_end = t + rng2.random_range(200_000..500_000),
                None => {
                    let to = target();
                    let amplitude_deg =
                        (to[0] - pos[0]).hypot(to[1] - pos[1]) / script.units_per_degree;
                    let duration = (main_sequence_duration_ms(amplitude_deg) * 1000.0) as u64;
                    saccade = Some((t, duration, pos, to));
                    phase_end = t + duration;
                }
            }
        }
        let p = match saccade {
            Some((start, duration, from, to)) => {
                let s = ((t - start) as f64 / duration as f64).clamp(0.0, 1.0);
                let k = saccade_profile(s);
                [
                    from[0] + (to[0] - from[0]) * k,
                    from[1] + (to[1] - from[1]) * k,
                ]
            }
            None => [
                pos[0] + rng2.random_range(-0.3..0.3),
                pos[1] + rng2.random_range(-0.3..0.3),
            ],
        };
        let blink = t < blink_until;
        let left = (!blink).then_some(p);
        let right = (!blink && t >= lost_until).then_some([p[0] + 2.5, p[1]]);
        out.push(TruthSample {
            t_us: t,
            left,
            right,
        });
    }
    out
}
