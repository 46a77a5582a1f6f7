//! The append-only TSV log the runner writes: rows formatted whole,
//! flushed by the durability policy, columns added to an older file on
//! resume.

use std::fs::{File, OpenOptions};
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::atomic::AtomicFile;
use super::error::SessionFileError;
use super::layout::NA;
use super::rows::TsvRow;
use super::tsv_read::{complete_len, shown};

pub(crate) fn tsv_writer<W: Write>(w: W) -> csv::Writer<W> {
    csv::WriterBuilder::new()
        .delimiter(b'\t')
        .has_headers(false)
        .quote_style(csv::QuoteStyle::Never)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(w)
}

/// An append-only TSV log of `T` rows: see the module documentation for
/// the durability policy.
pub struct TsvLog<T: TsvRow> {
    path: PathBuf,
    file: File,
    pending: Vec<u8>,
    pending_rows: usize,
    rows: u64,
    flush_rows: usize,
    flush_interval: Duration,
    last_flush: Instant,
    dropped: Option<String>,
    added: &'static [&'static str],
    _row: PhantomData<fn(&T)>,
}

impl<T: TsvRow> TsvLog<T> {
    /// Opens `path` for appending rows: creates it with the header line,
    /// or opens an existing file after checking that its header line is
    /// [`TsvRow::COLUMNS`] (a mismatch is [`SessionFileError::Header`]
    /// naming the file). A half-written last line left by a killed writer
    /// is cut off first (see [`TsvLog::dropped_partial_line`]); an
    /// incomplete header line is rewritten.
    ///
    /// A file written before the [`TsvRow::LATER_COLUMNS`] (its header
    /// stops short of them) gets them first: the file is rewritten whole
    /// (through a temporary file and a rename) with the current header and
    /// `n/a` for those columns at the end of every row, every other byte
    /// kept ([`TsvLog::added_columns`] names them). A row whose field count
    /// is not its header's is an error, and the file is left untouched.
    pub fn append_to(path: impl AsRef<Path>) -> Result<Self, SessionFileError> {
        let path = path.as_ref();
        let io_err = |e| SessionFileError::io(path, e);
        let expected = T::header_line();
        let (added, upgrade_dropped) = add_later_columns::<T>(path)?;
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io_err)?;
        let len = file.metadata().map_err(io_err)?.len();
        let mut rows = 0;
        let mut dropped = None;
        let good = complete_len(&mut file, len).map_err(io_err)?;
        if good == 0 {
            // New, empty, or only part of the header line.
            let mut have = Vec::new();
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            file.read_to_end(&mut have).map_err(io_err)?;
            if !expected.as_bytes().starts_with(&have) {
                return Err(SessionFileError::Header {
                    path: path.to_path_buf(),
                    expected: expected.replace('\t', " | "),
                    found: shown(&have),
                });
            }
            file.set_len(0).map_err(io_err)?;
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            file.write_all(format!("{expected}\n").as_bytes())
                .map_err(io_err)?;
        } else {
            file.seek(SeekFrom::Start(0)).map_err(io_err)?;
            let mut reader = BufReader::new(&mut file);
            let mut first = Vec::new();
            reader.read_until(b'\n', &mut first).map_err(io_err)?;
            let found = String::from_utf8_lossy(&first);
            let found = found.trim_end_matches('\n').trim_end_matches('\r');
            if found != expected {
                return Err(SessionFileError::Header {
                    path: path.to_path_buf(),
                    expected: expected.replace('\t', " | "),
                    found: found.replace('\t', " | "),
                });
            }
            // Count the data lines (for row numbers in errors).
            let mut line = Vec::new();
            let mut read = first.len() as u64;
            while read < good {
                line.clear();
                let n = reader.read_until(b'\n', &mut line).map_err(io_err)?;
                if n == 0 {
                    break;
                }
                read += n as u64;
                rows += 1;
            }
            drop(reader);
            if good < len {
                let mut tail = Vec::new();
                file.seek(SeekFrom::Start(good)).map_err(io_err)?;
                file.read_to_end(&mut tail).map_err(io_err)?;
                dropped = Some(String::from_utf8_lossy(&tail).into_owned());
                file.set_len(good).map_err(io_err)?;
            }
        }
        file.seek(SeekFrom::End(0)).map_err(io_err)?;
        Ok(TsvLog {
            path: path.to_path_buf(),
            file,
            pending: Vec::new(),
            pending_rows: 0,
            rows,
            flush_rows: 1,
            flush_interval: Duration::ZERO,
            last_flush: Instant::now(),
            dropped: dropped.or(upgrade_dropped),
            added,
            _row: PhantomData,
        })
    }

    /// The columns [`TsvLog::append_to`] added to an older file's rows
    /// (`n/a` in each), or none.
    pub fn added_columns(&self) -> &'static [&'static str] {
        self.added
    }

    /// Batches rows: hand them to the OS when `rows` rows are pending or
    /// `interval` has passed since the last flush (checked at each write).
    /// `rows = 1` (the default) flushes every row.
    pub fn flush_every(mut self, rows: usize, interval: Duration) -> Self {
        self.flush_rows = rows.max(1);
        self.flush_interval = interval;
        self
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Data rows in the file so far (including those still pending).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The half-written last line [`TsvLog::append_to`] cut off, if any.
    pub fn dropped_partial_line(&self) -> Option<&str> {
        self.dropped.as_deref()
    }

    /// Appends one row. A text field holding a tab, carriage return or
    /// line feed is refused ([`SessionFileError::Write`] naming the
    /// column) and nothing is written.
    pub fn write(&mut self, row: &T) -> Result<(), SessionFileError> {
        let line = format_row(row).map_err(|(column, message)| SessionFileError::Write {
            path: self.path.clone(),
            row: self.rows + 1,
            column,
            message,
        })?;
        self.pending.extend_from_slice(&line);
        self.pending_rows += 1;
        self.rows += 1;
        if self.pending_rows >= self.flush_rows
            || (self.flush_interval > Duration::ZERO
                && self.last_flush.elapsed() >= self.flush_interval)
        {
            self.flush()?;
        }
        Ok(())
    }

    /// Hands every pending row to the OS (one `write` of whole lines).
    pub fn flush(&mut self) -> Result<(), SessionFileError> {
        if !self.pending.is_empty() {
            self.file
                .write_all(&self.pending)
                .map_err(|e| SessionFileError::io(&self.path, e))?;
            self.pending.clear();
            self.pending_rows = 0;
        }
        self.last_flush = Instant::now();
        Ok(())
    }

    /// Flushes and asks the OS to put the data on disk (`fsync`).
    pub fn sync(&mut self) -> Result<(), SessionFileError> {
        self.flush()?;
        self.file
            .sync_data()
            .map_err(|e| SessionFileError::io(&self.path, e))
    }
}

