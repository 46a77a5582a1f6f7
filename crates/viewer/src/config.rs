//! Loading RON configuration files with errors that name the file, the line
//! and the field.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use raycast::{Scene, SceneError, SceneFile};

pub use foveation::fmt_f64;
pub use ron_config::{invalid_field, load, parse, ConfigError};

/// Nearest eye distance accepted, mm: 1 mm.
pub const MIN_EYE_DISTANCE_MM: f64 = 1.0;
/// Farthest eye distance accepted, mm: 100 m.
pub const MAX_EYE_DISTANCE_MM: f64 = 100_000.0;
/// Smallest screen side accepted, mm: 1 mm.
pub const MIN_SIZE_MM: f64 = 1.0;
/// Largest screen side accepted, mm: 100 m.
pub const MAX_SIZE_MM: f64 = 100_000.0;

/// Checks a display and returns its geometry: `Display::geometry`'s
/// checks (finite, positive, the resolution limits), then physical ranges
/// that keep every derived quantity (pixel pitch, pixels per degree, the
/// ray mask) finite and meaningful: `eye_distance_mm` from
/// [`MIN_EYE_DISTANCE_MM`] to [`MAX_EYE_DISTANCE_MM`] (1 mm to 100 m),
/// each side of `size_mm` from [`MIN_SIZE_MM`] to [`MAX_SIZE_MM`], and
/// `eye_point_px` within one screen width (height) of the screen.
pub fn check_display(
    display: &foveation::Display,
) -> Result<foveation::ScreenGeometry, foveation::ParamError> {
    let g = display.geometry()?;
    let d = display.eye_distance_mm;
    if !(MIN_EYE_DISTANCE_MM..=MAX_EYE_DISTANCE_MM).contains(&d) {
        return Err(foveation::ParamError::new(
            "eye_distance_mm",
            fmt_f64(d),
            "must be from 1 mm to 100 m (100000 mm)",
        ));
    }
    for (field, v) in [
        ("size_mm.0", display.size_mm.0),
        ("size_mm.1", display.size_mm.1),
    ] {
        if !(MIN_SIZE_MM..=MAX_SIZE_MM).contains(&v) {
            return Err(foveation::ParamError::new(
                field,
                fmt_f64(v),
                "must be from 1 mm to 100 m (100000 mm)",
            ));
        }
    }
    let [w, h] = g.size_px();
    for (field, v, side) in [
        ("eye_point_px.0", g.eye_point_px[0], w),
        ("eye_point_px.1", g.eye_point_px[1], h),
    ] {
        if !(-side..=2.0 * side).contains(&v) {
            return Err(foveation::ParamError::new(
                field,
                fmt_f64(v),
                format!(
                    "must be within one screen of the screen (-{side} to {} px)",
                    2.0 * side
                ),
            ));
        }
    }
    Ok(g)
}

/// Loads a display file and checks its values ([`check_display`]).
pub fn load_display(path: &Path) -> Result<foveation::Display, ConfigError> {
    let (display, text): (foveation::Display, String) = load(path)?;
    check_display(&display).map_err(|e| {
        invalid_field(
            path,
            &text,
            e.field,
            format!("{} = {}: {}", e.field, e.value, e.reason),
        )
    })?;
    Ok(display)
}

/// Loads a simulated observer's search model
/// (`experiment::run::observer`) and checks it; errors name the file, the
/// line and the field.
pub fn load_observer(path: &Path) -> Result<experiment::run::observer::ObserverModel, ConfigError> {
    let (model, text): (experiment::run::observer::ObserverModel, String) = load(path)?;
    model
        .validate()
        .map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok(model)
}

/// Loads an experiment design and checks it
/// (`experiment::Design::validate`); errors name the file, line and field.
pub fn load_design(path: &Path) -> Result<experiment::Design, ConfigError> {
    load_design_checked(path, |_| Ok(())).map(|(design, ())| design)
}

/// [`load_design`], then `check` on the design (against the display it
/// will run on, say); a `(field, message)` it returns is located in the
/// design file like a validation error.
pub fn load_design_checked<T>(
    path: &Path,
    check: impl FnOnce(&experiment::Design) -> Result<T, (String, String)>,
) -> Result<(experiment::Design, T), ConfigError> {
    let (design, text): (experiment::Design, String) = load(path)?;
    design.validate().map_err(|e| match e {
        experiment::DesignError::Invalid { field, message } => {
            invalid_field(path, &text, &field, message)
        }
        other => ConfigError::invalid(path, 0, 0, None, other.to_string()),
    })?;
    // Every condition's method is one the renderer knows (built in or a
    // registered module), named where the file names it.
    for (i, c) in design.conditions.iter().enumerate() {
        if let Err(e) = pipeline::Method::from_name(&c.method) {
            let field = format!("conditions[{i}].method");
            return Err(invalid_field(path, &text, &field, e.to_string()));
        }
    }
    let checked =
        check(&design).map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok((design, checked))
}

/// Loads a tracker file and checks its values, and that its mapping takes
/// the tracker's whole range onto the screen
/// (`tracker_hal::Mapping::check_range`).
pub fn load_tracker(path: &Path) -> Result<tracker_hal::TrackerConfig, ConfigError> {
    let (tracker, text): (tracker_hal::TrackerConfig, String) = load(path)?;
    tracker
        .validate()
        .map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok(tracker)
}

