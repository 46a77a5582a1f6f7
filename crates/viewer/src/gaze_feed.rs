//! The tracker thread shared by `view` and `calibrate`: it runs the driver
//! (a replayed recording at its original pacing, the mouse emulator fed by
//! the window's cursor, an ISCAN on its serial port, or a HID tracker),
//! optionally taps every byte into a recorder, and sends each sample over a
//! `crossbeam-channel` — raw tracker units and mapped screen pixels — never
//! blocking on the window. A device that fails or cannot be opened is
//! reopened with backoff; the window hears about it as a status line.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tracker_hal::calibration::Calibration;
use tracker_hal::clock::monotonic_us;
use tracker_hal::mouse::{spawn_device, CursorEvent, MouseConfig, MouseTiming};
use tracker_hal::{
    ClockState, DecodeStats, DeviceClock, Driver, ErrorKind, GazeSource, MonotonicClock, Pacing,
    Recorder, Recording, RecordingHeader, ReplayTransport, StreamDriver, Tap, TimeOrder,
    TrackerConfig,
};

use crate::config;

/// What the tracker thread tells the window.
#[derive(Debug, Clone)]
pub enum TrackerMsg {
    /// A sample with its three times (tracker-hal `timing`), raw tracker
    /// units and mapped screen pixels (`None` for both when invalid, e.g.
    /// a blink, or outside a calibration's domain).
    Gaze {
        /// This process's host monotonic clock (µs) when the tracker thread
        /// passed the sample on.
        received_us: u64,
        /// The tracker's own timestamp as decoded (µs, tracker clock).
        device_us: Option<u64>,
        /// When the sample's bytes arrived (µs, the source's host clock:
        /// the recorded one in a replay).
        arrival_us: u64,
        /// The device time mapped onto that host clock (µs): the sample's
        /// time for events, procedures and files.
        mapped_us: u64,
        /// How the device time stands against the previous sample's.
        time_order: TimeOrder,
        /// The clock segment (a device clock reset starts a new one).
        segment: u32,
        raw: Option<[f64; 2]>,
        gaze_px: Option<[f64; 2]>,
        /// The left and right eyes' points of regard, screen pixels, when
        /// the device measures two eyes (not the mouse or the attention
        /// source), the sample has both valid and both map onto the
        /// screen's neighbourhood (for vergence); `None` otherwise.
        eyes_px: Option<[[f64; 2]; 2]>,
        /// The eyes' distance from the screen plane (mm): the mean z of the
        /// eye positions the device reports (HID trackers; the tracker sits
        /// in the screen plane), when plausible
        /// ([`pipeline::EYE_DISTANCE_RANGE_MM`]); `None` otherwise.
        eye_distance_mm: Option<f64>,
    },
    /// The tracker's clock model was updated (offset, drift, corrections),
    /// with how the device times are obtained.
    Clock(ClockState, DeviceClock),
    /// A status line (disconnect, reconnect, end of recording); empty when
    /// the tracker is streaming again.
    Status(String),
}

type Source = Box<dyn GazeSource + Send>;

/// Opens the configured tracker (again, after a failure).
type Opener = Box<dyn FnMut() -> Result<Source, String> + Send>;

/// Raw tracker units to screen pixels.
type Map = Box<dyn Fn([f64; 2]) -> Option<[f64; 2]> + Send>;

/// Silence after which the status line says so.
const SILENT_REPORT: Duration = Duration::from_millis(500);
/// Silence after which a live device is closed and reopened.
const SILENT_RECONNECT: Duration = Duration::from_secs(2);
/// Bytes arriving without a record for this long: wrong baud or format.
const UNDECODED_REPORT: Duration = Duration::from_secs(1);
/// The longest one device read may block the tracker thread: serial read
/// timeout, replay pacing wait.
const READ_TIMEOUT: Duration = Duration::from_millis(100);
/// The longest one `next_sample` call reads bytes that decode to nothing.
const MAX_WAIT: Duration = Duration::from_millis(200);
/// How long [`GazeFeed::finish`] waits for the thread before detaching it.
const JOIN_WAIT: Duration = Duration::from_millis(500);
/// Minimum time between two status lines about off-screen gaze.
const FAR_REPORT_EVERY: Duration = Duration::from_secs(1);

