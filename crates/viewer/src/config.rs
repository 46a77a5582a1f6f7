//! Loading RON configuration files with errors that name the file, the line
//! and the field.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Deserialize;

use raycast::{Scene, SceneError, SceneFile};

/// A configuration file that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{path}: cannot read the file: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {field_note}{message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        column: usize,
        field: Option<String>,
        field_note: String,
        message: String,
    },
}

impl ConfigError {
    fn invalid(
        path: &Path,
        line: usize,
        column: usize,
        field: Option<String>,
        message: String,
    ) -> Self {
        let field_note = field
            .as_ref()
            .map(|f| format!("field `{f}`: "))
            .unwrap_or_default();
        ConfigError::Invalid {
            path: path.to_path_buf(),
            line,
            column,
            field,
            field_note,
            message,
        }
    }

    /// The field the error is about, when known.
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Invalid { field, .. } => field.as_deref(),
            ConfigError::Read { .. } => None,
        }
    }

    /// The 1-based line the error is about (0 when unknown).
    pub fn line(&self) -> usize {
        match self {
            ConfigError::Invalid { line, .. } => *line,
            ConfigError::Read { .. } => 0,
        }
    }
}

/// Reads and parses a RON file.
pub fn load<T: DeserializeOwned>(path: &Path) -> Result<(T, String), ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let value = parse(path, &text)?;
    Ok((value, text))
}

/// Parses RON `text` that came from `path` (used in messages only).
pub fn parse<T: DeserializeOwned>(path: &Path, text: &str) -> Result<T, ConfigError> {
    ron::from_str(text).map_err(|e| {
        let (line, column) = (e.position.line, e.position.col);
        let field = match &e.code {
            ron::Error::MissingStructField { field, .. } => Some((*field).to_string()),
            ron::Error::NoSuchStructField { found, .. } => Some(found.clone()),
            ron::Error::DuplicateStructField { field, .. } => Some((*field).to_string()),
            _ => field_before(text, line, column),
        };
        ConfigError::invalid(path, line, column, field, e.code.to_string())
    })
}

/// A value that parsed but makes no sense, reported at its field's line.
pub fn invalid_field(path: &Path, text: &str, field: &str, message: String) -> ConfigError {
    let (line, column) = locate(text, field).unwrap_or((0, 0));
    ConfigError::invalid(path, line, column, Some(field.to_string()), message)
}

/// Line and column of a dotted field path. `objects[3].mesh` is the fourth
/// `mesh:` after `objects:`; otherwise the innermost named segment is looked
/// up first (`driver.rate_hz` → `rate_hz`), then outwards (`size_mm.0` →
/// `size_mm`).
fn locate(text: &str, field: &str) -> Option<(usize, usize)> {
    let segments: Vec<&str> = field.split('.').collect();
    if let Some(k) = segments.iter().position(|s| s.ends_with(']')) {
        let (name, index) = segments[k].trim_end_matches(']').split_once('[')?;
        let index: usize = index.parse().ok()?;
        let (start, _) = find_field_from(text, name, 0)?;
        let Some(inner) = segments.get(k + 1) else {
            return Some((start, 1));
        };
        let mut line = start;
        for _ in 0..=index {
            match find_field_from(text, inner, line) {
                Some((l, _)) => line = l,
                // Not every element names the field (`effects[1].half_px`
                // where effect 0 has no parameters): the first one after
                // the list, else the list itself.
                None => {
                    return find_field_from(text, inner, start - 1).or(Some((start, 1)));
                }
            }
        }
        return find_field_from(text, inner, line - 1);
    }
    field
        .rsplit('.')
        .filter(|seg| !seg.chars().all(|c| c.is_ascii_digit()))
        .find_map(|seg| find_field_from(text, seg, 0))
}

