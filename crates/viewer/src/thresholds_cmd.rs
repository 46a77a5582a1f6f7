//! `gazecast thresholds measure`: measure contrast thresholds over a
//! frequency × eccentricity grid with interleaved QUEST staircases
//! (`psychophysics`), fit the Geisler–Perry CSF and write a session folder.
//!
//! Only the headless form exists so far: a simulated observer
//! (`--simulate-observer FILE.ron`) answers, and every file says
//! `synthetic`. No window, and no person has yet run this procedure.
//!
//! The folder `OUT/sub-<ID>/` holds `trials.tsv` (every trial: condition,
//! contrast, the rendered patch's measured contrast, the answer, its
//! validity and the staircase's state after it), `thresholds-<ID>.ron`
//! (`psychophysics::participant::ParticipantThresholds`: the measured
//! table and the fitted CT0, α, e2; what `--thresholds FILE` reads), `fit-<ID>.json` (CT0, α, e2 with bootstrap
//! intervals and every condition's result), `thresholds-<ID>.png` (the
//! measured thresholds with ±1.96 sd bars against the fitted curves per
//! eccentricity, titled SYNTHETIC when it is) and `session.json` (what ran,
//! `synthetic: true`). An existing folder is never overwritten.

use std::io::Write;
use std::path::{Path, PathBuf};

use psychophysics::fit::{fit_session, threshold_table, FitOptions, GeislerPerryFit};
use psychophysics::luminance::{GammaCurve, LuminanceTable, Transfer, TransferKind};
use psychophysics::observer::{ObserverSpec, SimulatedObserver};
use psychophysics::session::{ConditionResult, Session, SessionSpec};
use psychophysics::stimulus::{GaborPatch, GaborSpec};
use serde::Serialize;

#[derive(Debug, Clone, clap::Args)]
pub struct ThresholdsArgs {
    #[command(subcommand)]
    pub command: ThresholdsCommand,
}

#[derive(Debug, Clone, clap::Subcommand)]
pub enum ThresholdsCommand {
    /// Measure a participant's thresholds and fit the Geisler–Perry CSF.
    Measure(MeasureArgs),
}

#[derive(Debug, Clone, clap::Args)]
pub struct MeasureArgs {
    /// No window: the simulated observer answers every trial at once.
    /// (Required for now: the windowed session is not written yet.)
    #[arg(long)]
    pub headless: bool,
    /// The simulated observer (RON, psychophysics::observer::ObserverSpec).
    /// A model, not a person: everything written is marked synthetic.
    #[arg(long, value_name = "FILE.ron")]
    pub simulate_observer: Option<PathBuf>,
    /// Participant id (letters, digits, '-', '_'); names the folder.
    #[arg(long, value_name = "ID")]
    pub participant: String,
    /// The session folder goes to OUT/sub-<ID>; it must not exist yet.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The session design (RON, psychophysics::session::SessionSpec);
    /// default: 1–16 cpd × 0–10°, QUEST, 40 trials per condition.
    #[arg(long, value_name = "FILE.ron")]
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

/// `session.json`.
#[derive(Serialize)]
struct SessionInfo<'a> {
    synthetic: bool,
    note: &'static str,
    software: String,
    participant: &'a str,
    observer_file: String,
    observer: ObserverSpec,
    design: &'a SessionSpec,
    display: &'a foveation::Display,
    transfer: TransferKind,
    max_contrast: f64,
    sigma_deg: f64,
    background_level: u8,
    fit_options: FitOptions,
    trials: usize,
    invalid_trials: usize,
}

/// `fit-<ID>.json`.
#[derive(Serialize)]
struct FitFile<'a> {
    synthetic: bool,
    fit: &'a GeislerPerryFit,
    conditions: Vec<ConditionResult>,
}

pub fn run(args: &ThresholdsArgs, out: &mut dyn Write) -> Result<(), String> {
    match &args.command {
        ThresholdsCommand::Measure(a) => measure(a, out),
    }
}

