//! Lee's attention model with its per-pixel part on the GPU
//! (`pipeline::gpu_attention`) at 64² and 256² saliency maps, on the same
//! synthetic 1280×1024 frame with 30 objects as the CPU benchmark
//! (`cargo bench -p attention --bench attention`).
//!
//! Timed per frame: `update_uploaded` — the WGSL passes on a frame already
//! on the GPU (as the renderer's frame is), one wait, the read-back of the
//! per-object statistics and the CPU's finishing steps; and `update`, which
//! also uploads the frame (12 bytes a pixel), as a caller with a CPU frame
//! pays.
//!
//! **On a machine without a GPU this runs on Mesa's lavapipe, a CPU
//! implementation of Vulkan: its times say nothing about a GPU.** The
//! benchmark is for a lab's real GPU, where Lee reports 0.97 ms (64²) and
//! 5.68 ms (256²) on a 2006 GeForce 7900GTX. The adapter is printed first.
//!
//! `cargo bench -p pipeline --bench attention_gpu -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use attention::synthetic::SyntheticScene;
use attention::{AttentionConfig, CameraMotion};
use criterion::{criterion_group, criterion_main, Criterion};
use pipeline::gpu_attention::GpuAttention;

fn attention_on_the_gpu(c: &mut Criterion) {
    let scene = SyntheticScene::new(1280, 1024, 30, 2009).expect("valid size");
    let objects = scene.objects();
    let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -1000.0]);
    let mut group = c.benchmark_group("attention_gpu_1280x1024_30_objects");
    group.sample_size(10);
    for map_size in [64u32, 256] {
        let mut model = match GpuAttention::new(AttentionConfig::with_map_size(map_size)) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("attention_gpu: no GPU model ({e}); nothing to time");
                return;
            }
        };
        eprintln!("attention_gpu: adapter {}", model.adapter());
        model.upload(&scene.view()).expect("upload");
        group.bench_function(format!("map_{map_size}_frame_on_gpu"), |b| {
            b.iter(|| {
                black_box(
                    model
                        .update_uploaded(&objects, camera, 1.0 / 60.0)
                        .expect("frame"),
                )
            })
        });
        group.bench_function(format!("map_{map_size}_with_upload"), |b| {
            b.iter(|| {
                black_box(
                    model
                        .update(&scene.view(), &objects, camera, 1.0 / 60.0)
                        .expect("frame"),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, attention_on_the_gpu);
criterion_main!(benches);
