//! What the tracker thread tells the window: [`TrackerMsg`], and the
//! times and status lines it carries.

use crate::sample::EyeSample;
use crate::timing::{ClockState, DeviceClock, TimeOrder};

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
        /// The eye tracker's point, tracker units; `None` when invalid.
        raw: Option<[f64; 2]>,
        /// That point mapped to the screen, pixels; `None` when invalid or far off the screen.
        gaze_px: Option<[f64; 2]>,
        /// The left and right eyes' points of regard, screen pixels, when
        /// the device measures two eyes (not the mouse or the attention
        /// source), the sample has both valid and both map onto the
        /// screen's neighbourhood (for vergence); `None` otherwise.
        eyes_px: Option<[[f64; 2]; 2]>,
        /// The eyes' distance from the screen plane (mm): the mean z of the
        /// eye positions the device reports (HID trackers; the tracker sits
        /// in the screen plane), when plausible
        /// ([`screen_geometry::EYE_DISTANCE_RANGE_MM`]); `None` otherwise.
        eye_distance_mm: Option<f64>,
        /// Each eye (left, right) as the device reported it, when the
        /// device measures eyes (not the mouse or the attention source,
        /// whose decoders copy one point into both): its point in raw
        /// tracker units (`None` when that eye was not tracked or is not
        /// finite) and its pupil size in the device's units where it
        /// reports one; both [`EyeSample::MISSING`] otherwise. For the
        /// per-eye columns of a session's samples.
        eyes: [EyeSample; 2],
        /// Those eyes' points mapped onto the screen (px) by the source's
        /// mapping, each when plausible; `None` otherwise.
        eye_px: [Option<[f64; 2]>; 2],
    },
    /// The tracker's clock model was updated (offset, drift, corrections),
    /// with how the device times are obtained.
    Clock(ClockState, DeviceClock),
    /// A status line (disconnect, reconnect, end of recording); empty when
    /// the tracker is streaming again.
    Status(String),
}

/// The capture time of a sample on this process's clock (µs): when it
/// was received, less how long after its mapped capture time it arrived
/// (the delivery delay, which a replay records too). Gaze age counts from
/// here, so the tracker's own latency shows where it reports it.
pub fn capture_us(received_us: u64, arrival_us: u64, mapped_us: u64) -> u64 {
    received_us.saturating_sub(arrival_us.saturating_sub(mapped_us))
}

/// The line that reports a recording's write error.
pub fn recording_stopped(error: &str) -> String {
    format!("RECORDING STOPPED: {error}; what was written before it is kept, nothing after it is recorded")
}
