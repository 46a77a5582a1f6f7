//! The `hid-log` text format and its decoder.
//!
//! One line per event, `\n`-terminated:
//!
//! ```text
//! # descriptor 05 12 09 01 a1 01 …      the report descriptor (device (re)connected)
//! # feature 11 …                        a feature report read from the device, ID first
//! # control 3                           host → device: Control mode request (0 = stop)
//! # anything else                       a comment
//! 1234567 10 a0 86 01 …                 an input report: host arrival time (µs), then
//!                                       the report bytes in hex, report ID first
//! ```
//!
//! Hex bytes may be separated by spaces or not. A line that does not parse,
//! an input report before any descriptor, or a report of the wrong length is
//! dropped and counted (`dropped_bytes`, `resyncs`); decoding goes on at the
//! next line.

use std::collections::VecDeque;
use std::fmt::Write as _;

use super::{DeviceInfo, TrackerLayout};
use crate::sample::{DecodeStats, EyeSample, GazeSample};
use crate::source::Decoder;

/// Longest line accepted (bytes); longer ones are dropped.
const MAX_LINE: usize = 16 * 1024;

/// One parsed line.
#[derive(Debug, Clone, PartialEq)]
pub enum Line {
    /// `# descriptor …`: the report descriptor (device (re)connected).
    Descriptor(Vec<u8>),
    /// `# feature …`: a feature report read from the device, ID first.
    Feature(Vec<u8>),
    /// `# control N`: host to device, a Control mode request (0 = stop).
    Control(u32),
    /// Any other `#` line: a comment.
    Comment,
    /// An input report.
    Report {
        /// Host arrival time, µs.
        host_time_us: u64,
        /// The report's bytes, report ID first.
        bytes: Vec<u8>,
    },
}

fn hex(s: &str) -> Option<Vec<u8>> {
    let digits: Vec<u8> = s.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    if digits.is_empty() || !digits.len().is_multiple_of(2) {
        return None;
    }
    digits
        .chunks(2)
        .map(|p| {
            let d = |c: u8| (c as char).to_digit(16);
            Some((d(p[0])? * 16 + d(p[1])?) as u8)
        })
        .collect()
}

/// Parses one line (without its newline). `None`: not a valid line.
pub fn parse_line(line: &str) -> Option<Line> {
    let line = line.trim_end_matches('\r');
    if let Some(rest) = line.strip_prefix('#') {
        let rest = rest.trim_start();
        return Some(if let Some(h) = rest.strip_prefix("descriptor ") {
            Line::Descriptor(hex(h)?)
        } else if let Some(h) = rest.strip_prefix("feature ") {
            Line::Feature(hex(h)?)
        } else if let Some(m) = rest.strip_prefix("control ") {
            Line::Control(m.trim().parse().ok()?)
        } else {
            Line::Comment
        });
    }
    let (t, h) = line.split_once(' ')?;
    Some(Line::Report {
        host_time_us: t.parse().ok()?,
        bytes: hex(h)?,
    })
}

