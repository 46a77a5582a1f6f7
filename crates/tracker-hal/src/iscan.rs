//! ISCAN RK-726PCI / DQW serial output (Murphy & Duchowski 2001 §3: binocular
//! point of regard over RS-232 at 19.2 kbaud, a 512×512 frame per eye, 60 Hz).
//!
//! The format, as ISCAN's documentation is quoted by public lab toolkits
//! (Psychtoolbox `DatarecordingFromISCANDemo.m`, MWorks' ISCAN plugin):
//!
//! - Up to 12 output parameters per sample, sent in the configured order while
//!   tracking is active. Which parameter is which is configuration
//!   ([`IscanConfig::parameters`]).
//! - **Binary**: each record is the header `0x44 0x44`, then one little-endian
//!   `u16` per parameter holding the value × 10 (tenths).
//! - **ASCII**: each value as text (`xxx.x`), separated by spaces or tabs, the
//!   record ended by CR LF (a bare LF is accepted too; any spacing is).
//! - Host → device: command bytes 0x80–0xFF (start / stop tracking output are
//!   configurable: 0x84/0x88 in some set-ups, 0x80/0x81 in others); bytes
//!   0–127 are logged by the device as sync markers ([`marker_byte`]).
//!
//! **Timestamps.** ISCAN sends none, but it sends one record per video
//! field at a fixed rate ([`IscanConfig::rate_hz`], 60 Hz in the seed's
//! set-up). The driver's device clock counts records: record *k* of a
//! connection has device time `round(k × 10⁶ / rate_hz)` µs, 0 at the
//! connection's first record ([`DeviceClock::Counter`]). A
//! resynchronisation adds the records its dropped bytes held: each run of
//! dropped bytes (a truncated record, a record whose header was lost or
//! corrupted) counts ⌈run ÷ record length⌉ records; in ASCII each bad
//! line counts max(1, round(its length ÷ the mean length of the lines
//! decoded so far)) (two lines merge when a line end is lost). What this
//! cannot see: a record lost whole, without one of its
//! bytes arriving (the next record's time is then one period early), and
//! noise bytes on an idle line (counted as one lost record). The
//! derivation never looks at arrival times, so a busy host cannot change
//! it; the mapping onto the
//! host clock (and a measured drift that says `rate_hz` is wrong) is the
//! driver's clock model ([`crate::timing`]).
//!
//! **Validity.** A position outside the frame (`[0, width) × [0, height)`) is
//! reported as a missing eye and counted as an invalid value: never clamped.
//! ISCAN's documentation does not say what it sends for a lost eye; our
//! simulator sends an out-of-frame value (binary `0xFFFF`, ASCII `999.9`).
//!
//! **Resynchronisation.** Binary: bytes before a header are dropped; a record
//! whose payload contains the header sequence is taken as truncated (with a
//! 512 frame, an in-range value never contains the byte pair `44 44`), and
//! decoding restarts at that header. ASCII: a line that does not hold exactly
//! one number per parameter is dropped whole. Dropped bytes and resyncs are
//! counted; bit flips inside a binary value are only caught by the range check.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::error::{Error, ErrorKind, Result};
use crate::framing::Framing;
use crate::sample::{DecodeStats, EyeSample, GazeSample};
use crate::source::Decoder;
use crate::timing::DeviceClock;

/// The binary record header.
pub const HEADER: [u8; 2] = [0x44, 0x44];
/// ISCAN sends at most this many parameters.
pub const MAX_PARAMETERS: usize = 12;
/// Longest ASCII line accepted before it is dropped as garbage.
const MAX_LINE: usize = MAX_PARAMETERS * 12 + 16;

/// One output parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum IscanParam {
    /// Left eye, horizontal point of regard.
    LeftPorH,
    /// Left eye, vertical point of regard.
    LeftPorV,
    /// Right eye, horizontal point of regard.
    RightPorH,
    /// Right eye, vertical point of regard.
    RightPorV,
    /// Left pupil size.
    LeftPupil,
    /// Right pupil size.
    RightPupil,
    /// Any other parameter: decoded and ignored.
    Other,
}

