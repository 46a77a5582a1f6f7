//! `gazecast experiment`: run a design's session in a window (`run`),
//! list a participant's trials (`plan`), analyse session folders
//! (`analyze`) and export them to BIDS (`export-bids`).

use std::io::Write;
use std::path::PathBuf;

use pipeline::BackendChoice;

use crate::runner::{self, RunOptions};

#[derive(Debug, Clone, clap::Args)]
pub struct ExperimentArgs {
    #[command(subcommand)]
    pub command: ExperimentCommand,
}

#[derive(Debug, Clone, clap::Subcommand)]
pub enum ExperimentCommand {
    /// Run (or --resume) one participant's session in a window, writing
    /// its session folder as it happens.
    Run(RunArgs),
    /// Print one participant's trials (TSV): run, condition, seed, target.
    Plan(PlanArgs),
    /// Analyse session folders: means ± SE, ANOVAs, pairwise t-tests,
    /// Table 7.1, Figs. 7.3 and 7.4, scanpaths.
    Analyze(AnalyzeArgs),
    /// Export session folders to BIDS eye-tracking (physio.tsv.gz + JSON
    /// sidecars, events.tsv).
    ExportBids(ExportArgs),
}

#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    /// The design file (RON), e.g. config/experiments/murphy2007-search.ron.
    #[arg(value_name = "DESIGN.ron")]
    pub design: PathBuf,
    /// Participant id (letters, digits, '-', '_'); names the session folder.
    #[arg(long, value_name = "ID")]
    pub participant: String,
    /// Counterbalancing row (0-based); default: the id's trailing number − 1
    /// (P01 → 0).
    #[arg(long, value_name = "N")]
    pub participant_index: Option<usize>,
    /// Tracker file (RON): config/trackers/mouse.ron, iscan-*.ron, tobii-hid.ron.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: PathBuf,
    /// Display file (RON); default: the seed's 17" 1280×1024 at 54 cm.
    #[arg(
        long,
        value_name = "FILE",
        default_value = "config/displays/tobii-et1750-17in.ron"
    )]
    pub display: PathBuf,
    /// Session folders go to OUT/<design name>/sub-<ID>.
    #[arg(long, value_name = "DIR", default_value = "data")]
    pub out: PathBuf,
    /// Continue a session at its first unfinished trial (after a crash or Esc).
    #[arg(long)]
    pub resume: bool,
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    #[arg(long)]
    pub fullscreen: bool,
    #[arg(long, value_name = "INDEX")]
    pub monitor: Option<usize>,
    /// A simulated participant (seeded) looks and presses instead of a
    /// person, through the mouse tracker (tests, demonstrations). Every
    /// file it produces is marked synthetic.
    #[arg(long, value_name = "SEED")]
    pub simulate_participant: Option<u64>,
    /// Do not save each trial's search display (stimuli/trial-NNN.png, used
    /// for the scanpath pictures).
    #[arg(long)]
    pub no_stimulus_pictures: bool,
    /// End this sitting after N trials (the session stays resumable).
    #[arg(long, value_name = "N")]
    pub max_trials: Option<usize>,
    /// Save the first frame of each kind of screen to DIR/<screen>.png.
    #[arg(long, value_name = "DIR")]
    pub screenshots: Option<PathBuf>,
    #[command(flatten)]
    pub lsl: crate::args::LslArgs,
}

#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    #[arg(value_name = "DESIGN.ron")]
    pub design: PathBuf,
    /// Counterbalancing row (0-based).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub participant_index: usize,
    /// The display the session will run on (RON): the design is checked
    /// against it as `run` checks it (every cell on the screen, objects at
    /// least a few pixels, the trial scenes buildable).
    #[arg(
        long,
        value_name = "FILE",
        default_value = "config/displays/tobii-et1750-17in.ron"
    )]
    pub display: PathBuf,
}

#[derive(Debug, Clone, clap::Args)]
pub struct AnalyzeArgs {
    /// Session folders (OUT/<design>/sub-<ID>), one per participant.
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    /// Where the report, tables and figures go.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Leave out trials whose confirming click missed the target.
    #[arg(long)]
    pub exclude_incorrect: bool,
}

