//! `gazecast thresholds measure`: measure contrast thresholds over a
//! frequency × eccentricity grid with interleaved QUEST staircases
//! (`psychophysics`), fit the Geisler–Perry CSF and write a session folder.
//! (`gazecast thresholds validate`, Luebke & Hallen §6.2's full-against-
//! simplified validation, is `validate`; `gazecast thresholds degradation`,
//! Murphy & Duchowski §6.2's staircase over the `lod` levels, is
//! `degradation`; `--procedure luebke-hallen`,
//! Luebke & Hallen §6.1's own contrast ramp with a location click, is
//! `ramp` headless and `ramp_window` in a window.)
//!
//! Two forms:
//!
//! - `--headless --simulate-observer FILE`: no window; a simulated observer
//!   answers every trial at once, and every file says `synthetic`.
//! - with `--tracker FILE` (and no `--headless`): a window (`window`):
//!   a two-interval forced choice with gaze-contingent fixation control
//!   (`psychophysics::fixation`), answered by a person with the arrow keys
//!   or the mouse buttons — or, for tests and demonstrations, by the
//!   simulated observer with a scripted gaze on the mouse tracker
//!   (`--simulate-observer` without `--headless`; synthetic again). No
//!   person has yet run it.
//!
//! The folder `OUT/sub-<ID>/` holds `trials.tsv` (every trial: condition,
//! contrast, the rendered patch's measured contrast, the answer, its
//! validity, the staircase's state after it, and the attempts aborted
//! before it by the fixation control), `thresholds-<ID>.ron`
//! (`psychophysics::participant::ParticipantThresholds`: the measured
//! table and the fitted CT0, α, e2; what `--thresholds FILE` reads),
//! `fit-<ID>.json` (CT0, α, e2 with bootstrap intervals and every
//! condition's result), `thresholds-<ID>.png` (the measured thresholds with
//! ±1.96 sd bars against the fitted curves per eccentricity, titled
//! SYNTHETIC when it is) and `session.json` (what ran, `synthetic`). The
//! windowed form also writes, as it happens, `samples.tsv` (every gaze
//! sample), `aborts.tsv` (every aborted attempt) and `tracker.gzrec` (the
//! tracker's bytes), and `trials.tsv` a row per answer. An existing folder
//! is never overwritten.

mod degradation;
mod ramp;
mod ramp_window;
mod validate;
mod window;

use std::io::Write;
use std::path::{Path, PathBuf};

use foveation::perceptibility::ThresholdTable;
use psychophysics::fit::{fit_session, threshold_table, FitOptions, GeislerPerryFit};
use psychophysics::luminance::{GammaCurve, LuminanceTable, Transfer, TransferKind};
use psychophysics::observer::{ObserverSpec, SimulatedObserver};
use psychophysics::ramp::{RampOutcome, RampSession, RampSpec};
use psychophysics::session::{ConditionResult, Session, SessionSpec, TrialRecord};
use psychophysics::stimulus::{GaborPatch, GaborSpec};
use serde::Serialize;

/// `gazecast thresholds`: its subcommand.
#[derive(Debug, Clone, clap::Args)]
pub struct ThresholdsArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: ThresholdsCommand,
}

/// The subcommands of `gazecast thresholds`.
#[derive(Debug, Clone, clap::Subcommand)]
pub enum ThresholdsCommand {
    /// Measure a participant's thresholds and fit the Geisler–Perry CSF.
    Measure(MeasureArgs),
    /// Luebke & Hallen §6.2's validation: can the participant tell the
    /// rendering simplified at their thresholds from the full one?
    /// Two-interval trials, proportion correct against chance. Headless
    /// with a simulated observer only: the windowed form is not built.
    Validate(validate::ValidateArgs),
    /// Murphy & Duchowski §6.2's degradation staircase: per depth and
    /// eccentricity, the coarsest lod level the observer cannot tell from
    /// full; writes a Table-1-style degradation table. Headless with a
    /// simulated observer only.
    Degradation(degradation::DegradationArgs),
}

