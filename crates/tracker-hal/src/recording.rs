//! Lossless recordings of a tracker session, and the tap that feeds them.
//!
//! ## File format (`.gzrec`)
//!
//! ```text
//! file   := magic chunk*
//! magic  := "GZCREC" 0x00 0x01                      (8 bytes: name, format version 1)
//! chunk  := kind:u8 length:u32 time_us:u64 payload[length] crc:u32
//! ```
//! All integers little-endian; `crc` is the CRC-32 (IEEE) of kind, length,
//! time and payload. Kinds:
//!
//! | kind | payload | time |
//! |---|---|---|
//! | 1 header | UTF-8 RON of [`RecordingHeader`] (tracker config, display, mapping, note) | host time at start |
//! | 2 device → host | raw transport bytes as read | host arrival time |
//! | 3 host → device | raw bytes written (commands, markers) | host time |
//! | 4 overflow | lost chunks (u64), lost bytes (u64), cumulative | host time |
//! | 5 end | empty: the recorder closed the file cleanly | host time |
//!
//! The file is append-only, one chunk at a time, so a process killed
//! mid-write leaves a readable file: the reader stops at the first
//! incomplete chunk or bad CRC and reports the torn tail (offset and size).
//!
//! ## Writing
//!
//! [`Recorder::start`] runs a writer thread fed by a bounded channel. The
//! tracker thread sends through a [`Tap`], which never blocks: when the
//! channel is full the chunk is dropped and counted, the writer records an
//! overflow chunk, and [`Recorder::finish`] returns the totals — a loss is
//! never silent.

use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender, TrySendError};
use serde::{Deserialize, Serialize};

use crate::config::TrackerConfig;
use crate::error::{Error, ErrorKind, Result};

pub const MAGIC: [u8; 8] = *b"GZCREC\x00\x01";
const CHUNK_OVERHEAD: usize = 1 + 4 + 8 + 4;
/// Largest payload a reader accepts (a corrupt length must not allocate gigabytes).
pub const MAX_PAYLOAD: usize = 16 << 20;

/// Chunk kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ChunkKind {
    Header = 1,
    DeviceToHost = 2,
    HostToDevice = 3,
    Overflow = 4,
    End = 5,
}

impl ChunkKind {
    fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            1 => Self::Header,
            2 => Self::DeviceToHost,
            3 => Self::HostToDevice,
            4 => Self::Overflow,
            5 => Self::End,
            _ => return None,
        })
    }
}

/// What a recording says about itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingHeader {
    /// The tracker configuration in force (driver and mapping).
    pub tracker: TrackerConfig,
    /// Name of the display the session ran on, if any.
    #[serde(default)]
    pub display: Option<String>,
    /// Free text: who, what, synthesised or real.
    #[serde(default)]
    pub note: String,
}

/// One chunk read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chunk {
    pub kind: ChunkKind,
    pub time_us: u64,
    pub payload: Vec<u8>,
}

fn encode_chunk(kind: ChunkKind, time_us: u64, payload: &[u8]) -> Vec<u8> {
    let mut c = Vec::with_capacity(CHUNK_OVERHEAD + payload.len());
    c.push(kind as u8);
    c.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    c.extend_from_slice(&time_us.to_le_bytes());
    c.extend_from_slice(payload);
    let crc = crc32fast::hash(&c);
    c.extend_from_slice(&crc.to_le_bytes());
    c
}

/// Writes a whole recording at once (the simulator's path; live sessions use
/// [`Recorder`]).
pub fn write_recording(path: &Path, header: &RecordingHeader, chunks: &[Chunk]) -> Result<()> {
    let io = |e: std::io::Error| Error::from_io(&format!("{}", path.display()), &e);
    let mut w = BufWriter::new(std::fs::File::create(path).map_err(io)?);
    w.write_all(&MAGIC).map_err(io)?;
    let text = header_text(header)?;
    let t0 = chunks.first().map_or(0, |c| c.time_us);
    w.write_all(&encode_chunk(ChunkKind::Header, t0, text.as_bytes()))
        .map_err(io)?;
    for c in chunks {
        w.write_all(&encode_chunk(c.kind, c.time_us, &c.payload))
            .map_err(io)?;
    }
    let t1 = chunks.last().map_or(0, |c| c.time_us);
    w.write_all(&encode_chunk(ChunkKind::End, t1, &[]))
        .map_err(io)?;
    w.flush().map_err(io)
}

fn header_text(header: &RecordingHeader) -> Result<String> {
    ron::ser::to_string_pretty(header, ron::ser::PrettyConfig::default()).map_err(|e| {
        Error::new(
            ErrorKind::InvalidData,
            format!("cannot serialise the recording header: {e}"),
        )
    })
}

