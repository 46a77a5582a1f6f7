//! The supervisor against tracker-hal's own fake devices: a replayed
//! simulated ISCAN stream, a device that cannot be opened, one whose bytes
//! never decode, one that stays silent.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;

use super::{run, Faults, Source, Supervisor, TrackerMsg, MAX_WAIT};
use crate::clock::MonotonicClock;
use crate::iscan::{IscanConfig, IscanDecoder, IscanMode};
use crate::sim::{gaze_script, simulate_iscan, Script, SimStream};
use crate::{Pacing, ReplayTransport, StreamDriver};

/// One second of a simulated binocular binary ISCAN at 60 Hz.
fn iscan_stream() -> (IscanConfig, SimStream) {
    let config = IscanConfig::binocular(IscanMode::Binary);
    let truth = gaze_script(&Script {
        seconds: 1.0,
        rate_hz: 60.0,
        frame: config.frame,
        units_per_degree: 12.8,
        seed: 3,
    });
    let stream = simulate_iscan(&config, &truth, 3);
    (config, stream)
}

/// A replay of `stream` as fast as possible.
fn replay(config: &IscanConfig, stream: &SimStream) -> Source {
    let chunks = stream
        .chunks
        .iter()
        .map(|c| (c.time_us, c.payload.clone()))
        .collect();
    let t = ReplayTransport::new(chunks, Pacing::AsFastAsPossible);
    let clock = t.clock();
    Box::new(StreamDriver::new(
        t,
        IscanDecoder::new(config.clone()),
        Box::new(clock),
    ))
}

/// A supervisor mapping tracker units one to one, with its receiver, stop
/// flag and counts.
fn supervisor(ends: bool) -> (Supervisor, Receiver<TrackerMsg>, Arc<AtomicBool>) {
    let (tx, rx) = crossbeam_channel::unbounded();
    let stop = Arc::new(AtomicBool::new(false));
    let s = Supervisor {
        recording: None,
        map: Box::new(Some),
        screen_px: None,
        tx,
        stop: stop.clone(),
        ends,
        faults: Arc::new(Mutex::new(Faults::default())),
        binocular: true,
    };
    (s, rx, stop)
}

fn statuses(rx: &Receiver<TrackerMsg>) -> Vec<String> {
    rx.try_iter()
        .filter_map(|m| match m {
            TrackerMsg::Status(s) => Some(s),
            _ => None,
        })
        .collect()
}

/// A device that sends bytes that never decode, a little at a time.
struct Garbage;

impl Read for Garbage {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        std::thread::sleep(Duration::from_millis(5));
        let n = buf.len().min(16);
        buf[..n].fill(0x11);
        Ok(n)
    }
}

/// A device that never sends anything: every read times out.
struct Silent;

impl Read for Silent {
    fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
        std::thread::sleep(Duration::from_millis(20));
        Err(std::io::ErrorKind::TimedOut.into())
    }
}

