//! A device simulator: synthesised gaze behaviour encoded in each driver's
//! documented wire format, with the samples a correct decoder must produce.
//!
//! The recorded streams under `tests/data/` come from here (`gazecast
//! simulate`); they are **synthesised, not captured from a real device**.
//!
//! - `saccade`: the main sequence ([`main_sequence_duration_ms`]) and the
//!   saccade profile every simulated saccade uses.
//! - `search`: [`gaze_script`], fixations with small drift, main-sequence
//!   saccades, blinks (both eyes missing), spells with one eye lost, a
//!   vergence offset between the eyes.
//! - `fixation`: [`fixation_script`], a person following targets on a
//!   calibration procedure's schedule.
//! - `uncalibrated`: [`uncalibrated_raw`], a tracker that sees the screen
//!   in perspective with a second-order bow, and [`calibration_stops`], a
//!   calibration session's targets in its raw units.
//! - `scanpath`: [`search_scanpath`], the demo's search of a display, frame
//!   by frame in screen pixels.
//! - `wire`: [`simulate_iscan`] (serial reads that split records at random
//!   points) and [`simulate_mouse`]; the HID device is [`crate::hid::sim`].
//! - [`preset`]: each driver's simulated device (rate, frame, scale) and
//!   its encoder, [`preset::encode`].

mod fixation;
pub mod preset;
mod saccade;
mod scanpath;
mod search;
mod uncalibrated;
mod wire;

pub use fixation::{fixation_script, Stop};
pub use saccade::{main_sequence_duration_ms, saccade_profile};
pub use scanpath::{search_scanpath, search_stops};
pub use search::{gaze_script, Script};
pub use uncalibrated::{calibration_stops, uncalibrated_raw, NoSuchTarget};
pub use wire::{simulate_iscan, simulate_mouse};

use crate::recording::Chunk;
use crate::sample::GazeSample;

/// The simulated truth at one sampling instant, in tracker units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// The sampling instant, µs.
    pub t_us: u64,
    /// The left eye's point of regard, tracker units; `None`: closed or lost.
    pub left: Option<[f64; 2]>,
    /// The right eye's point of regard, tracker units; `None`: closed or lost.
    pub right: Option<[f64; 2]>,
}

/// A simulated stream: what the device sends, and what must come out.
#[derive(Debug, Clone)]
pub struct SimStream {
    /// Device → host chunks with host arrival times.
    pub chunks: Vec<Chunk>,
    /// The samples a correct decoder produces from `chunks`.
    pub expected: Vec<GazeSample>,
}

impl SimStream {
    /// The stream with its expected samples mapped onto the host clock as
    /// a driver maps them ([`crate::timing::ClockMapper`]), for simulators
    /// whose every record is completed by a read of its own (each record's
    /// last chunk holds no other record's end).
    pub fn one_record_per_read(chunks: Vec<Chunk>, mut expected: Vec<GazeSample>) -> Self {
        let mut mapper = crate::timing::ClockMapper::new();
        for s in &mut expected {
            mapper.map_sample(s);
        }
        Self { chunks, expected }
    }
}
