//! `gazecast bench ulod`: attention-guided level of detail (Lee 2009 ch. 7)
//! against no LOD, frame time against the number of visible objects (Lee's
//! Figs. 7.4–7.5), and the cost model of eqs. 7.1–7.2 with measured terms.
//!
//! The scene is generated (seeded): up to 256 instances of one mesh — the
//! first object of `--mesh-scene`, the bunny by default — with random
//! diffuse colour (so random luminance and hue), size, position and
//! rotation, all in front of the screen and inside the view. The mesh's
//! five quadric levels (1, 1/4, 1/16, 1/64, 1/256 of its triangles) are
//! built once and placed per instance. For each object count `n`, the
//! first `n` instances are drawn:
//!
//! - `NOLOD`: every instance at level 0, one CPU raster;
//! - `ULODk`: [`pipeline::ulod::Ulod`] with levels `0 … k−1`, its levels
//!   set each frame by Lee's attention model on the previous frame (64²
//!   maps), the fine level opaque and the next blended.
//!
//! Every figure is the median of `--frames` timed frames after three
//! warm-up frames (which also let the attention settle), by the wall clock
//! over the whole frame: building its triangle list, the attention model,
//! the rasters and the blend. The generated scene keeps every instance's
//! five levels in memory (about 1.8 GB for 256 bunnies, 5–6 GB at peak).

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::{EulerRot, Mat3, Vec3};
use pipeline::ulod::{ObjectLevels, Ulod};
use rand::{Rng, SeedableRng};
use raycast::raster::{self, RasterScratch};
use raycast::scene::{MeshSource, Object, WorldTriangle};
use raycast::{Camera, Frame, Scene, SceneFile};

use crate::bench::report::{create_dir, write_file};
use crate::config::{self, load_scene};
use experiment::stats::nearest_rank::median;

/// Most instances (Lee's 8-bit item buffer held 256).
pub const MAX_OBJECTS: usize = 256;

/// `gazecast bench ulod`'s arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct UlodArgs {
    /// Scene whose first object's mesh is instanced (RON).
    #[arg(long, value_name = "FILE", default_value = "config/scenes/bunny.ron")]
    pub mesh_scene: PathBuf,
    /// Display file (RON).
    #[arg(long, value_name = "FILE")]
    pub display: PathBuf,
    /// Output folder (created): ulod.md, ulod.csv, ulod.png.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Object counts, comma-separated (1 to 256 each).
    #[arg(long, value_name = "N,…", value_delimiter = ',',
          default_value = "1,2,4,8,16,32,64,128,256",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_OBJECTS as u64))]
    pub objects: Vec<usize>,
    /// ULOD level counts, comma-separated (2 to 5).
    #[arg(long, value_name = "K,…", value_delimiter = ',', default_value = "2,3,4,5",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(2..=5))]
    pub levels: Vec<usize>,
    /// Timed frames per point (1 to 1000, after three warm-up frames).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub frames: u32,
    /// Seed of the generated scene.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// One measured point.
#[derive(Debug, Clone)]
struct Point {
    condition: String,
    objects: usize,
    frame_ms: f64,
    attention_ms: f64,
    raster_ms: f64,
    triangles_drawn: usize,
    triangles_full: usize,
}

/// The instanced mesh, centred on the origin with radius 1.
fn base_mesh(path: &Path) -> Result<ObjectLevels, String> {
    let scene = load_scene(path)?;
    // Welded by exact position, as the model-based methods do.
    let mut mesh = pipeline::model_based::weld(&scene)
        .into_iter()
        .next()
        .filter(|m| !m.triangles.is_empty())
        .ok_or_else(|| {
            format!(
                "--mesh-scene {}: its first object has no triangles",
                path.display()
            )
        })?;
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &p in &mesh.positions {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo) * 0.5).length().max(f32::MIN_POSITIVE);
    for p in &mut mesh.positions {
        *p = (*p - centre) / radius;
    }
    ObjectLevels::build(0, &mesh.positions, &mesh.normals, &mesh.triangles, 5)
}

