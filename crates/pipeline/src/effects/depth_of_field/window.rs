//! The gaze window of `focus: Gaze` and `focus: Vergence`: the square
//! around the point of regard whose depths' median is the focus, with the
//! helpers the GPU path uses to read the same window.

use raycast::Frame;

/// Side of the square around the gaze whose depths' median is the focus
/// for `focus: Gaze`, px.
pub const FOCUS_WINDOW_PX: i64 = 9;

/// The [`FOCUS_WINDOW_PX`] square around `gaze_px` clipped to a `w`×`h`
/// frame, as [`gaze_depth_mm`] reads it: inclusive pixel bounds `(x0, y0, x1, y1)`, empty (x0 > x1 or
/// y0 > y1) when it misses the frame; `None` for a non-finite gaze.
pub(crate) fn focus_window(w: i64, h: i64, gaze_px: [f64; 2]) -> Option<(i64, i64, i64, i64)> {
    if !gaze_px[0].is_finite() || !gaze_px[1].is_finite() {
        return None;
    }
    let half = FOCUS_WINDOW_PX / 2;
    // Clamp before converting so a far-off gaze cannot overflow.
    let cx = gaze_px[0].floor().clamp(-1e9, 1e9) as i64;
    let cy = gaze_px[1].floor().clamp(-1e9, 1e9) as i64;
    Some((
        (cx - half).max(0),
        (cy - half).max(0),
        (cx + half).min(w - 1),
        (cy + half).min(h - 1),
    ))
}

/// The median of the finite positive depths of a window (the focus of
/// `focus: Gaze`, as [`gaze_depth_mm`] takes it), or `None` when it holds
/// none.
pub(crate) fn median_depth(mut depths: Vec<f32>) -> Option<f64> {
    depths.retain(|d| d.is_finite() && *d > 0.0);
    if depths.is_empty() {
        return None;
    }
    depths.sort_by(f32::total_cmp);
    Some(f64::from(depths[depths.len() / 2]))
}

/// `focus: Vergence`'s depth: the vergence depth when valid (finite,
/// positive), else the gaze's (`gaze`, evaluated only then).
pub(crate) fn vergence_or(
    vergence_mm: Option<f64>,
    gaze: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    vergence_mm
        .filter(|d| d.is_finite() && *d > 0.0)
        .or_else(gaze)
}

/// The median of the finite positive depths in the [`FOCUS_WINDOW_PX`]
/// square around `gaze_px`, or `None` when it holds none.
pub fn gaze_depth_mm(frame: &Frame, gaze_px: [f64; 2]) -> Option<f64> {
    if !frame.has_surface() {
        return None;
    }
    let w = i64::from(frame.width_px);
    let (x0, y0, x1, y1) = focus_window(w, i64::from(frame.height_px), gaze_px)?;
    let mut depths = Vec::with_capacity((FOCUS_WINDOW_PX * FOCUS_WINDOW_PX) as usize);
    for y in y0..=y1 {
        for x in x0..=x1 {
            depths.push(frame.depth_mm[(y * w + x) as usize]);
        }
    }
    median_depth(depths)
}
