//! Gaze from a Lab Streaming Layer (LSL) stream.
//!
//! An LSL outlet (a tracker vendor's LSL app, a Pupil Labs relay, a script)
//! is read through an inlet ([`inlet::LslTransport`], feature `lsl`, the
//! only place the `labstream` crate is used) that frames every pulled
//! sample as a binary record, so the stream is a byte transport like a
//! serial port: [`StreamDriver`](crate::StreamDriver) runs [`LslDecoder`]
//! over it, the recorder's tap writes the records into a `.gzrec`
//! losslessly, and a replay decodes them again with the same decoder (the
//! decoder needs no `labstream`).
//!
//! # Records (little-endian)
//!
//! `4C 53` ("LS"), kind (u8), payload length (u32), payload, CRC-32 of the
//! kind, length and payload (u32):
//!
//! - kind 1, *stream info*: UTF-8 lines `key<TAB>value`: `name`, `type`,
//!   `source_id`, `channels` (the count), then one `channel` line per
//!   channel with its label, in channel order (at most [`MAX_INFO_BYTES`]).
//!   After it, a sample record must hold exactly that many values. The transport sends one at
//!   the start of every connection, so a recording carries the labels its
//!   channel mapping refers to.
//! - kind 2, *sample*: the LSL timestamp (f64 s, the sender's clock), the
//!   inlet's latest time correction (f64 s, NaN before the first
//!   measurement), then every channel value as f64 (a float32 stream's
//!   values convert exactly), at most [`MAX_CHANNELS`].
//!
//! A record whose CRC fails, whose kind is unknown or whose length is out
//! of bounds is skipped from its first byte on: the decoder resynchronises
//! on the next magic and counts the skipped bytes and the resync.
//!
//! # Times
//!
//! - **Device time**: with a `device_time` channel, its value × its unit
//!   (seconds, milliseconds or µs) rounded to µs. Otherwise the LSL
//!   timestamp plus the record's time correction (0 when it is NaN),
//!   × 10⁶, rounded: the sender's capture time on *this* machine's LSL
//!   clock, in µs. A value that is not finite, negative or beyond 2⁶³ µs
//!   gives no device time.
//! - **Arrival time**: when the transport handed the record over (host
//!   monotonic µs; the recorded one in a replay).
//! - **Mapped time**: the device time mapped onto the host clock by the
//!   driver's [`ClockMapper`](crate::ClockMapper) like any tracker's
//!   ([`DeviceClock::Device`]).
//!
//! # Validity
//!
//! An eye (or the combined point) is valid when its x and y are finite
//! (LSL apps send NaN for a lost eye) and, with a `confidence` channel,
//! the confidence is at least its threshold (a NaN confidence is not). A
//! channel the stream does not have (an index past its end, a label its
//! info does not list) makes the eye missing and counts an invalid value.
//! A pupil value is kept when finite.
//!
//! A stream with only a `combined` point gives both eyes that point (as
//! the mouse emulator does); with `left` and/or `right`, each eye is its
//! own and a `combined` point, when also configured and valid, is the
//! sample's combined gaze.

#[cfg(feature = "lsl")]
pub mod inlet;

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::framing::Framing;
use crate::sample::{DecodeStats, EyeSample, GazeSample};
use crate::source::Decoder;
use crate::timing::DeviceClock;

/// The records' magic, "LS".
pub const MAGIC: [u8; 2] = [0x4C, 0x53];
/// Record kind: stream info.
pub const KIND_INFO: u8 = 1;
/// Record kind: sample.
pub const KIND_SAMPLE: u8 = 2;
/// Most channels a stream may have (the transport refuses wider streams).
pub const MAX_CHANNELS: usize = 256;
/// Largest stream-info payload (bytes).
pub const MAX_INFO_BYTES: usize = 16 * 1024;
/// Longest channel label kept (characters).
pub const MAX_LABEL_CHARS: usize = 128;
/// Magic, kind, length.
const PREFIX: usize = 7;
/// The CRC.
const TRAILER: usize = 4;
/// Largest sample payload.
const MAX_SAMPLE_BYTES: usize = 16 + 8 * MAX_CHANNELS;