/// Binary or ASCII output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum IscanMode {
    /// Binary records.
    Binary,
    /// ASCII lines.
    Ascii,
}

/// How an ISCAN is set up.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IscanConfig {
    /// Binary or ASCII output.
    pub mode: IscanMode,
    /// Output parameters in the order the device sends them (1 to 12).
    pub parameters: Vec<IscanParam>,
    /// Tracker frame per eye, (width, height) in tracker units.
    #[serde(default = "default_frame")]
    pub frame: (f64, f64),
    /// Serial speed, bits per second (19200 in the seed's set-up).
    #[serde(default = "default_baud")]
    pub baud: u32,
    /// Records per second the tracker sends (its video field rate: 60 in
    /// the seed's set-up; RK-726 systems also run at 120 and 240). The
    /// device clock counts records at this rate.
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Serial device, e.g. `/dev/ttyUSB0` (used by `record` and the viewer).
    #[serde(default)]
    pub port: Option<String>,
    /// Command byte that starts tracking output (0x80–0xFF).
    #[serde(default = "default_start")]
    pub start_command: u8,
    /// Command byte that stops tracking output (0x80–0xFF).
    #[serde(default = "default_stop")]
    pub stop_command: u8,
}

fn default_frame() -> (f64, f64) {
    (512.0, 512.0)
}
fn default_baud() -> u32 {
    19_200
}
fn default_rate() -> f64 {
    60.0
}

/// The highest record rate accepted (Hz).
pub const MAX_RATE_HZ: f64 = 2_000.0;
fn default_start() -> u8 {
    0x84
}
fn default_stop() -> u8 {
    0x88
}

impl IscanConfig {
    /// The seed's set-up: binocular POR, 4 parameters, 512×512, 19200 baud.
    pub fn binocular(mode: IscanMode) -> Self {
        use IscanParam::*;
        Self {
            mode,
            parameters: vec![LeftPorH, LeftPorV, RightPorH, RightPorV],
            frame: default_frame(),
            baud: default_baud(),
            rate_hz: default_rate(),
            port: None,
            start_command: default_start(),
            stop_command: default_stop(),
        }
    }

    /// Checks the values; the error names the field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.parameters.is_empty() || self.parameters.len() > MAX_PARAMETERS {
            return Err((
                "parameters",
                format!(
                    "needs 1 to {MAX_PARAMETERS} parameters, got {}",
                    self.parameters.len()
                ),
            ));
        }
        let (w, h) = self.frame;
        if !(w.is_finite() && w > 0.0 && h.is_finite() && h > 0.0) {
            return Err(("frame", format!("({w}, {h}) must be two positive sizes")));
        }
        if self.baud == 0 {
            return Err(("baud", "must be positive".into()));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0 && self.rate_hz <= MAX_RATE_HZ) {
            return Err((
                "rate_hz",
                format!(
                    "{} must be a rate above 0 and at most {MAX_RATE_HZ} Hz",
                    self.rate_hz
                ),
            ));
        }
        for (field, b) in [
            ("start_command", self.start_command),
            ("stop_command", self.stop_command),
        ] {
            if b < 0x80 {
                return Err((
                    field,
                    format!("0x{b:02X} is a marker byte; commands are 0x80–0xFF"),
                ));
            }
        }
        Ok(())
    }

    /// Bytes of one record on the wire.
    pub fn record_len(&self) -> usize {
        HEADER.len() + 2 * self.parameters.len()
    }

    /// The nominal period between records, µs.
    pub fn period_us(&self) -> f64 {
        1e6 / self.rate_hz
    }

    /// Wire time of `bytes` bytes in µs (start + 8 data + stop bits = 10 per byte).
    pub fn wire_time_us(&self, bytes: usize) -> u64 {
        (bytes as u64 * 10 * 1_000_000) / u64::from(self.baud.max(1))
    }
}

