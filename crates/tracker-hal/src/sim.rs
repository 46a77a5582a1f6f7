//! A device simulator: synthesised gaze behaviour encoded in each driver's
//! documented wire format, with the samples a correct decoder must produce.
//!
//! The recorded streams under `tests/data/` come from here (`gazecast
//! simulate`); they are **synthesised, not captured from a real device**.
//! The script has fixations with small drift, main-sequence saccades, blinks
//! (both eyes missing), spells with one eye lost, a vergence offset between
//! the eyes, and serial reads that split records at random points.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::iscan::{encode_ascii, encode_binary, IscanConfig, IscanMode, IscanParam};
use crate::mouse::{CursorEvent, MouseConfig, MouseEmulator, RECORD_LEN};
use crate::recording::{Chunk, ChunkKind};
use crate::sample::{EyeSample, GazeSample};

/// The simulated truth at one sampling instant, in tracker units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    pub t_us: u64,
    pub left: Option<[f64; 2]>,
    pub right: Option<[f64; 2]>,
}

/// What to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Script {
    pub seconds: f64,
    pub rate_hz: f64,
    /// Area the gaze moves in, (width, height) in tracker units.
    pub frame: (f64, f64),
    /// Tracker units per degree (for the main sequence).
    pub units_per_degree: f64,
    pub seed: u64,
}

