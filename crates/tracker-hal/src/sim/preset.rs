//! The simulated device of each driver: its sampling rate, the frame and
//! scale its simulated gaze is drawn in, and the encoder that turns that
//! gaze into the driver's wire format. `gazecast simulate` builds its
//! streams from these, so the recordings under `tests/data/` follow them.

use crate::config::Driver;
use crate::hid::sim::{simulate_hid, HidLayout};
use crate::sim::{simulate_iscan, simulate_mouse, SimStream, TruthSample};

/// The seed's ISCAN covers about ±20° with 512 units: 12.8 units/deg.
pub const ISCAN_UNITS_PER_DEGREE: f64 = 12.8;
/// The screen the simulated mouse (and attention source) moves over (px).
pub const MOUSE_SCREEN_PX: (f64, f64) = (1280.0, 1024.0);
/// A HID tracker's units are µm on the display: 1° at 60 cm is 10.47 mm.
pub const HID_UM_PER_DEGREE: f64 = 10_470.0;
/// The seed's Tobii ET-1750 ran at 50 Hz (Murphy 2007 §7.1).
pub const HID_RATE_HZ: f64 = 50.0;
/// The uniform noise of a simulated fixation on a calibration target (°).
pub const FIXATION_JITTER_DEG: f64 = 0.03;

/// Where a driver's simulated gaze is drawn: the device's own sampling
/// rate, its frame (width, height, tracker units) and tracker units per
/// degree of visual angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// The device's sampling rate, Hz.
    pub rate_hz: f64,
    /// The device's frame (width, height), tracker units.
    pub frame: (f64, f64),
    /// Tracker units per degree of visual angle.
    pub units_per_degree: f64,
}

impl Preset {
    /// The simulated device of `driver`; `None` for a driver without one
    /// (LSL: its streams are recorded from an outlet).
    pub fn of(driver: &Driver) -> Option<Self> {
        match driver {
            Driver::Iscan(c) => Some(Self {
                rate_hz: c.rate_hz,
                frame: c.frame,
                units_per_degree: ISCAN_UNITS_PER_DEGREE,
            }),
            Driver::Mouse(c) => Some(Self {
                rate_hz: c.rate_hz,
                frame: MOUSE_SCREEN_PX,
                units_per_degree: c.pixels_per_degree,
            }),
            // The attention source's stream is the mouse emulator's.
            Driver::Attention(a) => Some(Self {
                rate_hz: a.rate_hz,
                frame: MOUSE_SCREEN_PX,
                units_per_degree: a.stream().pixels_per_degree,
            }),
            Driver::TobiiHid(c) => Some(Self {
                rate_hz: HID_RATE_HZ,
                frame: c.screen_um,
                units_per_degree: HID_UM_PER_DEGREE,
            }),
            Driver::Lsl(_) => None,
        }
    }
}

/// Encodes `truth` (tracker units, sampled at `rate_hz`) as `driver`'s
/// device sends it (`layout`: the HID report layout; other drivers ignore
/// it); `None` for a driver without a simulated device.
pub fn encode(
    driver: &Driver,
    truth: &[TruthSample],
    rate_hz: f64,
    layout: HidLayout,
    seed: u64,
) -> Option<SimStream> {
    match driver {
        Driver::Iscan(c) => Some(simulate_iscan(c, truth, seed)),
        // The truth is in screen pixels already.
        Driver::Mouse(c) => Some(simulate_mouse(c, truth, 1.0, seed)),
        Driver::Attention(a) => Some(simulate_mouse(&a.stream(), truth, 1.0, seed)),
        Driver::TobiiHid(c) => Some(simulate_hid(layout, truth, c.screen_um, rate_hz, seed)),
        Driver::Lsl(_) => None,
    }
}