/// Where reading stopped early, if it did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TornTail {
    /// Byte offset of the first chunk that could not be read.
    pub offset: u64,
    /// Bytes from there to the end of the file.
    pub bytes: u64,
    pub reason: String,
}

/// A recording read back.
#[derive(Debug, Clone)]
pub struct Recording {
    pub header: RecordingHeader,
    /// Data, command and overflow chunks in file order (no header or end).
    pub chunks: Vec<Chunk>,
    /// The file ended with an end chunk (closed cleanly).
    pub closed: bool,
    /// Set when the file was cut or damaged after some point.
    pub torn_tail: Option<TornTail>,
    /// Chunks the recorder reported as lost (from overflow chunks).
    pub lost_chunks: u64,
}

impl Recording {
    /// Reads a recording. A torn or damaged tail is reported in
    /// [`torn_tail`](Self::torn_tail), not an error; a file that is not a
    /// recording, or whose header is unreadable, is.
    pub fn read(path: &Path) -> Result<Self> {
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut bytes))
            .map_err(|e| Error::from_io(&format!("{}", path.display()), &e))?;
        Self::parse(&bytes)
            .map_err(|e| Error::new(e.kind, format!("{}: {}", path.display(), e.message)))
    }

    /// Parses a recording held in memory.
    pub fn parse(bytes: &[u8]) -> Result<Self> {
        if bytes.len() < MAGIC.len() || bytes[..6] != MAGIC[..6] {
            return Err(Error::new(
                ErrorKind::InvalidData,
                "not a gazecast recording (bad magic)",
            ));
        }
        if bytes[6..8] != MAGIC[6..8] {
            return Err(Error::new(
                ErrorKind::Unsupported,
                format!(
                    "recording format version {}.{} is not supported (this build reads 0.1)",
                    bytes[6], bytes[7]
                ),
            ));
        }
        let mut pos = MAGIC.len();
        let mut header = None;
        let mut chunks = Vec::new();
        let mut closed = false;
        let mut torn_tail = None;
        let mut lost_chunks = 0;
        while pos < bytes.len() {
            match parse_chunk(&bytes[pos..]) {
                Ok((chunk, used)) => {
                    pos += used;
                    match chunk.kind {
                        ChunkKind::Header => {
                            let text = std::str::from_utf8(&chunk.payload).map_err(|_| {
                                Error::new(ErrorKind::InvalidData, "the header is not UTF-8")
                            })?;
                            header = Some(ron::from_str::<RecordingHeader>(text).map_err(|e| {
                                Error::new(
                                    ErrorKind::InvalidData,
                                    format!("the header does not parse: {e}"),
                                )
                            })?);
                        }
                        ChunkKind::End => closed = true,
                        ChunkKind::Overflow => {
                            if chunk.payload.len() >= 8 {
                                let mut n = [0u8; 8];
                                n.copy_from_slice(&chunk.payload[..8]);
                                lost_chunks = u64::from_le_bytes(n);
                            }
                            chunks.push(chunk);
                        }
                        _ => chunks.push(chunk),
                    }
                }
                Err(reason) => {
                    torn_tail = Some(TornTail {
                        offset: pos as u64,
                        bytes: (bytes.len() - pos) as u64,
                        reason,
                    });
                    break;
                }
            }
        }
        let header = header.ok_or_else(|| {
            Error::new(ErrorKind::InvalidData, "the recording has no header chunk")
        })?;
        Ok(Self {
            header,
            chunks,
            closed,
            torn_tail,
            lost_chunks,
        })
    }

    /// The device → host chunks: what a driver reads on replay.
    pub fn device_chunks(&self) -> impl Iterator<Item = &Chunk> {
        self.chunks
            .iter()
            .filter(|c| c.kind == ChunkKind::DeviceToHost)
    }
}

fn parse_chunk(b: &[u8]) -> std::result::Result<(Chunk, usize), String> {
    if b.len() < CHUNK_OVERHEAD {
        return Err(format!(
            "incomplete chunk: {} bytes left, a chunk needs at least {CHUNK_OVERHEAD}",
            b.len()
        ));
    }
    let kind = ChunkKind::from_u8(b[0]).ok_or_else(|| format!("unknown chunk kind {}", b[0]))?;
    let len = u32::from_le_bytes([b[1], b[2], b[3], b[4]]) as usize;
    if len > MAX_PAYLOAD {
        return Err(format!(
            "chunk length {len} exceeds the limit of {MAX_PAYLOAD}"
        ));
    }
    let total = CHUNK_OVERHEAD + len;
    if b.len() < total {
        return Err(format!(
            "incomplete chunk: needs {total} bytes, {} left",
            b.len()
        ));
    }
    let crc = u32::from_le_bytes([b[total - 4], b[total - 3], b[total - 2], b[total - 1]]);
    if crc32fast::hash(&b[..total - 4]) != crc {
        return Err("chunk checksum mismatch".into());
    }
    let mut t = [0u8; 8];
    t.copy_from_slice(&b[5..13]);
    Ok((
        Chunk {
            kind,
            time_us: u64::from_le_bytes(t),
            payload: b[13..total - 4].to_vec(),
        },
        total,
    ))
}

