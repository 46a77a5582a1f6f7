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
        let message = tidy_numbers(&message);
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
    let text = input_file::read_to_string(path, input_file::CONFIG).map_err(|source| {
        ConfigError::Read {
            path: path.to_path_buf(),
            source,
        }
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

/// Rewrites every decimal number in `message` longer than 16 characters
/// (`1e-300` printed as 300 digits) with [`fmt_f64`]'s
/// rule: six significant digits in scientific notation outside 1e-4..1e9.
/// Integers of up to 20 digits (any `u64`: sizes, counts) are kept.
fn tidy_numbers(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let bytes = message.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let starts = c.is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if !starts {
            let ch = message[i..].chars().next().unwrap_or(' ');
            out.push(ch);
            i += ch.len_utf8();
            continue;
        }
        let mut j = i;
        while j < bytes.len()
            && (bytes[j].is_ascii_digit()
                || (bytes[j] == b'.' && j + 1 < bytes.len() && bytes[j + 1].is_ascii_digit()))
        {
            j += 1;
        }
        let token = &message[i..j];
        let integer = !token.contains('.');
        match token.parse::<f64>() {
            Ok(v) if token.len() > 16 && !(integer && token.len() <= 20) => {
                out.push_str(&fmt_f64(v))
            }
            _ => out.push_str(token),
        }
        i = j;
    }
    out
}

/// Six significant digits in scientific notation outside 1e-4..1e9 (the
/// rule of `ParamError`'s values).
pub use foveation::fmt_f64;

/// Line and column (1-based) of a dotted field path, found by walking the
/// text: each named segment is the first `name:` (or map key `"name":`)
/// after the previous one and inside its value; `list[k]` is the k-th
/// element of the list `list: [...]`, counted at the list's own nesting
/// level, so several objects on one line are told apart. Tuple indices
/// (`size_mm.0`) point at the tuple's field. When the walk finds nothing,
/// the innermost named segment is looked up on its own, then outwards.
fn locate(text: &str, field: &str) -> Option<(usize, usize)> {
    let code = strip_comments(text);
    let mut scope = (0, code.len());
    let mut found: Option<usize> = None;
    for segment in field.split('.') {
        if segment.chars().all(|c| c.is_ascii_digit()) {
            continue;
        }
        let (name, index) = match segment.strip_suffix(']').and_then(|s| s.split_once('[')) {
            Some((n, k)) => (n, k.parse::<usize>().ok()),
            None => (segment, None),
        };
        let Some((key, value)) = find_key(&code, name, scope) else {
            continue;
        };
        found = Some(key);
        scope = (value, value_end(&code, value, scope.1));
        if let Some(k) = index {
            match list_element(&code, scope, k) {
                Some(element) => {
                    found = Some(element.0);
                    scope = element;
                }
                // No such element: the list itself.
                None => break,
            }
        }
    }
    match found {
        Some(pos) => Some(line_col(&code, pos)),
        None => field
            .rsplit('.')
            .map(|seg| seg.split('[').next().unwrap_or(seg))
            .filter(|seg| !seg.is_empty() && !seg.chars().all(|c| c.is_ascii_digit()))
            .find_map(|seg| find_field_from(text, seg, 0)),
    }
}

/// `text` with `//` comments blanked out (same byte positions).
fn strip_comments(text: &str) -> String {
    text.lines()
        .map(|line| match line.find("//") {
            Some(k) => format!("{}{}", &line[..k], " ".repeat(line.len() - k)),
            None => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// 1-based line and column of byte `pos`.
fn line_col(code: &str, pos: usize) -> (usize, usize) {
    let before = &code[..pos.min(code.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |k| k + 1) + 1;
    (line, column)
}

/// The first key `name:` or `"name":` in `scope`: (key start, value start).
fn find_key(code: &str, name: &str, scope: (usize, usize)) -> Option<(usize, usize)> {
    let hay = &code[scope.0..scope.1];
    let bytes = hay.as_bytes();
    let mut from = 0;
    while let Some(k) = hay[from..].find(name) {
        let at = from + k;
        from = at + name.len();
        let quoted = at > 0 && bytes[at - 1] == b'"' && bytes.get(from) == Some(&b'"');
        let before_ok =
            at == 0 || !(bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_');
        let after = if quoted { from + 1 } else { from };
        if !(quoted || before_ok) {
            continue;
        }
        if !quoted
            && bytes
                .get(from)
                .is_some_and(|b| b.is_ascii_alphanumeric() || *b == b'_')
        {
            continue;
        }
        let rest = &hay[after..];
        let trimmed = rest.trim_start();
        if let Some(value) = trimmed.strip_prefix(':') {
            let start = if quoted { at - 1 } else { at };
            let value_at = hay.len() - value.len();
            return Some((scope.0 + start, scope.0 + value_at));
        }
    }
    None
}

/// Where the value starting at `start` ends: the first `,` or closing
/// bracket at its own nesting level (or `limit`).
fn value_end(code: &str, start: usize, limit: usize) -> usize {
    let mut depth = 0i32;
    let mut in_string = false;
    let bytes = code.as_bytes();
    let mut i = start;
    while i < limit.min(bytes.len()) {
        let b = bytes[i];
        if in_string {
            if b == b'\\' {
                i += 1;
            } else if b == b'"' {
                in_string = false;
            }
        } else {
            match b {
                b'"' => in_string = true,
                b'(' | b'[' | b'{' => depth += 1,
                b')' | b']' | b'}' => {
                    if depth == 0 {
                        return i;
                    }
                    depth -= 1;
                }
                b',' if depth == 0 => return i,
                _ => {}
            }
        }
        i += 1;
    }
    limit
}

/// The `k`-th element of the list whose value spans `scope` (from before
/// its `[`): the element's start and end.
fn list_element(code: &str, scope: (usize, usize), k: usize) -> Option<(usize, usize)> {
    let open = scope.0 + code[scope.0..scope.1].find('[')?;
    list_element_from(code, (open + 1, scope.1), k)
}

/// The `k`-th element of a list whose elements start at `scope.0`.
fn list_element_from(code: &str, scope: (usize, usize), k: usize) -> Option<(usize, usize)> {
    let skip = code[scope.0..scope.1].len() - code[scope.0..scope.1].trim_start().len();
    let start = scope.0 + skip;
    if start >= scope.1 || code[start..].starts_with(']') {
        return None;
    }
    let end = value_end(code, start, scope.1);
    if k == 0 {
        return Some((start, end));
    }
    if end >= scope.1 || code.as_bytes()[end] != b',' {
        return None;
    }
    list_element_from(code, (end + 1, scope.1), k - 1)
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
            let named = format!("method: {:?}", m.key());
            std::fs::write(&path, text.replacen(control, &named, 1)).expect("write");
            load_design(&path).unwrap_or_else(|e| panic!("{}: {e}", m.key()));
        }
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
    fn long_numbers_in_messages_are_shortened() {
        let huge = format!("{} must be a positive number", 1e308);
        assert_eq!(tidy_numbers(&huge), "1e308 must be a positive number");
        let tiny = format!("rate {} too small", 1e-300);
        assert_eq!(tidy_numbers(&tiny), "rate 1e-300 too small");
        // Ordinary numbers, 64-bit integers and identifiers stay.
        let plain = "size_mm.0 = 337.9, 18446744073709551615 px, bumpy0";
        assert_eq!(tidy_numbers(plain), plain);
    }

    #[test]
    fn list_elements_are_found_on_a_shared_line() {
        let text = "S(\n  objects: [\n    (mesh: \"a\", scale: 1.0), (mesh: \"b\", scale: (1, 2)),\n    (mesh: \"c\"), (mesh: \"d\"),\n  ],\n  params: [1.0, 2.0, NaN],\n)";
        assert_eq!(locate(text, "objects[1].mesh"), Some((3, 31)));
        assert_eq!(locate(text, "objects[1].scale"), Some((3, 42)));
        assert_eq!(locate(text, "objects[3].mesh"), Some((4, 19)));
        assert_eq!(locate(text, "objects[3]"), Some((4, 18)));
        assert_eq!(locate(text, "params[2]"), Some((6, 22)));
        assert_eq!(locate(text, "objects[9].mesh"), Some((2, 3)));
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
