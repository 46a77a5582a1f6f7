//! Mask generation time at 3840×2160 (27" at 60 cm), POR at the centre and
//! in a corner, built from scratch and rebuilt in place (the renderer's
//! path when the gaze moves). Goal (issue 2): ≤ 5 ms on one core.

use criterion::{criterion_group, criterion_main, Criterion};
use foveation::{mask, Display, GeislerPerry, Layout, SamplingModel};

fn uhd() -> SamplingModel {
    let display = Display {
        name: "27in 4K".into(),
        resolution_px: (3840, 2160),
        size_mm: (596.7, 335.7),
        eye_distance_mm: 600.0,
        eye_point_px: None,
    };
    let geometry = display.geometry().expect("valid display");
    SamplingModel::new(
        geometry,
        GeislerPerry::default(),
        1.0,
        foveation::sampling::SEED_MAX_SPACING_PX,
    )
    .expect("valid model")
}

fn bench(c: &mut Criterion) {
    let model = uhd();
    let mut group = c.benchmark_group("mask_3840x2160");
    for (name, por) in [("centre", [1920.0, 1080.0]), ("corner", [0.5, 0.5])] {
        for layout in [Layout::Nyquist, Layout::Seed] {
            group.bench_function(format!("{}_{name}_new", layout.name()), |b| {
                b.iter(|| mask::build(&model, layout, por).expect("mask"))
            });
            // What a renderer does when the gaze moves: rebuild in place,
            // alternating between two nearby PORs so nothing is cached.
            let mut m = mask::build(&model, layout, por).expect("mask");
            let mut flip = false;
            group.bench_function(format!("{}_{name}_rebuild", layout.name()), |b| {
                b.iter(|| {
                    flip = !flip;
                    let p = [por[0] + if flip { 0.25 } else { 0.0 }, por[1]];
                    mask::rebuild(&mut m, &model, layout, p).expect("mask");
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
