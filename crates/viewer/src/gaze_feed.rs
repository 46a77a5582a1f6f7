//! The tracker thread shared by `view` and `calibrate`: it runs the driver
//! (a replayed recording at its original pacing, the mouse emulator fed by
//! the window's cursor, an ISCAN on its serial port, or a HID tracker),
//! optionally taps every byte into a recorder, and sends each sample over a
//! `crossbeam-channel` — raw tracker units and mapped screen pixels — never
//! blocking on the window. A device that fails or cannot be opened is
//! reopened with backoff; the window hears about it as a status line.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use tracker_hal::calibration::Calibration;
use tracker_hal::clock::monotonic_us;
use tracker_hal::mouse::{spawn_device, CursorEvent};
use tracker_hal::{
    Driver, ErrorKind, GazeSource, MonotonicClock, Pacing, Recorder, Recording, RecordingHeader,
    ReplayTransport, StreamDriver, Tap, TrackerConfig,
};

use crate::config;

/// What the tracker thread tells the window.
#[derive(Debug, Clone)]
pub enum TrackerMsg {
    /// A sample. `host_us`: host monotonic time (µs) when the thread got it
    /// (for gaze age); `sample_us`: the source's own arrival time (the
    /// recorded one in a replay; for procedures that must replay exactly);
    /// `raw`: tracker units; `gaze_px`: screen pixels (`None` for both when
    /// invalid, e.g. a blink, or outside a calibration's domain).
    Gaze {
        host_us: u64,
        sample_us: u64,
        raw: Option<[f64; 2]>,
        gaze_px: Option<[f64; 2]>,
    },
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

/// Runs a tracker until `stop`: samples to `tx`, reopening with backoff
/// (0.25 s doubling to 4 s) when the device fails or stays silent for 2 s;
/// a replay ends at its end.
fn tracker_thread(
    mut open: Opener,
    map: Map,
    tx: Sender<TrackerMsg>,
    stop: Arc<AtomicBool>,
    ends: bool,
) {
    let mut backoff = Duration::from_millis(250);
    while !stop.load(Ordering::Relaxed) {
        let mut source = match open() {
            Ok(s) => s,
            Err(e) => {
                let _ = tx.send(TrackerMsg::Status(format!(
                    "tracker: {e}; retrying in {:.2} s",
                    backoff.as_secs_f64()
                )));
                // Sleep in short steps so a shutdown is not held up.
                let until = std::time::Instant::now() + backoff;
                while std::time::Instant::now() < until && !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(20));
                }
                backoff = (backoff * 2).min(Duration::from_secs(4));
                continue;
            }
        };
        if let Err(e) = source.start() {
            let _ = tx.send(TrackerMsg::Status(format!("tracker: {e}")));
        }
        let _ = tx.send(TrackerMsg::Status(String::new()));
        backoff = Duration::from_millis(250);
        let mut last_data = std::time::Instant::now();
        let mut silent = false;
        while !stop.load(Ordering::Relaxed) {
            match source.next_sample() {
                Ok(Some(s)) => {
                    last_data = std::time::Instant::now();
                    if silent {
                        silent = false;
                        let _ = tx.send(TrackerMsg::Status(String::new()));
                    }
                    let raw = s.gaze().filter(|p| p[0].is_finite() && p[1].is_finite());
                    let _ = tx.send(TrackerMsg::Gaze {
                        host_us: monotonic_us(),
                        sample_us: s.host_time_us,
                        raw,
                        gaze_px: raw.and_then(&map),
                    });
                }
                Ok(None) => {
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
                    // stopped, a dead line) is reported, then reopened.
                    let quiet = last_data.elapsed();
                    if quiet >= SILENT_RECONNECT && !ends {
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: no data for {:.1} s; keeping the last gaze, reconnecting",
                            quiet.as_secs_f64()
                        )));
                        break;
                    }
                    if quiet >= SILENT_REPORT && !silent {
                        silent = true;
                        let _ = tx.send(TrackerMsg::Status(format!(
                            "tracker: no data for {:.1} s; keeping the last gaze",
                            quiet.as_secs_f64()
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
}

/// A running tracker thread.
pub struct GazeFeed {
    pub rx: Receiver<TrackerMsg>,
    /// The mouse device's cursor input (dropped to stop it).
    pub cursor_tx: Option<Sender<CursorEvent>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    recorder: Option<Recorder>,
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
        })
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
        let (cursor_tx, cursor_rx) = crossbeam_channel::unbounded();
        let (frame, mapping) = (self.tracker.frame(), self.tracker.mapping.clone());
        let map: Map = match calibration {
            Some(c) => Box::new(move |p| c.map(p)),
            None => Box::new(move |p| Some(mapping.to_screen(p, frame))),
        };
        let ends = self.replay.is_some();
        let open = opener(self.tracker, self.replay, tap, cursor_rx);
        let (tx, rx) = crossbeam_channel::unbounded();
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("tracker".into())
                .spawn(move || tracker_thread(open, map, tx, stop, ends))
                .map_err(|e| e.to_string())?
        };
        Ok(GazeFeed {
            rx,
            cursor_tx: Some(cursor_tx),
            stop,
            thread: Some(thread),
            recorder,
        })
    }
}

