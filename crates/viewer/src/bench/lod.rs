//! `gazecast bench lod`: the model-based methods along a scanpath, in the
//! shape of Murphy & Duchowski 2001's Table 2 (faces min / max / average
//! and frame time over a viewing sequence, for a torus of 16,384 faces and
//! a dense mesh), and Luebke & Hallen 2001's Fig. 8 set-up (imperceptible
//! mode with the gaze 29° from the object's centre).
//!
//! - Meshes: a torus of 16,384 faces (128 segments × 64 sides, M&D's face
//!   count), a dense torus of 262,144 faces (512 × 256, the size of M&D's
//!   268,686-face *igea*, which is not available here), and each
//!   `--scene` file (e.g. the Stanford bunny). `--quick`: tori of 256 and
//!   1,024 faces.
//! - The tori are placed to subtend about 22° from the eye, the middle of
//!   M&D's 18°–26° (their Table 1 depth row 2).
//! - Methods: `full-raster` (every triangle through the same CPU z-buffer
//!   rasteriser: the model-based control), `lod` (Murphy–Duchowski),
//!   `simplify` (Luebke–Hallen imperceptible mode).
//! - The scanpath is **synthetic**, not recorded: a 3:2 Lissajous figure
//!   over 90 % of the screen, `--frames` gazes; one warm-up frame at the
//!   first gaze is not counted. Frame time = selection + raster (ms, wall
//!   clock, CPU).
//!
//! Writes `lod.md` (the tables), `lod.csv` (one row per mesh, method and
//! frame) and `lod.json` (the summaries).

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use foveation::Display;
use glam::{Quat, Vec3};
use pipeline::{BackendChoice, Method, Options, Renderer};
use raycast::raster::{self, RasterScratch};
use raycast::scene::{Effect, Sampling};
use raycast::{Camera, Frame, Scene};
use serde::Serialize;

use crate::bench::report::{create_dir, write_file};
use crate::bench::scaling::scaling_display;
use crate::bench::torus::{torus_scene, Placement};
use crate::config::{self, load_scene};

/// Most scanpath frames.
pub const MAX_FRAMES: usize = 10_000;

/// Luebke & Hallen Fig. 8: the gaze 29° from the bunny's centre.
pub const FIG8_ECCENTRICITY_DEG: f64 = 29.0;

/// `gazecast bench lod`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct LodArgs {
    /// Output folder (created): lod.md, lod.csv, lod.json.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// A scene whose objects are one more mesh (e.g.
    /// config/scenes/bunny.ron); repeatable.
    #[arg(long, value_name = "FILE")]
    pub scene: Vec<PathBuf>,
    /// Display file (RON). Default: a 27" 16:9 panel at 60 cm, 1280×720
    /// (320×180 with --quick).
    #[arg(long, value_name = "FILE")]
    pub display: Option<PathBuf>,
    /// Frames along the synthetic scanpath (1 to 10000). Default 240, or
    /// 12 with --quick.
    #[arg(long, value_name = "N",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_FRAMES as u64))]
    pub frames: Option<usize>,
    /// Small tori (256 and 1,024 faces), 12 frames, 320×180.
    #[arg(long)]
    pub quick: bool,
}

/// One frame of one method on one mesh.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LodFrame {
    /// Index along the scanpath.
    pub frame: usize,
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// Triangles drawn.
    pub faces: usize,
    /// Selection time, ms.
    pub select_ms: f64,
    /// Raster time, ms.
    pub raster_ms: f64,
    /// Whole frame time, ms.
    pub frame_ms: f64,
}

