//! A simulated HID eye tracker: report descriptor, feature reports and
//! Tracking Data input reports, written as hid-log text split into reads.
//!
//! **Synthesised, not captured from a real device.** The descriptors follow
//! the public facts of the interface (HUTRR74 usages, Microsoft's GazeHid /
//! DMF VirtualEyeGaze reference layout); several layouts are provided so
//! that the decoder is tested on field positions it cannot have hard-coded,
//! two of them ([`HidLayout::Named`], [`HidLayout::Unnamed`]) byte for byte
//! the published descriptors of Microsoft's virtual eye-gaze device.
//!
//! Behaviour: the gaze script of [`crate::sim::gaze_script`] in µm on the
//! display; no report during blinks (the device sees no eyes); one eye lost
//! (its position fields out of range, the gaze from the other eye); a
//! disconnect at 60 % of the session (350 ms of silence, then the descriptor
//! and features again); a device clock that runs 40 ppm fast with an offset.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::log::{format_line, Line};
use super::TrackerLayout;
use crate::recording::{Chunk, ChunkKind};
use crate::sample::{EyeSample, GazeSample};
use crate::sim::{SimStream, TruthSample};

/// Which report layout the simulated device uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HidLayout {
    /// As the reference descriptor: timestamp as eight 1-byte fields, every
    /// field declared Constant, gaze before the eyes, head position.
    Reference,
    /// Another implementation: 64-bit timestamp, Data fields, 4 bits of
    /// padding, the eyes before the gaze, no head position.
    Compact,
    /// Microsoft's virtual eye-gaze device as DMF ships it now
    /// ([`DMF_NAMED`]): named collections with units.
    Named,
    /// Its earlier descriptor ([`DMF_UNNAMED`]): unnamed logical
    /// collections, no units, eight one-byte timestamp fields, positions
    /// with Logical Minimum 0x80000000 (every 32-bit value valid, so a lost
    /// eye cannot be flagged), Mode Request 0..1.
    Unnamed,
    /// Named collections without units, positions with Logical Minimum
    /// 0x80000000, and a 64-bit timestamp declared after them that inherits
    /// their 32-bit logical range.
    Wide,
}

impl HidLayout {
    /// Every layout, for tests that run each.
    pub const ALL: [HidLayout; 5] = [
        HidLayout::Reference,
        HidLayout::Compact,
        HidLayout::Named,
        HidLayout::Unnamed,
        HidLayout::Wide,
    ];
}

struct Desc(Vec<u8>);

impl Desc {
    fn item(&mut self, prefix: u8, v: i64) -> &mut Self {
        let (size_code, n) = if (0..=0xFF).contains(&v) {
            (1, 1)
        } else if (0..=0xFFFF).contains(&v) {
            (2, 2)
        } else {
            (3, 4)
        };
        self.0.push(prefix | size_code);
        self.0.extend(&(v as u32).to_le_bytes()[..n]);
        self
    }
    fn signed(&mut self, prefix: u8, v: i32) -> &mut Self {
        self.0.push(prefix | 3);
        self.0.extend(v.to_le_bytes());
        self
    }
    fn usage(&mut self, u: u16) -> &mut Self {
        self.item(0x08, i64::from(u))
    }
    fn collection(&mut self, kind: i64) -> &mut Self {
        self.item(0xA0, kind)
    }
    fn end(&mut self) -> &mut Self {
        self.0.push(0xC0);
        self
    }
    fn size_count(&mut self, size: i64, count: i64) -> &mut Self {
        self.item(0x74, size).item(0x94, count)
    }
    fn range(&mut self, lo: i32, hi: i32) -> &mut Self {
        self.signed(0x14, lo).signed(0x24, hi)
    }
}

