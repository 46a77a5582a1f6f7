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
    /// Tracker file (RON): driver and mapping used to decode. Needed for
    /// --format raw-bytes and hid-log. A recording carries its tracker in
    /// its header, which is used without --tracker; a --tracker that
    /// disagrees with it is an error listing the differences (see
    /// --tracker-overrides-header).
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// Decode a recording with --tracker even where it disagrees with the
    /// recording's header (the differences are printed as a warning).
    #[arg(long, requires = "tracker")]
    pub tracker_overrides_header: bool,
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
    /// Deliver the data at its original pacing instead of as fast as
    /// possible. The CSV is then written through, row by row as each is
    /// due (a reader can follow it; a killed replay keeps the rows played),
    /// and a silent gap longer than 5 s is skipped with a warning.
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
    /// Stop after this many seconds (a positive number; default: until
    /// Ctrl-C or SIGTERM, which stop the device and close the recording
    /// cleanly).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
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
    /// Microsoft's virtual eye-gaze device (DMF) as shipped now: named
    /// collections with units.
    Named,
    /// Its earlier descriptor: unnamed logical collections, no units,
    /// positions with Logical Minimum 0x80000000, Mode Request 0..1.
    Unnamed,
    /// Named collections without units, 32-bit positions from 0x80000000
    /// and a 64-bit timestamp after them.
    Wide,
}

/// The sample CSV of `replay` and `simulate`, with errors naming the file.
/// Normally written whole or not at all (`crate::output`): an error part-way
/// leaves any existing file as it was. `replay --realtime` writes it
/// through instead ([`SampleCsv::create_through`]).
struct SampleCsv<'a> {
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
    fn create(path: &'a Path) -> Result<Self, String> {
        let w = crate::output::AtomicFile::create(path).map_err(|e| Self::fail(path, e))?;
        Self::start(path, CsvSink::Atomic(w))
    }

    /// Written straight to `path`, one unbuffered write per row: what is
    /// played is on disk, whatever happens next.
    fn create_through(path: &'a Path) -> Result<Self, String> {
        let w = std::fs::File::create(path).map_err(|e| Self::fail(path, e))?;
        Self::start(path, CsvSink::Through(w))
    }

    fn start(path: &'a Path, w: CsvSink) -> Result<Self, String> {
        let mut csv = Self { path, w };
        writeln!(csv.w, "{CSV_HEADER}").map_err(|e| Self::fail(path, e))?;
        Ok(csv)
    }

    fn row(
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

    fn finish(self) -> Result<(), String> {
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

fn load_tracker(path: &Path) -> Result<TrackerConfig, String> {
    config::load_tracker(path).map_err(|e| e.to_string())
}

/// Driver settings that say how a live device is reached or emulated, not
/// what recorded bytes mean: a replay does not compare them with the
/// recording's header (the port it was on; the mouse emulation's realism,
/// already in the recorded stream; which USB device, and its read timeout).
const LIVE_ONLY: &[&str] = &[
    "port",
    "jitter_rms_deg",
    "saccades",
    "saccade_threshold_deg",
    "latency_ms",
    "seed",
    "vendor_id",
    "product_id",
    "timeout_ms",
];

/// Where `given` disagrees with a recording's `header` tracker, one line a
/// field: `driver.baud: header 115200, --tracker 19200` (fields named as in
/// the tracker file; [`LIVE_ONLY`] settings are not compared). Empty when
/// they agree.
pub fn tracker_differences(header: &TrackerConfig, given: &TrackerConfig) -> Vec<String> {
    tracker_differences_except(header, given, LIVE_ONLY)
}

/// How a device is reached (its port, which USB device, a read timeout):
/// what may change between the sittings of one session.
pub const CONNECTION_ONLY: &[&str] = &["port", "vendor_id", "product_id", "timeout_ms"];

/// [`tracker_differences`], leaving out the driver settings in `ignore`.
pub fn tracker_differences_except(
    header: &TrackerConfig,
    given: &TrackerConfig,
    ignore: &[&str],
) -> Vec<String> {
    if header.driver_name() != given.driver_name() {
        return vec![format!(
            "driver: header {}, --tracker {}",
            header.driver_name(),
            given.driver_name()
        )];
    }
    let mut out = Vec::new();
    match (serde_json::to_value(header), serde_json::to_value(given)) {
        (Ok(a), Ok(b)) => json_differences("", &a, &b, ignore, &mut out),
        _ if header != given => out.push("the tracker configuration differs".into()),
        _ => {}
    }
    out
}

fn json_differences(
    path: &str,
    a: &serde_json::Value,
    b: &serde_json::Value,
    ignore: &[&str],
    out: &mut Vec<String>,
) {
    use serde_json::Value;
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            // An enum variant (`Iscan(...)`, `Frame(...)`): the same variant
            // on both sides is compared field by field under the same name.
            if let (Some((kx, vx)), Some((ky, vy))) = (variant(x), variant(y)) {
                if kx == ky {
                    return json_differences(path, vx, vy, ignore, out);
                }
            }
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                if path == "driver" && ignore.contains(&k.as_str()) {
                    continue;
                }
                json_differences(
                    &join(k),
                    x.get(k).unwrap_or(&Value::Null),
                    y.get(k).unwrap_or(&Value::Null),
                    ignore,
                    out,
                );
            }
        }
        _ if a != b => out.push(format!(
            "{}: header {}, --tracker {}",
            if path.is_empty() { "tracker" } else { path },
            show_json(a),
            show_json(b)
        )),
        _ => {}
    }
}

