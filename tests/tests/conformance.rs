//! Driver conformance suite: one set of checks, run against every driver
//! through replay of the (synthesised) recorded streams in `tests/data`.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use tracker_hal::csv::{csv_row, CSV_HEADER};
use tracker_hal::iscan::{IscanConfig, IscanDecoder, IscanMode};
use tracker_hal::mouse::MouseDecoder;
use tracker_hal::{
    decode_all, Decoder, GazeSample, GazeSource, Pacing, Recording, ReplayTransport, StreamDriver,
    TrackerConfig,
};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

/// A recorded stream with the samples it must decode to.
struct Stream {
    name: &'static str,
    recording: Recording,
    expected_csv: String,
}

fn streams() -> Vec<Stream> {
    [
        "iscan-binary-60hz",
        "iscan-ascii-60hz",
        "iscan-binary-240hz",
        "mouse-120hz",
        "tobii-hid-50hz",
        "tobii-hid-compact-120hz",
    ]
    .into_iter()
    .map(|name| Stream {
        name,
        recording: Recording::read(&data(&format!("{name}.gzrec")))
            .unwrap_or_else(|e| panic!("{e}")),
        expected_csv: std::fs::read_to_string(data(&format!("{name}.csv")))
            .unwrap_or_else(|e| panic!("{name}: {e}")),
    })
    .collect()
}

fn tracker(s: &Stream) -> &TrackerConfig {
    &s.recording.header.tracker
}

fn driver(s: &Stream) -> StreamDriver<ReplayTransport, Box<dyn Decoder>> {
    let t = ReplayTransport::from_recording(&s.recording, Pacing::AsFastAsPossible);
    let clock = t.clock();
    StreamDriver::new(t, tracker(s).decoder(), Box::new(clock))
}

fn decode(s: &Stream) -> Vec<GazeSample> {
    let mut d = driver(s);
    let mut out = Vec::new();
    while let Some(x) = d
        .next_sample()
        .unwrap_or_else(|e| panic!("{}: {e}", s.name))
    {
        out.push(x);
    }
    out
}

/// All device bytes of a stream, concatenated.
fn bytes(s: &Stream) -> Vec<u8> {
    s.recording
        .device_chunks()
        .flat_map(|c| c.payload.iter().copied())
        .collect()
}

#[test]
fn every_stream_is_marked_synthesised_and_closed_cleanly() {
    for s in streams() {
        assert!(
            s.recording.header.note.contains("SYNTHESISED"),
            "{}",
            s.name
        );
        assert!(
            s.recording.closed && s.recording.torn_tail.is_none(),
            "{}",
            s.name
        );
    }
}

#[test]
fn decoded_samples_equal_the_expected_csv() {
    for s in streams() {
        let got: Vec<String> = std::iter::once(CSV_HEADER.to_string())
            .chain(decode(&s).iter().map(|x| csv_row(x, &|p| Some(p))))
            .collect();
        let want: Vec<&str> = s.expected_csv.lines().collect();
        assert_eq!(got.len(), want.len(), "{}: record count", s.name);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "{}: line {}", s.name, i + 1);
        }
    }
}

#[test]
fn start_and_stop_bytes_are_sent() {
    for s in streams() {
        let mut d = driver(&s);
        d.start().expect("start");
        d.stop().expect("stop");
        let dec = tracker(&s).decoder();
        let mut want = dec.start_command();
        want.extend(dec.stop_command());
        assert!(
            !want.is_empty(),
            "{}: a driver must have start/stop bytes",
            s.name
        );
        assert_eq!(d.transport_mut().written(), &want[..], "{}", s.name);
    }
}

#[test]
fn sequence_and_both_timestamps_are_monotonic() {
    for s in streams() {
        let samples = decode(&s);
        assert!(!samples.is_empty());
        for w in samples.windows(2) {
            assert_eq!(w[1].seq, w[0].seq + 1, "{}", s.name);
            assert!(
                w[1].host_time_us >= w[0].host_time_us,
                "{}: host time went back at {}",
                s.name,
                w[1].seq
            );
            let (a, b) = (
                w[0].device_time_us.expect("device time"),
                w[1].device_time_us.expect("device time"),
            );
            assert!(
                b > a,
                "{}: device time not increasing at {}",
                s.name,
                w[1].seq
            );
        }
    }
}

