//! Damaged, interrupted and extended `.gzrec` files: what the reader keeps,
//! what it skips, and that every loss is counted.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::Read;

use proptest::prelude::*;
use tracker_hal::iscan::{IscanConfig, IscanMode};
use tracker_hal::recording::{write_recording, Chunk, ChunkKind, MAGIC, MAX_PAYLOAD};
use tracker_hal::{Driver, Pacing, Recording, RecordingHeader, ReplayTransport, TrackerConfig};

/// Records the largest single allocation made by the current thread.
struct Tracking;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(layout.size())));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` above with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(new_size)));
        // SAFETY: as for `alloc` and `dealloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOC: Tracking = Tracking;

const OVERHEAD: usize = 1 + 4 + 8 + 4;
const HEADER: u8 = 1;
const D2H: u8 = 2;
const H2D: u8 = 3;
const END: u8 = 5;

fn header() -> RecordingHeader {
    RecordingHeader {
        tracker: TrackerConfig {
            driver: Driver::Iscan(IscanConfig::binocular(IscanMode::Binary)),
            mapping: Default::default(),
        },
        display: None,
        note: "faults".into(),
    }
}

/// A chunk as the format describes it, written independently of the crate.
fn chunk(kind: u8, time_us: u64, payload: &[u8]) -> Vec<u8> {
    let mut c = vec![kind];
    c.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    c.extend_from_slice(&time_us.to_le_bytes());
    c.extend_from_slice(payload);
    let crc = crc32fast::hash(&c);
    c.extend_from_slice(&crc.to_le_bytes());
    c
}

/// Magic and header chunk, as the crate's writer makes them.
fn prefix() -> Vec<u8> {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("p.gzrec");
    write_recording(&path, &header(), &[]).expect("write");
    let bytes = std::fs::read(&path).expect("read");
    // The writer ends with an empty end chunk.
    let body = bytes[..bytes.len() - OVERHEAD].to_vec();
    assert_eq!(body[..8], MAGIC);
    assert_eq!(body[8], HEADER);
    body
}

/// One chunk of a test file: its kind, time and payload.
#[derive(Debug, Clone)]
struct Spec {
    kind: u8,
    time_us: u64,
    payload: Vec<u8>,
}

/// A file from specs; returns the bytes and each chunk's byte range.
fn build(specs: &[Spec]) -> (Vec<u8>, Vec<std::ops::Range<usize>>) {
    let mut bytes = prefix();
    let mut ranges = Vec::new();
    for s in specs {
        let start = bytes.len();
        bytes.extend_from_slice(&chunk(s.kind, s.time_us, &s.payload));
        ranges.push(start..bytes.len());
    }
    (bytes, ranges)
}

fn data(n: usize) -> Vec<Spec> {
    (0..n)
        .map(|i| Spec {
            kind: D2H,
            time_us: 1000 + 10 * i as u64,
            payload: vec![i as u8; 1 + i % 7],
        })
        .collect()
}

fn end(t: u64) -> Spec {
    Spec {
        kind: END,
        time_us: t,
        payload: vec![],
    }
}

/// The device → host records the reader returns, as (time, payload).
fn records(r: &Recording) -> Vec<(u64, Vec<u8>)> {
    r.chunks
        .iter()
        .filter(|c| c.kind == ChunkKind::DeviceToHost)
        .map(|c| (c.time_us, c.payload.clone()))
        .collect()
}

/// The device → host records of the specs before the end chunk that `keep`
/// accepts.
fn expected(specs: &[Spec], keep: impl Fn(usize) -> bool) -> Vec<(u64, Vec<u8>)> {
    let mut out = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        if s.kind == END {
            break;
        }
        if s.kind == D2H && keep(i) {
            out.push((s.time_us, s.payload.clone()));
        }
    }
    out
}

/// Compares record lists with a short message (they can be long).
fn same(got: &[(u64, Vec<u8>)], want: &[(u64, Vec<u8>)]) -> Result<(), String> {
    if got == want {
        return Ok(());
    }
    let first = got
        .iter()
        .zip(want)
        .position(|(a, b)| a != b)
        .unwrap_or(got.len().min(want.len()));
    Err(format!(
        "{} records read, {} expected; first difference at record {first}",
        got.len(),
        want.len()
    ))
}

fn check(r: &Recording, want: &[(u64, Vec<u8>)], context: &str) {
    if let Err(e) = same(&records(r), want) {
        panic!("{context}: {e}");
    }
}