/// The byte that asks the device to log sync marker `value` (0–127).
pub fn marker_byte(value: u8) -> Result<u8> {
    if value < 0x80 {
        Ok(value)
    } else {
        Err(Error::new(
            ErrorKind::Unsupported,
            format!("ISCAN markers are 0–127, got {value}"),
        ))
    }
}

/// The ISCAN decoder (binary or ASCII).
#[derive(Debug, Clone)]
pub struct IscanDecoder {
    config: IscanConfig,
    framing: Framing,
    /// ASCII: drop bytes until the next line end (after an over-long line).
    skip_line: bool,
    values: Vec<f64>,
    /// The device clock: records sent so far (decoded + estimated lost).
    sent: u64,
    /// Lost records (the framing's count) already added to `sent`.
    lost_seen: u64,
    /// Bytes and count of the ASCII lines decoded (for their mean length).
    line_bytes: u64,
    lines: u64,
}

impl IscanDecoder {
    /// A decoder for an ISCAN set up as `config`.
    pub fn new(config: IscanConfig) -> Self {
        let n = config.parameters.len();
        let mut framing = Framing::new();
        framing.record_len = match config.mode {
            IscanMode::Binary => config.record_len(),
            // Until a line has decoded: a guess of "xxx.x " per value.
            IscanMode::Ascii => 6 * config.parameters.len().max(1),
        };
        framing.line_records = config.mode == IscanMode::Ascii;
        Self {
            config,
            framing,
            skip_line: false,
            values: Vec::with_capacity(n),
            sent: 0,
            lost_seen: 0,
            line_bytes: 0,
            lines: 0,
        }
    }

    /// The configuration it decodes.
    pub fn config(&self) -> &IscanConfig {
        &self.config
    }

    /// Builds a sample from `self.values` (one per parameter).
    fn emit(&mut self, record_bytes: usize, arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        use IscanParam::*;
        let (w, h) = self.config.frame;
        let mut eye = [[f64::NAN; 2]; 2];
        let mut pupil = [None, None];
        for (p, &v) in self.config.parameters.iter().zip(&self.values) {
            match p {
                LeftPorH => eye[0][0] = v,
                LeftPorV => eye[0][1] = v,
                RightPorH => eye[1][0] = v,
                RightPorV => eye[1][1] = v,
                LeftPupil => pupil[0] = Some(v),
                RightPupil => pupil[1] = Some(v),
                Other => {}
            }
        }
        let mut eyes = [EyeSample::MISSING; 2];
        for k in 0..2 {
            let [x, y] = eye[k];
            let configured = !(x.is_nan() && y.is_nan());
            let in_frame = (0.0..w).contains(&x) && (0.0..h).contains(&y);
            if in_frame {
                eyes[k].position = Some([x, y]);
                eyes[k].pupil = pupil[k].filter(|p| p.is_finite() && *p >= 0.0);
            } else if configured {
                self.framing.stats.invalid_values += 1;
            }
        }
        // Records lost since the last one (see the module docs).
        self.sent += self.framing.lost_records - self.lost_seen;
        self.lost_seen = self.framing.lost_records;
        if self.config.mode == IscanMode::Ascii {
            self.line_bytes += record_bytes as u64;
            self.lines += 1;
            self.framing.record_len = (self.line_bytes / self.lines).max(1) as usize;
        }
        let device_us = (self.sent as f64 * self.config.period_us()).round() as u64;
        self.sent += 1;
        let seq = self.framing.record();
        out.push_back(GazeSample {
            seq,
            device_time_us: Some(device_us),
            host_time_us: arrival_us,
            mapped_time_us: arrival_us,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left: eyes[0],
            right: eyes[1],
            combined: None,
            eye_position_um: [None, None],
        });
    }