/// Generates the gaze script: fixations (200–500 ms), saccades between them
/// (2.2 ms/deg + 21 ms), blinks after 10 % of fixations (80–180 ms), the
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
                    let duration = ((2.2 * amplitude_deg + 21.0) * 1000.0) as u64;
                    saccade = Some((t, duration, pos, to));
                    phase_end = t + duration;
                }
            }
        }
        let p = match saccade {
            Some((start, duration, from, to)) => {
                let s = ((t - start) as f64 / duration as f64).clamp(0.0, 1.0);
                let k = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
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

/// One stop of a [`fixation_script`]: where the eye looks (tracker units),
/// for how long, and whether it is closed throughout (a target that must be
/// rejected and shown again).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    pub at: [f64; 2],
    pub dwell_us: u64,
    pub closed: bool,
}

/// How long a [`fixation_script`] holds its last point past its last stop.
const TAIL_US: u64 = 250_000;

/// A person following targets, as in a calibration run: per stop, a
/// main-sequence saccade from the previous point (2.2 ms/° + 21 ms), then a
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
            (2.2 * amplitude_deg + 21.0) * 1000.0
        } else {
            0.0
        };
        let since = (since0 + tol).saturating_sub(starts[s]) as f64;
        let p = if since < saccade_us {
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

/// A simulated stream: what the device sends, and what must come out.
#[derive(Debug, Clone)]
pub struct SimStream {
    /// Device → host chunks with host arrival times.
    pub chunks: Vec<Chunk>,
    /// The samples a correct decoder produces from `chunks`.
    pub expected: Vec<GazeSample>,
}

/// Encodes the truth as an ISCAN would send it over a serial line, each
/// record split into 1–3 reads that arrive after their wire time plus up to
/// 0.8 ms of host latency.
pub fn simulate_iscan(config: &IscanConfig, truth: &[TruthSample], seed: u64) -> SimStream {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut chunks = Vec::new();
    let mut expected = Vec::new();
    let mut last_arrival = 0u64;
    let (fw, fh) = config.frame;
    for (k, s) in truth.iter().enumerate() {
        let values: Vec<Option<f64>> = config
            .parameters
            .iter()
            .map(|p| match p {
                IscanParam::LeftPorH => s.left.map(|p| p[0]),
                IscanParam::LeftPorV => s.left.map(|p| p[1]),
                IscanParam::RightPorH => s.right.map(|p| p[0]),
                IscanParam::RightPorV => s.right.map(|p| p[1]),
                IscanParam::LeftPupil => s.left.map(|_| 30.0),
                IscanParam::RightPupil => s.right.map(|_| 31.0),
                IscanParam::Other => Some(0.0),
            })
            .collect();
        let (record, quantised): (Vec<u8>, Vec<Option<f64>>) = match config.mode {
            IscanMode::Binary => (
                encode_binary(&values),
                values
                    .iter()
                    .map(|v| v.map(|v| ((v * 10.0).round() as u16) as f64 / 10.0))
                    .collect(),
            ),
            IscanMode::Ascii => (
                encode_ascii(&values),
                values
                    .iter()
                    .map(|v| v.and_then(|v| format!("{v:.1}").parse::<f64>().ok()))
                    .collect(),
            ),
        };
        // Split points and arrival times.
        let pieces = rng.random_range(1..=3usize).min(record.len());
        let mut cuts: Vec<usize> = (1..pieces)
            .map(|_| rng.random_range(1..record.len()))
            .collect();
        cuts.push(record.len());
        cuts.sort_unstable();
        cuts.dedup();
        let mut from = 0;
        for &to in &cuts {
            let arrival =
                (s.t_us + config.wire_time_us(to) + rng.random_range(0..800u64)).max(last_arrival);
            last_arrival = arrival;
            chunks.push(Chunk {
                kind: ChunkKind::DeviceToHost,
                time_us: arrival,
                payload: record[from..to].to_vec(),
            });
            from = to;
        }
        let eye = |h: IscanParam, v: IscanParam| {
            let get = |p: IscanParam| {
                config
                    .parameters
                    .iter()
                    .position(|q| *q == p)
                    .and_then(|i| quantised[i])
            };
            match (get(h), get(v)) {
                (Some(x), Some(y)) if (0.0..fw).contains(&x) && (0.0..fh).contains(&y) => {
                    EyeSample {
                        position: Some([x, y]),
                        pupil: None,
                    }
                }
                _ => EyeSample::MISSING,
            }
        };
        let mut left = eye(IscanParam::LeftPorH, IscanParam::LeftPorV);
        let mut right = eye(IscanParam::RightPorH, IscanParam::RightPorV);
        let pupil = |p: IscanParam| {
            config
                .parameters
                .iter()
                .position(|q| *q == p)
                .and_then(|i| quantised[i])
        };
        if left.valid() {
            left.pupil = pupil(IscanParam::LeftPupil);
        }
        if right.valid() {
            right.pupil = pupil(IscanParam::RightPupil);
        }
        expected.push(GazeSample {
            seq: k as u64,
            device_time_us: Some(last_arrival.saturating_sub(config.wire_time_us(record.len()))),
            host_time_us: last_arrival,
            left,
            right,
            combined: None,
            eye_position_um: [None, None],
        });
    }
    SimStream { chunks, expected }
}

/// Drives the mouse emulator with the truth's left eye (scaled by
/// `px_per_unit`) as the cursor, a blink while both eyes are closed, one
/// record per truth sample arriving 50–400 µs after its tick.
pub fn simulate_mouse(
    config: &MouseConfig,
    truth: &[TruthSample],
    px_per_unit: f64,
    seed: u64,
) -> SimStream {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut emulator = MouseEmulator::new(config.clone());
    let mut cursor = [0.0, 0.0];
    let mut chunks = Vec::with_capacity(truth.len());
    let mut expected = Vec::with_capacity(truth.len());
    for (k, s) in truth.iter().enumerate() {
        if let Some(p) = s.left {
            cursor = [p[0] * px_per_unit, p[1] * px_per_unit];
        }
        let blink = s.left.is_none() && s.right.is_none();
        emulator.cursor(CursorEvent {
            t_us: s.t_us,
            position_px: cursor,
            blink,
        });
        let record: [u8; RECORD_LEN] = emulator.tick(s.t_us);
        let arrival = s.t_us + rng.random_range(50..400u64);
        chunks.push(Chunk {
            kind: ChunkKind::DeviceToHost,
            time_us: arrival,
            payload: record.to_vec(),
        });
        // What the record says, read field by field from the documented layout.
        let f = |o: usize| {
            f64::from(f32::from_le_bytes([
                record[o],
                record[o + 1],
                record[o + 2],
                record[o + 3],
            ]))
        };
        let eye = if record[10] == 1 {
            EyeSample {
                position: Some([f(11), f(15)]),
                pupil: None,
            }
        } else {
            EyeSample::MISSING
        };
        expected.push(GazeSample {
            seq: k as u64,
            device_time_us: Some(s.t_us),
            host_time_us: arrival,
            left: eye,
            right: eye,
            combined: None,
            eye_position_um: [None, None],
        });
    }
    SimStream { chunks, expected }
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
