//! `gazecast bench attention`: how well Lee's attention model (2009 ch. 3,
//! `crates/attention`) predicts where people looked, the evaluation of
//! Lee §3.5 on a lab's own recordings.
//!
//! Input: a scene, a display and one or more sessions, each a sample CSV as
//! `gazecast replay --input SESSION.gzrec --csv FILE` writes it (screen
//! pixels, host timestamps, validity). For each session:
//!
//! 1. **Frames.** The session is cut into frames at `--frame-rate` (60 Hz,
//!    Lee's rate) from its first sample to its last; each frame takes the
//!    newest sample at or before its time. The scene is rendered at full
//!    resolution (every pixel cast, with the scene's effects): once when it
//!    lists no effect, else at every frame with that frame's gaze and time.
//!    The scenes do not move yet (no camera path), so the camera is static.
//!    Frames render on the CPU backend; the model runs on the CPU.
//! 2. **Eye state** (Lee §3.5.2): an invalid sample is a blink; otherwise
//!    the velocity is the change of the gaze in normalised screen
//!    coordinates (0–1 on each axis) since the last frame, per 60-Hz frame
//!    (scaled at other rates): below 0.03 a fixation, above 0.1 a saccade,
//!    a drift in between. A sample more than two frames old (a gap in the
//!    recording) counts as invalid. The first frame and
//!    the first after a blink have no velocity and are dropped with the
//!    saccades. Only fixations and drifts are scored.
//! 3. **Looked-at object:** the object under the gaze pixel; on background,
//!    the object with the nearest pixel within `--radius-deg` (default 1°,
//!    about an eye tracker's accuracy; Lee reports errors "as high as 3
//!    inches"). Objects of importance 0 (scenery) are background.
//! 4. **Predictions:** the model runs on every frame (so its Kalman filter
//!    and temporal context see time pass) in Lee's eight feature-group
//!    combinations of Table 3.2 (B = luminance and hue, E = depth, size and
//!    motion, T = spatial and temporal context). The baseline with no group
//!    is Lee's: a random screen pixel; its object is the prediction, and for
//!    A₂/A₃ the objects of a second and third random pixel follow
//!    (background pixels predict nothing).
//! 5. **Scores:** A₁, A₂, A₃ (`attention::AccuracyAccumulator`) over the
//!    scored frames that show any object of importance above 0.
//!
//! Output (`--out DIR`): `attention.md` (the table beside Lee's Table 3.2,
//! the frame counts and where the sessions came from — their `#` comment
//! lines), `attention.csv` (per session and combination) and
//! `frames-N.csv` (per frame of session N: gaze, eye state, looked-at
//! object, the full model's top three). With two or more sessions the
//! table gives the mean and standard error over sessions, as Lee's does
//! over participants.
//!
//! `--synthesize-gaze FILE` writes a synthetic session for the scene
//! instead: fixations (200–600 ms, 0.1° Gaussian jitter per sample) on
//! objects drawn uniformly at random from those covering at least 20
//! pixels (never the one just fixated), 40-ms saccades,
//! and a 150-ms blink after one fixation in ten, at 120 Hz. Its comment
//! line says it is synthetic, and every report made from it repeats that.
//! Its viewer looks at random objects, so the model's scores on it are
//! near chance by design: it exercises the protocol, it does not measure
//! the model.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use foveation::ScreenGeometry;
use pipeline::frame_attention::FrameAttention;
use pipeline::{BackendChoice, Method, Options, Renderer};
use rand::{Rng, SeedableRng};
use raycast::{Camera, Frame, Scene};
use tracker_hal::csv::{parse_gaze, GazeRow, CSV_HEADER};

use crate::bench::report::{create_dir, write_file};
use crate::config::{self, load_scene};

/// Most frames one session may be cut into (9 hours at 60 Hz); a longer
/// session (or a clock jump that makes one) is cut there and says so.
pub const MAX_FRAMES: usize = 2_000_000;
/// Most `#` note lines kept from a session, and their length.
pub const MAX_NOTES: usize = 100;
/// Longest note line kept, characters.
pub const MAX_NOTE_CHARS: usize = 500;
/// Largest `--radius-deg`.
pub const MAX_RADIUS_DEG: f64 = 5.0;
pub use attention::eval::{eye_state, EyeState, FIXATION_BELOW, SACCADE_ABOVE};