#[derive(Debug, Clone, clap::Args)]
pub struct ExportArgs {
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    /// The BIDS dataset folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// BIDS task label.
    #[arg(long, default_value = "search")]
    pub task: String,
}

pub fn run(args: &ExperimentArgs, out: &mut dyn Write) -> Result<(), String> {
    match &args.command {
        ExperimentCommand::Run(a) => {
            a.lsl.check()?;
            let opts = RunOptions {
                design: a.design.clone(),
                participant: a.participant.clone(),
                participant_index: a.participant_index,
                tracker: Some(a.tracker.clone()),
                display: a.display.clone(),
                out: a.out.clone(),
                resume: a.resume,
                backend: a.backend,
                fullscreen: a.fullscreen,
                monitor: a.monitor,
                simulate: a.simulate_participant,
                stimulus_pictures: !a.no_stimulus_pictures,
                max_trials: a.max_trials,
                screenshots: a.screenshots.clone(),
                lsl: a.lsl,
            };
            runner::run(&opts, out)
        }
        ExperimentCommand::Plan(a) => {
            let display = crate::config::load_display(&a.display).map_err(|e| e.to_string())?;
            let geometry = display.geometry().map_err(|e| e.to_string())?;
            // The very check `run` makes: what plan lists, run accepts.
            let (_, checked) = crate::config::load_design_checked(&a.design, |d| {
                runner::check_design(d, a.participant_index, &geometry)
            })
            .map_err(|e| e.to_string())?;
            let trials = checked.trials;
            let w =
                |out: &mut dyn Write, s: String| writeln!(out, "{s}").map_err(|e| e.to_string());
            w(out, "trial\trun\ttrial_in_run\tcondition\tseed\ttarget_mesh\ttarget_row\ttarget_col\treference_row\treference_col\tbefore".into())?;
            for t in &trials {
                let before: Vec<String> = t.before.iter().map(|s| format!("{s:?}")).collect();
                // The reference cell (holding the target mesh too), n/a
                // without one.
                let (reference_row, reference_col) = match t.reference_cell {
                    Some((r, c)) => (r.to_string(), c.to_string()),
                    None => ("n/a".to_string(), "n/a".to_string()),
                };
                w(
                    out,
                    format!(
                        "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
                        t.index,
                        t.run,
                        t.trial_in_run,
                        t.condition_name,
                        t.seed,
                        t.target_mesh,
                        t.target_cell.0,
                        t.target_cell.1,
                        reference_row,
                        reference_col,
                        if before.is_empty() {
                            "n/a".into()
                        } else {
                            before.join(",")
                        }
                    ),
                )?;
            }
            Ok(())
        }
        ExperimentCommand::Analyze(a) => {
            let opts = experiment::analysis::AnalyzeOptions {
                exclude_incorrect: a.exclude_incorrect,
                ..Default::default()
            };
            let report =
                experiment::analysis::analyze(&a.dirs, &a.out, &opts).map_err(|e| e.to_string())?;
            let anova = match &report.anova {
                experiment::analysis::Computed::Done(a) => a.apa(),
                experiment::analysis::Computed::Skipped(why) => {
                    format!("one-way ANOVA skipped: {why}")
                }
            };
            writeln!(
                out,
                "{}{} trials of {} participants ({}): {anova}; wrote {}",
                if report.synthetic {
                    "SYNTHETIC DATA (simulated participant): "
                } else {
                    ""
                },
                report.n_trials,
                report.sessions.len(),
                report.design_name,
                a.out.join("report.md").display()
            )
            .map_err(|e| e.to_string())
        }
        ExperimentCommand::ExportBids(a) => {
            // Every method the renderer knows is described in the events'
            // sidecar, so a design's module method (`layers`) has a level.
            let methods: Vec<(&str, &str)> = pipeline::Method::all()
                .map(|m| (m.name(), m.help()))
                .collect();
            let done = experiment::bids::export_bids_described(&a.dirs, &a.out, &a.task, &methods)
                .map_err(|e| e.to_string())?;
            for w in &done.warnings {
                eprintln!("warning: {w}");
            }
            writeln!(
                out,
                "BIDS dataset {}: {} participants ({}), {} files",
                a.out.display(),
                done.labels.len(),
                done.labels.join(", "),
                done.files.len()
            )
            .map_err(|e| e.to_string())
        }
    }
}
