//! `gazecast replay`, `record`, `devices` and `simulate`: the tracker side of
//! the command line.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use tracker_hal::csv::{csv_row, CSV_HEADER};
use tracker_hal::hid::sim::{simulate_hid, HidLayout};
use tracker_hal::recording::{write_recording, ChunkKind, RecordingHeader};
use tracker_hal::sim::{
    calibration_stops, fixation_script, gaze_script, simulate_iscan, simulate_mouse, Script,
    SimStream,
};
use tracker_hal::{
    Driver, GazeSource, MonotonicClock, Pacing, Recorder, Recording, ReplayTransport, StreamDriver,
    TrackerConfig,
};

use crate::args::PlanArgs;
use crate::config;

/// Input format of `gazecast replay`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InputFormat {
    /// A `.gzrec` recording (arrival times as recorded).
    Recording,
    /// Raw device bytes with no timing (arrival times synthesised from the baud rate).
    RawBytes,
    /// HID report log: `<host_time_us> <hex bytes>` per report, `# descriptor
    /// <hex>` and `# feature <hex>` lines (the HID driver's recording format).
    HidLog,
}

#[derive(Debug, Clone, clap::Args)]
pub struct ReplayArgs {
    /// Tracker file (RON): driver and mapping used to decode.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: PathBuf,
    /// The recording or byte dump to decode.
    #[arg(long, value_name = "FILE")]
    pub input: PathBuf,
    #[arg(long, value_enum, default_value = "recording")]
    pub format: InputFormat,
    /// Output CSV, one row per decoded record.
    #[arg(long, value_name = "OUT.csv")]
    pub csv: PathBuf,
    /// Coordinates in tracker units instead of screen pixels.
    #[arg(long)]
    pub raw: bool,
    /// Deliver the data at its original pacing instead of as fast as possible.
    #[arg(long)]
    pub realtime: bool,
    /// Map gaze with this calibration (RON, from `tracker_hal::calibration`)
    /// instead of the tracker file's mapping.
    #[arg(long, value_name = "FILE.ron")]
    pub calibration: Option<PathBuf>,
}

#[derive(Debug, Clone, clap::Args)]
pub struct RecordArgs {
    /// Tracker file (RON); an ISCAN needs `port`.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: PathBuf,
    /// Recording to write (`.gzrec`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Stop after this many seconds (default: until interrupted; the file
    /// stays readable either way).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
}

#[derive(Debug, Clone, clap::Args)]
pub struct SimulateArgs {
    /// Tracker file (RON) whose wire format to simulate.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: PathBuf,
    /// Recording to write (`.gzrec`).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Also write the samples a correct decoder must produce (tracker units).
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<PathBuf>,
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub seconds: f64,
    /// Sampling rate (default: 60 Hz for ISCAN, the tracker file's rate for the mouse).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// HID trackers: which report layout the simulated device uses.
    #[arg(long, value_enum, default_value = "reference")]
    pub hid_layout: HidLayoutArg,
    /// HID trackers: also write the device side as a hid-log text file.
    #[arg(long, value_name = "FILE")]
    pub hid_log: Option<PathBuf>,
    /// What the simulated person does: `search` (fixations anywhere,
    /// saccades, blinks, a lost eye; --seconds long) or `calibration`
    /// (follows `gazecast calibrate`'s targets, then its validation
    /// targets, given the same plan options and --display; the tracker is
    /// uncalibrated: it sees the screen in perspective).
    #[arg(long, value_enum, default_value = "search")]
    pub script: ScriptArg,
    /// --script calibration: the display the targets are on.
    #[arg(long, value_name = "FILE")]
    pub display: Option<PathBuf>,
    #[command(flatten)]
    pub plan: PlanArgs,
    /// --script calibration: the eyes are closed through this calibration
    /// target (0-based, in presentation order), so it is rejected and
    /// shown again.
    #[arg(long, value_name = "I")]
    pub closed_target: Option<usize>,
}

/// Behaviours the simulator scripts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ScriptArg {
    Search,
    Calibration,
}

/// Report layouts of the simulated HID tracker.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum HidLayoutArg {
    /// As Microsoft's reference descriptor (8×1-byte timestamp, Constant fields).
    Reference,
    /// Another order, 64-bit timestamp, padding, no head position.
    Compact,
}

