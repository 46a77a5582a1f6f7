//! Hue is circular: differences and averages across the 0/360° wrap.

mod common;

use attention::hls::{
    hue_difference_deg, hue_vector_angle_deg, hue_vector_contrast, mean_hue_deg, rgb_to_hls,
};
use attention::pyramid::{Pyramid, PYRAMID_LEVELS};
use attention::{AttentionConfig, AttentionTracker, CameraMotion, Feature, Features, ObjectInfo};
use common::Canvas;

fn unit(deg: f32) -> [f32; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    [c, s]
}

#[test]
fn hues_350_and_10_differ_by_20_degrees_not_340() {
    assert!((hue_difference_deg(350.0, 10.0) - 20.0).abs() < 1e-4);
    assert!((hue_difference_deg(10.0, 350.0) - 20.0).abs() < 1e-4);
    assert!((hue_difference_deg(0.0, 180.0) - 180.0).abs() < 1e-4);
    assert!((hue_difference_deg(725.0, -5.0) - 10.0).abs() < 1e-3);
    assert_eq!(hue_difference_deg(f32::NAN, 3.0), 0.0);
    let c = hue_vector_contrast(unit(350.0), unit(10.0));
    assert!((c - 20.0 / 180.0).abs() < 1e-4, "vector contrast {c}");
}

#[test]
fn averaging_350_and_10_gives_0() {
    let mean = mean_hue_deg(&[(350.0, 1.0), (10.0, 1.0)]).expect("defined");
    assert!(hue_difference_deg(mean, 0.0) < 1e-3, "mean {mean}");
    // Weighted by chroma: the stronger hue pulls the mean.
    let mean = mean_hue_deg(&[(350.0, 3.0), (10.0, 1.0)]).expect("defined");
    assert!(mean > 350.0 && mean < 356.0, "weighted mean {mean}");
    assert_eq!(mean_hue_deg(&[(0.0, 1.0), (180.0, 1.0)]), None);
    assert_eq!(mean_hue_deg(&[(90.0, 0.0)]), None);
}

#[test]
fn the_hue_pyramid_averages_350_and_10_to_0() {
    // Two texels, 350° and 10°, full chroma: level 1 is their mean.
    let (a, b) = (unit(350.0), unit(10.0));
    let px = Pyramid::from_base(&[a[0], b[0]], 2, 1).expect("valid");
    let py = Pyramid::from_base(&[a[1], b[1]], 2, 1).expect("valid");
    let v = [px.level(1).data[0], py.level(1).data[0]];
    assert!(
        hue_difference_deg(hue_vector_angle_deg(v), 0.0) < 1e-3,
        "{v:?}"
    );
    // The mean vector is shorter by cos 10°: the two hues disagree a little.
    assert!(((v[0] * v[0] + v[1] * v[1]).sqrt() - 10f32.to_radians().cos()).abs() < 1e-5);

    // Alternating columns: every level-1 texel away from the clamped edges
    // sees both hues equally ([1, 3, 3, 1] over 10°, 350°, 10°, 350°).
    let (w, h) = (64usize, 64usize);
    let (mut vx, mut vy) = (vec![0.0f32; w * h], vec![0.0f32; w * h]);
    for i in 0..w * h {
        let v = unit(if (i % w) % 2 == 0 { 350.0 } else { 10.0 });
        vx[i] = v[0];
        vy[i] = v[1];
    }
    let px = Pyramid::from_base(&vx, w, h).expect("valid");
    let py = Pyramid::from_base(&vy, w, h).expect("valid");
    let (lx, ly) = (px.level(1), py.level(1));
    for y in 0..lx.height {
        for x in 1..lx.width - 1 {
            let i = y * lx.width + x;
            let hue = hue_vector_angle_deg([lx.data[i], ly.data[i]]);
            assert!(
                hue_difference_deg(hue, 0.0) < 0.01,
                "texel ({x}, {y}) hue {hue}"
            );
        }
    }
    // Deeper levels stay near 0° (the edge texels lean to 350°, never towards 180°).
    for l in 2..PYRAMID_LEVELS {
        for (&x, &y) in px.level(l).data.iter().zip(py.level(l).data) {
            assert!(hue_difference_deg(hue_vector_angle_deg([x, y]), 0.0) < 3.0);
        }
    }
}

/// Pixels of hue about 350° and 10° (full saturation, L = 0.5).
const RED_MAGENTA: [u8; 3] = [255, 0, 43];
const RED_ORANGE: [u8; 3] = [255, 43, 0];
/// The same two rotated by 120° (a cyclic channel permutation): ~110°, ~130°.
const GREEN_YELLOW: [u8; 3] = [43, 255, 0];
const GREEN_CYAN: [u8; 3] = [0, 255, 43];

fn hue_contrast_of_halves(left: [u8; 3], right: [u8; 3]) -> Vec<f32> {
    let mut canvas = Canvas::new(128, 128, left);
    canvas.rect([64, 0, 128, 128], 1, right, 3000.0);
    let features = Features {
        hue: true,
        ..Features::NONE
    };
    let config = AttentionConfig {
        features,
        ..AttentionConfig::with_map_size(64)
    };
    let mut tracker = AttentionTracker::new(config).expect("valid config");
    tracker
        .update(
            &canvas.view(),
            &[ObjectInfo::still(1, 1.0)],
            CameraMotion::STATIC,
            1.0 / 60.0,
        )
        .expect("valid frame");
    tracker.maps().contrast(Feature::Hue).to_vec()
}

#[test]
fn hue_contrast_across_the_wrap_equals_the_same_step_elsewhere() {
    assert!((rgb_to_hls(1.0, 0.0, 43.0 / 255.0).hue_deg - 350.0).abs() < 0.2);
    assert!((rgb_to_hls(1.0, 43.0 / 255.0, 0.0).hue_deg - 10.0).abs() < 0.2);
    let across = hue_contrast_of_halves(RED_MAGENTA, RED_ORANGE);
    let elsewhere = hue_contrast_of_halves(GREEN_YELLOW, GREEN_CYAN);
    let max = across.iter().copied().fold(0.0f32, f32::max);
    // A 20° step: each term is at most 20/180; a wrap bug would see 340°.
    assert!(max > 0.01 && max < 20.2 / 180.0, "max hue contrast {max}");
    let diff = across
        .iter()
        .zip(&elsewhere)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(diff < 1e-4, "wrap changes the contrast by {diff}");
}