/// What went wrong with the gaze during a session, counted by the tracker
/// thread and read by the window for the session log.
#[derive(Debug, Clone, Default)]
pub struct Faults {
    /// Samples the thread got.
    pub samples: u64,
    /// Samples without a gaze from the tracker (blinks, invalid values).
    pub missing: u64,
    /// Samples whose mapped gaze was not finite or more than one screen
    /// diagonal outside the screen: marked invalid.
    pub far: u64,
    /// Stretches of at least 0.5 s with no record, and the longest (s).
    pub silences: u64,
    pub longest_silence_s: f64,
    /// Stretches of at least 1 s in which bytes arrived but no record
    /// decoded (wrong baud or format).
    pub undecoded: u64,
    /// Times the device was closed and reopened.
    pub reconnects: u64,
    /// Decoder totals over every connection of the session.
    pub decode: DecodeStats,
}

/// The capture time of a sample on this process's clock (µs): when it
/// was received, less how long after its mapped capture time it arrived
/// (the delivery delay, which a replay records too). Gaze age counts from
/// here, so the tracker's own latency shows where it reports it.
pub fn capture_us(received_us: u64, arrival_us: u64, mapped_us: u64) -> u64 {
    received_us.saturating_sub(arrival_us.saturating_sub(mapped_us))
}

impl Faults {
    /// The session log's lines.
    pub fn lines(&self) -> Vec<String> {
        let d = &self.decode;
        vec![
            format!(
                "tracker: {} samples, {} far off the screen or not finite (marked invalid), {} without a gaze (blinks, invalid values)",
                self.samples, self.far, self.missing
            ),
            format!(
                "tracker decode: {} bytes, {} records, {} bytes dropped, {} resyncs, {} invalid values",
                d.bytes, d.records, d.dropped_bytes, d.resyncs, d.invalid_values
            ),
            format!(
                "tracker silences: {} (longest {:.1} s), {} stretches of bytes that did not decode, {} reconnects",
                self.silences, self.longest_silence_s, self.undecoded, self.reconnects
            ),
        ]
    }
}

fn lock(f: &Mutex<Faults>) -> std::sync::MutexGuard<'_, Faults> {
    f.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// What the tracker thread was given.
struct ThreadCtx {
    /// The recording's tap, watched for a write error to report at once.
    recording: Option<Tap>,
    map: Map,
    screen_px: Option<[f64; 2]>,
    tx: Sender<TrackerMsg>,
    stop: Arc<AtomicBool>,
    ends: bool,
    faults: Arc<Mutex<Faults>>,
    /// The device measures two eyes (not the mouse or the attention
    /// source, whose decoder copies one point into both): only then are
    /// both eyes' points passed on for vergence.
    binocular: bool,
}

