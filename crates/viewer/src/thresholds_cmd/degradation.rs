//! `gazecast thresholds degradation`: Murphy & Duchowski's degradation
//! staircase (2001, §6.2; `psychophysics::degradation`): for each depth
//! (the scene's objects moved along the line of sight until they subtend
//! 26°, 24°, 22°, 20°, 18°) and each eccentricity of a grid, a staircase
//! over the `lod` method's levels; from the thresholds, a Table-1-style
//! degradation table (`foveation::degradation::DegradationTable`, RON).
//!
//! A trial is a two-interval choice rendered by the `lod` method on the
//! CPU for one gaze (the display's eye point, on which the object is
//! centred): in one interval the object at full resolution (level 5
//! everywhere), in the other at full resolution within `e` of the gaze
//! and at the staircase's level beyond (a degradation table whose every
//! row is that step, `lod::Mode::MurphyDuchowskiTable`); the interval is
//! drawn at random (seeded). The simulated observer names the degraded
//! interval with the probability its psychometric function gives the
//! visibility of the two frames' difference — `psychophysics::validation`'s
//! Peli band-limited contrast against its Geisler–Perry CSF, as
//! `thresholds validate` does. Each (depth, eccentricity, level)'s frames
//! are rendered once and their visibility cached: the gaze does not move
//! headless.
//!
//! **Headless only** (`--headless --simulate-observer FILE`); everything
//! written is marked synthetic. **The windowed form is not built.**
//!
//! The folder `OUT/sub-<ID>/` holds `trials.tsv` (a row per trial, written
//! as it happens; times on a virtual clock), `degradation-<ID>.ron` (the
//! table) and `session.json` (what ran, every staircase's estimate). An
//! existing folder is never overwritten.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use foveation::degradation::{DegradationTable, DEPTH_SUBTENDED_DEG};
use glam::Vec3;
use pipeline::{BackendChoice, Method, Options, Renderer};
use psychophysics::degradation::{
    check_grid, table_row, LevelStaircase, LevelStaircaseParams, LevelThreshold, TableRow,
    FINEST_LEVEL,
};
use psychophysics::luminance::TransferKind;
use psychophysics::observer::ObserverSpec;
use psychophysics::validation::{difference_visibility, frame_luminance};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use raycast::{Camera, Scene, SceneFile};
use serde::Serialize;

use super::{create_session_folder, load_observer, read_transfer, software, write_file};

/// The default eccentricity grid, degrees.
const DEFAULT_ECCENTRICITIES: [f64; 7] = [0.0, 2.5, 5.0, 7.5, 10.0, 12.5, 15.0];
/// An extent no eccentricity reaches: "this level everywhere".
const EVERYWHERE_DEG: f64 = 180.0;
/// The virtual clock's fixed parts of a trial, ms: two intervals, the gap
/// between them, and the pause after the answer.
const INTERVAL_MS: f64 = 500.0;
const GAP_MS: f64 = 500.0;
const ITI_MS: f64 = 500.0;

