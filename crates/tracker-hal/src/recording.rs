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
//! time and payload. `length` is at most [`MAX_PAYLOAD`] (1 MiB): writers
//! split longer device or host data into several chunks with the same time.
//! Kinds:
//!
//! | kind | payload | time |
//! |---|---|---|
//! | 1 header | UTF-8 RON of [`RecordingHeader`] (tracker config, display, mapping, note) | host time at start |
//! | 2 device → host | raw transport bytes as read | host arrival time |
//! | 3 host → device | raw bytes written (commands, markers) | host time |
//! | 4 overflow | lost chunks (u64), lost bytes (u64), cumulative | host time |
//! | 5 end | empty: the recorder closed the file cleanly | host time |
//!
//! Any chunk may be empty, and other kinds may appear (written by a later
//! version): a reader skips them and counts them.
//!
//! ## Reading damaged files
//!
//! The file is append-only, one chunk at a time, so a process killed
//! mid-write leaves a readable file. The reader never gives up after the
//! magic and header:
//!
//! - A chunk is *valid* at an offset when its length is at most
//!   [`MAX_PAYLOAD`] and fits in the bytes remaining, and its CRC matches.
//!   Lengths are checked against both bounds before anything is sliced or
//!   allocated, so a corrupt length costs nothing.
//! - Where no valid chunk starts (a flipped bit, a bad length, garbage), the
//!   reader *resynchronises*: it tries every following byte offset and
//!   resumes at the first one where a valid chunk starts. The bytes in
//!   between form a [`SkippedRegion`] (offset, size, why the first chunk
//!   failed); only the chunks inside it are lost. A region that runs to the
//!   end of the file is also the [`torn_tail`](Recording::torn_tail): the
//!   typical remains of a killed recorder.
//! - Chunks of unknown kind are skipped whole and counted.
//! - Nothing after the end chunk is decoded; its size and the number of
//!   valid chunks in it are reported ([`AfterEnd`]).
//! - A file without an end chunk was not closed (the recorder was
//!   interrupted); [`Recording::summary`] says how much it holds.
//!
//! [`Recording::warnings`] turns all of this into one line per problem for
//! a replay to print.
//!
//! ## Writing
//!
//! [`Recorder::start`] runs a writer thread fed by a bounded channel. The
//! tracker thread sends through a [`Tap`], which never blocks: when the
//! channel is full the chunk is dropped and counted, the writer records an
//! overflow chunk, and [`Recorder::finish`] returns the totals — a loss is
//! never silent.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender, TrySendError};
use serde::{Deserialize, Serialize};

use crate::config::TrackerConfig;
use crate::error::{Error, ErrorKind, Result};

/// The file's first 8 bytes: "GZCREC", then format version 1.
pub const MAGIC: [u8; 8] = *b"GZCREC\x00\x01";
const CHUNK_OVERHEAD: usize = 1 + 4 + 8 + 4;
/// Largest payload of one chunk: 1 MiB. Writers split longer device and host
/// data into several chunks; readers treat a longer length as damage. Real
/// chunks are one transport read (a few kilobytes at most); the bound keeps a
/// corrupt length from reaching an allocation and keeps resynchronisation
/// cheap (each candidate offset costs a CRC over at most this much).
pub const MAX_PAYLOAD: usize = 1 << 20;

/// Chunk kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ChunkKind {
    /// The recording's header (RON of [`RecordingHeader`]).
    Header = 1,
    /// Raw transport bytes as read, at their arrival time.
    DeviceToHost = 2,
    /// Raw bytes written to the device (commands, markers).
    HostToDevice = 3,
    /// Chunks the recorder lost so far: lost chunks (u64), lost bytes (u64).
    Overflow = 4,
    /// The recorder closed the file cleanly (empty payload).
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
    /// What the chunk holds.
    pub kind: ChunkKind,
    /// Host time, µs (see [`ChunkKind`] for which instant).
    pub time_us: u64,
    /// The chunk's bytes.
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

/// Writes `payload` as one chunk, or as several of at most [`MAX_PAYLOAD`]
/// bytes with the same time when it is longer (data is a byte stream, so the
/// pieces replay exactly as the whole). An empty payload is one empty chunk.
fn write_chunks(
    w: &mut impl Write,
    kind: ChunkKind,
    time_us: u64,
    payload: &[u8],
) -> std::io::Result<()> {
    if payload.is_empty() {
        return w.write_all(&encode_chunk(kind, time_us, payload));
    }
    for piece in payload.chunks(MAX_PAYLOAD) {
        w.write_all(&encode_chunk(kind, time_us, piece))?;
    }
    Ok(())
}

