//! `gazecast view`: the live gaze-contingent window ([`crate::live`]) with
//! the gaze from a tracker, a replayed recording or the mouse.

use std::io::Write;
use std::path::PathBuf;

use pipeline::BackendChoice;

use crate::args::Overlay;
use crate::live::{self, LiveOptions};

/// `gazecast view`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ViewArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Tracker file (RON). Not needed with --replay (the recording's header
    /// carries it, and is what the replay decodes with); given with
    /// --replay, it must agree with that header, or the viewer refuses to
    /// start and lists the differences.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// Play a tracker-hal recording at its original pacing as the gaze.
    #[arg(long, value_name = "FILE.gzrec")]
    pub replay: Option<PathBuf>,
    /// Map raw gaze with this calibration (from `gazecast calibrate`)
    /// instead of the tracker file's mapping.
    #[arg(long, value_name = "FILE.ron")]
    pub calibration: Option<PathBuf>,
    /// Record the session losslessly (every byte from and to the tracker,
    /// with arrival times) for `gazecast replay` / `view --replay`.
    #[arg(long, value_name = "FILE.gzrec")]
    pub record: Option<PathBuf>,
    /// Exit after this many frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Write the last frame (with overlays) here on exit.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Force the POR box on.
    #[arg(long, value_enum, value_name = "por")]
    pub overlay: Option<Overlay>,
    /// Where to render: `cpu`, `gpu`, or `auto` (the GPU when there is one).
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    /// The rendering method (`foveated` is an alias of `hybrid`).
    #[arg(long, value_parser = crate::args::method_parser(), default_value = "hybrid")]
    pub method: pipeline::Method,
    /// Model-based methods' options (budget, no gaze).
    #[command(flatten)]
    pub model_based: crate::args::ModelBasedArgs,
    /// A participant's thresholds file instead of the default CSF model.
    #[command(flatten)]
    pub thresholds: crate::args::ThresholdsArg,
    /// Hybrid method: build each ray mask dense enough for any gaze within
    /// DEG degrees of its own, and keep it (and, on the CPU, its frame)
    /// while the gaze stays within DEG: a fixation's jitter then costs no
    /// new frame. 0: a new mask for every new gaze sample.
    #[arg(long, value_name = "DEG", default_value_t = crate::args::LIVE_GAZE_TOLERANCE_DEG,
          value_parser = crate::args::parse_gaze_tolerance)]
    pub gaze_tolerance: f64,
    /// Hybrid and image methods: build the ray masks for the eye distance
    /// the tracker measures (HID trackers report eye positions; others keep
    /// the display file's), or always for the display file's (`fixed`).
    /// The picture itself is drawn for the display file's eye either way.
    #[arg(long, value_enum, default_value = "measured")]
    pub eye_distance: crate::live::EyeDistance,
    /// Fullscreen on the current monitor.
    #[arg(long)]
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based; an out-of-range index lists them).
    #[arg(long, value_name = "INDEX")]
    pub monitor: Option<usize>,
    /// How the window presents: `auto` (the lowest latency without
    /// tearing: Mailbox where the adapter offers it, else FIFO), `fifo`
    /// (vsync), `mailbox`, `immediate` (no wait; it tears). The log says
    /// which was used and what the adapter offers.
    #[arg(long, value_enum, default_value = "auto")]
    pub present_mode: crate::screen::PresentChoice,
    /// Print the passes the scene's effects make the pipeline run, and exit.
    #[arg(long)]
    pub explain: bool,
    /// Lab Streaming Layer output.
    #[command(flatten)]
    pub lsl: crate::args::LslArgs,
}

impl ViewArgs {
    /// The live session these arguments ask for.
    pub fn live_options(&self) -> LiveOptions {
        LiveOptions {
            scene: self.scene.clone(),
            display: self.display.clone(),
            tracker: self.tracker.clone(),
            replay: self.replay.clone(),
            calibration: self.calibration.clone(),
            record: self.record.clone(),
            frames: self.frames,
            screenshot: self.screenshot.clone(),
            por_overlay: self.overlay == Some(Overlay::Por),
            backend: self.backend,
            method: self.method,
            model_based: self.model_based.into(),
            thresholds: self.thresholds.thresholds.clone(),
            gaze_tolerance_deg: self.gaze_tolerance,
            eye_distance: self.eye_distance,
            fullscreen: self.fullscreen,
            monitor: self.monitor,
            present_mode: self.present_mode,
            lsl: self.lsl.options("view", String::new(), false),
        }
    }
}

/// `--tracker` with `--replay`: the replay decodes with the recording's
/// header, so a tracker file that says otherwise would be silently ignored.
/// Agreeing (as `gazecast replay` compares them) it is accepted; otherwise
/// an error lists the differences.
fn check_tracker_against_replay(args: &ViewArgs) -> Result<(), String> {
    let (Some(tracker_path), Some(replay)) = (&args.tracker, &args.replay) else {
        return Ok(());
    };
    let tracker = crate::config::load_tracker(tracker_path).map_err(|e| e.to_string())?;
    let rec = tracker_hal::Recording::read(replay).map_err(|e| e.to_string())?;
    let diffs =
        tracker_hal::config::differences::tracker_differences(&rec.header.tracker, &tracker);
    if diffs.is_empty() {
        return Ok(());
    }
    let list: String = diffs.iter().map(|d| format!("\n  {d}")).collect();
    Err(format!(
        "--tracker {} disagrees with the tracker in the header of --replay {}, which the replay decodes with:{list}\n\
         leave out --tracker (or decode with another tracker file: gazecast replay --tracker-overrides-header)",
        tracker_path.display(),
        replay.display()
    ))
}

/// Runs `gazecast view`.
pub fn run(args: &ViewArgs, out: &mut dyn Write) -> Result<(), String> {
    args.lsl.check()?;
    args.model_based.check(args.method)?;
    let mut outputs = Vec::new();
    outputs.extend(args.record.as_deref().map(|p| ("--record", p)));
    outputs.extend(args.screenshot.as_deref().map(|p| ("--screenshot", p)));
    crate::output::Inputs::new()
        .scene("--scene", &args.scene)
        .file("--display", &args.display)
        .maybe("--tracker", args.tracker.as_deref())
        .maybe("--replay", args.replay.as_deref())
        .maybe("--calibration", args.calibration.as_deref())
        .refuse(&outputs)?;
    check_tracker_against_replay(args)?;
    let options = args.live_options();
    if args.explain {
        return live::explain(&options, out);
    }
    live::run(&options, out).map_err(|e| e.to_string())
}