/// A channel of the stream: by its label (as the stream's description
/// names it) or by its index (from 0).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum ChannelRef {
    /// By label, as the stream's description names it.
    Label(String),
    /// By index, from 0.
    Index(usize),
}

impl std::fmt::Display for ChannelRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChannelRef::Label(l) => write!(f, "Label({l:?})"),
            ChannelRef::Index(i) => write!(f, "Index({i})"),
        }
    }
}

/// The channels of one eye (or of the combined point).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EyeChannels {
    /// The x coordinate's channel.
    pub x: ChannelRef,
    /// The y coordinate's channel.
    pub y: ChannelRef,
    /// The pupil size's channel, when read.
    #[serde(default)]
    pub pupil: Option<ChannelRef>,
}

/// What the gaze coordinates are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GazeUnits {
    /// Screen pixels (`frame`: the screen's size in pixels).
    Pixels,
    /// 0..1 of the screen, from its upper-left corner (`frame` (1, 1)).
    Normalized,
    /// Millimetres from the screen's upper-left corner (`frame`: its size).
    Millimetres,
}

/// A confidence channel: a sample below `threshold` has no valid gaze.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfidenceChannel {
    /// The channel.
    pub channel: ChannelRef,
    /// Values below this mark the sample's gaze invalid.
    pub threshold: f64,
}

/// Unit of a device-time channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimeUnit {
    /// Seconds.
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Microseconds.
    Microseconds,
}

impl TimeUnit {
    fn to_us(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1e6,
            TimeUnit::Milliseconds => 1e3,
            TimeUnit::Microseconds => 1.0,
        }
    }
}

/// A channel carrying the device's own timestamp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeChannel {
    /// The channel.
    pub channel: ChannelRef,
    /// Its unit.
    pub unit: TimeUnit,
}

/// An LSL gaze stream (`config/trackers/lsl-*.ron`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LslConfig {
    /// Which stream: any subset of its name, type and source id (at least
    /// one); the first stream that matches them all is read.
    #[serde(default)]
    pub name: Option<String>,
    /// The stream's type (e.g. `Gaze`).
    #[serde(default)]
    pub stream_type: Option<String>,
    /// The stream's source id.
    #[serde(default)]
    pub source_id: Option<String>,
    /// The combined (cyclopean) point's channels.
    #[serde(default)]
    pub combined: Option<EyeChannels>,
    /// The left and right eyes' channels.
    #[serde(default)]
    pub left: Option<EyeChannels>,
    /// The right eye's channels.
    #[serde(default)]
    pub right: Option<EyeChannels>,
    /// What the gaze coordinates are.
    pub units: GazeUnits,
    /// The screen's extent in `units` (the tracker's range): needed for
    /// Pixels and Millimetres; (1, 1) for Normalized.
    #[serde(default)]
    pub frame: Option<(f64, f64)>,
    /// A confidence channel that marks samples invalid.
    #[serde(default)]
    pub confidence: Option<ConfidenceChannel>,
    /// The device's own timestamp channel (else the LSL timestamp).
    #[serde(default)]
    pub device_time: Option<TimeChannel>,
    /// No sample for this long (ms) is a lost stream: the inlet is closed
    /// and the stream resolved again.
    #[serde(default = "default_silence_ms")]
    pub silence_ms: u64,
    /// How long resolving the stream, reading its description and opening
    /// the inlet may take, each (ms).
    #[serde(default = "default_resolve_ms")]
    pub resolve_timeout_ms: u64,
}

fn default_silence_ms() -> u64 {
    2000
}
fn default_resolve_ms() -> u64 {
    5000
}