/// Writes a whole recording at once (the simulator's path; live sessions use
/// [`Recorder`]).
pub fn write_recording(path: &Path, header: &RecordingHeader, chunks: &[Chunk]) -> Result<()> {
    let io = |e: std::io::Error| Error::from_io(&format!("{}", path.display()), &e);
    let text = header_text(header)?;
    let mut w = BufWriter::new(std::fs::File::create(path).map_err(io)?);
    w.write_all(&MAGIC).map_err(io)?;
    let t0 = chunks.first().map_or(0, |c| c.time_us);
    w.write_all(&encode_chunk(ChunkKind::Header, t0, text.as_bytes()))
        .map_err(io)?;
    for c in chunks {
        write_chunks(&mut w, c.kind, c.time_us, &c.payload).map_err(io)?;
    }
    let t1 = chunks.last().map_or(0, |c| c.time_us);
    w.write_all(&encode_chunk(ChunkKind::End, t1, &[]))
        .map_err(io)?;
    w.flush().map_err(io)
}

fn header_text(header: &RecordingHeader) -> Result<String> {
    let text =
        ron::ser::to_string_pretty(header, ron::ser::PrettyConfig::default()).map_err(|e| {
            Error::new(
                ErrorKind::InvalidData,
                format!("cannot serialise the recording header: {e}"),
            )
        })?;
    if text.len() > MAX_PAYLOAD {
        return Err(Error::new(
            ErrorKind::InvalidData,
            format!(
                "the recording header is {} bytes; a chunk holds at most {MAX_PAYLOAD}",
                text.len()
            ),
        ));
    }
    Ok(text)
}

/// A stretch of a recording the reader could not use and skipped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedRegion {
    /// Byte offset of the first byte skipped.
    pub offset: u64,
    /// Bytes skipped, up to the next valid chunk or the end of the file.
    pub bytes: u64,
    /// Why no chunk could be read at `offset`.
    pub reason: String,
}

/// The damaged region at the end of a file (the name predates
/// resynchronisation).
pub type TornTail = SkippedRegion;

/// What follows the end chunk: reported, never decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AfterEnd {
    /// Byte offset just past the end chunk.
    pub offset: u64,
    /// Bytes from there to the end of the file.
    pub bytes: u64,
    /// Valid chunks among them (of any kind).
    pub chunks: u64,
}

/// A recording read back.
#[derive(Debug, Clone)]
pub struct Recording {
    /// What the recording says about itself.
    pub header: RecordingHeader,
    /// Data, command and overflow chunks of known kind in file order, empty
    /// ones included (no header, end, unknown kinds or anything after the end).
    pub chunks: Vec<Chunk>,
    /// The file holds an end chunk: the recorder closed it cleanly.
    pub closed: bool,
    /// The last damaged region, when it runs to the end of the file (a file
    /// cut mid-chunk); also listed in [`damaged`](Self::damaged).
    pub torn_tail: Option<TornTail>,
    /// Chunks the recorder reported as lost (from overflow chunks).
    pub lost_chunks: u64,
    /// Every damaged region skipped before the end chunk, in file order.
    pub damaged: Vec<SkippedRegion>,
    /// Valid chunks of unknown kind, skipped (before the end chunk).
    pub unknown_chunks: u64,
    /// Their size in bytes, framing included.
    pub unknown_bytes: u64,
    /// Bytes after the end chunk, if there are any.
    pub after_end: Option<AfterEnd>,
    /// Time of the header chunk: the start of the recording.
    pub start_time_us: u64,
    /// Time of the last data, command or overflow chunk.
    pub last_time_us: Option<u64>,
}

/// Counts describing how a recording read: what a replay reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadSummary {
    /// The file ends with an end chunk (closed cleanly).
    pub closed: bool,
    /// Device → host chunks read, empty ones included.
    pub device_chunks: u64,
    /// Host → device chunks read.
    pub host_chunks: u64,
    /// Time of the last data chunk after the start of the recording.
    pub duration_us: u64,
    /// Damaged regions skipped (the torn tail included).
    pub damaged_regions: u64,
    /// Bytes in them.
    pub bytes_skipped: u64,
    /// Chunks of unknown kind skipped, and their bytes.
    pub unknown_chunks: u64,
    /// Bytes of those chunks, framing included.
    pub unknown_bytes: u64,
    /// Bytes after the end chunk, not decoded, and the valid chunks in them.
    pub after_end_bytes: u64,
    /// Valid chunks in the bytes after the end chunk.
    pub after_end_chunks: u64,
    /// Chunks the recorder lost while writing (from overflow chunks).
    pub lost_chunks: u64,
}