/// `gazecast bench attention`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct AttentionArgs {
    /// Scene file (RON).
    #[arg(long, value_name = "FILE")]
    pub scene: PathBuf,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Sessions: sample CSVs in screen pixels, as `gazecast replay --csv`
    /// writes them, comma-separated (one per participant or session).
    #[arg(
        long,
        value_name = "FILE,…",
        value_delimiter = ',',
        required_unless_present = "synthesize_gaze"
    )]
    pub gaze: Vec<PathBuf>,
    /// Output folder (created): attention.md, attention.csv, frames-N.csv.
    #[arg(long, value_name = "DIR", required_unless_present = "synthesize_gaze")]
    pub out: Option<PathBuf>,
    /// Saliency map size (64 to 512; Lee found under 1 % difference
    /// between 512² and 64²).
    #[arg(long, value_name = "N", default_value_t = 64,
          value_parser = clap::value_parser!(u32).range(64..=512))]
    pub map_size: u32,
    /// Frames per second the sessions are cut into (1 to 1000).
    #[arg(long, value_name = "HZ", default_value_t = 60.0)]
    pub frame_rate: f64,
    /// How far from the gaze an object still counts as looked at when the
    /// gaze pixel is background (0 to 5 degrees).
    #[arg(long, value_name = "DEG", default_value_t = 1.0)]
    pub radius_deg: f64,
    /// Score at most this many frames of each session (1 to 10000000).
    #[arg(long, value_name = "N",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_FRAMES as u64))]
    pub max_frames: Option<usize>,
    /// Seed of the baseline's random pixels and of a synthesised session.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write a synthetic session for the scene to FILE (a sample CSV)
    /// instead of evaluating.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["gaze", "out"])]
    pub synthesize_gaze: Option<PathBuf>,
    /// Length of a synthesised session, s (1 to 3600).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 30.0,
        requires = "synthesize_gaze"
    )]
    pub seconds: f64,
}

/// A frame's time (s since the session's first sample) and gaze (screen
/// px; `None`: invalid).
pub type FrameGaze = (f64, Option<[f64; 2]>);

/// A gap between samples longer than this (s) gets no frames past its
/// first [`LONG_GAP_S`]: the frame clock moves on to the next sample, and
/// the gap is counted. A clock jump of days in a CSV would otherwise ask
/// for billions of frames of "no gaze".
pub const LONG_GAP_S: f64 = 2.0;

/// A session cut into frames.
#[derive(Debug, Clone, Default)]
pub struct FrameCut {
    /// One entry per frame: its time and gaze.
    pub frames: Vec<FrameGaze>,
    /// More frames were due than `max`.
    pub truncated: bool,
    /// Gaps between samples longer than [`LONG_GAP_S`], and the seconds
    /// of them that got no frames.
    pub long_gaps: usize,
    /// Seconds of those gaps that got no frames.
    pub skipped_s: f64,
}

/// Cuts `rows` into frames at `rate_hz`: each frame's time (s since the
/// first sample) and the newest sample's gaze at or before it (`None`
/// when that sample is invalid or more than two frames old). A gap longer
/// than [`LONG_GAP_S`] has frames (without gaze) for its first
/// [`LONG_GAP_S`] only, then the frames go on from the next sample. At
/// most `max` frames: the work is bounded by `max` and the row count,
/// never by the times in the file.
pub fn frames_of(rows: &[GazeRow], rate_hz: f64, max: usize) -> FrameCut {
    let mut cut = FrameCut::default();
    let Some(first) = rows.first() else {
        return cut;
    };
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return cut;
    }
    let period_us = 1e6 / rate_hz;
    let long_gap_us = (LONG_GAP_S * 1e6) as u64;
    // A sample older than two frames is no gaze for this frame: a gap in
    // the recording counts as invalid (a blink), not as a still eye.
    let max_age_us = (2.0 * period_us).ceil() as u64;
    let span_us = rows[rows.len() - 1].time_us.saturating_sub(first.time_us);
    let mut next = 0;
    let mut gap_after = None;
    let mut k: u64 = 0;
    loop {
        // The frame's offset from the first sample; compared in f64
        // before it becomes an integer, so no time in the file overflows.
        let offset_us = (k as f64 * period_us).round();
        if offset_us > span_us as f64 {
            break;
        }
        let due_us = first.time_us + (offset_us as u64).min(span_us);
        if cut.frames.len() >= max {
            cut.truncated = true;
            break;
        }
        while next + 1 < rows.len() && rows[next + 1].time_us <= due_us {
            next += 1;
        }
        let row = rows[next];
        let age_us = due_us.saturating_sub(row.time_us);
        if age_us > long_gap_us && next + 1 < rows.len() {
            // Jump to the first frame at or after the next sample.
            let resume_us = rows[next + 1].time_us - first.time_us;
            let resume_k = (resume_us as f64 / period_us).ceil() as u64;
            // Rounding can land a frame short of the sample: the gap is
            // still the one after row `next`, counted once.
            if gap_after != Some(next) {
                cut.long_gaps += 1;
                gap_after = Some(next);
            }
            cut.skipped_s += (resume_k.saturating_sub(k)) as f64 * period_us * 1e-6;
            k = resume_k.max(k + 1);
            continue;
        }
        let fresh = age_us <= max_age_us;
        cut.frames
            .push((offset_us * 1e-6, row.gaze.filter(|_| fresh)));
        k += 1;
    }
    cut
}

