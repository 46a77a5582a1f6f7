//! Values more than one command line takes, each parsed in one place and
//! converted to its library type in one place. Not a command module:
//! command modules may use it, never each other.

use raycast::ray::TriangleTest;
use raycast::scene::Accel;
use tracker_hal::calibration::{Order, Plan, PlanError, SessionPlan};

/// `X,Y`: a point in screen pixels (`--gaze`), both finite.
pub fn parse_point(s: &str) -> Result<[f64; 2], String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected X,Y (e.g. 640,512)"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|f| f.is_finite())
            .ok_or_else(|| format!("`{v}` in `{s}` is not a finite number"))
    };
    Ok([num(x)?, num(y)?])
}

/// `--budget N`: a triangle budget, a whole number from 1 to
/// [`pipeline::model_based::MAX_TRIANGLE_BUDGET`].
pub fn parse_budget(s: &str) -> Result<usize, String> {
    let max = pipeline::model_based::MAX_TRIANGLE_BUDGET;
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: expected a whole number of triangles from 1 to {max}"))?;
    if !(1..=max).contains(&n) {
        return Err(format!("`{s}`: must be from 1 to {max} triangles"));
    }
    Ok(n)
}

/// The live loops' default gaze tolerance (`view`, `demo`), degrees: the
/// accuracy eye trackers of the seeds' kind state (about 0.5°, e.g. the
/// Tobii ET-1750), so a mask is trusted no further than the tracker is.
pub const LIVE_GAZE_TOLERANCE_DEG: f64 = 0.5;

/// `--gaze-tolerance DEG`: the sampling model's gaze tolerance
/// (`foveation::SamplingModel::gaze_tolerance_deg`), 0 to
/// [`foveation::sampling::MAX_GAZE_TOLERANCE_DEG`] degrees.
pub fn parse_gaze_tolerance(s: &str) -> Result<f64, String> {
    let max = foveation::sampling::MAX_GAZE_TOLERANCE_DEG;
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|d| d.is_finite() && (0.0..=max).contains(d))
        .ok_or_else(|| format!("`{s}`: expected an angle from 0 to {max} degrees"))
}

/// The sampling model for a display and contrast with the hybrid method's
/// gaze tolerance (degrees; 0 for none); errors name the option.
pub fn sampling_model(
    geometry: foveation::ScreenGeometry,
    contrast: f64,
    gaze_tolerance_deg: f64,
) -> Result<foveation::SamplingModel, String> {
    let flag = |e: foveation::ParamError| format!("--{}: {e}", e.field.replace('_', "-"));
    pipeline::sampling_model(geometry, contrast)
        .map_err(flag)?
        .with_gaze_tolerance_deg(gaze_tolerance_deg)
        .map_err(|e| format!("--gaze-tolerance: {e}"))
}

/// The model-based methods' options (`render`, `view`, `demo`).
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct ModelBasedArgs {
    /// `--method simplify` only: Luebke & Hallen's best-effort mode, at
    /// most N triangles (1 to 10^9), most perceptible fold undone first;
    /// reports the viewing distance at which the folds left become
    /// imperceptible.
    #[arg(long, value_name = "TRIANGLES", value_parser = parse_budget)]
    pub budget: Option<usize>,
    /// Model-based methods only: select without the gaze (eccentricity 0
    /// everywhere, every node foveal).
    #[arg(long)]
    pub no_gaze: bool,
}

impl ModelBasedArgs {
    /// Checks the options against `method` (as the renderer will); an
    /// error names the flag at fault.
    pub fn check(self, method: pipeline::Method) -> Result<(), String> {
        use pipeline::model_based::{ModelBasedOptions, ModelBasedSetting};
        ModelBasedOptions::from(self).validate(method).map_err(|e| {
            let flag = match e.setting() {
                ModelBasedSetting::Budget => "--budget",
                ModelBasedSetting::IgnoreGaze => "--no-gaze",
            };
            format!("{flag}: {e}")
        })
    }
}

impl From<ModelBasedArgs> for pipeline::model_based::ModelBasedOptions {
    fn from(a: ModelBasedArgs) -> Self {
        Self {
            budget: a.budget,
            ignore_gaze: a.no_gaze,
        }
    }
}

/// `--accel`: the acceleration structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelArg {
    /// Binned-SAH BVH.
    Bvh,
    /// The seed's uniform grid (Murphy 2007 §6.1.1), for comparison.
    Grid,
}

