//! `gazecast record`: a serial tracker or an LSL stream recorded losslessly
//! (raw bytes with arrival times), reopening a lost LSL stream.

use std::io::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use tracker_hal::recording::RecordingHeader;
use tracker_hal::supervisor::recording_stopped;
use tracker_hal::{Driver, GazeSource, MonotonicClock, Recorder, StreamDriver};

use super::load_tracker;
use crate::interrupt;

/// `gazecast record`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct RecordArgs {
    /// Tracker file (RON); an ISCAN needs `port`.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: PathBuf,
    /// Recording to write (`.gzrec`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Stop after this many seconds (a positive number; default: until
    /// Ctrl-C or SIGTERM, which stop the device and close the recording
    /// cleanly).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub seconds: Option<f64>,
}

/// A device link `record` reads: a serial port, an LSL inlet.
trait Link: std::io::Read + std::io::Write + Send {}
impl<T: std::io::Read + std::io::Write + Send> Link for T {}

/// Opens a live link again after it was lost.
type Reopen = Box<dyn Fn() -> Result<Box<dyn Link>, String>>;

/// A link that has ended (what `record` holds when a lost stream did not
/// come back before the end).
struct Closed;

impl std::io::Read for Closed {
    fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
        Ok(0)
    }
}

impl std::io::Write for Closed {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Runs `gazecast record`.
pub fn record(args: &RecordArgs, out: &mut dyn Write) -> Result<(), String> {
    if let Some(s) = args.seconds {
        if !(s.is_finite() && s > 0.0) {
            return Err(format!(
                "--seconds {s}: must be a positive number of seconds (leave it out to record until Ctrl-C)"
            ));
        }
    }
    crate::output::refuse_inputs(&[("--out", &args.out)], &[("--tracker", &args.tracker)])?;
    let tracker = load_tracker(&args.tracker)?;
    // The device link: a serial port, or an LSL inlet (which is opened
    // again, re-resolving the stream, when the stream is lost).
    let (link, note, reopen): (Box<dyn Link>, String, Option<Reopen>) = match &tracker.driver {
        Driver::Iscan(iscan) => {
            let port_name = iscan.port.clone().ok_or_else(|| {
                format!(
                    "{}: field `port` is needed to record from a serial tracker",
                    args.tracker.display()
                )
            })?;
            let port =
                tracker_hal::serial::open(&port_name, iscan.baud, Duration::from_millis(250))
                    .map_err(|e| e.to_string())?;
            (Box::new(port), format!("recorded from {port_name}"), None)
        }
        #[cfg(feature = "lsl")]
        Driver::Lsl(c) => {
            use tracker_hal::lsl::inlet::{describe, LslTransport};
            let open = {
                let c = c.clone();
                move || -> Result<Box<dyn Link>, String> {
                    Ok(Box::new(LslTransport::open(&c).map_err(|e| e.to_string())?))
                }
            };
            let first = open()?;
            (
                first,
                format!("recorded from the {}", describe(c)),
                Some(Box::new(open) as Reopen),
            )
        }
        _ => {
            return Err(format!(
                "{}: `record` talks to a serial tracker or an LSL stream; the {} driver needs the viewer window: gazecast view --record FILE (or calibrate --record FILE)",
                args.tracker.display(),
                tracker.driver_name()
            ))
        }
    };
    let header = RecordingHeader {
        tracker: tracker.clone(),
        display: None,
        note,
    };
    let recorder = Recorder::start(&args.out, &header, 8192).map_err(|e| e.to_string())?;
    let mut driver = StreamDriver::new(link, tracker.decoder(), Box::new(MonotonicClock))
        .with_tap(recorder.tap());
    // Decoder totals of the connections before this one.
    let mut before = tracker_hal::DecodeStats::default();
    let mut reconnects = 0u64;
    // Ctrl-C and SIGTERM end the loop below (within one read timeout), so
    // the device is stopped and the recording closed as at the end of
    // --seconds.
    interrupt::catch_interrupts();
    let started = driver.start().map_err(|e| e.to_string());
    let start = Instant::now();
    let mut timeouts = 0u64;
    let mut interrupted = false;
    let outcome = loop {
        if let Err(e) = &started {
            break Err(e.clone());
        }
        if interrupt::interrupted() {
            interrupted = true;
            break Ok(());
        }
        // A write error (a full disk) ends the recording at once: the
        // device is stopped and the file closed with what it holds.
        if let Some(e) = recorder.failure() {
            break Err(recording_stopped(&e));
        }
        if args
            .seconds
            .is_some_and(|s| start.elapsed().as_secs_f64() >= s)
        {
            break Ok(());
        }
        match driver.next_sample() {
            Ok(Some(_)) => {}
            Ok(None) => break Ok(()),
            Err(e) if e.kind == tracker_hal::ErrorKind::TimedOut => timeouts += 1,
            // A signal can cut a read short: it is the interruption, not a
            // device error.
            Err(_) if interrupt::interrupted() => {
                interrupted = true;
                break Ok(());
            }
            Err(e) if e.kind == tracker_hal::ErrorKind::Disconnected && reopen.is_some() => {
                let _ = writeln!(out, "{e}; opening it again");
                before = before + driver.stats();
                let Some(open) = &reopen else {
                    break Err(e.to_string());
                };
                // Try until it is back, the time is up or an interrupt.
                let link = loop {
                    if interrupt::interrupted()
                        || args
                            .seconds
                            .is_some_and(|s| start.elapsed().as_secs_f64() >= s)
                    {
                        break None;
                    }
                    match open() {
                        Ok(l) => break Some(l),
                        Err(e) => {
                            let _ = writeln!(out, "{e}; retrying");
                            std::thread::sleep(Duration::from_millis(250));
                        }
                    }
                };
                let Some(link) = link else {
                    driver = StreamDriver::new(
                        Box::new(Closed) as Box<dyn Link>,
                        tracker.decoder(),
                        Box::new(MonotonicClock),
                    );
                    continue;
                };
                reconnects += 1;
                let _ = writeln!(out, "reconnected ({reconnects})");
                driver = StreamDriver::new(link, tracker.decoder(), Box::new(MonotonicClock))
                    .with_tap(recorder.tap());
            }
            Err(e) => break Err(e.to_string()),
        }
    };
    let _ = driver.stop();
    let summary = match (recorder.finish(), &outcome) {
        (Ok(s), _) => s,
        (Err(e), Ok(())) => return Err(e.to_string()),
        // The loop's error already names a write error (it stopped there).
        (Err(e), Err(o)) if o.contains(&e.to_string()) => return Err(o.clone()),
        (Err(e), Err(o)) => return Err(format!("{o}; {e}")),
    };
    let s = before + driver.stats();
    let _ = writeln!(
        out,
        "{}: records={} dropped_bytes={} resyncs={} read_timeouts={} chunks={} bytes={}{}",
        args.out.display(),
        s.records,
        s.dropped_bytes,
        s.resyncs,
        timeouts,
        summary.chunks_written,
        summary.bytes_written,
        if reopen.is_some() {
            format!(" reconnects={reconnects}")
        } else {
            String::new()
        }
    );
    if interrupted {
        let _ = writeln!(
            out,
            "interrupted (Ctrl-C or SIGTERM): stop command sent, {} closed",
            args.out.display()
        );
    }
    if summary.lost_chunks > 0 {
        return Err(format!(
            "THE RECORDING LOST DATA: {} chunks ({} bytes) were dropped because the disk did not keep up",
            summary.lost_chunks, summary.lost_bytes
        ));
    }
    outcome
}