/// The generated scene (materials, lights) and each instance's levels.
fn generate(
    base: &ObjectLevels,
    geometry: &foveation::ScreenGeometry,
    count: usize,
    seed: u64,
) -> Result<(Scene, Vec<ObjectLevels>), String> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let half = [
        geometry.width_px as f32 * geometry.pitch_x_mm as f32 / 2.0,
        geometry.height_px as f32 * geometry.pitch_y_mm as f32 / 2.0,
    ];
    let mut file = SceneFile {
        name: format!("ulod-{count}-instances (generated, seed {seed})"),
        background: (0.05, 0.05, 0.06),
        meshes: [(
            "stub".to_string(),
            MeshSource::Triangle {
                a: (0.0, 0.0, -1e3),
                b: (1.0, 0.0, -1e3),
                c: (0.0, 1.0, -1e3),
            },
        )]
        .into(),
        materials: Default::default(),
        objects: Vec::new(),
        lights: Vec::new(),
        sampling: None,
        passes: None,
        effects: Some(Vec::new()),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    };
    let mut placed = Vec::with_capacity(count);
    for k in 0..count {
        // Random hue on the colour wheel and random luminance.
        let hue = rng.random_range(0.0..std::f32::consts::TAU);
        let lum = rng.random_range(0.2..0.9f32);
        let rgb =
            [0.0f32, 2.094, 4.189].map(|o| (lum * (0.6 + 0.4 * (hue + o).cos())).clamp(0.0, 1.0));
        let name = format!("m{k}");
        file.materials.insert(
            name.clone(),
            raycast::scene::Material {
                diffuse: (rgb[0], rgb[1], rgb[2]),
                ..raycast::scene::Material::default()
            },
        );
        file.objects.push(Object {
            mesh: "stub".into(),
            material: Some(name),
            translate_mm: (0.0, 0.0, -1e3),
            rotate_deg: (0.0, 0.0, 0.0),
            scale_mm: 1.0,
            importance: 1.0,
            motion: None,
        });
        let size = rng.random_range(8.0..24.0f32);
        let z = rng.random_range(-120.0..0.0f32);
        let shrink =
            0.85 * (geometry.eye_distance_mm as f32 / (geometry.eye_distance_mm as f32 - z));
        let t = Vec3::new(
            rng.random_range(-1.0..1.0f32) * (half[0] - size) * shrink,
            rng.random_range(-1.0..1.0f32) * (half[1] - size) * shrink,
            z,
        );
        let r = Mat3::from_euler(
            EulerRot::ZYX,
            rng.random_range(0.0..std::f32::consts::TAU),
            rng.random_range(0.0..std::f32::consts::TAU),
            rng.random_range(0.0..std::f32::consts::TAU),
        );
        placed.push(base.placed(k as u32, |p| r * (p * size) + t, |n| r * n));
    }
    let scene = Scene::build(&file, Path::new(".")).map_err(|e| e.to_string())?;
    Ok((scene, placed))
}

