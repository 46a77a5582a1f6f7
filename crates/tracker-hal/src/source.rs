//! The gaze-source trait and the generic stream driver that every
//! byte-stream device (ISCAN, the mouse emulator, replays) goes through.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use crate::clock::Clock;
use crate::error::{Error, ErrorKind, Result};
use crate::recording::Tap;
use crate::sample::{DecodeStats, GazeSample};
use crate::timing::{ClockMapper, ClockState, DeviceClock};

/// A source of gaze samples. Blocking, in the style of `embedded-io`.
///
/// - [`start`](GazeSource::start) asks the device to stream; [`stop`](GazeSource::stop)
///   asks it to stop. Both only send; neither waits for data.
/// - [`next_sample`](GazeSource::next_sample) blocks until one complete record is
///   decoded and returns it. It returns early with:
///   - `Ok(None)`: the stream ended cleanly (the transport reported end of
///     file, e.g. the end of a replay). Every later call returns `Ok(None)`.
///   - `Err` with [`ErrorKind::TimedOut`]: no complete record arrived within
///     the transport's timeout. Nothing is lost; call again.
///   - `Err` with [`ErrorKind::Disconnected`]: the transport failed. Reopen it.
/// - Garbage in the stream is not an error: decoders skip it, resynchronise and
///   count it in [`stats`](GazeSource::stats).
pub trait GazeSource {
    /// Asks the device to stream; only sends, does not wait for data.
    fn start(&mut self) -> Result<()>;
    /// Asks the device to stop streaming; only sends.
    fn stop(&mut self) -> Result<()>;
    /// The next complete sample; blocks until one is decoded (see the trait doc).
    fn next_sample(&mut self) -> Result<Option<GazeSample>>;
    /// What the decoder has counted so far (records, dropped bytes, resyncs…).
    fn stats(&self) -> DecodeStats;
    /// How this source's device times are obtained.
    fn device_clock(&self) -> DeviceClock {
        DeviceClock::Device
    }
    /// The clock model of the current connection (offset, drift, what it
    /// corrected), once a sample has been mapped; `None` for sources that
    /// do not map (their `mapped_time_us` is the arrival time).
    fn clock(&self) -> Option<ClockState> {
        None
    }
}

/// Turns device bytes into samples. A decoder is a pure state machine: no
/// I/O, no clock; it is what the conformance suite and the fuzzers drive.
pub trait Decoder: Send {
    /// Feeds `bytes` that arrived at host time `arrival_us`, appending every
    /// record they complete to `out`.
    fn push(&mut self, bytes: &[u8], arrival_us: u64, out: &mut VecDeque<GazeSample>);
    /// The stream ended: whatever is left is counted as dropped.
    fn finish(&mut self);
    /// What the decoder has counted so far (records, dropped bytes, resyncs…).
    fn stats(&self) -> DecodeStats;
    /// Bytes that ask the device to start streaming (may be empty).
    fn start_command(&self) -> Vec<u8>;
    /// Bytes that ask the device to stop streaming (may be empty).
    fn stop_command(&self) -> Vec<u8>;
    /// The coordinate frame (width, height, tracker units) the device has
    /// reported about itself, when it does (HID: the calibrated screen size).
    fn frame_hint(&self) -> Option<(f64, f64)> {
        None
    }
    /// How the decoder obtains device times (see [`DeviceClock`]).
    fn device_clock(&self) -> DeviceClock {
        DeviceClock::Device
    }
}

/// A [`GazeSource`] over any byte transport (`Read + Write`): a serial port,
/// a pseudo-terminal, a pipe, an in-memory buffer, a replayed recording.
pub struct StreamDriver<T, D> {
    transport: T,
    decoder: D,
    clock: Box<dyn Clock>,
    tap: Option<Tap>,
    pending: VecDeque<GazeSample>,
    buf: Vec<u8>,
    ended: bool,
    max_wait: Option<Duration>,
    mapper: ClockMapper,
}

impl<T: Read + Write, D: Decoder> StreamDriver<T, D> {
    /// `clock` stamps each chunk read from the transport with its arrival time.
    pub fn new(transport: T, decoder: D, clock: Box<dyn Clock>) -> Self {
        Self {
            transport,
            decoder,
            clock,
            tap: None,
            pending: VecDeque::new(),
            buf: vec![0; 4096],
            ended: false,
            max_wait: None,
            mapper: ClockMapper::new(),
        }
    }

    /// Bounds the time one [`next_sample`](GazeSource::next_sample) call
    /// spends reading: when bytes keep arriving but no record completes
    /// within `wait` (wrong baud or format, a garbage burst), it returns
    /// [`ErrorKind::TimedOut`] after the read that crossed it, so the caller
    /// regains control (a stop flag, a status line) even though the
    /// transport itself never times out. Nothing is lost: the decoder keeps
    /// its partial record. Without it a call returns only on a record, the
    /// end of the stream, or a transport error or timeout.
    pub fn with_max_wait(mut self, wait: Duration) -> Self {
        self.max_wait = Some(wait);
        self
    }