impl LslConfig {
    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let e = |f: &str, m: String| Err((f.to_string(), m));
        if self.name.is_none() && self.stream_type.is_none() && self.source_id.is_none() {
            return e(
                "name",
                "give at least one of `name`, `stream_type`, `source_id` to choose the stream"
                    .into(),
            );
        }
        for (f, v) in [
            ("name", &self.name),
            ("stream_type", &self.stream_type),
            ("source_id", &self.source_id),
        ] {
            if let Some(v) = v {
                if v.is_empty() || v.len() > 256 || v.contains(['\'', '"']) {
                    return e(
                        f,
                        format!("{v:?} must be 1 to 256 characters without quotes"),
                    );
                }
            }
        }
        if self.combined.is_none() && self.left.is_none() && self.right.is_none() {
            return e(
                "combined",
                "give the gaze channels: `combined`, `left` and/or `right`".into(),
            );
        }
        let check = |f: String, c: &ChannelRef| match c {
            ChannelRef::Label(l) if l.is_empty() || l.chars().count() > MAX_LABEL_CHARS => Err((
                f,
                format!("a label must be 1 to {MAX_LABEL_CHARS} characters"),
            )),
            ChannelRef::Label(l) if l.contains(['\t', '\n']) => {
                Err((f, "a label cannot hold a tab or a line break".into()))
            }
            ChannelRef::Index(i) if *i >= MAX_CHANNELS => Err((
                f,
                format!("{i}: a channel index must be below {MAX_CHANNELS}"),
            )),
            _ => Ok(()),
        };
        for (name, eye) in [
            ("combined", &self.combined),
            ("left", &self.left),
            ("right", &self.right),
        ] {
            if let Some(eye) = eye {
                check(format!("{name}.x"), &eye.x)?;
                check(format!("{name}.y"), &eye.y)?;
                if let Some(p) = &eye.pupil {
                    check(format!("{name}.pupil"), p)?;
                }
            }
        }
        if let Some(c) = &self.confidence {
            check("confidence.channel".into(), &c.channel)?;
            if !c.threshold.is_finite() {
                return e(
                    "confidence.threshold",
                    format!("{} must be finite", c.threshold),
                );
            }
        }
        if let Some(t) = &self.device_time {
            check("device_time.channel".into(), &t.channel)?;
        }
        match (self.units, self.frame) {
            (GazeUnits::Normalized, Some(f)) if f != (1.0, 1.0) => {
                return e(
                    "frame",
                    "Normalized gaze spans (1.0, 1.0): leave `frame` out".into(),
                )
            }
            (GazeUnits::Pixels | GazeUnits::Millimetres, None) => {
                return e(
                    "frame",
                    "Pixels and Millimetres need the screen's extent in those units, e.g. frame: (1920.0, 1080.0)".into(),
                )
            }
            (_, Some((w, h))) if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) => {
                return e("frame", format!("({w}, {h}) must be positive"))
            }
            _ => {}
        }
        if !(100..=60_000).contains(&self.silence_ms) {
            return e(
                "silence_ms",
                format!("{} must be 100 to 60000 ms", self.silence_ms),
            );
        }
        if !(100..=60_000).contains(&self.resolve_timeout_ms) {
            return e(
                "resolve_timeout_ms",
                format!("{} must be 100 to 60000 ms", self.resolve_timeout_ms),
            );
        }
        Ok(())
    }

    /// The gaze coordinates' range, (width, height) in `units`.
    pub fn frame(&self) -> (f64, f64) {
        match self.units {
            GazeUnits::Normalized => (1.0, 1.0),
            _ => self.frame.unwrap_or((1.0, 1.0)),
        }
    }

    /// Whether the stream measures both eyes separately.
    pub fn binocular(&self) -> bool {
        self.left.is_some() && self.right.is_some()
    }

    /// Every label the mapping names, with its field.
    pub fn labels<'a>(&'a self) -> Vec<(String, &'a str)> {
        let mut out = Vec::new();
        let mut add = |f: String, c: &'a ChannelRef| {
            if let ChannelRef::Label(l) = c {
                out.push((f, l.as_str()));
            }
        };
        for (name, eye) in [
            ("combined", &self.combined),
            ("left", &self.left),
            ("right", &self.right),
        ] {
            if let Some(eye) = eye {
                add(format!("{name}.x"), &eye.x);
                add(format!("{name}.y"), &eye.y);
                if let Some(p) = &eye.pupil {
                    add(format!("{name}.pupil"), p);
                }
            }
        }
        if let Some(c) = &self.confidence {
            add("confidence.channel".into(), &c.channel);
        }
        if let Some(t) = &self.device_time {
            add("device_time.channel".into(), &t.channel);
        }
        out
    }
}