impl AccelArg {
    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            AccelArg::Bvh => "bvh",
            AccelArg::Grid => "grid",
        }
    }
}

impl From<AccelArg> for Accel {
    fn from(a: AccelArg) -> Self {
        match a {
            AccelArg::Bvh => Accel::Bvh,
            AccelArg::Grid => Accel::Grid,
        }
    }
}

/// `--intersector`: the ray/triangle test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Intersector {
    /// Woop, Benthin & Wald 2013's watertight test: no ray slips between triangles sharing an edge.
    Watertight,
    /// Möller–Trumbore (Murphy 2007, Algorithm 4.2), for comparison.
    MollerTrumbore,
}

impl From<Intersector> for TriangleTest {
    fn from(i: Intersector) -> Self {
        match i {
            Intersector::Watertight => TriangleTest::Watertight,
            Intersector::MollerTrumbore => TriangleTest::MollerTrumbore,
        }
    }
}

/// `--overlay`: what to draw over the frame whatever the scene asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Overlay {
    /// The seed's POR box around the point of regard.
    Por,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn points_parse_or_say_what_is_wrong() {
        assert_eq!(parse_point("640,512"), Ok([640.0, 512.0]));
        assert_eq!(parse_point(" 1.5 , -2 "), Ok([1.5, -2.0]));
        assert!(parse_point("640").unwrap_err().contains("expected X,Y"));
        assert!(parse_point("1,nan")
            .unwrap_err()
            .contains("not a finite number"));
        assert!(parse_point("inf,1").is_err());
        assert!(parse_point("").is_err());
    }

    #[test]
    fn budgets_parse_or_say_what_is_wrong() {
        assert_eq!(parse_budget("1"), Ok(1));
        assert_eq!(parse_budget(" 5000 "), Ok(5000));
        assert_eq!(parse_budget("1000000000"), Ok(1_000_000_000));
        for bad in [
            "0",
            "-3",
            "1.5",
            "",
            "lots",
            "1000000001",
            "99999999999999999999999",
        ] {
            let e = parse_budget(bad).expect_err(bad);
            assert!(e.contains("from 1 to"), "{bad}: {e}");
        }
    }

    #[test]
    fn each_value_converts_to_its_library_type_and_named_as_on_the_command_line() {
        for a in AccelArg::value_variants() {
            let spelled = a.to_possible_value().expect("visible");
            assert_eq!(spelled.get_name(), a.name());
        }
        assert_eq!(Accel::from(AccelArg::Bvh), Accel::Bvh);
        assert_eq!(Accel::from(AccelArg::Grid), Accel::Grid);
        assert_eq!(
            TriangleTest::from(Intersector::Watertight),
            TriangleTest::Watertight
        );
        assert_eq!(
            TriangleTest::from(Intersector::MollerTrumbore),
            TriangleTest::MollerTrumbore
        );
    }
}

/// The targets of a calibration run and of its validation (`gazecast
/// calibrate`, and `gazecast simulate --script calibration`, which must
/// follow the same targets).
#[derive(Debug, Clone, clap::Args)]
pub struct PlanArgs {
    /// Calibration targets: 5 (the centre and the corners) or a square
    /// number (4, 9, 16, …), 10 % in from the edges.
    #[arg(long, default_value_t = 9, value_name = "N")]
    pub points: usize,
    /// Validation targets: a square number, 25 % in from the edges (between
    /// the calibration targets).
    #[arg(long, default_value_t = 4, value_name = "N")]
    pub validation_points: usize,
    /// Ignored at the start of each target (the saccade, settling).
    #[arg(long, default_value_t = 400, value_name = "MS")]
    pub settle_ms: u32,
    /// Collected per target after settling.
    #[arg(long, default_value_t = 800, value_name = "MS")]
    pub collect_ms: u32,
    /// Show the targets in a seeded shuffle instead of row by row.
    #[arg(long, value_name = "SEED")]
    pub shuffle: Option<u64>,
}

impl PlanArgs {
    /// The session plan these options describe.
    pub fn session_plan(&self) -> SessionPlan {
        SessionPlan {
            points: self.points,
            validation_points: self.validation_points,
            settle_ms: self.settle_ms,
            collect_ms: self.collect_ms,
            order: self
                .shuffle
                .map_or(Order::RowMajor, |seed| Order::Shuffled { seed }),
        }
    }

