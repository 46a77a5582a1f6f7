//! `gazecast replay`: a recording or byte dump decoded through the
//! tracker's driver into a sample CSV, as fast as possible or at its
//! original pacing.

use std::io::Write;
use std::path::{Path, PathBuf};

use tracker_hal::config::differences::tracker_differences;
use tracker_hal::{
    Driver, GazeSource, Pacing, Recording, ReplayTransport, StreamDriver, TrackerConfig,
};

use super::load_tracker;
use super::pacer::Pacer;
use super::sample_csv::SampleCsv;
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

/// `gazecast replay`'s arguments.
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
    /// How `--input` is encoded: a recording, raw device bytes or a HID report log.
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
        crate::interrupt::catch_interrupts();
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
