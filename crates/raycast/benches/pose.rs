//! What a moving scene costs (issue 18, *Scenes that move*): the time to
//! pose a scene for a frame ([`Scene::posed`]: every vertex placed, the BVH
//! rebuilt) next to the foveated CPU frame it is posed for, side by side
//! in one run.
//!
//! ```text
//! cargo bench -p raycast --bench pose -- \
//!     [--scene FILE[,FILE…]] [--display FILE] [--frames N] [--rounds R]
//! ```
//!
//! Defaults: `config/scenes/moving.ron`, `search-task.ron` and `bunny.ron`
//! on the seed's display (1280×1024), 30 frames of 1/60 s each, 3 rounds.
//! A scene file without any path is given a **camera path added by this
//! bench** (200 mm forward in 4 s, turning 8°, `Bounce`), so that every
//! vertex moves; the output says so. Each frame: pose at its time, then
//! render it foveated with the gaze at the screen centre. Printed per
//! scene: triangles, the median pose time, the median frame time, and the
//! pose's share of pose + frame.

use std::path::{Path, PathBuf};
use std::time::Instant;

use raycast::motion::{Key, Motion, Repeat};
use raycast::render::{render_with, Scratch};
use raycast::{Camera, Frame, Scene, SceneFile};

mod common;
use common::{display_model, foveated, median, read, repo};

struct Args {
    scenes: Vec<PathBuf>,
    display: PathBuf,
    frames: usize,
    rounds: usize,
}

fn args() -> Result<Args, String> {
    let scenes = repo().join("config/scenes");
    let mut a = Args {
        scenes: ["moving.ron", "search-task.ron", "bunny.ron"]
            .iter()
            .map(|n| scenes.join(n))
            .collect(),
        display: repo().join("config/displays/tobii-et1750-17in.ron"),
        frames: 30,
        rounds: 3,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--bench" {
            continue; // cargo bench passes it
        }
        let value = it.next().ok_or(format!("{flag}: a value is needed"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--scene" => a.scenes = value.split(',').map(PathBuf::from).collect(),
            "--display" => a.display = value.into(),
            "--frames" => a.frames = number(&value)?.clamp(1, 10_000) as usize,
            "--rounds" => a.rounds = number(&value)?.clamp(1, 100) as usize,
            _ => return Err(format!("unknown argument `{flag}`")),
        }
    }
    Ok(a)
}

/// The scene of `path`, moving: a file without paths gets the bench's
/// camera path (the second value says so).
fn moving_scene(path: &Path) -> Result<(Scene, bool), String> {
    let mut file: SceneFile =
        ron::from_str(&read(path)?).map_err(|e| format!("{}: {e}", path.display()))?;
    let added = file.camera.is_none() && file.objects.iter().all(|o| o.motion.is_none());
    if added {
        file.camera = Some(Motion {
            keys: vec![
                Key {
                    t_s: 0.0,
                    translate_mm: (0.0, 0.0, 0.0),
                    rotate_deg: (0.0, 0.0, 0.0),
                },
                Key {
                    t_s: 4.0,
                    translate_mm: (0.0, 0.0, -200.0),
                    rotate_deg: (0.0, -8.0, 0.0),
                },
            ],
            repeat: Repeat::Bounce,
        });
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let scene = Scene::build(&file, dir).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((scene, added))
}

fn main() -> Result<(), String> {
    let a = args()?;
    let (g, model) = display_model(&a.display)?;
    let cam = Camera::new(&g);
    let gaze = g.centre_px();
    println!(
        "{}x{}, {} frames of 1/60 s, {} rounds, threads {}; gaze at the centre",
        g.width_px,
        g.height_px,
        a.frames,
        a.rounds,
        rayon::current_num_threads()
    );
    println!();
    println!(
        "| scene | triangles | what moves | pose ms | foveated frame ms | pose / (pose + frame) |"
    );
    println!("|---|---:|---|---:|---:|---:|");
    for path in &a.scenes {
        let (scene, added) = moving_scene(path)?;
        let settings = foveated(&scene);
        let mut scratch = Scratch::default();
        let mut frame = Frame::default();
        let (mut pose_ms, mut frame_ms) = (Vec::new(), Vec::new());
        for round in 0..=a.rounds {
            for i in 0..a.frames {
                let t = i as f64 / 60.0;
                let t0 = Instant::now();
                let posed = scene
                    .posed(t)
                    .ok_or(format!("{}: the scene does not move", path.display()))?;
                let t1 = Instant::now();
                render_with(
                    &posed,
                    &cam,
                    &model,
                    &settings,
                    gaze,
                    false,
                    &mut frame,
                    &mut scratch,
                )
                .map_err(|e| e.to_string())?;
                let t2 = Instant::now();
                // Round 0 warms the caches and the scratch up.
                if round > 0 {
                    pose_ms.push((t1 - t0).as_secs_f64() * 1e3);
                    frame_ms.push((t2 - t1).as_secs_f64() * 1e3);
                }
            }
        }
        let (p, f) = (median(pose_ms), median(frame_ms));
        println!(
            "| {} | {} | {} | {p:.1} | {f:.1} | {:.0} % |",
            scene.name,
            scene.triangles.len(),
            if added {
                "camera (path added by this bench)"
            } else {
                "the file's paths"
            },
            100.0 * p / (p + f)
        );
    }
    Ok(())
}