#[test]
fn an_empty_device_chunk_does_not_end_the_replay() {
    let mut specs = data(6);
    specs.insert(
        3,
        Spec {
            kind: D2H,
            time_us: 1025,
            payload: vec![],
        },
    );
    specs.push(end(2000));
    let (bytes, _) = build(&specs);
    let r = Recording::parse(&bytes).expect("parse");
    let mut replayed = Vec::new();
    ReplayTransport::from_recording(&r, Pacing::AsFastAsPossible)
        .read_to_end(&mut replayed)
        .expect("replay");
    let all: Vec<u8> = specs.iter().flat_map(|s| s.payload.clone()).collect();
    assert_eq!(replayed, all, "the replay stopped at the empty chunk");
    // The empty chunk is valid: kept, counted, nothing to report.
    check(&r, &expected(&specs, |_| true), "empty chunk");
    assert_eq!(r.summary().device_chunks, 7);
    assert!(r.summary().is_clean() && r.warnings().is_empty());
}

#[test]
fn a_flipped_bit_loses_only_its_chunk() {
    let mut specs = data(600);
    specs.push(end(9000));
    let (clean, ranges) = build(&specs);
    for (victim, at) in [(154usize, 13usize), (300, 0), (0, 5), (599, 16)] {
        let mut bytes = clean.clone();
        bytes[ranges[victim].start + at] ^= 0x10;
        let r = Recording::parse(&bytes).expect("header intact");
        let context = format!("flip in chunk {victim} at +{at}");
        check(&r, &expected(&specs, |i| i != victim), &context);
        assert!(r.closed && r.torn_tail.is_none(), "{context}");
        let s = r.summary();
        assert_eq!(s.damaged_regions, 1, "{context}");
        assert_eq!(s.bytes_skipped, ranges[victim].len() as u64, "{context}");
        assert_eq!(
            r.damaged[0].offset, ranges[victim].start as u64,
            "{context}"
        );
        assert!(!s.is_clean());
        let w = r.warnings();
        assert!(
            w.len() == 1 && w[0].contains("bytes skipped"),
            "{context}: {w:?}"
        );
    }
}

#[test]
fn a_flipped_length_loses_only_its_chunk() {
    let mut specs = data(600);
    specs.push(end(9000));
    let (clean, ranges) = build(&specs);
    for bit in [0u8, 3, 7] {
        for byte in 1..5 {
            let mut bytes = clean.clone();
            bytes[ranges[1].start + byte] ^= 1 << bit;
            let r = Recording::parse(&bytes).expect("header intact");
            let context = format!("length byte {byte} bit {bit}");
            check(&r, &expected(&specs, |i| i != 1), &context);
            assert_eq!(
                r.summary().bytes_skipped,
                ranges[1].len() as u64,
                "{context}"
            );
        }
    }
}

#[test]
fn an_unknown_chunk_kind_is_skipped() {
    let mut specs = data(10);
    for (at, kind) in [(2, 9u8), (6, 200), (8, 0)] {
        specs.insert(
            at,
            Spec {
                kind,
                time_us: 1,
                payload: vec![kind; 40],
            },
        );
    }
    specs.push(end(9000));
    let (bytes, _) = build(&specs);
    let r = Recording::parse(&bytes).expect("parse");
    check(&r, &expected(&specs, |_| true), "unknown kinds");
    assert!(r.closed);
    let s = r.summary();
    assert_eq!(
        (s.unknown_chunks, s.unknown_bytes),
        (3, 3 * (OVERHEAD as u64 + 40))
    );
    assert_eq!(s.damaged_regions, 0);
    let w = r.warnings();
    assert!(w.len() == 1 && w[0].contains("unknown kind"), "{w:?}");
}

#[test]
fn chunks_after_the_end_are_reported_not_decoded() {
    let mut specs = data(5);
    specs.push(end(5000));
    specs.extend(data(3));
    let (mut bytes, ranges) = build(&specs);
    bytes.extend_from_slice(b"garbage");
    let r = Recording::parse(&bytes).expect("parse");
    check(&r, &expected(&specs, |_| true), "after the end");
    assert!(r.closed);
    let a = r.after_end.expect("reported");
    assert_eq!(a.offset, ranges[5].end as u64);
    assert_eq!(a.bytes, (bytes.len() - ranges[5].end) as u64);
    assert_eq!(a.chunks, 3);
    let s = r.summary();
    assert_eq!((s.after_end_bytes, s.after_end_chunks), (a.bytes, 3));
    assert!(!s.is_clean());
    let w = r.warnings();
    assert!(
        w.len() == 1 && w[0].contains("after the end chunk"),
        "{w:?}"
    );
}

