//! Test helpers shared by the calibration modules' tests.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::{Model, Order, Plan, Procedure, TimedPoint};

/// A tracker whose raw output is a known distortion of the screen.
pub fn distort(model: Model, p: [f64; 2]) -> [f64; 2] {
    let [x, y] = [p[0] / 1280.0, p[1] / 1024.0];
    let q = match model {
        Model::Affine => [0.8 * x + 0.1 * y + 0.05, -0.05 * x + 0.7 * y + 0.1],
        Model::Homography => {
            let w = 1.0 + 0.15 * x - 0.1 * y;
            [
                (0.8 * x + 0.1 * y + 0.05) / w,
                (0.1 * x + 0.75 * y + 0.1) / w,
            ]
        }
        Model::Polynomial2 => [
            0.1 + 0.8 * x + 0.05 * y + 0.08 * x * x - 0.04 * x * y,
            0.05 + 0.02 * x + 0.85 * y + 0.06 * y * y + 0.03 * x * y,
        ],
    };
    [512.0 * q[0], 512.0 * q[1]]
}

/// A procedure run to the end on `targets` by a person the `model`
/// distortion of [`distort`] describes, with Gaussian noise of `noise` raw
/// units, at 250 Hz.
pub fn procedure_on(model: Model, targets: &[[f64; 2]], noise: f64, seed: u64) -> Procedure {
    let mut plan = Plan::grid(9, (1280, 1024), 0.1, Order::RowMajor).expect("9 points");
    plan.targets_px = targets.to_vec();
    let mut p = Procedure::new(plan);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let gauss = Normal::new(0.0, noise.max(1e-12)).expect("sigma");
    let mut t = 0u64;
    while let Some((_, target)) = p.target() {
        let r = distort(model, target);
        p.feed(TimedPoint {
            t_us: t,
            raw: Some([r[0] + gauss.sample(&mut rng), r[1] + gauss.sample(&mut rng)]),
        });
        t += 4_000; // 250 Hz
    }
    p
}

pub fn grid(k: usize) -> Vec<[f64; 2]> {
    Plan::grid(k, (1280, 1024), 0.08, Order::RowMajor)
        .expect("grid")
        .targets_px
}
