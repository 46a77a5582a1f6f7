//! The one error type of the crate: a parameter that the maths cannot use.

/// A value the maths refuses, named by the field it came from so a caller
/// (the config loader, the CLI) can point a person at the right place.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {value}: {reason}")]
pub struct ParamError {
    /// Dotted path of the offending field, e.g. `size_mm.0` or `contrast`.
    pub field: &'static str,
    /// The value as given, formatted.
    pub value: String,
    /// What is wrong and what would be accepted.
    pub reason: String,
}

impl ParamError {
    pub fn new(
        field: &'static str,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Self {
            field,
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

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