/// How to (re)open the source.
fn opener(
    tracker: TrackerConfig,
    replay: Option<Recording>,
    tap: Option<Tap>,
    cursor_rx: Receiver<CursorEvent>,
) -> Opener {
    fn tapped<T: std::io::Read + std::io::Write, D: tracker_hal::Decoder>(
        d: StreamDriver<T, D>,
        tap: &Option<Tap>,
    ) -> StreamDriver<T, D> {
        match tap {
            Some(t) => d.with_tap(t.clone()),
            None => d,
        }
    }
    if let Some(rec) = replay {
        let mut once = Some(rec);
        return Box::new(move || {
            let rec = once.take().ok_or("the recording has been played")?;
            let t = ReplayTransport::from_recording(&rec, Pacing::RealTime);
            let clock = t.clock();
            Ok(Box::new(tapped(
                StreamDriver::new(t, tracker.decoder(), Box::new(clock)),
                &tap,
            )) as Source)
        });
    }
    match tracker.driver.clone() {
        Driver::Mouse(c) => {
            let mut cursor = Some(cursor_rx);
            Box::new(move || {
                let rx = cursor.take().ok_or("the mouse device has stopped")?;
                let link = spawn_device(c.clone(), rx).map_err(|e| e.to_string())?;
                Ok(Box::new(tapped(
                    StreamDriver::new(
                        link,
                        tracker_hal::mouse::MouseDecoder::new(),
                        Box::new(MonotonicClock),
                    ),
                    &tap,
                )) as Source)
            })
        }
        Driver::Iscan(c) => Box::new(move || {
            let name = c
                .port
                .clone()
                .ok_or("the ISCAN tracker file has no `port`")?;
            let port = tracker_hal::serial::open(&name, c.baud, Duration::from_millis(250))
                .map_err(|e| e.to_string())?;
            Ok(Box::new(tapped(
                StreamDriver::new(port, tracker.decoder(), Box::new(MonotonicClock)),
                &tap,
            )) as Source)
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
    /// The window's cursor moved (window pixels): input for the mouse
    /// device; ignored with other trackers.
    pub fn cursor_moved(&self, x: f64, y: f64) {
        if let Some(tx) = &self.cursor_tx {
            let _ = tx.send(CursorEvent {
                t_us: monotonic_us(),
                position_px: [x, y],
                blink: false,
            });
        }
    }

    /// Stops the thread (the flag, and the mouse device's cursor channel),
    /// joins it, and closes the recording: queued chunks, an overflow chunk
    /// if any were lost, the end chunk. Returns a line for the session log.
    pub fn finish(&mut self) -> Result<Option<String>, String> {
        self.stop.store(true, Ordering::Relaxed);
        self.cursor_tx = None;
        if let Some(t) = self.thread.take() {
            t.join().map_err(|_| "the tracker thread panicked")?;
        }
        let Some(rec) = self.recorder.take() else {
            return Ok(None);
        };
        let path = rec.path().display().to_string();
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

impl Drop for GazeFeed {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// Set by Ctrl-C (SIGINT) or SIGTERM; the window loops check it every frame
/// and shut down as if the window had been closed.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C / SIGTERM handler (once per process).
pub fn catch_interrupts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst));
    });
}

/// Whether Ctrl-C or SIGTERM has arrived.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}