impl Write for Garbage {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Write for Silent {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_replay_is_passed_on_whole_and_ends_the_loop() {
    let (config, stream) = iscan_stream();
    let (s, rx, _stop) = supervisor(true);
    let faults = s.faults.clone();
    let mut once = Some(replay(&config, &stream));
    run(move || once.take().ok_or_else(|| "played".to_string()), s);
    let msgs: Vec<TrackerMsg> = rx.try_iter().collect();
    let gaze: Vec<u64> = msgs
        .iter()
        .filter_map(|m| match m {
            TrackerMsg::Gaze { mapped_us, .. } => Some(*mapped_us),
            _ => None,
        })
        .collect();
    assert_eq!(gaze.len(), stream.expected.len());
    assert!(
        gaze.windows(2).all(|w| w[0] <= w[1]),
        "mapped times in order"
    );
    let last = msgs.iter().rev().find_map(|m| match m {
        TrackerMsg::Status(s) => Some(s.clone()),
        _ => None,
    });
    assert_eq!(
        last.as_deref(),
        Some("tracker: end of stream; keeping the last gaze")
    );
    let f = Faults::read(&faults);
    assert_eq!(f.samples, stream.expected.len() as u64);
    assert_eq!(f.reconnects, 0);
    assert_eq!(f.decode.records, stream.expected.len() as u64);
}

#[test]
fn a_device_that_cannot_be_opened_is_retried_with_backoff() {
    let (config, stream) = iscan_stream();
    let (s, rx, _stop) = supervisor(true);
    let faults = s.faults.clone();
    let mut tries = 0;
    let mut source = Some(replay(&config, &stream));
    let t = Instant::now();
    run(
        move || {
            tries += 1;
            if tries <= 2 {
                Err("no such port".into())
            } else {
                source.take().ok_or_else(|| "played".to_string())
            }
        },
        s,
    );
    // 0.25 s, then 0.5 s.
    assert!(
        t.elapsed() >= Duration::from_millis(750),
        "{:?}",
        t.elapsed()
    );
    let st = statuses(&rx);
    assert_eq!(st[0], "tracker: no such port; retrying in 0.25 s");
    assert_eq!(st[1], "tracker: no such port; retrying in 0.50 s");
    assert_eq!(st[2], "", "streaming: the status line is cleared");
    // The first successful opening is no reconnection.
    assert_eq!(Faults::read(&faults).reconnects, 0);
}

#[test]
fn bytes_that_never_decode_are_reported_then_reconnected() {
    let (s, rx, stop) = supervisor(false);
    let faults = s.faults.clone();
    let config = IscanConfig::binocular(IscanMode::Binary);
    let handle = std::thread::spawn(move || {
        run(
            move || {
                let d = StreamDriver::new(
                    Garbage,
                    IscanDecoder::new(config.clone()),
                    Box::new(MonotonicClock),
                )
                .with_max_wait(MAX_WAIT);
                Ok(Box::new(d) as Source)
            },
            s,
        )
    });
    std::thread::sleep(Duration::from_millis(2800));
    stop.store(true, Ordering::Relaxed);
    let asked = Instant::now();
    handle.join().expect("the supervisor");
    assert!(asked.elapsed() < Duration::from_secs(1), "stop is seen");
    let st = statuses(&rx);
    assert!(
        st.iter().any(|s| s
            .ends_with("bytes, 0 records decoded: wrong baud or format? (keeping the last gaze)")),
        "{st:?}"
    );
    assert!(
        st.iter().any(|s| s.ends_with(
            "bytes, 0 records decoded: wrong baud or format?; keeping the last gaze, reconnecting"
        )),
        "{st:?}"
    );
    let f = Faults::read(&faults);
    assert_eq!(f.undecoded, 1, "{f:?}");
    assert_eq!(f.reconnects, 1, "{f:?}");
    assert_eq!(f.samples, 0);
}

#[test]
fn a_silent_device_is_reported_and_the_silence_counted() {
    let (s, rx, stop) = supervisor(false);
    let faults = s.faults.clone();
    let config = IscanConfig::binocular(IscanMode::Binary);
    let handle = std::thread::spawn(move || {
        run(
            move || {
                let d = StreamDriver::new(
                    Silent,
                    IscanDecoder::new(config.clone()),
                    Box::new(MonotonicClock),
                );
                Ok(Box::new(d) as Source)
            },
            s,
        )
    });
    std::thread::sleep(Duration::from_millis(900));
    stop.store(true, Ordering::Relaxed);
    handle.join().expect("the supervisor");
    let st = statuses(&rx);
    assert!(
        st.iter()
            .any(|s| s.starts_with("tracker: no data for ")
                && s.ends_with(" s; keeping the last gaze")),
        "{st:?}"
    );
    let f = Faults::read(&faults);
    assert_eq!(f.silences, 1, "{f:?}");
    assert!(f.longest_silence_s >= 0.3, "{f:?}");
    assert_eq!(f.reconnects, 0);
}