/// Microsoft's virtual eye-gaze HID device, DMF
/// `Dmf/Modules.Library/Dmf_VirtualEyeGaze.c` at
/// bfac434fd3497259095a1f8d70ed734493228091 (github.com/microsoft/DMF):
/// logical collections named by their usage, Unit and Unit Exponent items,
/// positions in ±2,000,000 µm, a timestamp as eight one-byte fields, head
/// position and direction, Status as feature and input, Mode Request 0..7.
#[rustfmt::skip]
pub const DMF_NAMED: &[u8] = &[
    0x05, 0x12,                         // Usage Page (Eye and Head Trackers)
    0x09, 0x01,                         // Usage (Eye Tracker)
    0xA1, 0x01,                         // Collection (Application)
    0x09, 0x10, 0xA1, 0x02,             //   Usage (Tracking Data), Collection (Logical)
    0x85, 0x10,                         //     Report ID 0x10
    0x15, 0x00, 0x26, 0xFF, 0x00,       //     Logical 0..255
    0x75, 0x08,                         //     Report Size 8
    0x09, 0x20,                         //     Usage (Sensor Timestamp)
    0x66, 0x01, 0x10, 0x55, 0x0A,       //     Unit (SI linear, s), Exponent -6
    0x95, 0x08, 0x81, 0x02,             //     8 × 8 bits, Input (Data,Var,Abs)
    0x95, 0x01, 0x75, 0x20,             //     Report Count 1, Size 32
    0x65, 0x11, 0x55, 0x0C,             //     Unit (cm), Exponent -4: µm
    0x17, 0x80, 0x7B, 0xE1, 0xFF,       //     Logical Minimum -2000000
    0x27, 0x80, 0x84, 0x1E, 0x00,       //     Logical Maximum 2000000
    0x09, 0x24, 0xA1, 0x00,             //     Usage (Gaze Point), Collection (Physical)
    0x95, 0x02, 0x09, 0x21, 0x09, 0x22, 0x81, 0x03, 0xC0,
    0x09, 0x25, 0xA1, 0x00,             //     Usage (Left Eye Position)
    0x95, 0x03, 0x09, 0x21, 0x09, 0x22, 0x09, 0x23, 0x81, 0x03, 0xC0,
    0x09, 0x26, 0xA1, 0x00,             //     Usage (Right Eye Position)
    0x95, 0x03, 0x09, 0x21, 0x09, 0x22, 0x09, 0x23, 0x81, 0x03, 0xC0,
    0x09, 0x27, 0xA1, 0x00,             //     Usage (Head Position)
    0x95, 0x03, 0x09, 0x21, 0x09, 0x22, 0x09, 0x23, 0x81, 0x03, 0xC0,
    0x09, 0x28, 0xA1, 0x00,             //     Usage (Head Direction Point)
    0x95, 0x03, 0x09, 0x29, 0x09, 0x2A, 0x09, 0x2B, 0x81, 0x03, 0xC0,
    0xC0,                               //   End Collection
    0x09, 0x11, 0xA1, 0x02,             //   Usage (Capabilities), Collection (Logical)
    0x85, 0x11,
    0x75, 0x08, 0x95, 0x01,
    0x0A, 0x00, 0x01,                   //     Usage (Tracker Quality)
    0x15, 0x00, 0x25, 0x01, 0x65, 0x00, 0x55, 0x00,
    0xB1, 0x03,                         //     Feature (Const,Var,Abs)
    0xA1, 0x00,                         //     Collection (Physical), no usage
    0x95, 0x05, 0x75, 0x20,
    0x17, 0x80, 0x7B, 0xE1, 0xFF, 0x27, 0x80, 0x84, 0x1E, 0x00,
    0x65, 0x11, 0x55, 0x0C,
    0x0A, 0x01, 0x01, 0x0A, 0x02, 0x01, 0x0A, 0x03, 0x01, 0x0A, 0x04, 0x01, 0x0A, 0x05, 0x01,
    0xB1, 0x03, 0xC0,
    0xC0,
    0x09, 0x12, 0xA1, 0x02,             //   Usage (Configuration), Collection (Logical)
    0x85, 0x12,
    0x75, 0x08, 0x15, 0x00, 0x26, 0xFF, 0x00, 0x95, 0x01,
    0x75, 0x10, 0x27, 0xFF, 0xFF, 0x00, 0x00, 0x65, 0x00, 0x55, 0x00,
    0x0A, 0x00, 0x02, 0xB1, 0x03,       //     Display Manufacturer ID
    0x0A, 0x01, 0x02, 0xB1, 0x03,       //     Display Product ID
    0x75, 0x20, 0x27, 0xFF, 0xFF, 0xFF, 0x7F,
    0x0A, 0x02, 0x02, 0xB1, 0x03,       //     Display Serial Number
    0x75, 0x10, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0x00, 0x00,
    0x0A, 0x03, 0x02, 0xB1, 0x03,       //     Display Manufacturer Date
    0xA1, 0x00,
    0x65, 0x11, 0x55, 0x0C, 0x27, 0xFF, 0xFF, 0xFF, 0x7F, 0x75, 0x20,
    0x0A, 0x04, 0x02, 0xB1, 0x03,       //     Calibrated Screen Width
    0x0A, 0x05, 0x02, 0xB1, 0x03,       //     Calibrated Screen Height
    0xC0,
    0xC0,
    0x09, 0x13, 0xA1, 0x02,             //   Usage (Status), Collection (Logical): feature
    0x85, 0x13,
    0x75, 0x08, 0x65, 0x00, 0x55, 0x00, 0x25, 0x04,
    0x0A, 0x01, 0x03, 0xB1, 0x02,       //     Configuration Status
    0x75, 0x10, 0x27, 0xFF, 0xFF, 0x00, 0x00, 0x66, 0x01, 0xF0, 0x55, 0x00,
    0x0A, 0x00, 0x03, 0xB1, 0x02,       //     Sampling Frequency (Hz)
    0xC0,
    0x09, 0x13, 0xA1, 0x02,             //   Usage (Status), Collection (Logical): input
    0x85, 0x13,
    0x75, 0x08, 0x65, 0x00, 0x55, 0x00, 0x25, 0x04,
    0x0A, 0x01, 0x03, 0x81, 0x02,
    0x75, 0x10, 0x27, 0xFF, 0xFF, 0x00, 0x00, 0x66, 0x01, 0xF0, 0x55, 0x00,
    0x0A, 0x00, 0x03, 0x81, 0x02,
    0xC0,
    0x09, 0x14, 0xA1, 0x02,             //   Usage (Control), Collection (Logical)
    0x85, 0x14,
    0x75, 0x08, 0x25, 0x07, 0x65, 0x00, 0x55, 0x00,
    0x0A, 0x00, 0x04, 0xB1, 0x02,       //     Mode Request 0..7
    0xC0,
    0xC0,
];