impl ReadSummary {
    /// Nothing to report: closed, undamaged, nothing unknown, skipped or lost.
    pub fn is_clean(&self) -> bool {
        self.closed
            && self.damaged_regions == 0
            && self.unknown_chunks == 0
            && self.after_end_bytes == 0
            && self.lost_chunks == 0
    }
}

impl Recording {
    /// Reads a recording. Damage, a torn tail, unknown chunks and bytes after
    /// the end are reported (see [`summary`](Self::summary)), not errors; a
    /// file that is not a recording, or whose header is unreadable, is.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = input_file::read(path, input_file::RECORDING)
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
        let mut header = None;
        let mut chunks = Vec::new();
        let mut closed = false;
        let mut lost_chunks = 0;
        let mut damaged: Vec<SkippedRegion> = Vec::new();
        let (mut unknown_chunks, mut unknown_bytes) = (0u64, 0u64);
        let (mut start_time_us, mut last_time_us) = (0, None);
        let mut pos = MAGIC.len();
        while pos < bytes.len() {
            let raw = match raw_chunk(bytes, pos) {
                Ok(raw) => raw,
                Err(reason) => {
                    let next = resync(bytes, pos + 1);
                    damaged.push(SkippedRegion {
                        offset: pos as u64,
                        bytes: (next - pos) as u64,
                        reason,
                    });
                    pos = next;
                    continue;
                }
            };
            pos += raw.size;
            let Some(kind) = ChunkKind::from_u8(raw.kind) else {
                unknown_chunks += 1;
                unknown_bytes += raw.size as u64;
                continue;
            };
            match kind {
                ChunkKind::Header => {
                    // The first readable header is the recording's.
                    if header.is_none() {
                        header = Some(parse_header(raw.payload)?);
                        start_time_us = raw.time_us;
                    }
                }
                ChunkKind::End => {
                    closed = true;
                    break;
                }
                ChunkKind::Overflow | ChunkKind::DeviceToHost | ChunkKind::HostToDevice => {
                    if kind == ChunkKind::Overflow && raw.payload.len() >= 8 {
                        let mut n = [0u8; 8];
                        n.copy_from_slice(&raw.payload[..8]);
                        lost_chunks = u64::from_le_bytes(n);
                    }
                    last_time_us = Some(raw.time_us);
                    chunks.push(Chunk {
                        kind,
                        time_us: raw.time_us,
                        payload: raw.payload.to_vec(),
                    });
                }
            }
        }
        let header = header.ok_or_else(|| {
            Error::new(
                ErrorKind::InvalidData,
                "the recording has no readable header chunk",
            )
        })?;
        let after_end = (closed && pos < bytes.len()).then(|| AfterEnd {
            offset: pos as u64,
            bytes: (bytes.len() - pos) as u64,
            chunks: count_chunks(bytes, pos),
        });
        let torn_tail = damaged
            .last()
            .filter(|d| !closed && d.offset + d.bytes == bytes.len() as u64)
            .cloned();
        Ok(Self {
            header,
            chunks,
            closed,
            torn_tail,
            lost_chunks,
            damaged,
            unknown_chunks,
            unknown_bytes,
            after_end,
            start_time_us,
            last_time_us,
        })
    }

    /// The device → host chunks that carry data: what a driver reads on
    /// replay. Empty chunks are valid but skipped here, so that a reader of
    /// the stream never mistakes one for the end of the data.
    pub fn device_chunks(&self) -> impl Iterator<Item = &Chunk> {
        self.chunks
            .iter()
            .filter(|c| c.kind == ChunkKind::DeviceToHost && !c.payload.is_empty())
    }

    /// Counts of what was read, skipped and lost.
    pub fn summary(&self) -> ReadSummary {
        let count = |k: ChunkKind| self.chunks.iter().filter(|c| c.kind == k).count() as u64;
        let after = self.after_end.unwrap_or(AfterEnd {
            offset: 0,
            bytes: 0,
            chunks: 0,
        });
        ReadSummary {
            closed: self.closed,
            device_chunks: count(ChunkKind::DeviceToHost),
            host_chunks: count(ChunkKind::HostToDevice),
            duration_us: self
                .last_time_us
                .map_or(0, |t| t.saturating_sub(self.start_time_us)),
            damaged_regions: self.damaged.len() as u64,
            bytes_skipped: self.damaged.iter().map(|d| d.bytes).sum(),
            unknown_chunks: self.unknown_chunks,
            unknown_bytes: self.unknown_bytes,
            after_end_bytes: after.bytes,
            after_end_chunks: after.chunks,
            lost_chunks: self.lost_chunks,
        }
    }

    /// One line per problem, for a replay to print after the file name; empty
    /// for a clean recording.
    pub fn warnings(&self) -> Vec<String> {
        let s = self.summary();
        let mut w = Vec::new();
        let middle: Vec<&SkippedRegion> = self
            .damaged
            .iter()
            .filter(|d| Some(*d) != self.torn_tail.as_ref())
            .collect();
        if let Some(first) = middle.first() {
            w.push(format!(
                "{} damaged region(s), {} bytes skipped, their chunks lost (first at byte {}: {}); reading resumed after each",
                middle.len(),
                middle.iter().map(|d| d.bytes).sum::<u64>(),
                first.offset,
                first.reason
            ));
        }
        if let Some(t) = &self.torn_tail {
            w.push(format!(
                "the recording ends early at byte {} ({} bytes unreadable: {}); decoding what precedes it",
                t.offset, t.bytes, t.reason
            ));
        }
        if !s.closed {
            w.push(format!(
                "not closed: {} records up to t = {:.3} s (no end chunk: the recorder was interrupted)",
                s.device_chunks,
                s.duration_us as f64 / 1e6
            ));
        }
        if s.unknown_chunks > 0 {
            w.push(format!(
                "{} chunk(s) of unknown kind skipped ({} bytes; written by a newer gazecast?)",
                s.unknown_chunks, s.unknown_bytes
            ));
        }
        if let Some(a) = &self.after_end {
            w.push(format!(
                "{} bytes after the end chunk (byte {}, {} valid chunk(s)) not decoded",
                a.bytes, a.offset, a.chunks
            ));
        }
        if s.lost_chunks > 0 {
            w.push(format!(
                "the recorder lost {} chunks while writing this file",
                s.lost_chunks
            ));
        }
        w
    }
}