/// How thresholds are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ProcedureArg {
    /// Two-interval forced choice with interleaved QUEST staircases.
    #[value(name = "2ifc")]
    TwoIfc,
    /// Luebke & Hallen §6.1: a contrast ramp, a response, a click on
    /// where the grating was (psychophysics::ramp).
    LuebkeHallen,
}

/// `gazecast thresholds measure`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasureArgs {
    /// No window: the simulated observer answers every trial at once.
    /// Without it the session runs in a window with --tracker.
    #[arg(long)]
    pub headless: bool,
    /// The procedure: 2ifc (QUEST) or luebke-hallen (a contrast ramp and
    /// a location click; --session then reads a
    /// psychophysics::ramp::RampSpec; in a window --interval-ms and
    /// --gap-ms do not apply).
    #[arg(long, value_enum, value_name = "NAME", default_value = "2ifc")]
    pub procedure: ProcedureArg,
    /// The simulated observer (RON, psychophysics::observer::ObserverSpec).
    /// A model, not a person: everything written is marked synthetic. In a
    /// window it answers, and a scripted gaze on the mouse tracker fixates.
    #[arg(long, value_name = "FILE.ron")]
    pub simulate_observer: Option<PathBuf>,
    /// The windowed session's tracker (RON; config/trackers/mouse.ron: the
    /// mouse is the gaze, for development).
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// A calibration (`gazecast calibrate --out`) the tracker's raw gaze
    /// maps through; without it the tracker file's mapping is used.
    #[arg(long, value_name = "FILE.ron")]
    pub calibration: Option<PathBuf>,
    /// Radius of the fixation window around the target, degrees: the
    /// stimulus is shown only while the gaze stays inside.
    #[arg(long, value_name = "DEG", default_value_t = 1.5)]
    pub fixation_window_deg: f64,
    /// Steady fixation (every sample in the window) needed before the
    /// stimulus starts, ms.
    #[arg(long, value_name = "MS", default_value_t = 500.0)]
    pub fixate_ms: f64,
    /// Each of the two intervals, ms.
    #[arg(long, value_name = "MS", default_value_t = 200.0)]
    pub interval_ms: f64,
    /// The blank between the intervals, ms.
    #[arg(long, value_name = "MS", default_value_t = 400.0)]
    pub gap_ms: f64,
    /// Write the first frame of each screen (instructions, fixation,
    /// stimulus, abort, response, over) as PNG into this folder.
    #[arg(long, value_name = "DIR")]
    pub screenshots: Option<PathBuf>,
    /// Fullscreen on the current monitor.
    #[arg(long)]
    pub fullscreen: bool,
    /// Fullscreen on this monitor (0-based; an out-of-range index lists them).
    #[arg(long, value_name = "INDEX")]
    pub monitor: Option<usize>,
    /// With --simulate-observer in a window: the scripted gaze leaves the
    /// fixation window during the stimulus of the first N attempts (each
    /// is aborted and shown again).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub simulate_fixation_breaks: u32,
    /// Participant id (letters, digits, '-', '_'); names the folder.
    #[arg(long, value_name = "ID")]
    pub participant: String,
    /// The session folder goes to `OUT/sub-<ID>`; it must not exist yet.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The session design (RON, psychophysics::session::SessionSpec);
    /// default: 1–16 cpd × 0–10°, QUEST, 40 trials per condition.
    #[arg(long, visible_alias = "design", value_name = "FILE.ron")]
    pub session: Option<PathBuf>,
    /// Display file (RON): where the patches are drawn.
    #[arg(
        long,
        value_name = "FILE",
        default_value = "config/displays/tobii-et1750-17in.ron"
    )]
    pub display: PathBuf,
    /// Photometer readings (RON, psychophysics::luminance::LuminanceTable);
    /// default: the documented γ 2.2 curve (0.5–100 cd/m²).
    #[arg(long, value_name = "FILE.ron")]
    pub luminance_table: Option<PathBuf>,
    /// Standard deviation of the patches' Gaussian window, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 0.5)]
    pub sigma_deg: f64,
    /// Background grey level (its luminance is the patches' mean).
    #[arg(long, value_name = "LEVEL", default_value_t = 128)]
    pub background_level: u8,
    /// Bootstrap resamples for the intervals.
    #[arg(long, value_name = "N", default_value_t = 200)]
    pub bootstrap: u32,
}