/// The same device at DMF f2ff922ed7778dfa0de19ac2cb2e4c15190f4a91,
/// `Dmf/Modules.Template/Dmf_VirtualEyeGaze.c`: logical collections
/// *without* usages, no units, three reserved bytes, the timestamp as eight
/// one-byte fields, positions with Logical Minimum 0x80000000, Mode Request
/// 0..1. Encoded as the source declares it: that commit's item macros
/// shifted left instead of right (`(v << 8) & 0xFF`) and gave
/// `LOGICAL_MAXIMUM_DWORD` the minimum's tag, which DMF later corrected;
/// these bytes are the corrected encoding of the same declarations.
#[rustfmt::skip]
pub const DMF_UNNAMED: &[u8] = &[
    0x05, 0x12, 0x09, 0x01, 0xA1, 0x01, // Eye Tracker application
    0xA1, 0x02,                         //   Collection (Logical), no usage
    0x85, 0x10,
    0x15, 0x00, 0x25, 0xFF,             //     Logical 0..0xFF (one byte: -1, read as 255)
    0x75, 0x08, 0x95, 0x03, 0x81, 0x03, //     3 reserved bytes
    0x09, 0x20, 0x95, 0x08, 0x81, 0x02, //     Timestamp: 8 × 8 bits
    0x95, 0x01, 0x75, 0x20,
    0x17, 0x00, 0x00, 0x00, 0x80,       //     Logical Minimum 0x80000000
    0x27, 0xFF, 0xFF, 0xFF, 0x7F,       //     Logical Maximum 0x7FFFFFFF
    0x09, 0x24, 0xA1, 0x00, 0x95, 0x02, 0x09, 0x21, 0x09, 0x22, 0x81, 0x02, 0xC0,
    0x09, 0x25, 0xA1, 0x00, 0x95, 0x03, 0x09, 0x21, 0x09, 0x22, 0x09, 0x23, 0x81, 0x02, 0xC0,
    0x09, 0x26, 0xA1, 0x00, 0x95, 0x03, 0x09, 0x21, 0x09, 0x22, 0x09, 0x23, 0x81, 0x02, 0xC0,
    0xC0,
    0xA1, 0x02, 0x85, 0x11,             //   Capabilities, unnamed
    0x75, 0x08, 0x95, 0x01, 0x15, 0x01, 0x25, 0x04,
    0x0A, 0x00, 0x01, 0xB1, 0x03,
    0x95, 0x05, 0x75, 0x20, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0xFF, 0x7F,
    0x0A, 0x01, 0x01, 0x0A, 0x02, 0x01, 0x0A, 0x03, 0x01, 0x0A, 0x04, 0x01, 0x0A, 0x05, 0x01,
    0xB1, 0x03,
    0xC0,
    0xA1, 0x02, 0x85, 0x12,             //   Configuration, unnamed
    0x75, 0x08, 0x95, 0x01, 0xB1, 0x03, //     reserved byte
    0x75, 0x10, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0x00, 0x00,
    0x0A, 0x00, 0x02, 0xB1, 0x03, 0x0A, 0x01, 0x02, 0xB1, 0x03,
    0x75, 0x20, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0xFF, 0x7F,
    0x0A, 0x02, 0x02, 0xB1, 0x03,
    0x75, 0x10, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0x00, 0x00,
    0x0A, 0x03, 0x02, 0xB1, 0x03,
    0x75, 0x20, 0x95, 0x02, 0x15, 0x00, 0x27, 0xFF, 0xFF, 0xFF, 0x7F,
    0x0A, 0x04, 0x02, 0x0A, 0x05, 0x02, 0xB1, 0x03,
    0xC0,
    0xA1, 0x02, 0x85, 0x13,             //   Status, unnamed
    0x75, 0x08, 0x95, 0x01, 0xB1, 0x03, //     reserved byte
    0x15, 0x00, 0x25, 0x04, 0x0A, 0x01, 0x03, 0xB1, 0x02,
    0x75, 0x10, 0x15, 0x00, 0x26, 0xFF, 0x7F, 0x0A, 0x00, 0x03, 0xB1, 0x02,
    0xC0,
    0xA1, 0x02, 0x85, 0x14,             //   Control, unnamed
    0x75, 0x08, 0x95, 0x01, 0x75, 0x08, 0x15, 0x00, 0x25, 0x01,
    0x0A, 0x00, 0x04, 0xB1, 0x02,       //     Mode Request 0..1
    0xC0,
    0xC0,
];