/// What a stream-info record says.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StreamHeader {
    /// The stream's name.
    pub name: String,
    /// The stream's type.
    pub stream_type: String,
    /// The stream's source id.
    pub source_id: String,
    /// The stream's channel count (0: not stated): every sample record
    /// after this info record then has exactly this many values.
    pub channel_count: usize,
    /// Channel labels in channel order.
    pub labels: Vec<String>,
}

fn frame_record(kind: u8, payload: &[u8]) -> Vec<u8> {
    let mut r = Vec::with_capacity(PREFIX + payload.len() + TRAILER);
    r.extend_from_slice(&MAGIC);
    r.push(kind);
    r.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    r.extend_from_slice(payload);
    let crc = crc32fast::hash(&r[2..]);
    r.extend_from_slice(&crc.to_le_bytes());
    r
}

fn clean(s: &str) -> String {
    s.chars()
        .take(MAX_LABEL_CHARS)
        .map(|c| if c == '\t' || c == '\n' { ' ' } else { c })
        .collect()
}

/// A stream-info record (labels past [`MAX_CHANNELS`], characters past
/// [`MAX_LABEL_CHARS`] and lines past [`MAX_INFO_BYTES`] are left out;
/// tabs and line breaks become spaces).
pub fn encode_info(h: &StreamHeader) -> Vec<u8> {
    let mut text = format!(
        "name\t{}\ntype\t{}\nsource_id\t{}\nchannels\t{}\n",
        clean(&h.name),
        clean(&h.stream_type),
        clean(&h.source_id),
        h.channel_count.min(MAX_CHANNELS)
    );
    for l in h.labels.iter().take(MAX_CHANNELS) {
        let line = format!("channel\t{}\n", clean(l));
        if text.len() + line.len() > MAX_INFO_BYTES {
            break;
        }
        text.push_str(&line);
    }
    frame_record(KIND_INFO, text.as_bytes())
}

/// A sample record: the LSL timestamp, the time correction (NaN when not
/// yet measured) and the values (at most [`MAX_CHANNELS`]; more are cut).
pub fn encode_sample(timestamp: f64, time_correction: f64, values: &[f64]) -> Vec<u8> {
    let values = &values[..values.len().min(MAX_CHANNELS)];
    let mut p = Vec::with_capacity(16 + 8 * values.len());
    p.extend_from_slice(&timestamp.to_le_bytes());
    p.extend_from_slice(&time_correction.to_le_bytes());
    for v in values {
        p.extend_from_slice(&v.to_le_bytes());
    }
    frame_record(KIND_SAMPLE, &p)
}

fn parse_info(payload: &[u8]) -> Option<StreamHeader> {
    let text = std::str::from_utf8(payload).ok()?;
    let mut h = StreamHeader::default();
    for line in text.lines() {
        let (k, v) = line.split_once('\t')?;
        match k {
            "name" => h.name = v.to_string(),
            "type" => h.stream_type = v.to_string(),
            "source_id" => h.source_id = v.to_string(),
            "channels" => {
                h.channel_count = v.parse().ok().filter(|&n: &usize| n <= MAX_CHANNELS)?;
            }
            "channel" if h.labels.len() < MAX_CHANNELS => h.labels.push(v.to_string()),
            _ => return None,
        }
    }
    Some(h)
}

fn f64_at(p: &[u8], i: usize) -> f64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&p[i * 8..i * 8 + 8]);
    f64::from_le_bytes(b)
}

/// Resolved channel indices of one eye.
#[derive(Debug, Clone, Copy)]
struct EyeIdx {
    x: Option<usize>,
    y: Option<usize>,
    pupil: Option<usize>,
}

#[derive(Debug, Clone, Copy, Default)]
struct Indices {
    combined: Option<EyeIdx>,
    left: Option<EyeIdx>,
    right: Option<EyeIdx>,
    confidence: Option<Option<usize>>,
    time: Option<Option<usize>>,
}

/// Decodes LSL records (see the module docs) into samples.
#[derive(Debug, Clone)]
pub struct LslDecoder {
    config: LslConfig,
    framing: Framing,
    header: Option<StreamHeader>,
    idx: Indices,
}

