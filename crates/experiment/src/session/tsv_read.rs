//! Reading a session's TSV file into rows: the header checked against the
//! schema, errors that name the line and column, a half-written last line
//! skipped with a warning.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::{fmt, io};

use super::de;
use super::error::SessionFileError;
use super::rows::TsvRow;

/// Something [`read_tsv`] skipped rather than failed on (a half-written
/// last line of a killed session).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadWarning {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number.
    pub line: u64,
    /// What was skipped and why.
    pub message: String,
}

impl fmt::Display for ReadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: line {}: {}",
            self.path.display(),
            self.line,
            self.message
        )
    }
}

/// The rows of a TSV file, with their line numbers and any warnings.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOutcome<T> {
    /// The rows, in file order.
    pub rows: Vec<T>,
    /// `lines[i]` is the 1-based line number of `rows[i]`.
    pub lines: Vec<u64>,
    /// Lines skipped (a half-written last line).
    pub warnings: Vec<ReadWarning>,
}

pub(crate) fn tsv_reader<R: Read>(r: R) -> csv::Reader<R> {
    csv::ReaderBuilder::new()
        .delimiter(b'\t')
        .has_headers(true)
        .quoting(false)
        .flexible(false)
        .from_reader(r)
}

/// Length of the file up to and including its last `\n` (0 if none).
pub(crate) fn complete_len(file: &mut File, len: u64) -> io::Result<u64> {
    let mut end = len;
    let mut buf = vec![0u8; 64 * 1024];
    while end > 0 {
        let start = end.saturating_sub(buf.len() as u64);
        let chunk = &mut buf[..(end - start) as usize];
        file.seek(SeekFrom::Start(start))?;
        file.read_exact(chunk)?;
        if let Some(i) = chunk.iter().rposition(|&b| b == b'\n') {
            return Ok(start + i as u64 + 1);
        }
        end = start;
    }
    Ok(0)
}

pub(crate) fn shown(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let text = text.replace('\t', " | ");
    if text.chars().count() > 80 {
        format!("{}…", text.chars().take(80).collect::<String>())
    } else {
        text
    }
}

/// Reads every row of a session TSV file.
///
/// The header must be exactly [`TsvRow::COLUMNS`], or the header of a file
/// written before the [`TsvRow::LATER_COLUMNS`] (those columns left off
/// the end: their fields read as `None`). A last line without its
/// `\n` (a killed writer) is skipped with a warning, whatever it holds;
/// every other problem is an error naming the file, the line and, where
/// known, the column.
pub fn read_tsv<T: TsvRow>(path: &Path) -> Result<ReadOutcome<T>, SessionFileError> {
    let mut out = ReadOutcome {
        rows: Vec::new(),
        lines: Vec::new(),
        warnings: Vec::new(),
    };
    visit_tsv::<T>(path, |row, line| {
        out.rows.push(row);
        out.lines.push(line);
        Ok(())
    })
    .map(|w| {
        out.warnings = w;
    })?;
    Ok(out)
}

/// Streams the rows of a session TSV file to `each(row, line)` (for files
/// too large to hold, such as a long session's samples). Same rules as
/// [`read_tsv`]; returns the warnings.
pub fn visit_tsv<T: TsvRow>(
    path: &Path,
    mut each: impl FnMut(T, u64) -> Result<(), SessionFileError>,
) -> Result<Vec<ReadWarning>, SessionFileError> {
    let io_err = |e| SessionFileError::io(path, e);
    let (mut file, len) = input_file::open(path, input_file::SESSION_STREAM).map_err(io_err)?;
    let good = complete_len(&mut file, len).map_err(io_err)?;
    let mut warnings = Vec::new();
    if len == 0 {
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line: 1,
            message: "the file is empty (no header): no rows".into(),
        });
        return Ok(warnings);
    }
    let mut partial = None;
    if good < len {
        let mut tail = Vec::new();
        file.seek(SeekFrom::Start(good)).map_err(io_err)?;
        file.read_to_end(&mut tail).map_err(io_err)?;
        partial = Some(tail);
    }
    file.seek(SeekFrom::Start(0)).map_err(io_err)?;
    if good == 0 {
        // Only a partial header line.
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line: 1,
            message: format!(
                "incomplete header line (no line end; the writer was stopped?) skipped: {:?}",
                shown(partial.as_deref().unwrap_or_default())
            ),
        });
        return Ok(warnings);
    }
    let mut rdr = tsv_reader(BufReader::new(file.take(good)));
    let expected = T::header_line();
    let header = rdr.headers().map_err(|e| csv_error(path, e, T::COLUMNS))?;
    let found = header.iter().collect::<Vec<_>>().join("\t");
    // An older file without the later columns: its rows have fewer fields
    // (csv holds every record to the header's length), and the missing
    // ones take their serde default.
    if T::header_columns(&found).is_none() {
        return Err(SessionFileError::Header {
            path: path.to_path_buf(),
            expected: expected.replace('\t', " | "),
            found: found.replace('\t', " | "),
        });
    }
    let mut record = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, e, T::COLUMNS)),
        }
        let line = record.position().map_or(0, |p| p.line());
        let row: T = de::from_fields(&record).map_err(|(i, message)| SessionFileError::Parse {
            path: path.to_path_buf(),
            line,
            column: Some(
                T::COLUMNS
                    .get(i)
                    .map_or_else(|| format!("#{}", i + 1), |c| c.to_string()),
            ),
            message,
        })?;
        each(row, line)?;
    }
    if let Some(tail) = partial {
        let line = rdr.position().line();
        warnings.push(ReadWarning {
            path: path.to_path_buf(),
            line,
            message: format!(
                "incomplete last line (no line end; the writer was stopped?) skipped: {:?}",
                shown(&tail)
            ),
        });
    }
    Ok(warnings)
}

pub(crate) fn csv_error(path: &Path, e: csv::Error, columns: &[&str]) -> SessionFileError {
    let column_name = |i: u64| {
        columns
            .get(i as usize)
            .map(|c| c.to_string())
            .unwrap_or_else(|| format!("#{}", i + 1))
    };
    match e.into_kind() {
        csv::ErrorKind::Io(source) => SessionFileError::io(path, source),
        csv::ErrorKind::Utf8 { pos, err } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: Some(column_name(err.field() as u64)),
            message: format!("not UTF-8 text ({err})"),
        },
        csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: None,
            message: format!("{len} fields, expected {expected_len} (a tab too many or too few?)"),
        },
        csv::ErrorKind::Deserialize { pos, err } => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: pos.map_or(0, |p| p.line()),
            column: err.field().map(column_name),
            message: match err.kind() {
                csv::DeserializeErrorKind::Message(m) => m.clone(),
                other => other.to_string(),
            },
        },
        other => SessionFileError::Parse {
            path: path.to_path_buf(),
            line: 0,
            column: None,
            message: format!("{other:?}"),
        },
    }
}