#[test]
fn invalid_eyes_are_flagged_and_carry_no_coordinates() {
    for s in streams() {
        let samples = decode(&s);
        let missing = samples
            .iter()
            .filter(|x| !x.left.valid() || !x.right.valid())
            .count();
        assert!(
            missing > 0,
            "{}: the stream has blinks, some eyes must be missing",
            s.name
        );
        for x in &samples {
            for eye in [x.left, x.right] {
                assert_eq!(eye.valid(), eye.position.is_some());
                if !eye.valid() {
                    assert_eq!(eye.pupil, None);
                }
            }
        }
        if s.name.starts_with("iscan") {
            // The ISCAN streams also lose one eye at times.
            assert!(
                samples.iter().any(|x| x.left.valid() != x.right.valid()),
                "{}",
                s.name
            );
        }
    }
}

#[test]
fn clean_streams_end_cleanly_at_eof_with_nothing_dropped() {
    for s in streams() {
        let mut d = driver(&s);
        while d.next_sample().expect("decodes").is_some() {}
        assert_eq!(
            d.next_sample().expect("still fine"),
            None,
            "{}: EOF must stay EOF",
            s.name
        );
        let st = d.stats();
        assert_eq!((st.dropped_bytes, st.resyncs), (0, 0), "{}", s.name);
        assert_eq!(st.bytes, bytes(&s).len() as u64);
    }
}

/// Decodes `bytes` with the stream's decoder in reads of `read_len` bytes.
fn decode_bytes(
    s: &Stream,
    bytes: &[u8],
    read_len: usize,
) -> (Vec<GazeSample>, tracker_hal::DecodeStats) {
    let mut d = tracker(s).decoder();
    let mut out = std::collections::VecDeque::new();
    for (i, c) in bytes.chunks(read_len.max(1)).enumerate() {
        d.push(c, i as u64, &mut out);
    }
    d.finish();
    (out.into(), d.stats())
}

/// How many expected samples reappear, in order, in `got` (by position).
fn recovered(expected: &[GazeSample], got: &[GazeSample]) -> usize {
    let key = |s: &GazeSample| (s.left.position, s.right.position, s.combined);
    let mut i = 0;
    let mut n = 0;
    for g in got {
        // A damaged record matches nothing nearby: skip it without moving on.
        // (Only a short window is searched: a damaged record that decodes as
        // "both eyes missing" must not match the next blink far ahead.)
        let window = &expected[i..(i + 8).min(expected.len())];
        if let Some(k) = window.iter().position(|e| key(e) == key(g)) {
            n += 1;
            i += k + 1;
        }
    }
    n
}

#[test]
fn decoders_resync_after_garbage_truncation_and_bit_flips() {
    for s in streams() {
        let clean = bytes(&s);
        let (expected, _) = decode_bytes(&s, &clean, 4096);
        let n = expected.len();
        let mut rng = 0x2545_F491_4F6C_DD1Du64;
        let mut next = |m: usize| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % m as u64) as usize
        };
        // 20 damaged places of each kind. A HID report log is not
        // self-describing: its reports can only be read with the descriptor
        // line, so damage there costs the whole connection (tested on its
        // own below); here the descriptor lines are spared.
        let hid = s.name.starts_with("tobii-hid");
        let spot = |next: &mut dyn FnMut(usize) -> usize, buf: &[u8], len: usize| loop {
            let at = next(buf.len() - len);
            if !(hid && touches_descriptor(buf, at, at + len)) {
                break at;
            }
        };
        let mut garbage = clean.clone();
        for _ in 0..20 {
            let at = spot(&mut next, &garbage, 1);
            let junk: Vec<u8> = (0..1 + next(30)).map(|_| next(256) as u8).collect();
            garbage.splice(at..at, junk);
        }
        let mut truncated = clean.clone();
        for _ in 0..20 {
            let at = spot(&mut next, &truncated, 8);
            truncated.drain(at..at + 1 + next(6));
        }
        let mut flipped = clean.clone();
        for _ in 0..20 {
            let at = spot(&mut next, &flipped, 1);
            flipped[at] ^= 1 << next(8);
        }
        for (kind, damaged) in [
            ("garbage", &garbage),
            ("truncation", &truncated),
            ("bit flips", &flipped),
        ] {
            let (got, st) = decode_bytes(&s, damaged, 64);
            assert!(
                st.dropped_bytes > 0 || st.invalid_values > 0 || got.len() != n,
                "{} {kind}: damage went unnoticed",
                s.name
            );
            // Each damaged place may cost a few records, never the stream.
            let back = recovered(&expected, &got);
            assert!(
                back + 20 * 3 >= n,
                "{} {kind}: only {back} of {n} records recovered",
                s.name
            );
            assert!(
                st.records == got.len() as u64 && st.dropped_bytes <= st.bytes,
                "{} {kind}: {st:?}",
                s.name
            );
        }
    }
}