fn parse_header(payload: &[u8]) -> Result<RecordingHeader> {
    let text = std::str::from_utf8(payload)
        .map_err(|_| Error::new(ErrorKind::InvalidData, "the header is not UTF-8"))?;
    ron::from_str::<RecordingHeader>(text).map_err(|e| {
        Error::new(
            ErrorKind::InvalidData,
            format!("the header does not parse: {e}"),
        )
    })
}

/// A valid chunk of any kind, borrowed from the file.
struct RawChunk<'a> {
    kind: u8,
    time_us: u64,
    payload: &'a [u8],
    /// Bytes it takes in the file, framing included.
    size: usize,
}

/// The chunk starting at `pos`, if a valid one does: its length within
/// [`MAX_PAYLOAD`] and the bytes remaining (checked before anything is
/// sliced), and its CRC right.
fn raw_chunk(bytes: &[u8], pos: usize) -> std::result::Result<RawChunk<'_>, String> {
    let b = bytes.get(pos..).unwrap_or(&[]);
    if b.len() < CHUNK_OVERHEAD {
        return Err(format!(
            "incomplete chunk: {} bytes left, a chunk needs at least {CHUNK_OVERHEAD}",
            b.len()
        ));
    }
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
    Ok(RawChunk {
        kind: b[0],
        time_us: u64::from_le_bytes(t),
        payload: &b[13..total - 4],
        size: total,
    })
}

/// The first offset from `from` at which a valid chunk starts, or the end of
/// the file.
fn resync(bytes: &[u8], from: usize) -> usize {
    let last_start = bytes.len().saturating_sub(CHUNK_OVERHEAD);
    (from..=last_start)
        .find(|&p| raw_chunk(bytes, p).is_ok())
        .unwrap_or(bytes.len())
}

/// Valid chunks from `pos` on, resynchronising over damage.
fn count_chunks(bytes: &[u8], mut pos: usize) -> u64 {
    let mut n = 0;
    while pos < bytes.len() {
        match raw_chunk(bytes, pos) {
            Ok(raw) => {
                n += 1;
                pos += raw.size;
            }
            Err(_) => pos = resync(bytes, pos + 1),
        }
    }
    n
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
    /// The writer's error, set the moment a write fails (a full disk, a
    /// file size limit, a removed device): the writer stops there.
    failure: std::sync::Mutex<Option<String>>,
    /// Set when the writer has ended (closed the file, or stopped at an
    /// error), for [`Tap::close_now`].
    ended: (std::sync::Mutex<bool>, std::sync::Condvar),
}

