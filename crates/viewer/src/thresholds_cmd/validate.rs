//! `gazecast thresholds validate`: Luebke & Hallen's §6.2 validation — can
//! a participant tell the rendering simplified at their own thresholds
//! (`simplify` with `--thresholds FILE`) from the full one (`full`)?
//!
//! Each trial shows one scene twice, rendered for the same gaze: once
//! `full`, once `simplify` at the participant's thresholds, in the order of
//! `psychophysics::validation`'s seeded, balanced schedule; the answer is
//! which interval was simplified. The analysis is the proportion correct
//! against chance (0.5) with an exact Clopper–Pearson interval and a
//! one-sided exact binomial test.
//!
//! **Headless only** (`--headless --simulate-observer FILE`): the gaze is
//! the fixation point (the display's eye point), so each scene's two frames
//! are the same in every trial and are rendered once per scene; the
//! simulated observer answers by how visible the difference between them
//! is to its own Geisler–Perry CSF (`psychophysics::validation`'s model).
//! Everything written is marked synthetic. **The windowed form (a person
//! answering, the frames rendered for the tracker's gaze) is not built**:
//! without `--headless` the command says so and writes nothing.
//!
//! The folder `OUT/sub-<ID>/` holds `trials.tsv` (a row per trial, written
//! as it happens) and `validation.json` (the design, each scene's frames
//! and visibility, the analysis). An existing folder is never overwritten.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use pipeline::{BackendChoice, Method, Options, Renderer};
use psychophysics::luminance::{Transfer, TransferKind};
use psychophysics::observer::ObserverSpec;
use psychophysics::validation::{
    analyse, difference_visibility, frame_luminance, DifferenceVisibility, ValidationDesign,
    ValidationResult,
};
use raycast::Camera;
use serde::Serialize;

use super::{create_session_folder, load_observer, read_transfer, software, write_file};

#[derive(Debug, Clone, clap::Args)]
pub struct ValidateArgs {
    /// No window: the simulated observer answers every trial. Required:
    /// the windowed validation is not built.
    #[arg(long)]
    pub headless: bool,
    /// The simulated observer (RON, psychophysics::observer::ObserverSpec):
    /// its CSF is its true sensitivity. A model, not a person: everything
    /// written is marked synthetic.
    #[arg(long, value_name = "FILE.ron")]
    pub simulate_observer: Option<PathBuf>,
    /// The windowed form's tracker. Not built: refused with a message.
    #[arg(long, value_name = "FILE.ron")]
    pub tracker: Option<PathBuf>,
    /// The participant's thresholds (`thresholds-<ID>.ron` from
    /// `thresholds measure`): `simplify` folds by them.
    #[arg(long, value_name = "FILE.ron")]
    pub thresholds: PathBuf,
    /// A scene (RON); repeat for several. Each is shown in --trials trials.
    #[arg(long = "scene", value_name = "FILE.ron", required = true)]
    pub scenes: Vec<PathBuf>,
    /// Display file (RON): the geometry the frames are rendered for.
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Photometer readings (RON) the observer's luminance comes from;
    /// default: the documented γ 2.2 curve (0.5–100 cd/m²).
    #[arg(long, value_name = "FILE.ron")]
    pub luminance_table: Option<PathBuf>,
    /// Trials per scene: even (half with the simplified rendering first), ≥ 2.
    #[arg(long, value_name = "N", default_value_t = 40)]
    pub trials: u32,
    /// Level of the binomial interval, in (0, 1).
    #[arg(long, value_name = "P", default_value_t = 0.95)]
    pub ci_level: f64,
    /// Seed of the trial order.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Participant id (letters, digits, '-', '_'); names the folder.
    #[arg(long, value_name = "ID")]
    pub participant: String,
    /// The session folder goes to OUT/sub-<ID>; it must not exist yet.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// One scene's two frames, rendered for the gaze, and how visible their
/// difference is to the observer.
#[derive(Debug, Clone, Serialize)]
struct SceneFrames {
    scene: String,
    /// Triangles the simplified frame drew, of the scene's.
    simplified_triangles_drawn: Option<usize>,
    scene_triangles: usize,
    visibility: DifferenceVisibility,
    /// The observer's probability of naming the simplified interval.
    p_correct: f64,
}

/// `validation.json`.
#[derive(Serialize)]
struct ValidationFile<'a> {
    synthetic: bool,
    note: &'static str,
    software: String,
    participant: &'a str,
    thresholds_file: String,
    thresholds: String,
    thresholds_synthetic: bool,
    observer_file: String,
    observer: ObserverSpec,
    observer_model: &'static str,
    display: &'a foveation::Display,
    transfer: TransferKind,
    gaze_px: [f64; 2],
    gaze: &'static str,
    backend: &'static str,
    design: &'a ValidationDesign,
    scenes: &'a [SceneFrames],
    clocks: &'static str,
    analysis: ValidationResult,
}