impl LslDecoder {
    /// A decoder for streams as `config` describes them.
    pub fn new(config: LslConfig) -> Self {
        let mut framing = Framing::new();
        framing.record_len = PREFIX + 16 + 8 * 2 + TRAILER;
        let mut d = Self {
            config,
            framing,
            header: None,
            idx: Indices::default(),
        };
        d.resolve();
        d
    }

    /// The latest stream-info record seen.
    pub fn header(&self) -> Option<&StreamHeader> {
        self.header.as_ref()
    }

    fn index(&self, c: &ChannelRef) -> Option<usize> {
        match c {
            ChannelRef::Index(i) => Some(*i),
            ChannelRef::Label(l) => self
                .header
                .as_ref()
                .and_then(|h| h.labels.iter().position(|x| x == l)),
        }
    }

    fn resolve(&mut self) {
        let eye = |e: &Option<EyeChannels>| {
            e.as_ref().map(|e| EyeIdx {
                x: self.index(&e.x),
                y: self.index(&e.y),
                pupil: e.pupil.as_ref().and_then(|p| self.index(p)),
            })
        };
        self.idx = Indices {
            combined: eye(&self.config.combined),
            left: eye(&self.config.left),
            right: eye(&self.config.right),
            confidence: self
                .config
                .confidence
                .as_ref()
                .map(|c| self.index(&c.channel)),
            time: self
                .config
                .device_time
                .as_ref()
                .map(|t| self.index(&t.channel)),
        };
    }

    fn sample(&mut self, p: &[u8], arrival_us: u64) -> GazeSample {
        let n = (p.len() - 16) / 8;
        let ts = f64_at(p, 0);
        let tc = f64_at(p, 1);
        let get = |i: Option<usize>| i.filter(|&i| i < n).map(|i| f64_at(p, i + 2));
        let idx = self.idx;
        let confident = match (idx.confidence, &self.config.confidence) {
            (Some(i), Some(c)) => get(i).is_some_and(|v| v >= c.threshold),
            _ => true,
        };
        let mut invalid = 0u64;
        let mut eye = |e: Option<EyeIdx>| -> Option<EyeSample> {
            let e = e?;
            let (x, y) = (get(e.x), get(e.y));
            if x.is_none() || y.is_none() {
                invalid += 1;
            }
            let position = match (x, y) {
                (Some(x), Some(y)) if confident && x.is_finite() && y.is_finite() => Some([x, y]),
                _ => None,
            };
            let pupil = get(e.pupil).filter(|v| v.is_finite());
            Some(EyeSample { position, pupil })
        };
        let combined = eye(idx.combined);
        let left = eye(idx.left);
        let right = eye(idx.right);
        let device = match (idx.time, &self.config.device_time) {
            (Some(i), Some(t)) => get(i).map(|v| v * t.unit.to_us()),
            _ => Some((ts + if tc.is_finite() { tc } else { 0.0 }) * 1e6),
        };
        let device_time_us = device
            .filter(|v| v.is_finite() && *v >= 0.0 && *v < 9.2e18)
            .map(|v| v.round() as u64);
        self.framing.stats.invalid_values += invalid;
        let (left, right, combined) = match (left, right, combined) {
            (None, None, Some(c)) => (c, c, None),
            (l, r, c) => (
                l.unwrap_or(EyeSample::MISSING),
                r.unwrap_or(EyeSample::MISSING),
                c.and_then(|c| c.position),
            ),
        };
        let seq = self.framing.record();
        let mut s = GazeSample::new(seq, device_time_us, arrival_us, left, right);
        s.combined = combined;
        s
    }
}

