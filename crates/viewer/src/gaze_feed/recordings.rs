//! The recordings the gaze feeds of this process have open, so that a
//! process about to end without unwinding can still close them.

use std::sync::Mutex;
use std::time::Duration;

use tracker_hal::Tap;

/// Every recording a [`super::GazeFeed`] has open, for [`close_recordings_now`].
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

/// Forgets a recording that is being closed.
pub(super) fn forget(tap: &Tap) {
    if let Ok(mut open) = OPEN_RECORDINGS.lock() {
        open.retain(|t| !t.same_recording(tap));
    }
}

/// Remembers a recording a gaze feed has opened.
pub(super) fn remember(tap: &Tap) {
    if let Ok(mut open) = OPEN_RECORDINGS.lock() {
        open.push(tap.clone());
    }
}
