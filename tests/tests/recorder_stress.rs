//! The recorder loses nothing at 2000 samples/s for 60 s of samples, run at
//! 10× real time (20 000 chunks/s for 6 s) with both cores kept busy.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use tracker_hal::iscan::{encode_binary, IscanConfig, IscanMode};
use tracker_hal::recording::RecordingHeader;
use tracker_hal::{Driver, Recorder, Recording, TrackerConfig};

#[test]
#[ignore = "slow tier: stress test (a minute of 2000-Hz samples under load)"]
fn recording_2000_hz_for_60_s_under_load_loses_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("stress.gzrec");
    let header = RecordingHeader {
        tracker: TrackerConfig {
            driver: Driver::Iscan(IscanConfig::binocular(IscanMode::Binary)),
            mapping: Default::default(),
        },
        display: None,
        note: "stress test".into(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let load: Vec<_> = (0..2)
        .map(|_| {
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                    std::hint::black_box(x);
                }
            })
        })
        .collect();

    let recorder = Recorder::start(&path, &header, 8192).expect("recorder");
    let tap = recorder.tap();
    let total = 2000 * 60;
    let speedup = 10;
    let start = Instant::now();
    for k in 0..total as u64 {
        // Pace: chunk k is due at k / (2000 · speedup) s.
        if k % 20 == 0 {
            let due = start + Duration::from_micros(k * 1_000_000 / (2000 * speedup));
            if let Some(w) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(w);
            }
        }
        let v = (k % 5000) as f64 / 10.0;
        tap.device_to_host(
            k * 500,
            &encode_binary(&[Some(v), Some(v), Some(v), Some(v)]),
        );
    }
    let summary = recorder.finish().expect("finish");
    stop.store(true, Ordering::Relaxed);
    for t in load {
        t.join().expect("load thread");
    }
    assert_eq!(summary.lost_chunks, 0, "{summary:?}");
    assert_eq!(summary.chunks_written, total as u64);
    let rec = Recording::read(&path).expect("read back");
    assert!(rec.closed && rec.torn_tail.is_none() && rec.lost_chunks == 0);
    let chunks: Vec<_> = rec.device_chunks().collect();
    assert_eq!(chunks.len(), total);
    for (k, c) in chunks.iter().enumerate() {
        assert_eq!(c.time_us, k as u64 * 500);
    }
}

#[test]
fn overflow_is_counted_and_written_into_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("overflow.gzrec");
    let header = RecordingHeader {
        tracker: TrackerConfig {
            driver: Driver::Iscan(IscanConfig::binocular(IscanMode::Binary)),
            mapping: Default::default(),
        },
        display: None,
        note: String::new(),
    };
    // A one-chunk queue and a burst of large chunks: the writer cannot keep up.
    let recorder = Recorder::start(&path, &header, 1).expect("recorder");
    let tap = recorder.tap();
    let big = vec![7u8; 256 * 1024];
    for k in 0..200 {
        tap.device_to_host(k, &big);
    }
    let lost_seen_by_tap = tap.lost_chunks();
    let summary = recorder.finish().expect("finish");
    assert!(
        summary.lost_chunks > 0,
        "the burst should overflow a one-chunk queue"
    );
    assert_eq!(summary.lost_chunks, lost_seen_by_tap);
    assert_eq!(summary.chunks_written + summary.lost_chunks, 200);
    let rec = Recording::read(&path).expect("read back");
    assert_eq!(
        rec.lost_chunks, summary.lost_chunks,
        "the file records the loss"
    );
}
