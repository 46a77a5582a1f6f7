//! Display geometry: where the pixels are in millimetres and where the eye is.
//!
//! Defined in the `screen-geometry` crate, which `tracker-hal` shares
//! without depending on this one; re-exported here so that
//! `foveation::display::{Display, ScreenGeometry}` keep working.

pub use screen_geometry::{Display, ScreenGeometry};