/// Line and column (1-based) of the first `name:` on a line after line
/// `after` (0 = from the start), outside comments.
fn find_field_from(text: &str, name: &str, after: usize) -> Option<(usize, usize)> {
    for (i, line) in text.lines().enumerate().skip(after) {
        let code = line.split("//").next().unwrap_or("");
        if let Some(col) = code.find(name) {
            let before_ok = code[..col]
                .chars()
                .last()
                .is_none_or(|c| !c.is_alphanumeric() && c != '_');
            let after = code[col + name.len()..].trim_start();
            if before_ok && after.starts_with(':') {
                return Some((i + 1, col + 1));
            }
        }
    }
    None
}

/// The nearest `identifier:` at or before a position: the field whose value
/// the parser was reading.
fn field_before(text: &str, line: usize, column: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().collect();
    let last = line.min(lines.len());
    for l in (0..last).rev() {
        let mut code = lines[l].split("//").next().unwrap_or("");
        if l + 1 == line {
            let end = code
                .char_indices()
                .nth(column.saturating_sub(1))
                .map_or(code.len(), |(i, _)| i);
            code = &code[..end];
        }
        if let Some(colon) = code.rfind(':') {
            let ident: String = code[..colon]
                .trim_end()
                .chars()
                .rev()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect();
            if !ident.is_empty() {
                return Some(ident);
            }
        }
    }
    None
}

/// Loads a display file and checks its values.
pub fn load_display(path: &Path) -> Result<foveation::Display, ConfigError> {
    let (display, text): (foveation::Display, String) = load(path)?;
    display.geometry().map_err(|e| {
        invalid_field(
            path,
            &text,
            e.field,
            format!("{} = {}: {}", e.field, e.value, e.reason),
        )
    })?;
    Ok(display)
}

/// Loads a tracker file and checks its values.
pub fn load_tracker(path: &Path) -> Result<tracker_hal::TrackerConfig, ConfigError> {
    let (tracker, text): (tracker_hal::TrackerConfig, String) = load(path)?;
    tracker
        .validate()
        .map_err(|(field, message)| invalid_field(path, &text, &field, message))?;
    Ok(tracker)
}

/// Loads a calibration file (written by `gazecast calibrate` or
/// `tracker_hal::calibration`); errors name the file, line and field.
pub fn load_calibration(path: &Path) -> Result<tracker_hal::calibration::Calibration, ConfigError> {
    use tracker_hal::calibration::Model;
    let (c, text): (tracker_hal::calibration::Calibration, String) = load(path)?;
    let need = match c.model {
        Model::Affine => 6,
        Model::Homography => 9,
        Model::Polynomial2 => 12,
    };
    if c.params.len() != need || !c.params.iter().all(|v| v.is_finite()) {
        return Err(invalid_field(
            path,
            &text,
            "params",
            format!(
                "{:?} needs {need} finite parameters, found {}",
                c.model,
                c.params.len()
            ),
        ));
    }
    let finite = |n: &tracker_hal::calibration::Normaliser| {
        n.centre.iter().all(|v| v.is_finite()) && n.scale.is_finite() && n.scale > 0.0
    };
    if !finite(&c.raw) || !finite(&c.screen) {
        return Err(invalid_field(
            path,
            &text,
            "raw",
            "normalisers need finite centres and a positive scale".into(),
        ));
    }
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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_type_error_names_the_field_being_read() {
        let text = GOOD.replace("eye_distance_mm: 500.0", "eye_distance_mm: \"far\"");
        let err =
            parse::<foveation::Display>(Path::new("d.ron"), &text).expect_err("string distance");
        assert_eq!(err.field(), Some("eye_distance_mm"), "{err}");
        assert_eq!(err.line(), 5);
    }

    #[test]
    fn missing_and_unknown_fields_are_named() {
        let text = GOOD.replace("  eye_distance_mm: 500.0,\n", "");
        let err = parse::<foveation::Display>(Path::new("d.ron"), &text).expect_err("missing");
        assert_eq!(err.field(), Some("eye_distance_mm"), "{err}");
        let text = GOOD.replace("name:", "nmae:");
        let err = parse::<foveation::Display>(Path::new("d.ron"), &text).expect_err("unknown");
        assert_eq!(err.field(), Some("nmae"), "{err}");
        assert_eq!(err.line(), 2, "{err}");
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
