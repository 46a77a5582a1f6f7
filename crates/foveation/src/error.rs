//! The one error type of the crate: a parameter that the maths cannot use.
//! Defined in `screen-geometry` (display geometry fails the same way) and
//! re-exported.

pub use screen_geometry::ParamError;

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(field: &'static str, value: f64) -> Result<f64, ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ParamError::new(
            field,
            value,
            "must be a finite number greater than zero",
        ))
    }
}