#[derive(Debug, Clone, clap::Args)]
pub struct DegradationArgs {
    /// No window: the simulated observer answers every trial. Required:
    /// the windowed form is not built.
    #[arg(long)]
    pub headless: bool,
    /// The simulated observer (RON, psychophysics::observer::ObserverSpec).
    /// A model, not a person: everything written is marked synthetic.
    #[arg(long, value_name = "FILE.ron")]
    pub simulate_observer: Option<PathBuf>,
    /// The scene (RON, still): its objects, moved together along the line
    /// of sight to each depth.
    #[arg(long, value_name = "FILE.ron")]
    pub scene: PathBuf,
    /// Display file (RON): the geometry the frames are rendered for.
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Photometer readings (RON) the observer's luminance comes from;
    /// default: the documented γ 2.2 curve (0.5–100 cd/m²).
    #[arg(long, value_name = "FILE.ron")]
    pub luminance_table: Option<PathBuf>,
    /// The object's angular sizes (degrees), one depth each, 1 to 5 of
    /// them; default Murphy & Duchowski's 26,24,22,20,18.
    #[arg(long, value_name = "DEG,...", value_delimiter = ',')]
    pub depths: Vec<f64>,
    /// The eccentricity grid (degrees, increasing); default
    /// 0,2.5,5,7.5,10,12.5,15.
    #[arg(long, value_name = "DEG,...", value_delimiter = ',')]
    pub eccentricities: Vec<f64>,
    /// Correct answers in a row that make the level one finer (one wrong
    /// makes it coarser): 2 converges on 70.7 % correct.
    #[arg(long, value_name = "N", default_value_t = 2)]
    pub n_down: u32,
    /// Reversals that end a staircase.
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub max_reversals: u32,
    /// Trials that end a staircase (at most 1000).
    #[arg(long, value_name = "N", default_value_t = 40)]
    pub max_trials: u32,
    /// Reversals left out of the estimate.
    #[arg(long, value_name = "N", default_value_t = 2)]
    pub discard_reversals: u32,
    /// Seed of which interval holds the degraded object.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Participant id (letters, digits, '-', '_'); names the folder.
    #[arg(long, value_name = "ID")]
    pub participant: String,
    /// The session folder goes to OUT/sub-<ID>; it must not exist yet.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

const NOTE: &str = "SYNTHETIC: a simulated observer answered every trial (headless, the gaze at \
                    the fixation point); no person has run this staircase";
const MODEL: &str = "Peli (1990) band-limited contrast of the two frames' luminance difference \
                     against the observer's Geisler-Perry thresholds, the largest through its \
                     Weibull psychometric function (psychophysics::validation, as thresholds \
                     validate)";
const CLOCKS: &str = "onset_virtual_ms: a virtual clock, no host clock: each trial takes two \
                      500 ms intervals with a 500 ms gap, then the simulated response time, then \
                      a 500 ms pause; rt_simulated_ms is drawn from the simulated observer's \
                      response-time distribution";
const STIMULUS: &str = "two intervals rendered by the lod method (CPU raster) for the gaze at the \
                        display's eye point, the objects centred on it: full resolution (level 5 \
                        everywhere) against level 5 within the eccentricity and the staircase's \
                        level beyond it (lod::Mode::MurphyDuchowskiTable, every row that step)";
const TRIALS_HEADER: &str = "trial\tdepth\tsubtended_deg\teccentricity_deg\tlevel\t\
                             degraded_interval\tchosen_interval\tcorrect\tlog10_over_threshold\t\
                             p_correct\ttriangles_drawn\trt_simulated_ms\tonset_virtual_ms\n";

/// One staircase's outcome.
#[derive(Debug, Clone, Serialize)]
struct Condition {
    depth: usize,
    subtended_deg: f64,
    eccentricity_deg: f64,
    threshold: LevelThreshold,
    reversal_levels: Vec<u8>,
}

/// One level's frames at one condition.
#[derive(Debug, Clone, Copy)]
struct Seen {
    log10_over_threshold: f64,
    triangles_drawn: usize,
}

#[derive(Serialize)]
struct SessionFile<'a> {
    synthetic: bool,
    note: &'static str,
    software: String,
    participant: &'a str,
    procedure: &'static str,
    observer_file: String,
    observer: ObserverSpec,
    observer_model: &'static str,
    stimulus: &'static str,
    scene: String,
    display: &'a foveation::Display,
    transfer: TransferKind,
    gaze_px: [f64; 2],
    backend: &'static str,
    level_angle_deg: [f64; 5],
    staircase: LevelStaircaseParams,
    staircase_target_p: f64,
    estimator: &'static str,
    seed: u64,
    depths_subtended_deg: &'a [f64],
    eccentricities_deg: &'a [f64],
    conditions: &'a [Condition],
    table_rows: &'a [TableRow],
    table_file: String,
    clocks: &'static str,
}

const ESTIMATOR: &str = "x = mean coarseness (5 - level) at the reversals after the discarded \
                         ones; threshold level = 5 - floor(x), or level 1 when the proportion \
                         correct at level 1 over at least 4 trials is below the staircase's \
                         target (psychophysics::degradation)";

/// The scene's objects moved together along the line of sight through
/// the eye point until their bounding sphere subtends `subtended_deg`.
fn at_depth(
    file: &SceneFile,
    dir: &Path,
    eye: Vec3,
    centre: Vec3,
    radius: f32,
    subtended_deg: f64,
) -> Result<Scene, String> {
    let half = (subtended_deg / 2.0).to_radians();
    let distance = (f64::from(radius) / half.sin()) as f32;
    let target = eye - Vec3::Z * distance;
    let delta = target - centre;
    let mut moved = file.clone();
    for o in &mut moved.objects {
        o.translate_mm.0 += delta.x;
        o.translate_mm.1 += delta.y;
        o.translate_mm.2 += delta.z;
    }
    Scene::build(&moved, dir).map_err(|e| e.to_string())
}

