// Image-based foveation, the GPU twin of `image_foveation` (the
// reference): level 0 decoded, Burt–Adelson REDUCE (separable binomial,
// rows then columns), and the linear blend of the two levels around each
// pixel's level. The level map is the CPU's (it depends on the gaze only),
// uploaded per gaze. Every sum is in the CPU's order.

struct Params {
    width: u32,
    height: u32,
    n_levels: u32,
    src: u32,
    levels: array<LevelDesc, 8>,
}

@group(0) @binding(0) var<uniform> p: Params;
// The level per pixel (0: untouched).
@group(0) @binding(4) var<storage, read> level_map: array<f32>;
// The pyramid (linear RGB in xyz), every level.
@group(0) @binding(5) var<storage, read_write> px: array<vec4<f32>>;
// The horizontal pass of REDUCE: level src + 1's width × level src's height.
@group(0) @binding(6) var<storage, read_write> rows: array<vec4<f32>>;


@compute @workgroup_size(8, 8)
fn fov_base(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let i = id.y * p.width + id.x;
    px[i] = vec4<f32>(decode(pixels[i]), 0.0);
}

// `(2x + t).saturating_sub(2).min(n − 1)`.
fn tap_at(x: u32, t: u32, n: u32) -> u32 {
    return min(max(2u * x + t, 2u) - 2u, n - 1u);
}

@compute @workgroup_size(8, 8)
fn fov_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = p.levels[p.src];
    let t = p.levels[p.src + 1u];
    if (id.x >= t.w || id.y >= s.h) {
        return;
    }
    // [1 4 6 4 1] / 16 (`TAPS`), summed in the CPU's order.
    var taps = array<f32, 5>(0.0625, 0.25, 0.375, 0.25, 0.0625);
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < 5u; k++) {
        acc += taps[k] * px[s.off + id.y * s.w + tap_at(id.x, k, s.w)].xyz;
    }
    rows[id.y * t.w + id.x] = vec4<f32>(acc, 0.0);
}

@compute @workgroup_size(8, 8)
fn fov_columns(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = p.levels[p.src];
    let t = p.levels[p.src + 1u];
    if (id.x >= t.w || id.y >= t.h) {
        return;
    }
    var taps = array<f32, 5>(0.0625, 0.25, 0.375, 0.25, 0.0625);
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < 5u; k++) {
        acc += taps[k] * rows[tap_at(id.y, k, s.h) * t.w + id.x].xyz;
    }
    px[t.off + id.y * t.w + id.x] = vec4<f32>(acc, 0.0);
}

// Level k at the centre of level-0 pixel (x, y), bilinear, clamped.
fn at_pixel(k: u32, x: u32, y: u32) -> vec3<f32> {
    let l = p.levels[k];
    let scale = f32(1u << k);
    let xc = clamp((f32(x) + 0.5) / scale - 0.5, 0.0, f32(l.w - 1u));
    let yc = clamp((f32(y) + 0.5) / scale - 0.5, 0.0, f32(l.h - 1u));
    let x0f = floor(xc);
    let y0f = floor(yc);
    let fx = xc - x0f;
    let fy = yc - y0f;
    let x0 = u32(x0f);
    let y0 = u32(y0f);
    let x1 = min(x0 + 1u, l.w - 1u);
    let y1 = min(y0 + 1u, l.h - 1u);
    let a = px[l.off + y0 * l.w + x0].xyz;
    let b = px[l.off + y0 * l.w + x1].xyz;
    let c = px[l.off + y1 * l.w + x0].xyz;
    let d = px[l.off + y1 * l.w + x1].xyz;
    let top = a + (b - a) * fx;
    let bot = c + (d - c) * fx;
    return top + (bot - top) * fy;
}

@compute @workgroup_size(8, 8)
fn fov_blend(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let i = id.y * p.width + id.x;
    let m = level_map[i];
    if (!(m > 0.0)) {
        return;
    }
    let lf = min(floor(m), f32(p.n_levels - 1u));
    let l = u32(lf);
    let beta = m - lf;
    var a: vec3<f32>;
    if (l == 0u) {
        a = px[i].xyz;
    } else {
        a = at_pixel(l, id.x, id.y);
    }
    var c = a;
    if (!(beta <= 0.0) && l + 1u < p.n_levels) {
        let b = at_pixel(l + 1u, id.x, id.y);
        c = a + (b - a) * beta;
    }
    pixels[i] = encode_into(pixels[i], c);
}