const INPUT: u8 = 0x80;
const FEATURE: u8 = 0xB0;

/// The simulated device's report descriptor.
pub fn descriptor(layout: HidLayout) -> Vec<u8> {
    use super::usage::*;
    match layout {
        HidLayout::Named => return DMF_NAMED.to_vec(),
        HidLayout::Unnamed => return DMF_UNNAMED.to_vec(),
        HidLayout::Reference | HidLayout::Compact | HidLayout::Wide => {}
    }
    let mut d = Desc(Vec::new());
    let reference = layout == HidLayout::Reference;
    let wide = layout == HidLayout::Wide;
    let (lo, hi) = if wide {
        (i32::MIN, i32::MAX)
    } else {
        (-2_000_000, 2_000_000)
    };
    let flags = if reference { 3 } else { 2 }; // Const,Var or Data,Var
    d.item(0x04, i64::from(super::PAGE))
        .usage(EYE_TRACKER)
        .collection(1);
    // Tracking Data.
    d.item(0x84, 0x10).usage(TRACKING_DATA).collection(2);
    let position = |d: &mut Desc, c: u16, axes: &[u16]| {
        d.usage(c).collection(0);
        for &a in axes {
            d.usage(a);
        }
        d.range(lo, hi)
            .size_count(32, axes.len() as i64)
            .item(INPUT, flags)
            .end();
    };
    let xyz = [POSITION_X, POSITION_Y, POSITION_Z];
    if reference {
        d.usage(SENSOR_TIMESTAMP)
            .range(0, 255)
            .size_count(8, 8)
            .item(INPUT, flags);
        position(&mut d, GAZE_POINT, &xyz[..2]);
        position(&mut d, LEFT_EYE_POSITION, &xyz);
        position(&mut d, RIGHT_EYE_POSITION, &xyz);
        position(&mut d, HEAD_POSITION, &xyz);
    } else if wide {
        position(&mut d, GAZE_POINT, &xyz[..2]);
        position(&mut d, LEFT_EYE_POSITION, &xyz);
        position(&mut d, RIGHT_EYE_POSITION, &xyz);
        // No range of its own: the 32-bit one above is still in force.
        d.usage(SENSOR_TIMESTAMP)
            .size_count(64, 1)
            .item(INPUT, flags);
    } else {
        position(&mut d, LEFT_EYE_POSITION, &xyz);
        position(&mut d, RIGHT_EYE_POSITION, &xyz);
        d.size_count(4, 1).item(INPUT, 1); // padding
        d.usage(SENSOR_TIMESTAMP)
            .range(0, 0)
            .size_count(64, 1)
            .item(INPUT, flags);
        d.size_count(4, 1).item(INPUT, 1); // padding
        position(&mut d, GAZE_POINT, &xyz[..2]);
    }
    d.end();
    // Capabilities.
    d.item(0x84, 0x11).usage(CAPABILITIES).collection(2);
    d.usage(TRACKER_QUALITY)
        .range(0, 255)
        .size_count(8, 1)
        .item(FEATURE, flags);
    for u in [
        MIN_TRACKING_DISTANCE,
        OPTIMUM_TRACKING_DISTANCE,
        MAX_TRACKING_DISTANCE,
        MAX_SCREEN_PLANE_WIDTH,
        MAX_SCREEN_PLANE_HEIGHT,
    ] {
        d.usage(u);
    }
    d.range(0, i32::MAX)
        .size_count(32, 5)
        .item(FEATURE, flags)
        .end();
    // Configuration.
    d.item(0x84, 0x12).usage(CONFIGURATION).collection(2);
    d.usage(CALIBRATED_SCREEN_WIDTH)
        .usage(CALIBRATED_SCREEN_HEIGHT)
        .range(0, i32::MAX)
        .size_count(32, 2)
        .item(FEATURE, flags)
        .end();
    // Status, as a feature and as an input report.
    d.item(0x84, 0x13).usage(STATUS).collection(2);
    for kind in [FEATURE, INPUT] {
        d.usage(CONFIGURATION_STATUS)
            .range(0, 255)
            .size_count(8, 1)
            .item(kind, flags);
        d.usage(SAMPLING_FREQUENCY)
            .range(0, 65535)
            .size_count(16, 1)
            .item(kind, flags);
    }
    d.end();
    // Control.
    d.item(0x84, 0x14).usage(CONTROL).collection(2);
    d.usage(DEVICE_MODE_REQUEST)
        .range(0, 255)
        .size_count(8, 1)
        .item(FEATURE, 2)
        .end();
    d.end();
    d.0
}