/// Loads a calibration file (written by `gazecast calibrate` or
/// `tracker_hal::calibration`); errors name the file, line and field.
/// Every value is checked, and the calibration must map its whole raw
/// range onto finite points near its screen
/// (`tracker_hal::calibration::Calibration::check`).
pub fn load_calibration(path: &Path) -> Result<tracker_hal::calibration::Calibration, ConfigError> {
    let (c, text): (tracker_hal::calibration::Calibration, String) = load(path)?;
    c.check()
        .map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok(c)
}

/// `config/default.ron`: which files a command uses when given none.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Defaults {
    /// Display file, relative to the defaults file.
    pub display: PathBuf,
}

/// Where the defaults file is looked for: `$GAZECAST_CONFIG`, else
/// `config/default.ron` under the current directory.
pub fn defaults_path() -> PathBuf {
    std::env::var_os("GAZECAST_CONFIG")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("config/default.ron"))
}

/// The default display file, resolved relative to the defaults file.
pub fn default_display_path() -> Result<PathBuf, ConfigError> {
    let path = defaults_path();
    let (defaults, _): (Defaults, String) = load(&path)?;
    Ok(path
        .parent()
        .unwrap_or(Path::new("."))
        .join(defaults.display))
}

/// Loads and builds a scene; errors name the file, line and field.
pub fn load_scene(path: &Path) -> Result<Scene, String> {
    let (file, text): (SceneFile, String) = load(path).map_err(|e| e.to_string())?;
    let dir = path.parent().unwrap_or(Path::new("."));
    Scene::build(&file, dir).map_err(|e| match e {
        SceneError::Field { field, message } => {
            invalid_field(path, &text, &field, message).to_string()
        }
        mesh @ SceneError::Mesh { .. } => format!("{}: {mesh}", path.display()),
    })
}

/// Loads a degradation table (`foveation::degradation::DegradationTable`,
/// RON) and checks it: every error names the file, the line and the field
/// (`extents_deg.2`: row 2; the line is the field's, as `ron-config` places
/// tuple indices).
pub fn load_degradation(
    path: &Path,
) -> Result<foveation::degradation::DegradationTable, ConfigError> {
    let (table, text): (foveation::degradation::DegradationTable, String) = load(path)?;
    table
        .check()
        .map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_degradation_table_names_file_line_and_field() {
        let good = "(\n  source: \"t\",\n  depth_subtended_deg: (26.0, 24.0, 22.0, 20.0, 18.0),\n  extents_deg: (\n    (1.0, 2.0, 3.0, 4.0, 5.0),\n    (1.0, 2.0, 3.0, 4.0, 5.0),\n    (1.0, 2.0, -3.0, 4.0, 5.0),\n    (1.0, 2.0, 3.0, 4.0, 5.0),\n    (1.0, 2.0, 3.0, 4.0, 5.0),\n  ),\n)";
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("t.ron");
        std::fs::write(&path, good.replace("-3.0", "3.0")).expect("write");
        let t = load_degradation(&path).expect("a good table");
        assert!(!t.synthetic);
        std::fs::write(&path, good).expect("write");
        let err = load_degradation(&path).expect_err("a negative extent");
        assert_eq!(err.field(), Some("extents_deg.2"));
        // ron-config places a tuple index at the tuple's field (its line).
        assert_eq!(err.line(), 4, "{err}");
        assert!(err.to_string().contains("t.ron"), "{err}");
        std::fs::write(&path, good.replace("source", "sorce")).expect("write");
        assert!(load_degradation(&path).is_err());
    }

    const GOOD: &str = "Display(\n  name: \"x\",\n  resolution_px: (100, 80),\n  size_mm: (50.0, 40.0),\n  eye_distance_mm: 500.0,\n)";

    #[test]
    fn a_bad_value_names_line_and_field() {
        let text = GOOD.replace("(50.0, 40.0)", "(50.0, -4.0)");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("d.ron");
        std::fs::write(&path, text).expect("write");
        let err = load_display(&path).expect_err("negative height");
        assert_eq!(err.field(), Some("size_mm.1"));
        assert_eq!(err.line(), 4);
        let msg = err.to_string();
        assert!(
            msg.contains("d.ron:4:") && msg.contains("size_mm.1"),
            "{msg}"
        );
    }

    /// A condition's method the renderer does not know is refused when
    /// the design loads, naming the file, line and field; every method it
    /// knows (built in or registered) loads.
    #[test]
    fn an_unknown_method_in_a_design_names_file_line_and_field() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let text = std::fs::read_to_string(root.join("config/experiments/murphy2007-search.ron"))
            .expect("the seed design");
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("e.ron");
        let control = r#"method: "full""#;
        assert!(text.contains(control));
        std::fs::write(&path, text.replacen(control, r#"method: "ful""#, 1)).expect("write");
        let err = load_design(&path).expect_err("unknown method");
        assert_eq!(err.field(), Some("conditions[0].method"), "{err}");
        let msg = err.to_string();
        assert!(
            msg.contains("e.ron:") && msg.contains("unknown method \"ful\""),
            "{msg}"
        );
        for m in pipeline::Method::all().filter(|m| !m.follows_gaze()) {
            let named = format!("method: {:?}", m.name());
            std::fs::write(&path, text.replacen(control, &named, 1)).expect("write");
            load_design(&path).unwrap_or_else(|e| panic!("{}: {e}", m.name()));
        }
    }

    #[test]
    fn a_missing_file_says_so() {
        let err = load_display(Path::new("/nonexistent/display.ron")).expect_err("missing file");
        assert!(
            err.to_string()
                .contains("/nonexistent/display.ron: cannot read"),
            "{err}"
        );
    }
}
