//! # tracker-hal — gaze sources for gazecast (not yet implemented)
//!
//! This crate will hold the gaze-source trait, the ISCAN serial and Tobii HID
//! drivers, mouse emulation, calibration and mapping, and lossless recording
//! and replay (issues 3 and 4). It is empty on purpose: nothing here pretends
//! to work yet.
