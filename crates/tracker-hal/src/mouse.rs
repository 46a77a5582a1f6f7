//! Mouse-emulated gaze: a simulated tracker that behaves like a real one
//! (PsychoPy iohub's MouseGaze idea), for development without a tracker.
//!
//! The *device* ([`MouseEmulator`], run on its own thread by [`spawn_device`])
//! samples the cursor at a fixed rate (default 120 Hz) and writes one binary
//! record per sample to a byte stream, exactly like a serial tracker; the
//! *driver* is the ordinary [`StreamDriver`](crate::StreamDriver) with
//! [`MouseDecoder`]. Recording and replay therefore work the same as for ISCAN.
//!
//! Optional realism, all off by default and deterministic for a given seed:
//! fixation jitter (Gaussian, RMS in degrees), saccades that follow the main
//! sequence when the cursor jumps (duration
//! [`main_sequence_duration_ms`](crate::sim::main_sequence_duration_ms),
//! 2.2·amplitude_deg + 21 ms after Carpenter 1988, as PsychoPy's MouseGaze
//! models it), added latency, and blinks (a held button makes both eyes
//! invalid).
//!
//! Record (23 bytes, little-endian): `47 5A` ("GZ"), device time µs (u64),
//! flags (u8, bit 0 = valid), x px (f32), y px (f32), CRC-32 of the 17 bytes
//! after the header (u32). Host → device: `0x01` start, `0x02` stop.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::framing::Framing;
use crate::sample::{DecodeStats, EyeSample, GazeSample};
use crate::source::Decoder;

/// Start of every record: `GZ`.
pub const HEADER: [u8; 2] = [0x47, 0x5A];
/// Length of one record, bytes.
pub const RECORD_LEN: usize = 23;
/// Host-to-device command: start streaming.
pub const START: u8 = 0x01;
/// Host-to-device command: stop streaming.
pub const STOP: u8 = 0x02;

/// Mouse-emulation settings (`config/trackers/mouse.ron`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MouseConfig {
    /// Samples per second.
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Screen pixels per degree, to convert the degree settings below.
    #[serde(default = "default_ppd")]
    pub pixels_per_degree: f64,
    /// RMS fixation jitter in degrees (0 = none).
    #[serde(default)]
    pub jitter_rms_deg: f64,
    /// Move the gaze with main-sequence saccades when the cursor jumps.
    #[serde(default)]
    pub saccades: bool,
    /// Cursor jumps of at least this amplitude (degrees) become saccades.
    #[serde(default = "default_saccade_threshold")]
    pub saccade_threshold_deg: f64,
    /// Added latency between the cursor and the reported gaze, ms.
    #[serde(default)]
    pub latency_ms: f64,
    /// Seed for the jitter.
    #[serde(default)]
    pub seed: u64,
}

fn default_rate() -> f64 {
    120.0
}
fn default_ppd() -> f64 {
    35.7
}
fn default_saccade_threshold() -> f64 {
    1.0
}

impl Default for MouseConfig {
    fn default() -> Self {
        Self {
            rate_hz: default_rate(),
            pixels_per_degree: default_ppd(),
            jitter_rms_deg: 0.0,
            saccades: false,
            saccade_threshold_deg: default_saccade_threshold(),
            latency_ms: 0.0,
            seed: 0,
        }
    }
}

impl MouseConfig {
    /// Checks the settings; the error names the field and says why.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let positive = |f: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((f, format!("{v} must be a positive number")))
            }
        };
        let non_negative = |f: &'static str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err((f, format!("{v} must be zero or positive")))
            }
        };
        positive("rate_hz", self.rate_hz)?;
        positive("pixels_per_degree", self.pixels_per_degree)?;
        non_negative("jitter_rms_deg", self.jitter_rms_deg)?;
        non_negative("saccade_threshold_deg", self.saccade_threshold_deg)?;
        non_negative("latency_ms", self.latency_ms)?;
        Ok(())
    }

    /// Sampling period in µs.
    pub fn period_us(&self) -> u64 {
        (1e6 / self.rate_hz).round().max(1.0) as u64
    }
}

/// What the cursor did, in screen pixels, at host time `t_us`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CursorEvent {
    /// Host time of the event, µs.
    pub t_us: u64,
    /// Cursor position, screen pixels.
    pub position_px: [f64; 2],
    /// A button or key is held: the emulated eyes are closed.
    pub blink: bool,
}

