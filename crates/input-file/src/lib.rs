//! Reading a file the user named on the command line or in a config.
//!
//! Every input gazecast reads goes through here, so that a path which is
//! not a regular file, or is larger than its kind can plausibly be, is
//! refused with the reason before a byte is allocated:
//!
//! - a FIFO, a character or block device or a socket is not a file: a FIFO
//!   blocks until something writes to it, `/dev/zero` never ends. The path
//!   is opened with `O_NONBLOCK` (so opening a FIFO does not wait for a
//!   writer) and the open file's own type is checked (`fstat`), so a path
//!   swapped between a check and the open is caught too;
//! - a directory says so;
//! - each kind of input has a [`Limit`]: its length is checked against it
//!   before reading, and the read itself stops one byte past it, so a file
//!   that grows while it is read is refused too.
//!
//! Errors are `std::io::Error`s (kind `InvalidInput` for what is not a
//! file, `FileTooLarge` for what is too large) whose message says what the
//! path is and what was expected; callers add the path and the flag.

#![warn(missing_docs)]

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::path::Path;

/// What a kind of input is called in messages and how large it may be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limit {
    /// The kind, as a message names it ("a configuration file").
    pub what: &'static str,
    /// The most bytes read.
    pub max_bytes: u64,
}

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// RON configuration files: displays, trackers, calibrations, scenes
/// (a scene lists its objects; the largest shipped is under 20 KiB).
pub const CONFIG: Limit = Limit {
    what: "a configuration file",
    max_bytes: 16 * MIB,
};

/// Experiment designs.
pub const DESIGN: Limit = Limit {
    what: "an experiment design",
    max_bytes: 4 * MIB,
};

/// OBJ meshes (text; about 40 bytes a triangle, so 1 GiB is some 25 M
/// triangles, above the scene's triangle limit).
pub const MESH: Limit = Limit {
    what: "an OBJ mesh",
    max_bytes: GIB,
};

/// Gaze CSV files (a 1000 Hz session of 10 hours is about 2 GiB).
pub const GAZE_CSV: Limit = Limit {
    what: "a gaze CSV file",
    max_bytes: 2 * GIB,
};

/// Gaze recordings (`.gzrec`) and raw device logs, read whole.
pub const RECORDING: Limit = Limit {
    what: "a gaze recording",
    max_bytes: 4 * GIB,
};

/// A session's tables that are held in memory (`trials.tsv`,
/// `session.json`, markers).
pub const SESSION_TABLE: Limit = Limit {
    what: "a session table",
    max_bytes: 256 * MIB,
};

/// A session's tables that are streamed row by row (`samples.tsv`):
/// nothing is held, so only the type is checked and the limit is large.
pub const SESSION_STREAM: Limit = Limit {
    what: "a session table",
    max_bytes: 64 * GIB,
};

/// Pictures read back (PNG stimuli for figures).
pub const PICTURE: Limit = Limit {
    what: "a picture",
    max_bytes: 256 * MIB,
};

/// A name for what a path is when it is not a regular file.
fn kind_of(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

fn open_nonblocking(path: &Path) -> io::Result<File> {
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    options.open(path)
}

/// Opens `path` for reading if it is a regular file of at most
/// `limit.max_bytes`; returns the file and its length.
pub fn open(path: &Path, limit: Limit) -> io::Result<(File, u64)> {
    let file = open_nonblocking(path)?;
    let meta = file.metadata()?;
    let t = meta.file_type();
    if !t.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "is {}, not a regular file: {} must be a file",
                kind_of(t),
                limit.what
            ),
        ));
    }
    too_large(meta.len(), limit)?;
    Ok((file, meta.len()))
}

fn too_large(len: u64, limit: Limit) -> io::Result<()> {
    if len > limit.max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!(
                "is {len} bytes; {} is read up to {} bytes",
                limit.what, limit.max_bytes
            ),
        ));
    }
    Ok(())
}

