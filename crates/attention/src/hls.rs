//! HLS colour and circular hue (Lee §3.1.1: `B_l`, `B_h` from HLS).
//!
//! Hue is an angle, so it is never averaged or differenced as a number.
//! The maps carry the *chroma-weighted hue vector* `C·(cos h, sin h)`
//! (`C = max − min` of RGB): averaging those vectors gives the hue of the
//! mean vector, weighted by chroma, and its length says how much of a hue
//! there is. Two hues differ by the angle between their vectors, in
//! [0°, 180°].

use std::f32::consts::PI;

/// Hue, lightness and saturation of one colour (the HLS double hexcone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hls {
    /// Hue in degrees, [0, 360); 0 for greys.
    pub hue_deg: f32,
    /// Lightness `(max + min) / 2`, [0, 1] — this is `B_l`.
    pub lightness: f32,
    /// HLS saturation, [0, 1].
    pub saturation: f32,
    /// Chroma `max − min`, [0, 1]: the weight of the hue.
    pub chroma: f32,
}

/// HLS of an RGB colour with components in [0, 1] (values outside are
/// clamped; NaN counts as 0).
pub fn rgb_to_hls(r: f32, g: f32, b: f32) -> Hls {
    let clamp = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let (r, g, b) = (clamp(r), clamp(g), clamp(b));
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let chroma = max - min;
    let lightness = 0.5 * (max + min);
    let hue_deg = hexcone_hue_sextant(r, g, b, max, chroma) * 60.0;
    let denom = 1.0 - (2.0 * lightness - 1.0).abs();
    let saturation = if denom > 1e-6 {
        (chroma / denom).min(1.0)
    } else {
        0.0
    };
    Hls {
        hue_deg,
        lightness,
        saturation,
        chroma,
    }
}

/// Hexcone hue in sextants, [0, 6); 0 when chroma is 0.
fn hexcone_hue_sextant(r: f32, g: f32, b: f32, max: f32, chroma: f32) -> f32 {
    if chroma <= 0.0 {
        return 0.0;
    }
    let h = if max == r {
        (g - b) / chroma
    } else if max == g {
        (b - r) / chroma + 2.0
    } else {
        (r - g) / chroma + 4.0
    };
    let h = if h < 0.0 { h + 6.0 } else { h };
    if h >= 6.0 {
        0.0
    } else {
        h
    }
}

/// Lightness and chroma-weighted hue vector of an RGB colour in [0, 1]:
/// `(L, C·cos h, C·sin h)`. What the pipeline stores per map pixel.
pub fn lightness_and_hue_vector(r: f32, g: f32, b: f32) -> (f32, [f32; 2]) {
    let hls = rgb_to_hls(r, g, b);
    let (s, c) = (hls.hue_deg.to_radians()).sin_cos();
    (hls.lightness, [hls.chroma * c, hls.chroma * s])
}

/// Hue difference in degrees across the wrap, [0, 180]: 350° and 10°
/// differ by 20°. Non-finite inputs give 0.
pub fn hue_difference_deg(a_deg: f32, b_deg: f32) -> f32 {
    let d = (a_deg - b_deg).rem_euclid(360.0);
    if !d.is_finite() {
        return 0.0;
    }
    if d > 180.0 {
        360.0 - d
    } else {
        d
    }
}

/// Weighted circular mean of hues: the angle of the weighted mean unit
/// vector, in [0, 360). `None` when the weights are all 0 or the vectors
/// cancel (e.g. 0° and 180° equally weighted). Entries with a non-finite
/// or negative weight or hue are skipped.
pub fn mean_hue_deg(samples: &[(f32, f32)]) -> Option<f32> {
    let (mut x, mut y, mut w_sum) = (0.0f64, 0.0f64, 0.0f64);
    for &(hue, weight) in samples {
        if !(hue.is_finite() && weight.is_finite() && weight >= 0.0) {
            continue;
        }
        let (s, c) = f64::from(hue).to_radians().sin_cos();
        x += f64::from(weight) * c;
        y += f64::from(weight) * s;
        w_sum += f64::from(weight);
    }
    if w_sum <= 0.0 || (x * x + y * y).sqrt() <= 1e-9 * w_sum {
        return None;
    }
    let deg = y.atan2(x).to_degrees().rem_euclid(360.0) as f32;
    Some(if deg >= 360.0 { 0.0 } else { deg })
}

/// Hue contrast between two chroma-weighted hue vectors, [0, 1]: the angle
/// between them over 180°, times the shorter length (so a grey side, whose
/// hue is undefined, carries no hue contrast). This is the `|B_h^c − B_h^s|`
/// of Lee eq. 3.4 made circular.
pub fn hue_vector_contrast(a: [f32; 2], b: [f32; 2]) -> f32 {
    if !(a.iter().chain(&b).all(|v| v.is_finite())) {
        return 0.0;
    }
    let len_a = (a[0] * a[0] + a[1] * a[1]).sqrt();
    let len_b = (b[0] * b[0] + b[1] * b[1]).sqrt();
    hue_vector_contrast_with_lengths(a, len_a, b, len_b)
}

#[inline(always)]
pub(crate) fn hue_vector_contrast_with_lengths(
    a: [f32; 2],
    len_a: f32,
    b: [f32; 2],
    len_b: f32,
) -> f32 {
    // Branch-free (selects only) so that the contrast loop vectorises;
    // inputs are finite map values.
    let weight = len_a.min(len_b);
    let cross = (a[0] * b[1] - a[1] * b[0]).abs();
    let dot = a[0] * b[0] + a[1] * b[1];
    let angle = crate::fast_math::angle_from_cross_dot(cross, dot);
    let value = weight * angle * (1.0 / PI);
    if weight > 1e-12 && value < 1.0 {
        value.max(0.0)
    } else if weight > 1e-12 {
        1.0
    } else {
        0.0
    }
}

/// The hue in degrees [0, 360) of a chroma-weighted hue vector; 0 for a
/// zero vector. For debug pictures.
pub fn hue_vector_angle_deg(v: [f32; 2]) -> f32 {
    if !(v[0].is_finite() && v[1].is_finite()) || (v[0] == 0.0 && v[1] == 0.0) {
        return 0.0;
    }
    let deg = v[1].atan2(v[0]).to_degrees().rem_euclid(360.0);
    if deg >= 360.0 {
        0.0
    } else {
        deg
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primaries_have_hexcone_hues() {
        assert_eq!(rgb_to_hls(1.0, 0.0, 0.0).hue_deg, 0.0);
        assert!((rgb_to_hls(0.0, 1.0, 0.0).hue_deg - 120.0).abs() < 1e-4);
        assert!((rgb_to_hls(0.0, 0.0, 1.0).hue_deg - 240.0).abs() < 1e-4);
        assert!((rgb_to_hls(1.0, 0.0, 1.0).hue_deg - 300.0).abs() < 1e-4);
        let grey = rgb_to_hls(0.5, 0.5, 0.5);
        assert_eq!(
            (grey.hue_deg, grey.chroma, grey.saturation),
            (0.0, 0.0, 0.0)
        );
        assert!((grey.lightness - 0.5).abs() < 1e-6);
    }

    #[test]
    fn nan_and_out_of_range_colours_are_clamped() {
        let hls = rgb_to_hls(f32::NAN, 2.0, -1.0);
        assert!(hls.hue_deg.is_finite() && hls.lightness == 0.5 && hls.chroma == 1.0);
    }
}