#[derive(Debug, Clone, Copy)]
struct Saccade {
    from: [f64; 2],
    to: [f64; 2],
    start_us: u64,
    duration_us: u64,
}

/// The emulated device: cursor in, records out.
#[derive(Debug, Clone)]
pub struct MouseEmulator {
    config: MouseConfig,
    history: VecDeque<CursorEvent>,
    /// The cursor event the eye is following now, for the jitter's key.
    current: Option<CursorEvent>,
    eye: Option<[f64; 2]>,
    saccade: Option<Saccade>,
}

impl MouseEmulator {
    /// An emulator with `config`, before any cursor event.
    pub fn new(config: MouseConfig) -> Self {
        Self {
            config,
            history: VecDeque::new(),
            current: None,
            eye: None,
            saccade: None,
        }
    }

    /// Its settings.
    pub fn config(&self) -> &MouseConfig {
        &self.config
    }

    /// The cursor moved (or a button changed). Events must come in time order.
    pub fn cursor(&mut self, event: CursorEvent) {
        self.history.push_back(event);
    }

    /// The gaze point (before jitter) and validity at device time `t_us`.
    fn state_at(&mut self, t_us: u64) -> Option<[f64; 2]> {
        let effective = t_us.saturating_sub((self.config.latency_ms * 1000.0).round() as u64);
        while self.history.len() > 1 && self.history[1].t_us <= effective {
            self.history.pop_front();
        }
        let cursor = *self.history.front().filter(|e| e.t_us <= effective)?;
        self.current = Some(cursor);
        let target = cursor.position_px;
        let eye = match self.saccade {
            Some(sac) if sac.to == target => {
                if effective < sac.start_us + sac.duration_us {
                    // Raised-cosine position profile: smooth start and end.
                    let p = effective.saturating_sub(sac.start_us) as f64 / sac.duration_us as f64;
                    let k = crate::sim::saccade_profile(p);
                    [
                        sac.from[0] + (sac.to[0] - sac.from[0]) * k,
                        sac.from[1] + (sac.to[1] - sac.from[1]) * k,
                    ]
                } else {
                    self.saccade = None;
                    target
                }
            }
            _ => {
                // The target changed (or nothing was moving): jump, or start a
                // saccade from wherever the eye is now.
                self.saccade = None;
                match self.eye {
                    Some(from) if self.config.saccades && from != target => {
                        let amplitude_deg = (target[0] - from[0]).hypot(target[1] - from[1])
                            / self.config.pixels_per_degree;
                        if amplitude_deg >= self.config.saccade_threshold_deg {
                            let duration_us = (crate::sim::main_sequence_duration_ms(amplitude_deg)
                                * 1000.0) as u64;
                            // The saccade starts when the cursor moved, not
                            // at the first tick after: the eye's path is
                            // the same whatever the sampling phase.
                            let start_us = cursor.t_us.min(effective);
                            self.saccade = Some(Saccade {
                                from,
                                to: target,
                                start_us,
                                duration_us,
                            });
                            let p = effective.saturating_sub(start_us) as f64
                                / duration_us.max(1) as f64;
                            if p >= 1.0 {
                                self.saccade = None;
                                target
                            } else {
                                let k = crate::sim::saccade_profile(p);
                                [
                                    from[0] + (target[0] - from[0]) * k,
                                    from[1] + (target[1] - from[1]) * k,
                                ]
                            }
                        } else {
                            target
                        }
                    }
                    _ => target,
                }
            }
        };
        self.eye = Some(eye);
        if cursor.blink {
            None
        } else {
            self.eye
        }
    }

    /// The jitter's random source for the sample at `t_us`: keyed by the
    /// seed, the cursor event the eye follows and the sample's index since
    /// it (its period of the nominal rate), never by how many samples came
    /// before. A simulated participant whose looks are dated by a plan so
    /// gets the same eye, noise included, on a quiet and on a loaded
    /// machine, whenever the session's earlier screens ended.
    fn jitter_rng(&self, t_us: u64) -> ChaCha8Rng {
        let (event_t, [x, y]) = self
            .current
            .map_or((0, [0.0, 0.0]), |c| (c.t_us, c.position_px));
        let period_us = 1e6 / self.config.rate_hz.max(1e-3);
        let effective = t_us.saturating_sub((self.config.latency_ms * 1000.0).round() as u64);
        let k = (effective.saturating_sub(event_t) as f64 / period_us).floor() as u64;
        let mut key = self.config.seed ^ 0x9E37_79B9_7F4A_7C15;
        for word in [event_t, x.to_bits(), y.to_bits(), k] {
            key = (key ^ word)
                .wrapping_mul(0xBF58_476D_1CE4_E5B9)
                .rotate_left(31);
        }
        ChaCha8Rng::seed_from_u64(key)
    }