#[test]
fn an_interrupted_recording_says_how_much_it_holds() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("r.gzrec");
    let chunks: Vec<Chunk> = (0..600u64)
        .map(|i| Chunk {
            kind: ChunkKind::DeviceToHost,
            time_us: 1_000_000 + 10_000 * i,
            payload: vec![i as u8; 4],
        })
        .collect();
    write_recording(&path, &header(), &chunks).expect("write");
    let full = std::fs::read(&path).expect("read");
    let r = Recording::parse(&full).expect("parse");
    assert!(r.closed && r.summary().is_clean() && r.warnings().is_empty());

    // Killed between two chunks: no end chunk, nothing damaged.
    let killed = &full[..full.len() - OVERHEAD];
    let r = Recording::parse(killed).expect("parse");
    let s = r.summary();
    assert!(!s.closed && !s.is_clean());
    assert_eq!((s.device_chunks, s.duration_us), (600, 5_990_000));
    assert_eq!(r.last_time_us, Some(1_000_000 + 10_000 * 599));
    assert_eq!(
        r.warnings(),
        vec!["not closed: 600 records up to t = 5.990 s (no end chunk: the recorder was interrupted)"]
    );

    // Killed in the middle of a chunk: the torn tail too.
    let torn = &full[..full.len() - OVERHEAD - 10];
    let r = Recording::parse(torn).expect("parse");
    let s = r.summary();
    assert_eq!(
        (s.device_chunks, s.bytes_skipped),
        (599, (OVERHEAD + 4 - 10) as u64)
    );
    let tail = r.torn_tail.clone().expect("torn tail");
    assert_eq!(tail.offset + tail.bytes, torn.len() as u64);
    let w = r.warnings();
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w[0].contains("ends early"), "{w:?}");
    assert!(
        w[1].starts_with("not closed: 599 records up to t = 5.980 s"),
        "{w:?}"
    );
}

#[test]
fn a_host_chunk_and_the_header_survive_a_damaged_neighbour() {
    let mut specs = data(4);
    specs.insert(
        1,
        Spec {
            kind: H2D,
            time_us: 1001,
            payload: vec![0x84],
        },
    );
    specs.push(end(5000));
    let (mut bytes, ranges) = build(&specs);
    bytes[ranges[0].start + 14] ^= 1;
    let r = Recording::parse(&bytes).expect("parse");
    assert_eq!(r.header, header());
    assert!(r
        .chunks
        .iter()
        .any(|c| c.kind == ChunkKind::HostToDevice && c.payload == [0x84]));
    assert_eq!(r.summary().host_chunks, 1);
}

#[test]
fn a_damaged_header_is_an_error() {
    let (clean, _) = build(&[end(1)]);
    let mut bytes = clean.clone();
    bytes[8 + 20] ^= 1;
    assert!(Recording::parse(&bytes).is_err());
}

#[test]
fn cutting_inside_the_magic_or_header_is_an_error() {
    let (bytes, _) = build(&[end(1)]);
    let body = prefix().len();
    for cut in 0..body {
        assert!(Recording::parse(&bytes[..cut]).is_err(), "cut at {cut}");
    }
}

#[test]
fn a_corrupt_length_never_reaches_an_allocation() {
    let mut specs = data(20);
    specs.push(end(9000));
    let (clean, ranges) = build(&specs);
    for len in [u32::MAX, 1 << 31, 1 << 24, MAX_PAYLOAD as u32 + 1, 5000] {
        let mut bytes = clean.clone();
        bytes[ranges[3].start + 1..ranges[3].start + 5].copy_from_slice(&len.to_le_bytes());
        LARGEST.with(|l| l.set(0));
        let r = Recording::parse(&bytes).expect("header intact");
        let largest = LARGEST.with(|l| l.get());
        assert!(
            largest <= 4 * bytes.len(),
            "length {len}: an allocation of {largest} bytes for a {}-byte file",
            bytes.len()
        );
        check(&r, &expected(&specs, |i| i != 3), &format!("length {len}"));
        assert_eq!(r.summary().bytes_skipped, ranges[3].len() as u64);
    }
}

/// Random chunk sequences: mostly data, some host, unknown kinds (0 and
/// 6..=255) and empty chunks.
fn specs_strategy() -> impl Strategy<Value = Vec<Spec>> {
    let one = (
        prop_oneof![6 => Just(D2H), 1 => Just(H2D), 1 => 6u8..=255, 1 => Just(0u8)],
        0u64..1_000_000,
        prop_oneof![1 => Just(vec![]), 4 => prop::collection::vec(any::<u8>(), 1..40)],
    )
        .prop_map(|(kind, time_us, payload)| Spec {
            kind,
            time_us,
            payload,
        });
    prop::collection::vec(one, 0..25)
}

