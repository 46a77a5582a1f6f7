//! The live side: an LSL inlet as a byte transport (feature `lsl`). This
//! is the only code that uses `labstream`.
//!
//! [`LslTransport::open`] resolves the configured stream, reads its full
//! description (the resolve answer carries placeholder labels), checks
//! that every label the mapping names exists, opens an inlet that does
//! *not* recover on its own (`recover(false)`: a lost stream must be
//! reported, and the driver re-resolves it), and waits up to
//! `resolve_timeout_ms` for the first time-correction measurement. Each
//! `read` then gives the stream-info record once, then one sample record
//! per pulled sample.
//!
//! A `read` waits at most [`READ_SLICE`] for a sample and returns a
//! `TimedOut` error when none came (the driver's caller stays in control).
//! The stream counts as lost — a `ConnectionAborted` error, which the
//! driver reports as `Disconnected`, and the viewer's tracker thread and
//! `gazecast record` reopen (re-resolve) it — when the inlet says the
//! source has ended (`is_finished`; `pull` itself never reports it), when
//! `pull` says `Lost`, or when no sample came for `silence_ms`.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use labstream::{Buffer, Format, Inlet, Post, Query};

use super::{encode_info, encode_sample, LslConfig, StreamHeader, MAX_CHANNELS};
use crate::error::{Error, ErrorKind, Result};

/// The longest one `read` waits for a sample.
pub const READ_SLICE: Duration = Duration::from_millis(100);

/// An open LSL inlet that reads as a stream of records.
pub struct LslTransport {
    inlet: Inlet,
    /// Bytes framed and not yet read.
    out: Vec<u8>,
    pos: usize,
    silence: Duration,
    last_sample: Instant,
    channels: usize,
    what: String,
}

fn io(kind: std::io::ErrorKind, m: String) -> std::io::Error {
    std::io::Error::new(kind, m)
}

/// The stream the configuration names, for messages.
pub fn describe(c: &LslConfig) -> String {
    let mut parts = Vec::new();
    for (k, v) in [
        ("name", &c.name),
        ("type", &c.stream_type),
        ("source_id", &c.source_id),
    ] {
        if let Some(v) = v {
            parts.push(format!("{k}={v:?}"));
        }
    }
    format!("LSL stream {}", parts.join(" "))
}

impl LslTransport {
    /// Resolves and opens the configured stream (see the module docs).
    pub fn open(c: &LslConfig) -> Result<Self> {
        let what = describe(c);
        let timeout = Duration::from_millis(c.resolve_timeout_ms);
        let mut query: Option<Query> = None;
        for q in [
            c.name.as_deref().map(Query::name),
            c.stream_type.as_deref().map(Query::stream_type),
            c.source_id.as_deref().map(Query::source_id),
        ]
        .into_iter()
        .flatten()
        {
            query = Some(match query {
                Some(a) => a.and(q),
                None => q,
            });
        }
        let query = query.ok_or_else(|| {
            Error::new(
                ErrorKind::InvalidData,
                "the LSL tracker names no stream (name, stream_type or source_id)",
            )
        })?;
        let lost = |m: String| Error::new(ErrorKind::Disconnected, m);
        let info = labstream::resolve_first(&query, timeout)
            .map_err(|e| lost(format!("resolving the {what}: {e}")))?
            .ok_or_else(|| {
                lost(format!(
                    "no {what} found within {} ms",
                    c.resolve_timeout_ms
                ))
            })?;
        let channels = info.channel_count();
        if !(1..=MAX_CHANNELS).contains(&channels) {
            return Err(Error::new(
                ErrorKind::Unsupported,
                format!("the {what} has {channels} channels; 1 to {MAX_CHANNELS} are read"),
            ));
        }
        if matches!(info.format(), Format::String | Format::Undefined) {
            return Err(Error::new(
                ErrorKind::Unsupported,
                format!("the {what} carries text, not numbers"),
            ));
        }
        let full = info
            .fetch(timeout)
            .map_err(|e| lost(format!("reading the {what}'s description: {e}")))?;
        let labels: Vec<String> = full
            .channels()
            .into_iter()
            .take(MAX_CHANNELS)
            .map(|ch| ch.label)
            .collect();
        for (field, label) in c.labels() {
            if !labels.iter().any(|l| l == label) {
                return Err(Error::new(
                    ErrorKind::Unsupported,
                    format!(
                        "{field}: the {what} has no channel labelled {label:?}; its channels are {labels:?}"
                    ),
                ));
            }
        }
        let inlet = Inlet::builder(&info)
            .buffer(Buffer::Seconds(360.0))
            .recover(false)
            .postprocess(Post::NONE)
            .open(timeout)
            .map_err(|e| lost(format!("opening an inlet on the {what}: {e}")))?;
        // The first measurement normally takes a few ms; a record before it
        // carries NaN (see the decoder's docs).
        let _ = inlet.wait_for_time_correction(timeout);
        let header = StreamHeader {
            name: full.name().to_string(),
            stream_type: full.stream_type().to_string(),
            source_id: full.source_id().to_string(),
            channel_count: channels,
            labels,
        };
        Ok(Self {
            inlet,
            out: encode_info(&header),
            pos: 0,
            silence: Duration::from_millis(c.silence_ms),
            last_sample: Instant::now(),
            channels,
            what,
        })
    }

    /// Samples the inlet's buffer dropped because they were not read in time.
    pub fn dropped(&self) -> u64 {
        self.inlet.dropped()
    }

    fn give(&mut self, buf: &mut [u8]) -> usize {
        let n = (self.out.len() - self.pos).min(buf.len());
        buf[..n].copy_from_slice(&self.out[self.pos..self.pos + n]);
        self.pos += n;
        n
    }
}

impl Read for LslTransport {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.pos < self.out.len() || buf.is_empty() {
            return Ok(self.give(buf));
        }
        use std::io::ErrorKind as K;
        match self.inlet.pull::<f64>(READ_SLICE) {
            Ok(Some((ts, values))) => {
                if values.len() != self.channels {
                    return Err(io(
                        K::InvalidData,
                        format!(
                            "the {} sent {} values for {} channels",
                            self.what,
                            values.len(),
                            self.channels
                        ),
                    ));
                }
                let tc = self.inlet.time_correction().unwrap_or(f64::NAN);
                self.out = encode_sample(ts, tc, &values);
                self.pos = 0;
                self.last_sample = Instant::now();
                Ok(self.give(buf))
            }
            Ok(None) if self.inlet.is_finished() => Err(io(
                K::ConnectionAborted,
                format!("the {} has gone", self.what),
            )),
            Ok(None) if self.last_sample.elapsed() >= self.silence => Err(io(
                K::ConnectionAborted,
                format!(
                    "no sample from the {} for {} ms: taken as lost",
                    self.what,
                    self.silence.as_millis()
                ),
            )),
            Ok(None) => Err(io(
                K::TimedOut,
                format!("no sample from the {} yet", self.what),
            )),
            Err(labstream::Error::Lost) => Err(io(
                K::ConnectionAborted,
                format!("the {} has gone", self.what),
            )),
            Err(labstream::Error::Timeout) => Err(io(K::TimedOut, "LSL pull timed out".into())),
            Err(e) => Err(io(K::Other, format!("reading the {}: {e}", self.what))),
        }
    }
}

impl Write for LslTransport {
    /// An LSL stream takes no commands: written bytes are ignored.
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
