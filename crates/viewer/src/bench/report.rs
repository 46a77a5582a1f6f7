//! The files the bench writes: `results.csv` and `report.md` of the
//! accuracy sweep, `scaling.csv` and `scaling.md` of the scaling sweep.

use std::fmt::Write as _;
use std::path::Path;

use foveation::{Display, ScreenGeometry};
use raycast::Scene;

use crate::args::AccelArg;
use crate::bench::scaling::ScalingPoint;
use crate::bench::summary::{Row, Summary};
use crate::bench::{AccuracyArgs, ScalingArgs};

/// Creates the output folder (and its parents).
pub fn create_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create: {e}", dir.display()))
}

/// Writes one output file.
pub fn write_file(path: &Path, text: &str) -> Result<(), String> {
    crate::output::write_whole(path, text.as_bytes())
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// A PSNR figure: 3 decimals, `inf` when exact, empty when undefined.
pub fn fmt_db(v: Option<f64>) -> String {
    match v {
        None => String::new(),
        Some(x) if x.is_infinite() => "inf".into(),
        Some(x) => format!("{x:.3}"),
    }
}

/// The header of `results.csv`.
pub const RESULTS_HEADER: &str = "scene,width_px,height_px,backend,threads,config,layout,contrast,max_spacing_px,refinement,accel,gaze_index,gaze_x_px,gaze_y_px,time_ms,rays_total,rays_fovea,rays_mask,rays_refine,cells_total,cells_refined,psnr_db,psnr_2deg_db,psnr_5deg_db,psnr_10deg_db,foveated_psnr_db,silhouette_error";

/// `results.csv`: one row per configuration and gaze.
pub fn results_csv(rows: &[Row], scene: &str, g: &ScreenGeometry, threads: usize) -> String {
    let mut s = String::from(RESULTS_HEADER);
    s.push('\n');
    for r in rows {
        let c = &r.config;
        let q = &r.quality;
        let _ = writeln!(
            s,
            "{scene},{},{},cpu,{threads},{},{},{},{},{},{},{},{:.2},{:.2},{:.3},{},{},{},{},{},{},{},{},{},{},{},{}",
            g.width_px,
            g.height_px,
            c.name(),
            c.layout.map_or(c.method.name(), |l| l.name()),
            c.contrast,
            c.max_spacing_px,
            c.refinement.name(),
            c.accel.name(),
            r.gaze_index,
            r.gaze_px[0],
            r.gaze_px[1],
            r.stats.time_ms,
            r.stats.rays_total,
            r.stats.rays_fovea,
            r.stats.rays_mask,
            r.stats.rays_refine,
            r.stats.cells_total,
            r.stats.cells_refined,
            fmt_db(q.screen.psnr_db()),
            fmt_db(q.within[0].psnr_db()),
            fmt_db(q.within[1].psnr_db()),
            fmt_db(q.within[2].psnr_db()),
            fmt_db(q.foveated.psnr_db()),
            q.silhouette_error().map_or(String::new(), |e| format!("{e:.6}")),
        );
    }
    s
}

/// The processor, as the OS names it (Linux), and the thread count.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!(
        "{cpu}, {} rayon threads, CPU backend",
        rayon::current_num_threads()
    )
}

const METRICS_DOC: &str = "\
- **time**: wall time of one whole frame on the CPU backend (mask build, all rays, \
reconstruction, shading), median of the repeats after one warm-up, then the mean over the gazes.
- **rays**: rays cast per frame (fovea + mask vertices + refined pixels), mean over the gazes.
- **PSNR**: `10·log10(255²/MSE)` against the full-resolution frame of the same gaze, over all \
pixels and channels (8-bit). Over several gazes the MSEs are averaged first, so ∞ means exact at every gaze.
- **≤2°, ≤5°, ≤10°**: the same over the pixels within that visual angle of the gaze.
- **foveated PSNR**: PSNR of the visibility-weighted MSE `Σ w·e² / Σ w`, where `e²` is a pixel's \
squared error and `w = min(1, f_c(e)/f_N)`: the Geisler–Perry cut-off frequency at full contrast \
(Murphy 2007 eq. 4.3, C = 1) at the pixel's eccentricity, over the display's Nyquist frequency there \
(half the conservative local pixels per degree). It is the fraction of the frequencies the display \
can show at that pixel that the eye can see there: 1 where single pixels are resolved, smaller in \
the periphery. An error spread evenly gives the plain PSNR; the same error moved away from the gaze \
scores higher.
- **silhouette error**: fraction of pixels whose hit/miss (geometry or background) differs from the \
reference.
- **Pareto**: no other configuration is at least as fast and at least as good in foveated PSNR.
- Configurations: layout (`seed`: the seed's integer spacing; `nyquist`: the default), contrast C of \
the CSF cut-off (lower = sparser), maximum spacing n in pixels, refinement triggers (none; silhouette \
= corners disagree on hit/miss or object, plus the one-cell margin; + crease = corner normals differ \
by more than the scene's crease angle), acceleration structure (`bvh`; `grid`: the seed's uniform \
grid, §6.1.1). `full` casts one ray per pixel (the reference). `image` is image-based foveation \
(Geisler & Perry 1998): the full frame blurred by a Gaussian pyramid to level log2(ray spacing) at \
each pixel, the spacing from the same C and n (its silhouettes are the full frame's by construction; \
its time includes the full frame it blurs). `simplify` (Luebke & Hallen, imperceptible mode) and \
`lod` (Murphy & Duchowski, Table 1 levels) simplify each object's vertex tree for the gaze and \
rasterise it on the CPU; `simplify budget=N` (`--budget N`) is Luebke & Hallen's best-effort mode, \
at most N triangles.";