fn is_unknown(kind: u8) -> bool {
    !(1..=5).contains(&kind)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(256)))]

    #[test]
    fn bit_flips_lose_only_the_chunks_they_hit(
        specs in specs_strategy(),
        flips in prop::collection::vec((any::<prop::sample::Index>(), 0u8..8), 0..4),
        closed in any::<bool>(),
    ) {
        let mut specs = specs;
        if closed {
            specs.push(end(2_000_000));
        }
        let (clean, ranges) = build(&specs);
        let mut bytes = clean.clone();
        let body = prefix().len();
        if bytes.len() > body {
            for (idx, bit) in &flips {
                let at = body + idx.index(clean.len() - body);
                bytes[at] ^= 1 << bit;
            }
        }
        // Two flips of one bit cancel: a chunk is hit when its bytes differ.
        let hit: Vec<bool> = ranges.iter().map(|r| bytes[r.clone()] != clean[r.clone()]).collect();
        let r = Recording::parse(&bytes).expect("header intact");
        let got = same(&records(&r), &expected(&specs, |i| !hit[i]));
        prop_assert!(got.is_ok(), "{}", got.unwrap_err());
        let s = r.summary();
        // Every hit chunk lies inside a counted damaged region; nothing else does.
        for (i, range) in ranges.iter().enumerate() {
            let inside = r.damaged.iter().any(|d| {
                d.offset <= range.start as u64 && range.end as u64 <= d.offset + d.bytes
            });
            prop_assert_eq!(inside, hit[i], "chunk {}", i);
        }
        let hit_bytes: usize = ranges.iter().zip(&hit).filter(|(_, h)| **h).map(|(r, _)| r.len()).sum();
        prop_assert_eq!(s.bytes_skipped, hit_bytes as u64);
        prop_assert_eq!(s.bytes_skipped > 0, hit.iter().any(|h| *h));
        let unknown = specs.iter().zip(&hit).filter(|(sp, h)| is_unknown(sp.kind) && !**h).count();
        prop_assert_eq!(s.unknown_chunks, unknown as u64);
        let end_intact = closed && !hit[specs.len() - 1];
        prop_assert_eq!(s.closed, end_intact);
        prop_assert_eq!(s.is_clean(), end_intact && s.bytes_skipped == 0 && unknown == 0);
        prop_assert!(r.after_end.is_none());
    }

    #[test]
    fn a_file_cut_anywhere_keeps_every_whole_chunk(specs in specs_strategy()) {
        let mut specs = specs;
        specs.push(end(2_000_000));
        let (bytes, ranges) = build(&specs);
        let body = prefix().len();
        for cut in body..=bytes.len() {
            let r = Recording::parse(&bytes[..cut]).expect("header intact");
            let whole = |i: usize| ranges[i].end <= cut;
            let got = same(&records(&r), &expected(&specs, whole));
            prop_assert!(got.is_ok(), "cut at {}: {}", cut, got.unwrap_err());
            prop_assert_eq!(r.closed, cut == bytes.len());
            // The cut chunk's bytes, if any, are the torn tail.
            let boundary = ranges.iter().map(|r| r.end).filter(|e| *e <= cut).max().unwrap_or(body);
            let s = r.summary();
            prop_assert_eq!(s.bytes_skipped, (cut - boundary) as u64, "cut at {}", cut);
            prop_assert_eq!(r.torn_tail.is_some(), cut > boundary);
            prop_assert_eq!(
                r.warnings().iter().any(|w| w.starts_with("not closed: ")),
                cut < bytes.len()
            );
        }
    }

    #[test]
    fn garbage_between_chunks_is_skipped_and_counted(
        specs in specs_strategy(),
        garbage in prop::collection::vec((any::<prop::sample::Index>(), prop::collection::vec(any::<u8>(), 1..64)), 0..4),
    ) {
        let mut specs = specs;
        specs.push(end(2_000_000));
        let mut bytes = prefix();
        let mut inserted = 0usize;
        let n = specs.len();
        let mut at: Vec<Option<&Vec<u8>>> = vec![None; n];
        for (idx, g) in &garbage {
            at[idx.index(n)] = Some(g);
        }
        for (s, g) in specs.iter().zip(&at) {
            if let Some(g) = g {
                bytes.extend_from_slice(g);
                inserted += g.len();
            }
            bytes.extend_from_slice(&chunk(s.kind, s.time_us, &s.payload));
        }
        let r = Recording::parse(&bytes).expect("header intact");
        let got = same(&records(&r), &expected(&specs, |_| true));
        prop_assert!(got.is_ok(), "{}", got.unwrap_err());
        prop_assert!(r.closed);
        prop_assert_eq!(r.summary().bytes_skipped, inserted as u64);
    }
}