impl Counters {
    fn failure(&self) -> Option<String> {
        self.failure.lock().ok().and_then(|f| f.clone())
    }
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

    /// The write error that stopped the recording, as soon as it happens
    /// (see [`Recorder::failure`]).
    pub fn failure(&self) -> Option<String> {
        self.counters.failure()
    }

    /// Closes the recording from anywhere, now: asks the writer to write
    /// what is queued and the end chunk and to sync, and waits up to
    /// `limit` for it. For a process about to end without unwinding (the
    /// X server went away, and Xlib exits): the file is closed as at a
    /// normal end. Returns whether the writer ended in time.
    pub fn close_now(&self, limit: std::time::Duration) -> bool {
        let _ = self.tx.send_timeout(Message::Close, limit);
        let (lock, cv) = &self.counters.ended;
        let Ok(ended) = lock.lock() else {
            return false;
        };
        cv.wait_timeout_while(ended, limit, |e| !*e)
            .map(|(e, _)| *e)
            .unwrap_or(false)
    }

    /// Whether `other` taps the same recording.
    pub fn same_recording(&self, other: &Tap) -> bool {
        Arc::ptr_eq(&self.counters, &other.counters)
    }
}

/// Totals of a finished recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecorderSummary {
    /// Chunks written to the file.
    pub chunks_written: u64,
    /// Bytes written to the file.
    pub bytes_written: u64,
    /// Chunks dropped because the writer fell behind.
    pub lost_chunks: u64,
    /// Bytes in those chunks.
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
        let file = std::fs::File::create(path).map_err(io)?;
        Self::start_on(file, path, header, capacity)
    }

    /// [`start`](Self::start) on any [`Sink`] (tests give one that fails).
    fn start_on<W: Sink>(
        file: W,
        path: &Path,
        header: &RecordingHeader,
        capacity: usize,
    ) -> Result<Self> {
        let io = |e: std::io::Error| Error::from_io(&format!("{}", path.display()), &e);
        let mut file = BufWriter::new(file);
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
            .spawn(move || {
                let result = write_loop(file, rx, &writer_counters, &display);
                if let Err(e) = &result {
                    if let Ok(mut f) = writer_counters.failure.lock() {
                        *f = Some(e.to_string());
                    }
                }
                let (lock, cv) = &writer_counters.ended;
                if let Ok(mut ended) = lock.lock() {
                    *ended = true;
                }
                cv.notify_all();
                result
            })
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

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The write error that stopped the recording, as soon as it happens:
    /// the writer thread stops at the first failed write (a full disk, a
    /// file size limit), the file keeps every chunk written before it (a
    /// reader reports the torn tail), and later chunks are counted lost.
    /// A caller polls this to report the failure at once rather than at
    /// [`finish`](Self::finish).
    pub fn failure(&self) -> Option<String> {
        self.tap.counters.failure()
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

/// Where a recording's bytes go: a file, or in tests a writer that fails.
trait Sink: Write + Send + 'static {
    /// Makes what was written durable (`fsync` for a file).
    fn sync(&self) -> std::io::Result<()>;
}

impl Sink for std::fs::File {
    fn sync(&self) -> std::io::Result<()> {
        self.sync_all()
    }
}

fn write_loop<W: Sink>(
    mut file: BufWriter<W>,
    rx: Receiver<Message>,
    counters: &Counters,
    path: &str,
) -> Result<(u64, u64)> {
    let io = |e: std::io::Error| Error::from_io(path, &e);
    let (mut chunks, mut bytes) = (0u64, 0u64);
    let mut reported_lost = 0u64;
    let mut last_time = 0u64;
    let overflow = |file: &mut BufWriter<W>, t: u64, reported: &mut u64| -> std::io::Result<()> {
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
                write_chunks(&mut file, kind, t, &payload).map_err(io)?;
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
                file.get_ref().sync().map_err(io)?;
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

    /// A writer that accepts `room` bytes, then fails as a full disk does.
    struct FullAfter {
        written: Arc<std::sync::Mutex<Vec<u8>>>,
        room: usize,
    }

    impl Write for FullAfter {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let mut w = self.written.lock().expect("lock");
            let n = buf.len().min(self.room - w.len());
            if n == 0 && !buf.is_empty() {
                return Err(std::io::Error::from_raw_os_error(28)); // ENOSPC
            }
            w.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Sink for FullAfter {
        fn sync(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A full disk part-way through is known the moment it happens (not
    /// only at `finish`), later chunks are counted lost, and what was
    /// written before it reads back as a recording with a torn tail.
    #[test]
    fn a_write_error_is_known_at_once_and_what_was_written_reads_back() {
        let written = Arc::new(std::sync::Mutex::new(Vec::new()));
        let sink = FullAfter {
            written: written.clone(),
            room: 4096,
        };
        let rec = Recorder::start_on(sink, Path::new("full.gzrec"), &header(), 4).expect("start");
        let tap = rec.tap();
        let mut t = 0;
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while rec.failure().is_none() {
            assert!(std::time::Instant::now() < deadline, "no failure reported");
            t += 1;
            tap.device_to_host(t, &[7; 100]);
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let failure = rec.failure().expect("failure");
        assert!(failure.contains("full.gzrec"), "{failure}");
        assert_eq!(tap.failure(), Some(failure.clone()));
        // The writer is gone: what is sent now is counted, not queued.
        let lost = tap.lost_chunks();
        tap.device_to_host(t + 1, &[7; 100]);
        assert_eq!(tap.lost_chunks(), lost + 1);
        let e = rec.finish().expect_err("finish reports it too");
        assert!(e.to_string().contains("full.gzrec"), "{e}");
        let bytes = written.lock().expect("lock").clone();
        assert!(bytes.len() <= 4096);
        let r = Recording::parse(&bytes).expect("what was written reads back");
        assert!(!r.chunks.is_empty());
        assert!(!r.summary().closed, "{:?}", r.summary());
    }

    /// `close_now` from another thread closes the file as `finish` does
    /// (end chunk, nothing lost), and `finish` afterwards still succeeds.
    #[test]
    fn close_now_closes_the_file_from_anywhere() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.gzrec");
        let rec = Recorder::start(&path, &header(), 16).expect("start");
        let tap = rec.tap();
        tap.device_to_host(1, &[1, 2, 3]);
        let other = rec.tap();
        assert!(other.same_recording(&tap));
        let closed = std::thread::spawn(move || other.close_now(std::time::Duration::from_secs(5)))
            .join()
            .expect("thread");
        assert!(closed);
        let r = Recording::read(&path).expect("read");
        assert!(r.summary().is_clean(), "{:?}", r.warnings());
        assert_eq!(r.device_chunks().count(), 1);
        rec.finish().expect("finish after close_now");
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
    fn a_flipped_bit_skips_its_chunk_with_a_reason() {
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
        // The reader resynchronises on the end chunk that follows.
        assert!(r.closed && r.torn_tail.is_none() && r.chunks.is_empty());
        assert_eq!(r.damaged.len(), 1);
        assert_eq!(r.damaged[0].bytes, (CHUNK_OVERHEAD + 10) as u64);
        assert!(r.damaged[0].reason.contains("checksum"));
    }

    #[test]
    fn long_data_is_split_into_chunks_of_at_most_the_maximum() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.gzrec");
        let big: Vec<u8> = (0..2 * MAX_PAYLOAD + 5).map(|i| i as u8).collect();
        let chunk = |payload: Vec<u8>| Chunk {
            kind: ChunkKind::DeviceToHost,
            time_us: 7,
            payload,
        };
        write_recording(&path, &header(), &[chunk(big.clone()), chunk(vec![])]).expect("write");
        let r = Recording::read(&path).expect("read");
        assert!(r.summary().is_clean(), "{:?}", r.warnings());
        let sizes: Vec<usize> = r.chunks.iter().map(|c| c.payload.len()).collect();
        assert_eq!(sizes, vec![MAX_PAYLOAD, MAX_PAYLOAD, 5, 0]);
        let joined: Vec<u8> = r.device_chunks().flat_map(|c| c.payload.clone()).collect();
        assert_eq!(joined, big);

        let rec = Recorder::start(&path, &header(), 4).expect("start");
        rec.tap().device_to_host(9, &big);
        assert_eq!(rec.finish().expect("finish").chunks_written, 1);
        let r = Recording::read(&path).expect("read");
        assert!(r.summary().is_clean(), "{:?}", r.warnings());
        assert_eq!(r.chunks.len(), 3);
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
