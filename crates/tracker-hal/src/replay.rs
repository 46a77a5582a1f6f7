//! Replay: a recording (or a raw byte dump) as a transport, so replayed data
//! goes through exactly the decode path a live device does.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use crate::clock::SharedClock;
use crate::recording::Recording;

/// How fast a replay delivers its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pacing {
    /// Every chunk at once: for tests, conversion and analysis.
    AsFastAsPossible,
    /// Each chunk at its original offset from the first: for viewing a
    /// session as it happened.
    RealTime,
}

/// A transport that plays back timed chunks. Reading sets the paired
/// [`SharedClock`] to the chunk's recorded arrival time, so a driver stamps
/// samples with the original host times. Bytes written to it (start/stop
/// commands, markers) are kept in [`written`](Self::written).
pub struct ReplayTransport {
    chunks: Vec<(u64, Vec<u8>)>,
    next: usize,
    offset: usize,
    clock: SharedClock,
    pacing: Pacing,
    started: Option<(Instant, u64)>,
    written: Vec<u8>,
}

impl ReplayTransport {
    /// Plays `(arrival_time_us, bytes)` chunks in order.
    pub fn new(chunks: Vec<(u64, Vec<u8>)>, pacing: Pacing) -> Self {
        Self {
            chunks,
            next: 0,
            offset: 0,
            clock: SharedClock::default(),
            pacing,
            started: None,
            written: Vec::new(),
        }
    }

    /// The device → host data of a recording.
    pub fn from_recording(recording: &Recording, pacing: Pacing) -> Self {
        Self::new(
            recording
                .device_chunks()
                .map(|c| (c.time_us, c.payload.clone()))
                .collect(),
            pacing,
        )
    }

    /// A raw byte dump with no timing: arrival times are synthesised as if the
    /// bytes came over a serial line at `baud` (10 bits a byte), in reads of
    /// `chunk_len` bytes.
    pub fn from_raw_bytes(bytes: &[u8], baud: u32, chunk_len: usize, pacing: Pacing) -> Self {
        let per_byte_us = 10_000_000.0 / f64::from(baud.max(1));
        let chunks = bytes
            .chunks(chunk_len.max(1))
            .scan(0usize, |sent, c| {
                *sent += c.len();
                Some(((*sent as f64 * per_byte_us).round() as u64, c.to_vec()))
            })
            .collect();
        Self::new(chunks, pacing)
    }

    /// The clock a driver must use to get the recorded arrival times.
    pub fn clock(&self) -> SharedClock {
        self.clock.clone()
    }

    /// Everything the driver wrote to the "device".
    pub fn written(&self) -> &[u8] {
        &self.written
    }
}

impl Read for ReplayTransport {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // An empty chunk is valid data (nothing arrived): skip it rather
        // than read it as the end of the stream.
        while self.offset == 0
            && self
                .chunks
                .get(self.next)
                .is_some_and(|(_, b)| b.is_empty())
        {
            self.next += 1;
        }
        let Some((time_us, bytes)) = self.chunks.get(self.next) else {
            return Ok(0);
        };
        if self.pacing == Pacing::RealTime {
            let (start, first) = *self.started.get_or_insert((Instant::now(), *time_us));
            let due = start + Duration::from_micros(time_us.saturating_sub(first));
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        let n = buf.len().min(bytes.len() - self.offset);
        buf[..n].copy_from_slice(&bytes[self.offset..self.offset + n]);
        self.clock.set_us(*time_us);
        self.offset += n;
        if self.offset == bytes.len() {
            self.next += 1;
            self.offset = 0;
        }
        Ok(n)
    }
}

impl Write for ReplayTransport {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.written.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An empty chunk (a valid one: nothing arrived) used to read as the end
    /// of the stream and cut a replay short.
    #[test]
    fn an_empty_chunk_is_not_the_end_of_the_stream() {
        let chunks = vec![(0, vec![1, 2]), (10, vec![]), (15, vec![]), (20, vec![3])];
        let mut t = ReplayTransport::new(chunks, Pacing::AsFastAsPossible);
        let (mut all, mut buf) = (Vec::new(), [0u8; 8]);
        loop {
            let n = t.read(&mut buf).expect("reads");
            if n == 0 {
                break;
            }
            all.extend_from_slice(&buf[..n]);
        }
        assert_eq!(all, [1, 2, 3]);
    }
}
