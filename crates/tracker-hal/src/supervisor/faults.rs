//! What went wrong with the gaze during a session, as the supervisor
//! counts it: missing and far-off samples, silences, undecodable stretches,
//! reconnects, the decoder's totals.

use std::sync::Mutex;

use crate::sample::DecodeStats;

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
    /// The longest silence, seconds.
    pub longest_silence_s: f64,
    /// Stretches of at least 1 s in which bytes arrived but no record
    /// decoded (wrong baud or format).
    pub undecoded: u64,
    /// Times the device was closed and reopened.
    pub reconnects: u64,
    /// Decoder totals over every connection of the session.
    pub decode: DecodeStats,
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

    /// A copy of the counts `shared` holds now (also after a thread
    /// panicked holding the lock).
    pub fn read(shared: &Mutex<Faults>) -> Faults {
        lock(shared).clone()
    }
}

/// The counts, locked (also after a thread panicked holding the lock).
pub(super) fn lock(f: &Mutex<Faults>) -> std::sync::MutexGuard<'_, Faults> {
    f.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}