/// A report of `layout`'s `report_id` with the given values set, ID first.
fn report(
    layout: &TrackerLayout,
    kind: super::descriptor::ReportKind,
    report_id: u8,
    values: &[(&super::Value, i64)],
) -> Vec<u8> {
    let mut data = vec![0u8; layout.descriptor.report_len(kind, report_id)];
    for (v, x) in values {
        v.write(&mut data, *x);
    }
    let mut out = vec![report_id];
    out.extend(data);
    out
}

/// The feature reports a host reads at start, as hid-log lines.
pub fn feature_lines(layout: &TrackerLayout, screen_um: (f64, f64), rate_hz: f64) -> Vec<Line> {
    use super::descriptor::ReportKind::Feature;
    use super::usage::*;
    let value = |list: &[(u16, super::Value)], u: u16| {
        list.iter().find(|(k, _)| *k == u).map(|(_, v)| v.clone())
    };
    let mut lines = Vec::new();
    let mut emit = |list: &[(u16, super::Value)], vals: &[(u16, i64)]| {
        let set: Vec<(super::Value, i64)> = vals
            .iter()
            .filter_map(|(u, x)| value(list, *u).map(|v| (v, *x)))
            .collect();
        if let Some((v, _)) = set.first() {
            let refs: Vec<(&super::Value, i64)> = set.iter().map(|(v, x)| (v, *x)).collect();
            lines.push(Line::Feature(report(layout, Feature, v.report_id, &refs)));
        }
    };
    emit(
        &layout.capabilities,
        &[
            (TRACKER_QUALITY, 1),
            (MIN_TRACKING_DISTANCE, 450_000),
            (OPTIMUM_TRACKING_DISTANCE, 600_000),
            (MAX_TRACKING_DISTANCE, 800_000),
            (MAX_SCREEN_PLANE_WIDTH, 600_000),
            (MAX_SCREEN_PLANE_HEIGHT, 340_000),
        ],
    );
    emit(
        &layout.configuration,
        &[
            (CALIBRATED_SCREEN_WIDTH, screen_um.0.round() as i64),
            (CALIBRATED_SCREEN_HEIGHT, screen_um.1.round() as i64),
        ],
    );
    emit(
        &layout.status,
        &[
            (CONFIGURATION_STATUS, 1),
            (SAMPLING_FREQUENCY, rate_hz.round() as i64),
        ],
    );
    lines
}

