//! A simulated HID eye tracker: report descriptor, feature reports and
//! Tracking Data input reports, written as hid-log text split into reads.
//!
//! **Synthesised, not captured from a real device.** The descriptors follow
//! the public facts of the interface (HUTRR74 usages, Microsoft's GazeHid /
//! DMF VirtualEyeGaze reference layout); two layouts are provided so that the
//! decoder is tested on field positions it cannot have hard-coded.
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

const INPUT: u8 = 0x80;
const FEATURE: u8 = 0xB0;

/// The simulated device's report descriptor.
pub fn descriptor(layout: HidLayout) -> Vec<u8> {
    use super::usage::*;
    let mut d = Desc(Vec::new());
    let reference = layout == HidLayout::Reference;
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
        d.range(-2_000_000, 2_000_000)
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
        out.chunks.push(Chunk {
            kind: ChunkKind::HostToDevice,
            time_us: t,
            payload: format_line(&Line::Control(
                super::mode::GAZE_POINT | super::mode::EYE_POSITION,
            ))
            .into_bytes(),
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
            eye_position_um: [le, re],
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