/// Whether `buf[from..=to]` touches a `# descriptor` line (or its newline).
fn touches_descriptor(buf: &[u8], from: usize, to: usize) -> bool {
    (from..=to.min(buf.len().saturating_sub(1))).any(|i| {
        let start = buf[..i]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1);
        let next_line = buf[i..].iter().position(|&b| b == b'\n').map(|p| i + p + 1);
        buf[start..].starts_with(b"# descriptor")
            || next_line.is_some_and(|n| buf[n..].starts_with(b"# descriptor"))
    })
}

#[test]
fn a_damaged_hid_descriptor_costs_its_connection_only() {
    for s in streams().iter().filter(|s| s.name.starts_with("tobii-hid")) {
        let clean = bytes(s);
        let (expected, _) = decode_bytes(s, &clean, 4096);
        // Cut two bytes out of the first descriptor line.
        let mut cut = clean.clone();
        cut.drain(40..42);
        let (got, st) = decode_bytes(s, &cut, 64);
        assert!(st.resyncs > 0 && st.dropped_bytes > 0, "{}: {st:?}", s.name);
        // The second connection (after the reconnect) decodes in full.
        let text = String::from_utf8_lossy(&clean);
        let second = text.match_indices("# descriptor").nth(1).map(|(i, _)| i);
        let before = second.map_or(0, |i| {
            text[..i].lines().filter(|l| !l.starts_with('#')).count()
        });
        assert!(
            !got.is_empty() && got.len() == expected.len() - before,
            "{}",
            s.name
        );
        for (g, e) in got.iter().zip(&expected[before..]) {
            assert_eq!(
                (g.combined, g.device_time_us),
                (e.combined, e.device_time_us)
            );
        }
    }
}

fn decoders() -> Vec<(&'static str, Box<dyn Decoder>)> {
    vec![
        (
            "iscan-binary",
            Box::new(IscanDecoder::new(IscanConfig::binocular(IscanMode::Binary))),
        ),
        (
            "iscan-ascii",
            Box::new(IscanDecoder::new(IscanConfig::binocular(IscanMode::Ascii))),
        ),
        ("mouse", Box::new(MouseDecoder::new())),
        ("hid-log", Box::new(tracker_hal::hid::HidLogDecoder::new())),
    ]
}

/// The invariants every decoder keeps on any input.
fn check_invariants(
    name: &str,
    d: &mut Box<dyn Decoder>,
    input: &[u8],
    split: usize,
) -> Result<(), TestCaseError> {
    let mut out = std::collections::VecDeque::new();
    for (i, c) in input.chunks(split.max(1)).enumerate() {
        d.push(c, i as u64, &mut out);
    }
    d.finish();
    let st = d.stats();
    prop_assert_eq!(st.bytes, input.len() as u64, "{}", name);
    prop_assert_eq!(st.records, out.len() as u64, "{}", name);
    prop_assert!(st.dropped_bytes <= st.bytes, "{}", name);
    for (k, s) in out.iter().enumerate() {
        prop_assert_eq!(s.seq, k as u64);
        for eye in [s.left, s.right] {
            if let Some([x, y]) = eye.position {
                prop_assert!(
                    x.is_finite() && y.is_finite(),
                    "{}: non-finite coordinate",
                    name
                );
            }
        }
    }
    Ok(())
}