/// `report.md` of the accuracy sweep.
pub fn accuracy_report(
    args: &AccuracyArgs,
    scene: &Scene,
    display: &Display,
    gazes: &[[f64; 2]],
    repeats: u32,
    summaries: &[Summary],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Accuracy versus time: `{}` on {}\n",
        scene.name, display.name
    );
    let _ = writeln!(
        s,
        "Command: `gazecast bench accuracy --scene {} --display {} --out {} --gazes {}{}{}`\n",
        args.scene.display(),
        args.display.display(),
        args.out.display(),
        gazes.len(),
        args.repeats
            .map_or(String::new(), |r| format!(" --repeats {r}")),
        if args.quick { " --quick" } else { "" }
    );
    let _ = writeln!(s, "- Machine: {}", machine());
    let _ = writeln!(
        s,
        "- Thresholds: {}",
        // Loaded (and checked) before the sweep ran.
        match args.thresholds.load().ok().flatten() {
            Some(t) => format!("{} (`--thresholds`)", t.source()),
            None => "the default Geisler–Perry model (CT0 1/64, α 0.106, e2 2.3°)".to_string(),
        }
    );
    let _ = writeln!(
        s,
        "- Resolution {}x{}, {} triangles, {} timed repeats per frame",
        display.resolution_px.0,
        display.resolution_px.1,
        scene.triangles.len(),
        repeats
    );
    let gz: Vec<String> = gazes
        .iter()
        .map(|g| format!("({:.0}, {:.0})", g[0], g[1]))
        .collect();
    let _ = writeln!(s, "- Gazes (px): {}\n", gz.join(", "));
    let _ = writeln!(s, "![quality against time](pareto.png)\n");
    let full = summaries
        .iter()
        .find(|x| x.config.method == pipeline::Method::Full && x.config.accel == AccelArg::Bvh)
        .map_or(f64::NAN, |x| x.time_ms);
    let _ = writeln!(s, "## Results, fastest first\n");
    let _ = writeln!(
        s,
        "| configuration | time ms | speed-up vs full bvh | rays | PSNR dB | ≤2° | ≤5° | ≤10° | foveated PSNR dB | silhouette error % | Pareto |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|:-:|");
    let mut sorted: Vec<&Summary> = summaries.iter().collect();
    sorted.sort_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
    for x in &sorted {
        let q = &x.quality;
        let name = if x.config.is_default() {
            format!("**{}** (default)", x.config.name())
        } else {
            x.config.name()
        };
        let _ = writeln!(
            s,
            "| {name} | {:.1} | {:.2} | {:.0} | {} | {} | {} | {} | {} | {} | {} |",
            x.time_ms,
            full / x.time_ms,
            x.rays,
            fmt_db(q.screen.psnr_db()),
            fmt_db(q.within[0].psnr_db()),
            fmt_db(q.within[1].psnr_db()),
            fmt_db(q.within[2].psnr_db()),
            fmt_db(q.foveated.psnr_db()),
            q.silhouette_error()
                .map_or(String::new(), |e| format!("{:.3}", 100.0 * e)),
            if x.pareto { "●" } else { "" }
        );
    }
    let _ = writeln!(s, "\n## What the columns mean\n\n{METRICS_DOC}");
    s
}

/// `scaling.csv`: one row per point.
pub fn scaling_csv(points: &[ScalingPoint]) -> String {
    let mut csv = String::from(
        "axis,triangles,width_px,height_px,pixels,full_ms,foveated_ms,full_rays,foveated_rays\n",
    );
    for p in points {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{:.3},{:.3},{},{}",
            p.axis,
            p.triangles,
            p.width_px,
            p.height_px,
            u64::from(p.width_px) * u64::from(p.height_px),
            p.full_ms,
            p.foveated_ms,
            p.full_rays,
            p.foveated_rays
        );
    }
    csv
}

/// `scaling.md`; `exponents`: the time exponents against triangles (full,
/// foveated) and pixels (full, foveated), formatted.
pub fn scaling_report(
    args: &ScalingArgs,
    repeats: u32,
    points: &[ScalingPoint],
    exponents: &[String; 4],
) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Scaling: frame time against triangles and pixels\n");
    let _ = writeln!(
        md,
        "Command: `gazecast bench scaling --out {}{}`\n\n- Machine: {}\n- Scene: a tilted torus \
         (procedural), gaze at the screen centre, default configuration (nyquist, C = 1, n = 17, \
         silhouette + crease)\n- {} timed repeats after one warm-up, median\n",
        args.out.display(),
        if args.quick { " --quick" } else { "" },
        machine(),
        repeats
    );
    let _ = writeln!(
        md,
        "Exponent k of time ∝ x^k (least squares on the logs): triangles — full {}, foveated {}; \
         pixels — full {}, foveated {}.\n",
        exponents[0], exponents[1], exponents[2], exponents[3]
    );
    let _ = writeln!(md, "![time vs triangles](scaling-triangles.png)\n");
    let _ = writeln!(md, "![time vs pixels](scaling-resolution.png)\n");
    let _ = writeln!(
        md,
        "| axis | triangles | resolution | full ms | foveated ms | full/foveated | full rays | foveated rays |"
    );
    let _ = writeln!(md, "|---|---:|---|---:|---:|---:|---:|---:|");
    for p in points {
        let _ = writeln!(
            md,
            "| {} | {} | {}x{} | {:.1} | {:.1} | {:.2} | {} | {} |",
            p.axis,
            p.triangles,
            p.width_px,
            p.height_px,
            p.full_ms,
            p.foveated_ms,
            p.full_ms / p.foveated_ms,
            p.full_rays,
            p.foveated_rays
        );
    }
    md
}
