//! `gazecast simulate`: a synthesised device stream (tracker-hal's
//! simulator and its presets, [`tracker_hal::sim::preset`]) written as a
//! recording, with the samples it must decode to.

use std::io::Write;
use std::path::PathBuf;

use tracker_hal::hid::sim::HidLayout;
use tracker_hal::recording::{write_recording, ChunkKind, RecordingHeader};
use tracker_hal::sim::preset::{self, Preset, FIXATION_JITTER_DEG};
use tracker_hal::sim::{calibration_stops, fixation_script, gaze_script, Script, SimStream};
use tracker_hal::{Driver, TrackerConfig};

use super::load_tracker;
use super::sample_csv::SampleCsv;
use crate::args::PlanArgs;
use crate::config;

/// `gazecast simulate`'s arguments.
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
    /// Length of the simulated session, seconds (`--script search`).
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub seconds: f64,
    /// Sampling rate (default: 60 Hz for ISCAN, the tracker file's rate for the mouse).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// Seed of the simulated behaviour (same seed, same stream).
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
    /// The calibration plan (`--script calibration`).
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
    /// Fixations anywhere, saccades, blinks, a lost eye.
    Search,
    /// Follows `gazecast calibrate`'s targets, then its validation targets.
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
                FIXATION_JITTER_DEG * units_per_degree,
                args.seed,
            ))
        }
    };
    let device = Preset::of(&tracker.driver).ok_or(NO_LSL_SIM)?;
    let rate = args.rate.unwrap_or(device.rate_hz);
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
    let truth = script(rate, device.frame, device.units_per_degree)?;
    let layout = match args.hid_layout {
        HidLayoutArg::Reference => HidLayout::Reference,
        HidLayoutArg::Compact => HidLayout::Compact,
        HidLayoutArg::Named => HidLayout::Named,
        HidLayoutArg::Unnamed => HidLayout::Unnamed,
        HidLayoutArg::Wide => HidLayout::Wide,
    };
    let stream =
        preset::encode(&tracker.driver, &truth, rate, layout, args.seed).ok_or(NO_LSL_SIM)?;
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
