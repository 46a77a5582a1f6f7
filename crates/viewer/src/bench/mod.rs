//! `gazecast bench`: what accuracy costs in time.
//!
//! - `accuracy`: sweeps the method's knobs (mask layout, CSF contrast,
//!   maximum ray spacing, refinement triggers, acceleration structure), and
//!   for every configuration and gaze measures the frame time and the error
//!   against the full-resolution frame of the same gaze
//!   ([`foveation::quality`]). Writes `results.csv`, `pareto.png`, `report.md`.
//! - `attention`: Lee's attention model against recorded gaze (A1–A3 and
//!   the feature-group ablations of Lee's Table 3.2).
//! - `lod`: the model-based methods along a synthetic scanpath (Murphy &
//!   Duchowski Table 2's shape; Luebke & Hallen Fig. 8's set-up). Writes
//!   `lod.md`, `lod.csv`, `lod.json`.
//! - `scaling`: frame time of full and foveated rendering against triangle
//!   count and against resolution (log–log), to show whether the cost
//!   follows the eye's ray budget. Writes `scaling.csv`,
//!   `scaling-triangles.png`, `scaling-resolution.png`, `scaling.md`.
//!
//! Modules: [`configs`] (what the accuracy sweep tries), [`measure`] (a
//! timed frame), [`summary`] (per configuration, the Pareto front),
//! [`accuracy`] and [`scaling`] (the two sweeps), [`report`] (the files).

pub mod accuracy;
pub mod attention;
pub mod configs;
pub mod lod;
pub mod measure;
pub mod report;
pub mod scaling;
pub mod stages;
pub mod summary;
pub mod torus;
pub mod ulod;

use std::io::Write;
use std::path::PathBuf;

use pipeline::BackendChoice;

/// `gazecast bench`: its subcommand.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// The benchmark to run.
    #[command(subcommand)]
    pub command: BenchCommand,
}

/// `bench accuracy --quick`'s help, with the sweep's true sizes.
fn quick_help() -> String {
    format!(
        "Fewer configurations ({} of {}) and two gazes unless --gazes is given",
        configs::configurations(true).len(),
        configs::configurations(false).len()
    )
}

/// The benchmarks of `gazecast bench`.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum BenchCommand {
    /// Sweep layout, contrast, maximum spacing, refinement and acceleration
    /// of the hybrid method, contrast and spacing of image-based foveation,
    /// and the model-based methods; time each configuration and measure its error against
    /// full resolution.
    Accuracy(AccuracyArgs),
    /// Frame time of full and foveated rendering against triangle count and
    /// resolution (log–log plots).
    Scaling(ScalingArgs),
    /// Per-stage time of a foveated CPU frame next to a full frame.
    Stages(stages::StagesArgs),
    /// Lee's attention model against recorded gaze: A1/A2/A3 in the eight
    /// feature-group combinations of Lee's Table 3.2.
    Attention(attention::AttentionArgs),
    /// Attention-guided level of detail (Lee ch. 7): frame time against
    /// visible objects for no LOD and ULOD2–ULOD5, and the cost model.
    Ulod(ulod::UlodArgs),
    /// The model-based methods along a synthetic scanpath: faces min/max/
    /// average and frame time per method (Murphy & Duchowski Table 2), and
    /// Luebke & Hallen Fig. 8's gaze 29° from the object.
    Lod(lod::LodArgs),
}

/// Most gaze positions `bench accuracy` takes: every gaze costs a
/// full-resolution reference frame kept in memory (about 6 MB at
/// 1280×1024) and one frame per configuration.
pub const MAX_GAZES: usize = 10_000;
/// Most timed repeats per point.
pub const MAX_REPEATS: u32 = 1000;

/// `gazecast bench accuracy`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct AccuracyArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Output folder (created): results.csv, pareto.png, report.md.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Gaze positions per configuration (1 to 10000): the centre, the four
    /// corners, then seeded uniform positions on the screen.
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_GAZES as u64))]
    pub gazes: usize,
    /// Timed repeats per configuration and gaze (1 to 1000, after one
    /// warm-up); the median is reported. Default 3, or 1 with --quick.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_REPEATS)))]
    pub repeats: Option<u32>,
    /// Seed of the random gaze positions.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The sweep runs on the CPU backend (`gpu` is refused; `auto` = CPU).
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    /// Fewer configurations and two gazes unless --gazes is given (the
    /// counts, which registered method modules change, in `quick_help`).
    #[arg(long, help = quick_help())]
    pub quick: bool,
    /// Add `simplify` under a triangle budget of N (Luebke & Hallen's
    /// best-effort mode; 1 to 10^9); repeat for several budgets.
    #[arg(long, value_name = "TRIANGLES", value_parser = crate::args::parse_budget)]
    pub budget: Vec<usize>,
    /// A participant's thresholds file instead of the default CSF model.
    #[command(flatten)]
    pub thresholds: crate::args::ThresholdsArg,
}

/// `gazecast bench scaling`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ScalingArgs {
    /// Output folder (created).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Timed repeats per point (1 to 1000, after one warm-up). Default 3, or
    /// 1 with --quick.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_REPEATS)))]
    pub repeats: Option<u32>,
    /// As for `accuracy`: the CPU backend.
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    /// 10^4–10^5 triangles and 640×360–1280×720 only.
    #[arg(long)]
    pub quick: bool,
}

/// Runs `gazecast bench …`.
pub fn run(args: &BenchArgs, out: &mut dyn Write) -> Result<(), String> {
    let backend = match &args.command {
        BenchCommand::Accuracy(a) => a.backend,
        BenchCommand::Scaling(a) => a.backend,
        BenchCommand::Stages(_)
        | BenchCommand::Lod(_)
        | BenchCommand::Attention(_)
        | BenchCommand::Ulod(_) => BackendChoice::Cpu,
    };
    if backend == BackendChoice::Gpu {
        return Err(
            "--backend gpu: the bench times the CPU backend only (the accuracy sweep includes \
             the seed's uniform grid, which only the CPU backend has, and every configuration \
             is timed on the one backend so that the figures compare); use --backend cpu or auto"
                .into(),
        );
    }
    match &args.command {
        BenchCommand::Accuracy(a) => accuracy::run(a, out),
        BenchCommand::Scaling(a) => scaling::run(a, out),
        BenchCommand::Stages(a) => stages::run(a, out),
        BenchCommand::Attention(a) => attention::run(a, out),
        BenchCommand::Ulod(a) => ulod::run(a, out),
        BenchCommand::Lod(a) => lod::run(a, out),
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::configs::configurations;

    /// `--quick`'s help states the sweep's true sizes.
    #[test]
    fn the_quick_help_counts_the_configurations() {
        let cli = crate::Cli::command();
        let accuracy = cli
            .find_subcommand("bench")
            .and_then(|b| b.find_subcommand("accuracy"))
            .expect("bench accuracy");
        let help = accuracy
            .get_arguments()
            .find(|a| a.get_id() == "quick")
            .and_then(|a| a.get_help())
            .map(ToString::to_string)
            .expect("--quick has help");
        let counts = format!(
            "({} of {})",
            configurations(true).len(),
            configurations(false).len()
        );
        assert!(help.contains(&counts), "{help} lacks {counts}");
    }
}