/// Table 2's row: one method on one mesh over the scanpath.
#[derive(Debug, Clone, Serialize)]
pub struct LodSummary {
    /// The mesh's name.
    pub mesh: String,
    /// The method's name.
    pub method: &'static str,
    /// Triangles of the unsimplified mesh.
    pub faces_full: usize,
    /// Frames measured.
    pub frames: usize,
    /// Tree building (scene set-up) time, ms; 0 for `full-raster`.
    pub build_ms: f64,
    /// Fewest triangles drawn in a frame.
    pub faces_min: usize,
    /// Most triangles drawn in a frame.
    pub faces_max: usize,
    /// Mean triangles drawn per frame.
    pub faces_avg: f64,
    /// Shortest frame time, ms.
    pub frame_ms_min: f64,
    /// Longest frame time, ms.
    pub frame_ms_max: f64,
    /// Mean frame time, ms.
    pub frame_ms_avg: f64,
    /// Mean selection time, ms.
    pub select_ms_avg: f64,
    /// Mean raster time, ms.
    pub raster_ms_avg: f64,
    /// 1000 / `frame_ms_avg` (M&D report frame rates).
    pub fps_avg: f64,
}

/// Luebke & Hallen Fig. 8's measurement on one mesh: imperceptible mode,
/// one frame from a fresh cut.
#[derive(Debug, Clone, Serialize)]
pub struct Fig8Row {
    /// The mesh's name.
    pub mesh: String,
    /// Triangles of the unsimplified mesh.
    pub faces_full: usize,
    /// Angle between the gaze and the eye → object-centre direction, deg.
    pub eccentricity_deg: f64,
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// Triangles drawn.
    pub faces: usize,
    /// The object's angular extent, deg: the diameter of the sphere about
    /// its bounding box's centre that holds every triangle.
    pub object_extent_deg: f64,
}

/// Everything `lod.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct LodReport {
    /// The display's name.
    pub display: String,
    /// Display width, pixels.
    pub width_px: u32,
    /// Display height, pixels.
    pub height_px: u32,
    /// Threads in the rayon pool.
    pub threads: usize,
    /// Which scanpath the frames follow.
    pub scanpath: &'static str,
    /// Table 2's rows: one per method and mesh.
    pub summaries: Vec<LodSummary>,
    /// Fig. 8's rows: one per mesh.
    pub fig8: Vec<Fig8Row>,
}

/// The header of `lod.csv`.
pub const LOD_CSV_HEADER: &str =
    "mesh,method,faces_full,frame,gaze_x_px,gaze_y_px,faces,select_ms,raster_ms,frame_ms";

/// What `lod.json` says the scanpath is.
const SCANPATH: &str =
    "synthetic: a 3:2 Lissajous figure over 90 % of the screen (not a recorded viewing sequence)";

/// A torus of `2·segments·sides` faces, tilted, about 22° across from a
/// 600 mm eye distance (M&D's objects subtended 18°–26°).
pub fn lod_torus(segments: u32, sides: u32) -> Result<Scene, String> {
    let at = Placement {
        translate_mm: (0.0, 0.0, -100.0),
        scale_mm: 95.0,
    };
    torus_scene(segments, sides, at, vec![Effect::FoveatedSampling])
}

/// The synthetic scanpath: `n` gazes on a 3:2 Lissajous figure over 90 %
/// of a `w × h` px screen.
pub fn scanpath(w: u32, h: u32, n: usize) -> Vec<[f64; 2]> {
    let (w, h) = (f64::from(w), f64::from(h));
    (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            [
                w * (0.5 + 0.45 * (3.0 * t).sin()),
                h * (0.5 + 0.45 * (2.0 * t + 0.5).sin()),
            ]
        })
        .collect()
}