impl<T: TsvRow> Drop for TsvLog<T> {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

/// [`TsvLog::append_to`]'s first step: when `path` exists with the header
/// of a file written before the [`TsvRow::LATER_COLUMNS`], rewrites it
/// with the current header and `\tn/a` for each missing column at the end
/// of every complete row. Returns the columns added and the half-written
/// last line cut off, if any; nothing for any other file (a new one, the
/// current header, a header `append_to` refuses).
pub(crate) fn add_later_columns<T: TsvRow>(
    path: &Path,
) -> Result<(&'static [&'static str], Option<String>), SessionFileError> {
    let io_err = |e| SessionFileError::io(path, e);
    let mut file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok((&[], None)),
        Err(e) => return Err(io_err(e)),
    };
    let len = file.metadata().map_err(io_err)?.len();
    let good = complete_len(&mut file, len).map_err(io_err)?;
    if good == 0 {
        return Ok((&[], None));
    }
    file.seek(SeekFrom::Start(0)).map_err(io_err)?;
    let mut reader = BufReader::new((&mut file).take(good));
    let mut line = Vec::new();
    reader.read_until(b'\n', &mut line).map_err(io_err)?;
    let found = String::from_utf8_lossy(&line);
    let found = found.trim_end_matches('\n').trim_end_matches('\r');
    let all = T::COLUMNS.len();
    let n = match T::header_columns(found) {
        Some(n) if n < all => n,
        _ => return Ok((&[], None)),
    };
    let added = &T::COLUMNS[n..];
    let fill: String = added.iter().map(|_| format!("\t{NA}")).collect();
    let mut out = AtomicFile::create(path).map_err(io_err)?;
    writeln!(out, "{}", T::header_line()).map_err(io_err)?;
    let mut number = 1u64;
    loop {
        line.clear();
        if reader.read_until(b'\n', &mut line).map_err(io_err)? == 0 {
            break;
        }
        number += 1;
        let body = line.strip_suffix(b"\n").unwrap_or(&line);
        // A `\r\n` line end stays one, after the added fields.
        let (body, cr) = match body.strip_suffix(b"\r") {
            Some(b) => (b, &b"\r"[..]),
            None => (body, &b""[..]),
        };
        let fields = 1 + body.iter().filter(|&&b| b == b'\t').count();
        if fields != n {
            return Err(SessionFileError::Parse {
                path: path.to_path_buf(),
                line: number,
                column: None,
                message: format!(
                    "{fields} fields, expected {n} (its header's); the file is left as it is, without the added column{} {}",
                    if added.len() == 1 { "" } else { "s" },
                    added.join(", ")
                ),
            });
        }
        out.write_all(body).map_err(io_err)?;
        out.write_all(fill.as_bytes()).map_err(io_err)?;
        out.write_all(cr).map_err(io_err)?;
        out.write_all(b"\n").map_err(io_err)?;
    }
    drop(reader);
    let dropped = if good < len {
        let mut tail = Vec::new();
        file.seek(SeekFrom::Start(good)).map_err(io_err)?;
        file.read_to_end(&mut tail).map_err(io_err)?;
        Some(String::from_utf8_lossy(&tail).into_owned())
    } else {
        None
    };
    drop(file);
    out.commit().map_err(io_err)?;
    Ok((added, dropped))
}

