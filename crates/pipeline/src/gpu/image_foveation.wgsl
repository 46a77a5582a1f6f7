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
// Binding 5: the pyramid `px` (pyramid.wgsl).
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
        acc += taps[k] * px[s.off + id.y * s.w + reduce_source(id.x, k, 5u, s.w)].xyz;
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
        acc += taps[k] * rows[reduce_source(id.y, k, 5u, s.h) * t.w + id.x].xyz;
    }
    px[t.off + id.y * t.w + id.x] = vec4<f32>(acc, 0.0);
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
        a = level_at_pixel(p.levels[l], l, id.x, id.y);
    }
    var c = a;
    if (!(beta <= 0.0) && l + 1u < p.n_levels) {
        let b = level_at_pixel(p.levels[l + 1u], l + 1u, id.x, id.y);
        c = a + (b - a) * beta;
    }
    pixels[i] = encode_into(pixels[i], c);
}