/// The variant and its value when `m` is an enum value (`{"Iscan": ...}`).
fn variant(
    m: &serde_json::Map<String, serde_json::Value>,
) -> Option<(&String, &serde_json::Value)> {
    if m.len() != 1 {
        return None;
    }
    m.iter()
        .next()
        .filter(|(k, _)| k.starts_with(|c: char| c.is_ascii_uppercase()))
}

/// A value as the tracker file spells it, near enough: unit variants bare,
/// `None` for a missing option.
fn show_json(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => "None".into(),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The tracker a recording is decoded with: its header's, or a `--tracker`
/// that agrees with it (or overrides it, with a warning).
fn recording_tracker(
    rec: &Recording,
    input: &Path,
    given: Option<(&Path, TrackerConfig)>,
    overrides: bool,
    err: &mut dyn Write,
) -> Result<TrackerConfig, String> {
    let header = &rec.header.tracker;
    header.validate().map_err(|(field, msg)| {
        format!(
            "{}: the tracker in its header is invalid: {field}: {msg}",
            input.display()
        )
    })?;
    let Some((path, tracker)) = given else {
        return Ok(header.clone());
    };
    let diffs = tracker_differences(header, &tracker);
    if diffs.is_empty() {
        return Ok(header.clone());
    }
    let list: String = diffs.iter().map(|d| format!("\n  {d}")).collect();
    if overrides {
        let _ = writeln!(
            err,
            "warning: --tracker {} disagrees with the tracker in the header of {} (decoding with --tracker, as --tracker-overrides-header asks):{list}",
            path.display(),
            input.display()
        );
        return Ok(tracker);
    }
    Err(format!(
        "--tracker {} disagrees with the tracker in the header of {}:{list}\n\
         leave out --tracker to decode with the header's tracker, or add \
         --tracker-overrides-header to decode with {} anyway",
        path.display(),
        input.display(),
        path.display()
    ))
}

/// The longest pacing wait of `replay --realtime`: a longer silent gap in
/// the data is skipped, with a warning.
const MAX_PACING_SLEEP: Duration = Duration::from_secs(5);

/// Real-time pacing of `replay --realtime`: each sample is released at its
/// recorded host time's offset from the first, less the gaps skipped.
struct Pacer {
    /// Wall time and host time of the first sample.
    start: Option<(Instant, u64)>,
    /// Recorded time skipped so far (gaps beyond [`MAX_PACING_SLEEP`]).
    skipped_us: u64,
}

impl Pacer {
    fn new() -> Self {
        Self {
            start: None,
            skipped_us: 0,
        }
    }

    /// Waits until a sample recorded at `host_us` is due (never more than
    /// [`MAX_PACING_SLEEP`]); false when interrupted while waiting.
    fn wait(&mut self, host_us: u64, err: &mut dyn Write) -> bool {
        let (start, first) = *self.start.get_or_insert((Instant::now(), host_us));
        let offset = host_us
            .saturating_sub(first)
            .saturating_sub(self.skipped_us);
        let mut due = start + Duration::from_micros(offset);
        let now = Instant::now();
        if due > now + MAX_PACING_SLEEP {
            let gap = due - now;
            let _ = writeln!(
                err,
                "warning: gap of {:.0} s skipped (replay --realtime waits at most {} s)",
                gap.as_secs_f64(),
                MAX_PACING_SLEEP.as_secs()
            );
            self.skipped_us = self
                .skipped_us
                .saturating_add(u64::try_from(gap.as_micros()).unwrap_or(u64::MAX));
            due = now;
        }
        loop {
            if crate::gaze_feed::interrupted() {
                return false;
            }
            let now = Instant::now();
            if due <= now {
                return true;
            }
            std::thread::sleep((due - now).min(Duration::from_millis(50)));
        }
    }
}

/// Runs `gazecast replay`.
pub fn replay(args: &ReplayArgs, err: &mut dyn Write) -> Result<(), String> {
    let mut inputs = vec![("--input", args.input.as_path())];
    inputs.extend(args.tracker.as_deref().map(|p| ("--tracker", p)));
    inputs.extend(args.calibration.as_deref().map(|p| ("--calibration", p)));
    crate::output::refuse_inputs(&[("--csv", &args.csv)], &inputs)?;
    let given = match &args.tracker {
        Some(path) => Some((path.as_path(), load_tracker(path)?)),
        None => None,
    };
    // Paced here, sample by sample (see `Pacer`), not by the transport.
    let pacing = Pacing::AsFastAsPossible;
    let (tracker, transport) = match args.format {
        InputFormat::Recording => {
            let rec = Recording::read(&args.input).map_err(|e| e.to_string())?;
            // Damage, interruption, unknown chunks, data after End and lost
            // chunks: each said once; what can be read is replayed.
            for w in rec.warnings() {
                let _ = writeln!(err, "warning: {}: {w}", args.input.display());
            }
            let tracker =
                recording_tracker(&rec, &args.input, given, args.tracker_overrides_header, err)?;
            (tracker, ReplayTransport::from_recording(&rec, pacing))
        }
        InputFormat::RawBytes | InputFormat::HidLog => {
            let format = if args.format == InputFormat::HidLog {
                "hid-log"
            } else {
                "raw-bytes"
            };
            let Some((path, tracker)) = given else {
                return Err(format!(
                    "--format {format} needs --tracker FILE.ron: the bytes carry no tracker configuration (a .gzrec recording does)"
                ));
            };
            if args.tracker_overrides_header {
                return Err(format!(
                    "--tracker-overrides-header: --format {format} has no header to override (only a recording has one)"
                ));
            }
            if (args.format == InputFormat::HidLog) != matches!(tracker.driver, Driver::TobiiHid(_))
            {
                return Err(format!(
                    "--format hid-log goes with a TobiiHid tracker file; {} has a {} driver",
                    path.display(),
                    tracker.driver_name()
                ));
            }
            let bytes = input_file::read(&args.input, input_file::RECORDING)
                .map_err(|e| format!("{}: cannot read: {e}", args.input.display()))?;
            let baud = match &tracker.driver {
                Driver::Iscan(c) => c.baud,
                _ => 115_200,
            };
            let transport = ReplayTransport::from_raw_bytes(&bytes, baud, 16, pacing);
            (tracker, transport)
        }
    };
    let clock = transport.clock();
    let mut driver = StreamDriver::new(transport, tracker.decoder(), Box::new(clock));
    // Every input is read and checked before the output is created.
    let calibration = match &args.calibration {
        Some(path) => Some(config::load_calibration(path).map_err(|e| e.to_string())?),
        None => None,
    };
    let mut pacer = args.realtime.then(|| {
        crate::gaze_feed::catch_interrupts();
        Pacer::new()
    });
    let mut out = if args.realtime {
        SampleCsv::create_through(&args.csv)?
    } else {
        SampleCsv::create(&args.csv)?
    };
    let mapping = tracker.mapping.clone();
    let mut interrupted = false;
    driver.start().map_err(|e| e.to_string())?;
    while let Some(sample) = driver.next_sample().map_err(|e| e.to_string())? {
        if let Some(p) = &mut pacer {
            if !p.wait(sample.host_time_us, err) {
                interrupted = true;
                break;
            }
        }
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
    .map_err(|e| e.to_string())?;
    if interrupted {
        writeln!(
            err,
            "interrupted (Ctrl-C or SIGTERM): {} holds the rows played so far",
            args.csv.display()
        )
        .map_err(|e| e.to_string())?;
    }
    Ok(())
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
    crate::gaze_feed::catch_interrupts();
    let started = driver.start().map_err(|e| e.to_string());
    let start = Instant::now();
    let mut timeouts = 0u64;
    let mut interrupted = false;
    let outcome = loop {
        if let Err(e) = &started {
            break Err(e.clone());
        }
        if crate::gaze_feed::interrupted() {
            interrupted = true;
            break Ok(());
        }
        // A write error (a full disk) ends the recording at once: the
        // device is stopped and the file closed with what it holds.
        if let Some(e) = recorder.failure() {
            break Err(crate::gaze_feed::recording_stopped(&e));
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
            Err(_) if crate::gaze_feed::interrupted() => {
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
                    if crate::gaze_feed::interrupted()
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

/// Why `simulate` refuses an LSL tracker file.
const NO_LSL_SIM: &str = "gazecast simulate has no simulated LSL stream: record one from an LSL outlet (gazecast record --tracker lsl.ron; tests/lsl/outlet_gaze.py is a pylsl outlet)";

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
    let rate = args.rate.unwrap_or(match &tracker.driver {
        Driver::Iscan(c) => c.rate_hz,
        Driver::Mouse(c) => c.rate_hz,
        Driver::Attention(c) => c.rate_hz,
        // The seed's Tobii ET-1750 ran at 50 Hz (Murphy 2007 §7.1).
        Driver::TobiiHid(_) => 50.0,
        Driver::Lsl(_) => return Err(NO_LSL_SIM.into()),
    });
    // Checked before anything is generated: the stream's size follows the
    // rate.
    if !(rate.is_finite() && rate > 0.0 && rate <= 10_000.0) {
        return Err(format!("--rate {rate}: must be in (0, 10000] Hz"));
    }
    // A simulated ISCAN sends at the simulated rate, and its recording's
    // tracker says so (the driver's record-counting clock runs at it).
    let mut tracker = tracker.clone();
    if let Driver::Iscan(c) = &mut tracker.driver {
        c.rate_hz = rate;
        c.validate()
            .map_err(|(field, e)| format!("--rate: the ISCAN's {field}: {e}"))?;
    }
    let tracker = &tracker;
    let stream = match &tracker.driver {
        Driver::Iscan(c) => {
            // The seed's ISCAN covers about ±20° with 512 units: 12.8 units/deg.
            simulate_iscan(c, &script(rate, c.frame, 12.8)?, args.seed)
        }
        Driver::Mouse(c) => {
            let truth = script(rate, (1280.0, 1024.0), c.pixels_per_degree)?;
            simulate_mouse(c, &truth, 1.0, args.seed)
        }
        // The attention source's stream is the mouse emulator's.
        Driver::Attention(a) => {
            let c = a.stream();
            let truth = script(rate, (1280.0, 1024.0), c.pixels_per_degree)?;
            simulate_mouse(&c, &truth, 1.0, args.seed)
        }
        Driver::TobiiHid(c) => {
            // 1° at 60 cm is 10.47 mm on the screen.
            let truth = script(rate, c.screen_um, 10_470.0)?;
            let layout = match args.hid_layout {
                HidLayoutArg::Reference => HidLayout::Reference,
                HidLayoutArg::Compact => HidLayout::Compact,
                HidLayoutArg::Named => HidLayout::Named,
                HidLayoutArg::Unnamed => HidLayout::Unnamed,
                HidLayoutArg::Wide => HidLayout::Wide,
            };
            simulate_hid(layout, &truth, c.screen_um, rate, args.seed)
        }
        Driver::Lsl(_) => return Err(NO_LSL_SIM.into()),
    };
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