/// Whether object `id` is worth attending in this scene (among the ids the
/// model lists, with an importance above 0).
fn foreground(id: u32, importance: &[f32]) -> bool {
    (id as usize) < attention::frame::MAX_OBJECTS
        && importance.get(id as usize).is_some_and(|&i| i > 0.0)
}

/// The object looked at: under the gaze pixel, else the nearest
/// foreground pixel within `radius_px`.
pub fn looked_at(frame: &Frame, gaze: [f64; 2], radius_px: f64, importance: &[f32]) -> Option<u32> {
    let (w, h) = (frame.width_px as i64, frame.height_px as i64);
    let (gx, gy) = (gaze[0].floor(), gaze[1].floor());
    let at = |x: i64, y: i64| -> Option<u32> {
        if x < 0 || y < 0 || x >= w || y >= h {
            return None;
        }
        let id = *frame.object.get((y * w + x) as usize)?;
        foreground(id, importance).then_some(id)
    };
    let r = radius_px.clamp(0.0, (w.max(h)) as f64);
    // Far off the screen nothing is near (and the loop below stays bounded).
    if !(gx.is_finite() && gy.is_finite())
        || gx < -r - 1.0
        || gy < -r - 1.0
        || gx > (w as f64) + r
        || gy > (h as f64) + r
    {
        return None;
    }
    let (cx, cy) = (gx as i64, gy as i64);
    if let Some(id) = at(cx, cy) {
        return Some(id);
    }
    let ri = r.floor() as i64;
    let mut best: Option<(i64, u32)> = None;
    for y in (cy - ri).max(0)..=(cy + ri).min(h - 1) {
        for x in (cx - ri).max(0)..=(cx + ri).min(w - 1) {
            let d2 = (x - cx).pow(2) + (y - cy).pow(2);
            if (d2 as f64) > r * r || best.is_some_and(|(b, _)| b <= d2) {
                continue;
            }
            if let Some(id) = at(x, y) {
                best = Some((d2, id));
            }
        }
    }
    best.map(|(_, id)| id)
}

/// Whether any pixel of `frame` shows a foreground object.
fn has_foreground(frame: &Frame, importance: &[f32]) -> bool {
    frame.object.iter().any(|&id| foreground(id, importance))
}