/// Runs `gazecast bench ulod`.
pub fn run(args: &UlodArgs, out: &mut dyn Write) -> Result<(), String> {
    crate::output::Inputs::new()
        .scene("--mesh-scene", &args.mesh_scene)
        .file("--display", &args.display)
        .refuse_in("--out", &args.out, &["ulod.md", "ulod.csv", "ulod.png"])?;
    let display = config::load_display(&args.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let camera = Camera::new(&geometry);
    let mut counts = args.objects.clone();
    counts.sort_unstable();
    counts.dedup();
    let mut level_sets = args.levels.clone();
    level_sets.sort_unstable();
    level_sets.dedup();
    let base = base_mesh(&args.mesh_scene)?;
    let max = counts.last().copied().unwrap_or(1);
    let (scene, placed) = generate(&base, &geometry, max, args.seed)?;
    let level_counts: Vec<usize> = base.levels.iter().map(Vec::len).collect();
    create_dir(&args.out)?;
    let timed = args.frames.max(1) as usize;
    let mut points = Vec::new();
    let mut nolod: Vec<WorldTriangle> = Vec::new();
    let mut scratch = RasterScratch::default();
    let mut frame = Frame::default();
    // 𝒯_n: a frame with nothing to draw.
    let mut empty = Vec::new();
    for k in 0..timed + 3 {
        let started = std::time::Instant::now();
        raster::rasterize(&scene, &camera, &[], true, &mut frame, &mut scratch);
        if k >= 3 {
            empty.push(started.elapsed().as_secs_f64() * 1e3);
        }
    }
    let t_n = median(&empty);
    for &n in &counts {
        // Timed like ULOD's frames: the wall clock over building the
        // frame's triangle list and drawing it, after three warm-up frames.
        let mut times = Vec::new();
        for k in 0..timed + 3 {
            let started = std::time::Instant::now();
            nolod.clear();
            for o in &placed[..n] {
                nolod.extend_from_slice(&o.levels[0]);
            }
            raster::rasterize(&scene, &camera, &nolod, true, &mut frame, &mut scratch);
            if k >= 3 {
                times.push(started.elapsed().as_secs_f64() * 1e3);
            }
        }
        let ms = median(&times);
        points.push(Point {
            condition: "NOLOD".into(),
            objects: n,
            frame_ms: ms,
            attention_ms: 0.0,
            raster_ms: ms,
            triangles_drawn: nolod.len(),
            triangles_full: nolod.len(),
        });
        for &levels in &level_sets {
            let mut ulod = Ulod::new(placed[..n].to_vec(), levels, 64)?;
            let (mut previous, mut current) = (Frame::default(), Frame::default());
            let (mut total, mut att, mut ras, mut drawn) = (Vec::new(), Vec::new(), Vec::new(), 0);
            let mut full = 0;
            for k in 0..timed + 3 {
                let started = std::time::Instant::now();
                let last = (k > 0).then_some(&previous);
                let s = ulod.render(&scene, &camera, last, Some(k as f64 / 60.0), &mut current);
                let ms = started.elapsed().as_secs_f64() * 1e3;
                if k >= 3 {
                    total.push(ms);
                    att.push(s.attention_ms);
                    ras.push(s.raster_ms);
                    drawn = s.triangles_opaque + s.triangles_blended;
                    full = s.triangles_full;
                }
                std::mem::swap(&mut previous, &mut current);
            }
            points.push(Point {
                condition: format!("ULOD{levels}"),
                objects: n,
                frame_ms: median(&total),
                attention_ms: median(&att),
                raster_ms: median(&ras),
                triangles_drawn: drawn,
                triangles_full: full,
            });
        }
    }
    let report = report(args, &scene, &level_counts, t_n, &points);
    write_file(&args.out.join("ulod.md"), &report)?;
    write_file(&args.out.join("ulod.csv"), &csv(&points))?;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for p in &points {
        match series.iter_mut().find(|(c, _)| *c == p.condition) {
            Some((_, v)) => v.push((p.objects as f64, p.frame_ms)),
            None => series.push((p.condition.clone(), vec![(p.objects as f64, p.frame_ms)])),
        }
    }
    let refs: Vec<(&str, &[(f64, f64)])> = series
        .iter()
        .map(|(c, v)| (c.as_str(), v.as_slice()))
        .collect();
    crate::plots::draw_log_log(
        &args.out.join("ulod.png"),
        "Frame time against visible objects (CPU raster, 2 threads)",
        "visible objects",
        &refs,
    )
    .map_err(|e| format!("{}: {e}", args.out.join("ulod.png").display()))?;
    out.write_all(report.as_bytes()).map_err(|e| e.to_string())
}

fn csv(points: &[Point]) -> String {
    let mut s = String::from(
        "condition,objects,frame_ms,attention_ms,raster_ms,triangles_drawn,triangles_full\n",
    );
    for p in points {
        let _ = writeln!(
            s,
            "{},{},{:.3},{:.3},{:.3},{},{}",
            p.condition,
            p.objects,
            p.frame_ms,
            p.attention_ms,
            p.raster_ms,
            p.triangles_drawn,
            p.triangles_full
        );
    }
    s
}

fn report(args: &UlodArgs, scene: &Scene, levels: &[usize], t_n: f64, points: &[Point]) -> String {
    let mut s = String::from("# Attention-guided LOD (Lee 2009 ch. 7) against no LOD\n\n");
    let _ = writeln!(
        s,
        "Generated scene `{}` (synthetic placement), mesh of `{}` with levels of {} triangles; {} timed frames per point after 3 warm-up frames; {} threads.\n",
        scene.name,
        args.mesh_scene.display(),
        levels.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(" / "),
        args.frames,
        rayon::current_num_threads()
    );
    let conditions: Vec<String> = {
        let mut c: Vec<String> = Vec::new();
        for p in points {
            if !c.contains(&p.condition) {
                c.push(p.condition.clone());
            }
        }
        c
    };
    s.push_str("Frame time, ms (median):\n\n| objects |");
    for c in &conditions {
        let _ = write!(s, " {c} |");
    }
    s.push_str("\n|---:|");
    for _ in &conditions {
        s.push_str("---:|");
    }
    s.push('\n');
    let mut counts: Vec<usize> = points.iter().map(|p| p.objects).collect();
    counts.dedup();
    for &n in &counts {
        let _ = write!(s, "| {n} |");
        for c in &conditions {
            match points.iter().find(|p| p.objects == n && &p.condition == c) {
                Some(p) => {
                    let _ = write!(s, " {:.1} |", p.frame_ms);
                }
                None => s.push_str(" – |"),
            }
        }
        s.push('\n');
    }
    // The cost model at the largest count.
    if let Some(&n) = counts.iter().max() {
        let full = points
            .iter()
            .find(|p| p.objects == n && p.condition == "NOLOD");
        if let Some(full) = full {
            let t = (full.frame_ms - t_n).max(0.0) / n as f64;
            let _ = writeln!(
                s,
                "\nCost model (eqs. 7.1–7.2) at {n} objects, with measured terms: 𝒯_n = {t_n:.2} ms (a frame with nothing to draw), t = {t:.3} ms per object at full detail (from NOLOD), a = 0 (the attention reads the previous frame's G-buffer; no extra pass), 𝒯_a = the model's time, r = triangles drawn / full.\n"
            );
            s.push_str("| condition | 𝒯_a ms | r | predicted 𝒯_n + 𝒯_a + t·n·r ms | measured ms |\n|---|---:|---:|---:|---:|\n");
            let _ = writeln!(
                s,
                "| NOLOD | 0 | 1 | {:.1} | {:.1} |",
                t_n + t * n as f64,
                full.frame_ms
            );
            for p in points
                .iter()
                .filter(|p| p.objects == n && p.condition != "NOLOD")
            {
                let r = p.triangles_drawn as f64 / p.triangles_full.max(1) as f64;
                let _ = writeln!(
                    s,
                    "| {} | {:.2} | {r:.4} | {:.1} | {:.1} |",
                    p.condition,
                    p.attention_ms,
                    t_n + p.attention_ms + t * n as f64 * r,
                    p.frame_ms
                );
            }
        }
    }
    s.push_str("\nr counts the blended level's triangles too (ULOD draws two levels of an object between levels). The ULOD rows include the model (64² maps) and the blend.\n");
    s
}