/// The row as one TSV line with its `\n`, or the offending column and why.
pub(crate) fn format_row<T: TsvRow>(row: &T) -> Result<Vec<u8>, (Option<String>, String)> {
    let mut w = tsv_writer(Vec::new());
    w.serialize(row)
        .map_err(|e| (None, format!("cannot serialize: {e}")))?;
    let line = w
        .into_inner()
        .map_err(|e| (None, format!("cannot serialize: {}", e.error())))?;
    let tabs = line.iter().filter(|&&b| b == b'\t').count();
    let breaks = line.iter().filter(|&&b| b == b'\n' || b == b'\r').count();
    if tabs + 1 == T::COLUMNS.len() && breaks == 1 && line.last() == Some(&b'\n') {
        return Ok(line);
    }
    // Find the culprit: serialize again with quoting, which keeps fields whole.
    let mut q = csv::WriterBuilder::new()
        .delimiter(b'\t')
        .has_headers(false)
        .from_writer(Vec::new());
    let column = q.serialize(row).ok().and_then(|_| {
        let bytes = q.into_inner().ok()?;
        let mut r = csv::ReaderBuilder::new()
            .delimiter(b'\t')
            .has_headers(false)
            .from_reader(bytes.as_slice());
        let rec = r.records().next()?.ok()?;
        let i = rec.iter().position(|f| f.contains(['\t', '\n', '\r']))?;
        T::COLUMNS.get(i).map(|c| c.to_string())
    });
    Err((
        column,
        "a text field contains a tab or a line break, which TSV cannot hold (not written)".into(),
    ))
}
