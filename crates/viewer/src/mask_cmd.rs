//! `gazecast mask`: build the ray mask for one gaze and report it.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use foveation::{bound, mask, Display, GeislerPerry, Layout, RayMask, SamplingModel};
use serde::Serialize;

use crate::args::parse_point;
use crate::config;
use crate::plots;

/// Arguments of `gazecast mask`.
#[derive(Debug, Clone, clap::Args)]
pub struct MaskArgs {
    /// Display file (RON). Default: the display named in config/default.ron.
    #[arg(long, value_name = "FILE")]
    pub display: Option<PathBuf>,
    /// Point of regard in screen pixels, origin top-left. Default: the screen centre.
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    pub gaze: Option<[f64; 2]>,
    /// Eye-to-screen distance, overriding the display file.
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    pub eye_distance_mm: Option<f64>,
    /// Michelson contrast C of the CSF cut-off (1 = the seed's conservative case).
    #[arg(
        long,
        value_name = "C",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub contrast: f64,
    /// Ring layout.
    #[arg(long, value_name = "nyquist|seed", default_value = "nyquist")]
    pub layout: Layout,
    /// Largest ray spacing in pixels (the seed's n_max).
    #[arg(long, value_name = "N", default_value_t = foveation::sampling::SEED_MAX_SPACING_PX)]
    pub max_spacing_px: f64,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Write the on-screen rays as CSV (`x_px,y_px`).
    #[arg(long, value_name = "FILE.csv")]
    pub points: Option<PathBuf>,
    /// Draw the mask and its mesh; also writes `<name>-csf.png`.
    #[arg(long, value_name = "FILE.png")]
    pub png: Option<PathBuf>,
}

/// What `--json` prints. The first eight fields are the command-line
/// contract; the rest add detail.
#[derive(Debug, Clone, Serialize)]
pub struct MaskReport {
    /// Display width, pixels.
    pub width_px: u32,
    /// Display height, pixels.
    pub height_px: u32,
    /// Conservative local pixels per degree at the gaze point.
    pub ppd: f64,
    /// Radius of the fovea disc (one ray per pixel), pixels.
    pub fovea_radius_px: f64,
    /// Rays inside the screen for this gaze.
    pub rays: usize,
    /// The Nyquist bound on the ray count for this gaze.
    pub nyquist_bound_rays: f64,
    /// The mask's layout (`nyquist` or `seed`).
    pub layout: &'static str,
    /// Time to build the mask, ms.
    pub mask_build_ms: f64,
    /// The display's name.
    pub display: String,
    /// The gaze, screen px.
    pub gaze_px: [f64; 2],
    /// Eye-to-screen distance, mm.
    pub eye_distance_mm: f64,
    /// Michelson contrast of the CSF cut-off.
    pub contrast: f64,
    /// Largest ray spacing allowed, pixels.
    pub max_spacing_px: f64,
    /// Rays in the fovea disc.
    pub fovea_rays: usize,
    /// Rays on the rings (mesh vertices on the screen).
    pub ring_rays: usize,
    /// Mesh vertices just off the screen that close the edge cells.
    pub off_screen_vertices: usize,
    /// Rings outside the fovea.
    pub rings: usize,
    /// Quadrilateral cells of the mesh.
    pub quads: usize,
    /// Triangular cells of the mesh.
    pub triangles: usize,
    /// rays / nyquist_bound_rays.
    pub ratio_to_bound: f64,
}

/// A mask with everything it was built from.
pub struct BuiltMask {
    /// The display.
    pub display: Display,
    /// The sampling model the mask was built with.
    pub model: SamplingModel,
    /// The mask.
    pub mask: RayMask,
    /// What `--json` prints about it.
    pub report: MaskReport,
}