    /// Samples the emulated eye at device time `t_us` and encodes the record.
    pub fn tick(&mut self, t_us: u64) -> [u8; RECORD_LEN] {
        let state = self.state_at(t_us);
        let point = state.map(|p| {
            if self.config.jitter_rms_deg > 0.0 {
                // RMS of the 2-D displacement = jitter → σ per axis = rms/√2.
                let sigma = self.config.jitter_rms_deg * self.config.pixels_per_degree
                    / std::f64::consts::SQRT_2;
                let n = Normal::new(0.0, sigma)
                    .unwrap_or_else(|_| unreachable!("sigma is finite and positive"));
                let mut rng = self.jitter_rng(t_us);
                [p[0] + n.sample(&mut rng), p[1] + n.sample(&mut rng)]
            } else {
                p
            }
        });
        encode_record(t_us, point.map(|p| [p[0] as f32, p[1] as f32]))
    }
}

/// Encodes one mouse record.
pub fn encode_record(device_time_us: u64, point: Option<[f32; 2]>) -> [u8; RECORD_LEN] {
    let mut r = [0u8; RECORD_LEN];
    r[..2].copy_from_slice(&HEADER);
    r[2..10].copy_from_slice(&device_time_us.to_le_bytes());
    let p = point.unwrap_or([0.0, 0.0]);
    r[10] = u8::from(point.is_some());
    r[11..15].copy_from_slice(&p[0].to_le_bytes());
    r[15..19].copy_from_slice(&p[1].to_le_bytes());
    let crc = crc32fast::hash(&r[2..19]);
    r[19..23].copy_from_slice(&crc.to_le_bytes());
    r
}

/// Decodes mouse records; resynchronises on the header, rejects bad CRCs.
#[derive(Debug, Clone)]
pub struct MouseDecoder {
    framing: Framing,
}

impl MouseDecoder {
    /// A decoder waiting for a header.
    pub fn new() -> Self {
        Self {
            framing: Framing::new(),
        }
    }
}

impl Default for MouseDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder for MouseDecoder {
    fn push(&mut self, bytes: &[u8], arrival_us: u64, out: &mut VecDeque<GazeSample>) {
        self.framing.accept(bytes);
        let mut start = 0;
        while self.framing.seek_record(&mut start, HEADER, RECORD_LEN) {
            let r = &self.framing.buf[start..start + RECORD_LEN];
            let crc = u32::from_le_bytes([r[19], r[20], r[21], r[22]]);
            if crc32fast::hash(&r[2..19]) != crc || r[10] > 1 {
                // Not a record after all: skip this header byte and look again.
                self.framing.drop_bytes(1);
                start += 1;
                continue;
            }
            let t = u64::from_le_bytes([r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9]]);
            let x = f32::from_le_bytes([r[11], r[12], r[13], r[14]]);
            let y = f32::from_le_bytes([r[15], r[16], r[17], r[18]]);
            let valid = r[10] == 1 && x.is_finite() && y.is_finite();
            if r[10] == 1 && !valid {
                self.framing.stats.invalid_values += 1;
            }
            let eye = if valid {
                EyeSample {
                    position: Some([f64::from(x), f64::from(y)]),
                    pupil: None,
                }
            } else {
                EyeSample::MISSING
            };
            let seq = self.framing.record();
            out.push_back(GazeSample {
                seq,
                device_time_us: Some(t),
                host_time_us: arrival_us,
                mapped_time_us: arrival_us,
                time_order: crate::timing::TimeOrder::Unmapped,
                clock_segment: 0,
                left: eye,
                right: eye,
                combined: None,
                eye_position_um: [None, None],
            });
            start += RECORD_LEN;
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
        vec![START]
    }

    fn stop_command(&self) -> Vec<u8> {
        vec![STOP]
    }
}

/// The host end of a running mouse device: read records, write commands.
pub struct MouseLink {
    reader: std::io::PipeReader,
    commands: Sender<u8>,
    timing: Arc<DeviceTiming>,
}

/// What the device thread's schedule went through.
#[derive(Debug, Default)]
struct DeviceTiming {
    late: AtomicU64,
    skipped: AtomicU64,
}

/// A handle on a running mouse device's schedule counts (clones share).
#[derive(Debug, Clone)]
pub struct MouseTiming(Arc<DeviceTiming>);

