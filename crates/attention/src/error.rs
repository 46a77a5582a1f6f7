//! The one error type of the crate.

use thiserror::Error;

/// Everything [`crate::AttentionTracker`] can refuse. Each message says what
/// was wrong and what would be accepted.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum AttentionError {
    /// The saliency map side is outside `MIN_MAP_SIZE..=MAX_MAP_SIZE`.
    #[error("saliency map size {size}x{size} is out of range: use a side from {min} to {max}")]
    MapSizeOutOfRange {
        /// The side asked for.
        size: u32,
        /// Smallest side accepted.
        min: u32,
        /// Largest side accepted.
        max: u32,
    },
    /// A frame has zero width or height.
    #[error("frame is {width}x{height}: width and height must both be at least 1")]
    EmptyFrame {
        /// Frame width in pixels.
        width: u32,
        /// Frame height in pixels.
        height: u32,
    },
    /// A frame is larger than the crate accepts (checked before anything is
    /// sized from it).
    #[error(
        "frame {width}x{height} is too large: at most {max_side} px a side and {max_pixels} px in all"
    )]
    FrameTooLarge {
        /// Frame width in pixels.
        width: u32,
        /// Frame height in pixels.
        height: u32,
        /// Largest side accepted.
        max_side: u32,
        /// Largest pixel count accepted.
        max_pixels: u64,
    },
    /// A frame buffer's length does not match `width * height` (times 3 for RGB).
    #[error(
        "frame buffer `{buffer}` has {actual} elements, expected {expected} for the frame size"
    )]
    BufferLength {
        /// `"rgb"`, `"depth_mm"` or `"object"`.
        buffer: &'static str,
        /// Elements expected from width and height.
        expected: u64,
        /// Elements given.
        actual: u64,
    },
    /// Two entries of the object list share an id.
    #[error("object id {0} is listed twice; each object must appear once per frame")]
    DuplicateObjectId(u32),
    /// An object in the list uses the background id.
    #[error("object id u32::MAX is reserved for background pixels; give the object another id")]
    ReservedObjectId,
    /// The object list is longer than the crate accepts.
    #[error("{count} objects listed; at most {max} are accepted per frame")]
    TooManyObjects {
        /// Objects given.
        count: usize,
        /// Most accepted.
        max: usize,
    },
    /// The frame time step is negative or not finite.
    #[error("time step {0} s is invalid: use a finite value >= 0")]
    InvalidTimeStep(f64),
    /// A measured frame record ([`crate::FrameMeasure`]) does not fit the
    /// frame or the object list.
    #[error("measured frame statistics are inconsistent: {0}")]
    InvalidMeasure(String),
    /// A configuration value is out of its range.
    #[error("configuration `{field}` is invalid: {reason}")]
    InvalidConfig {
        /// The field's name in [`crate::AttentionConfig`].
        field: &'static str,
        /// What is accepted.
        reason: String,
    },
}
