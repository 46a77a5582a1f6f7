//! Loads gazecast's RON configuration files, with errors that name the
//! file, the line and the field.
//!
//! [`load`] and [`parse`] locate serde's errors, and
//! [`invalid_field`] places a value that parsed but makes no sense at its
//! field's line (`objects[3].mesh`, `size_mm.1`), found in the text by a
//! small RON scanner (comments, nesting, list elements on a shared line).
//! Numbers printed in messages are shortened to a readable form.
//!
//! Every configuration reader of gazecast (displays, scenes, designs,
//! trackers, calibrations) goes through it; files are read with
//! [`input_file`] (a regular file, at most [`input_file::CONFIG`] bytes).

#![warn(missing_docs)]

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

/// A configuration file that could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (missing, not a regular file, too large, I/O error).
    #[error("{path}: cannot read the file: {source}")]
    Read {
        /// The file as the caller named it.
        path: PathBuf,
        /// The reading error, from [`input_file`].
        source: std::io::Error,
    },
    /// The file was read but is not valid RON for the expected type, or a
    /// value in it makes no sense ([`invalid_field`]).
    #[error("{path}:{line}:{column}: {field_note}{message}")]
    Invalid {
        /// The file as the caller named it.
        path: PathBuf,
        /// 1-based line of the error; 0 when unknown.
        line: usize,
        /// 1-based column of the error; 0 when unknown.
        column: usize,
        /// Dotted path of the field the error is about (`objects[3].mesh`), when known.
        field: Option<String>,
        /// "field `NAME`: " when the field is known, else empty (the message's prefix).
        field_note: String,
        /// What is wrong, with long numbers shortened.
        message: String,
    },
}

impl ConfigError {
    /// An error at `line`:`column` of `path` (0 when unknown), about
    /// `field` when known; long numbers in `message` are shortened.
    pub fn invalid(
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

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "Display(\n  name: \"x\",\n  resolution_px: (100, 80),\n  size_mm: (50.0, 40.0),\n  eye_distance_mm: 500.0,\n)";

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
        let err = load::<foveation::Display>(Path::new("/nonexistent/display.ron"))
            .expect_err("missing file");
        assert!(
            err.to_string()
                .contains("/nonexistent/display.ron: cannot read"),
            "{err}"
        );
    }
}

/// The README's examples, compiled and run as doc-tests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
