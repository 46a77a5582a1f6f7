//! Conformance of the HID eye-tracker driver with real descriptor shapes
//! (issue 29): one test per shape through the path the driver uses (parse
//! the descriptor → locate the reports → decode a report), and the same
//! shapes through the live driver flow and the `replay --format hid-log`
//! path (a hid-log byte stream into the stream driver).
//!
//! The descriptors are Microsoft's virtual eye-gaze HID device (DMF module
//! `VirtualEyeGaze`, github.com/microsoft/DMF), kept in the simulator
//! ([`tracker_hal::hid::sim`]), which emits them:
//!
//! - [`DMF_NAMED`]: `Dmf/Modules.Library/Dmf_VirtualEyeGaze.c` at
//!   bfac434fd3497259095a1f8d70ed734493228091 (2025): every logical
//!   collection named by its usage, Unit and Unit Exponent items (µs, µm),
//!   positions in ±2,000,000, head position and head direction, Status as a
//!   feature and as an input report, Mode Request 0..7.
//! - [`DMF_UNNAMED`]: `Dmf/Modules.Template/Dmf_VirtualEyeGaze.c` at
//!   f2ff922ed7778dfa0de19ac2cb2e4c15190f4a91 (2020): logical collections
//!   *without* usages (`A1 02` with no `09 xx` before it), no units, three
//!   reserved bytes, the timestamp as eight one-byte fields, positions with
//!   Logical Minimum 0x80000000, Mode Request 0..1. Encoded as the source
//!   declares it: the item macros of that commit shifted left instead of
//!   right (`(v << 8) & 0xFF`) and gave `LOGICAL_MAXIMUM_DWORD` the minimum's
//!   tag, which DMF later corrected; the bytes below are the corrected
//!   encoding of the same declarations.
//!
//! Reports are packed here by hand from the C structures of the same files
//! (`GAZE_REPORT`, `CONFIGURATION_REPORT`, …), not with the crate's own
//! writer, so a wrong field position cannot cancel out.

use tracker_hal::hid::driver::{HidDriver, HidLogTransport};
use tracker_hal::hid::sim::{DMF_NAMED, DMF_UNNAMED};
use tracker_hal::hid::{HidConfig, HidLogDecoder, TrackerLayout};
use tracker_hal::{Decoder, GazeSource, Pacing, ReplayTransport, SharedClock, StreamDriver};

fn le32(out: &mut Vec<u8>, v: i32) {
    out.extend(v.to_le_bytes());
}

/// `GAZE_REPORT` of either file, report ID first.
fn gaze_report(unnamed: bool, ts: u64, gaze: [i32; 2], left: [i32; 3], right: [i32; 3]) -> Vec<u8> {
    let mut r = vec![0x10];
    if unnamed {
        r.extend([0, 0, 0]); // Reserved[3]
    }
    r.extend(ts.to_le_bytes());
    for v in gaze.into_iter().chain(left).chain(right) {
        le32(&mut r, v);
    }
    if !unnamed {
        for v in [0, 20_000, 620_000, 0, 0, 0] {
            le32(&mut r, v); // head position, head direction
        }
    }
    r
}

