//! The `gazecast` binary's library: command-line wiring, configuration
//! loading, pictures, windows (viewer, calibration, experiment runs) and
//! the threads that feed them.
//!
//! It owns no maths or policy: the foveation
//! and ray-casting maths are `foveation`, `raycast`, `lod` and `pipeline`
//! (the frame); the attention model is `attention`; gaze devices, the
//! tracker supervisor (reconnects, silences, fault counts), recording,
//! replay, the device simulator and its presets, and the comparison of
//! tracker configurations are `tracker_hal`; experiment designs, sessions
//! and every statistic the reports quote (`experiment::stats`) are
//! `experiment`. Here they are only chosen from the command line and
//! wired together.

#![warn(missing_docs)]

pub mod args;
pub mod bench;
pub mod calibrate_cmd;
pub mod config;
pub mod demo_cmd;
pub mod experiment_cmd;
pub mod gaze_feed;
pub mod interrupt;
pub mod live;
pub mod lsl_out;
pub mod mask_cmd;
pub mod output;
pub mod picture;
pub mod plots;
pub mod render_cmd;
pub mod runner;
pub mod screen;
pub mod thresholds_cmd;
pub mod tracker_cmd;
pub mod view_cmd;

use clap::{Parser, Subcommand};

/// gazecast: a gaze-contingent ray caster for vision-science labs.
#[derive(Debug, Parser)]
#[command(name = "gazecast", version, about)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `gazecast`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Build the CSF ray mask for one gaze point; report rays against the
    /// Nyquist bound; optionally write the rays (CSV) and pictures (PNG).
    Mask(mask_cmd::MaskArgs),
    /// Render one frame of a scene, foveated or at full resolution, to a PNG.
    Render(render_cmd::RenderArgs),
    /// Decode a recording or raw byte dump through the tracker's driver and
    /// write one CSV row per record; a summary line goes to stderr.
    Replay(tracker_cmd::ReplayArgs),
    /// Record a serial tracker session losslessly (raw bytes with arrival times).
    Record(tracker_cmd::RecordArgs),
    /// List the serial ports, USB eye trackers and HID eye-tracker interfaces.
    Devices,
    /// Write a synthesised device stream (and the samples it must decode to).
    Simulate(tracker_cmd::SimulateArgs),
    /// Measure what accuracy costs in time (`accuracy`) and how the cost
    /// scales with triangles and pixels (`scaling`).
    Bench(bench::BenchArgs),
    /// The search task: in a window with the mouse as the gaze when there is
    /// a display; otherwise along a built-in scanpath, rendered foveated to
    /// an animated PNG and a contact sheet.
    Demo(demo_cmd::DemoArgs),
    /// The live gaze-contingent window: a tracker (or a replayed recording,
    /// or the mouse) drives the point of regard.
    View(view_cmd::ViewArgs),
    /// The calibration screen: targets in order, a fit, validation in
    /// degrees (arrows per point), redo of bad points, saved as RON.
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Experiments: run a design's session in a window (`run`), list a
    /// participant's trials (`plan`), analyse session folders (`analyze`),
    /// export them to BIDS (`export-bids`).
    Experiment(experiment_cmd::ExperimentArgs),
    /// Contrast thresholds: measure them over frequency × eccentricity with
    /// interleaved QUEST staircases and fit the Geisler–Perry CSF
    /// (`measure`: in a window with a tracker and gaze-contingent fixation
    /// control, or headless with a simulated observer).
    Thresholds(thresholds_cmd::ThresholdsArgs),
}

/// Runs a parsed command line, writing normal output to `out`.
pub fn run(cli: Cli, out: &mut dyn std::io::Write) -> Result<(), String> {
    match cli.command {
        Command::Mask(args) => mask_cmd::run(&args, out),
        Command::Render(args) => render_cmd::run(&args, out),
        Command::Replay(args) => tracker_cmd::replay(&args, &mut std::io::stderr()),
        Command::Record(args) => tracker_cmd::record(&args, out),
        Command::Devices => tracker_cmd::devices(out),
        Command::Simulate(args) => tracker_cmd::simulate(&args, out),
        Command::Bench(args) => bench::run(&args, out),
        Command::Demo(args) => demo_cmd::run(&args, out),
        Command::View(args) => view_cmd::run(&args, out),
        Command::Calibrate(args) => calibrate_cmd::run(&args, out),
        Command::Experiment(args) => experiment_cmd::run(&args, out),
        Command::Thresholds(args) => thresholds_cmd::run(&args, out),
    }
}