/// Runs a tracker until `stop`: samples to `tx`, reopening with backoff
/// (0.25 s doubling to 4 s) when the device fails or stays silent for 2 s;
/// a replay ends at its end. Every device read is bounded in time (serial
/// read timeout, replay pacing in slices, the driver's maximum wait for a
/// record), so `stop` is seen within a fraction of a second.
fn tracker_thread(mut open: Opener, ctx: ThreadCtx) {
    let ThreadCtx {
        recording,
        map,
        screen_px,
        tx,
        stop,
        ends,
        binocular,
        faults,
    } = ctx;
    let mut backoff = Duration::from_millis(250);
    // Bytes received since the last record, over reconnects.
    let mut undecoded_bytes = 0u64;
    let mut far_reported: Option<(Instant, u64)> = None;
    let mut first = true;
    // The newest mapped time passed on: a new connection's mapper starts
    // afresh, and its times are shifted (by a constant, so intervals stay)
    // to follow the previous connection's strictly.
    let mut last_mapped: Option<u64> = None;
    let mut recording_failed = false;
    while !stop.load(Ordering::Relaxed) {
        let mut source = match open() {
            Ok(s) => s,
            Err(e) => {
                let _ = tx.send(TrackerMsg::Status(format!(
                    "tracker: {e}; retrying in {:.2} s",
                    backoff.as_secs_f64()
                )));
                // Sleep in short steps so a shutdown is not held up.
                let until = Instant::now() + backoff;
                while Instant::now() < until && !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(20));
                }
                backoff = (backoff * 2).min(Duration::from_secs(4));
                continue;
            }
        };
        if !first {
            lock(&faults).reconnects += 1;
        }
        first = false;
        if let Err(e) = source.start() {
            let _ = tx.send(TrackerMsg::Status(format!("tracker: {e}")));
        }
        let _ = tx.send(TrackerMsg::Status(String::new()));
        backoff = Duration::from_millis(250);
        let opened = Instant::now();
        let mut shift: Option<u64> = None;
        let mut refits = u64::MAX;
        let mut last_record = opened;
        let mut last_byte = opened;
        // When a silence (no byte at all) began, once reported.
        let mut silent: Option<Instant> = None;
        let mut undecoded = false;
        let mut seen_bytes = 0u64;
        let base = lock(&faults).decode;
        let end_silence = |silent: &mut Option<Instant>| {
            if let Some(t) = silent.take() {
                let mut f = lock(&faults);
                f.longest_silence_s = f.longest_silence_s.max(t.elapsed().as_secs_f64());
                true
            } else {
                false
            }
        };
        while !stop.load(Ordering::Relaxed) {
            if let Some(e) = recording.as_ref().and_then(Tap::failure) {
                if !recording_failed {
                    recording_failed = true;
                    let _ = tx.send(TrackerMsg::Status(recording_stopped(&e)));
                }
            }
            let next = source.next_sample();
            let stats = source.stats();
            if stats.bytes > seen_bytes {
                undecoded_bytes += stats.bytes - seen_bytes;
                seen_bytes = stats.bytes;
                last_byte = Instant::now();
                if end_silence(&mut silent) {
                    let _ = tx.send(TrackerMsg::Status(String::new()));
                }
            }
            lock(&faults).decode = base + stats;
            match next {
                Ok(Some(s)) => {
                    last_record = Instant::now();
                    undecoded_bytes = 0;
                    if undecoded {
                        undecoded = false;
                        let _ = tx.send(TrackerMsg::Status(String::new()));
                    }
                    let raw = s.gaze().filter(|p| p[0].is_finite() && p[1].is_finite());
                    let mapped = raw.and_then(&map);
                    let gaze_px =
                        mapped.filter(|&p| tracker_hal::plausibility::plausible(p, screen_px));
                    let eye = |e: &tracker_hal::EyeSample| {
                        e.position
                            .and_then(&map)
                            .filter(|&p| tracker_hal::plausibility::plausible(p, screen_px))
                    };
                    let eyes_px = match (eye(&s.left), eye(&s.right)) {
                        (Some(l), Some(r)) if binocular && gaze_px.is_some() => Some([l, r]),
                        _ => None,
                    };
                    let far = {
                        let mut f = lock(&faults);
                        f.samples += 1;
                        if raw.is_none() {
                            f.missing += 1;
                        }
                        if mapped.is_some() && gaze_px.is_none() {
                            f.far += 1;
                        }
                        f.far
                    };
                    let shift = *shift.get_or_insert_with(|| match last_mapped {
                        Some(l) if s.mapped_time_us <= l => l + 1 - s.mapped_time_us,
                        _ => 0,
                    });
                    let mapped_us = s.mapped_time_us + shift;
                    last_mapped = Some(last_mapped.map_or(mapped_us, |l| l.max(mapped_us)));
                    if let Some(c) = source.clock().filter(|c| c.refits != refits) {
                        refits = c.refits;
                        let _ = tx.send(TrackerMsg::Clock(c, source.device_clock()));
                    }
                    let _ = tx.send(TrackerMsg::Gaze {
                        received_us: monotonic_us(),
                        device_us: s.device_time_us,
                        arrival_us: s.host_time_us,
                        mapped_us,
                        time_order: s.time_order,
                        segment: s.clock_segment,
                        raw,
                        gaze_px,
                        eyes_px,
                        eye_distance_mm: tracker_hal::plausibility::eye_distance_mm(&s),
                    });
                    let due = far_reported
                        .is_none_or(|(t, n)| n != far && t.elapsed() >= FAR_REPORT_EVERY);
                    if far > 0 && due {
                        far_reported = Some((Instant::now(), far));
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {far} gaze samples far off the screen or not finite, marked invalid; keeping the last valid gaze"
                        )));
                    }
                }
                Ok(None) => {
                    end_silence(&mut silent);
                    let _ = tx.send(TrackerMsg::Status(
                        "tracker: end of stream; keeping the last gaze".into(),
                    ));
                    if ends {
                        return;
                    }
                    break;
                }
                Err(e) if e.kind == ErrorKind::TimedOut => {
                    // A device that goes silent (unplugged without an error,
                    // stopped, a dead line) is reported, then reopened; one
                    // whose bytes never decode (wrong baud or mode) too.
                    let (no_record, no_byte) = (last_record.elapsed(), last_byte.elapsed());
                    let arriving = undecoded_bytes > 0 && no_byte < SILENT_REPORT;
                    let what = if arriving {
                        format!("{undecoded_bytes} bytes, 0 records decoded: wrong baud or format?")
                    } else {
                        format!("no data for {:.1} s", no_byte.as_secs_f64())
                    };
                    if no_record >= SILENT_RECONNECT && !ends {
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what}; keeping the last gaze, reconnecting"
                        )));
                        break;
                    }
                    if arriving && no_record >= UNDECODED_REPORT && !undecoded {
                        undecoded = true;
                        lock(&faults).undecoded += 1;
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what} (keeping the last gaze)"
                        )));
                    } else if no_byte >= SILENT_REPORT && silent.is_none() {
                        silent = Some(last_byte);
                        lock(&faults).silences += 1;
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: {what}; keeping the last gaze"
                        )));
                    }
                }
                Err(e) => {
                    let _ = tx.send(TrackerMsg::Status(format!(
                        "tracker: {e}; keeping the last gaze, reconnecting"
                    )));
                    break;
                }
            }
        }
        end_silence(&mut silent);
        let _ = source.stop();
    }
}