/// The centre of the scene's triangles' bounding box and the radius of the
/// sphere about it that holds them.
fn bounds(scene: &Scene) -> Option<(Vec3, f32)> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for t in &scene.triangles {
        for p in t.p {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let c = 0.5 * (lo + hi);
    let r = scene
        .triangles
        .iter()
        .flat_map(|t| t.p)
        .map(|p| p.distance(c))
        .fold(0.0f32, f32::max);
    (r > 0.0).then_some((c, r))
}

/// The table row `lod` selects by for an object subtending `angle_deg`
/// (`lod::select`: the nearest of Murphy & Duchowski's 26°, 24°, 22°, 20°,
/// 18°, clamped to rows 0–4).
fn lod_row(angle_deg: f64) -> usize {
    ((26.0 - angle_deg) / 2.0).round().clamp(0.0, 4.0) as usize
}

/// A degradation table whose every row is full resolution within `e` and
/// `level` beyond (level 5: everywhere).
fn step_table(e: f64, level: u8) -> [[f64; 5]; 5] {
    let mut row = [EVERYWHERE_DEG; 5];
    for k in (level + 1..=FINEST_LEVEL).rev() {
        row[usize::from(FINEST_LEVEL - k)] = e;
    }
    [row; 5]
}

/// Runs the staircase.
pub fn run(a: &DegradationArgs, out: &mut dyn Write) -> Result<(), String> {
    experiment::design::check_id(&a.participant).map_err(|e| format!("--participant {e}"))?;
    if !a.headless {
        return Err(
            "thresholds degradation: the windowed form (a person answering) is not \
                    built; run --headless --simulate-observer FILE.ron"
                .into(),
        );
    }
    let Some(observer_path) = &a.simulate_observer else {
        return Err("--headless needs --simulate-observer FILE.ron (who answers?)".into());
    };
    let mut observer = load_observer(observer_path)?;
    let depths: Vec<f64> = if a.depths.is_empty() {
        DEPTH_SUBTENDED_DEG.to_vec()
    } else {
        a.depths.clone()
    };
    if depths.len() > 5 {
        return Err(format!(
            "--depths: {} given; at most 5 (the table's rows)",
            depths.len()
        ));
    }
    if let Some(d) = depths
        .iter()
        .find(|d| !(d.is_finite() && **d > 0.0 && **d < 90.0))
    {
        return Err(format!(
            "--depths {d}: must be finite and in (0, 90) degrees"
        ));
    }
    for (i, &d) in depths.iter().enumerate() {
        if let Some(&other) = depths[..i].iter().find(|&&o| lod_row(o) == lod_row(d)) {
            return Err(format!(
                "--depths {other} and {d}: both fall on the table's row {} (rows are 26°, 24°, \
                 22°, 20°, 18°, the nearest taken)",
                lod_row(d)
            ));
        }
    }
    let grid: Vec<f64> = if a.eccentricities.is_empty() {
        DEFAULT_ECCENTRICITIES.to_vec()
    } else {
        a.eccentricities.clone()
    };
    check_grid(&grid).map_err(|e| format!("--eccentricities {}: {}", e.value, e.reason))?;
    let params = LevelStaircaseParams {
        n_down: a.n_down,
        max_reversals: a.max_reversals,
        max_trials: a.max_trials,
        discard_reversals: a.discard_reversals,
        ..LevelStaircaseParams::default()
    };
    params.validate().map_err(|e| {
        let flag = match e.field {
            "n_down" => "--n-down",
            "max_reversals" => "--max-reversals",
            "max_trials" => "--max-trials",
            other => other,
        };
        format!("{flag} {}: {}", e.value, e.reason)
    })?;
    let display = crate::config::load_display(&a.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let transfer = read_transfer(a.luminance_table.as_deref())?;
    let scene = crate::config::load_scene(&a.scene)?;
    if scene.is_moving() {
        return Err(format!(
            "--scene {}: a moving scene; the staircase shows a still object",
            a.scene.display()
        ));
    }
    let (file, _): (SceneFile, String) =
        crate::config::load(&a.scene).map_err(|e| e.to_string())?;
    let scene_dir = a.scene.parent().unwrap_or(Path::new(".")).to_path_buf();
    let Some((centre, radius)) = bounds(&scene) else {
        return Err(format!("--scene {}: no triangles", a.scene.display()));
    };
    let camera = Camera::new(&geometry);
    let gaze = geometry.eye_point_px;

    let dir = create_session_folder(&a.out, &a.participant)?;
    let trials_path = dir.join("trials.tsv");
    let mut tsv = BufWriter::new(
        File::create(&trials_path).map_err(|e| format!("{}: {e}", trials_path.display()))?,
    );
    let mut row = |line: String| {
        tsv.write_all(line.as_bytes())
            .and_then(|()| tsv.flush())
            .map_err(|e| format!("{}: {e}", trials_path.display()))
    };
    row(TRIALS_HEADER.to_string())?;
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let mut clock_ms = 0.0;
    let mut trial = 0u32;
    let mut conditions = Vec::new();
    let mut rows = Vec::new();
    let mut extents = [[0.0; 5]; 5];
    for (d, &angle) in depths.iter().enumerate() {
        let moved = at_depth(&file, &scene_dir, camera.eye, centre, radius, angle)
            .map_err(|e| format!("--scene {} at {angle}°: {e}", a.scene.display()))?;
        let options = Options {
            method: Method::Lod,
            backend: BackendChoice::Cpu,
            ..Options::default()
        };
        let model = crate::args::sampling_model_for(geometry, 1.0, 0.0, None)?;
        let mut r =
            Renderer::new(&moved, camera, model, &options).map_err(|e| format!("lod: {e}"))?;
        let mut render = |table: [[f64; 5]; 5]| -> Result<(Vec<f64>, usize), String> {
            let m = r
                .model_based_mut()
                .ok_or("lod: not a model-based renderer")?;
            m.set_degradation(Some(table))?;
            let (frame, _) = r.render(gaze).map_err(|e| format!("lod: {e}"))?;
            let drawn = r.model_based().map_or(0, |m| m.last().triangles_drawn);
            Ok((frame_luminance(&frame.rgb, &transfer), drawn))
        };
        let (full, _) = render(step_table(0.0, FINEST_LEVEL))?;
        let mut levels = Vec::with_capacity(grid.len());
        for &e in &grid {
            let mut seen: HashMap<u8, Seen> = HashMap::new();
            let mut s = LevelStaircase::new(params).map_err(|e| e.to_string())?;
            while !s.is_finished() {
                let level = s.next_level();
                let v = match seen.get(&level) {
                    Some(v) => *v,
                    None => {
                        let (frame, drawn) = render(step_table(e, level))?;
                        let vis = difference_visibility(
                            &full,
                            &frame,
                            &geometry,
                            gaze,
                            &observer.spec().csf,
                        )
                        .map_err(|e| e.to_string())?;
                        let v = Seen {
                            log10_over_threshold: vis.log10_over_threshold(),
                            triangles_drawn: drawn,
                        };
                        seen.insert(level, v);
                        v
                    }
                };
                let degraded: u8 = rng.random_range(0..2);
                let answer = observer
                    .respond_at(v.log10_over_threshold)
                    .map_err(|e| format!("trial {trial}: {e}"))?
                    .0;
                let chosen = if answer.correct {
                    degraded
                } else {
                    1 - degraded
                };
                row(format!(
                    "{trial}\t{d}\t{angle}\t{e}\t{level}\t{}\t{}\t{}\t{}\t{:.4}\t{}\t{:.1}\t{:.1}\n",
                    degraded + 1,
                    chosen + 1,
                    u8::from(answer.correct),
                    if v.log10_over_threshold.is_finite() {
                        format!("{:.4}", v.log10_over_threshold)
                    } else {
                        "-inf".into()
                    },
                    observer.p_correct_at(v.log10_over_threshold),
                    v.triangles_drawn,
                    answer.rt_ms,
                    clock_ms,
                ))?;
                clock_ms += 2.0 * INTERVAL_MS + GAP_MS + answer.rt_ms + ITI_MS;
                trial += 1;
                s.update(answer.correct);
            }
            let threshold = s.threshold();
            levels.push(threshold.level);
            conditions.push(Condition {
                depth: d,
                subtended_deg: angle,
                eccentricity_deg: e,
                threshold,
                reversal_levels: s.reversal_levels(),
            });
        }
        let t = table_row(&grid, &levels).map_err(|e| e.to_string())?;
        rows.push(t);
    }
    // Each measured depth goes to the row lod picks for its angle
    // (nearest of 26°, 24°, …, 18°); a row not measured repeats the
    // nearest measured one (said in `source`).
    let mut filled = [None; 5];
    for (d, &angle) in depths.iter().enumerate() {
        filled[lod_row(angle)] = Some(d);
    }
    for (row, slot) in extents.iter_mut().enumerate() {
        let nearest = (0..5)
            .filter_map(|r| filled[r].map(|d| (r.abs_diff(row), d)))
            .min()
            .map(|(_, d)| d);
        if let Some(d) = nearest {
            *slot = rows[d].extents_deg;
        }
    }
    let unmeasured: Vec<String> = (0..5)
        .filter(|&r| filled[r].is_none())
        .map(|r| r.to_string())
        .collect();
    let table = DegradationTable {
        source: format!(
            "SYNTHETIC: gazecast thresholds degradation, participant {}, simulated observer {}, \
             depths {:?} degrees{}",
            a.participant,
            observer_path.display(),
            depths,
            if unmeasured.is_empty() {
                String::new()
            } else {
                format!(
                    "; rows {} not measured: each repeats the nearest measured row",
                    unmeasured.join(", ")
                )
            }
        ),
        synthetic: true,
        depth_subtended_deg: DEPTH_SUBTENDED_DEG,
        extents_deg: extents,
    };
    table
        .check()
        .map_err(|(f, m)| format!("the table: {f}: {m}"))?;
    let table_name = format!("degradation-{}.ron", a.participant);
    let ron_text = ron::ser::to_string_pretty(&table, ron::ser::PrettyConfig::default())
        .map_err(|e| e.to_string())?;
    write_file(&dir, &table_name, &format!("// {NOTE}\n{ron_text}\n"))?;
    let session = SessionFile {
        synthetic: true,
        note: NOTE,
        software: software(),
        participant: &a.participant,
        procedure: "Murphy & Duchowski 2001 §6.2: a staircase over the lod levels per depth and \
                    eccentricity (psychophysics::degradation)",
        observer_file: observer_path.display().to_string(),
        observer: *observer.spec(),
        observer_model: MODEL,
        stimulus: STIMULUS,
        scene: a.scene.display().to_string(),
        display: &display,
        transfer: transfer.kind(),
        gaze_px: gaze,
        backend: "cpu",
        level_angle_deg: lod::MD_DEFAULT_LEVEL_ANGLE_DEG,
        staircase: params,
        staircase_target_p: params.target(),
        estimator: ESTIMATOR,
        seed: a.seed,
        depths_subtended_deg: &depths,
        eccentricities_deg: &grid,
        conditions: &conditions,
        table_rows: &rows,
        table_file: table_name.clone(),
        clocks: CLOCKS,
    };
    write_file(
        &dir,
        "session.json",
        &serde_json::to_string_pretty(&session).map_err(|e| e.to_string())?,
    )?;
    writeln!(
        out,
        "SYNTHETIC {}: {trial} trials; extents (degrees) of levels 5 4 3 2 1 per depth:",
        dir.display()
    )
    .map_err(|e| e.to_string())?;
    for (d, r) in rows.iter().enumerate() {
        let cells: Vec<String> = r
            .extents_deg
            .iter()
            .zip(r.censored)
            .map(|(x, c)| format!("{x}{}", if c { "+" } else { "" }))
            .collect();
        writeln!(out, "  {}°: {}", depths[d], cells.join(" ")).map_err(|e| e.to_string())?;
    }
    writeln!(
        out,
        "  (+: still needed at the last eccentricity) -> {table_name}"
    )
    .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_table_is_full_within_the_eccentricity_and_the_level_beyond() {
        use foveation::degradation::level_in;
        for level in 1..=5u8 {
            let t = step_table(6.0, level);
            for depth in 0..5 {
                assert_eq!(level_in(&t, 0.0, depth), Some(5));
                assert_eq!(level_in(&t, 5.9, depth), Some(5));
                assert_eq!(level_in(&t, 6.0, depth), Some(level));
                assert_eq!(level_in(&t, 90.0, depth), Some(level));
            }
        }
        // At 0 the whole object is at the level.
        assert_eq!(level_in(&step_table(0.0, 2), 0.0, 0), Some(2));
    }

    #[test]
    fn each_angle_falls_on_the_row_lod_selects() {
        let rows: Vec<usize> = DEPTH_SUBTENDED_DEG.iter().map(|&a| lod_row(a)).collect();
        assert_eq!(rows, [0, 1, 2, 3, 4]);
        assert_eq!(lod_row(40.0), 0);
        assert_eq!(lod_row(5.0), 4);
        assert_eq!(lod_row(23.2), 1);
    }
}
