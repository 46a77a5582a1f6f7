//! The perceptual maths of gazecast: how finely a point of the screen must
//! be sampled for a given gaze (contrast sensitivity, ray masks, sampling
//! bounds, perceptibility) and how good a foveated frame is.
//!
//! Pure functions and data, no I/O, no GPU. Every formula cites the seed
//! section it implements (the seeds are in `shared/seeds/`).
//!
//! - [`display`]: display geometry, pixel pitch, eccentricity at the eye,
//!   local pixels-per-degree.
//! - [`csf`]: the Geisler–Perry contrast threshold and its inversions
//!   (Murphy 2007, eq. 4.1–4.3).
//! - [`sampling`]: the allowed ray spacing (Nyquist) at a screen point.
//! - [`mask`]: the ray mask and its intermediate mesh (Murphy 2007 §4.4.4),
//!   in two layouts, `nyquist` (default) and `seed`.
//! - [`bound`]: the continuous Nyquist bound on the ray count.
//! - [`perceptibility`]: Luebke & Hallen's threshold table, `is_perceptible`
//!   and the best-effort inverse.
//! - [`degradation`]: Murphy & Duchowski's acuity degradation table.
//! - [`thin_lens`]: circle of confusion and mipmap level (Lee 2009 §4.1).
//! - [`quality`]: PSNR, PSNR near the gaze, the visibility-weighted
//!   foveated error and the silhouette error of a frame against its reference.
//!
//! Conventions: units are in names (`_px`, `_deg`, `_mm`, `_cpd`); screen
//! coordinates are pixels from the top-left corner, y down. Functions return
//! NaN only when given NaN; parameters that make no sense are a [`ParamError`]
//! naming the field.

#![warn(missing_docs)]

pub mod bound;
pub mod csf;
pub mod degradation;
pub mod display;
mod error;
pub mod mask;
pub mod perceptibility;
pub mod quality;
pub mod sampling;
pub mod thin_lens;

pub use csf::GeislerPerry;
pub use display::{Display, ScreenGeometry};
pub use error::{fmt_f64, ParamError};
pub use mask::{Layout, RayMask};
pub use sampling::SamplingModel;
pub use screen_geometry::EYE_DISTANCE_RANGE_MM;

/// The README's examples, compiled and run as doc-tests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
