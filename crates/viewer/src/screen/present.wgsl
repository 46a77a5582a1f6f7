// Draws a frame that stayed on the GPU into the window's surface: one
// triangle covering the surface; each fragment takes its pixel's word
// (`pack` in raycast's cast.wgsl: red, green, blue in the low bytes) from
// the frame's buffer, and the HUD's overlay where that has a box.
// 8-bit values k/255 convert back to k exactly in an 8-bit target.

struct Sizes {
    // The frame, and the overlay (0 × 0 without one) and its top left.
    width: u32,
    height: u32,
    overlay_width: u32,
    overlay_height: u32,
    overlay_x: u32,
    overlay_y: u32,
    pad0: u32,
    pad1: u32,
};

@group(0) @binding(0) var<uniform> sizes: Sizes;
@group(0) @binding(1) var<storage, read> pixels: array<u32>;
// The overlay: RGBA8 words, alpha 0 where the frame shows through.
@group(0) @binding(2) var<storage, read> overlay: array<u32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn unpack(word: u32) -> vec4<f32> {
    return vec4<f32>(
        f32(word & 255u),
        f32((word >> 8u) & 255u),
        f32((word >> 16u) & 255u),
        255.0,
    ) / 255.0;
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let x = u32(p.x);
    let y = u32(p.y);
    // Unsigned: a pixel left of or above the overlay wraps past its size.
    let ox = x - sizes.overlay_x;
    let oy = y - sizes.overlay_y;
    if (ox < sizes.overlay_width && oy < sizes.overlay_height) {
        let o = overlay[oy * sizes.overlay_width + ox];
        if ((o >> 24u) != 0u) {
            return unpack(o);
        }
    }
    if (x >= sizes.width || y >= sizes.height) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    return unpack(pixels[y * sizes.width + x]);
}
