//! A design's stimuli on the display they will be shown on, checked
//! before any session folder or window exists (`experiment run`,
//! `experiment plan`): objects big enough to be seen, the grid wholly on
//! the screen, the renderer's own check, and trial scenes that build.

use screen_geometry::ScreenGeometry;

use super::layout::Layout;
use super::stimulus::{preview_scene, search_scene};
use crate::design::Design;
use crate::Trial;

/// Smallest object a design may show: this many pixels across on the
/// session's display (a smaller one draws no recognisable face, or no
/// pixel at all).
pub const MIN_OBJECT_PX: f64 = 8.0;

/// The renderer's own check of a design on the display, which this crate
/// cannot make (the sampling model of the contrast and of each
/// condition's inset): the caller supplies it. `Err((field, message))`
/// names the design field.
pub type RendererCheck<'a> = &'a dyn Fn(&Design) -> Result<(), (String, String)>;

/// Participant `index`'s trials and the layout, the design checked on
/// `geometry` ([`check_on_display`]): what `experiment run` and
/// `experiment plan` do before anything else.
pub fn plan_on_display(
    design: &Design,
    index: usize,
    geometry: &ScreenGeometry,
    renderer: RendererCheck<'_>,
) -> Result<(Vec<Trial>, Layout), (String, String)> {
    let trials = crate::plan(design, index)
        .map_err(|e| (e.field().unwrap_or("runs").to_string(), e.to_string()))?;
    let layout = check_on_display(design, &trials, geometry, renderer)?;
    Ok((trials, layout))
}

/// The design's stimuli on the display they will be shown on, checked
/// before any session folder or window exists (`experiment run`,
/// `experiment plan`): every object at least [`MIN_OBJECT_PX`] across,
/// every cell's object wholly on the screen, the `renderer`'s own check
/// (every condition's sampling model buildable: contrast, inset), and the
/// trial scenes buildable
/// (the scene's triangle limit, sizes that underflow: the first trial's
/// search display and preview go through every check of `Scene::build`,
/// without the hierarchy, and every trial's scene has the same meshes,
/// object count and sizes). `Err((field, message))` names
/// the design field to change.
pub fn check_on_display(
    design: &Design,
    trials: &[Trial],
    geometry: &ScreenGeometry,
    renderer: RendererCheck<'_>,
) -> Result<Layout, (String, String)> {
    let s = &design.stimulus;
    let layout = Layout::new(design, geometry);
    // Pixels to one decimal, degrees as written (tiny or huge: 1e-42).
    let px = |v: f64| {
        if v.is_finite() && v.abs() >= 0.05 && v.abs() < 1e9 {
            format!("{v:.1}")
        } else {
            screen_geometry::fmt_f64(v)
        }
    };
    let deg = screen_geometry::fmt_f64;
    let [w, h] = geometry.size_px();
    let on = format!(
        "on this display ({}×{} px at {} mm)",
        geometry.width_px, geometry.height_px, geometry.eye_distance_mm
    );
    let across_px = 2.0 * layout.radius_px;
    if !(across_px.is_finite() && across_px >= MIN_OBJECT_PX) {
        // The angle that MIN_OBJECT_PX subtends at the screen centre.
        let pitch = geometry.pitch_x_mm.max(geometry.pitch_y_mm);
        let min_deg = 2.0
            * (MIN_OBJECT_PX * pitch / 2.0 / geometry.eye_distance_mm)
                .atan()
                .to_degrees();
        return Err((
            "stimulus.object_deg".into(),
            format!(
                "{}° is {} px across {on}: an object must be at least {MIN_OBJECT_PX} px \
                 ({min_deg:.2}°) across to be seen",
                deg(s.object_deg),
                px(across_px),
            ),
        ));
    }
    let r = layout.radius_px;
    for (k, c) in layout.centres_px.iter().enumerate() {
        let inside = c[0] - r >= 0.0 && c[0] + r <= w && c[1] - r >= 0.0 && c[1] + r <= h;
        if !(c[0].is_finite() && c[1].is_finite() && inside) {
            let (row, col) = (k as u32 / layout.cols, k as u32 % layout.cols);
            let first = layout.centres_px.first().copied().unwrap_or(*c);
            let last = layout.centres_px.last().copied().unwrap_or(*c);
            let (span_x, span_y) = (
                (last[0] - first[0]).abs() + 2.0 * r,
                (last[1] - first[1]).abs() + 2.0 * r,
            );
            let field = if s.grid_deg > s.object_deg {
                "stimulus.grid_deg"
            } else {
                "stimulus.grid"
            };
            return Err((
                field.into(),
                format!(
                    "the {}×{} grid ({}° wide, objects {}°) takes {} × {} px {on}: cell ({row}, \
                     {col}) at ({}, {}) px reaches off the screen; every object must be wholly \
                     on it",
                    s.grid.0,
                    s.grid.1,
                    deg(s.grid_deg),
                    deg(s.object_deg),
                    px(span_x),
                    px(span_y),
                    px(c[0]),
                    px(c[1])
                ),
            ));
        }
    }
    renderer(design)?;
    if let Some(t) = trials.first() {
        for file in [
            search_scene(design, t, &layout),
            preview_scene(design, t, &layout),
        ] {
            raycast::Scene::check(&file, std::path::Path::new(".")).map_err(|e| {
                (
                    "stimulus".to_string(),
                    format!("the trials' scene cannot be built {on}: {e}"),
                )
            })?;
        }
    }
    Ok(layout)
}