    fn push_binary(&mut self, arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        let len = self.config.record_len();
        let mut start = 0;
        while self.framing.seek_record(&mut start, HEADER, len) {
            let avail = &self.framing.buf[start..];
            if let Some(q) = avail[2..len].windows(2).position(|w| w == HEADER) {
                // A header inside the payload: this record was truncated.
                self.framing.drop_bytes(2 + q);
                start += 2 + q;
                continue;
            }
            self.values.clear();
            for k in 0..self.config.parameters.len() {
                let raw = u16::from_le_bytes([avail[2 + 2 * k], avail[3 + 2 * k]]);
                self.values.push(f64::from(raw) / 10.0);
            }
            start += len;
            self.emit(len, arrival_us, out);
        }
        self.framing.buf.drain(..start);
    }

    fn push_ascii(&mut self, arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        let mut start = 0;
        while let Some(nl) = self.framing.buf[start..].iter().position(|&b| b == b'\n') {
            let line_len = nl + 1;
            if self.skip_line {
                self.skip_line = false;
                self.framing.drop_bytes(line_len);
                start += line_len;
                continue;
            }
            let line = &self.framing.buf[start..start + nl];
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            if line.iter().all(|b| b.is_ascii_whitespace()) {
                // Blank line: tolerated spacing, not a record.
                start += line_len;
                continue;
            }
            self.values.clear();
            let ok = parse_ascii(line, self.config.parameters.len(), &mut self.values);
            start += line_len;
            if ok {
                self.emit(line_len, arrival_us, out);
            } else {
                self.framing.drop_bytes(line_len);
            }
        }
        self.framing.buf.drain(..start);
        if self.framing.buf.len() > MAX_LINE {
            let n = self.framing.buf.len();
            self.framing.drop_bytes(n);
            self.framing.buf.clear();
            self.skip_line = true;
        }
    }
}

/// Parses exactly `n` whitespace-separated finite numbers.
fn parse_ascii(line: &[u8], n: usize, values: &mut Vec<f64>) -> bool {
    let Ok(text) = std::str::from_utf8(line) else {
        return false;
    };
    for field in text.split_ascii_whitespace() {
        match field.parse::<f64>() {
            Ok(v) if v.is_finite() && values.len() < n => values.push(v),
            _ => return false,
        }
    }
    values.len() == n
}

impl Decoder for IscanDecoder {
    fn push(&mut self, bytes: &[u8], arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        self.framing.accept(bytes);
        match self.config.mode {
            IscanMode::Binary => self.push_binary(arrival_us, out),
            IscanMode::Ascii => self.push_ascii(arrival_us, out),
        }
    }

    fn finish(&mut self) {
        self.framing.finish();
    }

    fn stats(&self) -> DecodeStats {
        self.framing.stats
    }

    fn start_command(&self) -> Vec<u8> {
        vec![self.config.start_command]
    }

    fn stop_command(&self) -> Vec<u8> {
        vec![self.config.stop_command]
    }

    fn device_clock(&self) -> DeviceClock {
        DeviceClock::Counter {
            period_us: self.config.period_us(),
        }
    }
}

/// Encodes one binary record (the simulator's and the tests' encoder).
/// Values are rounded to tenths; `None` or out-of-u16 values become 0xFFFF.
pub fn encode_binary(values: &[Option<f64>]) -> Vec<u8> {
    let mut rec = HEADER.to_vec();
    for v in values {
        let raw = v
            .map(|v| (v * 10.0).round())
            .filter(|t| (0.0..65535.0).contains(t))
            .map_or(0xFFFF, |t| t as u16);
        rec.extend_from_slice(&raw.to_le_bytes());
    }
    rec
}

