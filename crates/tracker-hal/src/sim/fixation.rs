//! A person following targets, as in a calibration run.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::saccade::main_sequence_duration_ms;
use super::TruthSample;

/// One stop of a [`fixation_script`]: where the eye looks (tracker units),
/// for how long, and whether it is closed throughout (a target that must be
/// rejected and shown again).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// Where the eye looks, tracker units.
    pub at: [f64; 2],
    /// How long, µs.
    pub dwell_us: u64,
    /// Whether the eye is closed throughout.
    pub closed: bool,
}

/// How long a [`fixation_script`] holds its last point past its last stop.
const TAIL_US: u64 = 250_000;

/// A person following targets, as in a calibration run: per stop, a
/// main-sequence saccade from the previous point
/// ([`main_sequence_duration_ms`], the raised-cosine profile of
/// [`saccade_profile`](super::saccade_profile)), then a
/// fixation with `jitter` units of uniform noise. Stops follow one another
/// on the schedule [`Procedure`](crate::calibration::Procedure) uses (each
/// `dwell_us` after the previous, from the first sample, less
/// [`CHANGE_TOLERANCE_US`](crate::calibration::CHANGE_TOLERANCE_US)), and
/// the script holds the last point 250 ms past the last stop's end, so a
/// recorded calibration run replays in step with the procedure. Both eyes see the
/// same point; times start one second after the epoch.
pub fn fixation_script(
    stops: &[Stop],
    rate_hz: f64,
    units_per_degree: f64,
    jitter: f64,
    seed: u64,
) -> Vec<TruthSample> {
    if stops.is_empty() {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let period_us = 1e6 / rate_hz.max(1e-3);
    let tol = crate::calibration::CHANGE_TOLERANCE_US;
    let t0 = 1_000_000u64;
    // Stop s begins at starts[s] (µs after t0).
    let mut starts = Vec::with_capacity(stops.len() + 1);
    let mut at = 0u64;
    for s in stops {
        starts.push(at);
        at += s.dwell_us;
    }
    let end = at;
    let mut out = Vec::new();
    for k in 0u64.. {
        let t = t0 + (k as f64 * period_us).round() as u64;
        let since0 = t - t0;
        let s = (0..stops.len())
            .rev()
            .find(|&s| since0 + tol >= starts[s])
            .unwrap_or(0);
        let stop = &stops[s];
        let from = if s == 0 { stop.at } else { stops[s - 1].at };
        let amplitude_deg =
            (stop.at[0] - from[0]).hypot(stop.at[1] - from[1]) / units_per_degree.max(1e-9);
        let saccade_us = if amplitude_deg > 0.0 {
            main_sequence_duration_ms(amplitude_deg) * 1000.0
        } else {
            0.0
        };
        let since = (since0 + tol).saturating_sub(starts[s]) as f64;
        let p = if since < saccade_us {
            // `saccade_profile(since / saccade_us)`, in the order of
            // operations the script has always used (bit for bit).
            let e = 0.5 - 0.5 * (std::f64::consts::PI * since / saccade_us).cos();
            [
                from[0] + (stop.at[0] - from[0]) * e,
                from[1] + (stop.at[1] - from[1]) * e,
            ]
        } else {
            [
                stop.at[0] + rng.random_range(-1.0..=1.0) * jitter,
                stop.at[1] + rng.random_range(-1.0..=1.0) * jitter,
            ]
        };
        let eye = (!stop.closed).then_some(p);
        out.push(TruthSample {
            t_us: t,
            left: eye,
            right: eye,
        });
        // Hold the last point a little longer: phase changes that restart
        // the procedure's schedule at the next sample end a little later.
        if since0 + tol >= end + TAIL_US {
            break;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::{Order, Plan, Procedure, TimedPoint};

    /// The fixation script moves on exactly when the calibration procedure
    /// does, so every open-eyed target is accepted on the point it shows,
    /// and a closed-eye target is rejected.
    #[test]
    fn a_fixation_script_stays_in_step_with_the_procedure() {
        let plan = Plan::grid(9, (512, 512), 0.1, Order::Shuffled { seed: 3 }).expect("plan");
        let dwell = u64::from(plan.settle_ms + plan.collect_ms) * 1000;
        let stops: Vec<Stop> = plan
            .targets_px
            .iter()
            .enumerate()
            .map(|(i, &at)| Stop {
                at,
                dwell_us: dwell,
                closed: i == 4,
            })
            .collect();
        for rate in [50.0, 60.0, 250.0, 1000.0] {
            let truth = fixation_script(&stops, rate, 12.8, 0.2, 1);
            let mut p = Procedure::new(plan.clone());
            for s in &truth {
                p.feed(TimedPoint {
                    t_us: s.t_us,
                    raw: s.left,
                });
            }
            assert!(p.done(), "{rate} Hz: the script ended before the procedure");
            assert_eq!(p.rejected(), vec![4], "{rate} Hz");
            for r in p.results() {
                if let Ok(w) = &r.window {
                    let e = (w.raw[0] - r.target_px[0]).hypot(w.raw[1] - r.target_px[1]);
                    assert!(e < 0.3, "{rate} Hz: window {e} units from its target");
                }
            }
        }
    }
}
