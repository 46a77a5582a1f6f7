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
use raycast::{Camera, SceneFile};

use crate::config::{self, load_scene};
use crate::live::{self, LiveError, LiveOptions};
use crate::picture::{draw_box, half_size, save_apng, save_png};

/// `gazecast demo`'s arguments.
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
    /// The rendering method (`foveated` is an alias of `hybrid`).
    #[arg(long, value_parser = crate::args::method_parser(), default_value = "hybrid")]
    pub method: pipeline::Method,
    /// Model-based methods' options (budget, no gaze).
    #[command(flatten)]
    pub model_based: crate::args::ModelBasedArgs,
    /// A participant's thresholds file instead of the default CSF model.
    #[command(flatten)]
    pub thresholds: crate::args::ThresholdsArg,
    /// Hybrid method: keep a ray mask while the gaze stays within DEG
    /// degrees of the gaze it was built for (see `view --help`).
    #[arg(long, value_name = "DEG", default_value_t = crate::args::LIVE_GAZE_TOLERANCE_DEG,
          value_parser = crate::args::parse_gaze_tolerance)]
    pub gaze_tolerance: f64,
    /// Window mode: the gaze source (`config/trackers/attention.ron`:
    /// Lee's attention model predicts it from each frame, no tracker).
    #[arg(long, value_name = "FILE.ron", default_value = MOUSE)]
    pub tracker: PathBuf,
    /// Window mode only (the headless scanpath publishes nothing).
    #[command(flatten)]
    pub lsl: crate::args::LslArgs,
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

/// Runs `gazecast demo`.
pub fn run(args: &DemoArgs, out: &mut dyn Write) -> Result<(), String> {
    if !(1..=120).contains(&args.fps) {
        return Err(format!("--fps {}: must be in 1..=120", args.fps));
    }
    args.lsl.check()?;
    args.model_based.check(args.method)?;
    let line = |out: &mut dyn Write, s: String| writeln!(out, "{s}").map_err(|e| e.to_string());
    if !args.headless && has_display() {
        line(
            out,
            format!(
                "gazecast demo: the search task in a window; the gaze from {}. \
                 Keys: P POR box, L layers, H HUD, S screenshot, Esc quit. \
                 (--headless renders the built-in scanpath to {} instead.)",
                args.tracker.display(),
                args.out.display()
            ),
        )?;
        let session = LiveOptions {
            scene: SCENE.into(),
            display: DISPLAY.into(),
            tracker: Some(args.tracker.clone()),
            frames: args.frames,
            // The box is drawn into the frame; an attention model reading
            // the frame would see it, so it is off when the model leads.
            por_overlay: crate::config::load_tracker(&args.tracker).map_or(true, |t| {
                !matches!(t.driver, tracker_hal::Driver::Attention(_))
            }),
            backend: pipeline::BackendChoice::Auto,
            method: args.method,
            model_based: args.model_based.into(),
            thresholds: args.thresholds.thresholds.clone(),
            gaze_tolerance_deg: args.gaze_tolerance,
            lsl: args.lsl.options("demo", String::new(), false),
            ..LiveOptions::default()
        };
        match live::run(&session, out) {
            Err(LiveError::NoWindow(cause)) => {
                line(
                    out,
                    format!("cannot open a window ({cause}); rendering headless instead"),
                )?;
            }
            other => return other.map_err(|e| e.to_string()),
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
    if args.lsl.lsl {
        line(
            out,
            "--lsl: the headless demo publishes no LSL streams (the window's does)".into(),
        )?;
    }
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
    let gazes =
        tracker_hal::sim::search_scanpath(&g, &objects, target, f64::from(args.fps), args.seed);
    let thresholds = args.thresholds.load()?;
    let model = crate::args::sampling_model_for(g, 1.0, args.gaze_tolerance, thresholds.as_ref())?;
    let options = pipeline::Options {
        method: args.method,
        por_overlay: true,
        model_based: args.model_based.into(),
        reuse: true,
        ..pipeline::Options::default()
    };
    let mut renderer =
        pipeline::Renderer::new(&scene, cam, model, &options).map_err(|e| e.to_string())?;
    if let Some(t) = &thresholds {
        t.apply(&mut renderer);
        line(out, format!("thresholds: {}", t.source()))?;
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: cannot create: {e}", args.out.display()))?;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let mut frames = Vec::with_capacity(gazes.len());
    let (mut rays, mut ms) = (0u64, 0.0f64);
    let (mut new_masks, mut copied) = (0u32, 0u32);
    for (k, &gaze) in gazes.iter().enumerate() {
        let (frame, stats) = renderer.render(gaze).map_err(|e| e.to_string())?;
        let model = renderer
            .model_based()
            .map(|m| {
                crate::render_cmd::ModelBasedReport::new(m.last(), args.model_based.no_gaze).line()
            })
            .or_else(|| renderer.ulod().map(|u| u.last().line()));
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
        if let Some(m) = model {
            line(out, format!("          {m}"))?;
        }
        rays += stats.rays_total;
        ms += stats.time_ms;
        let reuse = renderer.reuse_stats();
        if reuse.frame_reused {
            copied += 1;
        } else if stats.rays_mask > 0 && !reuse.mask_reused {
            new_masks += 1;
        }
        frames.push(half_size(&frame.rgb, w, h));
        renderer.recycle(frame);
    }
    let (hw, hh) = (w / 2, h / 2);
    let anim = args.out.join("demo.png");
    save_apng(&anim, (hw as u32, hh as u32), args.fps, &frames)
        .map_err(|e| format!("{}: {e}", anim.display()))?;
    // Contact sheet: 12 frames evenly spread, 4 × 3, at half the animation's size.
    let (tw, th) = (hw / 2, hh / 2);
    let (cols, rows) = (4usize, 3usize);
    let mut sheet = vec![255u8; cols * tw * rows * th * 3];
    for s in 0..cols * rows {
        let k = s * (frames.len() - 1) / (cols * rows - 1).max(1);
        let mut thumb = half_size(&frames[k], hw, hh);
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
    save_png(
        &sheet_path,
        ((cols * tw) as u32, (rows * th) as u32),
        &sheet,
    )
    .map_err(|e| format!("{}: {e}", sheet_path.display()))?;
    let n = gazes.len() as f64;
    line(
        out,
        format!(
            "{} frames on cpu ({} threads): mean {:.0} rays ({:.1} % of {}x{}), mean {:.1} ms ({new_masks} drew a new ray mask, {copied} were the last frame copied: gaze tolerance {}°); wrote {} and {}",
            gazes.len(),
            rayon::current_num_threads(),
            rays as f64 / n,
            100.0 * rays as f64 / n / (w * h) as f64,
            w,
            h,
            ms / n,
            args.gaze_tolerance,
            anim.display(),
            sheet_path.display()
        ),
    )
}