proptest! {
    // 34 000 random streams per decoder (136 000 cases) plus the 4 000
    // mutated real streams below: over 100 000 cases in a few seconds.
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(34_000), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn iscan_binary_never_panics_on_random_bytes(input in prop::collection::vec(any::<u8>(), 0..160), split in 1usize..40) {
        let (name, mut d) = decoders().swap_remove(0);
        check_invariants(name, &mut d, &input, split)?;
    }

    #[test]
    fn iscan_ascii_never_panics_on_random_bytes(input in prop::collection::vec(any::<u8>(), 0..160), split in 1usize..40) {
        let (name, mut d) = decoders().swap_remove(1);
        check_invariants(name, &mut d, &input, split)?;
    }

    #[test]
    fn mouse_never_panics_on_random_bytes(input in prop::collection::vec(any::<u8>(), 0..160), split in 1usize..40) {
        let (name, mut d) = decoders().swap_remove(2);
        check_invariants(name, &mut d, &input, split)?;
    }

    /// Random text of the hid-log alphabet: hex digits, spaces, newlines, `#`.
    #[test]
    fn hid_log_never_panics_on_random_lines(
        input in prop::collection::vec(prop::sample::select(b"0123456789abcdef #\n descriptorfeaturecontrol".to_vec()), 0..400),
        split in 1usize..40,
    ) {
        let (name, mut d) = decoders().swap_remove(3);
        check_invariants(name, &mut d, &input, split)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(4_000), failure_persistence: None, ..ProptestConfig::default() })]

    /// Real records with random damage: still no panic, invariants hold.
    #[test]
    fn decoders_never_panic_on_mutated_streams(
        which in 0usize..6,
        start in 0usize..2000,
        edits in prop::collection::vec((0usize..400, any::<u8>(), 0u8..3), 0..12),
        split in 1usize..64,
    ) {
        let all = streams();
        let s = &all[which];
        let clean = bytes(s);
        let from = start.min(clean.len().saturating_sub(1));
        let mut input = clean[from..(from + 400).min(clean.len())].to_vec();
        for (at, byte, op) in edits {
            let at = at.min(input.len());
            match op {
                0 => input.insert(at, byte),
                1 if at < input.len() => { input.remove(at); }
                _ if at < input.len() => input[at] ^= byte,
                _ => {}
            }
        }
        let mut d = tracker(s).decoder();
        check_invariants(s.name, &mut d, &input, split)?;
    }
}

#[test]
fn a_decoder_fed_twice_the_same_records_gives_them_twice() {
    // decode_all is the transport-free path the fuzz target uses.
    let s = &streams()[0];
    let b = bytes(s);
    let mut twice = b.clone();
    twice.extend(&b);
    let one = decode_all(&mut tracker(s).decoder(), &b, 0);
    let two = decode_all(&mut tracker(s).decoder(), &twice, 0);
    assert_eq!(two.len(), 2 * one.len());
}

#[test]
fn hid_streams_show_blinks_one_eye_loss_and_a_reconnect() {
    for s in streams().iter().filter(|s| s.name.starts_with("tobii-hid")) {
        let mut d = tracker_hal::hid::HidLogDecoder::new();
        let samples = decode_all(&mut d, &bytes(s), 0);
        assert_eq!(d.connections(), 2, "{}: one reconnect", s.name);
        assert!(d.gaps() > 0, "{}: blinks are gaps in the reports", s.name);
        let info = d.info();
        assert_eq!(info.screen_um, Some((337_900.0, 270_300.0)), "{}", s.name);
        assert!(samples.iter().all(|x| x.combined.is_some()), "{}", s.name);
        assert!(
            samples
                .iter()
                .any(|x| x.eye_position_um[0].is_some() && x.eye_position_um[1].is_none()),
            "{}: the right eye is lost at times",
            s.name
        );
        // The gaze is in µm on the display.
        for x in &samples {
            let [gx, gy] = x.combined.expect("valid");
            assert!((0.0..=337_900.0).contains(&gx) && (0.0..=270_300.0).contains(&gy));
        }
    }
}