/// Capabilities, Configuration and Status feature reports, ID first.
fn features(unnamed: bool, screen_um: (i32, i32), hz: u16) -> Vec<Vec<u8>> {
    let mut caps = vec![0x11, 1];
    for v in [450_000, 600_000, 800_000, 600_000, 340_000] {
        le32(&mut caps, v);
    }
    let mut config = vec![0x12];
    if unnamed {
        config.push(0); // Reserved
    }
    config.extend(0x4C2Du16.to_le_bytes());
    config.extend(0x1234u16.to_le_bytes());
    config.extend(777u32.to_le_bytes());
    config.extend(0x2011u16.to_le_bytes());
    le32(&mut config, screen_um.0);
    le32(&mut config, screen_um.1);
    let mut status = vec![0x13];
    if unnamed {
        status.push(0); // Reserved
    }
    status.push(1); // Ready
    status.extend(hz.to_le_bytes());
    vec![caps, config, status]
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

const SCREEN: (i32, i32) = (344_000, 193_000);
const TS: u64 = 0x0102_0304_0506_0708;

/// A hid-log of one connection: descriptor, features, `n` gaze reports.
fn hid_log(descriptor: &[u8], unnamed: bool, n: u64) -> String {
    let mut s = format!("# descriptor {}\n", hex(descriptor));
    for f in features(unnamed, SCREEN, 60) {
        s += &format!("# feature {}\n", hex(&f));
    }
    for k in 0..n {
        let r = gaze_report(
            unnamed,
            TS + k * 16_667,
            [172_000 + k as i32, 96_500],
            [-32_000, 12_000, 600_000],
            [32_000, 12_000, 600_000],
        );
        s += &format!("{} {}\n", 1_000 + k * 16_667, hex(&r));
    }
    s
}

fn shapes() -> [(&'static str, &'static [u8], bool); 2] {
    [("named", DMF_NAMED, false), ("unnamed", DMF_UNNAMED, true)]
}

/// Parse → locate → decode, as the driver does, for one shape.
fn check_layout(name: &str, descriptor: &[u8], unnamed: bool) {
    let l = TrackerLayout::from_descriptor(descriptor).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(l.tracking_report_id, 0x10, "{name}");
    let ts = l
        .timestamp
        .as_ref()
        .unwrap_or_else(|| panic!("{name}: timestamp"));
    assert_eq!(ts.bits(), 64, "{name}: eight one-byte fields, one value");
    assert_eq!(l.feature_ids(), vec![0x11, 0x12, 0x13], "{name}");
    assert_eq!(l.capabilities.len(), 6, "{name}: capabilities");
    assert_eq!(l.configuration.len(), 2, "{name}: configuration");
    assert_eq!(l.status.len(), 2, "{name}: status");
    assert!(l.mode_request.is_some(), "{name}: mode request");
    let r = gaze_report(
        unnamed,
        TS,
        [-5, 1_999_999],
        [-32_000, 12_000, 600_000],
        [32_000, 12_000, 600_000],
    );
    let t = l
        .tracking(&r[1..])
        .unwrap_or_else(|| panic!("{name}: decodes"));
    assert_eq!(t.timestamp_us, Some(TS), "{name}: little-endian, in order");
    assert_eq!(t.gaze_um, Some([-5.0, 1_999_999.0]), "{name}");
    assert_eq!(
        t.left_eye_um,
        Some([-32_000.0, 12_000.0, 600_000.0]),
        "{name}"
    );
    assert_eq!(
        t.right_eye_um,
        Some([32_000.0, 12_000.0, 600_000.0]),
        "{name}"
    );
    assert_eq!(l.head.is_some(), !unnamed, "{name}: head position");
    let mut info = tracker_hal::hid::DeviceInfo::default();
    for f in features(unnamed, SCREEN, 60) {
        for list in [&l.capabilities, &l.configuration, &l.status] {
            info.apply(&TrackerLayout::values(list, f[0], &f[1..]));
        }
    }
    assert_eq!(
        info.screen_um,
        Some((f64::from(SCREEN.0), f64::from(SCREEN.1))),
        "{name}: calibrated screen size"
    );
    assert_eq!(info.sampling_hz, Some(60.0), "{name}");
    assert_eq!(
        info.tracking_distance_um,
        Some((450_000.0, 600_000.0, 800_000.0)),
        "{name}"
    );
}

#[test]
fn named_collections_with_units_decode() {
    check_layout("named", DMF_NAMED, false);
}

#[test]
fn unnamed_collections_without_units_decode() {
    check_layout("unnamed", DMF_UNNAMED, true);
}

#[test]
fn eight_one_byte_timestamp_fields_and_logical_minimum_0x80000000() {
    let l = TrackerLayout::from_descriptor(DMF_UNNAMED).expect("parses");
    let gx = l
        .descriptor
        .fields
        .iter()
        .find(|f| f.usage == 0x21 && f.kind == tracker_hal::hid::descriptor::ReportKind::Input)
        .expect("gaze X");
    assert_eq!(
        (gx.logical_min, gx.logical_max, gx.bit_offset, gx.bit_size),
        (i64::from(i32::MIN), i64::from(i32::MAX), 88, 32),
        "0x80000000 is HID's signed i32::MIN; gaze X after 3 reserved + 8 timestamp bytes"
    );
    let stamps: Vec<_> = l
        .descriptor
        .fields
        .iter()
        .filter(|f| f.usage == 0x20)
        .map(|f| (f.bit_offset, f.bit_size, f.logical_min, f.logical_max))
        .collect();
    assert_eq!(
        stamps,
        (0..8).map(|k| (24 + 8 * k, 8, 0, 255)).collect::<Vec<_>>(),
        "Logical Maximum 0xFF in one byte is 255 here, not -1"
    );
    for (ts, gaze) in [
        (u64::MAX, [i32::MIN, i32::MAX]),
        (0, [-1, 0]),
        (1 << 63, [i32::MIN + 1, i32::MAX - 1]),
        (TS, [0x7FFF_0000, -0x7FFF_0000]),
    ] {
        let r = gaze_report(true, ts, gaze, [0; 3], [0; 3]);
        let t = l.tracking(&r[1..]).expect("decodes");
        assert_eq!(t.timestamp_us, Some(ts));
        assert_eq!(
            t.gaze_um,
            Some([f64::from(gaze[0]), f64::from(gaze[1])]),
            "sign-extended from 32 bits"
        );
    }
}

fn config() -> HidConfig {
    HidConfig {
        vendor_id: None,
        product_id: None,
        screen_um: (1.0, 1.0),
        eye_positions: true,
        timeout_ms: 10,
    }
}

/// The live driver flow (the same code the `hidapi` transport runs) over a
/// transport that serves the reports and records the features written.
#[test]
fn the_live_driver_streams_every_shape_and_clamps_the_mode_request() {
    for (name, descriptor, unnamed) in shapes() {
        let text = hid_log(descriptor, unnamed, 5);
        let mut d = HidDriver::new(
            HidLogTransport::new(&text),
            config(),
            Box::new(SharedClock::default()),
        );
        d.start().unwrap_or_else(|e| panic!("{name}: starts: {e}"));
        assert_eq!(
            d.info().screen_um,
            Some((f64::from(SCREEN.0), f64::from(SCREEN.1))),
            "{name}: the screen size is read"
        );
        let mut got = Vec::new();
        while let Some(s) = d.next_sample().unwrap_or_else(|e| panic!("{name}: {e}")) {
            got.push(s);
        }
        d.stop().unwrap_or_else(|e| panic!("{name}: stops: {e}"));
        assert_eq!(got.len(), 5, "{name}");
        for (k, s) in got.iter().enumerate() {
            assert_eq!(s.device_time_us, Some(TS + k as u64 * 16_667), "{name}");
            assert_eq!(s.combined, Some([172_000.0 + k as f64, 96_500.0]), "{name}");
        }
        // Gaze point + eye positions = 3; the unnamed descriptor declares
        // the Mode Request as 0..1, so it gets 1 (gaze point only).
        let start = if unnamed { 1 } else { 3 };
        assert_eq!(
            d.transport_mut().sent,
            vec![vec![0x14, start], vec![0x14, 0]],
            "{name}: mode requests written"
        );
    }
}

/// `gazecast replay --format hid-log`: the file's bytes through a replay
/// transport into the stream driver with the hid-log decoder.
#[test]
fn a_hid_log_of_every_shape_replays() {
    for (name, descriptor, unnamed) in shapes() {
        let text = hid_log(descriptor, unnamed, 7);
        let transport =
            ReplayTransport::from_raw_bytes(text.as_bytes(), 115_200, 16, Pacing::AsFastAsPossible);
        let clock = transport.clock();
        let mut d = StreamDriver::new(transport, HidLogDecoder::new(), Box::new(clock));
        d.start().unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut got = Vec::new();
        while let Some(s) = d.next_sample().unwrap_or_else(|e| panic!("{name}: {e}")) {
            got.push(s);
        }
        assert_eq!(got.len(), 7, "{name}");
        assert!(got.iter().all(|s| s.device_time_us.is_some()), "{name}");
        assert_eq!(
            d.decoder().frame_hint(),
            Some((f64::from(SCREEN.0), f64::from(SCREEN.1))),
            "{name}: without --raw, gaze is mapped with the device's screen size"
        );
        let s = d.stats();
        assert_eq!((s.records, s.dropped_bytes, s.resyncs), (7, 0, 0), "{name}");
    }
}

/// A 64-bit timestamp declared after 32-bit fields with Logical Minimum
/// 0x80000000 inherits their range (Logical Minimum/Maximum are global
/// items of at most 32 bits): it cannot bound a 64-bit value, and a device
/// clock past 2^31 µs (36 minutes) must not read as invalid.
#[test]
fn a_64_bit_timestamp_under_a_leftover_32_bit_range_is_read() {
    #[rustfmt::skip]
    let d = [
        0x05, 0x12, 0x09, 0x01, 0xA1, 0x01,
        0x09, 0x10, 0xA1, 0x02, 0x85, 0x10,
        0x17, 0x00, 0x00, 0x00, 0x80, 0x27, 0xFF, 0xFF, 0xFF, 0x7F,
        0x75, 0x20,
        0x09, 0x24, 0xA1, 0x00, 0x95, 0x02, 0x09, 0x21, 0x09, 0x22, 0x81, 0x02, 0xC0,
        0x75, 0x40, 0x95, 0x01, 0x09, 0x20, 0x81, 0x02, // 64-bit timestamp
        0xC0,
        0x09, 0x14, 0xA1, 0x02, 0x85, 0x14,
        0x75, 0x08, 0x95, 0x01, 0x15, 0x00, 0x25, 0x07, 0x0A, 0x00, 0x04, 0xB1, 0x02,
        0xC0,
        0xC0,
    ];
    let l = TrackerLayout::from_descriptor(&d).expect("parses");
    for ts in [5_000_000_000u64, u64::MAX, 1 << 31, 0] {
        let mut r = Vec::new();
        le32(&mut r, i32::MIN);
        le32(&mut r, i32::MAX);
        r.extend(ts.to_le_bytes());
        let t = l.tracking(&r).expect("decodes");
        assert_eq!(t.timestamp_us, Some(ts));
        assert_eq!(t.gaze_um, Some([f64::from(i32::MIN), f64::from(i32::MAX)]));
    }
}

/// A named-collection tracker whose Mode Request declares `lo..=hi`.
fn with_mode_range(lo: u8, hi: u8) -> Vec<u8> {
    #[rustfmt::skip]
    let mut d = vec![
        0x05, 0x12, 0x09, 0x01, 0xA1, 0x01,
        0x09, 0x10, 0xA1, 0x02, 0x85, 0x10,
        0x17, 0x80, 0x7B, 0xE1, 0xFF, 0x27, 0x80, 0x84, 0x1E, 0x00, 0x75, 0x20,
        0x09, 0x24, 0xA1, 0x00, 0x95, 0x02, 0x09, 0x21, 0x09, 0x22, 0x81, 0x02, 0xC0,
        0xC0,
        0x09, 0x14, 0xA1, 0x02, 0x85, 0x14,
        0x75, 0x08, 0x95, 0x01,
    ];
    d.extend([0x15, lo, 0x25, hi]);
    d.extend([0x0A, 0x00, 0x04, 0xB1, 0x02, 0xC0, 0xC0]);
    d
}

/// The Mode Request written to the device stays inside the declared range:
/// checked on the feature reports a recording transport receives.
#[test]
fn the_mode_request_is_clamped_to_the_declared_range() {
    // (range, eye positions asked, start request written, stop written)
    for ((lo, hi), eyes, start, stop) in [
        ((0, 1), true, 1, 0),  // 3 → gaze point only
        ((0, 1), false, 1, 0), // 1 fits
        ((0, 7), true, 3, 0),  // fits: unchanged
        ((0, 2), true, 1, 0),  // 3 does not fit: gaze point only
        ((2, 7), false, 2, 0), // 1 below the range: clamped; a stop stays a stop
    ] {
        let text = format!("# descriptor {}\n", hex(&with_mode_range(lo, hi)));
        let mut d = HidDriver::new(
            HidLogTransport::new(&text),
            HidConfig {
                eye_positions: eyes,
                ..config()
            },
            Box::new(SharedClock::default()),
        );
        d.start().expect("starts");
        d.stop().expect("stops");
        assert_eq!(
            d.transport_mut().sent,
            vec![vec![0x14, start], vec![0x14, stop]],
            "range {lo}..={hi}, eye positions {eyes}"
        );
    }
}
