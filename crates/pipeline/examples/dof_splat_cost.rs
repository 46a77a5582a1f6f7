//! Cost of the ch. 5 depth-of-field pass (splatting on per-pixel layers,
//! `pipeline::effects::dof_splat`) against the mean circle of confusion,
//! next to the ch. 4 pass, on the CPU this runs on:
//!
//! ```text
//! cargo run -p pipeline --profile test --example dof_splat_cost [-- --quick]
//! ```
//!
//! The scene is the background-blur scene of `tests/dof_splat.rs` (a wall
//! of bumpy balls 1.5 m behind the screen, one ball at the screen, in
//! focus); the pupil is scaled so that the frame's mean CoC (each pixel's
//! CoC, clamped to `MAX_COC_PX`) is 8, 16 or 32 px. Each pass is timed over
//! a few frames (median); the sharp frame is rendered once. `--quick` does
//! 160×128 only.

use std::time::Instant;

use foveation::thin_lens::EyeLens;
use foveation::Display;
use pipeline::effects::depth_of_field::DepthOfField;
use pipeline::effects::dof_splat::{signed_coc_px, DepthOfFieldSplat};
use pipeline::effects::{Pass, PassInput};
use pipeline::{BackendChoice, Options, Renderer};
use raycast::scene::DofFocus;
use raycast::{Camera, Frame, Scene};

/// The in-focus ball's eye distance, mm.
const FOCUS_MM: f64 = 480.0;

fn display(w: u32, h: u32) -> Display {
    Display::seed_17in(w, h)
}

#[path = "../tests/common/dof_wall.rs"]
mod dof_wall;
use dof_wall::{NEAR_BALL, SCREEN_BALL, WALL_FOCUS_MM};

fn scene(front: &str) -> Result<Scene, Box<dyn std::error::Error>> {
    Ok(dof_wall::wall(front, "")?)
}

fn lens(pupil_mm: f64) -> EyeLens {
    EyeLens {
        aperture_mm: pupil_mm,
        ..EyeLens::default()
    }
}

/// Mean CoC (px) of `frame` for `pupil_mm` focused at `focus_mm`.
fn mean_coc(frame: &Frame, cam: &Camera, pupil_mm: f64, focus_mm: f64) -> f64 {
    let pitch = cam.pitch();
    let ppmm = 0.5 * (1.0 / f64::from(pitch[0]) + 1.0 / f64::from(pitch[1]));
    let ds = f64::from(cam.eye.z);
    let l = lens(pupil_mm);
    let sum: f64 = frame
        .depth_mm
        .iter()
        .map(|&d| f64::from(signed_coc_px(&l, f64::from(d), focus_mm, ds, ppmm).abs()))
        .sum();
    sum / frame.depth_mm.len().max(1) as f64
}

/// Median wall time (ms) of `pass` over `runs` frames.
fn time(pass: &mut dyn Pass, sharp: &Frame, scene: &Scene, cam: &Camera, runs: usize) -> f64 {
    let mut ms: Vec<f64> = (0..runs)
        .map(|_| {
            let mut f = sharp.clone();
            let t = Instant::now();
            pass.run(
                &mut f,
                &PassInput {
                    scene,
                    camera: cam,
                    gaze_px: [0.0, 0.0],
                    time_s: None,
                    vergence_mm: None,
                },
            );
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    ms[ms.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let quick = std::env::args().any(|a| a == "--quick");
    let s = scene(SCREEN_BALL)?;
    let fg = scene(NEAR_BALL)?;
    let sizes: &[(u32, u32)] = if quick {
        &[(160, 128)]
    } else {
        &[(160, 128), (640, 512)]
    };
    println!(
        "DOF pass cost, CPU, {} rayon threads ({} logical CPUs), profile {}",
        rayon::current_num_threads(),
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        if cfg!(debug_assertions) {
            "with debug assertions"
        } else {
            "optimised"
        },
    );
    println!("| frame | scene | mean CoC target px | pupil mm | mean CoC px | hidden samples | ch. 5 splat ms | ch. 4 mipmap ms |");
    println!("|---|---|---|---|---|---|---|---|");
    for &(w, h) in sizes {
        let g = display(w, h).geometry()?;
        let cam = Camera::new(&g);
        let model = pipeline::sampling_model(g, 1.0)?;
        let mut r = Renderer::new(
            &s,
            cam,
            model,
            &Options {
                backend: BackendChoice::Cpu,
                surface: true,
                ..Options::default()
            },
        )?;
        let sharp = r.render_at([0.0, 0.0], 0.0)?.0;
        let per_mm = mean_coc(&sharp, &cam, 1.0, FOCUS_MM);
        let runs = if w * h > 100_000 { 3 } else { 5 };
        let row = |scene: &Scene,
                   name: &str,
                   sharp: &Frame,
                   target: String,
                   pupil: f64,
                   focus_mm: f64| {
            let focus = DofFocus::Fixed { depth_mm: focus_mm };
            let mut splat = DepthOfFieldSplat::new(lens(pupil), focus);
            let splat_ms = time(&mut splat, sharp, scene, &cam, runs);
            let mut ch4 = DepthOfField::new(lens(pupil), focus);
            let ch4_ms = time(&mut ch4, sharp, scene, &cam, runs);
            println!(
                "| {w}×{h} | {name} | {target} | {pupil:.1} | {:.1} | {} | {splat_ms:.1} | {ch4_ms:.1} |",
                mean_coc(sharp, &cam, pupil, focus_mm),
                splat.hidden_samples(),
            );
        };
        for target in [8.0, 16.0, 32.0] {
            row(
                &s,
                "background blur",
                &sharp,
                format!("{target}"),
                target / per_mm,
                FOCUS_MM,
            );
        }
        // The PSNR test's foreground-blur set-up (16-mm pupil).
        let model = pipeline::sampling_model(g, 1.0)?;
        let mut r = Renderer::new(
            &fg,
            cam,
            model,
            &Options {
                backend: BackendChoice::Cpu,
                surface: true,
                ..Options::default()
            },
        )?;
        let sharp_fg = r.render_at([0.0, 0.0], 0.0)?.0;
        row(
            &fg,
            "foreground blur",
            &sharp_fg,
            "—".into(),
            16.0,
            WALL_FOCUS_MM,
        );
    }
    Ok(())
}
