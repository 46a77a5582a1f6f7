//! Temporal reuse during fixations (issue 15): frames per second of the
//! foveated CPU renderer along synthesised gaze traces, with reuse
//! ([`Scratch::with_reuse`]) and without ([`Scratch::default`], what
//! `pipeline::Renderer` keeps today), side by side in one run.
//!
//! ```text
//! cargo bench -p raycast --no-default-features --bench reuse -- \
//!     [--scene FILE] [--display FILE] [--frames N] [--rounds R] [--seed S]
//!     [--tolerance DEG]
//! ```
//!
//! Defaults: `config/scenes/search-task.ron` on the seed's display
//! (`config/displays/tobii-et1750-17in.ron`, 1280×1024), 24 frames a trace,
//! 3 rounds, no gaze tolerance (`--tolerance DEG`: the sampling model's
//! `gaze_tolerance_deg`, so that a fixation keeps its mask). Each round renders every trace once without reuse and once
//! with it (a fresh scratch each time, so a trace's first frame finds an
//! empty cache), the two alternating so both see the same machine load.
//! Every frame with reuse is checked byte for byte against the one without.
//!
//! The traces are **synthetic** (not a person's gaze), one frame per sample
//! of a 120 Hz stream:
//! - `fixation`: a fixation on the screen centre with tracker noise, each
//!   sample uniform in the disc of 0.5° radius around it;
//! - `saccades`: every sample a new fixation, uniform on the screen and at
//!   least 5° from the last (a frame per saccade: reuse's worst case);
//! - `still`: one gaze, bit for bit, every frame (a mouse at rest, or a
//!   tracker that repeats its last sample);
//! - `head`: the `fixation` trace with the eye moving 0.01 mm a frame
//!   (head tracking): the cache is emptied every frame, so this measures
//!   what reuse costs when it cannot pay.
//!
//! Printed: per trace and mode, frames per second over the trace (frames /
//! total wall time, the median over rounds), the on/off ratio per round,
//! each stage's mean wall time, and the share of cast pixels that came
//! from the cache.

use std::path::{Path, PathBuf};
use std::time::Instant;

use foveation::SamplingModel;
use raycast::render::{render_with, Scratch, Settings, StageTimes};
use raycast::{Camera, Frame, Scene, SceneFile};

mod common;
use common::{display_model, foveated, median, read, repo};

struct Args {
    scene: PathBuf,
    display: PathBuf,
    frames: usize,
    rounds: usize,
    seed: u64,
    tolerance_deg: f64,
}

fn args() -> Result<Args, String> {
    let mut a = Args {
        scene: repo().join("config/scenes/search-task.ron"),
        display: repo().join("config/displays/tobii-et1750-17in.ron"),
        frames: 24,
        rounds: 3,
        seed: 15,
        tolerance_deg: 0.0,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--bench" {
            continue; // cargo bench passes it
        }
        let value = it.next().ok_or(format!("{flag}: a value is needed"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--scene" => a.scene = value.into(),
            "--display" => a.display = value.into(),
            "--frames" => a.frames = number(&value)?.clamp(1, 10_000) as usize,
            "--rounds" => a.rounds = number(&value)?.clamp(1, 100) as usize,
            "--seed" => a.seed = number(&value)?,
            "--tolerance" => {
                a.tolerance_deg = value
                    .parse::<f64>()
                    .map_err(|e| format!("{flag} {value}: {e}"))?
            }
            _ => return Err(format!("unknown argument `{flag}`")),
        }
    }
    Ok(a)
}

/// SplitMix64: a reproducible trace without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The synthetic traces (see the module docs), `n` samples each.
fn traces(
    g: &foveation::ScreenGeometry,
    n: usize,
    seed: u64,
) -> Vec<(&'static str, Vec<[f64; 2]>)> {
    let mut rng = Rng(seed);
    let centre = g.centre_px();
    // 0.5° at the centre, in pixels (the screen is seen head-on there).
    let half_deg_px = g.eye_distance_mm * 0.5f64.to_radians().tan() / g.pitch_x_mm;
    let fixation: Vec<[f64; 2]> = (0..n)
        .map(|_| loop {
            let (dx, dy) = (2.0 * rng.next() - 1.0, 2.0 * rng.next() - 1.0);
            if dx * dx + dy * dy <= 1.0 {
                break [centre[0] + dx * half_deg_px, centre[1] + dy * half_deg_px];
            }
        })
        .collect();
    let [w, h] = g.size_px();
    let mut last = centre;
    let saccades = (0..n)
        .map(|_| {
            last = loop {
                let p = [rng.next() * w, rng.next() * h];
                if (p[0] - last[0]).hypot(p[1] - last[1]) >= 10.0 * half_deg_px {
                    break p;
                }
            };
            last
        })
        .collect();
    let still = vec![[centre[0] + 0.25, centre[1] - 0.25]; n];
    vec![
        ("fixation", fixation.clone()),
        ("saccades", saccades),
        ("still", still),
        ("head", fixation),
    ]
}

/// One trace rendered with one scratch: total ms, stage sums, cache shares.
struct Run {
    ms: f64,
    stages: StageTimes,
    reused: u64,
    cast: u64,
    frames: Vec<Frame>,
}

