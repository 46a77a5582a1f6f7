//! Gaze sources for gazecast: eye-tracker drivers (serial, HID, Lab
//! Streaming Layer), mouse emulation, recording and replay, calibration
//! and eye-movement events, behind one blocking trait ([`GazeSource`]).
//!
//! Labs run gazecast with a physical eye tracker, developers with a mouse,
//! tests with recorded device streams. All three go through one small,
//! blocking abstraction, in the style of `embedded-hal` / `embedded-io`.
//!
//! ## The trait
//!
//! [`GazeSource`]: `start`, `stop`, `next_sample`, `stats`. Its doc states
//! exactly what blocks and what returns early (`Ok(None)` = clean end of
//! stream; `TimedOut` = call again; `Disconnected` = reopen). Every error
//! has one [`ErrorKind`] (`#[non_exhaustive]`) and a message.
//!
//! A [`GazeSample`] carries a sequence number and three times: the device
//! timestamp as decoded, the host monotonic arrival time, and the device
//! time mapped onto the host clock by the driver's online clock model
//! ([`timing`]: what every file and event downstream uses), and
//! per eye a position in tracker units or *missing* — never a bogus
//! coordinate — with an optional pupil size. Mapping to screen pixels is a
//! separate, explicit step ([`Mapping`]).
//!
//! ## Drivers are decoders over a transport
//!
//! A byte-stream device is a [`Decoder`] (a pure state machine: bytes in,
//! samples out, garbage skipped and counted) run by [`StreamDriver`] over any
//! `Read + Write` transport: a serial port ([`serial::open`]), a
//! pseudo-terminal, a pipe, a `Cursor<Vec<u8>>`, or a [`ReplayTransport`].
//! The same decode path therefore runs live, in tests and on replay.
//!
//! - [`iscan`]: ISCAN DQW serial output, binary and ASCII (format and
//!   timestamp derivation documented there).
//! - [`lsl`]: a Lab Streaming Layer gaze stream; its inlet (feature `lsl`,
//!   on by default) frames each sample as a record, so LSL sessions record
//!   and replay like the others.
//! - [`mouse`]: mouse-emulated gaze, a simulated device thread with optional
//!   jitter, main-sequence saccades, latency and blinks.
//!
//! ## Recording and replay
//!
//! [`recording`] documents the `.gzrec` format (append-only CRC-checked
//! chunks; a torn tail is detected and reported). A [`Recorder`] writes from
//! its own thread; the driver's [`Tap`] never blocks and counts any overflow.
//! [`ReplayTransport`] plays a recording (or a raw byte dump) back through the
//! same decoder, as fast as possible or at the original pacing.
//!
//! ## Adding a driver
//!
//! 1. Write a `Decoder`: `push` appends every complete record to `out`,
//!    resynchronising on garbage and counting dropped bytes and resyncs in
//!    [`DecodeStats`]; `finish` counts what is left; `start_command` /
//!    `stop_command` give the bytes that start and stop streaming.
//! 2. Give it a config type and a variant in [`config::Driver`], so tracker
//!    files can name it and recordings can carry it.
//! 3. Teach [`sim`] to produce its wire format (and give its simulated
//!    device a [`sim::preset`]), add a stream to `tests/data`
//!    with `gazecast simulate`, and add it to the conformance suite
//!    (`tests/tests/conformance.rs`), which checks the rest.
//!
//! Devices that are not byte streams (HID reports) go through the same
//! decoder path: [`hid::driver::HidDriver`] turns each report into a line of
//! hid-log text and decodes it with [`hid::HidLogDecoder`], which is also the
//! byte-stream decoder of recorded and replayed HID sessions.
//!
//! ## Running a tracker
//!
//! [`supervisor`] runs a gaze source on its own thread for a live session:
//! it opens the device through the caller's opener, passes each sample on
//! (raw and mapped, with its times) over a channel, reopens a device that
//! fails, cannot be opened or stays silent (with back-off), and counts every
//! fault for the session log. [`config::differences`] says, field by field,
//! where two tracker configurations disagree (a replay's `--tracker`
//! against the recording's header).
//!
//! ## Calibration, binocular gaze, events, clocks
//!
//! [`calibration`]: targets, stable windows, affine / homography /
//! polynomial fits, validation in degrees, and the policy of a whole
//! calibration session (what the calibration window does between keys).
//! [`events`]: vergence depth, cyclopean gaze, I-VT fixations and
//! saccades, blinks, the device-to-host clock model.
//!
//! ## Dependencies
//!
//! Display geometry (pixels, millimetres, where the eye is, visual angle)
//! comes from the small `screen-geometry` crate, which `foveation` shares;
//! tracker-hal and `foveation` know nothing of each other. USB discovery
//! and the live HID transport (`hidapi`, `rusb`) are the default feature
//! `hid-usb`; without it ([`discovery`] then answers with an error) the
//! crate still decodes, records, replays, simulates and calibrates.

#![warn(missing_docs)]

pub mod calibration;
pub mod clock;
pub mod config;
pub mod csv;
pub mod discovery;
pub mod error;
pub mod events;
mod framing;
pub mod hid;
pub mod iscan;
pub mod lsl;
pub mod mapping;
pub mod mouse;
pub mod plausibility;
pub mod recording;
pub mod replay;
pub mod sample;
pub mod serial;
pub mod sim;
pub mod source;
pub mod supervisor;
#[cfg(test)]
mod test_support;
pub mod timing;
pub mod virtual_mouse;

pub use clock::{Clock, MonotonicClock, SharedClock};
pub use config::{AttentionSourceConfig, Driver, TrackerConfig};
pub use error::{Error, ErrorKind, Result};
pub use mapping::Mapping;
pub use recording::{Recorder, RecorderSummary, Recording, RecordingHeader, Tap};
pub use replay::{Pacing, ReplayTransport};
pub use sample::{DecodeStats, EyeSample, GazeSample};
pub use source::{decode_all, Decoder, GazeSource, StreamDriver};
pub use timing::{ClockMapper, ClockState, DeviceClock, TimeOrder};