impl MouseTiming {
    /// Ticks the device thread ran late for (one period or more after
    /// their scheduled time): each was still sampled at its scheduled
    /// device time, and the schedule kept.
    pub fn late_ticks(&self) -> u64 {
        self.0.late.load(Ordering::Relaxed)
    }

    /// Periods skipped because the thread was stalled for longer than
    /// [`MAX_CATCH_UP`] (a device would have overflowed its buffer).
    pub fn skipped_ticks(&self) -> u64 {
        self.0.skipped.load(Ordering::Relaxed)
    }
}

impl MouseLink {
    /// The device's schedule counts, readable after the link has moved
    /// into a driver.
    pub fn timing(&self) -> MouseTiming {
        MouseTiming(self.timing.clone())
    }
}

impl Read for MouseLink {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.reader.read(buf)
    }
}

impl Write for MouseLink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        for &b in buf {
            self.commands.send(b).map_err(|_| {
                std::io::Error::new(
                    std::io::ErrorKind::BrokenPipe,
                    "the mouse device has stopped",
                )
            })?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The longest stall the emulated device catches up on (its buffer):
/// beyond it the missed periods are skipped and counted.
pub const MAX_CATCH_UP: Duration = Duration::from_secs(1);

/// The device's fixed schedule: tick *k* is due at `start + k·period`.
/// [`Schedule::due`] gives every tick due by `now`, one per period, each
/// with its own scheduled time — a late thread samples the cursor at the
/// times it missed instead of ticking twice for one period or shifting
/// the schedule.
#[derive(Debug, Clone)]
pub struct Schedule {
    start_us: u64,
    period_us: u64,
    next: u64,
}

impl Schedule {
    /// Ticks every `period_us` (at least 1) from `start_us` (host µs).
    pub fn new(start_us: u64, period_us: u64) -> Self {
        Self {
            start_us,
            period_us: period_us.max(1),
            next: 0,
        }
    }

    /// The scheduled time of the next tick.
    pub fn next_us(&self) -> u64 {
        self.start_us + self.next * self.period_us
    }

