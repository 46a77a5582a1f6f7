//! The `gazecast` binary's library: command-line wiring, configuration
//! loading and pictures. It owns no maths (see `foveation`) and, later, the
//! threads and the window.

pub mod config;
pub mod mask_cmd;
pub mod plots;

use clap::{Parser, Subcommand};

/// gazecast: a gaze-contingent ray caster for vision-science labs.
#[derive(Debug, Parser)]
#[command(name = "gazecast", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Build the CSF ray mask for one gaze point; report rays against the
    /// Nyquist bound; optionally write the rays (CSV) and pictures (PNG).
    Mask(mask_cmd::MaskArgs),
}

/// Runs a parsed command line, writing normal output to `out`.
pub fn run(cli: Cli, out: &mut dyn std::io::Write) -> Result<(), String> {
    match cli.command {
        Command::Mask(args) => mask_cmd::run(&args, out),
    }
}
