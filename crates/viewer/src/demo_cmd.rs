//! `gazecast demo`: the seed's search task. With a display (`DISPLAY` or
//! `WAYLAND_DISPLAY` set) it opens the live window in mouse mode: the cursor
//! is the point of regard, through the same tracker path as a physical
//! tracker. Without one (or with `--headless`) it follows a built-in
//! scanpath — a plausible search of the 5×5 grid that ends on the target —
//! rendered foveated frame by frame to an animated PNG and a contact sheet,
//! with rays and times per frame.

use std::io::Write;
use std::path::{Path, PathBuf};

use foveation::ScreenGeometry;
use rand::{Rng, SeedableRng};
use raycast::render::render;
use raycast::{Camera, SceneFile};

use crate::config;
use crate::render_cmd::{draw_box, draw_por_box, load_scene};

#[derive(Debug, Clone, clap::Args)]
pub struct DemoArgs {
    /// Output folder: demo.png (animated PNG) and demo-sheet.png.
    #[arg(long, value_name = "DIR", default_value = "out")]
    pub out: PathBuf,
    /// Frames per second of the scanpath (and of the animation).
    #[arg(long, value_name = "HZ", default_value_t = 30)]
    pub fps: u16,
    /// Seed of the scanpath.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Render the scanpath to files even when a display is available.
    #[arg(long)]
    pub headless: bool,
    /// Window mode: exit after this many frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
}

const MOUSE: &str = "config/trackers/mouse.ron";

/// Whether a window can be tried: a display server is named.
fn has_display() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()))
}

const SCENE: &str = "config/scenes/search-task.ron";
const DISPLAY: &str = "config/displays/tobii-et1750-17in.ron";

/// Where an object's centre appears on the screen (px), seen from the eye.
fn screen_px(g: &ScreenGeometry, cam: &Camera, p: (f32, f32, f32)) -> [f64; 2] {
    let eye = cam.eye;
    let t = eye.z / (eye.z - p.2);
    let x = eye.x + (p.0 - eye.x) * t;
    let y = eye.y + (p.1 - eye.y) * t;
    let [w, h] = g.size_px();
    [
        f64::from(x) / g.pitch_x_mm + w / 2.0,
        h / 2.0 - f64::from(y) / g.pitch_y_mm,
    ]
}

/// Gaze per frame: a fixation at the centre, then 4–6 objects of the grid in
/// a seeded order (near ones first, as searches tend to go), then the
/// target; fixations of 250–450 ms with 0.1° jitter, saccades of
/// 2.2 ms/° + 21 ms (main sequence) with a smooth profile.
pub fn scanpath(
    g: &ScreenGeometry,
    objects: &[[f64; 2]],
    target: [f64; 2],
    fps: f64,
    seed: u64,
) -> Vec<[f64; 2]> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut stops = vec![g.centre_px()];
    let mut left: Vec<[f64; 2]> = objects.iter().copied().filter(|o| *o != target).collect();
    let visits = rng.random_range(4..=6usize).min(left.len());
    for _ in 0..visits {
        let here = stops[stops.len() - 1];
        // Prefer near objects: pick the nearest of three random candidates.
        let best = (0..3)
            .map(|_| rng.random_range(0..left.len()))
            .min_by(|&a, &b| {
                let d = |i: usize| (left[i][0] - here[0]).hypot(left[i][1] - here[1]);
                d(a).total_cmp(&d(b))
            })
            .unwrap_or(0);
        stops.push(left.swap_remove(best));
    }
    stops.push(target);
    let dt = 1.0 / fps;
    let px_per_deg = g.local_ppd(g.centre_px());
    let mut frames = Vec::new();
    for (k, &stop) in stops.iter().enumerate() {
        if k > 0 {
            let from = stops[k - 1];
            let amp = g.eccentricity_deg(from, stop);
            let dur = (2.2 * amp + 21.0) / 1000.0;
            let n = (dur / dt).ceil() as usize;
            for i in 1..n {
                let s = i as f64 / n as f64;
                let e = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
                frames.push([
                    from[0] + (stop[0] - from[0]) * e,
                    from[1] + (stop[1] - from[1]) * e,
                ]);
            }
        }
        let hold = rng.random_range(0.25..0.45) * if k + 1 == stops.len() { 2.0 } else { 1.0 };
        for _ in 0..((hold / dt).round() as usize).max(1) {
            let j = 0.1 * px_per_deg;
            frames.push([
                stop[0] + rng.random_range(-j..j),
                stop[1] + rng.random_range(-j..j),
            ]);
        }
    }
    frames
}

