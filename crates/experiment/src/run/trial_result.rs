//! What a finished trial records, apart from the files it goes to: its
//! eye-movement events over the samples captured up to the response
//! (fixations merged with the congruence thresholds), the confirming
//! click's score, its row of `trials.tsv` and the log's line.

use screen_geometry::ScreenGeometry;
use tracker_hal::events::{classify, merge_congruent_fixations, EventKind, IvtConfig, TimedGaze};

use crate::design::Design;
use crate::session::{EventRow, TrialRow};
use crate::Trial;

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
/// `sitting`, marked practice for a practice trial): those of its samples
/// captured up to `response_us` (on the mapped clock), classified by I-VT
/// and merged where congruent.
pub fn trial_events(
    samples: &[TimedGaze],
    response_us: u64,
    geometry: &ScreenGeometry,
    sitting: u32,
    trial: &Trial,
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
                trial: Some(trial.index),
                kind: kind.into(),
                onset_us: e.start_us,
                end_us: e.end_us,
                onset_device_us: e.start_device_us,
                end_device_us: e.end_device_us,
                x_px: x,
                y_px: y,
                end_x_px: ex,
                end_y_px: ey,
                practice: trial.practice,
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

/// What the runner measured of one trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// The search display's first frame presented (host µs).
    pub onset_us: u64,
    /// The response (host µs).
    pub response_us: u64,
    /// The confirming click, as [`score_click`] takes it.
    pub click: Option<Option<(u32, u32)>>,
    /// Search frames shown, and how many of them late.
    pub frames: u64,
    /// Of those frames, how many were presented late.
    pub frames_late: u64,
    /// Rays cast over the search frames.
    pub rays: u64,
    /// Triangles drawn over the search frames, for a method that draws
    /// triangles (the model-based `simplify` and `lod`, and `ulod`);
    /// `None` for the ray-cast methods.
    pub triangles: Option<u64>,
    /// Each search frame's render time (ms): the method and its passes,
    /// plus the full-resolution reference drawn over them.
    pub render_ms: Vec<f64>,
    /// The plan of the search frames (`Renderer::provenance`).
    pub plan: Option<String>,
}

/// Trial `trial`'s row of `trials.tsv` for `participant` in `sitting`:
/// the search time is the response minus the onset.
pub fn trial_row(
    design: &Design,
    trial: &Trial,
    participant: &str,
    sitting: u32,
    measured: &Measured,
    synthetic: bool,
) -> TrialRow {
    let condition = &design.conditions[trial.condition];
    let m = measured;
    let (clicked, correct) = score_click(m.click, trial.target_cell);
    TrialRow {
        participant: participant.to_string(),
        sitting,
        run: trial.run,
        trial: trial.index,
        trial_in_run: trial.trial_in_run,
        condition: condition.name.clone(),
        method: condition.method.clone(),
        inset_deg: condition.inset_deg,
        silhouette_edges: condition.silhouette_edges,
        target_mesh: trial.target_mesh,
        target_row: trial.target_cell.0,
        target_col: trial.target_cell.1,
        search_onset_us: m.onset_us,
        response_us: m.response_us,
        rt_s: m.response_us.saturating_sub(m.onset_us) as f64 / 1e6,
        clicked_row: clicked.map(|c| c.0),
        clicked_col: clicked.map(|c| c.1),
        correct,
        frames: m.frames,
        frames_late: m.frames_late,
        mean_rays: m.rays as f64 / (m.frames.max(1)) as f64,
        synthetic,
        plan: m.plan.clone(),
        reference_row: trial.reference_cell.map(|c| c.0),
        reference_col: trial.reference_cell.map(|c| c.1),
        mean_triangles: m.triangles.map(|t| t as f64 / (m.frames.max(1)) as f64),
        mean_render_ms: (!m.render_ms.is_empty())
            .then(|| m.render_ms.iter().sum::<f64>() / m.render_ms.len() as f64),
        p95_render_ms: (!m.render_ms.is_empty())
            .then(|| crate::stats::nearest_rank::percentile(&m.render_ms, 95.0)),
        practice: trial.practice,
    }
}

/// The log's line for a written trial `row`.
pub fn trial_line(row: &TrialRow) -> String {
    format!(
        "{}trial {} {}: {:.2} s, target {} at ({}, {}){}, {} frames ({} late), mean {:.0} rays",
        if row.practice { "practice " } else { "" },
        row.trial + 1,
        row.condition,
        row.rt_s,
        raycast::scene::FACE_EXPRESSIONS
            .get(row.target_mesh as usize)
            .copied()
            .unwrap_or("?"),
        row.target_row,
        row.target_col,
        match row.correct {
            Some(true) => ", clicked correctly",
            Some(false) => ", clicked WRONG",
            None => "",
        },
        row.frames,
        row.frames_late,
        row.mean_rays
    )
}