enum Message {
    Chunk(ChunkKind, u64, Vec<u8>),
    Close,
}

/// Counters shared by the tap and the writer.
#[derive(Debug, Default)]
struct Counters {
    lost_chunks: AtomicU64,
    lost_bytes: AtomicU64,
}

/// The tracker thread's end of a recorder: cheap to clone, never blocks.
#[derive(Clone)]
pub struct Tap {
    tx: Sender<Message>,
    counters: Arc<Counters>,
}

impl Tap {
    fn send(&self, kind: ChunkKind, time_us: u64, bytes: &[u8]) {
        match self
            .tx
            .try_send(Message::Chunk(kind, time_us, bytes.to_vec()))
        {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                self.counters.lost_chunks.fetch_add(1, Ordering::Relaxed);
                self.counters
                    .lost_bytes
                    .fetch_add(bytes.len() as u64, Ordering::Relaxed);
            }
        }
    }

    /// Bytes read from the device at `time_us`.
    pub fn device_to_host(&self, time_us: u64, bytes: &[u8]) {
        self.send(ChunkKind::DeviceToHost, time_us, bytes);
    }

    /// Bytes written to the device at `time_us`.
    pub fn host_to_device(&self, time_us: u64, bytes: &[u8]) {
        self.send(ChunkKind::HostToDevice, time_us, bytes);
    }

    /// Chunks lost so far because the writer fell behind.
    pub fn lost_chunks(&self) -> u64 {
        self.counters.lost_chunks.load(Ordering::Relaxed)
    }
}

/// Totals of a finished recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecorderSummary {
    pub chunks_written: u64,
    pub bytes_written: u64,
    pub lost_chunks: u64,
    pub lost_bytes: u64,
}

/// A recording being written by its own thread.
pub struct Recorder {
    tap: Tap,
    path: PathBuf,
    thread: std::thread::JoinHandle<Result<(u64, u64)>>,
}

impl Recorder {
    /// Creates `path`, writes the header, and starts the writer thread with a
    /// channel of `capacity` chunks.
    pub fn start(path: &Path, header: &RecordingHeader, capacity: usize) -> Result<Self> {
        let io = |e: std::io::Error| Error::from_io(&format!("{}", path.display()), &e);
        let mut file = BufWriter::new(std::fs::File::create(path).map_err(io)?);
        file.write_all(&MAGIC).map_err(io)?;
        let text = header_text(header)?;
        file.write_all(&encode_chunk(
            ChunkKind::Header,
            crate::clock::monotonic_us(),
            text.as_bytes(),
        ))
        .map_err(io)?;
        file.flush().map_err(io)?;
        let (tx, rx) = crossbeam_channel::bounded(capacity.max(1));
        let counters = Arc::new(Counters::default());
        let writer_counters = Arc::clone(&counters);
        let display = path.display().to_string();
        let thread = std::thread::Builder::new()
            .name("gaze-recorder".into())
            .spawn(move || write_loop(file, rx, writer_counters, &display))
            .map_err(|e| Error::from_io("starting the recorder thread", &e))?;
        Ok(Self {
            tap: Tap { tx, counters },
            path: path.to_path_buf(),
            thread,
        })
    }