fn read_ron<T: serde::de::DeserializeOwned>(path: &Path, what: &str) -> Result<T, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read the {what}: {e}", path.display()))?;
    ron::from_str(&text).map_err(|e| format!("{}: not a {what}: {e}", path.display()))
}

/// The display's transfer: the photometer table `luminance_table`, or the
/// documented γ 2.2 curve without one.
fn read_transfer(luminance_table: Option<&Path>) -> Result<Transfer, String> {
    match luminance_table {
        Some(p) => Ok(Transfer::measured(&read_ron::<LuminanceTable>(
            p,
            "luminance table",
        )?)),
        None => Transfer::gamma(GammaCurve::default()).map_err(|e| e.to_string()),
    }
}

/// `session.json`.
#[derive(Serialize)]
struct SessionInfo<'a> {
    synthetic: bool,
    note: String,
    software: String,
    participant: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    observer_file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    observer: Option<ObserverSpec>,
    /// Did every condition finish (false: ended early, e.g. by Esc)?
    completed: bool,
    /// Windowed: the tracker, the fixation control and the clocks.
    #[serde(skip_serializing_if = "Option::is_none")]
    window: Option<window::WindowInfo>,
    /// Attempts aborted by the fixation control (0 headless: no gaze).
    aborted_attempts: u32,
    #[serde(flatten)]
    setup: SessionSetup<'a>,
}

/// A session's design as `session.json` writes it.
#[derive(Serialize)]
#[serde(untagged)]
enum Design<'a> {
    Quest(&'a SessionSpec),
    Ramp(&'a RampSpec),
}

/// What every `session.json` states of the design, the display, the fit
/// and the trials, headless or in a window.
#[derive(Serialize)]
struct SessionSetup<'a> {
    /// `2ifc` or `luebke-hallen`.
    procedure: &'static str,
    design: Design<'a>,
    display: &'a foveation::Display,
    transfer: TransferKind,
    max_contrast: f64,
    sigma_deg: f64,
    background_level: u8,
    fit_options: FitOptions,
    trials: usize,
    invalid_trials: usize,
}

impl<'a> SessionSetup<'a> {
    fn of(loaded: &'a Loaded, a: &MeasureArgs, session: &Session) -> Self {
        Self {
            procedure: "2ifc",
            design: Design::Quest(&loaded.spec),
            display: &loaded.display,
            transfer: loaded.transfer.kind(),
            max_contrast: loaded.max_contrast,
            sigma_deg: a.sigma_deg,
            background_level: a.background_level,
            fit_options: fit_options(a, loaded.spec.seed),
            trials: session.records().len(),
            invalid_trials: session.records().iter().filter(|r| !r.valid).count(),
        }
    }

    /// A ramp session's; its failed trials are the invalid ones.
    fn of_ramp(loaded: &'a Loaded<RampSpec>, a: &MeasureArgs, session: &RampSession) -> Self {
        Self {
            procedure: "luebke-hallen",
            design: Design::Ramp(&loaded.spec),
            display: &loaded.display,
            transfer: loaded.transfer.kind(),
            max_contrast: loaded.max_contrast,
            sigma_deg: a.sigma_deg,
            background_level: a.background_level,
            fit_options: fit_options(a, loaded.spec.seed),
            trials: session.records().len(),
            invalid_trials: session
                .records()
                .iter()
                .filter(|r| r.outcome != RampOutcome::Correct)
                .count(),
        }
    }
}

