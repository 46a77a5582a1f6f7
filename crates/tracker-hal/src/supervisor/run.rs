//! The supervisor loop: opens the device, passes its samples on, and
//! reopens it with back-off when it fails, cannot be opened or stays
//! silent.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;

use super::faults::{lock, Faults};
use super::message::{recording_stopped, TrackerMsg};
use super::{
    Source, BACKOFF_FIRST, BACKOFF_MAX, FAR_REPORT_EVERY, SILENT_RECONNECT, SILENT_REPORT,
    UNDECODED_REPORT,
};
use crate::clock::monotonic_us;
use crate::error::ErrorKind;
use crate::recording::Tap;

/// Raw tracker units to screen pixels (`None` outside the mapping's
/// domain).
pub type Map = Box<dyn Fn([f64; 2]) -> Option<[f64; 2]> + Send>;

/// What the supervisor is given besides the opener.
pub struct Supervisor {
    /// The recording's tap, watched for a write error to report at once.
    pub recording: Option<Tap>,
    /// Raw tracker units to screen pixels.
    pub map: Map,
    /// The screen's size (px): mapped gaze that is not finite or more than
    /// one screen diagonal outside it is marked invalid and counted
    /// ([`crate::plausibility::plausible`]).
    pub screen_px: Option<[f64; 2]>,
    /// Where the samples, clock updates and status lines go; never blocks.
    pub tx: Sender<TrackerMsg>,
    /// Set to stop: seen within a fraction of a second.
    pub stop: Arc<AtomicBool>,
    /// The source ends (a replay): its end ends the loop, and a silence
    /// does not reopen it.
    pub ends: bool,
    /// The counts, shared with whoever reports them.
    pub faults: Arc<Mutex<Faults>>,
    /// The device measures two eyes (not the mouse or the attention
    /// source, whose decoder copies one point into both): only then are
    /// both eyes' points passed on for vergence.
    pub binocular: bool,
}