/// The sample CSV of `replay` and `simulate`, with errors naming the file.
/// Written whole or not at all (`crate::output`): an error part-way leaves
/// any existing file as it was.
struct SampleCsv<'a> {
    path: &'a Path,
    w: crate::output::AtomicFile,
}

impl<'a> SampleCsv<'a> {
    fn create(path: &'a Path) -> Result<Self, String> {
        let w = crate::output::AtomicFile::create(path).map_err(|e| Self::fail(path, e))?;
        let mut csv = Self { path, w };
        writeln!(csv.w, "{CSV_HEADER}").map_err(|e| Self::fail(path, e))?;
        Ok(csv)
    }

    fn row(
        &mut self,
        s: &tracker_hal::GazeSample,
        map: &dyn Fn([f64; 2]) -> Option<[f64; 2]>,
    ) -> Result<(), String> {
        writeln!(self.w, "{}", csv_row(s, map)).map_err(|e| Self::fail(self.path, e))
    }

    fn finish(self) -> Result<(), String> {
        self.w.commit().map_err(|e| Self::fail(self.path, e))
    }

    fn fail(path: &Path, e: std::io::Error) -> String {
        format!("{}: cannot write: {e}", path.display())
    }
}

fn load_tracker(path: &Path) -> Result<TrackerConfig, String> {
    config::load_tracker(path).map_err(|e| e.to_string())
}

/// Runs `gazecast replay`.
pub fn replay(args: &ReplayArgs, err: &mut dyn Write) -> Result<(), String> {
    let mut inputs = vec![
        ("--input", args.input.as_path()),
        ("--tracker", &args.tracker),
    ];
    inputs.extend(args.calibration.as_deref().map(|p| ("--calibration", p)));
    crate::output::refuse_inputs(&[("--csv", &args.csv)], &inputs)?;
    let tracker = load_tracker(&args.tracker)?;
    let pacing = if args.realtime {
        Pacing::RealTime
    } else {
        Pacing::AsFastAsPossible
    };
    let transport = match args.format {
        InputFormat::Recording => {
            let rec = Recording::read(&args.input).map_err(|e| e.to_string())?;
            // Damage, interruption, unknown chunks, data after End and lost
            // chunks: each said once; what can be read is replayed.
            for w in rec.warnings() {
                let _ = writeln!(err, "warning: {}: {w}", args.input.display());
            }
            ReplayTransport::from_recording(&rec, pacing)
        }
        InputFormat::RawBytes | InputFormat::HidLog => {
            if (args.format == InputFormat::HidLog) != matches!(tracker.driver, Driver::TobiiHid(_))
            {
                return Err(format!(
                    "--format hid-log goes with a TobiiHid tracker file; {} has a {} driver",
                    args.tracker.display(),
                    tracker.driver_name()
                ));
            }
            let bytes = std::fs::read(&args.input)
                .map_err(|e| format!("{}: cannot read: {e}", args.input.display()))?;
            let baud = match &tracker.driver {
                Driver::Iscan(c) => c.baud,
                _ => 115_200,
            };
            ReplayTransport::from_raw_bytes(&bytes, baud, 16, pacing)
        }
    };
    let clock = transport.clock();
    let mut driver = StreamDriver::new(transport, tracker.decoder(), Box::new(clock));
    // Every input is read and checked before the output is created.
    let calibration = match &args.calibration {
        Some(path) => Some(config::load_calibration(path).map_err(|e| e.to_string())?),
        None => None,
    };
    let mut out = SampleCsv::create(&args.csv)?;
    let mapping = tracker.mapping.clone();
    driver.start().map_err(|e| e.to_string())?;
    while let Some(sample) = driver.next_sample().map_err(|e| e.to_string())? {
        // A HID tracker reports its screen size in its features, which
        // precede the first sample.
        let frame = driver.decoder().frame_hint().unwrap_or(tracker.frame());
        let map = |p: [f64; 2]| {
            if args.raw {
                Some(p)
            } else if let Some(c) = &calibration {
                c.map(p)
            } else {
                Some(mapping.to_screen(p, frame))
            }
        };
        out.row(&sample, &map)?;
    }
    out.finish()?;
    let s = driver.stats();
    writeln!(
        err,
        "records={} dropped_bytes={} resyncs={}",
        s.records, s.dropped_bytes, s.resyncs
    )
    .map_err(|e| e.to_string())
}