/// The centre of the scene's bounding box and the farthest corner from it
/// (the radius of a sphere about that centre holding every triangle).
fn bounds(scene: &Scene) -> Option<(Vec3, f32)> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for t in &scene.triangles {
        for p in t.p {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if lo.x > hi.x {
        return None;
    }
    let c = (lo + hi) * 0.5;
    let r = scene
        .triangles
        .iter()
        .flat_map(|t| t.p)
        .map(|p| p.distance(c))
        .fold(0.0f32, f32::max);
    Some((c, r))
}

/// The screen point (px, maybe off the screen) whose ray is `deg` to the
/// right of the eye → `centre` direction, and the angle it really makes.
pub fn gaze_at_eccentricity(camera: &Camera, centre: Vec3, deg: f64) -> Option<([f64; 2], f64)> {
    let d0 = (centre - camera.eye).normalize_or_zero();
    // About the screen's up direction made perpendicular to d0, so that
    // the turn is exactly `deg`.
    let up = (Vec3::Y - d0 * d0.dot(Vec3::Y)).normalize_or_zero();
    if d0 == Vec3::ZERO || up == Vec3::ZERO {
        return None;
    }
    let d1 = Quat::from_axis_angle(up, -(deg as f32).to_radians()) * d0;
    if d1.z >= -1e-6 {
        return None;
    }
    let s = camera.eye + d1 * (camera.eye.z / -d1.z);
    let [px, py] = camera.pitch();
    let p = [
        f64::from(s.x / px) + f64::from(camera.width_px) / 2.0,
        f64::from(camera.height_px) / 2.0 - f64::from(s.y / py),
    ];
    let dir = camera.ray([p[0] as f32, p[1] as f32]).dir.normalize();
    let angle = f64::from(dir.dot(d0).clamp(-1.0, 1.0)).acos().to_degrees();
    Some((p, angle))
}

fn summarise(
    mesh: &str,
    method: &'static str,
    faces_full: usize,
    build_ms: f64,
    frames: &[LodFrame],
) -> LodSummary {
    let n = frames.len().max(1) as f64;
    let avg = |f: fn(&LodFrame) -> f64| frames.iter().map(f).sum::<f64>() / n;
    let ms = frames.iter().map(|f| f.frame_ms);
    let frame_ms_avg = avg(|f| f.frame_ms);
    LodSummary {
        mesh: mesh.to_string(),
        method,
        faces_full,
        frames: frames.len(),
        build_ms,
        faces_min: frames.iter().map(|f| f.faces).min().unwrap_or(0),
        faces_max: frames.iter().map(|f| f.faces).max().unwrap_or(0),
        faces_avg: avg(|f| f.faces as f64),
        frame_ms_min: ms.clone().fold(f64::INFINITY, f64::min),
        frame_ms_max: ms.fold(0.0, f64::max),
        frame_ms_avg,
        select_ms_avg: avg(|f| f.select_ms),
        raster_ms_avg: avg(|f| f.raster_ms),
        fps_avg: if frame_ms_avg > 0.0 {
            1000.0 / frame_ms_avg
        } else {
            f64::INFINITY
        },
    }
}

/// The model-based renderer of `method` on `scene` (CPU), and its set-up
/// time (tree building), ms.
fn model_renderer<'s>(
    scene: &'s Scene,
    display: &Display,
    method: Method,
) -> Result<(Renderer<'s>, f64), String> {
    let g = display.geometry().map_err(|e| e.to_string())?;
    let model = pipeline::sampling_model(g, 1.0).map_err(|e| e.to_string())?;
    let started = Instant::now();
    let r = Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            method,
            backend: BackendChoice::Cpu,
            ..Options::default()
        },
    )
    .map_err(|e| e.to_string())?;
    Ok((r, started.elapsed().as_secs_f64() * 1e3))
}

