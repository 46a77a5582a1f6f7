//! `gazecast experiment`: run a design's session in a window (`run`),
//! list a participant's trials (`plan`), analyse session folders
//! (`analyze`) and export them to BIDS (`export-bids`).

use std::io::Write;
use std::path::PathBuf;

use pipeline::BackendChoice;

use crate::runner::{self, RunOptions};

/// `gazecast experiment`: its subcommand.
#[derive(Debug, Clone, clap::Args)]
pub struct ExperimentArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: ExperimentCommand,
}

/// The subcommands of `gazecast experiment`.
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

/// `gazecast experiment run`'s arguments.
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
    /// Session folders go to `OUT/<design name>/sub-<ID>`.
    #[arg(long, value_name = "DIR", default_value = "data")]
    pub out: PathBuf,
    /// Continue a session at its first unfinished trial (after a crash or Esc).
    #[arg(long)]
    pub resume: bool,
    /// Where to render: `cpu`, `gpu`, or `auto`.
    #[arg(long, value_parser = crate::args::backend_parser(), default_value = "auto")]
    pub backend: BackendChoice,
    /// Fullscreen on the current monitor.
    #[arg(long)]
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based).
    #[arg(long, value_name = "INDEX")]
    pub monitor: Option<usize>,
    /// A simulated participant (seeded) looks and presses instead of a
    /// person, through the mouse tracker (tests, demonstrations). Every
    /// file it produces is marked synthetic.
    #[arg(long, value_name = "SEED")]
    pub simulate_participant: Option<u64>,
    /// The simulated participant searches with this observer model (RON,
    /// config/participants/search-observer.ron): what it identifies at
    /// each fixation depends on what the condition rendered there. A
    /// model, not a person: its data are synthetic.
    #[arg(long, value_name = "FILE.ron", requires = "simulate_participant")]
    pub participant_model: Option<PathBuf>,
    /// No window: the simulated participant's session on a virtual clock,
    /// as fast as the machine renders (same screens, renderer and files;
    /// the mouse tracker emulated on the same clock).
    #[arg(long, requires = "simulate_participant")]
    pub headless: bool,
    /// Show the last search frame again while the gaze stays within DEG
    /// degrees of the gaze it was rendered for (its rays and render time
    /// repeated in frames.tsv). Default: 0.5 with --headless, else 0
    /// (every frame rendered).
    #[arg(long, value_name = "DEG")]
    pub gaze_tolerance_deg: Option<f64>,
    /// Do not save each trial's search display (stimuli/trial-NNN.png, used
    /// for the scanpath pictures).
    #[arg(long)]
    pub no_stimulus_pictures: bool,
    /// End this sitting after N trials (the session stays resumable).
    #[arg(long, value_name = "N")]
    pub max_trials: Option<usize>,
    /// Save the first frame of each kind of screen to `DIR/<screen>.png`.
    #[arg(long, value_name = "DIR")]
    pub screenshots: Option<PathBuf>,
    /// Lab Streaming Layer output.
    #[command(flatten)]
    pub lsl: crate::args::LslArgs,
}

/// `gazecast experiment plan`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    /// The design file (RON).
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

/// `gazecast experiment analyze`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct AnalyzeArgs {
    /// Session folders (`OUT/<design>/sub-<ID>`), one per participant.
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    /// Where the report, tables and figures go.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Leave out trials whose confirming click missed the target.
    #[arg(long)]
    pub exclude_incorrect: bool,
}

/// `gazecast experiment export-bids`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ExportArgs {
    /// Session folders (`OUT/<design>/sub-<ID>`), one per participant.
    #[arg(value_name = "DIR", required = true)]
    pub dirs: Vec<PathBuf>,
    /// The BIDS dataset folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// BIDS task label.
    #[arg(long, default_value = "search")]
    pub task: String,
    /// Take the dataset metadata (the design's `bids` block) from this
    /// design file instead of the first session folder's design.ron.
    #[arg(long, value_name = "FILE")]
    pub design: Option<PathBuf>,
    /// Boxed: the enum of commands stays small.
    #[command(flatten)]
    pub metadata: Box<MetadataArgs>,
}

