// The renderer's 8-bit encoding both ways (`crate::colour`), shared by the
// post passes: `lut` is `colour::decode_lut()`, `thresholds` the 255 f32
// values where `colour::encode` moves from byte b to b + 1 (derived from
// `encode` itself on the CPU), so both directions are the CPU's, bit for bit.

@group(0) @binding(1) var<storage, read> lut: array<f32, 256>;
@group(0) @binding(2) var<storage, read> thresholds: array<f32, 255>;
// The frame's packed words (`pack` in cast.wgsl): RGB in bits 0-23.
@group(0) @binding(3) var<storage, read_write> pixels: array<u32>;

fn decode(word: u32) -> vec3<f32> {
    return vec3<f32>(lut[word & 255u], lut[(word >> 8u) & 255u], lut[(word >> 16u) & 255u]);
}

// `colour::encode`: the number of thresholds at or below v (0 for NaN or v <= 0).
fn encode1(v: f32) -> u32 {
    var lo = 0u;
    var hi = 255u;
    loop {
        if (lo >= hi) {
            break;
        }
        let mid = (lo + hi) / 2u;
        if (thresholds[mid] <= v) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// `c` encoded into `word`'s colour bits; the hit flag and layer (bits 24-31) kept.
fn encode_into(word: u32, c: vec3<f32>) -> u32 {
    return (word & 0xff000000u) | encode1(c.x) | (encode1(c.y) << 8u) | (encode1(c.z) << 16u);
}

// A level stored at `off` in a row-major texel array: offset, width, height.
struct LevelDesc {
    off: u32,
    w: u32,
    h: u32,
    pad: u32,
}
