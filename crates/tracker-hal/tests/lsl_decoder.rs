//! The LSL record decoder on damaged streams: whatever is cut, flipped or
//! inserted, it never panics, every undamaged record still decodes, and
//! the bytes it skips are counted.

use proptest::prelude::*;
use tracker_hal::lsl::{
    encode_info, encode_sample, ChannelRef, EyeChannels, GazeUnits, LslConfig, LslDecoder,
    StreamHeader,
};
use tracker_hal::{decode_all, Decoder};

fn config() -> LslConfig {
    LslConfig {
        name: Some("gz".into()),
        stream_type: None,
        source_id: None,
        combined: Some(EyeChannels {
            x: ChannelRef::Label("ScreenX".into()),
            y: ChannelRef::Index(1),
            pupil: None,
        }),
        left: None,
        right: None,
        units: GazeUnits::Normalized,
        frame: None,
        confidence: None,
        device_time: None,
        silence_ms: 2000,
        resolve_timeout_ms: 5000,
    }
}

/// An info record and `n` samples; returns the bytes and each sample
/// record's (start, end).
fn stream(n: usize) -> (Vec<u8>, Vec<(usize, usize)>) {
    let mut b = encode_info(&StreamHeader {
        name: "gz".into(),
        stream_type: "Gaze".into(),
        source_id: "s".into(),
        channel_count: 2,
        labels: vec!["ScreenX".into(), "ScreenY".into()],
    });
    let mut spans = Vec::new();
    for i in 0..n {
        let start = b.len();
        b.extend(encode_sample(
            10.0 + i as f64 / 120.0,
            0.0,
            &[i as f64, 0.5],
        ));
        spans.push((start, b.len()));
    }
    (b, spans)
}

proptest! {
    #[test]
    fn damaged_streams_resynchronise(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 0..6),
        junk in proptest::collection::vec(any::<u8>(), 0..64),
        at in any::<prop::sample::Index>(),
        cut in 0usize..40,
    ) {
        let (mut b, spans) = stream(30);
        let n0 = b.len();
        let mut damaged = vec![false; spans.len()];
        for (i, x) in &flips {
            let i = i.index(b.len());
            b[i] ^= x;
            for (k, (s, e)) in spans.iter().enumerate() {
                if (*s..*e).contains(&i) {
                    damaged[k] = true;
                }
            }
        }
        let at = at.index(b.len());
        b.splice(at..at, junk.iter().copied());
        b.truncate(b.len().saturating_sub(cut));
        let mut d = LslDecoder::new(config());
        let got = decode_all(&mut d, &b, 0);
        let s = d.stats();
        prop_assert!(s.dropped_bytes <= b.len() as u64);
        prop_assert_eq!(s.bytes, b.len() as u64);
        // Every record that was neither flipped, split by the junk nor cut
        // off decodes (the x value is its index).
        let xs: Vec<f64> = got.iter().filter_map(|g| g.gaze().map(|p| p[0])).collect();
        let info_ok = !flips.iter().any(|(i, _)| i.index(n0) < spans[0].0) && at >= spans[0].0;
        for (k, (s0, e0)) in spans.iter().enumerate() {
            let split = at > *s0 && at < *e0;
            let intact = !damaged[k] && !split && *e0 + junk.len() <= b.len();
            if intact && info_ok {
                prop_assert!(xs.contains(&(k as f64)), "record {} lost", k);
            }
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let mut d = LslDecoder::new(config());
        let mut out = std::collections::VecDeque::new();
        for c in bytes.chunks(7) {
            d.push(c, 1, &mut out);
        }
        d.finish();
        prop_assert_eq!(d.stats().bytes, bytes.len() as u64);
    }
}