    /// The target counts have the design file's bounds (5 or a square
    /// number, at most 25): a million targets would calibrate until killed.
    /// `calibrate` checks them before it loads anything; every command
    /// that makes plans (`simulate --script calibration` too) through
    /// [`Self::plans`].
    pub fn check_counts(&self) -> Result<(), String> {
        use experiment::design::{check_points, MAX_CALIBRATION_POINTS, MAX_VALIDATION_POINTS};
        for (flag, n, max) in [
            ("--points", self.points, MAX_CALIBRATION_POINTS),
            (
                "--validation-points",
                self.validation_points,
                MAX_VALIDATION_POINTS,
            ),
        ] {
            let n = u32::try_from(n).unwrap_or(u32::MAX);
            check_points(n, max).map_err(|m| format!("{flag} {m}"))?;
        }
        Ok(())
    }

    /// (calibration plan, validation plan) on a `w × h` px screen; errors
    /// name the option to change.
    pub fn plans(&self, screen_px: (u32, u32)) -> Result<(Plan, Plan), String> {
        self.check_counts()?;
        self.session_plan()
            .plans(screen_px)
            .map_err(|e| match e {
                PlanError::Timing {
                    settle_ms,
                    collect_ms,
                } => format!(
                    "--collect-ms {collect_ms} must be in [100, 10000] and --settle-ms {settle_ms} at most 10000"
                ),
                PlanError::Calibration(e) => format!("--points: {e}"),
                PlanError::Validation(e) => format!("--validation-points: {e}"),
            })
    }
}

/// `--lsl` and `--lsl-wait` (`view`, `demo`, `experiment run`).
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct LslArgs {
    /// Publish Lab Streaming Layer streams: the gaze (every sample, at its
    /// capture time), a marker per presented frame and, in an experiment,
    /// the session's markers (see the `lsl_out` module for names and
    /// channels). Needs the cargo feature `lsl` (on by default).
    #[arg(long)]
    pub lsl: bool,
    /// With --lsl: before the session starts, wait up to SECONDS for a
    /// consumer (e.g. LabRecorder) on every stream; LSL delivers a consumer
    /// only what is pushed after it connected.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, requires = "lsl",
          value_parser = parse_lsl_wait)]
    pub lsl_wait: f64,
}

/// `--lsl-wait SECONDS`: 0 to 600.
pub fn parse_lsl_wait(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|d| d.is_finite() && (0.0..=600.0).contains(d))
        .ok_or_else(|| format!("`{s}`: expected seconds from 0 to 600"))
}

impl LslArgs {
    /// Refuses --lsl at once when this gazecast was built without LSL.
    pub fn check(&self) -> Result<(), String> {
        if self.lsl && !crate::lsl_out::BUILT_IN {
            return Err("--lsl: this gazecast was built without LSL (cargo feature `lsl` of gazecast-viewer)".into());
        }
        Ok(())
    }

    /// The outlets' options for `command` (`view`, `demo`, `experiment`),
    /// `None` without --lsl.
    pub fn options(
        &self,
        command: &str,
        source_suffix: String,
        events: bool,
    ) -> Option<crate::lsl_out::LslOptions> {
        self.lsl.then(|| crate::lsl_out::LslOptions {
            command: command.into(),
            source_suffix,
            wait_s: self.lsl_wait,
            events,
        })
    }
}

/// `--method`: every method `pipeline` knows, built in or registered, by
/// its key or an alias, each with its help — taken from
/// [`pipeline::Method::all`], so a registered method needs no line here.
pub fn method_parser() -> impl clap::builder::TypedValueParser<Value = pipeline::Method> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(pipeline::Method::all().map(|m| {
        PossibleValue::new(m.name())
            .aliases(m.aliases().iter().copied())
            .help(m.help())
    }))
    .try_map(|s| s.parse::<pipeline::Method>().map_err(|e| e.to_string()))
}

/// `--backend`: [`pipeline::BackendChoice::ALL`], each with its help.
pub fn backend_parser() -> impl clap::builder::TypedValueParser<Value = pipeline::BackendChoice> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        pipeline::BackendChoice::ALL
            .iter()
            .map(|(_, name, help)| PossibleValue::new(*name).help(*help)),
    )
    .try_map(|s| s.parse::<pipeline::BackendChoice>())
}

