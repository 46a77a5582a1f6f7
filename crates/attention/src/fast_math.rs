//! A polynomial `atan2` for the hue contrast, six per map pixel, where the
//! libm call would dominate the centre–surround pass.

use std::f32::consts::{FRAC_PI_2, PI};

/// `atan2(y, x)` in (−π, π], absolute error below 2e-5 rad (checked
/// against `f32::atan2` in the tests). `(0, 0)` and non-finite input give 0.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    if !(x.is_finite() && y.is_finite()) {
        return 0.0;
    }
    let ax = x.abs();
    let ay = y.abs();
    let max = ax.max(ay);
    if max <= 0.0 {
        return 0.0;
    }
    let a = ax.min(ay) / max;
    let s = a * a;
    // Minimax polynomial for atan on [0, 1] (odd, degree 11).
    let mut r = a
        * (0.999_977_26
            + s * (-0.332_623_47
                + s * (0.193_543_46
                    + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_2)))));
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// The angle in [0, π] between two vectors, from `|a × b|` (≥ 0) and
/// `a · b`, both finite: `atan2(cross_abs, dot)` without branches, so the
/// hue contrast loop can vectorise. Same polynomial and error as [`atan2`].
#[inline(always)]
pub fn angle_from_cross_dot(cross_abs: f32, dot: f32) -> f32 {
    let ax = dot.abs();
    let ay = cross_abs;
    let max = ax.max(ay);
    let min = ax.min(ay);
    let a = if max > 0.0 { min / max } else { 0.0 };
    let s = a * a;
    let r = a
        * (0.999_977_26
            + s * (-0.332_623_47
                + s * (0.193_543_46
                    + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_2)))));
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    if dot < 0.0 {
        PI - r
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn matches_std_atan2_within_2e_5() {
        let mut worst = 0.0f32;
        for i in 0..20_000 {
            let t = i as f32 / 20_000.0 * std::f32::consts::TAU;
            for r in [1e-3f32, 0.5, 1.0, 7.0] {
                let (y, x) = (r * t.sin(), r * t.cos());
                let d = (super::atan2(y, x) - y.atan2(x)).abs();
                // ±π are the same angle.
                let d = d.min((d - std::f32::consts::TAU).abs());
                worst = worst.max(d);
            }
        }
        assert!(worst < 2e-5, "worst error {worst}");
        let mut worst_angle = 0.0f32;
        for i in 0..20_000 {
            let t = i as f32 / 20_000.0 * std::f32::consts::PI;
            let (y, x) = (t.sin().abs(), t.cos());
            worst_angle = worst_angle.max((super::angle_from_cross_dot(y, x) - y.atan2(x)).abs());
        }
        assert!(worst_angle < 2e-5, "worst angle error {worst_angle}");
        assert_eq!(super::angle_from_cross_dot(0.0, 0.0), 0.0);
        assert_eq!(super::atan2(0.0, 0.0), 0.0);
        assert_eq!(super::atan2(f32::NAN, 1.0), 0.0);
    }
}