fn measure(a: &MeasureArgs, out: &mut dyn Write) -> Result<(), String> {
    experiment::design::check_id(&a.participant).map_err(|e| format!("--participant {e}"))?;
    let observer_path = match (a.headless, &a.simulate_observer) {
        (true, Some(p)) => p,
        (true, None) => {
            return Err("--headless needs --simulate-observer FILE.ron (who answers?)".into())
        }
        (false, _) => {
            return Err(
                "thresholds measure runs only --headless with --simulate-observer for now: \
                 the windowed session for a person is not written yet"
                    .into(),
            )
        }
    };
    let text = std::fs::read_to_string(observer_path).map_err(|e| {
        format!(
            "{}: cannot read the simulated observer: {e}",
            observer_path.display()
        )
    })?;
    let mut observer = SimulatedObserver::from_ron(&text)
        .map_err(|e| format!("{}: {e}", observer_path.display()))?;
    let display = crate::config::load_display(&a.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let transfer = match &a.luminance_table {
        Some(p) => Transfer::measured(&read_ron::<LuminanceTable>(p, "luminance table")?),
        None => Transfer::gamma(GammaCurve::default()).map_err(|e| e.to_string())?,
    };
    // No trial asks for more contrast than the display shows around the
    // background.
    let max_contrast = transfer.max_contrast(a.background_level);
    let spec = match &a.session {
        Some(p) => read_ron::<SessionSpec>(p, "session design")?,
        None => SessionSpec::default(),
    }
    .limited_to_contrast(max_contrast)
    .map_err(|e| format!("--background-level {}: {e}", a.background_level))?;
    let mut session = Session::new(spec.clone()).map_err(|e| format!("session design: {e}"))?;
    let patch = |f: f64, e: f64, c: f64, seed: u64| {
        GaborPatch::render(
            &GaborSpec {
                frequency_cpd: f,
                orientation_deg: 0.0,
                eccentricity_deg: e,
                contrast: c,
                sigma_deg: a.sigma_deg,
                background_level: a.background_level,
            },
            &geometry,
            &transfer,
            seed,
        )
    };
    // Every condition must be drawable on this display before anything runs.
    for &e in &spec.eccentricities_deg {
        for &f in &spec.frequencies_cpd {
            patch(f, e, 0.0, 0).map_err(|err| {
                format!(
                    "{} cpd at {}° cannot be shown on {}: {err}",
                    f,
                    e,
                    a.display.display()
                )
            })?;
        }
    }

    // Refuse to overwrite: create the folder itself, failing if it exists.
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let dir = a.out.join(format!("sub-{}", a.participant));
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

    let mut tsv = String::from(
        "trial\tcondition\tfrequency_cpd\teccentricity_deg\tlog10_contrast\tcontrast\t\
         shown_contrast\tdither_sd\tcorrect\trt_ms\tvalid\testimate_log10\tspread_log10\t\
         reversals\tfinished_condition\n",
    );
    while let Some(t) = session.next_trial() {
        let p = patch(
            t.frequency_cpd,
            t.eccentricity_deg,
            t.contrast.min(max_contrast),
            u64::from(t.index),
        )
        .map_err(|e| format!("trial {}: {e}", t.index))?;
        let r = observer
            .respond(
                t.frequency_cpd,
                t.eccentricity_deg,
                t.contrast.min(max_contrast),
            )
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        session
            .record_synthetic(&t, r)
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        let rec = session.records()[session.records().len() - 1];
        tsv.push_str(&format!(
            "{}\t{}\t{}\t{}\t{:.4}\t{:.6}\t{:.6}\t{:.2e}\t{}\t{:.1}\t{}\t{:.4}\t{:.4}\t{}\t{}\n",
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
        ));
    }
    let fit_options = FitOptions {
        bootstrap_resamples: a.bootstrap,
        seed: spec.seed,
        ..FitOptions::default()
    };
    let fit = fit_session(&session, &fit_options).map_err(|e| format!("the fit: {e}"))?;
    let table = threshold_table(&session, &fit).map_err(|e| format!("the table: {e}"))?;

    let write = |name: String, body: String| {
        let p = dir.join(name);
        std::fs::write(&p, body).map_err(|e| format!("{}: {e}", p.display()))
    };
    write("trials.tsv".into(), tsv)?;
    let file = psychophysics::participant::ParticipantThresholds::new(
        &a.participant,
        session.is_synthetic(),
        fit.model(),
        table,
    );
    let ron_text = ron::ser::to_string_pretty(&file, ron::ser::PrettyConfig::default())
        .map_err(|e| e.to_string())?;
    write(
        format!("thresholds-{}.ron", a.participant),
        format!(
            "// SYNTHETIC: measured from a simulated observer ({}), not a person.\n{ron_text}\n",
            observer_path.display()
        ),
    )?;
    let fit_file = FitFile {
        synthetic: session.is_synthetic(),
        fit: &fit,
        conditions: session.results(),
    };
    write(
        format!("fit-{}.json", a.participant),
        serde_json::to_string_pretty(&fit_file).map_err(|e| e.to_string())?,
    )?;
    let png = dir.join(format!("thresholds-{}.png", a.participant));
    let points: Vec<crate::plots::ThresholdPoint> = session
        .results()
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
        "fit: CT0 {:.4} [{:.4}, {:.4}], α {:.4} [{:.4}, {:.4}], e2 {:.2}° [{:.2}, {:.2}] ({:.0} % bootstrap intervals, {} resamples)\nhollow circles: censored (beyond the display's contrast), left out of the fit; bars: ±1.96 sd of each QUEST estimate",
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
    );
    crate::plots::draw_thresholds(
        &png,
        &a.participant,
        session.is_synthetic(),
        &fit.model(),
        &fit_note,
        &points,
    )
    .map_err(|e| format!("{}: cannot draw the plot: {e}", png.display()))?;
    let info = SessionInfo {
        synthetic: session.is_synthetic(),
        note: "a simulated observer answered every trial; no person has yet run this procedure",
        software: format!("gazecast {}", env!("CARGO_PKG_VERSION")),
        participant: &a.participant,
        observer_file: observer_path.display().to_string(),
        observer: *observer.spec(),
        design: &spec,
        display: &display,
        transfer: transfer.kind(),
        max_contrast,
        sigma_deg: a.sigma_deg,
        background_level: a.background_level,
        fit_options,
        trials: session.records().len(),
        invalid_trials: session.records().iter().filter(|r| !r.valid).count(),
    };
    write(
        "session.json".into(),
        serde_json::to_string_pretty(&info).map_err(|e| e.to_string())?,
    )?;
    let m = fit.model();
    writeln!(
        out,
        "SYNTHETIC {}: {} trials; CT0 {:.4} [{:.4}, {:.4}], alpha {:.4} [{:.4}, {:.4}], e2 {:.3} [{:.3}, {:.3}] deg ({} of {} conditions fitted)",
        dir.display(),
        session.records().len(),
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