/// `fit-<ID>.json`.
#[derive(Serialize)]
struct FitFile<'a> {
    synthetic: bool,
    fit: &'a GeislerPerryFit,
    conditions: Vec<ConditionResult>,
}

/// Runs `gazecast thresholds`'s subcommand, writing normal output to `out`.
pub fn run(args: &ThresholdsArgs, out: &mut dyn Write) -> Result<(), String> {
    match &args.command {
        ThresholdsCommand::Measure(a) => measure(a, out),
        ThresholdsCommand::Validate(a) => validate::run(a, out),
        ThresholdsCommand::Degradation(a) => degradation::run(a, out),
    }
}

/// Everything read and checked before a folder is created; `S` is the
/// design (a QUEST [`SessionSpec`] or a ramp's [`RampSpec`]).
struct Loaded<S = SessionSpec> {
    display: foveation::Display,
    geometry: foveation::ScreenGeometry,
    transfer: Transfer,
    /// The display's highest contrast around the background.
    max_contrast: f64,
    /// The design, limited to that contrast.
    spec: S,
}

impl Loaded {
    /// Reads the display, the transfer and the design, and requires every
    /// condition to be drawable on this display.
    fn read(a: &MeasureArgs) -> Result<Self, String> {
        Loaded::read_with(a, |p, max_contrast| {
            match p {
                Some(p) => read_ron::<SessionSpec>(p, "session design")?,
                None => SessionSpec::default(),
            }
            .limited_to_contrast(max_contrast)
            .map_err(|e| format!("--background-level {}: {e}", a.background_level))
        })
    }
}

impl Loaded<RampSpec> {
    /// [`Loaded::read`] for a ramp: `--session` is a [`RampSpec`], checked.
    fn read_ramp(a: &MeasureArgs) -> Result<Self, String> {
        Loaded::read_with(a, |p, max_contrast| {
            let spec = match p {
                Some(p) => {
                    let s = read_ron::<RampSpec>(p, "ramp design (psychophysics::ramp::RampSpec)")?;
                    s.validate()
                        .map_err(|e| format!("{}: ramp design: {e}", p.display()))?;
                    s
                }
                None => RampSpec::default(),
            };
            spec.limited_to_contrast(max_contrast)
                .map_err(|e| format!("--background-level {}: {e}", a.background_level))
        })
    }
}

/// A design's grid.
trait Grid {
    fn grid(&self) -> (&[f64], &[f64]);
}

impl Grid for SessionSpec {
    fn grid(&self) -> (&[f64], &[f64]) {
        (&self.frequencies_cpd, &self.eccentricities_deg)
    }
}

impl Grid for RampSpec {
    fn grid(&self) -> (&[f64], &[f64]) {
        (&self.frequencies_cpd, &self.eccentricities_deg)
    }
}

impl<S: Grid> Loaded<S> {
    /// Reads the display and the transfer, the design by `read_spec` (the
    /// `--session` path, the display's highest contrast), and requires
    /// every condition to be drawable on this display.
    fn read_with(
        a: &MeasureArgs,
        read_spec: impl FnOnce(Option<&Path>, f64) -> Result<S, String>,
    ) -> Result<Self, String> {
        let display = crate::config::load_display(&a.display).map_err(|e| e.to_string())?;
        let geometry = display.geometry().map_err(|e| e.to_string())?;
        let transfer = read_transfer(a.luminance_table.as_deref())?;
        // No trial asks for more contrast than the display shows around the
        // background.
        let max_contrast = transfer.max_contrast(a.background_level);
        let spec = read_spec(a.session.as_deref(), max_contrast)?;
        let loaded = Self {
            display,
            geometry,
            transfer,
            max_contrast,
            spec,
        };
        let (freqs, eccs) = loaded.spec.grid();
        for &e in eccs {
            for &f in freqs {
                loaded.patch(a, f, e, 0.0, 0).map_err(|err| {
                    format!(
                        "{} cpd at {}° cannot be shown on {}: {err}",
                        f,
                        e,
                        a.display.display()
                    )
                })?;
            }
        }
        Ok(loaded)
    }