/// Runs `gazecast record`.
pub fn record(args: &RecordArgs, out: &mut dyn Write) -> Result<(), String> {
    crate::output::refuse_inputs(&[("--out", &args.out)], &[("--tracker", &args.tracker)])?;
    let tracker = load_tracker(&args.tracker)?;
    let Driver::Iscan(iscan) = &tracker.driver else {
        return Err(format!(
            "{}: `record` talks to a serial tracker; the {} driver needs the viewer window: gazecast view --record FILE (or calibrate --record FILE)",
            args.tracker.display(),
            tracker.driver_name()
        ));
    };
    let port_name = iscan.port.clone().ok_or_else(|| {
        format!(
            "{}: field `port` is needed to record from a serial tracker",
            args.tracker.display()
        )
    })?;
    let port = tracker_hal::serial::open(&port_name, iscan.baud, Duration::from_millis(250))
        .map_err(|e| e.to_string())?;
    let header = RecordingHeader {
        tracker: tracker.clone(),
        display: None,
        note: format!("recorded from {port_name}"),
    };
    let recorder = Recorder::start(&args.out, &header, 8192).map_err(|e| e.to_string())?;
    let mut driver = StreamDriver::new(port, tracker.decoder(), Box::new(MonotonicClock))
        .with_tap(recorder.tap());
    driver.start().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let mut timeouts = 0u64;
    let outcome = loop {
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
            Err(e) => break Err(e.to_string()),
        }
    };
    let _ = driver.stop();
    let summary = recorder.finish().map_err(|e| e.to_string())?;
    let s = driver.stats();
    let _ = writeln!(
        out,
        "{}: records={} dropped_bytes={} resyncs={} read_timeouts={} chunks={} bytes={}",
        args.out.display(),
        s.records,
        s.dropped_bytes,
        s.resyncs,
        timeouts,
        summary.chunks_written,
        summary.bytes_written
    );
    if summary.lost_chunks > 0 {
        return Err(format!(
            "THE RECORDING LOST DATA: {} chunks ({} bytes) were dropped because the disk did not keep up",
            summary.lost_chunks, summary.lost_bytes
        ));
    }
    outcome
}

/// Runs `gazecast devices`.
pub fn devices(out: &mut dyn Write) -> Result<(), String> {
    let ports = tracker_hal::serial::list_ports()
        .unwrap_or_else(|e| vec![format!("(serial ports unavailable: {e})")]);
    let w = |out: &mut dyn Write, s: &str| writeln!(out, "{s}").map_err(|e| e.to_string());
    w(out, "serial ports:")?;
    if ports.is_empty() {
        w(out, "  (none found)")?;
    }
    for p in ports {
        w(out, &format!("  {p}"))?;
    }
    for (title, found) in [
        (
            "USB eye trackers (known vendors: Tobii 0x2104):",
            tracker_hal::discovery::usb_trackers(),
        ),
        (
            "HID eye trackers (usage page 0x12):",
            tracker_hal::discovery::hid_trackers(),
        ),
    ] {
        w(out, title)?;
        match found {
            Ok(list) if list.is_empty() => w(out, "  (none found)")?,
            Ok(list) => {
                for d in list {
                    w(out, &format!("  {d}"))?;
                }
            }
            Err(e) => w(out, &format!("  ({e})"))?,
        }
    }
    Ok(())
}

