//! Primary-ray throughput and foveated-versus-full frame time.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use foveation::{Display, GeislerPerry, SamplingModel};
use raycast::render::{render, Mode, Settings, Triggers};
use raycast::{Camera, Scene, SceneFile};

fn main_benches(c: &mut Criterion) {
    let _ = (
        c,
        Path::new("."),
        Display::geometry,
        GeislerPerry::default,
        SamplingModel::new,
        render,
        Mode::Full,
    );
    let _ = (
        Settings::clone,
        Triggers::NONE,
        Camera::new,
        Scene::build,
        std::mem::size_of::<SceneFile>(),
    );
}

criterion_group!(benches, main_benches);
criterion_main!(benches);