fn hex_bytes(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(3 * bytes.len());
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// Formats a line (with its newline).
pub fn format_line(line: &Line) -> String {
    match line {
        Line::Descriptor(b) => format!("# descriptor {}\n", hex_bytes(b)),
        Line::Feature(b) => format!("# feature {}\n", hex_bytes(b)),
        Line::Control(m) => format!("# control {m}\n"),
        Line::Comment => "#\n".into(),
        Line::Report {
            host_time_us,
            bytes,
        } => format!("{host_time_us} {}\n", hex_bytes(bytes)),
    }
}

/// Decodes hid-log text into samples: `combined` is the gaze point (µm,
/// display upper-left origin), the per-eye 2-D positions are missing (the
/// interface reports no per-eye gaze), `eye_position_um` holds the eye
/// positions, `device_time_us` the sensor timestamp and `host_time_us` the
/// line's arrival time.
#[derive(Debug, Default)]
pub struct HidLogDecoder {
    line: Vec<u8>,
    overlong: bool,
    /// Bytes of the current line past [`MAX_LINE`]: counted, not kept.
    overlong_bytes: u64,
    layout: Option<TrackerLayout>,
    info: DeviceInfo,
    stats: DecodeStats,
    seq: u64,
    descriptors: u64,
    last_device_us: Option<u64>,
    gaps: u64,
}

impl HidLogDecoder {
    /// A decoder that has seen no descriptor yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The layout of the last descriptor seen.
    pub fn layout(&self) -> Option<&TrackerLayout> {
        self.layout.as_ref()
    }

    /// What the feature and status reports said.
    pub fn info(&self) -> DeviceInfo {
        self.info
    }

    /// Descriptors seen: 1 + the number of reconnects.
    pub fn connections(&self) -> u64 {
        self.descriptors
    }

    /// Reports that came more than 1.5 sampling periods after the previous
    /// one (the device sends nothing while it sees no eyes).
    pub fn gaps(&self) -> u64 {
        self.gaps
    }

    fn drop_line(&mut self, len: usize) {
        self.stats.dropped_bytes += len as u64;
        self.stats.resyncs += 1;
    }

    fn line_done(&mut self, out: &mut VecDeque<GazeSample>) {
        let raw = std::mem::take(&mut self.line);
        let extra = std::mem::take(&mut self.overlong_bytes);
        if std::mem::take(&mut self.overlong) {
            // Its real length: the bytes kept, those past the maximum and
            // the newline.
            self.stats.dropped_bytes += raw.len() as u64 + extra + 1;
            self.stats.resyncs += 1;
            return;
        }
        let len = raw.len() + 1;
        if raw.iter().all(|b| b.is_ascii_whitespace()) {
            return;
        }
        let Some(line) = std::str::from_utf8(&raw).ok().and_then(parse_line) else {
            self.drop_line(len);
            return;
        };
        match line {
            Line::Descriptor(d) => match TrackerLayout::from_descriptor(&d) {
                Ok(l) => {
                    self.layout = Some(l);
                    self.descriptors += 1;
                    self.last_device_us = None;
                }
                Err(_) => {
                    self.layout = None;
                    self.drop_line(len);
                }
            },
            Line::Feature(b) => {
                let Some(layout) = &self.layout else {
                    return self.drop_line(len);
                };
                let Some((&id, data)) = b.split_first() else {
                    return self.drop_line(len);
                };
                for list in [&layout.capabilities, &layout.configuration, &layout.status] {
                    let v = TrackerLayout::values(list, id, data);
                    self.info.apply(&v);
                }
            }
            Line::Control(_) | Line::Comment => {}
            Line::Report {
                host_time_us,
                bytes,
            } => {
                let Some(layout) = &self.layout else {
                    return self.drop_line(len);
                };
                let Some((&id, data)) = bytes.split_first() else {
                    return self.drop_line(len);
                };
                if id == layout.tracking_report_id {
                    let Some(t) = layout.tracking(data) else {
                        return self.drop_line(len);
                    };
                    self.sample(t, host_time_us, out);
                } else {
                    let v = TrackerLayout::values(&layout.status_input, id, data);
                    if v.is_empty() {
                        // A report this driver has no use for: not an error.
                        return;
                    }
                    self.info.apply(&v);
                }
            }
        }
    }

    fn sample(&mut self, t: super::Tracking, host_time_us: u64, out: &mut VecDeque<GazeSample>) {
        if t.gaze_um.is_none() {
            self.stats.invalid_values += 1;
        }
        if let (Some(now), Some(prev), Some(hz)) =
            (t.timestamp_us, self.last_device_us, self.info.sampling_hz)
        {
            if now.saturating_sub(prev) as f64 > 1.5e6 / hz {
                self.gaps += 1;
            }
        }
        if t.timestamp_us.is_some() {
            self.last_device_us = t.timestamp_us;
        }
        out.push_back(GazeSample {
            seq: self.seq,
            device_time_us: t.timestamp_us,
            host_time_us,
            mapped_time_us: host_time_us,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left: EyeSample::MISSING,
            right: EyeSample::MISSING,
            combined: t.gaze_um,
            eye_position_um: [t.left_eye_um, t.right_eye_um],
        });
        self.seq += 1;
        self.stats.records += 1;
    }
}

impl Decoder for HidLogDecoder {
    fn push(&mut self, bytes: &[u8], _arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        self.stats.bytes += bytes.len() as u64;
        for &b in bytes {
            if b == b'\n' {
                self.line_done(out);
            } else if self.line.len() < MAX_LINE {
                self.line.push(b);
            } else {
                self.overlong = true;
                self.overlong_bytes += 1;
            }
        }
    }

    fn finish(&mut self) {
        if !self.line.is_empty() || self.overlong {
            let len = self.line.len() as u64 + std::mem::take(&mut self.overlong_bytes);
            self.line.clear();
            self.overlong = false;
            self.stats.dropped_bytes += len;
            self.stats.resyncs += 1;
        }
    }

    fn stats(&self) -> DecodeStats {
        self.stats
    }

    fn start_command(&self) -> Vec<u8> {
        format_line(&Line::Control(
            super::mode::GAZE_POINT | super::mode::EYE_POSITION,
        ))
        .into_bytes()
    }

    fn stop_command(&self) -> Vec<u8> {
        format_line(&Line::Control(0)).into_bytes()
    }

    fn frame_hint(&self) -> Option<(f64, f64)> {
        self.info.screen_um
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_round_trip() {
        for l in [
            Line::Descriptor(vec![5, 0x12, 9, 1]),
            Line::Feature(vec![0x12, 0, 1, 0xff]),
            Line::Control(3),
            Line::Report {
                host_time_us: 123,
                bytes: vec![0x10, 0xab],
            },
        ] {
            let s = format_line(&l);
            assert_eq!(parse_line(s.trim_end()), Some(l));
        }
        assert_eq!(
            parse_line("7 10AB"),
            Some(Line::Report {
                host_time_us: 7,
                bytes: vec![0x10, 0xab]
            })
        );
        for bad in ["x 10", "7 1", "7 zz", "7", "# descriptor 1", "# control x"] {
            assert_eq!(parse_line(bad), None, "{bad}");
        }
        assert_eq!(parse_line("# a comment"), Some(Line::Comment));
    }
}

#[cfg(test)]
mod overlong_tests {
    use super::*;

    /// A line longer than the maximum used to count as `MAX_LINE + 1`
    /// dropped bytes whatever its real length.
    #[test]
    fn an_overlong_line_counts_its_real_length_without_buffering_it() {
        let mut d = HidLogDecoder::new();
        let mut out = VecDeque::new();
        let piece = vec![b'a'; 64 * 1024];
        let pieces = 16; // 1 MiB in one line
        for _ in 0..pieces {
            d.push(&piece, 0, &mut out);
            assert!(d.line.len() <= MAX_LINE);
        }
        d.push(b"\n# a comment\n", 0, &mut out);
        let s = d.stats();
        assert_eq!(s.dropped_bytes, (pieces * piece.len() + 1) as u64);
        assert_eq!(s.resyncs, 1);
        // Unterminated at the end of the stream: its real length, no newline.
        for _ in 0..pieces {
            d.push(&piece, 0, &mut out);
        }
        d.finish();
        let s2 = d.stats();
        assert_eq!(
            s2.dropped_bytes - s.dropped_bytes,
            (pieces * piece.len()) as u64
        );
        assert_eq!(s2.resyncs, 2);
    }
}
