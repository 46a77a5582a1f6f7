//! Attention per frame from a 1280×1024 synthetic frame with 30 objects,
//! at 256² and 64² saliency maps, on a 2-thread rayon pool; plus Lee's
//! Table 3.2 ablations at 64².
//!
//! Lee 2009 §3.4, §7.2 (GeForce 7900GTX, 2006; model rendering excluded):
//! 5.68 ms at 256², 0.97 ms at 64².
//!
//! `cargo bench --bench attention -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use attention::synthetic::SyntheticScene;
use attention::{AttentionConfig, AttentionTracker, CameraMotion, Features};
use criterion::{criterion_group, criterion_main, Criterion};

fn attention_per_frame(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("thread pool");
    let scene = SyntheticScene::new(1280, 1024, 30, 2009).expect("valid size");
    let objects = scene.objects();
    let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -1000.0]);
    let mut group = c.benchmark_group("attention_1280x1024_30_objects_2_threads");
    for map_size in [256u32, 64] {
        let mut tracker =
            AttentionTracker::new(AttentionConfig::with_map_size(map_size)).expect("config");
        group.bench_function(format!("map_{map_size}"), |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        tracker
                            .update(&scene.view(), &objects, camera, 1.0 / 60.0)
                            .expect("frame"),
                    )
                })
            })
        });
    }
    for (name, features) in [
        ("map_64_B", Features::lee_groups(true, false, false)),
        ("map_64_E", Features::lee_groups(false, true, false)),
        ("map_64_T", Features::lee_groups(false, false, true)),
    ] {
        let config = AttentionConfig {
            features,
            ..AttentionConfig::with_map_size(64)
        };
        let mut tracker = AttentionTracker::new(config).expect("config");
        group.bench_function(name, |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        tracker
                            .update(&scene.view(), &objects, camera, 1.0 / 60.0)
                            .expect("frame"),
                    )
                })
            })
        });
    }
    group.finish();
}

criterion_group!(benches, attention_per_frame);
criterion_main!(benches);