/// `--thresholds FILE`: a participant's measured thresholds
/// (`render`, `view`, `demo`, `bench`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ThresholdsArg {
    /// A participant's contrast thresholds: the `thresholds-<ID>.ron` that
    /// `gazecast thresholds measure` writes (the measured table and the
    /// fitted Geisler–Perry CT0, α, e2). `simplify` judges its folds by the
    /// table (the fitted model outside its grid); the hybrid, image and
    /// layers methods build their ray masks from the fitted parameters.
    /// Default: the Geisler–Perry model (CT0 1/64, α 0.106, e2 2.3°).
    #[arg(long, value_name = "FILE.ron")]
    pub thresholds: Option<std::path::PathBuf>,
}

impl ThresholdsArg {
    /// The file, loaded and checked; `None` without the flag.
    pub fn load(&self) -> Result<Option<Thresholds>, String> {
        self.thresholds.as_deref().map(Thresholds::load).transpose()
    }
}

/// A participant's thresholds as a renderer uses them.
#[derive(Debug, Clone)]
pub struct Thresholds {
    /// The file they came from.
    pub path: std::path::PathBuf,
    /// Its contents.
    pub file: psychophysics::participant::ParticipantThresholds,
    /// The table `simplify` judges folds by: the measured one inside its
    /// grid, the fitted model outside it.
    pub table: foveation::perceptibility::ThresholdTable,
}

impl Thresholds {
    /// Reads `path`; a malformed or invalid file is an error naming the
    /// file, the line and the field.
    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let (file, text): (psychophysics::participant::ParticipantThresholds, String) =
            crate::config::load(path).map_err(|e| e.to_string())?;
        let invalid = |e: foveation::ParamError| {
            crate::config::invalid_field(
                path,
                &text,
                e.field,
                format!("{} ({})", e.reason, e.value),
            )
            .to_string()
        };
        file.validate().map_err(invalid)?;
        let table = file.renderer_table().map_err(invalid)?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            table,
        })
    }

    /// Where the thresholds came from, as `explain` says it.
    pub fn source(&self) -> String {
        format!("{}: {}", self.path.display(), self.file.summary())
    }

    /// Gives `renderer` the table (its sampling model must already carry
    /// the fitted CSF: [`sampling_model_for`]).
    pub fn apply(&self, renderer: &mut pipeline::Renderer<'_>) {
        renderer.set_thresholds(self.table.clone(), self.source());
    }

    /// The `--stats` JSON's account of them.
    pub fn report(&self) -> ThresholdsReport {
        ThresholdsReport {
            source: self.path.display().to_string(),
            participant: Some(self.file.participant.clone()),
            synthetic: self.file.synthetic,
            ct0: self.file.geisler_perry.ct0,
            alpha: self.file.geisler_perry.alpha,
            e2_deg: self.file.geisler_perry.e2_deg,
        }
    }
}

/// Which thresholds a render used (`render --stats`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct ThresholdsReport {
    /// `default` (the Geisler–Perry model) or the file given.
    pub source: String,
    /// The file's participant.
    pub participant: Option<String>,
    /// True when the file's answers came from a simulated observer.
    pub synthetic: bool,
    /// The Geisler–Perry parameters the sampling model used.
    pub ct0: f64,
    /// Geisler–Perry α, the spatial-frequency decay constant.
    pub alpha: f64,
    /// Geisler–Perry e2, the half-resolution eccentricity, degrees.
    pub e2_deg: f64,
}

impl ThresholdsReport {
    /// The default model's.
    pub fn default_model() -> Self {
        let m = foveation::GeislerPerry::default();
        Self {
            source: "default".into(),
            participant: None,
            synthetic: false,
            ct0: m.ct0,
            alpha: m.alpha,
            e2_deg: m.e2_deg,
        }
    }
}

/// [`sampling_model`] with a participant's fitted CSF when there is one.
pub fn sampling_model_for(
    geometry: foveation::ScreenGeometry,
    contrast: f64,
    gaze_tolerance_deg: f64,
    thresholds: Option<&Thresholds>,
) -> Result<foveation::SamplingModel, String> {
    let Some(t) = thresholds else {
        return sampling_model(geometry, contrast, gaze_tolerance_deg);
    };
    let flag = |e: foveation::ParamError| {
        format!(
            "--{} with --thresholds {}: {e}",
            e.field.replace('_', "-"),
            t.path.display()
        )
    };
    pipeline::sampling_model_with(geometry, t.file.geisler_perry, contrast)
        .map_err(flag)?
        .with_gaze_tolerance_deg(gaze_tolerance_deg)
        .map_err(|e| format!("--gaze-tolerance: {e}"))
}