impl Decoder for LslDecoder {
    fn push(&mut self, bytes: &[u8], arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        self.framing.accept(bytes);
        let mut start = 0;
        while self.framing.seek_record(&mut start, MAGIC, PREFIX) {
            let b = &self.framing.buf[start..];
            let kind = b[2];
            let len = u32::from_le_bytes([b[3], b[4], b[5], b[6]]) as usize;
            let len_ok = match kind {
                KIND_INFO => len <= MAX_INFO_BYTES,
                // Once an info record stated the channel count, a sample's
                // length is exact: a damaged length is rejected at once
                // rather than awaited.
                KIND_SAMPLE => match self.header.as_ref().map(|h| h.channel_count) {
                    Some(n) if n > 0 => len == 16 + 8 * n,
                    _ => (16..=MAX_SAMPLE_BYTES).contains(&len) && len.is_multiple_of(8),
                },
                _ => false,
            };
            if !len_ok {
                self.framing.drop_bytes(1);
                start += 1;
                continue;
            }
            let total = PREFIX + len + TRAILER;
            if b.len() < total {
                break;
            }
            let crc = u32::from_le_bytes([b[total - 4], b[total - 3], b[total - 2], b[total - 1]]);
            if crc32fast::hash(&b[2..PREFIX + len]) != crc {
                self.framing.drop_bytes(1);
                start += 1;
                continue;
            }
            let payload = b[PREFIX..PREFIX + len].to_vec();
            if kind == KIND_INFO {
                match parse_info(&payload) {
                    Some(h) => {
                        self.header = Some(h);
                        self.resolve();
                    }
                    None => self.framing.stats.invalid_values += 1,
                }
            } else {
                let s = self.sample(&payload, arrival_us);
                out.push_back(s);
            }
            start += total;
        }
        self.framing.buf.drain(..start);
    }

    fn finish(&mut self) {
        self.framing.finish();
    }

    fn stats(&self) -> DecodeStats {
        self.framing.stats
    }

    fn start_command(&self) -> Vec<u8> {
        Vec::new()
    }

    fn stop_command(&self) -> Vec<u8> {
        Vec::new()
    }

