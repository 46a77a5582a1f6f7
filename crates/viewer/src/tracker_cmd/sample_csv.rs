//! The sample CSV that `replay` and `simulate` write.

use std::io::Write;
use std::path::Path;

use tracker_hal::csv::{csv_row, CSV_HEADER};

/// The sample CSV of `replay` and `simulate`, with errors naming the file.
/// Normally written whole or not at all (`crate::output`): an error part-way
/// leaves any existing file as it was. `replay --realtime` writes it
/// through instead ([`SampleCsv::create_through`]).
pub(super) struct SampleCsv<'a> {
    path: &'a Path,
    w: CsvSink,
}

enum CsvSink {
    Atomic(crate::output::AtomicFile),
    /// Every row flushed to the file as it is written.
    Through(std::fs::File),
}

impl Write for CsvSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Self::Atomic(w) => w.write(buf),
            Self::Through(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Self::Atomic(w) => w.flush(),
            Self::Through(w) => w.flush(),
        }
    }
}

impl<'a> SampleCsv<'a> {
    pub(super) fn create(path: &'a Path) -> Result<Self, String> {
        let w = crate::output::AtomicFile::create(path).map_err(|e| Self::fail(path, e))?;
        Self::start(path, CsvSink::Atomic(w))
    }

    /// Written straight to `path`, one unbuffered write per row: what is
    /// played is on disk, whatever happens next.
    pub(super) fn create_through(path: &'a Path) -> Result<Self, String> {
        let w = std::fs::File::create(path).map_err(|e| Self::fail(path, e))?;
        Self::start(path, CsvSink::Through(w))
    }

    fn start(path: &'a Path, w: CsvSink) -> Result<Self, String> {
        let mut csv = Self { path, w };
        writeln!(csv.w, "{CSV_HEADER}").map_err(|e| Self::fail(path, e))?;
        Ok(csv)
    }

    pub(super) fn row(
        &mut self,
        s: &tracker_hal::GazeSample,
        map: &dyn Fn([f64; 2]) -> Option<[f64; 2]>,
    ) -> Result<(), String> {
        // One write per row: written through (an unbuffered `File`), a row
        // is on disk as soon as this returns.
        let line = format!("{}\n", csv_row(s, map));
        self.w
            .write_all(line.as_bytes())
            .map_err(|e| Self::fail(self.path, e))
    }

    pub(super) fn finish(self) -> Result<(), String> {
        match self.w {
            CsvSink::Atomic(w) => w.commit(),
            CsvSink::Through(w) => w.sync_all(),
        }
        .map_err(|e| Self::fail(self.path, e))
    }

    fn fail(path: &Path, e: std::io::Error) -> String {
        format!("{}: cannot write: {e}", path.display())
    }
}