/// The device clock of the simulation: 40 ppm fast, offset by 5000 s.
pub fn device_clock_us(t_us: u64) -> u64 {
    5_000_000_000 + t_us + t_us * 40 / 1_000_000
}

/// An eye position that the device flags invalid: out of the logical range.
const INVALID: i64 = i32::MIN as i64;

/// Encodes the truth (µm on the display) as the device would report it.
pub fn simulate_hid(
    layout_kind: HidLayout,
    truth: &[TruthSample],
    screen_um: (f64, f64),
    rate_hz: f64,
    seed: u64,
) -> SimStream {
    let desc = descriptor(layout_kind);
    let layout = match TrackerLayout::from_descriptor(&desc) {
        Ok(l) => l,
        Err(e) => unreachable!("the simulator's own descriptor is valid: {e}"),
    };
    let mut out = TextOut {
        rng: ChaCha8Rng::seed_from_u64(seed),
        chunks: Vec::new(),
        last_arrival: 0,
    };
    let mut expected = Vec::new();
    let connect = |out: &mut TextOut, t: u64| {
        out.push(format_line(&Line::Descriptor(desc.clone())), t);
        for l in feature_lines(&layout, screen_um, rate_hz) {
            out.push(format_line(&l), t);
        }
        // The host's request, as the driver clamps it to the declared range.
        let asked = super::mode::GAZE_POINT | super::mode::EYE_POSITION;
        let sent = layout
            .mode_value(asked)
            .and_then(|m| u32::try_from(m).ok())
            .unwrap_or(asked);
        out.chunks.push(Chunk {
            kind: ChunkKind::HostToDevice,
            time_us: t,
            payload: format_line(&Line::Control(sent)).into_bytes(),
        });
    };
    let start = truth.first().map_or(0, |s| s.t_us.saturating_sub(50_000));
    connect(&mut out, start);
    let reconnect_at = truth.get(truth.len() * 6 / 10).map(|s| s.t_us);
    let mut reconnected = false;
    let Some(gaze) = layout.gaze.clone() else {
        unreachable!("the simulator's descriptor has a gaze point")
    };
    for s in truth {
        if let Some(r) = reconnect_at {
            if !reconnected && s.t_us >= r {
                reconnected = true;
                let t = s.t_us + 350_000;
                out.push("# device disconnected and reopened\n".into(), t);
                connect(&mut out, t);
            }
            if reconnected && s.t_us < r + 350_000 {
                continue; // the device was away
            }
        }
        let g = match (s.left, s.right) {
            (Some(l), Some(r)) => [(l[0] + r[0]) / 2.0, (l[1] + r[1]) / 2.0],
            (Some(p), None) | (None, Some(p)) => p,
            (None, None) => continue, // no eyes, no report
        };
        let sway = (s.t_us as f64 / 1e6 * 0.7).sin() * 3_000.0;
        let eye = |present: bool, x: f64| -> Option<[f64; 3]> {
            present.then_some([(x + sway).round(), 12_000.0, (600_000.0 + sway).round()])
        };
        let (le, re) = (
            eye(s.left.is_some(), -32_000.0),
            eye(s.right.is_some(), 32_000.0),
        );
        // Where the logical range covers every 32-bit value (Logical Minimum
        // 0x80000000) a lost eye cannot be flagged: the host reads the
        // marker as a position.
        let seen = |e: Option<[f64; 3]>, vs: &Option<[super::Value; 3]>| match (e, vs) {
            (None, Some([x, ..])) if x.in_range(INVALID) => Some([INVALID as f64; 3]),
            _ => e,
        };
        let (le_seen, re_seen) = (seen(le, &layout.left_eye), seen(re, &layout.right_eye));
        let gum = [g[0].round(), g[1].round()];
        let device_us = device_clock_us(s.t_us);
        let mut values: Vec<(&super::Value, i64)> =
            vec![(&gaze[0], gum[0] as i64), (&gaze[1], gum[1] as i64)];
        if let Some(ts) = &layout.timestamp {
            values.push((ts, device_us as i64));
        }
        for (vs, e) in [(&layout.left_eye, le), (&layout.right_eye, re)] {
            if let Some(vs) = vs {
                for (k, v) in vs.iter().enumerate() {
                    values.push((v, e.map_or(INVALID, |p| p[k] as i64)));
                }
            }
        }
        if let Some(h) = &layout.head {
            for (k, v) in h.iter().enumerate() {
                values.push((v, [0, 20_000, 620_000][k]));
            }
        }
        let bytes = report(
            &layout,
            super::descriptor::ReportKind::Input,
            layout.tracking_report_id,
            &values,
        );
        let arrival = s.t_us + 2_000 + out.rng.random_range(0..1_500u64);
        let line = format_line(&Line::Report {
            host_time_us: arrival,
            bytes,
        });
        out.push(line, arrival);
        expected.push(GazeSample {
            seq: expected.len() as u64,
            device_time_us: Some(device_us),
            host_time_us: arrival,
            mapped_time_us: arrival,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left: EyeSample::MISSING,
            right: EyeSample::MISSING,
            combined: Some(gum),
            eye_position_um: [le_seen, re_seen],
        });
    }
    SimStream::one_record_per_read(out.chunks, expected)
}