    /// Also send every byte read and written, with its time, to a recorder.
    pub fn with_tap(mut self, tap: Tap) -> Self {
        self.tap = Some(tap);
        self
    }

    /// The decoder.
    pub fn decoder(&self) -> &D {
        &self.decoder
    }

    /// The transport, for tests and replays that drive it.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Writes raw bytes to the device (commands, markers).
    pub fn send(&mut self, bytes: &[u8]) -> Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        self.transport
            .write_all(bytes)
            .map_err(|e| Error::from_io("writing to the tracker", &e))?;
        self.transport
            .flush()
            .map_err(|e| Error::from_io("writing to the tracker", &e))?;
        if let Some(tap) = &self.tap {
            tap.host_to_device(self.clock.now_us(), bytes);
        }
        Ok(())
    }
}

impl<T: Read + Write, D: Decoder> GazeSource for StreamDriver<T, D> {
    fn start(&mut self) -> Result<()> {
        let bytes = self.decoder.start_command();
        self.send(&bytes)
    }

    fn stop(&mut self) -> Result<()> {
        let bytes = self.decoder.stop_command();
        self.send(&bytes)
    }

    fn next_sample(&mut self) -> Result<Option<GazeSample>> {
        let began = self.max_wait.map(|w| (Instant::now(), w));
        loop {
            if let Some(s) = self.pending.pop_front() {
                return Ok(Some(s));
            }
            if self.ended {
                return Ok(None);
            }
            match self.transport.read(&mut self.buf) {
                Ok(0) => {
                    self.decoder.finish();
                    self.ended = true;
                }
                Ok(n) => {
                    let t = self.clock.now_us();
                    if let Some(tap) = &self.tap {
                        tap.device_to_host(t, &self.buf[..n]);
                    }
                    let before = self.pending.len();
                    self.decoder.push(&self.buf[..n], t, &mut self.pending);
                    // The records this read completed, mapped together: the
                    // last of them is the least delayed.
                    let pending = self.pending.make_contiguous();
                    self.mapper.map_read(&mut pending[before..]);
                    if let Some((began, wait)) = began {
                        if self.pending.is_empty() && began.elapsed() >= wait {
                            return Err(Error::new(
                                ErrorKind::TimedOut,
                                format!(
                                    "no complete record within {} ms although bytes arrive",
                                    wait.as_millis()
                                ),
                            ));
                        }
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    let err = Error::from_io("reading from the tracker", &e);
                    if err.kind == ErrorKind::Disconnected {
                        self.decoder.finish();
                    }
                    return Err(err);
                }
            }
        }
    }

    fn stats(&self) -> DecodeStats {
        self.decoder.stats()
    }

    fn device_clock(&self) -> DeviceClock {
        self.decoder.device_clock()
    }

    fn clock(&self) -> Option<ClockState> {
        (self.mapper.state().samples > 0).then(|| self.mapper.state())
    }
}

/// Decodes a whole byte buffer at once (arrival time `arrival_us` for all of
/// it): the decoder path without a transport, for tests and fuzzers.
pub fn decode_all<D: Decoder>(decoder: &mut D, bytes: &[u8], arrival_us: u64) -> Vec<GazeSample> {
    let mut out = VecDeque::new();
    decoder.push(bytes, arrival_us, &mut out);
    decoder.finish();
    out.into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MonotonicClock;
    use crate::iscan::{IscanConfig, IscanDecoder, IscanMode};

    /// A transport that never times out and never ends: garbage forever,
    /// a little at a time (a device at the wrong baud).
    struct Garbage;

    impl Read for Garbage {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            std::thread::sleep(Duration::from_millis(2));
            let n = buf.len().min(16);
            buf[..n].fill(0x11);
            Ok(n)
        }
    }

    impl Write for Garbage {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// Bytes that never decode used to keep `next_sample` reading forever,
    /// so its caller could never check a stop flag.
    #[test]
    fn bytes_that_never_decode_return_timed_out_within_the_max_wait() {
        let decoder = IscanDecoder::new(IscanConfig::binocular(IscanMode::Binary));
        let mut d = StreamDriver::new(Garbage, decoder, Box::new(MonotonicClock))
            .with_max_wait(Duration::from_millis(100));
        let t = Instant::now();
        let e = d.next_sample().expect_err("no record can decode");
        assert_eq!(e.kind, ErrorKind::TimedOut, "{e}");
        assert!(
            t.elapsed() < Duration::from_millis(500),
            "{:?}",
            t.elapsed()
        );
        assert!(d.stats().bytes > 0 && d.stats().records == 0);
    }
}
