//! Replay: a recording (or a raw byte dump) as a transport, so replayed data
//! goes through exactly the decode path a live device does.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
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
    read_timeout: Option<Duration>,
    stop: Option<Arc<AtomicBool>>,
}

/// The longest single sleep of real-time pacing: waits are sliced so a stop
/// flag or a read timeout is noticed within it.
const PACING_SLICE: Duration = Duration::from_millis(10);

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
            read_timeout: None,
            stop: None,
        }
    }

    /// Like a serial port's read timeout: in real-time pacing, a read whose
    /// next chunk is not due within `timeout` (a silent gap in the
    /// recording) waits that long, then fails with
    /// [`std::io::ErrorKind::TimedOut`] (the driver's
    /// [`TimedOut`](crate::ErrorKind::TimedOut): call again). Without it a
    /// read sleeps through the whole gap.
    pub fn with_read_timeout(mut self, timeout: Duration) -> Self {
        self.read_timeout = Some(timeout);
        self
    }

    /// A flag that, once set, cuts any pacing wait short: the read fails at
    /// once with [`std::io::ErrorKind::TimedOut`] (checked every 10 ms).
    pub fn with_stop(mut self, stop: Arc<AtomicBool>) -> Self {
        self.stop = Some(stop);
        self
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
            let give_up = self.read_timeout.map(|t| Instant::now() + t);
            loop {
                let now = Instant::now();
                if due <= now {
                    break;
                }
                let stopped = self
                    .stop
                    .as_ref()
                    .is_some_and(|s| s.load(Ordering::Relaxed));
                if stopped || give_up.is_some_and(|g| now >= g) {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::TimedOut,
                        if stopped {
                            "the replay was asked to stop"
                        } else {
                            "no data within the read timeout (a silent stretch of the recording)"
                        },
                    ));
                }
                let mut wait = (due - now).min(PACING_SLICE);
                if let Some(g) = give_up {
                    wait = wait.min(g - now);
                }
                std::thread::sleep(wait);
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

    /// A 40-s silent gap used to hold a real-time read for 40 s, whatever
    /// its caller wanted: with a read timeout the read returns `TimedOut`
    /// in time, and a stop flag ends the wait at once. The data after the
    /// gap is still delivered.
    #[test]
    fn a_silent_gap_times_out_and_a_stop_flag_cuts_the_wait_short() {
        let chunks = vec![(0, vec![1]), (40_000_000, vec![2])];
        let mut t = ReplayTransport::new(chunks.clone(), Pacing::RealTime)
            .with_read_timeout(Duration::from_millis(50));
        let mut buf = [0u8; 4];
        assert_eq!(t.read(&mut buf).expect("first chunk"), 1);
        let began = Instant::now();
        let e = t.read(&mut buf).expect_err("the gap");
        assert_eq!(e.kind(), std::io::ErrorKind::TimedOut);
        assert!(
            began.elapsed() < Duration::from_millis(500),
            "{:?}",
            began.elapsed()
        );
        let stop = Arc::new(AtomicBool::new(false));
        let mut t = ReplayTransport::new(chunks, Pacing::RealTime).with_stop(stop.clone());
        assert_eq!(t.read(&mut buf).expect("first chunk"), 1);
        let setter = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            stop.store(true, Ordering::Relaxed);
        });
        let began = Instant::now();
        let e = t.read(&mut buf).expect_err("stopped");
        assert_eq!(e.kind(), std::io::ErrorKind::TimedOut);
        assert!(
            began.elapsed() < Duration::from_millis(500),
            "{:?}",
            began.elapsed()
        );
        setter.join().expect("setter");
        // Not lost: the replay goes on where it was (here, as fast as possible).
        t.pacing = Pacing::AsFastAsPossible;
        assert_eq!(t.read(&mut buf).expect("second chunk"), 1);
        assert_eq!(buf[0], 2);
    }
}