/// Device text split into 1–3 reads at random points, arrival times never
/// going back.
struct TextOut {
    rng: ChaCha8Rng,
    chunks: Vec<Chunk>,
    last_arrival: u64,
}

impl TextOut {
    fn push(&mut self, text: String, t: u64) {
        let bytes = text.into_bytes();
        let pieces = self.rng.random_range(1..=3usize).min(bytes.len());
        let mut cuts: Vec<usize> = (1..pieces)
            .map(|_| self.rng.random_range(1..bytes.len()))
            .collect();
        cuts.push(bytes.len());
        cuts.sort_unstable();
        cuts.dedup();
        let mut from = 0;
        for to in cuts {
            let at = t.max(self.last_arrival);
            self.last_arrival = at;
            self.chunks.push(Chunk {
                kind: ChunkKind::DeviceToHost,
                time_us: at,
                payload: bytes[from..to].to_vec(),
            });
            from = to;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_layout_puts_fields_where_the_reference_does() {
        let l = TrackerLayout::from_descriptor(&descriptor(HidLayout::Reference)).expect("valid");
        assert_eq!(l.tracking_report_id, 0x10);
        let ts = l.timestamp.as_ref().expect("timestamp");
        assert_eq!(ts.bits(), 64);
        // Timestamp bytes 0..8, gaze X 8..12, gaze Y 12..16 (little-endian).
        let mut data = vec![0u8; 16 + 36];
        data[..8].copy_from_slice(&0x0102_0304_0506_0708u64.to_le_bytes());
        data[8..12].copy_from_slice(&(-5i32).to_le_bytes());
        data[12..16].copy_from_slice(&1_999_999i32.to_le_bytes());
        let t = l.tracking(&data).expect("long enough");
        assert_eq!(t.timestamp_us, Some(0x0102_0304_0506_0708));
        assert_eq!(t.gaze_um, Some([-5.0, 1_999_999.0]));
        data[12..16].copy_from_slice(&2_000_001i32.to_le_bytes());
        assert_eq!(
            l.tracking(&data).expect("long").gaze_um,
            None,
            "out of range"
        );
        assert!(l.tracking(&data[..20]).is_none(), "short report");
        assert_eq!(l.control_report(3), Some(vec![0x14, 3]));
        assert_eq!(l.feature_ids(), vec![0x11, 0x12, 0x13]);
    }

    #[test]
    fn both_layouts_decode_to_the_same_values() {
        for kind in [HidLayout::Reference, HidLayout::Compact] {
            let l = TrackerLayout::from_descriptor(&descriptor(kind)).expect("valid");
            let gaze = l.gaze.clone().expect("gaze");
            let ts = l.timestamp.clone().expect("timestamp");
            let left = l.left_eye.clone().expect("left eye");
            let r = report(
                &l,
                super::super::descriptor::ReportKind::Input,
                0x10,
                &[
                    (&gaze[0], 123_456),
                    (&gaze[1], -7),
                    (&ts, 9_876_543_210),
                    (&left[2], 600_000),
                ],
            );
            let t = l.tracking(&r[1..]).expect("decodes");
            assert_eq!(t.gaze_um, Some([123_456.0, -7.0]), "{kind:?}");
            assert_eq!(t.timestamp_us, Some(9_876_543_210), "{kind:?}");
            assert_eq!(t.left_eye_um, Some([0.0, 0.0, 600_000.0]), "{kind:?}");
            assert_eq!(l.head.is_some(), kind == HidLayout::Reference);
        }
    }

    /// A value in `v`'s declared range: its minimum, its maximum or one in
    /// between (any 32-bit value where it declares none).
    fn pick(v: &super::super::Value, edge: u8, seed: u64) -> i64 {
        let (lo, hi) = v
            .range()
            .unwrap_or((i64::from(i32::MIN), i64::from(i32::MAX)));
        match edge {
            0 => lo,
            1 => hi,
            _ => lo + (seed % (hi - lo + 1) as u64) as i64,
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fixtures::proptest_cases(2_000)))]
        /// Every descriptor shape the simulator emits round-trips through
        /// parse → locate → write → decode, at the edges of every range.
        #[test]
        fn every_simulated_shape_round_trips(
            k in 0..HidLayout::ALL.len(),
            ts in proptest::prelude::any::<u64>(),
            edges in proptest::array::uniform8(0..3u8),
            seeds in proptest::array::uniform8(proptest::prelude::any::<u64>()),
        ) {
            let kind = HidLayout::ALL[k];
            let l = TrackerLayout::from_descriptor(&descriptor(kind)).expect("valid");
            let gaze = l.gaze.clone().expect("gaze");
            let left = l.left_eye.clone().expect("left eye");
            let right = l.right_eye.clone().expect("right eye");
            let stamp = l.timestamp.clone().expect("timestamp");
            proptest::prop_assert_eq!(stamp.bits(), 64);
            let vals: Vec<i64> = gaze
                .iter()
                .chain(left.iter())
                .chain(right.iter().take(3))
                .enumerate()
                .map(|(i, v)| pick(v, edges[i % 8], seeds[i % 8]))
                .collect();
            let mut set: Vec<(&super::super::Value, i64)> = gaze
                .iter()
                .chain(left.iter())
                .chain(right.iter())
                .zip(vals.iter().copied())
                .collect();
            set.push((&stamp, ts as i64));
            let r = report(&l, super::super::descriptor::ReportKind::Input, 0x10, &set);
            let t = l.tracking(&r[1..]).expect("decodes");
            let f = |i: usize| vals[i] as f64;
            proptest::prop_assert_eq!(t.timestamp_us, Some(ts));
            proptest::prop_assert_eq!(t.gaze_um, Some([f(0), f(1)]));
            proptest::prop_assert_eq!(t.left_eye_um, Some([f(2), f(3), f(4)]));
            proptest::prop_assert_eq!(t.right_eye_um, Some([f(5), f(6), f(7)]));
            // Just past a declared range that leaves room: invalid.
            if let Some((_, hi)) = gaze[0].range().filter(|(_, hi)| *hi < i64::from(i32::MAX)) {
                let r = report(
                    &l,
                    super::super::descriptor::ReportKind::Input,
                    0x10,
                    &[(&gaze[0], hi + 1), (&gaze[1], vals[1])],
                );
                proptest::prop_assert_eq!(l.tracking(&r[1..]).expect("decodes").gaze_um, None);
            }
        }
    }

