// The POR box (`effects::por_overlay::draw_box`) on the frame's packed
// words: a thread per pixel of the box's bounding square clipped to the
// frame; a pixel is on the outline when it lies within `r` of the centre
// on one axis and on one of the four lines -r, -r+1, r-1, r on the other
// (the CPU's loops, as a test). The hit flag and layer bits are kept.

struct PorParams {
    // The clipped bounding square: first pixel, size.
    x0: u32,
    y0: u32,
    bw: u32,
    bh: u32,
    // The frame's width, the box's centre and half-size.
    w: u32,
    cx: i32,
    cy: i32,
    r: i32,
}

@group(0) @binding(0) var<uniform> por: PorParams;

fn on_line(v: i32, r: i32) -> bool {
    return v == -r || v == -r + 1 || v == r - 1 || v == r;
}

@compute @workgroup_size(8, 8)
fn por_box(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= por.bw || id.y >= por.bh) {
        return;
    }
    let x = por.x0 + id.x;
    let y = por.y0 + id.y;
    let dx = i32(x) - por.cx;
    let dy = i32(y) - por.cy;
    let outline = (abs(dx) <= por.r && on_line(dy, por.r)) || (abs(dy) <= por.r && on_line(dx, por.r));
    if (outline) {
        let i = y * por.w + x;
        // RGB 255, 220, 0 in bits 0-23.
        pixels[i] = (pixels[i] & 0xff000000u) | 255u | (220u << 8u);
    }
}