/// Lee's baseline: the objects of three random pixels, in draw order,
/// without repeats; background draws predict nothing.
fn random_ranking(
    frame: &Frame,
    importance: &[f32],
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Vec<u32> {
    let n = frame.object.len();
    let mut out = Vec::with_capacity(3);
    if n == 0 {
        return out;
    }
    for _ in 0..3 {
        let id = frame.object[rng.random_range(0..n)];
        if foreground(id, importance) && !out.contains(&id) {
            out.push(id);
        }
    }
    out
}

/// Lee's eight combinations (B, E, T), baseline first.
pub const COMBINATIONS: [(bool, bool, bool); 8] = [
    (false, false, false),
    (true, false, false),
    (false, true, false),
    (true, true, false),
    (false, false, true),
    (true, false, true),
    (false, true, true),
    (true, true, true),
];

/// Lee's Table 3.2 means, in [`COMBINATIONS`] order.
pub const LEE_TABLE_3_2: [[f64; 3]; 8] = [
    [0.156, 0.272, 0.359],
    [0.432, 0.726, 0.866],
    [0.459, 0.746, 0.880],
    [0.446, 0.734, 0.874],
    [0.561, 0.815, 0.915],
    [0.547, 0.808, 0.918],
    [0.554, 0.812, 0.914],
    [0.553, 0.811, 0.914],
];

/// One session's outcome.
#[derive(Debug, Clone)]
pub struct SessionResult {
    /// The session's sample CSV.
    pub path: PathBuf,
    /// Its comment lines (`#`), at most [`MAX_NOTES`].
    pub notes: Vec<String>,
    /// Frames the session was cut into.
    pub frames: usize,
    /// More frames were due than [`MAX_FRAMES`].
    pub truncated: bool,
    /// Gaps between samples over [`LONG_GAP_S`] and the seconds skipped.
    pub long_gaps: usize,
    /// Seconds of those gaps that got no frames.
    pub skipped_s: f64,
    /// Frames per eye state: blink, start, saccade, drift, fixation.
    pub states: [usize; 5],
    /// Lee's `A_1`–`A_3` per feature-group combination (Table 3.2's eight).
    pub accuracy: [attention::AccuracyAccumulator; 8],
    /// Median model time per frame, ms, per combination (the baseline's is
    /// drawing its random pixels).
    pub model_ms: [f64; 8],
}

fn state_index(s: EyeState) -> usize {
    match s {
        EyeState::Blink => 0,
        EyeState::Start => 1,
        EyeState::Saccade => 2,
        EyeState::Drift => 3,
        EyeState::Fixation => 4,
    }
}

fn radius_px(geometry: &ScreenGeometry, deg: f64) -> f64 {
    deg.to_radians().tan() * geometry.eye_distance_mm / geometry.max_pitch_mm()
}

fn read_session(path: &Path) -> Result<tracker_hal::csv::GazeCsv, String> {
    let text = input_file::read_to_string(path, input_file::GAZE_CSV)
        .map_err(|e| format!("--gaze {}: cannot read: {e}", path.display()))?;
    let mut csv = parse_gaze(&text).map_err(|e| format!("--gaze {}: {e}", path.display()))?;
    let extra = csv.notes.len().saturating_sub(MAX_NOTES);
    csv.notes.truncate(MAX_NOTES);
    for n in &mut csv.notes {
        if n.chars().count() > MAX_NOTE_CHARS {
            *n = n.chars().take(MAX_NOTE_CHARS).collect::<String>() + "…";
        }
    }
    if extra > 0 {
        csv.notes
            .push(format!("({extra} more note lines not shown)"));
    }
    Ok(csv)
}

fn check_args(args: &AttentionArgs) -> Result<(), String> {
    if !(args.frame_rate.is_finite() && (1.0..=1000.0).contains(&args.frame_rate)) {
        return Err(format!(
            "--frame-rate {}: must be from 1 to 1000",
            args.frame_rate
        ));
    }
    if !(args.radius_deg.is_finite() && (0.0..=MAX_RADIUS_DEG).contains(&args.radius_deg)) {
        return Err(format!(
            "--radius-deg {}: must be from 0 to {MAX_RADIUS_DEG}",
            args.radius_deg
        ));
    }
    if !(args.seconds.is_finite() && (1.0..=3600.0).contains(&args.seconds)) {
        return Err(format!(
            "--seconds {}: must be from 1 to 3600",
            args.seconds
        ));
    }
    Ok(())
}

/// Runs `gazecast bench attention`.
pub fn run(args: &AttentionArgs, out: &mut dyn Write) -> Result<(), String> {
    check_args(args)?;
    let inputs = args.gaze.iter().fold(
        crate::output::Inputs::new()
            .scene("--scene", &args.scene)
            .file("--display", &args.display),
        |i, g| i.file("--gaze", g),
    );
    let scene = load_scene(&args.scene)?;
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let model = pipeline::sampling_model(geometry, 1.0)
        .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
    let options = Options {
        method: Method::Full,
        backend: BackendChoice::Cpu,
        surface: true,
        ..Options::default()
    };
    let mut renderer = Renderer::new(&scene, Camera::new(&geometry), model, &options)
        .map_err(|e| e.to_string())?;
    if let Some(path) = &args.synthesize_gaze {
        inputs.refuse(&[("--synthesize-gaze", path)])?;
        let (frame, _) = renderer
            .render(geometry.centre_px())
            .map_err(|e| e.to_string())?;
        let text = synthesize(&frame, &scene, &geometry, args)?;
        write_file(path, &text)?;
        return writeln!(
            out,
            "wrote a synthetic session of {} s to {}",
            args.seconds,
            path.display()
        )
        .map_err(|e| e.to_string());
    }
    let Some(dir) = &args.out else {
        return Err("--out DIR is needed to evaluate".into());
    };
    let outputs: Vec<(String, PathBuf)> = ["attention.md", "attention.csv"]
        .iter()
        .map(|n| (n.to_string(), dir.join(n)))
        .chain((1..=args.gaze.len()).map(|k| {
            (
                format!("frames-{k}.csv"),
                dir.join(format!("frames-{k}.csv")),
            )
        }))
        .collect();
    let flags: Vec<(&str, &Path)> = outputs
        .iter()
        .map(|(n, p)| (n.as_str(), p.as_path()))
        .collect();
    inputs.refuse(&flags)?;
    // Every session is read and checked before anything is written.
    let sessions: Vec<_> = args
        .gaze
        .iter()
        .map(|p| read_session(p).map(|c| (p.clone(), c)))
        .collect::<Result<_, _>>()?;
    create_dir(dir)?;
    let mut results = Vec::new();
    for (k, (path, csv)) in sessions.into_iter().enumerate() {
        // A fresh renderer per session: no effect's state (a focus, its
        // clock) carries from one session into the next.
        if k > 0 {
            renderer = Renderer::new(&scene, Camera::new(&geometry), model, &options)
                .map_err(|e| e.to_string())?;
        }
        let (result, frames_csv) =
            evaluate(&mut renderer, &scene, &geometry, args, k as u64, path, csv)?;
        write_file(&dir.join(format!("frames-{}.csv", k + 1)), &frames_csv)?;
        results.push(result);
    }
    let report = report(&results, args, &scene);
    write_file(&dir.join("attention.csv"), &results_csv(&results))?;
    write_file(&dir.join("attention.md"), &report)?;
    out.write_all(report.as_bytes()).map_err(|e| e.to_string())
}

fn evaluate(
    renderer: &mut Renderer<'_>,
    scene: &Scene,
    geometry: &ScreenGeometry,
    args: &AttentionArgs,
    session: u64,
    path: PathBuf,
    csv: tracker_hal::csv::GazeCsv,
) -> Result<(SessionResult, String), String> {
    let max = args.max_frames.unwrap_or(MAX_FRAMES);
    let FrameCut {
        frames,
        truncated,
        long_gaps,
        skipped_s,
    } = frames_of(&csv.rows, args.frame_rate, max);
    let importance = &scene.object_importance;
    let mut models: Vec<FrameAttention> = COMBINATIONS[1..]
        .iter()
        .map(|&(b, e, t)| {
            FrameAttention::with_features(args.map_size, attention::Features::lee_groups(b, e, t))
        })
        .collect::<Result<_, _>>()?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
        args.seed ^ session.wrapping_mul(0x9E37_79B9_7F4A_7C15),
    );
    let size = geometry.size_px();
    let radius = radius_px(geometry, args.radius_deg);
    // Effects with dynamics (refocusing) and scenes that move need every
    // frame rendered; a static scene without effects is rendered once.
    let dynamic = scene.sampling != raycast::scene::Sampling::Full
        || !scene.passes.is_empty()
        || scene.is_moving();
    let centre = geometry.centre_px();
    let mut still: Option<(Frame, bool)> = None;
    let mut result = SessionResult {
        path,
        notes: csv.notes,
        frames: frames.len(),
        truncated,
        long_gaps,
        skipped_s,
        states: [0; 5],
        accuracy: Default::default(),
        model_ms: [0.0; 8],
    };
    let mut times: Vec<Vec<f64>> = (0..8).map(|_| Vec::with_capacity(frames.len())).collect();
    let mut rows = String::from("frame,t_s,gaze_x,gaze_y,state,looked_at,top1,top2,top3\n");
    let mut last = None;
    for (i, &(t_s, gaze)) in frames.iter().enumerate() {
        if dynamic || still.is_none() {
            if let Some((old, _)) = still.take() {
                renderer.recycle(old);
            }
            let (frame, _) = renderer
                .render_at(gaze.unwrap_or(centre), t_s)
                .map_err(|e| e.to_string())?;
            let fg = has_foreground(&frame, importance);
            still = Some((frame, fg));
        }
        let Some((frame, fg)) = &still else {
            continue;
        };
        let state = eye_state(last, gaze, size, args.frame_rate);
        last = gaze;
        result.states[state_index(state)] += 1;
        let seen = gaze.and_then(|g| looked_at(frame, g, radius, importance));
        let mut rankings: Vec<Vec<u32>> = Vec::with_capacity(8);
        let started = std::time::Instant::now();
        rankings.push(random_ranking(frame, importance, &mut rng));
        times[0].push(started.elapsed().as_secs_f64() * 1e3);
        for (m, model) in models.iter_mut().enumerate() {
            let started = std::time::Instant::now();
            let ranking = model
                .update(frame, renderer.scene(), Some(t_s))
                .map(|a| a.ranking_ids())
                .unwrap_or_default();
            times[m + 1].push(started.elapsed().as_secs_f64() * 1e3);
            rankings.push(ranking);
        }
        if state.scored() {
            for (acc, ranking) in result.accuracy.iter_mut().zip(&rankings) {
                acc.record_frame(*fg, ranking, seen);
            }
        }
        let cell = |v: Option<u32>| v.map(|v| v.to_string()).unwrap_or_default();
        let (gx, gy) = gaze.map_or((String::new(), String::new()), |g| {
            (g[0].to_string(), g[1].to_string())
        });
        let all = &rankings[7];
        let _ = writeln!(
            rows,
            "{i},{t_s:.6},{gx},{gy},{},{},{},{},{}",
            state.name(),
            cell(seen),
            cell(all.first().copied()),
            cell(all.get(1).copied()),
            cell(all.get(2).copied())
        );
    }
    if let Some((frame, _)) = still {
        renderer.recycle(frame);
    }
    for (slot, t) in result.model_ms.iter_mut().zip(&times) {
        *slot = if t.is_empty() {
            0.0
        } else {
            experiment::stats::nearest_rank::median(t)
        };
    }
    Ok((result, rows))
}