/// One mesh: every method along the scanpath, and the Fig. 8 frame.
fn bench_mesh(
    name: &str,
    scene: &Scene,
    display: &Display,
    gazes: &[[f64; 2]],
    csv: &mut String,
) -> Result<(Vec<LodSummary>, Fig8Row), String> {
    let g = display.geometry().map_err(|e| e.to_string())?;
    let camera = Camera::new(&g);
    let faces_full = scene.triangles.len();
    let mut summaries = Vec::new();
    let mut push = |method: &'static str, build_ms: f64, frames: Vec<LodFrame>| {
        for f in &frames {
            let _ = writeln!(
                csv,
                "{name},{method},{faces_full},{},{:.2},{:.2},{},{:.4},{:.4},{:.4}",
                f.frame, f.gaze_px[0], f.gaze_px[1], f.faces, f.select_ms, f.raster_ms, f.frame_ms
            );
        }
        summaries.push(summarise(name, method, faces_full, build_ms, &frames));
    };

    // The control: every triangle through the same rasteriser.
    let mut frame = Frame::default();
    let mut scratch = RasterScratch::default();
    raster::rasterize(
        scene,
        &camera,
        &scene.triangles,
        false,
        &mut frame,
        &mut scratch,
    );
    let full: Vec<LodFrame> = gazes
        .iter()
        .enumerate()
        .map(|(k, &gaze_px)| {
            let r = raster::rasterize(
                scene,
                &camera,
                &scene.triangles,
                false,
                &mut frame,
                &mut scratch,
            );
            LodFrame {
                frame: k,
                gaze_px,
                faces: faces_full,
                select_ms: 0.0,
                raster_ms: r.time_ms,
                frame_ms: r.time_ms,
            }
        })
        .collect();
    push("full-raster", 0.0, full);

    for method in [Method::Lod, Method::Simplify] {
        let (mut r, build_ms) = model_renderer(scene, display, method)?;
        let warm = gazes.first().copied().unwrap_or_else(|| g.centre_px());
        let (f, _) = r.render(warm).map_err(|e| e.to_string())?;
        r.recycle(f);
        let mut frames = Vec::with_capacity(gazes.len());
        for (k, &gaze_px) in gazes.iter().enumerate() {
            let (f, _) = r.render(gaze_px).map_err(|e| e.to_string())?;
            r.recycle(f);
            let m = *r
                .model_based()
                .ok_or("the model-based state is missing")?
                .last();
            frames.push(LodFrame {
                frame: k,
                gaze_px,
                faces: m.triangles_drawn,
                select_ms: m.select_ms,
                raster_ms: m.raster_ms,
                frame_ms: m.select_ms + m.raster_ms,
            });
        }
        push(method.name(), build_ms, frames);
    }

    // Luebke & Hallen Fig. 8: imperceptible mode, the gaze 29° to the
    // right of the object's centre, from a fresh cut.
    let (centre, radius) = bounds(scene).ok_or_else(|| format!("{name}: no triangles"))?;
    let (gaze_px, eccentricity_deg) = gaze_at_eccentricity(&camera, centre, FIG8_ECCENTRICITY_DEG)
        .ok_or_else(|| {
            format!("{name}: no screen point {FIG8_ECCENTRICITY_DEG}° from the object")
        })?;
    let (mut r, _) = model_renderer(scene, display, Method::Simplify)?;
    r.render(gaze_px).map_err(|e| e.to_string())?;
    let faces = r
        .model_based()
        .ok_or("the model-based state is missing")?
        .last()
        .triangles_drawn;
    let distance = f64::from((centre - camera.eye).length());
    let fig8 = Fig8Row {
        mesh: name.to_string(),
        faces_full,
        eccentricity_deg,
        gaze_px,
        faces,
        object_extent_deg: 2.0 * (f64::from(radius) / distance).min(1.0).asin().to_degrees(),
    };
    Ok((summaries, fig8))
}

/// `lod.md`.
pub fn lod_markdown(report: &LodReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Model-based methods along a scanpath\n");
    let _ = writeln!(
        s,
        "`{command}` on {} ({}x{} px), cpu ({} threads). Scanpath: {}, {} frames. \
         Frame time = selection + CPU raster, wall clock.\n",
        report.display,
        report.width_px,
        report.height_px,
        report.threads,
        report.scanpath,
        report.summaries.first().map_or(0, |s| s.frames)
    );
    let _ = writeln!(s, "## Murphy & Duchowski Table 2 shape\n");
    let _ = writeln!(
        s,
        "| mesh | method | faces | min faces | max faces | avg faces | min ms | max ms | avg ms | avg fps | select ms | raster ms | build ms |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in &report.summaries {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {:.0} | {:.2} | {:.2} | {:.0} |",
            r.mesh,
            r.method,
            r.faces_full,
            r.faces_min,
            r.faces_max,
            r.faces_avg,
            r.frame_ms_min,
            r.frame_ms_max,
            r.frame_ms_avg,
            r.fps_avg,
            r.select_ms_avg,
            r.raster_ms_avg,
            r.build_ms
        );
    }
    let _ = writeln!(
        s,
        "\n## Luebke & Hallen Fig. 8 set-up (imperceptible mode, gaze {FIG8_ECCENTRICITY_DEG}° from the object's centre)\n"
    );
    let _ = writeln!(
        s,
        "| mesh | faces | object extent ° | gaze px | eccentricity ° | faces drawn |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for f in &report.fig8 {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.0},{:.0} | {:.2} | {} |",
            f.mesh,
            f.faces_full,
            f.object_extent_deg,
            f.gaze_px[0],
            f.gaze_px[1],
            f.eccentricity_deg,
            f.faces
        );
    }
    s
}