    /// The patch of a trial (contrast capped at the display's).
    fn patch(
        &self,
        a: &MeasureArgs,
        frequency_cpd: f64,
        eccentricity_deg: f64,
        contrast: f64,
        seed: u64,
    ) -> Result<GaborPatch, psychophysics::ParamError> {
        GaborPatch::render(
            &GaborSpec {
                frequency_cpd,
                orientation_deg: 0.0,
                eccentricity_deg,
                contrast: contrast.min(self.max_contrast),
                sigma_deg: a.sigma_deg,
                background_level: a.background_level,
            },
            &self.geometry,
            &self.transfer,
            seed,
        )
    }
}

/// Creates `OUT/sub-<ID>`, failing if it exists.
fn create_folder(a: &MeasureArgs) -> Result<PathBuf, String> {
    create_session_folder(&a.out, &a.participant)
}

/// Creates `out/sub-<participant>`, failing if it exists.
fn create_session_folder(out: &Path, participant: &str) -> Result<PathBuf, String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let dir = out.join(format!("sub-{participant}"));
    std::fs::create_dir(&dir).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            format!(
                "{}: already exists; refusing to overwrite a session (choose another --out or --participant)",
                dir.display()
            )
        } else {
            format!("{}: {e}", dir.display())
        }
    })?;
    Ok(dir)
}

/// `trials.tsv`'s header. Times are on this process's host monotonic
/// clock (µs; the clock the tracker's sample times are mapped onto);
/// `n/a` in the headless form, which has no window and no clock.
const TRIALS_HEADER: &str =
    "trial\tcondition\tfrequency_cpd\teccentricity_deg\tlog10_contrast\tcontrast\t\
     shown_contrast\tdither_sd\tcorrect\trt_ms\tvalid\testimate_log10\tspread_log10\t\
     reversals\tfinished_condition\taborted_attempts\ttarget_interval\tchosen_interval\t\
     onset_host_us\tresponse_host_us\n";

/// A windowed trial's facts beyond the session's record.
struct Shown {
    /// Attempts of this trial aborted before the answered one.
    aborted_attempts: u32,
    /// 1 or 2, as the participant counts them.
    target_interval: u8,
    chosen_interval: u8,
    /// The answered attempt's first stimulus frame and the answer, host
    /// monotonic µs.
    onset_host_us: u64,
    response_host_us: u64,
}

/// One `trials.tsv` row.
fn trial_row(p: &GaborPatch, rec: &TrialRecord, shown: Option<&Shown>) -> String {
    let t = &rec.trial;
    let windowed = match shown {
        Some(s) => format!(
            "{}\t{}\t{}\t{}\t{}",
            s.aborted_attempts,
            s.target_interval,
            s.chosen_interval,
            s.onset_host_us,
            s.response_host_us
        ),
        None => "0\tn/a\tn/a\tn/a\tn/a".into(),
    };
    format!(
        "{}\t{}\t{}\t{}\t{:.4}\t{:.6}\t{:.6}\t{:.2e}\t{}\t{:.1}\t{}\t{:.4}\t{:.4}\t{}\t{}\t{windowed}\n",
        t.index,
        t.condition,
        t.frequency_cpd,
        t.eccentricity_deg,
        t.log10_contrast,
        t.contrast,
        p.measured_contrast(),
        p.dither_contrast_sd,
        u8::from(rec.response.correct),
        rec.response.rt_ms,
        u8::from(rec.valid),
        rec.estimate_log10,
        rec.spread_log10,
        rec.reversals,
        u8::from(rec.finished_condition),
    )
}

