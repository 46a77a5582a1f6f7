//! Timing truth: the times a session keeps must not depend on how busy the
//! host was. Every recorded stream in `tests/data` is replayed twice
//! through the real driver — once as recorded, once through a transport
//! that delays and batches its bytes the way a loaded machine delivers
//! them (bursts of up to 50 ms, stalls of up to 200 ms) — and must give
//! exactly the same device times and exactly the same eye-movement events,
//! with mapped times that increase strictly and keep the tracker's
//! intervals within 0.1 ms.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use tracker_hal::events::{classify, merge_congruent_fixations, Event, IvtConfig, TimedGaze};
use tracker_hal::{GazeSample, GazeSource, Pacing, Recording, ReplayTransport, StreamDriver};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

const STREAMS: [&str; 6] = [
    "iscan-binary-60hz",
    "iscan-ascii-60hz",
    "iscan-binary-240hz",
    "mouse-120hz",
    "tobii-hid-50hz",
    "tobii-hid-compact-120hz",
];

fn geometry() -> foveation::ScreenGeometry {
    foveation::Display {
        name: "17in".into(),
        resolution_px: (1280, 1024),
        size_mm: (337.9, 270.3),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    }
    .geometry()
    .expect("geometry")
}

/// The recording's device → host chunks as (arrival µs, bytes).
fn chunks(rec: &Recording) -> Vec<(u64, Vec<u8>)> {
    rec.device_chunks()
        .map(|c| (c.time_us, c.payload.clone()))
        .collect()
}

/// What a loaded host makes of the same bytes: consecutive chunks merged
/// into bursts spanning up to `burst_us` of the original arrivals, each
/// burst delivered after its last byte plus a random delay, and now and
/// then a stall of up to `stall_us` that holds everything behind it.
/// Bytes and their order are unchanged; arrival times only grow.
fn loaded(
    chunks: &[(u64, Vec<u8>)],
    burst_us: u64,
    stall_us: u64,
    seed: u64,
) -> Vec<(u64, Vec<u8>)> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out: Vec<(u64, Vec<u8>)> = Vec::new();
    let mut held_until = 0u64;
    let mut i = 0;
    while i < chunks.len() {
        let start = chunks[i].0;
        let window = rng.random_range(0..=burst_us);
        let mut bytes = Vec::new();
        let mut last = start;
        while i < chunks.len() && chunks[i].0 <= start + window {
            bytes.extend_from_slice(&chunks[i].1);
            last = chunks[i].0;
            i += 1;
        }
        if rng.random_range(0..40) == 0 {
            held_until = last + rng.random_range(0..=stall_us);
        }
        let prev = out.last().map_or(0, |c| c.0);
        let arrival = (last + rng.random_range(0..2_000))
            .max(held_until)
            .max(prev);
        out.push((arrival, bytes));
    }
    out
}

fn decode(rec: &Recording, chunks: Vec<(u64, Vec<u8>)>) -> Vec<GazeSample> {
    let t = ReplayTransport::new(chunks, Pacing::AsFastAsPossible);
    let clock = t.clock();
    let mut d = StreamDriver::new(t, rec.header.tracker.decoder(), Box::new(clock));
    let mut out = Vec::new();
    while let Some(s) = d.next_sample().expect("replays") {
        out.push(s);
    }
    out
}

fn events(rec: &Recording, samples: &[GazeSample]) -> Vec<Event> {
    let tracker = &rec.header.tracker;
    let g = geometry();
    let timed: Vec<TimedGaze> = samples
        .iter()
        .map(|s| {
            let px = s
                .gaze()
                .map(|p| tracker.mapping.to_screen(p, tracker.frame()));
            TimedGaze::of(s, px)
        })
        .collect();
    let c = classify(&timed, &g, &IvtConfig::default());
    merge_congruent_fixations(&c.events, &g, 1.0, 250_000)
}

/// An event without its host-clock times (which a loaded host may move by
/// a few µs): what it is, which samples it holds, its device-clock extent.
fn key(e: &Event) -> String {
    format!(
        "{:?} {}..{} {}..{} seg {}",
        e.kind, e.first, e.last, e.start_device_us, e.end_device_us, e.segment
    )
}

fn check(name: &str, burst_us: u64, stall_us: u64, seed: u64) -> Result<(), TestCaseError> {
    let rec = Recording::read(&data(&format!("{name}.gzrec"))).expect("recording");
    let quiet = decode(&rec, chunks(&rec));
    let busy = decode(&rec, loaded(&chunks(&rec), burst_us, stall_us, seed));
    prop_assert_eq!(quiet.len(), busy.len(), "{}: samples", name);
    for (q, b) in quiet.iter().zip(&busy) {
        prop_assert_eq!(q.device_time_us, b.device_time_us, "{}: device times", name);
        prop_assert_eq!(q.time_order, b.time_order, "{}", name);
    }
    for w in busy.windows(2) {
        prop_assert!(
            w[1].mapped_time_us > w[0].mapped_time_us,
            "{}: mapped times increase",
            name
        );
        if let (Some(a), Some(b)) = (w[0].device_time_us, w[1].device_time_us) {
            let dd = b as f64 - a as f64;
            let dm = w[1].mapped_time_us as f64 - w[0].mapped_time_us as f64;
            prop_assert!(
                (dm - dd).abs() <= 100.0,
                "{}: interval {} µs on the tracker, {} mapped",
                name,
                dd,
                dm
            );
        }
    }
    let (eq, eb) = (events(&rec, &quiet), events(&rec, &busy));
    prop_assert!(!eq.is_empty(), "{}: no events", name);
    prop_assert_eq!(
        eq.iter().map(key).collect::<Vec<_>>(),
        eb.iter().map(key).collect::<Vec<_>>(),
        "{}: events",
        name
    );
    Ok(())
}

/// The worst case on every stream: 50 ms bursts, 200 ms stalls.
#[test]
fn a_loaded_host_changes_neither_device_times_nor_events() {
    for name in STREAMS {
        check(name, 50_000, 200_000, 1).unwrap_or_else(|e| panic!("{e}"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(12)))]

    /// Any delivery pattern up to the bounds.
    #[test]
    fn any_delivery_pattern_keeps_the_device_times_and_events(
        stream in 0usize..STREAMS.len(),
        burst_us in 0u64..=50_000,
        stall_us in 0u64..=200_000,
        seed in any::<u64>(),
    ) {
        check(STREAMS[stream], burst_us, stall_us, seed)?;
    }
}