    #[test]
    fn the_dmf_descriptors_are_emitted_as_published() {
        assert_eq!(descriptor(HidLayout::Named), DMF_NAMED);
        assert_eq!(descriptor(HidLayout::Unnamed), DMF_UNNAMED);
        let wide = TrackerLayout::from_descriptor(&descriptor(HidLayout::Wide)).expect("valid");
        let ts = wide
            .descriptor
            .fields
            .iter()
            .find(|f| f.usage == super::super::usage::SENSOR_TIMESTAMP)
            .expect("timestamp");
        assert_eq!(
            (ts.bit_size, ts.logical_min, ts.logical_max),
            (64, i64::from(i32::MIN), i64::from(i32::MAX)),
            "the 64-bit timestamp inherits the 32-bit range"
        );
    }

    #[test]
    fn treating_constant_as_padding_would_lose_the_gaze() {
        // Guard for the trap the issue names: every field of the reference
        // descriptor is Constant, and all of them are located.
        let l = TrackerLayout::from_descriptor(&descriptor(HidLayout::Reference)).expect("valid");
        assert!(l
            .descriptor
            .fields
            .iter()
            .filter(|f| f.usage != 0)
            .all(|f| f.constant || f.usage == super::super::usage::DEVICE_MODE_REQUEST));
        assert!(l.gaze.is_some() && l.left_eye.is_some() && l.right_eye.is_some());
    }
}