/// Dataset metadata for `export-bids`: each flag given replaces the
/// design's `bids` field of the same name (a repeated flag's values
/// replace the whole list).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct MetadataArgs {
    /// An author of the dataset (repeat for each, in order): `Authors`.
    #[arg(long = "author", value_name = "NAME")]
    pub authors: Vec<String>,
    /// The data's licence, an SPDX identifier such as CC0-1.0: `License`.
    #[arg(long, value_name = "ID")]
    pub license: Option<String>,
    /// `Acknowledgements`.
    #[arg(long, value_name = "TEXT")]
    pub acknowledgements: Option<String>,
    /// How to cite the data: `HowToAcknowledge`.
    #[arg(long, value_name = "TEXT")]
    pub how_to_acknowledge: Option<String>,
    /// A funding source (repeat for each): `Funding`.
    #[arg(long, value_name = "TEXT")]
    pub funding: Vec<String>,
    /// An ethics approval (repeat for each): `EthicsApprovals`.
    #[arg(long = "ethics-approval", value_name = "TEXT")]
    pub ethics_approvals: Vec<String>,
    /// A paper or page about the data (repeat for each): `ReferencesAndLinks`.
    #[arg(long = "reference", value_name = "TEXT")]
    pub references_and_links: Vec<String>,
    /// The dataset's DOI as a URI (doi:10.…): `DatasetDOI`.
    #[arg(long, value_name = "URI")]
    pub dataset_doi: Option<String>,
    /// The instructions given to the participants: `Instructions`.
    #[arg(long, value_name = "TEXT")]
    pub instructions: Option<String>,
    /// Replaces gazecast's description of the task: `TaskDescription`.
    #[arg(long, value_name = "TEXT")]
    pub task_description: Option<String>,
    /// The Cognitive Atlas task's URI: `CogAtlasID`.
    #[arg(long, value_name = "URI")]
    pub cog_atlas_id: Option<String>,
    /// The CogPO term's URI: `CogPOID`.
    #[arg(long, value_name = "URI")]
    pub cog_po_id: Option<String>,
    /// `InstitutionName`.
    #[arg(long, value_name = "TEXT")]
    pub institution_name: Option<String>,
    /// `InstitutionAddress`.
    #[arg(long, value_name = "TEXT")]
    pub institution_address: Option<String>,
    /// `InstitutionalDepartmentName`.
    #[arg(long, value_name = "TEXT")]
    pub institutional_department_name: Option<String>,
}

impl MetadataArgs {
    /// The flags as metadata to lay over the design's.
    pub fn metadata(&self) -> experiment::design::BidsMetadata {
        experiment::design::BidsMetadata {
            authors: self.authors.clone(),
            license: self.license.clone(),
            acknowledgements: self.acknowledgements.clone(),
            how_to_acknowledge: self.how_to_acknowledge.clone(),
            funding: self.funding.clone(),
            ethics_approvals: self.ethics_approvals.clone(),
            references_and_links: self.references_and_links.clone(),
            dataset_doi: self.dataset_doi.clone(),
            instructions: self.instructions.clone(),
            task_description: self.task_description.clone(),
            cog_atlas_id: self.cog_atlas_id.clone(),
            cog_po_id: self.cog_po_id.clone(),
            institution_name: self.institution_name.clone(),
            institution_address: self.institution_address.clone(),
            institutional_department_name: self.institutional_department_name.clone(),
        }
    }
}

/// `--gaze-tolerance-deg`'s default with `--headless` (the live view's).
const HEADLESS_TOLERANCE_DEG: f64 = 0.5;
/// The largest `--gaze-tolerance-deg` (beyond, the fovea would lag the
/// gaze by more than its own radius).
const MAX_TOLERANCE_DEG: f64 = 2.0;

/// Runs `gazecast experiment`'s subcommand, writing normal output to `out`.
pub fn run(args: &ExperimentArgs, out: &mut dyn Write) -> Result<(), String> {
    match &args.command {
        ExperimentCommand::Run(a) => {
            a.lsl.check()?;
            let tolerance = a.gaze_tolerance_deg.unwrap_or(if a.headless {
                HEADLESS_TOLERANCE_DEG
            } else {
                0.0
            });
            if !(0.0..=MAX_TOLERANCE_DEG).contains(&tolerance) {
                return Err(format!(
                    "--gaze-tolerance-deg {tolerance}: give 0 to {MAX_TOLERANCE_DEG} degrees"
                ));
            }
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
                headless: a.headless,
                participant_model: a.participant_model.clone(),
                gaze_tolerance_deg: (tolerance > 0.0).then_some(tolerance),
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
            w(out, "trial\trun\ttrial_in_run\tcondition\tseed\ttarget_mesh\ttarget_row\ttarget_col\treference_row\treference_col\tbefore\tpractice".into())?;
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
                        "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
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
                        },
                        t.practice
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
                "{}{} trials of {} participants ({}{}): {anova}; wrote {}",
                if report.synthetic {
                    "SYNTHETIC DATA (simulated participant): "
                } else {
                    ""
                },
                report.n_trials,
                report.sessions.len(),
                if report.n_practice > 0 {
                    format!("{} practice trials left out; ", report.n_practice)
                } else {
                    String::new()
                },
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
            // The dataset metadata: the design's `bids` block (the first
            // session's copy, or --design), each flag laid over it; a bad
            // value names the file, line and field, or the flag.
            let design_path = match (&a.design, a.dirs.first()) {
                (Some(p), _) => p.clone(),
                (None, Some(dir)) => dir.join(experiment::session::DESIGN_RON),
                (None, None) => return Err("no session folders given".into()),
            };
            let flags = a.metadata.metadata();
            flags
                .validate()
                .map_err(|(field, message)| format!("--{}: {message}", flag_name(&field)))?;
            let design = crate::config::load_design(&design_path).map_err(|e| e.to_string())?;
            let dataset = design.bids.unwrap_or_default().overlay(&flags);
            let done =
                experiment::bids::export_bids_with(&a.dirs, &a.out, &a.task, &methods, &dataset)
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

/// The `export-bids` flag of a metadata field (`authors[1]` → `author`).
fn flag_name(field: &str) -> String {
    let name = field.split('[').next().unwrap_or(field);
    match name {
        "authors" => "author".into(),
        "ethics_approvals" => "ethics-approval".into(),
        "references_and_links" => "reference".into(),
        other => other.replace('_', "-"),
    }
}
