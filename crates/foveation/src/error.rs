//! The one error type of the crate: a parameter that the maths cannot use.
//! Defined in `screen-geometry` (display geometry fails the same way) and
//! re-exported.

pub use screen_geometry::{fmt_f64, ParamError};

pub(crate) use screen_geometry::positive;
