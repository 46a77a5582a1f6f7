//! The renderer's 8-bit encoding, both ways, for passes that filter a
//! rendered frame (depth of field, image-based foveation): they decode to
//! linear light, filter, and encode again with the same gamma 2.2 the
//! renderer writes (`raycast::shade::to_rgb8`), so a filter of a constant
//! region gives the region back, byte for byte.

/// Linear light of every byte: `(b / 255)^2.2`.
pub fn decode_lut() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0f32; 256];
        for (i, v) in t.iter_mut().enumerate() {
            *v = (f64::from(i as u8) / 255.0).powf(2.2) as f32;
        }
        t
    })
}

/// Linear light to a byte, `round(255 · v^(1/2.2))`, clamped; NaN to 0.
/// The exact inverse of [`decode_lut`] on every byte (the renderer's
/// 4096-step table would lose the darkest ones). A binary search over the
/// 255 thresholds between bytes, no `powf`.
pub fn encode(v: f32) -> u8 {
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    let t = thresholds();
    // The number of thresholds at or below v is the byte.
    t.partition_point(|&x| x <= v) as u8
}

/// `((b + 0.5) / 255)^2.2` for b = 0..255: where rounding moves from byte
/// b to b + 1.
fn thresholds() -> &'static [f32; 255] {
    static TABLE: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0f32; 255];
        for (b, v) in t.iter_mut().enumerate() {
            *v = ((b as f64 + 0.5) / 255.0).powf(2.2) as f32;
        }
        t
    })
}

/// [`encode`] on three channels.
pub fn encode3(c: [f32; 3]) -> [u8; 3] {
    c.map(encode)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_round_trips() {
        for (i, v) in decode_lut().iter().enumerate() {
            assert_eq!(encode(*v), i as u8);
        }
    }

    #[test]
    fn the_search_is_the_formula() {
        for i in 0..=100_000u32 {
            let v = i as f32 / 100_000.0;
            let exact = ((f64::from(v)).powf(1.0 / 2.2) * 255.0).round() as u8;
            let got = encode(v);
            // Equal but where v sits on a threshold to f32 rounding.
            assert!(got.abs_diff(exact) <= 1, "{v}: {got} vs {exact}");
        }
    }

    #[test]
    fn the_encoding_is_the_renderers_gamma() {
        // raycast's table: round(255 · x^(1/2.2)) at 4096 steps of x.
        for i in [512usize, 1024, 2048, 4096] {
            let x = i as f32 / 4096.0;
            let table = raycast::shade::to_rgb8(glam::Vec3::splat(x))[0];
            assert!((i32::from(encode(x)) - i32::from(table)).abs() <= 1, "{x}");
        }
        assert_eq!(encode(f32::NAN), 0);
        assert_eq!(encode(-1.0), 0);
        assert_eq!(encode(7.0), 255);
    }
}
