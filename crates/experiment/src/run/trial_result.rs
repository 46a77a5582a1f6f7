//! What a finished trial records, apart from the files it goes to: its
//! eye-movement events over the samples captured up to the response
//! (fixations merged with the congruence thresholds) and the confirming
//! click's score.

use screen_geometry::ScreenGeometry;
use tracker_hal::events::{classify, merge_congruent_fixations, EventKind, IvtConfig, TimedGaze};

use crate::session::EventRow;

/// Fixations closer than this (degrees) with only saccades between them,
/// at most [`CONGRUENT_GAP_US`] apart, are one ("congruent", Murphy 2007
/// §7.3): 1° is several times a good video tracker's noise and under a
/// third of an object's width; 250 ms is longer than any noise "saccade"
/// and too short for a real look away and back (that puts a fixation
/// elsewhere between them, which is never bridged).
pub const CONGRUENT_DEG: f64 = 1.0;
/// The longest gap (µs) bridged between two congruent fixations.
pub const CONGRUENT_GAP_US: u64 = 250_000;

/// Trial `trial`'s eye-movement events (rows of `events.tsv` for
/// `sitting`): those of its samples captured up to `response_us` (on the
/// mapped clock), classified by I-VT and merged where congruent.
pub fn trial_events(
    samples: &[TimedGaze],
    response_us: u64,
    geometry: &ScreenGeometry,
    sitting: u32,
    trial: usize,
) -> Vec<EventRow> {
    let n = samples
        .iter()
        .rposition(|s| s.order.is_timed() && s.mapped_us <= response_us)
        .map_or(0, |i| i + 1);
    let samples = &samples[..n];
    let classified = classify(samples, geometry, &IvtConfig::default());
    let events = merge_congruent_fixations(
        &classified.events,
        geometry,
        CONGRUENT_DEG,
        CONGRUENT_GAP_US,
    );
    events
        .into_iter()
        .map(|e| {
            let (kind, (x, y), (ex, ey)) = match e.kind {
                EventKind::Fixation { centroid_px } => (
                    "fixation",
                    (centroid_px[0], centroid_px[1]),
                    (centroid_px[0], centroid_px[1]),
                ),
                EventKind::Saccade { .. } => {
                    let at = |i: usize| samples[i].gaze.unwrap_or([f64::NAN, f64::NAN]);
                    let (a, b) = (at(e.first), at(e.last));
                    ("saccade", (a[0], a[1]), (b[0], b[1]))
                }
                EventKind::Blink => ("blink", (f64::NAN, f64::NAN), (f64::NAN, f64::NAN)),
                EventKind::Lost => ("lost", (f64::NAN, f64::NAN), (f64::NAN, f64::NAN)),
            };
            EventRow {
                sitting,
                trial: Some(trial),
                kind: kind.into(),
                onset_us: e.start_us,
                end_us: e.end_us,
                onset_device_us: e.start_device_us,
                end_device_us: e.end_device_us,
                x_px: x,
                y_px: y,
                end_x_px: ex,
                end_y_px: ey,
            }
        })
        .collect()
}

/// The clicked cell and whether it is the target's: `click` is `None`
/// where the design asks for no click (neither is known), `Some(None)` for
/// a click on no object (wrong).
pub fn score_click(
    click: Option<Option<(u32, u32)>>,
    target_cell: (u32, u32),
) -> (Option<(u32, u32)>, Option<bool>) {
    match click {
        Some(Some(c)) => (Some(c), Some(c == target_cell)),
        Some(None) => (None, Some(false)),
        None => (None, None),
    }
}