/// The simulated stream the arguments describe, with its recording header.
pub fn simulated(
    tracker: &TrackerConfig,
    args: &SimulateArgs,
) -> Result<(RecordingHeader, SimStream), String> {
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 3600.0) {
        return Err(format!("--seconds {}: must be in (0, 3600]", args.seconds));
    }
    let screen_px = match &args.display {
        Some(d) => Some(
            config::load_display(d)
                .map_err(|e| e.to_string())?
                .resolution_px,
        ),
        None => None,
    };
    let script = |rate_hz: f64, frame: (f64, f64), units_per_degree: f64| match args.script {
        ScriptArg::Search => Ok(gaze_script(&Script {
            seconds: args.seconds,
            rate_hz,
            frame,
            units_per_degree,
            seed: args.seed,
        })),
        ScriptArg::Calibration => {
            let screen = screen_px
                .ok_or("--script calibration needs --display FILE (the screen of the targets)")?;
            let (cal, val) = args.plan.plans(screen)?;
            let stops =
                calibration_stops(&cal, &val, screen, frame, args.closed_target).map_err(|e| {
                    format!(
                        "--closed-target {}: there are {} targets",
                        e.index, e.targets
                    )
                })?;
            Ok::<_, String>(fixation_script(
                &stops,
                rate_hz,
                units_per_degree,
                0.03 * units_per_degree,
                args.seed,
            ))
        }
    };
    let (stream, rate) = match &tracker.driver {
        Driver::Iscan(c) => {
            let rate = args.rate.unwrap_or(60.0);
            // The seed's ISCAN covers about ±20° with 512 units: 12.8 units/deg.
            (
                simulate_iscan(c, &script(rate, c.frame, 12.8)?, args.seed),
                rate,
            )
        }
        Driver::Mouse(c) => {
            let rate = args.rate.unwrap_or(c.rate_hz);
            let truth = script(rate, (1280.0, 1024.0), c.pixels_per_degree)?;
            (simulate_mouse(c, &truth, 1.0, args.seed), rate)
        }
        Driver::TobiiHid(c) => {
            // The seed's Tobii ET-1750 ran at 50 Hz (Murphy 2007 §7.1).
            let rate = args.rate.unwrap_or(50.0);
            // 1° at 60 cm is 10.47 mm on the screen.
            let truth = script(rate, c.screen_um, 10_470.0)?;
            let layout = match args.hid_layout {
                HidLayoutArg::Reference => HidLayout::Reference,
                HidLayoutArg::Compact => HidLayout::Compact,
            };
            (
                simulate_hid(layout, &truth, c.screen_um, rate, args.seed),
                rate,
            )
        }
    };
    if !(rate.is_finite() && rate > 0.0 && rate <= 10_000.0) {
        return Err(format!("--rate {rate}: must be in (0, 10000] Hz"));
    }
    let header = RecordingHeader {
        tracker: tracker.clone(),
        display: None,
        note: match args.script {
            ScriptArg::Search => format!(
                "SYNTHESISED by gazecast simulate (tracker_hal::sim), seed {}, {} s at {} Hz: not captured from a real device",
                args.seed, args.seconds, rate
            ),
            ScriptArg::Calibration => format!(
                "SYNTHESISED by gazecast simulate (tracker_hal::sim), calibration script ({} + {} targets, settle {} ms, collect {} ms, closed target {:?}), seed {} at {} Hz: not captured from a real device",
                args.plan.points,
                args.plan.validation_points,
                args.plan.settle_ms,
                args.plan.collect_ms,
                args.closed_target,
                args.seed,
                rate
            ),
        },
    };
    Ok((header, stream))
}

/// Runs `gazecast simulate`.
pub fn simulate(args: &SimulateArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut outputs = vec![("--out", args.out.as_path())];
    outputs.extend(args.csv.as_deref().map(|p| ("--csv", p)));
    outputs.extend(args.hid_log.as_deref().map(|p| ("--hid-log", p)));
    let mut inputs = vec![("--tracker", args.tracker.as_path())];
    inputs.extend(args.display.as_deref().map(|p| ("--display", p)));
    crate::output::refuse_inputs(&outputs, &inputs)?;
    let tracker = load_tracker(&args.tracker)?;
    let (header, stream) = simulated(&tracker, args)?;
    write_recording(&args.out, &header, &stream.chunks).map_err(|e| e.to_string())?;
    if let Some(path) = &args.hid_log {
        if !matches!(tracker.driver, Driver::TobiiHid(_)) {
            return Err("--hid-log: only for a TobiiHid tracker file".into());
        }
        let mut text = format!("# {}\n", header.note);
        for c in stream
            .chunks
            .iter()
            .filter(|c| c.kind == ChunkKind::DeviceToHost)
        {
            text.push_str(&String::from_utf8_lossy(&c.payload));
        }
        crate::output::write_whole(path, text.as_bytes())
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    }
    if let Some(csv) = &args.csv {
        let mut w = SampleCsv::create(csv)?;
        for s in &stream.expected {
            w.row(s, &|p| Some(p))?;
        }
        w.finish()?;
    }
    writeln!(
        out,
        "{}: {} records in {} chunks",
        args.out.display(),
        stream.expected.len(),
        stream.chunks.len()
    )
    .map_err(|e| e.to_string())
}