fn measure(a: &MeasureArgs, out: &mut dyn Write) -> Result<(), String> {
    experiment::design::check_id(&a.participant).map_err(|e| format!("--participant {e}"))?;
    if a.procedure == ProcedureArg::LuebkeHallen {
        if !a.headless {
            return ramp_window::run(a, out);
        }
        return ramp::measure_headless(a, out);
    }
    if !a.headless {
        return window::run(a, out);
    }
    let Some(observer_path) = &a.simulate_observer else {
        return Err("--headless needs --simulate-observer FILE.ron (who answers?)".into());
    };
    let mut observer = load_observer(observer_path)?;
    let loaded = Loaded::read(a)?;
    let mut session =
        Session::new(loaded.spec.clone()).map_err(|e| format!("session design: {e}"))?;
    let dir = create_folder(a)?;

    let mut tsv = String::from(TRIALS_HEADER);
    while let Some(t) = session.next_trial() {
        let p = loaded
            .patch(
                a,
                t.frequency_cpd,
                t.eccentricity_deg,
                t.contrast,
                u64::from(t.index),
            )
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        let r = observer
            .respond(
                t.frequency_cpd,
                t.eccentricity_deg,
                t.contrast.min(loaded.max_contrast),
            )
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        session
            .record_synthetic(&t, r)
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        let rec = session.records()[session.records().len() - 1];
        tsv.push_str(&trial_row(&p, &rec, None));
    }
    let p = dir.join("trials.tsv");
    std::fs::write(&p, tsv).map_err(|e| format!("{}: {e}", p.display()))?;
    let info = SessionInfo {
        synthetic: session.is_synthetic(),
        note: "a simulated observer answered every trial; no person has yet run this procedure"
            .into(),
        software: software(),
        participant: &a.participant,
        observer_file: Some(observer_path.display().to_string()),
        observer: Some(*observer.spec()),
        completed: true,
        window: None,
        aborted_attempts: 0,
        setup: SessionSetup::of(&loaded, a, &session),
    };
    write_session_json(&dir, &info)?;
    let fitted = fit_and_table(&session, &info.setup.fit_options)?;
    let who = format!("a simulated observer ({})", observer_path.display());
    write_results(a, &dir, &Measured::of(&session), fitted, &who, out)
}

fn software() -> String {
    format!("gazecast {}", env!("CARGO_PKG_VERSION"))
}

