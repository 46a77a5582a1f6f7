//! What the raycast benches share: paths, reading files, the renderer's
//! sampling model on a display, the foveated settings and a median.

use std::path::Path;

use foveation::{Display, GeislerPerry, Layout, SamplingModel, ScreenGeometry};
use raycast::ray::TriangleTest;
use raycast::render::{Mode, Settings, Triggers};
use raycast::Scene;

/// The repository root (where `config/` is).
pub fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

pub fn read(p: &Path) -> Result<String, String> {
    std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))
}

/// The display file's geometry and `pipeline::sampling_model(geometry,
/// 1.0)`, the renderer's model.
pub fn display_model(path: &Path) -> Result<(ScreenGeometry, SamplingModel), String> {
    let display: Display =
        ron::from_str(&read(path)?).map_err(|e| format!("{}: {e}", path.display()))?;
    let g = display.geometry().map_err(|e| e.to_string())?;
    let model = SamplingModel::new(
        g,
        GeislerPerry::default(),
        1.0,
        foveation::sampling::SEED_MAX_SPACING_PX,
    )
    .map_err(|e| e.to_string())?;
    Ok((g, model))
}

/// Foveated frames with the scene's refinement triggers (the default).
pub fn foveated(scene: &Scene) -> Settings {
    Settings {
        mode: Mode::Hybrid,
        layout: Layout::Nyquist,
        triggers: Triggers::from_scene(scene),
        test: TriangleTest::Watertight,
        check_coverage: false,
    }
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}