/// A gaze source chosen from the command line, not yet started.
pub struct GazeSetup {
    /// The tracker configuration (from the recording's header in a replay).
    pub tracker: TrackerConfig,
    replay: Option<Recording>,
    /// For messages: the driver and file.
    pub name: String,
    /// The screen (px), to mark gaze far off it invalid.
    screen_px: Option<[f64; 2]>,
}

/// A running tracker thread.
pub struct GazeFeed {
    pub rx: Receiver<TrackerMsg>,
    /// The mouse device's cursor input (dropped to stop it).
    pub cursor_tx: Option<Sender<CursorEvent>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    recorder: Option<Recorder>,
    faults: Arc<Mutex<Faults>>,
    /// How the last [`GazeFeed::finish`] ended the thread, for the log.
    stopped: Option<String>,
    /// The mouse emulator's schedule counts, when the source is one.
    mouse_timing: Arc<Mutex<Option<MouseTiming>>>,
    /// The attention source's settings when the gaze is the attention
    /// model's (not in a replay): the viewer then runs the model on every
    /// frame and feeds its point in ([`GazeFeed::attention_gaze`]).
    pub attention: Option<tracker_hal::AttentionSourceConfig>,
}

impl GazeSetup {
    /// `--replay FILE` (the tracker from its header) or `--tracker FILE.ron`.
    pub fn resolve(tracker: Option<&Path>, replay: Option<&Path>) -> Result<Self, String> {
        if let Some(path) = replay {
            let rec = Recording::read(path).map_err(|e| e.to_string())?;
            for w in rec.warnings() {
                eprintln!("warning: {}: {w}", path.display());
            }
            return Ok(Self {
                tracker: rec.header.tracker.clone(),
                replay: Some(rec),
                name: format!("replay of {}", path.display()),
                screen_px: None,
            });
        }
        let Some(path) = tracker else {
            return Err(
                "give --tracker FILE.ron (config/trackers/mouse.ron for the mouse) or --replay FILE"
                    .into(),
            );
        };
        let tracker: TrackerConfig = config::load_tracker(path).map_err(|e| e.to_string())?;
        let name = format!("{} ({})", tracker.driver_name(), path.display());
        Ok(Self {
            tracker,
            replay: None,
            name,
            screen_px: None,
        })
    }

    /// The screen's size (px): mapped gaze that is not finite or more than
    /// one screen diagonal outside it is then marked invalid and counted
    /// (without it only non-finite gaze is).
    pub fn with_screen(mut self, size_px: [f64; 2]) -> Self {
        self.screen_px = Some(size_px);
        self
    }

    /// How the tracker's device times are obtained.
    pub fn device_clock(&self) -> DeviceClock {
        self.tracker.decoder().device_clock()
    }

    pub fn is_replay(&self) -> bool {
        self.replay.is_some()
    }

    pub fn is_mouse(&self) -> bool {
        matches!(self.tracker.driver, Driver::Mouse(_))
    }