#[allow(clippy::too_many_arguments)]
fn run(
    scene: &Scene,
    cam: &Camera,
    model: &SamplingModel,
    settings: &Settings,
    trace: &[[f64; 2]],
    mut scratch: Scratch,
    keep: bool,
    move_eye: bool,
) -> Result<Run, String> {
    let mut r = Run {
        ms: 0.0,
        stages: StageTimes::default(),
        reused: 0,
        cast: 0,
        frames: Vec::new(),
    };
    let mut frame = Frame::default();
    for (i, &gaze) in trace.iter().enumerate() {
        let mut cam = *cam;
        if move_eye {
            cam.eye.x += 0.01 * i as f32;
        }
        let t0 = Instant::now();
        render_with(
            scene,
            &cam,
            model,
            settings,
            gaze,
            false,
            &mut frame,
            &mut scratch,
        )
        .map_err(|e| e.to_string())?;
        r.ms += t0.elapsed().as_secs_f64() * 1e3;
        let s = scratch.stages();
        r.stages.mask += s.mask;
        r.stages.vertex_rays += s.vertex_rays;
        r.stages.classify += s.classify;
        r.stages.margin += s.margin;
        r.stages.ownership += s.ownership;
        r.stages.pixels += s.pixels;
        r.stages.pixel_casts_cpu += s.pixel_casts_cpu;
        let u = scratch.reuse_stats();
        r.reused += u.pixels_reused;
        r.cast += u.pixels_cast;
        if keep {
            r.frames.push(frame.clone());
        }
    }
    Ok(r)
}

fn main() -> Result<(), String> {
    let a = args()?;
    let file: SceneFile =
        ron::from_str(&read(&a.scene)?).map_err(|e| format!("{}: {e}", a.scene.display()))?;
    let dir = a.scene.parent().unwrap_or(Path::new("."));
    let scene = Scene::build(&file, dir).map_err(|e| format!("{}: {e}", a.scene.display()))?;
    let (g, model) = display_model(&a.display)?;
    let model = model
        .with_gaze_tolerance_deg(a.tolerance_deg)
        .map_err(|e| format!("--tolerance: {e}"))?;
    let cam = Camera::new(&g);
    let settings = foveated(&scene);
    let traces = traces(&g, a.frames, a.seed);
    println!(
        "scene {}, {}x{}, {} frames a trace, {} rounds, threads {}, gaze tolerance {}°; synthetic gaze traces",
        scene.name,
        g.width_px,
        g.height_px,
        a.frames,
        a.rounds,
        rayon::current_num_threads(),
        a.tolerance_deg
    );
    // Warm-up: one frame of each kind.
    run(
        &scene,
        &cam,
        &model,
        &settings,
        &traces[0].1[..1],
        Scratch::default(),
        false,
        false,
    )?;
    // Per trace: (off runs, on runs).
    let mut results: Vec<(Vec<Run>, Vec<Run>)> = traces.iter().map(|_| (vec![], vec![])).collect();
    for round in 0..a.rounds {
        for (k, (name, trace)) in traces.iter().enumerate() {
            let check = round == 0;
            let head = *name == "head";
            let off = run(
                &scene,
                &cam,
                &model,
                &settings,
                trace,
                Scratch::default(),
                check,
                head,
            )?;
            let mut on = run(
                &scene,
                &cam,
                &model,
                &settings,
                trace,
                Scratch::with_reuse(),
                check,
                head,
            )?;
            if check {
                for (i, (x, y)) in off.frames.iter().zip(&on.frames).enumerate() {
                    if x != y {
                        return Err(format!("{}: frame {i} differs with reuse", traces[k].0));
                    }
                }
            }
            let mut off = off;
            off.frames.clear();
            on.frames.clear();
            results[k].0.push(off);
            results[k].1.push(on);
        }
    }
    println!();
    println!("| trace | reuse | fps | on/off per round | pixels from cache | mask | vertex rays | classify | margin | ownership | pixels | pixel casts (cpu) |");
    println!("|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for ((name, trace), (off, on)) in traces.iter().zip(&results) {
        let n = trace.len() as f64;
        let ratios: Vec<String> = off
            .iter()
            .zip(on)
            .map(|(x, y)| format!("{:.2}", x.ms / y.ms))
            .collect();
        for (label, runs) in [("off", off), ("on", on)] {
            let fps = median(runs.iter().map(|r| 1e3 * n / r.ms).collect());
            let mean = |f: &dyn Fn(&StageTimes) -> f64| {
                runs.iter().map(|r| f(&r.stages)).sum::<f64>() / (n * runs.len() as f64)
            };
            let (reused, cast): (u64, u64) = runs
                .iter()
                .fold((0, 0), |(a, b), r| (a + r.reused, b + r.cast));
            let share = if label == "on" && reused + cast > 0 {
                format!("{:.1} %", 100.0 * reused as f64 / (reused + cast) as f64)
            } else {
                "–".into()
            };
            println!(
                "| {name} | {label} | {fps:.1} | {} | {share} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
                if label == "on" { ratios.join(", ") } else { String::new() },
                mean(&|s| s.mask),
                mean(&|s| s.vertex_rays),
                mean(&|s| s.classify),
                mean(&|s| s.margin),
                mean(&|s| s.ownership),
                mean(&|s| s.pixels),
                mean(&|s| s.pixel_casts_cpu),
            );
        }
    }
    println!("\nstage columns: mean wall ms a frame (pixel casts: CPU ms summed over threads); every frame with reuse equalled the frame without it, byte for byte (checked in round 1)");
    Ok(())
}