const NOTE: &str = "SYNTHETIC: a simulated observer answered every trial (headless, the gaze at \
                    the fixation point); no person has run this validation";
const MODEL: &str = "Peli (1990) band-limited contrast of the two frames' luminance difference: \
                     octave difference-of-Gaussian bands (sigma 0.5, 1, 2, ... px) over the local \
                     mean luminance, normalised to a grating's contrast at the band's peak \
                     frequency; each pixel's and band's log10(c / CT(f, e)) against the observer's \
                     Geisler-Perry threshold at its eccentricity from the gaze; the largest \
                     through the observer's Weibull psychometric function (max rule; \
                     psychophysics::validation)";
const CLOCKS: &str = "rt_simulated_ms: drawn from the simulated observer's response-time \
                      distribution, on no clock; onset_host_us, response_host_us: this process's \
                      host monotonic clock in the windowed form, n/a headless (no window, no clock)";
const TRIALS_HEADER: &str = "trial\tscene\tsimplified_interval\tchosen_interval\tcorrect\t\
                             rt_simulated_ms\tp_correct\tonset_host_us\tresponse_host_us\n";

/// Everything read and checked before the folder is made.
struct Loaded {
    display: foveation::Display,
    geometry: foveation::ScreenGeometry,
    transfer: Transfer,
    thresholds: crate::args::Thresholds,
    design: ValidationDesign,
    scenes: Vec<raycast::scene::Scene>,
}

impl Loaded {
    fn read(a: &ValidateArgs) -> Result<Self, String> {
        let display = crate::config::load_display(&a.display).map_err(|e| e.to_string())?;
        let geometry = display.geometry().map_err(|e| e.to_string())?;
        let transfer = read_transfer(a.luminance_table.as_deref())?;
        let thresholds = crate::args::Thresholds::load(&a.thresholds)?;
        let design = ValidationDesign {
            scenes: a.scenes.iter().map(|p| p.display().to_string()).collect(),
            trials_per_scene: a.trials,
            ci_level: a.ci_level,
            seed: a.seed,
        };
        design.validate().map_err(|e| {
            let flag = match e.field {
                "trials_per_scene" => "--trials",
                "ci_level" => "--ci-level",
                "scenes" => "--scene",
                other => other,
            };
            format!("{flag} {}: {}", e.value, e.reason)
        })?;
        let scenes = a
            .scenes
            .iter()
            .map(|p| crate::config::load_scene(p))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some((p, _)) = a.scenes.iter().zip(&scenes).find(|(_, s)| s.is_moving()) {
            return Err(format!(
                "--scene {}: a moving scene; the validation shows still scenes",
                p.display()
            ));
        }
        Ok(Self {
            display,
            geometry,
            transfer,
            thresholds,
            design,
            scenes,
        })
    }

    /// A scene rendered by `method` for `gaze` on the CPU (the simplified
    /// one at the participant's thresholds): the frame's RGB and the
    /// triangles drawn.
    fn render(
        &self,
        scene: &raycast::scene::Scene,
        method: Method,
        gaze: [f64; 2],
    ) -> Result<(Vec<u8>, Option<usize>), String> {
        let model =
            crate::args::sampling_model_for(self.geometry, 1.0, 0.0, Some(&self.thresholds))?;
        let options = Options {
            method,
            backend: BackendChoice::Cpu,
            ..Options::default()
        };
        let mut r = Renderer::new(scene, Camera::new(&self.geometry), model, &options)
            .map_err(|e| format!("{}: {e}", method.name()))?;
        self.thresholds.apply(&mut r);
        let (frame, _) = r
            .render(gaze)
            .map_err(|e| format!("{}: {e}", method.name()))?;
        let drawn = r.model_based().map(|m| m.last().triangles_drawn);
        Ok((frame.rgb, drawn))
    }
}

