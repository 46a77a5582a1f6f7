//! From tracker units to screen pixels: an explicit step after decoding.

use serde::{Deserialize, Serialize};

/// How tracker coordinates map to screen pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub enum Mapping {
    /// Tracker units are screen pixels already (mouse emulation).
    #[default]
    Identity,
    /// The whole tracker frame spans the whole screen, linearly.
    Frame { screen_px: (u32, u32) },
    /// Murphy & Duchowski 2001 §4.1: the application window's corners are
    /// measured in tracker coordinates with the tracker's cursor, then raw
    /// POR is mapped by linear interpolation between those extents.
    Corners {
        /// Window extents in tracker units: (left, top, right, bottom).
        window_in_tracker: (f64, f64, f64, f64),
        /// Window size in pixels.
        window_px: (u32, u32),
        /// Window's top-left corner on the screen, pixels.
        #[serde(default)]
        window_origin_px: (f64, f64),
    },
}

impl Mapping {
    /// Checks the values; the error names the field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        match self {
            Mapping::Identity => Ok(()),
            Mapping::Frame { screen_px } => {
                if screen_px.0 == 0 || screen_px.1 == 0 {
                    Err((
                        "mapping.screen_px",
                        format!("{screen_px:?} must be positive"),
                    ))
                } else {
                    Ok(())
                }
            }
            Mapping::Corners {
                window_in_tracker: (l, t, r, b),
                window_px,
                window_origin_px,
            } => {
                let finite = [*l, *t, *r, *b, window_origin_px.0, window_origin_px.1]
                    .iter()
                    .all(|v| v.is_finite());
                if !finite || (r - l).abs() < 1e-9 || (b - t).abs() < 1e-9 {
                    Err((
                        "mapping.window_in_tracker",
                        format!("({l}, {t}, {r}, {b}) must span a non-empty area"),
                    ))
                } else if window_px.0 == 0 || window_px.1 == 0 {
                    Err((
                        "mapping.window_px",
                        format!("{window_px:?} must be positive"),
                    ))
                } else {
                    Ok(())
                }
            }
        }
    }

    /// Maps a point in tracker units (frame `frame` = (width, height)) to
    /// screen pixels.
    pub fn to_screen(&self, p: [f64; 2], frame: (f64, f64)) -> [f64; 2] {
        match self {
            Mapping::Identity => p,
            Mapping::Frame { screen_px } => [
                p[0] / frame.0 * f64::from(screen_px.0),
                p[1] / frame.1 * f64::from(screen_px.1),
            ],
            Mapping::Corners {
                window_in_tracker: (l, t, r, b),
                window_px,
                window_origin_px,
            } => [
                window_origin_px.0 + (p[0] - l) / (r - l) * f64::from(window_px.0),
                window_origin_px.1 + (p[1] - t) / (b - t) * f64::from(window_px.1),
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_interpolate_linearly() {
        // A 600×450 window measured at (56, 80)–(456, 380) in the 512 frame.
        let m = Mapping::Corners {
            window_in_tracker: (56.0, 80.0, 456.0, 380.0),
            window_px: (600, 450),
            window_origin_px: (0.0, 0.0),
        };
        assert_eq!(m.to_screen([56.0, 80.0], (512.0, 512.0)), [0.0, 0.0]);
        assert_eq!(m.to_screen([456.0, 380.0], (512.0, 512.0)), [600.0, 450.0]);
        assert_eq!(m.to_screen([256.0, 230.0], (512.0, 512.0)), [300.0, 225.0]);
    }

    #[test]
    fn degenerate_corners_are_rejected() {
        let m = Mapping::Corners {
            window_in_tracker: (5.0, 0.0, 5.0, 10.0),
            window_px: (10, 10),
            window_origin_px: (0.0, 0.0),
        };
        assert_eq!(m.validate().unwrap_err().0, "mapping.window_in_tracker");
    }
}
