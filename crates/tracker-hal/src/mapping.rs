//! From tracker units to screen pixels: an explicit step after decoding.

use screen_geometry::{fmt_f64, MAX_SIDE_PX};
use serde::{Deserialize, Serialize};

/// Points a side of the grid [`check_grid`] maps.
const GRID: usize = 9;

/// Maps the corners and a [`GRID`]² grid of `range` (x0, y0, x1, y1)
/// through `map`: every result must be finite and within one diagonal of
/// `screen` (x0, y0, x1, y1) on every side. The error says which point
/// went where.
pub(crate) fn check_grid(
    range: [f64; 4],
    screen: [f64; 4],
    map: impl Fn([f64; 2]) -> Option<[f64; 2]>,
) -> Result<(), String> {
    let d = (screen[2] - screen[0]).hypot(screen[3] - screen[1]);
    let allowed = [screen[0] - d, screen[1] - d, screen[2] + d, screen[3] + d];
    let lerp = |a: f64, b: f64, i: usize| a + (b - a) * (i as f64 / (GRID - 1) as f64);
    for i in 0..GRID {
        for j in 0..GRID {
            let p = [lerp(range[0], range[2], i), lerp(range[1], range[3], j)];
            let q = map(p);
            let ok = q.is_some_and(|q| {
                q[0].is_finite()
                    && q[1].is_finite()
                    && (allowed[0]..=allowed[2]).contains(&q[0])
                    && (allowed[1]..=allowed[3]).contains(&q[1])
            });
            if !ok {
                let to = match q {
                    Some(q) => format!("({}, {})", fmt_f64(q[0]), fmt_f64(q[1])),
                    None => "no point (off the mapping's horizon)".into(),
                };
                return Err(format!(
                    "maps the tracker point ({}, {}) to {to}, not a finite point within a \
                     screen diagonal of the screen (({}, {})–({}, {}) px); the tracker's range \
                     is ({}, {})–({}, {})",
                    fmt_f64(p[0]),
                    fmt_f64(p[1]),
                    fmt_f64(screen[0]),
                    fmt_f64(screen[1]),
                    fmt_f64(screen[2]),
                    fmt_f64(screen[3]),
                    fmt_f64(range[0]),
                    fmt_f64(range[1]),
                    fmt_f64(range[2]),
                    fmt_f64(range[3]),
                ));
            }
        }
    }
    Ok(())
}

