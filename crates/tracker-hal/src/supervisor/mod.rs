//! The tracker supervisor: runs a gaze source on its own thread and keeps
//! it running. It opens the device through a caller's opener (a serial
//! port, a HID tracker, an LSL inlet, the mouse emulator, a replay: how is
//! the caller's business), passes every sample on over a
//! `crossbeam-channel` — raw tracker units and mapped screen pixels, with
//! their times — never blocking on the receiver, and reopens the device
//! with back-off when it fails, cannot be opened or stays silent. Status
//! lines say what happens; [`Faults`] counts it for the session log.
//!
//! - `run`: the loop ([`run()`], [`Supervisor`]) and its policy constants
//!   here.
//! - `message`: what it sends ([`TrackerMsg`]).
//! - `faults`: what it counts ([`Faults`]).

mod faults;
mod message;
mod run;
#[cfg(test)]
mod tests;

use std::time::Duration;

pub use faults::Faults;
pub use message::{capture_us, recording_stopped, TrackerMsg};
pub use run::{run, Map, Supervisor};

use crate::source::GazeSource;

/// A started-or-not gaze source the supervisor runs.
pub type Source = Box<dyn GazeSource + Send>;

/// Opens the tracker (again, after a failure); the error is a status line.
pub type Opener = Box<dyn FnMut() -> Result<Source, String> + Send>;

/// Silence after which the status line says so.
pub const SILENT_REPORT: Duration = Duration::from_millis(500);
/// Silence after which a live device is closed and reopened.
pub const SILENT_RECONNECT: Duration = Duration::from_secs(2);
/// Bytes arriving without a record for this long: wrong baud or format.
pub const UNDECODED_REPORT: Duration = Duration::from_secs(1);
/// The longest one device read may block the supervisor: openers give
/// transports this read timeout (serial read timeout, replay pacing wait).
pub const READ_TIMEOUT: Duration = Duration::from_millis(100);
/// The longest one `next_sample` call reads bytes that decode to nothing
/// (openers give stream drivers this [`crate::StreamDriver::with_max_wait`]).
pub const MAX_WAIT: Duration = Duration::from_millis(200);
/// Minimum time between two status lines about off-screen gaze.
pub const FAR_REPORT_EVERY: Duration = Duration::from_secs(1);
/// The wait before the first reopening; it doubles after each failure.
pub const BACKOFF_FIRST: Duration = Duration::from_millis(250);
/// The longest wait between two reopenings.
pub const BACKOFF_MAX: Duration = Duration::from_secs(4);