/// Runs `gazecast bench lod`.
pub fn run(args: &LodArgs, out: &mut dyn Write) -> Result<(), String> {
    args.scene
        .iter()
        .fold(
            crate::output::Inputs::new().maybe("--display", args.display.as_deref()),
            |i, s| i.scene("--scene", s),
        )
        .refuse_in("--out", &args.out, &["lod.md", "lod.csv", "lod.json"])?;
    let display = match &args.display {
        Some(p) => config::load_display(p).map_err(|e| e.to_string())?,
        None if args.quick => scaling_display(320, 180),
        None => scaling_display(1280, 720),
    };
    let g = display.geometry().map_err(|e| e.to_string())?;
    let frames = args.frames.unwrap_or(if args.quick { 12 } else { 240 });
    if !(1..=MAX_FRAMES).contains(&frames) {
        return Err(format!("--frames {frames}: must be from 1 to {MAX_FRAMES}"));
    }
    let tori: &[(u32, u32)] = if args.quick {
        &[(16, 8), (32, 16)]
    } else {
        &[(128, 64), (512, 256)]
    };
    let mut meshes = Vec::new();
    for &(segments, sides) in tori {
        let s = lod_torus(segments, sides)?;
        meshes.push((s.name.clone(), s));
    }
    for path in &args.scene {
        let mut s = load_scene(path)?;
        if !s.sampling.is_foveated() {
            s.sampling = Sampling::Foveated { refine: Vec::new() };
        }
        meshes.push((s.name.clone(), s));
    }
    let gazes = scanpath(g.width_px, g.height_px, frames);
    let mut csv = String::from(LOD_CSV_HEADER);
    csv.push('\n');
    let mut summaries = Vec::new();
    let mut fig8 = Vec::new();
    for (name, scene) in &meshes {
        let (s, f) = bench_mesh(name, scene, &display, &gazes, &mut csv)?;
        summaries.extend(s);
        fig8.push(f);
    }
    let report = LodReport {
        display: display.name.clone(),
        width_px: g.width_px,
        height_px: g.height_px,
        threads: rayon::current_num_threads(),
        scanpath: SCANPATH,
        summaries,
        fig8,
    };
    create_dir(&args.out)?;
    let command: Vec<String> = std::env::args().skip(1).collect();
    let command = format!("gazecast {}", command.join(" "));
    let md = lod_markdown(&report, &command);
    write_file(&args.out.join("lod.md"), &md)?;
    write_file(&args.out.join("lod.csv"), &csv)?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    write_file(&args.out.join("lod.json"), &json)?;
    write!(out, "{md}").map_err(|e| e.to_string())?;
    writeln!(out, "wrote {}", args.out.display()).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scanpath_stays_on_the_screen_and_the_torus_has_table_2s_faces() {
        let p = scanpath(320, 180, 50);
        assert_eq!(p.len(), 50);
        assert!(p
            .iter()
            .all(|g| (0.0..320.0).contains(&g[0]) && (0.0..180.0).contains(&g[1])));
        let torus = lod_torus(128, 64).expect("torus");
        assert_eq!(torus.triangles.len(), 16_384);
    }

    #[test]
    fn the_fig8_gaze_is_29_degrees_from_the_centre() {
        let g = scaling_display(1280, 720).geometry().expect("display");
        let camera = Camera::new(&g);
        for centre in [Vec3::new(0.0, 0.0, -100.0), Vec3::new(40.0, -30.0, -300.0)] {
            let (_, angle) = gaze_at_eccentricity(&camera, centre, 29.0).expect("a point");
            assert!((angle - 29.0).abs() < 0.01, "{angle}");
        }
    }
}