/// Reads all of `path` (a regular file of at most `limit.max_bytes`).
pub fn read(path: &Path, limit: Limit) -> io::Result<Vec<u8>> {
    let (file, len) = open(path, limit)?;
    // The length is checked, so it bounds the allocation; a file that
    // grows past the limit while it is read is stopped by the `take`.
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(limit.max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    too_large(bytes.len() as u64, limit)?;
    Ok(bytes)
}

/// Reads all of `path` as UTF-8 text (see [`read`]).
pub fn read_to_string(path: &Path, limit: Limit) -> io::Result<String> {
    String::from_utf8(read(path, limit)?).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "is not UTF-8 text (byte {}): {} is text",
                e.utf8_error().valid_up_to(),
                limit.what
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::time::{Duration, Instant};

    fn mkfifo(path: &Path) {
        use std::os::unix::ffi::OsStrExt;
        let c = std::ffi::CString::new(path.as_os_str().as_bytes()).expect("no NUL");
        // SAFETY: a valid NUL-terminated path.
        let rc = unsafe { libc::mkfifo(c.as_ptr(), 0o600) };
        assert_eq!(rc, 0, "mkfifo {}", path.display());
    }

    #[test]
    fn a_fifo_is_refused_at_once_without_a_writer() {
        let dir = tempfile::tempdir().expect("tempdir");
        let fifo = dir.path().join("scene.ron");
        mkfifo(&fifo);
        let start = Instant::now();
        let e = read_to_string(&fifo, CONFIG).expect_err("a FIFO");
        assert!(start.elapsed() < Duration::from_secs(2));
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("FIFO"), "{e}");
        assert!(e.to_string().contains("a configuration file"), "{e}");
    }

    #[test]
    fn devices_and_directories_are_refused_by_what_they_are() {
        let e = read(Path::new("/dev/zero"), MESH).expect_err("endless");
        assert!(e.to_string().contains("character device"), "{e}");
        let e = read(Path::new("/dev/null"), CONFIG).expect_err("device");
        assert!(e.to_string().contains("character device"), "{e}");
        let dir = tempfile::tempdir().expect("tempdir");
        let e = read(dir.path(), DESIGN).expect_err("directory");
        assert!(e.to_string().contains("a directory"), "{e}");
        let e = read(&dir.path().join("missing"), DESIGN).expect_err("missing");
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
    }

    #[test]
    fn a_link_to_a_fifo_is_a_fifo() {
        let dir = tempfile::tempdir().expect("tempdir");
        let fifo = dir.path().join("f");
        mkfifo(&fifo);
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&fifo, &link).expect("symlink");
        let e = read(&link, GAZE_CSV).expect_err("FIFO behind a link");
        assert!(e.to_string().contains("FIFO"), "{e}");
    }

    #[test]
    fn text_that_is_not_utf8_is_refused_with_the_byte() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("d.ron");
        std::fs::write(&p, b"abc\xffdef").expect("write");
        let e = read_to_string(&p, CONFIG).expect_err("binary");
        assert!(e.to_string().contains("byte 3"), "{e}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(48)))]
        /// Files up to the limit read whole and equal; one byte more is
        /// refused, for limits from 0 bytes up.
        #[test]
        fn reads_up_to_the_limit_and_refuses_beyond(max in 0u64..300, len in 0usize..320) {
            let dir = tempfile::tempdir().expect("tempdir");
            let p = dir.path().join("x");
            let bytes: Vec<u8> = (0..len).map(|i| (i * 7) as u8).collect();
            std::fs::write(&p, &bytes).expect("write");
            let limit = Limit { what: "a test file", max_bytes: max };
            match read(&p, limit) {
                Ok(read) => {
                    prop_assert!(len as u64 <= max);
                    prop_assert_eq!(read, bytes);
                }
                Err(e) => {
                    prop_assert!(len as u64 > max);
                    prop_assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
                    let expected = format!("{len} bytes");
                    prop_assert!(e.to_string().contains(&expected), "{}", e);
                }
            }
        }
    }
}

/// The README's examples, compiled and run as doc-tests so they cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