    /// Starts the tracker thread. With `calibration`, raw gaze maps through
    /// it instead of the tracker file's mapping; with `record`, every byte
    /// from and to the device goes to that recording (its own writer
    /// thread), which [`GazeFeed::finish`] closes properly.
    pub fn spawn(
        self,
        calibration: Option<Calibration>,
        record: Option<(&Path, &str)>,
    ) -> Result<GazeFeed, String> {
        let recorder = match record {
            Some((path, display)) => {
                let header = RecordingHeader {
                    tracker: self.tracker.clone(),
                    display: Some(display.to_string()),
                    note: format!("recorded by gazecast from {}", self.name),
                };
                Some(
                    Recorder::start(path, &header, 1 << 16)
                        .map_err(|e| format!("--record: {e}"))?,
                )
            }
            None => None,
        };
        let tap = recorder.as_ref().map(Recorder::tap);
        if let (Some(t), Ok(mut open)) = (&tap, OPEN_RECORDINGS.lock()) {
            open.push(t.clone());
        }
        let (cursor_tx, cursor_rx) = crossbeam_channel::unbounded();
        let (frame, mapping) = (self.tracker.frame(), self.tracker.mapping.clone());
        let map: Map = match calibration {
            Some(c) => Box::new(move |p| c.map(p)),
            None => Box::new(move |p| Some(mapping.to_screen(p, frame))),
        };
        let ends = self.replay.is_some();
        let attention = match &self.tracker.driver {
            Driver::Attention(a) if !ends => Some(a.clone()),
            _ => None,
        };
        let stop = Arc::new(AtomicBool::new(false));
        let binocular = match &self.tracker.driver {
            Driver::Mouse(_) | Driver::Attention(_) => false,
            // A stream with one gaze point copies it into both eyes.
            Driver::Lsl(c) => c.binocular(),
            _ => true,
        };
        let mouse_timing = Arc::new(Mutex::new(None));
        let open = opener(
            self.tracker,
            self.replay,
            tap,
            cursor_rx,
            stop.clone(),
            mouse_timing.clone(),
        );
        let (tx, rx) = crossbeam_channel::unbounded();
        let faults = Arc::new(Mutex::new(Faults::default()));
        let ctx = ThreadCtx {
            recording: recorder.as_ref().map(Recorder::tap),
            map,
            screen_px: self.screen_px,
            tx,
            stop: stop.clone(),
            ends,
            faults: faults.clone(),
            binocular,
        };
        let thread = std::thread::Builder::new()
            .name("tracker".into())
            .spawn(move || tracker_thread(open, ctx))
            .map_err(|e| e.to_string())?;
        Ok(GazeFeed {
            rx,
            cursor_tx: Some(cursor_tx),
            stop,
            thread: Some(thread),
            recorder,
            faults,
            stopped: None,
            mouse_timing,
            attention,
        })
    }
}

/// Opens the mouse emulator on the cursor events (once: it keeps running).
fn mouse_opener(
    c: MouseConfig,
    cursor_rx: Receiver<CursorEvent>,
    tap: Option<Tap>,
    timing: Arc<Mutex<Option<MouseTiming>>>,
) -> Opener {
    let mut cursor = Some(cursor_rx);
    Box::new(move || {
        let rx = cursor.take().ok_or("the mouse device has stopped")?;
        let link = spawn_device(c.clone(), rx).map_err(|e| e.to_string())?;
        if let Ok(mut t) = timing.lock() {
            *t = Some(link.timing());
        }
        let d = StreamDriver::new(
            link,
            tracker_hal::mouse::MouseDecoder::new(),
            Box::new(MonotonicClock),
        )
        .with_max_wait(MAX_WAIT);
        Ok(match &tap {
            Some(t) => Box::new(d.with_tap(t.clone())) as Source,
            None => Box::new(d) as Source,
        })
    })
}

