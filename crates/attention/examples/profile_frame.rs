//! Times `update` on the benchmark's frame (min of N runs per config).
//! `cargo run --release --example profile_frame -- [threads] [runs] [config name filter]`
use std::time::Instant;

use attention::synthetic::SyntheticScene;
use attention::{AttentionConfig, AttentionTracker, CameraMotion, Features};

fn main() {
    let mut args = std::env::args().skip(1);
    let threads: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(2);
    let runs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(50);
    let only: Option<String> = args.next();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let scene = SyntheticScene::new(1280, 1024, 30, 2009).expect("valid size");
    let objects = scene.objects();
    let camera = CameraMotion::STATIC;
    let configs = [
        ("256 all", 256, Features::ALL),
        ("64 all", 64, Features::ALL),
        ("64 B", 64, Features::lee_groups(true, false, false)),
        ("64 E", 64, Features::lee_groups(false, true, false)),
        ("64 T", 64, Features::lee_groups(false, false, true)),
    ];
    for (name, size, features) in configs {
        if only.as_ref().is_some_and(|o| !name.contains(o.as_str())) {
            continue;
        }
        let config = AttentionConfig {
            features,
            ..AttentionConfig::with_map_size(size)
        };
        let mut tracker = AttentionTracker::new(config).expect("config");
        let mut best = f64::INFINITY;
        let mut total = 0.0;
        for _ in 0..runs {
            let t0 = Instant::now();
            let r = pool.install(|| tracker.update(&scene.view(), &objects, camera, 1.0 / 60.0));
            let dt = t0.elapsed().as_secs_f64() * 1e3;
            assert!(r.is_ok());
            best = best.min(dt);
            total += dt;
        }
        println!(
            "{name:8} min {best:6.2} ms  mean {:6.2} ms",
            total / runs as f64
        );
    }
}
