//! # psychophysics — measuring a participant's contrast thresholds
//!
//! **No person has yet run this procedure.** Everything here was built and
//! checked against a simulated observer only; its figures are synthetic.
//!
//! - [`luminance`]: 8-bit levels ↔ linear light, by photometer table or gamma.
//! - [`stimulus`]: Gabor patches with unbiased spatial dithering.
//! - [`quest`]: QUEST (Watson & Pelli 1983).
//! - [`staircase`]: transformed up-down staircases.
//! - [`session`]: interleaved staircases over a frequency × eccentricity grid.
//! - [`observer`]: a simulated Geisler–Perry observer (synthetic answers).
//! - [`fit`]: the Geisler–Perry fit, bootstrap intervals, the threshold table.
pub mod fit;
pub mod luminance;
pub mod observer;
pub mod quest;
pub mod session;
pub mod staircase;
pub mod stimulus;

pub use foveation::ParamError;