/// How to (re)open the source.
fn opener(
    tracker: TrackerConfig,
    replay: Option<Recording>,
    tap: Option<Tap>,
    cursor_rx: Receiver<CursorEvent>,
    stop: Arc<AtomicBool>,
    mouse_timing: Arc<Mutex<Option<MouseTiming>>>,
) -> Opener {
    fn tapped<T: std::io::Read + std::io::Write, D: tracker_hal::Decoder>(
        d: StreamDriver<T, D>,
        tap: &Option<Tap>,
    ) -> StreamDriver<T, D> {
        let d = d.with_max_wait(MAX_WAIT);
        match tap {
            Some(t) => d.with_tap(t.clone()),
            None => d,
        }
    }
    if let Some(rec) = replay {
        let mut once = Some(rec);
        return Box::new(move || {
            let rec = once.take().ok_or("the recording has been played")?;
            let t = ReplayTransport::from_recording(&rec, Pacing::RealTime)
                .with_read_timeout(READ_TIMEOUT)
                .with_stop(stop.clone());
            let clock = t.clock();
            Ok(Box::new(tapped(
                StreamDriver::new(t, tracker.decoder(), Box::new(clock)),
                &tap,
            )) as Source)
        });
    }
    match tracker.driver.clone() {
        Driver::Mouse(c) => mouse_opener(c, cursor_rx, tap, mouse_timing),
        // The viewer feeds the attention model's point in as the cursor.
        Driver::Attention(a) => mouse_opener(a.stream(), cursor_rx, tap, mouse_timing),
        Driver::Iscan(c) => Box::new(move || {
            let name = c
                .port
                .clone()
                .ok_or("the ISCAN tracker file has no `port`")?;
            let port = tracker_hal::serial::open(&name, c.baud, READ_TIMEOUT)
                .map_err(|e| e.to_string())?;
            Ok(Box::new(tapped(
                StreamDriver::new(port, tracker.decoder(), Box::new(MonotonicClock)),
                &tap,
            )) as Source)
        }),
        // Each open resolves the stream again: after a lost stream (its
        // outlet ended or went silent for `silence_ms`) the tracker thread
        // reopens, finding a restarted outlet by the same query.
        #[cfg(feature = "lsl")]
        Driver::Lsl(c) => Box::new(move || {
            let t = tracker_hal::lsl::inlet::LslTransport::open(&c).map_err(|e| e.to_string())?;
            Ok(Box::new(tapped(
                StreamDriver::new(t, tracker.decoder(), Box::new(MonotonicClock)),
                &tap,
            )) as Source)
        }),
        #[cfg(not(feature = "lsl"))]
        Driver::Lsl(_) => Box::new(|| {
            Err("this gazecast was built without the `lsl` feature: it replays LSL recordings but cannot read a live LSL stream".into())
        }),
        Driver::TobiiHid(c) => Box::new(move || {
            let t = tracker_hal::hid::driver::hidapi_transport::HidApiTransport::open(&c)
                .map_err(|e| e.to_string())?;
            let d =
                tracker_hal::hid::driver::HidDriver::new(t, c.clone(), Box::new(MonotonicClock));
            Ok(Box::new(match &tap {
                Some(t) => d.with_tap(t.clone()),
                None => d,
            }) as Source)
        }),
    }
}

impl GazeFeed {
    /// The attention model's point of regard for the frame just rendered
    /// (screen pixels), or `None` (no object attended: an invalid sample,
    /// as a blink). Only with the attention source; ignored otherwise.
    pub fn attention_gaze(&self, gaze_px: Option<[f64; 2]>) {
        if let (Some(tx), Some(_)) = (&self.cursor_tx, &self.attention) {
            let _ = tx.send(CursorEvent {
                t_us: monotonic_us(),
                position_px: gaze_px.unwrap_or([0.0, 0.0]),
                blink: gaze_px.is_none(),
            });
        }
    }

    /// The window's cursor moved (window pixels): input for the mouse
    /// device; ignored with other trackers (and with the attention source,
    /// whose point is the model's).
    pub fn cursor_moved(&self, x: f64, y: f64) {
        if self.attention.is_some() {
            return;
        }
        if let Some(tx) = &self.cursor_tx {
            let _ = tx.send(CursorEvent {
                t_us: monotonic_us(),
                position_px: [x, y],
                blink: false,
            });
        }
    }