/// Runs a tracker until `stop`: samples to `tx`, reopening with backoff
/// (0.25 s doubling to 4 s) when the device fails or stays silent for 2 s;
/// a replay ends at its end. Every device read is bounded in time (serial
/// read timeout, replay pacing in slices, the driver's maximum wait for a
/// record), so `stop` is seen within a fraction of a second.
pub fn run(mut open: impl FnMut() -> Result<Source, String>, supervisor: Supervisor) {
    let Supervisor {
        recording,
        map,
        screen_px,
        tx,
        stop,
        ends,
        binocular,
        faults,
    } = supervisor;
    let mut backoff = BACKOFF_FIRST;
    // Bytes received since the last record, over reconnects.
    let mut undecoded_bytes = 0u64;
    let mut far_reported: Option<(Instant, u64)> = None;
    let mut first = true;
    // The newest mapped time passed on: a new connection's mapper starts
    // afresh, and its times are shifted (by a constant, so intervals stay)
    // to follow the previous connection's strictly.
    let mut last_mapped: Option<u64> = None;
    let mut recording_failed = false;
    while !stop.load(Ordering::Relaxed) {
        let mut source = match open() {
            Ok(s) => s,
            Err(e) => {
                let _ = tx.send(TrackerMsg::Status(format!(
                    "tracker: {e}; retrying in {:.2} s",
                    backoff.as_secs_f64()
                )));
                // Sleep in short steps so a shutdown is not held up.
                let until = Instant::now() + backoff;
                while Instant::now() < until && !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(20));
                }
                backoff = (backoff * 2).min(BACKOFF_MAX);
                continue;
            }
        };
        if !first {
            lock(&faults).reconnects += 1;
        }
        first = false;
        if let Err(e) = source.start() {
            let _ = tx.send(TrackerMsg::Status(format!("tracker: {e}")));
        }
        let _ = tx.send(TrackerMsg::Status(String::new()));
        backoff = BACKOFF_FIRST;
        let opened = Instant::now();
        let mut shift: Option<u64> = None;
        let mut refits = u64::MAX;
        let mut last_record = opened;
        let mut last_byte = opened;
        // When a silence (no byte at all) began, once reported.
        let mut silent: Option<Instant> = None;
        let mut undecoded = false;
        let mut seen_bytes = 0u64;
        let base = lock(&faults).decode;
        let end_silence = |silent: &mut Option<Instant>| {
            if let Some(t) = silent.take() {
                let mut f = lock(&faults);
                f.longest_silence_s = f.longest_silence_s.max(t.elapsed().as_secs_f64());
                true
            } else {
                false
            }
        };
        while !stop.load(Ordering::Relaxed) {
            if let Some(e) = recording.as_ref().and_then(Tap::failure) {
                if !recording_failed {
                    recording_failed = true;
                    let _ = tx.send(TrackerMsg::Status(recording_stopped(&e)));
                }
            }
            let next = source.next_sample();
            let stats = source.stats();
            if stats.bytes > seen_bytes {
                undecoded_bytes += stats.bytes - seen_bytes;
                seen_bytes = stats.bytes;
                last_byte = Instant::now();
                if end_silence(&mut silent) {
                    let _ = tx.send(TrackerMsg::Status(String::new()));
                }
            }
            lock(&faults).decode = base + stats;
            match next {
                Ok(Some(s)) => {
                    last_record = Instant::now();
                    undecoded_bytes = 0;
                    if undecoded {
                        undecoded = false;
                        let _ = tx.send(TrackerMsg::Status(String::new()));
                    }
                    let raw = s.gaze().filter(|p| p[0].is_finite() && p[1].is_finite());
                    let mapped = raw.and_then(&map);
                    let gaze_px = mapped.filter(|&p| crate::plausibility::plausible(p, screen_px));
                    let eye = |e: &crate::sample::EyeSample| {
                        e.position
                            .and_then(&map)
                            .filter(|&p| crate::plausibility::plausible(p, screen_px))
                    };
                    let measured = |e: &crate::sample::EyeSample| crate::sample::EyeSample {
                        position: e.position.filter(|p| p[0].is_finite() && p[1].is_finite()),
                        pupil: e.pupil.filter(|p| p.is_finite()),
                    };
                    let eyes = if binocular {
                        [measured(&s.left), measured(&s.right)]
                    } else {
                        [crate::sample::EyeSample::MISSING; 2]
                    };
                    let eye_px = [eyes[0], eyes[1]].map(|e| eye(&e));
                    let eyes_px = match (eye(&s.left), eye(&s.right)) {
                        (Some(l), Some(r)) if binocular && gaze_px.is_some() => Some([l, r]),
                        _ => None,
                    };
                    let far = {
                        let mut f = lock(&faults);
                        f.samples += 1;
                        if raw.is_none() {
                            f.missing += 1;
                        }
                        if mapped.is_some() && gaze_px.is_none() {
                            f.far += 1;
                        }
                        f.far
                    };
                    let shift = *shift.get_or_insert_with(|| match last_mapped {
                        Some(l) if s.mapped_time_us <= l => l + 1 - s.mapped_time_us,
                        _ => 0,
                    });
                    let mapped_us = s.mapped_time_us + shift;
                    last_mapped = Some(last_mapped.map_or(mapped_us, |l| l.max(mapped_us)));
                    if let Some(c) = source.clock().filter(|c| c.refits != refits) {
                        refits = c.refits;
                        let _ = tx.send(TrackerMsg::Clock(c, source.device_clock()));
                    }
                    let _ = tx.send(TrackerMsg::Gaze {
                        received_us: monotonic_us(),
                        device_us: s.device_time_us,
                        arrival_us: s.host_time_us,
                        mapped_us,
                        time_order: s.time_order,
                        segment: s.clock_segment,
                        raw,
                        gaze_px,
                        eyes_px,
                        eye_distance_mm: crate::plausibility::eye_distance_mm(&s),
                        eyes,
                        eye_px,
                    });
                    let due = far_reported
                        .is_none_or(|(t, n)| n != far && t.elapsed() >= FAR_REPORT_EVERY);
                    if far > 0 && due {
                        far_reported = Some((Instant::now(), far));
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {far} gaze samples far off the screen or not finite, marked invalid; keeping the last valid gaze"
                        )));
                    }
                }
                Ok(None) => {
                    end_silence(&mut silent);
                    let _ = tx.send(TrackerMsg::Status(
                        "tracker: end of stream; keeping the last gaze".into(),
                    ));
                    if ends {
                        return;
                    }
                    break;
                }
                Err(e) if e.kind == ErrorKind::TimedOut => {
                    // A device that goes silent (unplugged without an error,
                    // stopped, a dead line) is reported, then reopened; one
                    // whose bytes never decode (wrong baud or mode) too.
                    let (no_record, no_byte) = (last_record.elapsed(), last_byte.elapsed());
                    let arriving = undecoded_bytes > 0 && no_byte < SILENT_REPORT;
                    let what = if arriving {
                        format!("{undecoded_bytes} bytes, 0 records decoded: wrong baud or format?")
                    } else {
                        format!("no data for {:.1} s", no_byte.as_secs_f64())
                    };
                    if no_record >= SILENT_RECONNECT && !ends {
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what}; keeping the last gaze, reconnecting"
                        )));
                        break;
                    }
                    if arriving && no_record >= UNDECODED_REPORT && !undecoded {
                        undecoded = true;
                        lock(&faults).undecoded += 1;
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what} (keeping the last gaze)"
                        )));
                    } else if no_byte >= SILENT_REPORT && silent.is_none() {
                        silent = Some(last_byte);
                        lock(&faults).silences += 1;
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what}; keeping the last gaze"
                        )));
                    }
                }
                Err(e) => {
                    let _ = tx.send(TrackerMsg::Status(format!(
                        "tracker: {e}; keeping the last gaze, reconnecting"
                    )));
                    break;
                }
            }
        }
        end_silence(&mut silent);
        let _ = source.stop();
    }
}