fn half(rgb: &[u8], w: usize, h: usize) -> Vec<u8> {
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0u8; hw * hh * 3];
    for y in 0..hh {
        for x in 0..hw {
            for c in 0..3 {
                let at =
                    |dx: usize, dy: usize| u32::from(rgb[3 * ((2 * y + dy) * w + 2 * x + dx) + c]);
                out[3 * (y * hw + x) + c] =
                    ((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1) + 2) / 4) as u8;
            }
        }
    }
    out
}

fn write_apng(path: &Path, (w, h): (u32, u32), fps: u16, frames: &[Vec<u8>]) -> Result<(), String> {
    let fail = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(|e| fail(&e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    enc.set_animated(frames.len() as u32, 0)
        .map_err(|e| fail(&e))?;
    enc.set_frame_delay(1, fps).map_err(|e| fail(&e))?;
    let mut writer = enc.write_header().map_err(|e| fail(&e))?;
    for f in frames {
        writer.write_image_data(f).map_err(|e| fail(&e))?;
    }
    writer.finish().map_err(|e| fail(&e))
}

/// Runs `gazecast demo`.
pub fn run(args: &DemoArgs, out: &mut dyn Write) -> Result<(), String> {
    if !(1..=120).contains(&args.fps) {
        return Err(format!("--fps {}: must be in 1..=120", args.fps));
    }
    let line = |out: &mut dyn Write, s: String| writeln!(out, "{s}").map_err(|e| e.to_string());
    if !args.headless && has_display() {
        line(
            out,
            format!(
                "gazecast demo: the search task in a window; the mouse is the gaze ({MOUSE}). \
                 Keys: P POR box, L layers, H HUD, S screenshot, Esc quit. \
                 (--headless renders the built-in scanpath to {} instead.)",
                args.out.display()
            ),
        )?;
        let view = crate::view_cmd::ViewArgs {
            scene: SCENE.into(),
            display: DISPLAY.into(),
            tracker: Some(MOUSE.into()),
            replay: None,
            calibration: None,
            record: None,
            frames: args.frames,
            screenshot: None,
            overlay: Some("por".into()),
            backend: crate::render_cmd::Backend::Auto,
            fullscreen: false,
            monitor: None,
            explain: false,
        };
        match crate::view_cmd::run(&view, out) {
            Err(e) if e.starts_with(crate::view_cmd::NO_WINDOW) => {
                line(out, format!("{e}; rendering headless instead"))?;
            }
            other => return other,
        }
    }
    line(
        out,
        format!(
            "gazecast demo ({}): rendering the search task headless along a built-in scanpath",
            if args.headless {
                "--headless"
            } else {
                "no display"
            }
        ),
    )?;
    let scene = load_scene(Path::new(SCENE))?;
    let (file, _): (SceneFile, String) =
        config::load(Path::new(SCENE)).map_err(|e| e.to_string())?;
    let display = config::load_display(Path::new(DISPLAY)).map_err(|e| e.to_string())?;
    let g = display.geometry().map_err(|e| e.to_string())?;
    let cam = Camera::new(&g);
    let objects: Vec<[f64; 2]> = file
        .objects
        .iter()
        .map(|o| screen_px(&g, &cam, o.translate_mm))
        .collect();
    let target = file
        .objects
        .iter()
        .position(|o| o.mesh == "target")
        .map(|i| objects[i])
        .ok_or_else(|| format!("{SCENE}: no object with mesh `target`"))?;
    let gazes = scanpath(&g, &objects, target, f64::from(args.fps), args.seed);
    let model = crate::render_cmd::sampling_model(g, 1.0).map_err(|e| e.to_string())?;
    let settings = crate::render_cmd::foveated_settings(&scene);
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create: {e}", args.out.display()))?;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let mut frames = Vec::with_capacity(gazes.len());
    let (mut rays, mut ms) = (0u64, 0.0f64);
    for (k, &gaze) in gazes.iter().enumerate() {
        let (mut frame, stats) =
            render(&scene, &cam, &model, &settings, gaze).map_err(|e| e.to_string())?;
        draw_por_box(&mut frame.rgb, frame.width, frame.height, gaze);
        line(
            out,
            format!(
                "frame {k:3}  t {:6.3} s  gaze ({:6.1}, {:6.1})  rays {:7}  ({:4.1} % of a full frame)  {:6.1} ms",
                k as f64 / f64::from(args.fps),
                gaze[0],
                gaze[1],
                stats.rays_total,
                100.0 * stats.rays_total as f64 / (w * h) as f64,
                stats.time_ms
            ),
        )?;
        rays += stats.rays_total;
        ms += stats.time_ms;
        frames.push(half(&frame.rgb, w, h));
    }
    let (hw, hh) = (w / 2, h / 2);
    let anim = args.out.join("demo.png");
    write_apng(&anim, (hw as u32, hh as u32), args.fps, &frames)?;
    // Contact sheet: 12 frames evenly spread, 4 × 3, at half the animation's size.
    let (tw, th) = (hw / 2, hh / 2);
    let (cols, rows) = (4usize, 3usize);
    let mut sheet = vec![255u8; cols * tw * rows * th * 3];
    for s in 0..cols * rows {
        let k = s * (frames.len() - 1) / (cols * rows - 1).max(1);
        let mut thumb = half(&frames[k], hw, hh);
        let g = gazes[k];
        draw_box(
            &mut thumb,
            tw as u32,
            th as u32,
            [g[0] / 4.0, g[1] / 4.0],
            10,
        );
        let (ox, oy) = ((s % cols) * tw, (s / cols) * th);
        for y in 0..th {
            let row = &thumb[3 * y * tw..3 * (y + 1) * tw];
            let at = 3 * ((oy + y) * cols * tw + ox);
            sheet[at..at + 3 * tw].copy_from_slice(row);
        }
    }
    let sheet_path = args.out.join("demo-sheet.png");
    crate::plots::save_png(
        &sheet_path,
        ((cols * tw) as u32, (rows * th) as u32),
        &sheet,
    )
    .map_err(|e| format!("{}: {e}", sheet_path.display()))?;
    let n = gazes.len() as f64;
    line(
        out,
        format!(
            "{} frames on cpu ({} threads): mean {:.0} rays ({:.1} % of {}x{}), mean {:.1} ms; wrote {} and {}",
            gazes.len(),
            rayon::current_num_threads(),
            rays as f64 / n,
            100.0 * rays as f64 / n / (w * h) as f64,
            w,
            h,
            ms / n,
            anim.display(),
            sheet_path.display()
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scanpath_starts_at_the_centre_and_ends_on_the_target() {
        let g = foveation::Display {
            name: "t".into(),
            resolution_px: (1280, 1024),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 540.0,
            eye_point_px: None,
        }
        .geometry()
        .expect("display");
        let objects: Vec<[f64; 2]> = (0..25)
            .map(|i| {
                [
                    340.0 + 150.0 * f64::from(i % 5),
                    212.0 + 150.0 * f64::from(i / 5),
                ]
            })
            .collect();
        let target = objects[16];
        let path = scanpath(&g, &objects, target, 30.0, 1);
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 5.0;
        assert!(close(path[0], g.centre_px()));
        assert!(close(path[path.len() - 1], target));
        assert_eq!(path, scanpath(&g, &objects, target, 30.0, 1), "seeded");
        assert!(path.len() > 30 && path.len() < 200, "{}", path.len());
        // No jump between frames longer than a saccade covers in one frame.
        for w in path.windows(2) {
            assert!((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) < 400.0);
        }
    }
}
