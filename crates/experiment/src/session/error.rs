//! Why a session file could not be read or written.

use std::io;
use std::path::{Path, PathBuf};

/// Why a session file could not be read or written. Every variant names
/// the file; parse errors also the line and, where known, the column.
#[derive(Debug, thiserror::Error)]
pub enum SessionFileError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The header line is not the expected one.
    #[error("{}: line 1: the header is not the expected one\n  expected: {expected}\n  found:    {found}", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// The expected header (tab-separated, shown with tabs as ` | `).
        expected: String,
        /// The header found.
        found: String,
    },
    /// A row could not be parsed.
    #[error("{}: line {line}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column {c}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// Column name, where known.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A row could not be written (a tab or line break in a text field).
    #[error("{}: cannot write row {row}{}: {message}", path.display(), column.as_ref().map(|c| format!(", column {c}")).unwrap_or_default())]
    Write {
        /// The file.
        path: PathBuf,
        /// 1-based data row number within the file.
        row: u64,
        /// Column name, where known.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// `session.json` is not valid JSON of the expected shape.
    #[error("{}: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The cause (with line and column).
        source: serde_json::Error,
    },
}

impl SessionFileError {
    pub(crate) fn io(path: &Path, source: io::Error) -> Self {
        SessionFileError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            SessionFileError::Io { path, .. }
            | SessionFileError::Header { path, .. }
            | SessionFileError::Parse { path, .. }
            | SessionFileError::Write { path, .. }
            | SessionFileError::Json { path, .. } => path,
        }
    }
}