    /// Stops the thread (the flag, and the mouse device's cursor channel),
    /// joins it — waiting at most 0.5 s: a thread stuck in a device call
    /// is detached and left to the process's exit, and [`Self::report`]
    /// says so — and closes the recording: queued chunks, an overflow chunk
    /// if any were lost, the end chunk. Returns a line for the session log.
    pub fn finish(&mut self) -> Result<Option<String>, String> {
        self.stop.store(true, Ordering::Relaxed);
        self.cursor_tx = None;
        if let Some(t) = self.thread.take() {
            let asked = Instant::now();
            while !t.is_finished() && asked.elapsed() < JOIN_WAIT {
                std::thread::sleep(Duration::from_millis(2));
            }
            let waited = asked.elapsed().as_secs_f64() * 1e3;
            if t.is_finished() {
                t.join().map_err(|_| "the tracker thread panicked")?;
                self.stopped = Some(format!("tracker: stopped in {waited:.0} ms"));
            } else {
                // Dropping the handle detaches the thread.
                drop(t);
                self.stopped = Some(format!(
                    "tracker: the tracker thread did not stop within {waited:.0} ms (a device call is blocked); detached it"
                ));
            }
        }
        let Some(rec) = self.recorder.take() else {
            return Ok(None);
        };
        let path = rec.path().display().to_string();
        forget_recording(&rec.tap());
        let s = rec.finish().map_err(|e| format!("--record: {e}"))?;
        if s.lost_chunks > 0 {
            return Err(format!(
                "THE RECORDING {path} LOST DATA: {} chunks ({} bytes) were dropped because the disk did not keep up",
                s.lost_chunks, s.lost_bytes
            ));
        }
        Ok(Some(format!(
            "recorded {path}: {} chunks, {} bytes, closed",
            s.chunks_written, s.bytes_written
        )))
    }
}

/// Every recording a [`GazeFeed`] has open, for [`close_recordings_now`].
static OPEN_RECORDINGS: Mutex<Vec<Tap>> = Mutex::new(Vec::new());

/// Closes every open recording now (end chunk written, file synced),
/// waiting up to `limit` for each; returns how many closed. For a process
/// that is about to end without unwinding (see
/// [`crate::screen::close_recordings_if_the_x_server_goes`]).
pub fn close_recordings_now(limit: Duration) -> usize {
    let taps: Vec<Tap> = match OPEN_RECORDINGS.lock() {
        Ok(t) => t.clone(),
        Err(p) => p.into_inner().clone(),
    };
    taps.iter().filter(|t| t.close_now(limit)).count()
}

fn forget_recording(tap: &Tap) {
    if let Ok(mut open) = OPEN_RECORDINGS.lock() {
        open.retain(|t| !t.same_recording(tap));
    }
}

/// The line that reports a recording's write error.
pub fn recording_stopped(error: &str) -> String {
    format!("RECORDING STOPPED: {error}; what was written before it is kept, nothing after it is recorded")
}

impl GazeFeed {
    /// The recording's write error, from the moment it happens (the
    /// tracker thread also sends it once as a status line).
    pub fn recording_failure(&self) -> Option<String> {
        self.recorder.as_ref().and_then(Recorder::failure)
    }

    /// The session log's lines about the tracker: how it stopped (after
    /// [`Self::finish`]) and every fault counted.
    pub fn report(&self) -> Vec<String> {
        let mut lines: Vec<String> = self.stopped.iter().cloned().collect();
        lines.extend(lock(&self.faults).lines());
        let timing = self.mouse_timing.lock().ok().and_then(|t| t.clone());
        if let Some(t) = timing {
            lines.push(format!(
                "mouse emulator: {} ticks ran late (each sampled at its scheduled time, the schedule kept), {} periods skipped after stalls over {} s",
                t.late_ticks(),
                t.skipped_ticks(),
                tracker_hal::mouse::MAX_CATCH_UP.as_secs_f64()
            ));
        }
        lines
    }

    /// The counts so far.
    pub fn faults(&self) -> Faults {
        lock(&self.faults).clone()
    }
}

impl Drop for GazeFeed {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// Set by Ctrl-C (SIGINT) or SIGTERM; the window loops check it every frame
/// and shut down as if the window had been closed.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Host monotonic time (µs) of the first interrupt.
static INTERRUPTED_AT_US: AtomicU64 = AtomicU64::new(0);

/// Installs the Ctrl-C / SIGTERM handler (once per process).
pub fn catch_interrupts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let _ = INTERRUPTED_AT_US.compare_exchange(
                0,
                monotonic_us().max(1),
                Ordering::SeqCst,
                Ordering::SeqCst,
            );
            INTERRUPTED.store(true, Ordering::SeqCst);
        });
    });
}

/// When the first Ctrl-C or SIGTERM arrived (host monotonic µs).
pub fn interrupted_at_us() -> Option<u64> {
    Some(INTERRUPTED_AT_US.load(Ordering::SeqCst)).filter(|&t| t > 0)
}

/// Whether Ctrl-C or SIGTERM has arrived.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}