/// How tracker coordinates map to screen pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub enum Mapping {
    /// Tracker units are screen pixels already (mouse emulation).
    #[default]
    Identity,
    /// The whole tracker frame spans the whole screen, linearly.
    Frame {
        /// The screen's size (width, height), pixels.
        screen_px: (u32, u32),
    },
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

    /// Checks that the mapping takes the tracker's whole range onto finite
    /// screen coordinates near its screen; the error names the field.
    ///
    /// `range` is the tracker's range in tracker units, the rectangle
    /// `[0, w] × [0, h]` (see [`TrackerConfig::frame`]); `None` for a
    /// tracker whose units are already screen pixels with no declared
    /// extent (the mouse). The rules:
    ///
    /// * `Identity`: tracker units are screen pixels, so the range must fit
    ///   the largest accepted screen ([`MAX_SIDE_PX`] a side); with no range
    ///   (the mouse) there is nothing to check.
    /// * `Frame`: needs a range (the mouse has none: every sample would map
    ///   to (0, 0)); `screen_px` must be an accepted screen size.
    /// * `Corners`: the window must be an accepted size, its origin within
    ///   [`MAX_SIDE_PX`] of the screen's top-left corner, and the measured
    ///   corners inside the range grown by its diagonal on every side
    ///   (they were measured with the tracker's own cursor); with no range
    ///   the measured window itself is the range.
    ///
    /// Then the corners and a 9 × 9 grid of the range are mapped: every
    /// result must be finite and within one screen diagonal of the screen
    /// (the window, for `Corners`).
    ///
    /// [`TrackerConfig::frame`]: crate::TrackerConfig::frame
    pub fn check_range(&self, range: Option<(f64, f64)>) -> Result<(), (&'static str, String)> {
        self.validate()?;
        let max = f64::from(MAX_SIDE_PX);
        let size_ok = |px: &(u32, u32)| px.0 <= MAX_SIDE_PX && px.1 <= MAX_SIDE_PX;
        let range = range.filter(|(w, h)| w.is_finite() && h.is_finite() && *w > 0.0 && *h > 0.0);
        // (field blamed for a point off the screen, the screen rectangle, the range).
        let (field, screen, range): (&'static str, [f64; 4], [f64; 4]) = match self {
            Mapping::Identity => {
                let Some((w, h)) = range else { return Ok(()) };
                if w > max || h > max {
                    return Err((
                        "mapping",
                        format!(
                            "Identity takes tracker units as screen pixels, but the tracker's \
                             range is {} × {} units, larger than any screen ({MAX_SIDE_PX} px a \
                             side); use Frame or Corners",
                            fmt_f64(w),
                            fmt_f64(h)
                        ),
                    ));
                }
                return Ok(());
            }
            Mapping::Frame { screen_px } => {
                let Some((w, h)) = range else {
                    return Err((
                        "mapping",
                        "Frame needs a tracker with a frame; this tracker reports screen pixels \
                         with no frame (every sample would map to (0, 0)): use Identity"
                            .into(),
                    ));
                };
                if !size_ok(screen_px) {
                    return Err((
                        "mapping.screen_px",
                        format!("{screen_px:?}: a screen is at most {MAX_SIDE_PX} px a side"),
                    ));
                }
                let s = [0.0, 0.0, f64::from(screen_px.0), f64::from(screen_px.1)];
                ("mapping.screen_px", s, [0.0, 0.0, w, h])
            }
            Mapping::Corners {
                window_in_tracker: (l, t, r, b),
                window_px,
                window_origin_px: (ox, oy),
            } => {
                if !((r - l).is_finite() && (b - t).is_finite()) {
                    return Err((
                        "mapping.window_in_tracker",
                        format!(
                            "({}, {}, {}, {}): the window's width and height overflow",
                            fmt_f64(*l),
                            fmt_f64(*t),
                            fmt_f64(*r),
                            fmt_f64(*b)
                        ),
                    ));
                }
                if !size_ok(window_px) {
                    return Err((
                        "mapping.window_px",
                        format!("{window_px:?}: a window is at most {MAX_SIDE_PX} px a side"),
                    ));
                }
                if ox.abs() > max || oy.abs() > max {
                    return Err((
                        "mapping.window_origin_px",
                        format!(
                            "({}, {}): the window's origin must be within {MAX_SIDE_PX} px of the \
                             screen's top-left corner",
                            fmt_f64(*ox),
                            fmt_f64(*oy)
                        ),
                    ));
                }
                let (x0, x1, y0, y1) = (l.min(*r), l.max(*r), t.min(*b), t.max(*b));
                let range = match range {
                    Some((w, h)) => {
                        let d = w.hypot(h);
                        if x0 < -d || x1 > w + d || y0 < -d || y1 > h + d {
                            return Err((
                                "mapping.window_in_tracker",
                                format!(
                                    "({}, {}, {}, {}) lies outside the tracker's range \
                                     (0, 0)–({}, {}) by more than its diagonal",
                                    fmt_f64(*l),
                                    fmt_f64(*t),
                                    fmt_f64(*r),
                                    fmt_f64(*b),
                                    fmt_f64(w),
                                    fmt_f64(h)
                                ),
                            ));
                        }
                        [0.0, 0.0, w, h]
                    }
                    None => [x0, y0, x1, y1],
                };
                let s = [
                    *ox,
                    *oy,
                    ox + f64::from(window_px.0),
                    oy + f64::from(window_px.1),
                ];
                ("mapping.window_in_tracker", s, range)
            }
        };
        let frame = (range[2], range[3]);
        check_grid(range, screen, |p| Some(self.to_screen(p, frame))).map_err(|m| (field, m))
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
    fn mappings_that_miss_the_screen_are_refused() {
        let iscan = Some((512.0, 512.0));
        // The mouse has no frame: Frame would put every sample at (0, 0).
        let frame = Mapping::Frame {
            screen_px: (1280, 1024),
        };
        assert_eq!(frame.check_range(None).unwrap_err().0, "mapping");
        assert!(frame.check_range(iscan).is_ok());
        assert!(Mapping::Identity.check_range(None).is_ok());
        assert!(Mapping::Identity.check_range(iscan).is_ok());
        // µm as pixels: no screen is 337900 px wide.
        assert_eq!(
            Mapping::Identity
                .check_range(Some((337_900.0, 270_300.0)))
                .unwrap_err()
                .0,
            "mapping"
        );
        let corners = |l: f64, t: f64, r: f64, b: f64| Mapping::Corners {
            window_in_tracker: (l, t, r, b),
            window_px: (1280, 1024),
            window_origin_px: (0.0, 0.0),
        };
        assert!(corners(56.0, 80.0, 456.0, 380.0).check_range(iscan).is_ok());
        assert!(corners(0.0, 0.0, 1280.0, 1024.0).check_range(None).is_ok());
        for range in [iscan, None] {
            let err = corners(-1e308, -1e308, 1e308, 1e308)
                .check_range(range)
                .unwrap_err();
            assert_eq!(err.0, "mapping.window_in_tracker", "{range:?}");
            assert!(err.1.len() < 300, "{}", err.1);
        }
        // A window far outside the tracker's frame squeezes it to a point.
        assert_eq!(
            corners(0.0, 0.0, 1e12, 1e12)
                .check_range(iscan)
                .unwrap_err()
                .0,
            "mapping.window_in_tracker"
        );
        // A 1-unit window maps the 512 frame 512 windows wide.
        let tiny = Mapping::Corners {
            window_in_tracker: (100.0, 100.0, 101.0, 101.0),
            window_px: (1280, 1024),
            window_origin_px: (0.0, 0.0),
        };
        assert_eq!(
            tiny.check_range(iscan).unwrap_err().0,
            "mapping.window_in_tracker"
        );
        let far = Mapping::Corners {
            window_in_tracker: (56.0, 80.0, 456.0, 380.0),
            window_px: (1280, 1024),
            window_origin_px: (1e300, 0.0),
        };
        assert_eq!(
            far.check_range(iscan).unwrap_err().0,
            "mapping.window_origin_px"
        );
        let huge = Mapping::Frame {
            screen_px: (u32::MAX, 1024),
        };
        assert_eq!(huge.check_range(iscan).unwrap_err().0, "mapping.screen_px");
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