/// Encodes one ASCII record: values with one decimal, space separated, CR LF.
/// `None` becomes `999.9` (outside any 512 frame).
pub fn encode_ascii(values: &[Option<f64>]) -> Vec<u8> {
    let fields: Vec<String> = values
        .iter()
        .map(|v| format!("{:.1}", v.unwrap_or(999.9)))
        .collect();
    let mut rec = fields.join(" ").into_bytes();
    rec.extend_from_slice(b"\r\n");
    rec
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::decode_all;

    fn cfg(mode: IscanMode) -> IscanConfig {
        IscanConfig::binocular(mode)
    }

    #[test]
    fn binary_record_decodes_tenths() {
        let rec = encode_binary(&[Some(100.5), Some(200.0), Some(101.0), Some(199.9)]);
        let s = decode_all(
            &mut IscanDecoder::new(cfg(IscanMode::Binary)),
            &rec,
            1_000_000,
        );
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].left.position, Some([100.5, 200.0]));
        assert_eq!(s[0].right.position, Some([101.0, 199.9]));
        // The first record of a connection starts the device clock.
        assert_eq!(s[0].device_time_us, Some(0));
    }

    #[test]
    fn garbage_before_a_record_is_dropped_and_counted() {
        let mut bytes = vec![0x01, 0x44, 0x02, 0x03];
        bytes.extend(encode_binary(&[Some(1.0), Some(2.0), Some(3.0), Some(4.0)]));
        let mut d = IscanDecoder::new(cfg(IscanMode::Binary));
        let s = decode_all(&mut d, &bytes, 0);
        assert_eq!(s.len(), 1);
        assert_eq!(d.stats().dropped_bytes, 4);
        assert_eq!(d.stats().resyncs, 1);
    }

    #[test]
    fn a_truncated_record_resyncs_on_the_next_header() {
        let a = encode_binary(&[Some(1.0), Some(2.0), Some(3.0), Some(4.0)]);
        let b = encode_binary(&[Some(5.0), Some(6.0), Some(7.0), Some(8.0)]);
        let mut bytes = a[..6].to_vec();
        bytes.extend(&b);
        let mut d = IscanDecoder::new(cfg(IscanMode::Binary));
        let s = decode_all(&mut d, &bytes, 0);
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].left.position, Some([5.0, 6.0]));
        assert_eq!(d.stats().dropped_bytes, 6);
    }

    #[test]
    fn out_of_frame_values_are_missing_eyes_not_clamped() {
        let rec = encode_binary(&[Some(600.0), Some(10.0), None, Some(3.0)]);
        let mut d = IscanDecoder::new(cfg(IscanMode::Binary));
        let s = decode_all(&mut d, &rec, 0);
        assert_eq!(s[0].left.position, None);
        assert_eq!(s[0].right.position, None);
        assert_eq!(d.stats().invalid_values, 2);
        assert_eq!(s[0].gaze(), None);
    }

    #[test]
    fn ascii_tolerates_spacing_and_drops_bad_lines() {
        let text = b"  100.5\t200.0  101.0 199.9\r\n\r\nabc def\r\n1 2 3\r\n1 2 3 4\n";
        let mut d = IscanDecoder::new(cfg(IscanMode::Ascii));
        let s = decode_all(&mut d, text, 0);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].left.position, Some([100.5, 200.0]));
        assert_eq!(s[1].right.position, Some([3.0, 4.0]));
        assert_eq!(
            d.stats().dropped_bytes,
            (b"abc def\r\n".len() + b"1 2 3\r\n".len()) as u64
        );
    }

    #[test]
    fn records_split_across_reads_decode_once() {
        let rec = encode_binary(&[Some(1.0), Some(2.0), Some(3.0), Some(4.0)]);
        let mut d = IscanDecoder::new(cfg(IscanMode::Binary));
        let mut out = VecDeque::new();
        for (i, b) in rec.iter().enumerate() {
            d.push(&[*b], i as u64, &mut out);
        }
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].host_time_us, 9);
        assert_eq!(d.stats().dropped_bytes, 0);
    }

    #[test]
    fn markers_and_commands() {
        assert_eq!(marker_byte(5).unwrap(), 5);
        assert_eq!(marker_byte(200).unwrap_err().kind, ErrorKind::Unsupported);
        let mut c = cfg(IscanMode::Binary);
        c.start_command = 0x10;
        assert_eq!(c.validate().unwrap_err().0, "start_command");
    }

    /// The derived device clock against the simulator's truth: every
    /// decoded record's device time is its true capture time since the
    /// first record, exactly, whatever the host's read timing, with records
    /// truncated by lost bytes, records whose first bytes were lost and
    /// records corrupted into garbage (binary and ASCII).
    #[test]
    fn the_record_counter_clock_matches_the_simulators_truth() {
        use crate::sim::{gaze_script, simulate_iscan, Script};
        use rand::{Rng, SeedableRng};
        for (mode, rate) in [
            (IscanMode::Binary, 60.0),
            (IscanMode::Ascii, 60.0),
            (IscanMode::Binary, 240.0),
        ] {
            let mut config = cfg(mode);
            config.rate_hz = rate;
            let truth = gaze_script(&Script {
                seconds: 20.0,
                rate_hz: rate,
                frame: (512.0, 512.0),
                units_per_degree: 12.0,
                seed: 5,
            });
            let sim = simulate_iscan(&config, &truth, 5);
            // Reassemble the records (each is 1–3 chunks) and damage them.
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
            let mut bytes = Vec::new();
            let mut kept = Vec::new();
            let mut rec = Vec::new();
            let mut k = 0usize;

            for c in &sim.chunks {
                rec.extend_from_slice(&c.payload);
                let complete = match mode {
                    IscanMode::Binary => rec.len() == config.record_len(),
                    IscanMode::Ascii => rec.ends_with(b"\n"),
                };
                if !complete {
                    continue;
                }
                let r: f64 = rng.random();
                let n = rec.len();
                // Damage never hits two records in a row: a truncated record
                // followed by one whose header is gone cannot be told from
                // one record with bad values (the format has no length or
                // checksum), and decodes as such.
                // Nor a binary record with a payload byte 0x44 (a value's low
                // byte): a piece of it beside a header is a header too.
                let ambiguous = mode == IscanMode::Binary && rec[2..].contains(&HEADER[0]);
                let r = if kept.last() == Some(&(k.wrapping_sub(1))) && !ambiguous {
                    r
                } else {
                    1.0
                };
                if k > 0 && r < 0.03 && mode == IscanMode::Binary {
                    // Truncated: its last bytes lost on the line.
                    bytes.extend_from_slice(&rec[..rng.random_range(2..n - 1)]);
                } else if k > 0 && r < 0.06 {
                    // Its first bytes lost (the header, or part of a line).
                    // (Binary: the whole header, so that the payload's low
                    // bytes, which may be 0x44, cannot join what is left of
                    // it into a header — an ambiguity of the format itself.)
                    let from = match mode {
                        IscanMode::Binary => rng.random_range(2..n - 1),
                        // (ASCII: at least the first value, or the tail could
                        // parse as a record with a wrong first value.)
                        IscanMode::Ascii => {
                            let sep = rec
                                .iter()
                                .position(|b| *b == b' ' || *b == b'\t')
                                .unwrap_or(1);
                            rng.random_range(sep + 1..n - 2)
                        }
                    };
                    bytes.extend_from_slice(&rec[from..]);
                } else if k > 0 && r < 0.09 {
                    // Corrupted into garbage: a header byte or a digit hit.
                    let mut bad = rec.clone();
                    bad[0] = b'x';
                    bad[1] = b'#';
                    bytes.extend_from_slice(&bad);
                } else {
                    bytes.extend_from_slice(&rec);
                    kept.push(k);
                }
                rec.clear();
                k += 1;
            }
            // Keep the first record so the clock starts at the truth's first.
            assert_eq!(kept[0], 0);
            let got = decode_all(&mut IscanDecoder::new(config.clone()), &bytes, 0);
            assert_eq!(got.len(), kept.len(), "{mode:?}");
            for (g, &k) in got.iter().zip(&kept) {
                assert_eq!(
                    g.device_time_us,
                    Some(truth[k].t_us - truth[0].t_us),
                    "{mode:?} {rate} Hz record {k}"
                );
            }
        }
    }
}