    /// A tap to give to a driver ([`StreamDriver::with_tap`](crate::StreamDriver::with_tap)).
    pub fn tap(&self) -> Tap {
        self.tap.clone()
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes what is queued, an overflow chunk if anything was lost, the end
    /// chunk, and closes the file.
    pub fn finish(self) -> Result<RecorderSummary> {
        // A full queue is drained by the writer; a blocking send is fine here.
        let _ = self.tap.tx.send(Message::Close);
        let counters = Arc::clone(&self.tap.counters);
        drop(self.tap);
        let (chunks_written, bytes_written) = self
            .thread
            .join()
            .map_err(|_| Error::new(ErrorKind::Io, "the recorder thread panicked"))??;
        Ok(RecorderSummary {
            chunks_written,
            bytes_written,
            lost_chunks: counters.lost_chunks.load(Ordering::Relaxed),
            lost_bytes: counters.lost_bytes.load(Ordering::Relaxed),
        })
    }
}

fn write_loop(
    mut file: BufWriter<std::fs::File>,
    rx: Receiver<Message>,
    counters: Arc<Counters>,
    path: &str,
) -> Result<(u64, u64)> {
    let io = |e: std::io::Error| Error::from_io(path, &e);
    let (mut chunks, mut bytes) = (0u64, 0u64);
    let mut reported_lost = 0u64;
    let mut last_time = 0u64;
    let overflow =
        |file: &mut BufWriter<std::fs::File>, t: u64, reported: &mut u64| -> std::io::Result<()> {
            let lost = counters.lost_chunks.load(Ordering::Relaxed);
            if lost != *reported {
                let mut p = lost.to_le_bytes().to_vec();
                p.extend_from_slice(&counters.lost_bytes.load(Ordering::Relaxed).to_le_bytes());
                file.write_all(&encode_chunk(ChunkKind::Overflow, t, &p))?;
                *reported = lost;
            }
            Ok(())
        };
    loop {
        let msg = match rx.recv() {
            Ok(m) => m,
            Err(_) => Message::Close,
        };
        match msg {
            Message::Chunk(kind, t, payload) => {
                last_time = t;
                overflow(&mut file, t, &mut reported_lost).map_err(io)?;
                file.write_all(&encode_chunk(kind, t, &payload))
                    .map_err(io)?;
                chunks += 1;
                bytes += payload.len() as u64;
                // Flush whenever the queue is empty: the file stays current
                // without a system call per chunk under load.
                if rx.is_empty() {
                    file.flush().map_err(io)?;
                }
            }
            Message::Close => {
                overflow(&mut file, last_time, &mut reported_lost).map_err(io)?;
                file.write_all(&encode_chunk(ChunkKind::End, last_time, &[]))
                    .map_err(io)?;
                file.flush().map_err(io)?;
                file.get_ref().sync_all().map_err(io)?;
                return Ok((chunks, bytes));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Driver;
    use crate::iscan::{IscanConfig, IscanMode};

    fn header() -> RecordingHeader {
        RecordingHeader {
            tracker: TrackerConfig {
                driver: Driver::Iscan(IscanConfig::binocular(IscanMode::Binary)),
                mapping: Default::default(),
            },
            display: None,
            note: "test".into(),
        }
    }

    #[test]
    fn recorder_round_trips_and_a_torn_tail_is_reported() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.gzrec");
        let rec = Recorder::start(&path, &header(), 16).expect("start");
        let tap = rec.tap();
        tap.host_to_device(1, &[0x84]);
        tap.device_to_host(2, &[1, 2, 3]);
        tap.device_to_host(3, &[4]);
        let summary = rec.finish().expect("finish");
        assert_eq!(summary.lost_chunks, 0);
        assert_eq!(summary.chunks_written, 3);
        let r = Recording::read(&path).expect("read");
        assert!(r.closed && r.torn_tail.is_none());
        assert_eq!(r.header, header());
        let data: Vec<_> = r
            .device_chunks()
            .map(|c| (c.time_us, c.payload.clone()))
            .collect();
        assert_eq!(data, vec![(2, vec![1, 2, 3]), (3, vec![4])]);

        // Cut the file in the middle of the last data chunk.
        let bytes = std::fs::read(&path).expect("bytes");
        let cut = bytes.len() - CHUNK_OVERHEAD - 3;
        let r = Recording::parse(&bytes[..cut]).expect("still readable");
        assert!(!r.closed);
        assert_eq!(r.device_chunks().count(), 1);
        let tail = r.torn_tail.expect("torn tail reported");
        assert_eq!(tail.offset + tail.bytes, cut as u64);
    }

    #[test]
    fn a_flipped_bit_stops_reading_with_a_reason() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.gzrec");
        write_recording(
            &path,
            &header(),
            &[Chunk {
                kind: ChunkKind::DeviceToHost,
                time_us: 5,
                payload: vec![9; 10],
            }],
        )
        .expect("write");
        let mut bytes = std::fs::read(&path).expect("bytes");
        let n = bytes.len();
        bytes[n - 30] ^= 0x04;
        let r = Recording::parse(&bytes).expect("header still good");
        assert!(r.torn_tail.expect("reported").reason.contains("checksum"));
    }

    #[test]
    fn not_a_recording_is_an_error() {
        assert_eq!(
            Recording::parse(b"hello world").unwrap_err().kind,
            ErrorKind::InvalidData
        );
        assert_eq!(
            Recording::parse(b"GZCREC\x00\x09").unwrap_err().kind,
            ErrorKind::Unsupported
        );
    }
}