/// Runs the validation.
pub fn run(a: &ValidateArgs, out: &mut dyn Write) -> Result<(), String> {
    experiment::design::check_id(&a.participant).map_err(|e| format!("--participant {e}"))?;
    if !a.headless {
        return Err(format!(
            "thresholds validate: the windowed form (a person answering, frames rendered for the \
             tracker's gaze{}) is not built; run --headless --simulate-observer FILE.ron",
            a.tracker
                .as_ref()
                .map_or(String::new(), |t| format!(", --tracker {}", t.display()))
        ));
    }
    if let Some(t) = &a.tracker {
        return Err(format!(
            "--tracker {}: the headless validation has no gaze (it is the fixation point)",
            t.display()
        ));
    }
    let Some(observer_path) = &a.simulate_observer else {
        return Err("--headless needs --simulate-observer FILE.ron (who answers?)".into());
    };
    let mut observer = load_observer(observer_path)?;
    let loaded = Loaded::read(a)?;
    let schedule = loaded.design.schedule().map_err(|e| e.to_string())?;
    let gaze = loaded.geometry.eye_point_px;

    // Each scene's frames, once: the gaze does not move headless.
    let mut frames = Vec::new();
    for (path, scene) in a.scenes.iter().zip(&loaded.scenes) {
        let what = |e: String| format!("--scene {}: {e}", path.display());
        let (full, _) = loaded.render(scene, Method::Full, gaze).map_err(what)?;
        let (simple, drawn) = loaded.render(scene, Method::Simplify, gaze).map_err(what)?;
        let visibility = difference_visibility(
            &frame_luminance(&full, &loaded.transfer),
            &frame_luminance(&simple, &loaded.transfer),
            &loaded.geometry,
            gaze,
            &observer.spec().csf,
        )
        .map_err(|e| what(e.to_string()))?;
        frames.push(SceneFrames {
            scene: path.display().to_string(),
            simplified_triangles_drawn: drawn,
            scene_triangles: scene.triangles.len(),
            p_correct: observer.p_correct_at(visibility.log10_over_threshold()),
            visibility,
        });
    }

    let dir = create_session_folder(&a.out, &a.participant)?;
    let trials_path = dir.join("trials.tsv");
    let mut tsv = BufWriter::new(
        File::create(&trials_path).map_err(|e| format!("{}: {e}", trials_path.display()))?,
    );
    let mut correct = 0u32;
    let mut row = |line: String| {
        tsv.write_all(line.as_bytes())
            .and_then(|()| tsv.flush())
            .map_err(|e| format!("{}: {e}", trials_path.display()))
    };
    row(TRIALS_HEADER.to_string())?;
    for t in &schedule {
        let Some(k) = loaded.design.scenes.iter().position(|s| *s == t.scene) else {
            return Err(format!(
                "trial {}: scene {} not in the design",
                t.index, t.scene
            ));
        };
        let f = &frames[k];
        let r = observer
            .respond_at(f.visibility.log10_over_threshold())
            .map_err(|e| format!("trial {}: {e}", t.index))?
            .0;
        let chosen = if r.correct {
            t.simplified_interval
        } else {
            1 - t.simplified_interval
        };
        correct += u32::from(r.correct);
        row(format!(
            "{}\t{}\t{}\t{}\t{}\t{:.1}\t{:.4}\tn/a\tn/a\n",
            t.index,
            t.scene,
            t.simplified_interval + 1,
            chosen + 1,
            u8::from(r.correct),
            r.rt_ms,
            f.p_correct,
        ))?;
    }
    let analysis = analyse(schedule.len() as u32, correct, a.ci_level)
        .map_err(|e| format!("the analysis: {e}"))?;
    let file = ValidationFile {
        synthetic: true,
        note: NOTE,
        software: software(),
        participant: &a.participant,
        thresholds_file: a.thresholds.display().to_string(),
        thresholds: loaded.thresholds.source(),
        thresholds_synthetic: loaded.thresholds.file.synthetic,
        observer_file: observer_path.display().to_string(),
        observer: *observer.spec(),
        observer_model: MODEL,
        display: &loaded.display,
        transfer: loaded.transfer.kind(),
        gaze_px: gaze,
        gaze: "the fixation point (the display's eye point): headless, the gaze does not move",
        backend: "cpu",
        design: &loaded.design,
        scenes: &frames,
        clocks: CLOCKS,
        analysis,
    };
    write_file(
        &dir,
        "validation.json",
        &serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?,
    )?;
    for f in &frames {
        writeln!(
            out,
            "{}: simplified drew {} of {} triangles; {} pixels differ, most visible {} (log10 contrast over the observer's threshold), P(correct) {:.3}",
            f.scene,
            f.simplified_triangles_drawn.map_or("n/a".into(), |n| n.to_string()),
            f.scene_triangles,
            f.visibility.differing_pixels,
            f.visibility
                .max_log10_over_threshold
                .map_or("none".into(), |v| format!("{v:.3}")),
            f.p_correct,
        )
        .map_err(|e| e.to_string())?;
    }
    writeln!(
        out,
        "SYNTHETIC {}: {} of {} correct ({:.3}), {:.0} % CI [{:.3}, {:.3}], one-sided p vs 0.5 = {:.4}; {}",
        dir.display(),
        analysis.correct,
        analysis.trials,
        analysis.proportion_correct,
        analysis.ci_level * 100.0,
        analysis.ci_low,
        analysis.ci_high,
        analysis.p_value,
        if analysis.above_chance {
            "above chance: the simulated observer could tell"
        } else {
            "not shown above chance"
        }
    )
    .map_err(|e| e.to_string())
}