fn groups(c: (bool, bool, bool)) -> String {
    let b = |v: bool| if v { "1" } else { "0" };
    format!("{} {} {}", b(c.0), b(c.1), b(c.2))
}

fn results_csv(results: &[SessionResult]) -> String {
    let mut s = String::from("session,file,b,e,t,scored_frames,skipped_frames,a1,a2,a3,model_ms\n");
    for (k, r) in results.iter().enumerate() {
        for (c, (acc, ms)) in COMBINATIONS.iter().zip(r.accuracy.iter().zip(r.model_ms)) {
            let a = acc.accuracies();
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{ms:.3}",
                k + 1,
                r.path.display(),
                u8::from(c.0),
                u8::from(c.1),
                u8::from(c.2),
                acc.frames(),
                acc.skipped_frames(),
                a[0],
                a[1],
                a[2]
            );
        }
    }
    s
}

/// Mean and standard error over sessions that scored any frame.
fn mean_se(values: &[f64]) -> (f64, Option<f64>) {
    let n = values.len() as f64;
    if values.is_empty() {
        return (f64::NAN, None);
    }
    let mean = values.iter().sum::<f64>() / n;
    let se = (values.len() >= 2).then(|| {
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (var / n).sqrt()
    });
    (mean, se)
}

fn report(results: &[SessionResult], args: &AttentionArgs, scene: &Scene) -> String {
    let mut s = String::from("# Attention prediction against recorded gaze (Lee 2009 §3.5)\n\n");
    let _ = writeln!(
        s,
        "Scene `{}`, {} session(s), saliency maps {}², frames at {} Hz, looked-at radius {}°.\n",
        scene.name,
        results.len(),
        args.map_size,
        args.frame_rate,
        args.radius_deg
    );
    let synthetic = results.iter().any(|r| {
        r.notes
            .iter()
            .any(|n| n.to_ascii_lowercase().contains("synthetic"))
    });
    if synthetic {
        s.push_str("**Synthetic data:** at least one session says it is synthesised (below); its figures do not measure people.\n\n");
    }
    for (k, r) in results.iter().enumerate() {
        let [blink, start, saccade, drift, fixation] = r.states;
        let _ = writeln!(
            s,
            "- Session {}: `{}`: {} frames{}{}; fixation {fixation}, drift {drift}, saccade {saccade}, blink {blink}, no velocity {start}; scored with foreground: {}.",
            k + 1,
            r.path.display(),
            r.frames,
            if r.truncated { " (cut at --max-frames)" } else { "" },
            if r.long_gaps > 0 {
                format!(
                    " ({} gaps over {LONG_GAP_S} s between samples: {:.1} s without frames)",
                    r.long_gaps, r.skipped_s
                )
            } else {
                String::new()
            },
            r.accuracy[7].frames()
        );
        for n in &r.notes {
            let _ = writeln!(s, "  - note: {n}");
        }
    }
    s.push_str("\n| B E T | A1 | A2 | A3 | model ms/frame | Lee A1 | Lee A2 | Lee A3 |\n|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (c, combo) in COMBINATIONS.iter().enumerate() {
        let mut cells = Vec::new();
        for k in 1..=3 {
            let v: Vec<f64> = results
                .iter()
                .filter_map(|r| r.accuracy[c].accuracy(k))
                .collect();
            let (m, se) = mean_se(&v);
            cells.push(match (m.is_finite(), se) {
                (false, _) => "–".to_string(),
                (true, Some(se)) => format!("{m:.3} ({se:.3})"),
                (true, None) => format!("{m:.3}"),
            });
        }
        let ms: Vec<f64> = results.iter().map(|r| r.model_ms[c]).collect();
        let lee = LEE_TABLE_3_2[c];
        let _ = writeln!(
            s,
            "| {}{} | {} | {} | {} | {:.2} | {:.3} | {:.3} | {:.3} |",
            groups(*combo),
            if c == 0 { " (random pixel)" } else { "" },
            cells[0],
            cells[1],
            cells[2],
            experiment::stats::nearest_rank::median(&ms),
            lee[0],
            lee[1],
            lee[2]
        );
    }
    s.push_str("\nB = luminance and hue, E = depth, size and motion, T = spatial and temporal context. With two or more sessions, the standard error over sessions is in brackets. Model time is the median per frame on this machine.\n");
    s
}