/// Builds the mask the arguments describe.
pub fn build(args: &MaskArgs) -> Result<BuiltMask, String> {
    let display_path = match &args.display {
        Some(p) => p.clone(),
        None => config::default_display_path().map_err(|e| {
            format!(
                "{e}\n(no --display given; run from the repository root or set GAZECAST_CONFIG)"
            )
        })?,
    };
    let mut display = config::load_display(&display_path).map_err(|e| e.to_string())?;
    if let Some(d) = args.eye_distance_mm {
        display.eye_distance_mm = d;
    }
    // The same ranges as a display file's (1 mm to 100 m for the distance):
    // beyond them pixels per degree is not finite or means nothing.
    let geometry =
        config::check_display(&display).map_err(|e| format!("--eye-distance-mm: {e}"))?;
    let model = SamplingModel::new(
        geometry,
        GeislerPerry::default(),
        args.contrast,
        args.max_spacing_px,
    )
    .map_err(|e| format!("--{}: {e}", e.field.replace('_', "-")))?;
    let gaze = args.gaze.unwrap_or_else(|| geometry.centre_px());
    let start = Instant::now();
    let mask = mask::build(&model, args.layout, gaze).map_err(|e| format!("--gaze: {e}"))?;
    let mask_build_ms = start.elapsed().as_secs_f64() * 1e3;
    let nyquist_bound_rays = bound::nyquist_bound_rays(&model, gaze);
    let (quads, triangles) = mask.cell_counts();
    let rays = mask.rays();
    let report = MaskReport {
        width_px: geometry.width_px,
        height_px: geometry.height_px,
        ppd: geometry.local_ppd(gaze),
        fovea_radius_px: mask.fovea_radius_px,
        rays,
        nyquist_bound_rays,
        layout: args.layout.name(),
        mask_build_ms,
        display: display.name.clone(),
        gaze_px: gaze,
        eye_distance_mm: geometry.eye_distance_mm,
        contrast: args.contrast,
        max_spacing_px: args.max_spacing_px,
        fovea_rays: mask.fovea_rays(),
        ring_rays: mask.ring_rays(),
        off_screen_vertices: mask.off_screen_vertices(),
        rings: mask.rings.len(),
        quads,
        triangles,
        ratio_to_bound: rays as f64 / nyquist_bound_rays,
    };
    Ok(BuiltMask {
        display,
        model,
        mask,
        report,
    })
}

/// Runs `gazecast mask`, writing the summary or JSON to `out`.
pub fn run(args: &MaskArgs, out: &mut dyn Write) -> Result<(), String> {
    let mut outputs = Vec::new();
    outputs.extend(args.points.as_deref().map(|p| ("--points", p)));
    outputs.extend(args.png.as_deref().map(|p| ("--png", p)));
    let inputs: Vec<(&str, &Path)> = args
        .display
        .as_deref()
        .map(|p| ("--display", p))
        .into_iter()
        .collect();
    crate::output::refuse_inputs(&outputs, &inputs)?;
    let built = build(args)?;
    if let Some(path) = &args.points {
        write_points(path, &built.mask)?;
    }
    let mut written = Vec::new();
    if let Some(path) = &args.png {
        let (mask, model) = (&built.mask, &built.model);
        plots::draw_mask(path, mask, model, built.report.nyquist_bound_rays)
            .map_err(|e| format!("{}: cannot draw the mask: {e}", path.display()))?;
        let csf = plots::csf_path(path);
        plots::draw_csf(&csf, mask, model, &built.display.name)
            .map_err(|e| format!("{}: cannot draw the CSF plot: {e}", csf.display()))?;
        written.push(path.clone());
        written.push(csf);
    }
    let r = &built.report;
    let text = if args.json {
        serde_json::to_string(r).map_err(|e| e.to_string())?
    } else {
        let mut s = format!(
            "{} ({}x{} px, eye at {} mm), gaze ({:.1}, {:.1}), contrast {}, layout {}\n\
             rays {} = fovea {} + rings {} ({:.3}x the Nyquist bound of {:.0}); \
             {} mesh vertices off screen\n\
             fovea radius {:.1} px, {:.1} px/deg at the gaze, {} rings, {} quads + {} triangles, built in {:.2} ms",
            r.display, r.width_px, r.height_px, r.eye_distance_mm, r.gaze_px[0], r.gaze_px[1], r.contrast,
            r.layout, r.rays, r.fovea_rays, r.ring_rays, r.ratio_to_bound, r.nyquist_bound_rays,
            r.off_screen_vertices, r.fovea_radius_px, r.ppd, r.rings, r.quads, r.triangles, r.mask_build_ms
        );
        for w in &written {
            s.push_str(&format!("\nwrote {}", w.display()));
        }
        s
    };
    writeln!(out, "{text}").map_err(|e| format!("cannot write the output: {e}"))
}

fn write_points(path: &Path, mask: &RayMask) -> Result<(), String> {
    let fail = |e: std::io::Error| format!("{}: cannot write the points: {e}", path.display());
    let mut w = crate::output::AtomicFile::create(path).map_err(fail)?;
    writeln!(w, "x_px,y_px").map_err(fail)?;
    for p in mask.ray_positions() {
        writeln!(w, "{},{}", p[0], p[1]).map_err(fail)?;
    }
    w.commit().map_err(fail)
}