    /// The ticks due at `now_us`, oldest first: (scheduled time, late).
    /// At most `max_catch_up_us` worth of ticks; older ones are skipped
    /// (returned count in the second value).
    pub fn due(&mut self, now_us: u64, max_catch_up_us: u64) -> (Vec<(u64, bool)>, u64) {
        let mut skipped = 0;
        let oldest = now_us.saturating_sub(max_catch_up_us);
        if self.next_us() < oldest {
            let k = (oldest - self.start_us).div_ceil(self.period_us);
            skipped = k - self.next;
            self.next = k;
        }
        let mut out = Vec::new();
        while self.next_us() <= now_us {
            let t = self.next_us();
            out.push((t, now_us - t >= self.period_us));
            self.next += 1;
        }
        (out, skipped)
    }
}

/// Runs a [`MouseEmulator`] on its own thread, sampling at the configured
/// rate while started. Cursor events come from `cursor` (the viewer's window
/// thread); when that channel closes the device stops and the link reads end
/// of stream. Device time is host monotonic time: each record carries its
/// tick's *scheduled* time on a fixed schedule ([`Schedule`]), whatever the
/// thread's own delays.
pub fn spawn_device(
    config: MouseConfig,
    cursor: Receiver<CursorEvent>,
) -> std::io::Result<MouseLink> {
    let (reader, mut writer) = std::io::pipe()?;
    let (commands, command_rx) = crossbeam_channel::unbounded::<u8>();
    let period_us = config.period_us();
    let timing = Arc::new(DeviceTiming::default());
    let t = timing.clone();
    std::thread::Builder::new()
        .name("mouse-gaze".into())
        .spawn(move || {
            let mut emulator = MouseEmulator::new(config);
            let mut schedule: Option<Schedule> = None;
            let catch_up = MAX_CATCH_UP.as_micros() as u64;
            loop {
                for c in command_rx.try_iter() {
                    match c {
                        START => {
                            schedule.get_or_insert_with(|| {
                                Schedule::new(crate::clock::monotonic_us(), period_us)
                            });
                        }
                        STOP => schedule = None,
                        _ => {}
                    }
                }
                loop {
                    match cursor.try_recv() {
                        Ok(e) => emulator.cursor(e),
                        Err(crossbeam_channel::TryRecvError::Empty) => break,
                        Err(crossbeam_channel::TryRecvError::Disconnected) => return,
                    }
                }
                let now = crate::clock::monotonic_us();
                let next = match &mut schedule {
                    Some(s) => {
                        let (ticks, skipped) = s.due(now, catch_up);
                        t.skipped.fetch_add(skipped, Ordering::Relaxed);
                        let mut bytes = Vec::with_capacity(ticks.len() * RECORD_LEN);
                        for (at, late) in ticks {
                            t.late.fetch_add(u64::from(late), Ordering::Relaxed);
                            bytes.extend_from_slice(&emulator.tick(at));
                        }
                        if !bytes.is_empty() && writer.write_all(&bytes).is_err() {
                            return; // the driver is gone
                        }
                        s.next_us()
                    }
                    None => now + period_us,
                };
                let now = crate::clock::monotonic_us();
                if next > now {
                    std::thread::sleep(Duration::from_micros(next - now));
                }
            }
        })?;
    Ok(MouseLink {
        reader,
        commands,
        timing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::decode_all;

    fn at(t_ms: u64, x: f64, y: f64) -> CursorEvent {
        CursorEvent {
            t_us: t_ms * 1000,
            position_px: [x, y],
            blink: false,
        }
    }

    proptest::proptest! {
        /// However late and irregular the thread wakes (stalls up to 2 s),
        /// the device ticks once per period at its scheduled time: never
        /// two ticks for one period, never a shifted schedule; a stall
        /// beyond the catch-up bound skips (and counts) the oldest periods.
        #[test]
        fn the_schedule_ticks_once_per_period_at_its_time(
            period in 1_000u64..20_000,
            wakes in proptest::collection::vec(0u64..2_000_000, 1..200),
        ) {
            let mut s = Schedule::new(5_000, period);
            let mut now = 5_000;
            let mut times = Vec::new();
            let mut skipped = 0;
            for w in wakes {
                now += w;
                let (due, sk) = s.due(now, 1_000_000);
                skipped += sk;
                for (t, late) in due {
                    proptest::prop_assert!(t <= now);
                    proptest::prop_assert_eq!(late, now - t >= period);
                    proptest::prop_assert!(now - t <= 1_000_000 + period);
                    times.push(t);
                }
            }
            // Every scheduled time up to now, once, except the skipped ones.
            let expected = (now - 5_000) / period + 1;
            proptest::prop_assert_eq!(times.len() as u64 + skipped, expected);
            for w in times.windows(2) {
                proptest::prop_assert!(w[1] > w[0]);
                proptest::prop_assert_eq!((w[1] - 5_000) % period, 0);
            }
        }
    }

    #[test]
    fn records_round_trip() {
        let mut bytes = encode_record(5, Some([1.5, 2.25])).to_vec();
        bytes.extend(encode_record(6, None));
        let s = decode_all(&mut MouseDecoder::new(), &bytes, 9);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].gaze(), Some([1.5, 2.25]));
        assert_eq!(s[0].device_time_us, Some(5));
        assert_eq!(s[1].gaze(), None);
    }

    #[test]
    fn a_corrupt_record_is_skipped() {
        let mut a = encode_record(5, Some([1.0, 2.0])).to_vec();
        a[12] ^= 0x10;
        a.extend(encode_record(6, Some([3.0, 4.0])));
        let mut d = MouseDecoder::new();
        let s = decode_all(&mut d, &a, 0);
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].gaze(), Some([3.0, 4.0]));
        assert_eq!(d.stats().dropped_bytes, RECORD_LEN as u64);
    }

    #[test]
    fn saccade_follows_the_main_sequence() {
        let cfg = MouseConfig {
            saccades: true,
            pixels_per_degree: 10.0,
            ..MouseConfig::default()
        };
        let mut m = MouseEmulator::new(cfg);
        m.cursor(at(0, 0.0, 0.0));
        m.cursor(at(100, 100.0, 0.0)); // a 10° jump: 2.2·10 + 21 = 43 ms
        let x = |m: &mut MouseEmulator, t_ms: u64| {
            let r = m.tick(t_ms * 1000);
            f64::from(f32::from_le_bytes([r[11], r[12], r[13], r[14]]))
        };
        assert_eq!(x(&mut m, 50), 0.0);
        assert_eq!(x(&mut m, 100), 0.0);
        let mid = x(&mut m, 121);
        assert!(mid > 30.0 && mid < 70.0, "{mid}");
        assert!(x(&mut m, 140) < 100.0);
        assert_eq!(x(&mut m, 144), 100.0);
    }

    #[test]
    fn latency_delays_and_blink_invalidates() {
        let cfg = MouseConfig {
            latency_ms: 20.0,
            ..MouseConfig::default()
        };
        let mut m = MouseEmulator::new(cfg);
        m.cursor(at(0, 5.0, 5.0));
        m.cursor(at(10, 50.0, 50.0));
        m.cursor(CursorEvent {
            t_us: 40_000,
            position_px: [50.0, 50.0],
            blink: true,
        });
        let d = |r: [u8; RECORD_LEN]| decode_all(&mut MouseDecoder::new(), &r, 0)[0].gaze();
        assert_eq!(d(m.tick(25_000)), Some([5.0, 5.0]));
        assert_eq!(d(m.tick(30_000)), Some([50.0, 50.0]));
        assert_eq!(d(m.tick(61_000)), None);
    }

    /// The eye follows a dated plan the same way whatever the sampling
    /// phase and however many samples came before: two emulators that
    /// start at different times, one of them a whole second earlier, give
    /// each fixation's k-th sample the same jitter, and a saccade starts
    /// when the cursor moved (a loaded machine changes neither).
    #[test]
    fn a_dated_plan_gives_the_same_eye_at_any_phase_and_history() {
        let config = MouseConfig {
            rate_hz: 120.0,
            pixels_per_degree: 35.7,
            jitter_rms_deg: 0.15,
            saccades: true,
            saccade_threshold_deg: 1.0,
            latency_ms: 12.0,
            seed: 9,
        };
        let plan = [
            (2_000_000u64, [400.0, 300.0]),
            (2_400_000, [900.0, 700.0]),
            (2_900_000, [905.0, 702.0]),
        ];
        let run = |first_us: u64| {
            let mut m = MouseEmulator::new(config.clone());
            m.cursor(CursorEvent {
                t_us: 0,
                position_px: [640.0, 512.0],
                blink: false,
            });
            for (t, p) in plan {
                m.cursor(CursorEvent {
                    t_us: t,
                    position_px: p,
                    blink: false,
                });
            }
            let period = 1e6 / 120.0;
            (0..)
                .map(|n| first_us + (n as f64 * period).round() as u64)
                .take_while(|&t| t < 3_300_000)
                .map(|t| {
                    let r = m.tick(t);
                    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                    (t, [f(&r[11..15]), f(&r[15..19])])
                })
                .collect::<Vec<_>>()
        };
        let a = run(3_000);
        let b = run(1_007_777 - 1_000_000);
        // The k-th sample after each event's effect (latency included).
        let kth = |v: &[(u64, [f32; 2])], event: u64, k: usize| {
            v.iter()
                .filter(|(t, _)| t.saturating_sub(12_000) >= event)
                .nth(k)
                .map(|s| s.1)
        };
        for (event, _) in plan {
            for k in 0..20 {
                let (pa, pb) = (kth(&a, event, k), kth(&b, event, k));
                if event < 2_900_000 && k < 12 {
                    // Inside the saccade the phase moves the sample along
                    // the same path: close, not equal.
                    let (pa, pb) = (pa.expect("a"), pb.expect("b"));
                    let d = (pa[0] - pb[0]).hypot(pa[1] - pb[1]);
                    assert!(d < 150.0, "{event} {k}: {pa:?} {pb:?}");
                    continue;
                }
                assert_eq!(pa, pb, "event {event} sample {k}");
            }
        }
    }

    #[test]
    fn jitter_is_deterministic_for_a_seed_and_has_the_asked_rms() {
        let cfg = MouseConfig {
            jitter_rms_deg: 0.5,
            pixels_per_degree: 40.0,
            seed: 7,
            ..MouseConfig::default()
        };
        let run = || {
            let mut m = MouseEmulator::new(cfg.clone());
            m.cursor(at(0, 100.0, 100.0));
            (1..=4000u64)
                .map(|k| decode_all(&mut MouseDecoder::new(), &m.tick(k * 1000), 0)[0].gaze())
                .collect::<Vec<_>>()
        };
        let a = run();
        assert_eq!(a, run());
        let ms: f64 = a
            .iter()
            .flatten()
            .map(|p| (p[0] - 100.0).powi(2) + (p[1] - 100.0).powi(2))
            .sum::<f64>()
            / 4000.0;
        let rms_deg = ms.sqrt() / 40.0;
        assert!((rms_deg - 0.5).abs() < 0.03, "{rms_deg}");
    }
}
