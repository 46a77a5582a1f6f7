//! The gaze feed shared by `view` and `calibrate`: a tracker chosen from
//! the command line ([`GazeSetup`]) run on its own thread by tracker-hal's
//! supervisor ([`tracker_hal::supervisor`]: reconnects, silences, fault
//! counts), optionally tapping every byte into a recording, its samples
//! arriving as [`TrackerMsg`]s without ever blocking the window.
//!
//! - `setup`: [`GazeSetup`], the tracker or recording the arguments name,
//!   and how it is started.
//! - `open`: how each kind of source is (re)opened.
//! - `recordings`: the recordings open in this process, closed at once
//!   when it must end without unwinding.

mod open;
mod recordings;
mod setup;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use tracker_hal::clock::monotonic_us;
use tracker_hal::mouse::{CursorEvent, MouseTiming};
use tracker_hal::supervisor::Faults;
use tracker_hal::Recorder;

pub use recordings::close_recordings_now;
pub use setup::GazeSetup;
pub use tracker_hal::supervisor::TrackerMsg;

/// How long [`GazeFeed::finish`] waits for the thread before detaching it.
const JOIN_WAIT: Duration = Duration::from_millis(500);

/// A running tracker thread.
pub struct GazeFeed {
    /// The tracker thread's messages: samples, clock-model updates and status lines.
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
        recordings::forget(&rec.tap());
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

impl GazeFeed {
    /// The counts of a device without a supervisor (a headless
    /// simulation's virtual mouse), for [`Self::report`].
    pub fn set_faults(&self, faults: Faults) {
        if let Ok(mut f) = self.faults.lock() {
            *f = faults;
        }
    }

    /// The recording's write error, from the moment it happens (the
    /// tracker thread also sends it once as a status line).
    pub fn recording_failure(&self) -> Option<String> {
        self.recorder.as_ref().and_then(Recorder::failure)
    }

    /// The session log's lines about the tracker: how it stopped (after
    /// [`Self::finish`]) and every fault counted.
    pub fn report(&self) -> Vec<String> {
        let mut lines: Vec<String> = self.stopped.iter().cloned().collect();
        lines.extend(Faults::read(&self.faults).lines());
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
        Faults::read(&self.faults)
    }
}

impl Drop for GazeFeed {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}