    fn device_clock(&self) -> DeviceClock {
        DeviceClock::Device
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::decode_all;

    pub(crate) fn gaze_config() -> LslConfig {
        LslConfig {
            name: Some("gz".into()),
            stream_type: Some("Gaze".into()),
            source_id: None,
            combined: Some(EyeChannels {
                x: ChannelRef::Label("ScreenX".into()),
                y: ChannelRef::Label("ScreenY".into()),
                pupil: Some(ChannelRef::Index(2)),
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

    fn header() -> StreamHeader {
        StreamHeader {
            name: "gz".into(),
            stream_type: "Gaze".into(),
            source_id: "src".into(),
            channel_count: 3,
            labels: vec!["ScreenX".into(), "ScreenY".into(), "Pupil".into()],
        }
    }

    fn stream(n: usize) -> Vec<u8> {
        let mut b = encode_info(&header());
        for i in 0..n {
            let x = if i % 7 == 3 {
                f64::NAN
            } else {
                i as f64 * 0.01
            };
            b.extend(encode_sample(
                100.0 + i as f64 / 120.0,
                0.25,
                &[x, 0.5, 3.0],
            ));
        }
        b
    }

    #[test]
    fn records_decode_with_labels_times_and_nan_validity() {
        let mut d = LslDecoder::new(gaze_config());
        let s = decode_all(&mut d, &stream(10), 7);
        assert_eq!(s.len(), 10);
        assert_eq!(d.stats().dropped_bytes, 0);
        assert_eq!(d.header().map(|h| h.labels.len()), Some(3));
        for (i, s) in s.iter().enumerate() {
            assert_eq!(s.seq, i as u64);
            let want = ((100.0 + i as f64 / 120.0 + 0.25) * 1e6).round() as u64;
            assert_eq!(s.device_time_us, Some(want));
            assert_eq!(s.host_time_us, 7);
            if i % 7 == 3 {
                assert_eq!(s.gaze(), None);
            } else {
                assert_eq!(s.gaze(), Some([i as f64 * 0.01, 0.5]));
            }
            assert_eq!(s.left.pupil, Some(3.0));
        }
    }

    #[test]
    fn a_label_without_an_info_record_is_a_missing_eye() {
        let mut d = LslDecoder::new(gaze_config());
        let b = encode_sample(1.0, f64::NAN, &[0.1, 0.2, 3.0]);
        let s = decode_all(&mut d, &b, 0);
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].gaze(), None);
        assert_eq!(s[0].device_time_us, Some(1_000_000));
        assert_eq!(d.stats().invalid_values, 1);
    }

    #[test]
    fn confidence_time_channel_and_separate_eyes() {
        let mut c = gaze_config();
        c.combined = None;
        c.left = Some(EyeChannels {
            x: ChannelRef::Index(0),
            y: ChannelRef::Index(1),
            pupil: None,
        });
        c.right = Some(EyeChannels {
            x: ChannelRef::Index(2),
            y: ChannelRef::Index(3),
            pupil: None,
        });
        c.confidence = Some(ConfidenceChannel {
            channel: ChannelRef::Index(4),
            threshold: 0.6,
        });
        c.device_time = Some(TimeChannel {
            channel: ChannelRef::Index(5),
            unit: TimeUnit::Milliseconds,
        });
        let mut d = LslDecoder::new(c);
        let mut b = encode_sample(1.0, 0.0, &[1.0, 2.0, 3.0, f64::NAN, 0.9, 1500.25]);
        b.extend(encode_sample(1.0, 0.0, &[1.0, 2.0, 3.0, 4.0, 0.5, 1501.0]));
        b.extend(encode_sample(
            1.0,
            0.0,
            &[1.0, 2.0, 3.0, 4.0, f64::NAN, -1.0],
        ));
        let s = decode_all(&mut d, &b, 0);
        assert_eq!(s[0].left.position, Some([1.0, 2.0]));
        assert_eq!(s[0].right.position, None);
        assert_eq!(s[0].device_time_us, Some(1_500_250));
        assert_eq!(s[1].gaze(), None, "below the threshold");
        assert_eq!(s[1].device_time_us, Some(1_501_000));
        assert_eq!(s[2].gaze(), None, "a NaN confidence");
        assert_eq!(s[2].device_time_us, None);
    }

    #[test]
    fn damage_is_skipped_counted_and_resynchronised() {
        let good = stream(6);
        let mut bad = b"noise".to_vec();
        bad.extend_from_slice(&good);
        // Flip a byte inside the third sample's values.
        let info_len = encode_info(&header()).len();
        let rec = encode_sample(0.0, 0.0, &[0.0, 0.0, 0.0]).len();
        bad[5 + info_len + 2 * rec + 20] ^= 0xFF;
        let mut d = LslDecoder::new(gaze_config());
        let s = decode_all(&mut d, &bad, 0);
        assert_eq!(s.len(), 5);
        assert_eq!(d.stats().dropped_bytes, 5 + rec as u64);
        assert_eq!(d.stats().resyncs, 2);
        // Byte by byte gives the same.
        let mut d2 = LslDecoder::new(gaze_config());
        let mut out = VecDeque::new();
        for b in &bad {
            d2.push(std::slice::from_ref(b), 0, &mut out);
        }
        d2.finish();
        assert_eq!(Vec::from(out), s);
        assert_eq!(d2.stats(), d.stats());
    }

    #[test]
    fn a_huge_length_is_not_awaited() {
        let mut b = MAGIC.to_vec();
        b.push(KIND_SAMPLE);
        b.extend_from_slice(&u32::MAX.to_le_bytes());
        b.extend(stream(2));
        let mut d = LslDecoder::new(gaze_config());
        let s = decode_all(&mut d, &b, 0);
        assert_eq!(s.len(), 2);
        assert_eq!(d.stats().dropped_bytes, 7);
    }

    #[test]
    fn validation_names_fields() {
        let mut c = gaze_config();
        assert_eq!(c.validate(), Ok(()));
        c.frame = Some((1920.0, 1080.0));
        assert_eq!(c.validate().map_err(|e| e.0), Err("frame".to_string()));
        c.frame = None;
        c.units = GazeUnits::Pixels;
        assert_eq!(c.validate().map_err(|e| e.0), Err("frame".to_string()));
        c.units = GazeUnits::Normalized;
        c.combined = Some(EyeChannels {
            x: ChannelRef::Index(MAX_CHANNELS),
            y: ChannelRef::Index(0),
            pupil: None,
        });
        assert_eq!(c.validate().map_err(|e| e.0), Err("combined.x".to_string()));
        let mut c = gaze_config();
        c.name = None;
        c.stream_type = None;
        assert!(c.validate().is_err());
        let mut c = gaze_config();
        c.silence_ms = 5;
        assert_eq!(c.validate().map_err(|e| e.0), Err("silence_ms".to_string()));
    }
}
