//! Mask build time against the point of regard's distance from the screen,
//! at 3840×2160 (27" at 60 cm): on the screen (its centre), then one screen
//! diagonal, 1e3, 1e6, 1e9 and 1e15 px beyond the bottom-right corner. A mask
//! costs what is on the screen, so the time must be flat beyond it (before
//! the ring start moved to the nearest screen point it grew with the
//! distance: ~0.16 s at 1e6 px, minutes at 1e9).

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
    let [w, h] = model.geometry.size_px();
    let diagonal = w.hypot(h);
    // Off the bottom-right corner along (0.8, 0.6): `d` px from the screen.
    let off = |d: f64| [w + 0.8 * d, h + 0.6 * d];
    let cases = [
        ("on_screen", [w / 2.0, h / 2.0]),
        ("off_1_diagonal", off(diagonal)),
        ("off_1e3", off(1e3)),
        ("off_1e6", off(1e6)),
        ("off_1e9", off(1e9)),
        ("off_1e15", off(1e15)),
    ];
    let mut group = c.benchmark_group("mask_far_3840x2160");
    for layout in [Layout::Nyquist, Layout::Seed] {
        for (name, por) in cases {
            group.bench_function(format!("{}_{name}", layout.name()), |b| {
                b.iter(|| mask::build(&model, layout, por).expect("mask"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