/// A synthetic session for `frame` (see the module docs).
fn synthesize(
    frame: &Frame,
    scene: &Scene,
    geometry: &ScreenGeometry,
    args: &AttentionArgs,
) -> Result<String, String> {
    let importance = &scene.object_importance;
    let w = frame.width_px as usize;
    // Each visible object's pixel nearest its centroid.
    let n = importance.len().min(attention::frame::MAX_OBJECTS);
    let mut sums = vec![(0.0f64, 0.0f64, 0usize); n];
    for (i, &id) in frame.object.iter().enumerate() {
        if let Some(s) = sums
            .get_mut(id as usize)
            .filter(|_| foreground(id, importance))
        {
            s.0 += (i % w) as f64 + 0.5;
            s.1 += (i / w) as f64 + 0.5;
            s.2 += 1;
        }
    }
    let mut targets: Vec<[f64; 2]> = Vec::new();
    for (id, &(sx, sy, c)) in sums.iter().enumerate() {
        if c < 20 {
            continue;
        }
        let centroid = [sx / c as f64, sy / c as f64];
        let mut best = (f64::INFINITY, centroid);
        for (i, &o) in frame.object.iter().enumerate() {
            if o as usize == id {
                let p = [(i % w) as f64 + 0.5, (i / w) as f64 + 0.5];
                let d = (p[0] - centroid[0]).hypot(p[1] - centroid[1]);
                if d < best.0 {
                    best = (d, p);
                }
            }
        }
        targets.push(best.1);
    }
    if targets.is_empty() {
        return Err(format!(
            "--synthesize-gaze: scene {} shows no object of importance above 0 covering 20 pixels on this display",
            scene.name
        ));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let jitter_px = radius_px(geometry, 0.1);
    let gauss = |rng: &mut rand_chacha::ChaCha8Rng| {
        // Box–Muller.
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        let v: f64 = rng.random_range(0.0..1.0);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let period_us = 1e6 / 120.0;
    let total = (args.seconds * 120.0).round() as usize;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# synthetic: gazecast bench attention --synthesize-gaze --seed {} --seconds {} for scene {}: fixations on objects drawn uniformly at random; not a person's gaze",
        args.seed, args.seconds, scene.name
    );
    s.push_str(CSV_HEADER);
    s.push('\n');
    let mut seq = 0usize;
    let mut at = targets[rng.random_range(0..targets.len())];
    let push = |s: &mut String, p: Option<[f64; 2]>, seq: &mut usize| {
        // A synthetic tracker on an ideal clock: device, arrival and mapped
        // times are one.
        let t = 1_000_000 + (*seq as f64 * period_us).round() as u64;
        let order = if *seq == 0 { "first" } else { "ok" };
        match p {
            Some([x, y]) => {
                let _ = writeln!(s, "{seq},{t},{t},{t},{order},,,0,,,0,{x:.2},{y:.2},1");
            }
            None => {
                let _ = writeln!(s, "{seq},{t},{t},{t},{order},,,0,,,0,,,0");
            }
        }
        *seq += 1;
    };
    while seq < total {
        // Fixation.
        let n_fix = rng.random_range(24..=72); // 200–600 ms at 120 Hz
        for _ in 0..n_fix {
            if seq >= total {
                break;
            }
            let p = [
                at[0] + jitter_px * gauss(&mut rng),
                at[1] + jitter_px * gauss(&mut rng),
            ];
            push(&mut s, Some(p), &mut seq);
        }
        if rng.random_range(0..10) == 0 {
            for _ in 0..18 {
                if seq >= total {
                    break;
                }
                push(&mut s, None, &mut seq);
            }
        }
        // Saccade to another object (40 ms).
        let next = if targets.len() > 1 {
            loop {
                let t = targets[rng.random_range(0..targets.len())];
                if t != at {
                    break t;
                }
            }
        } else {
            at
        };
        for k in 1..=5 {
            if seq >= total {
                break;
            }
            let f = k as f64 / 5.0;
            push(
                &mut s,
                Some([at[0] + (next[0] - at[0]) * f, at[1] + (next[1] - at[1]) * f]),
                &mut seq,
            );
        }
        at = next;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_take_the_newest_sample_and_stop_at_max() {
        let row = |t: u64, x: f64| GazeRow {
            time_us: t,
            gaze: Some([x, 0.0]),
        };
        let rows = [
            row(1_000_000, 1.0),
            row(1_010_000, 2.0),
            row(1_020_000, 3.0),
            row(1_050_000, 4.0),
        ];
        let FrameCut {
            frames: f,
            truncated: cut,
            ..
        } = frames_of(&rows, 50.0, 100);
        assert!(!cut);
        let xs: Vec<f64> = f.iter().map(|(_, g)| g.map_or(-1.0, |g| g[0])).collect();
        assert_eq!(xs, vec![1.0, 3.0, 3.0]);
        let c = frames_of(&rows, 1000.0, 10);
        assert!(c.truncated);
        assert_eq!(c.frames.len(), 10);
        assert!(frames_of(&[], 60.0, 10).frames.is_empty());
        // A 200-ms gap: the frames inside it have no gaze.
        let f = frames_of(&[row(1_000_000, 1.0), row(1_200_000, 2.0)], 50.0, 100).frames;
        let valid: Vec<bool> = f.iter().map(|(_, g)| g.is_some()).collect();
        assert_eq!(
            valid,
            vec![true, true, true, false, false, false, false, false, false, false, true]
        );
    }

    /// A clock jump of days (or of u64's whole range) costs frames for
    /// [`LONG_GAP_S`] only and is reported; the frames after it follow the
    /// next sample. The work is bounded by the rows, not by the times.
    #[test]
    fn a_clock_jump_is_a_reported_gap_not_billions_of_frames() {
        let row = |t: u64, x: f64| GazeRow {
            time_us: t,
            gaze: Some([x, 0.0]),
        };
        for jump in [3_000_000u64, 86_400_000_000 * 3, u64::MAX / 2] {
            let rows = [
                row(1_000_000, 1.0),
                row(1_000_000 + jump, 2.0),
                row(1_100_000 + jump, 3.0),
            ];
            let c = frames_of(&rows, 60.0, 2_000_000);
            assert!(!c.truncated, "jump {jump}");
            assert_eq!(c.long_gaps, 1, "jump {jump}");
            let gap_frames = 1 + (LONG_GAP_S * 60.0) as usize;
            assert!(
                (gap_frames..=gap_frames + 7).contains(&c.frames.len()),
                "jump {jump}: {}",
                c.frames.len()
            );
            let (t, g) = c.frames[gap_frames];
            assert_eq!(g, Some([2.0, 0.0]), "jump {jump}");
            assert!(t * 1e6 >= jump as f64 * (1.0 - 1e-15), "jump {jump}: {t}");
            assert!(
                t * 1e6 - jump as f64 <= 1e6 / 60.0 + 1.0,
                "jump {jump}: {t}"
            );
        }
        // Times up to u64::MAX do not overflow the frame clock.
        let c = frames_of(
            &[
                row(0, 1.0),
                row(u64::MAX - 200_000, 2.0),
                row(u64::MAX, 3.0),
            ],
            60.0,
            1000,
        );
        assert_eq!(c.long_gaps, 1);
        assert!(
            c.frames.len() <= 1 + (LONG_GAP_S * 60.0) as usize + 14,
            "{}",
            c.frames.len()
        );
        // Rates that cannot make frames make none.
        for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(frames_of(&[row(0, 1.0), row(10, 1.0)], rate, 10)
                .frames
                .is_empty());
        }
    }

    #[test]
    fn looked_at_searches_the_radius_and_ignores_scenery() {
        let mut frame = Frame::default();
        frame.reshape(10, 10, true);
        frame.object.fill(raycast::frame::NO_OBJECT);
        frame.object[5 * 10 + 8] = 1;
        frame.object[2 * 10 + 2] = 0;
        let importance = [0.0, 1.0];
        assert_eq!(looked_at(&frame, [8.5, 5.5], 0.0, &importance), Some(1));
        assert_eq!(looked_at(&frame, [5.5, 5.5], 2.0, &importance), None);
        assert_eq!(looked_at(&frame, [5.5, 5.5], 3.0, &importance), Some(1));
        // Object 0 has importance 0: scenery.
        assert_eq!(looked_at(&frame, [2.5, 2.5], 0.0, &importance), None);
        assert_eq!(looked_at(&frame, [1e300, -1e300], 5.0, &importance), None);
        assert_eq!(looked_at(&frame, [f64::NAN, 0.0], 5.0, &importance), None);
        assert!(has_foreground(&frame, &importance));
    }

    #[test]
    fn the_standard_error_needs_two_sessions() {
        assert_eq!(mean_se(&[0.5]), (0.5, None));
        let (m, se) = mean_se(&[0.4, 0.6]);
        assert!((m - 0.5).abs() < 1e-12 && (se.unwrap_or(0.0) - 0.1).abs() < 1e-12);
        assert!(mean_se(&[]).0.is_nan());
    }
}