fn load_observer(path: &Path) -> Result<SimulatedObserver, String> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        format!(
            "{}: cannot read the simulated observer: {e}",
            path.display()
        )
    })?;
    SimulatedObserver::from_ron(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn fit_options(a: &MeasureArgs, seed: u64) -> FitOptions {
    FitOptions {
        bootstrap_resamples: a.bootstrap,
        seed,
        ..FitOptions::default()
    }
}

fn write_file(dir: &Path, name: &str, body: &str) -> Result<(), String> {
    let p = dir.join(name);
    std::fs::write(&p, body).map_err(|e| format!("{}: {e}", p.display()))
}

fn write_session_json(dir: &Path, info: &SessionInfo) -> Result<(), String> {
    write_file(
        dir,
        "session.json",
        &serde_json::to_string_pretty(info).map_err(|e| e.to_string())?,
    )
}

/// The Geisler–Perry fit of a finished session and its threshold table.
fn fit_and_table(
    session: &Session,
    options: &FitOptions,
) -> Result<(GeislerPerryFit, ThresholdTable), String> {
    let fit = fit_session(session, options).map_err(|e| format!("the fit: {e}"))?;
    let table = threshold_table(session, &fit).map_err(|e| format!("the table: {e}"))?;
    Ok((fit, table))
}

/// What [`write_results`] needs of a finished session, of either
/// procedure.
struct Measured {
    synthetic: bool,
    results: Vec<ConditionResult>,
    trials: usize,
    /// What the plot's error bars are.
    bars: &'static str,
}

impl Measured {
    fn of(session: &Session) -> Self {
        Self {
            synthetic: session.is_synthetic(),
            results: session.results(),
            trials: session.records().len(),
            bars: "±1.96 sd of each QUEST estimate",
        }
    }

    fn of_ramp(session: &RampSession) -> Self {
        Self {
            synthetic: session.is_synthetic(),
            results: session.results(),
            trials: session.records().len(),
            bars: "±1.96 standard errors of each geometric mean of the ramp's samples",
        }
    }
}

/// The thresholds file, the fit's JSON and the plot of a finished session
/// with its fit; a line to `out`. `who` answered (for the thresholds
/// file's first line when synthetic).
fn write_results(
    a: &MeasureArgs,
    dir: &Path,
    session: &Measured,
    (fit, table): (GeislerPerryFit, ThresholdTable),
    who: &str,
    out: &mut dyn Write,
) -> Result<(), String> {
    let synthetic = session.synthetic;
    let file = psychophysics::participant::ParticipantThresholds::new(
        &a.participant,
        synthetic,
        fit.model(),
        table,
    );
    let ron_text = ron::ser::to_string_pretty(&file, ron::ser::PrettyConfig::default())
        .map_err(|e| e.to_string())?;
    let first_line = if synthetic {
        format!("// SYNTHETIC: measured from {who}, not a person.")
    } else {
        format!(
            "// Measured from participant {} in a windowed session ({}).",
            a.participant,
            software()
        )
    };
    write_file(
        dir,
        &format!("thresholds-{}.ron", a.participant),
        &format!("{first_line}\n{ron_text}\n"),
    )?;
    let fit_file = FitFile {
        synthetic,
        fit: &fit,
        conditions: session.results.clone(),
    };
    write_file(
        dir,
        &format!("fit-{}.json", a.participant),
        &serde_json::to_string_pretty(&fit_file).map_err(|e| e.to_string())?,
    )?;
    let png = dir.join(format!("thresholds-{}.png", a.participant));
    let points: Vec<crate::plots::ThresholdPoint> = session
        .results
        .iter()
        .filter(|r| !r.abandoned && r.valid_trials > 0)
        .map(|r| crate::plots::ThresholdPoint {
            frequency_cpd: r.frequency_cpd,
            eccentricity_deg: r.eccentricity_deg,
            log10_threshold: r.log10_threshold,
            sd_log10: r.sd_log10,
            censored: r.censored,
        })
        .collect();
    let fit_note = format!(
        "fit: CT0 {:.4} [{:.4}, {:.4}], α {:.4} [{:.4}, {:.4}], e2 {:.2}° [{:.2}, {:.2}] ({:.0} % bootstrap intervals, {} resamples)\nhollow circles: censored (beyond the display's contrast), left out of the fit; bars: {}",
        fit.ct0.estimate,
        fit.ct0.ci_low,
        fit.ct0.ci_high,
        fit.alpha.estimate,
        fit.alpha.ci_low,
        fit.alpha.ci_high,
        fit.e2_deg.estimate,
        fit.e2_deg.ci_low,
        fit.e2_deg.ci_high,
        fit.ci_level * 100.0,
        fit.bootstrap_resamples,
        session.bars,
    );
    crate::plots::draw_thresholds(
        &png,
        &a.participant,
        synthetic,
        &fit.model(),
        &fit_note,
        &points,
    )
    .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    let m = fit.model();
    writeln!(
        out,
        "{}{}: {} trials; CT0 {:.4} [{:.4}, {:.4}], alpha {:.4} [{:.4}, {:.4}], e2 {:.3} [{:.3}, {:.3}] deg ({} of {} conditions fitted)",
        if synthetic { "SYNTHETIC " } else { "" },
        dir.display(),
        session.trials,
        m.ct0,
        fit.ct0.ci_low,
        fit.ct0.ci_high,
        m.alpha,
        fit.alpha.ci_low,
        fit.alpha.ci_high,
        m.e2_deg,
        fit.e2_deg.ci_low,
        fit.e2_deg.ci_high,
        fit.conditions_used,
        fit.conditions_used + fit.conditions_left_out,
    )
    .map_err(|e| e.to_string())
}
