// The foveated stages (appended to cast.wgsl): cast the mask vertices,
// classify the intermediate-mesh cells, widen the refined set by one vertex
// ring, then per pixel cast (fovea, refined cells) or interpolate
// (homogeneous cells), shade and fill the G-buffer — the CPU's `render::foveated`, stage by
// stage. The mask and the pixel ownership (which depend on the gaze only)
// come from the CPU.

struct Fov {
    n_vertices: u32,
    n_cells: u32,
    silhouette: u32,
    margin: u32,
    crease_cos: f32,   // < -1: no crease trigger
    depth_jump: f32,   // < 0: no depth trigger
    _pad0: u32,
    _pad1: u32,
};

const NO_VERTEX: u32 = 0xffffffffu;
const FOVEA: u32 = 0xffffffffu;
const UNOWNED: u32 = 0xfffffffeu;

@group(1) @binding(0) var<uniform> fov: Fov;
@group(1) @binding(1) var<storage, read> vertices: array<vec2<f32>>;
@group(1) @binding(2) var<storage, read> cells: array<vec4<u32>>;
@group(1) @binding(3) var<storage, read> owner: array<u32>;
// Per vertex: hit, object, t, normal x, y, z.
@group(1) @binding(4) var<storage, read_write> vhits: array<Sample>;
@group(1) @binding(5) var<storage, read_write> refined: array<u32>;
@group(1) @binding(6) var<storage, read_write> touched: array<u32>;
// fovea rays, refined rays, refined cells, pixels listed to cast.
@group(1) @binding(7) var<storage, read_write> counters: array<atomic<u32>, 4>;
// Pixels to cast (index | 1 << 31 for the fovea), appended by `pixels_foveated`.
@group(1) @binding(8) var<storage, read_write> cast_list: array<u32>;
// Workgroup counts of the indirect dispatch of `cast_listed` (a group of its
// own: bound as storage it may not be in the scope of the indirect dispatch).
@group(2) @binding(0) var<storage, read_write> dispatch: array<u32, 3>;

fn corner_count(c: vec4<u32>) -> u32 {
    if (c.w == NO_VERTEX) { return 3u; }
    return 4u;
}

@compute @workgroup_size(64)
fn cast_vertices(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= fov.n_vertices) { return; }
    vhits[i] = trace(vertices[i]);
}

fn homogeneous(c: vec4<u32>) -> bool {
    let n = corner_count(c);
    var any_hit = false;
    for (var k = 0u; k < n; k++) {
        if (vhits[c[k]].hit == 1u) { any_hit = true; }
    }
    if (!any_hit) { return true; }
    let a = vhits[c[0]];
    if (a.hit == 0u) { return fov.silhouette == 0u; }
    for (var k = 1u; k < n; k++) {
        let h = vhits[c[k]];
        if (h.hit == 0u || h.object != a.object) { return fov.silhouette == 0u; }
    }
    // All corners hit the same object.
    if (fov.crease_cos >= -1.0) {
        for (var i = 0u; i < n; i++) {
            for (var j = i + 1u; j < n; j++) {
                if (dot(vhits[c[i]].normal, vhits[c[j]].normal) < fov.crease_cos) { return false; }
            }
        }
    }
    if (fov.depth_jump >= 0.0) {
        var lo = INF;
        var hi = 0.0;
        for (var k = 0u; k < n; k++) {
            lo = min(lo, vhits[c[k]].t);
            hi = max(hi, vhits[c[k]].t);
        }
        if (hi > lo * (1.0 + fov.depth_jump)) { return false; }
    }
    return true;
}

@compute @workgroup_size(64)
fn classify(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= fov.n_cells) { return; }
    let c = cells[i];
    var r = 0u;
    if (!homogeneous(c)) {
        r = 1u;
        if (fov.margin == 1u) {
            for (var k = 0u; k < corner_count(c); k++) { touched[c[k]] = 1u; }
        }
    }
    refined[i] = r;
}

@compute @workgroup_size(64)
fn widen(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= fov.n_cells || fov.margin == 0u) { return; }
    let c = cells[i];
    for (var k = 0u; k < corner_count(c); k++) {
        if (touched[c[k]] == 1u) { refined[i] = 1u; }
    }
}

@compute @workgroup_size(64)
fn count_cells(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= fov.n_cells) { return; }
    if (refined[i] == 1u) { atomicAdd(&counters[2], 1u); }
}

// Interpolated colour at p from a homogeneous cell's corners (quads as two
// triangles), the CPU's `interpolate`.
fn interpolate(c: vec4<u32>, p: vec2<f32>) -> Sample {
    let first = vhits[c[0]];
    if (first.hit == 0u) { return MISS; }
    let n = corner_count(c);
    var ntri = 1u;
    if (n == 4u) { ntri = 2u; }
    var found = false;
    var ti = vec3<u32>(0u, 1u, 2u);
    var wts = vec3<f32>(0.0);
    for (var k = 0u; k < ntri; k++) {
        var t = vec3<u32>(0u, 1u, 2u);
        if (k == 1u) { t = vec3<u32>(0u, 2u, 3u); }
        let a = vertices[c[t.x]];
        let b = vertices[c[t.y]];
        let cc = vertices[c[t.z]];
        let d = (b.x - a.x) * (cc.y - a.y) - (b.y - a.y) * (cc.x - a.x);
        if (d == 0.0) { continue; }
        let wb = ((p.x - a.x) * (cc.y - a.y) - (p.y - a.y) * (cc.x - a.x)) / d;
        let wc = ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / d;
        let wa = 1.0 - wb - wc;
        let inside = wa >= -1e-4 && wb >= -1e-4 && wc >= -1e-4;
        if (inside || k + 1u == ntri) {
            ti = t;
            wts = vec3<f32>(wa, wb, wc);
            found = true;
            if (inside) { break; }
        }
    }
    if (!found) { return first; }
    var dist = 0.0;
    var normal = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        var h = vhits[c[ti[k]]];
        if (h.hit == 0u) { h = first; }
        dist += wts[k] * h.t;
        normal += wts[k] * h.normal;
    }
    var nn = try_normalize(normal);
    if (all(nn == vec3<f32>(0.0))) { nn = first.normal; }
    return Sample(1u, first.object, dist, nn);
}

// Layers: 1 fovea, 2 interpolated, 3 refined (as `render::Layer`).
@compute @workgroup_size(8, 8)
fn pixels_foveated(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) { return; }
    let i = id.y * params.width + id.x;
    let p = vec2<f32>(f32(id.x) + 0.5, f32(id.y) + 0.5);
    let o = owner[i];
    if (o == UNOWNED) {
        put(i, p, MISS, 2u);
        return;
    }
    if (o == FOVEA || refined[o] == 1u) {
        // Cast later, by `cast_listed` over the compacted list.
        var tag = 0u;
        if (o == FOVEA) {
            tag = 0x80000000u;
            atomicAdd(&counters[0], 1u);
        } else {
            atomicAdd(&counters[1], 1u);
        }
        let k = atomicAdd(&counters[3], 1u);
        cast_list[k] = i | tag;
        return;
    }
    let c = cells[o];
    // A homogeneous cell whose corners all miss is background.
    var all_miss = true;
    for (var k = 0u; k < corner_count(c); k++) {
        if (vhits[c[k]].hit == 1u) { all_miss = false; }
    }
    if (all_miss) {
        put(i, p, MISS, 2u);
        return;
    }
    put(i, p, interpolate(c, p), 2u);
}

// One thread: the workgroup counts for `cast_listed` (64 per group, at most
// 65535 groups in x).
@compute @workgroup_size(1)
fn prepare_cast() {
    let n = atomicLoad(&counters[3]);
    let groups = (n + 63u) / 64u;
    dispatch[0] = min(groups, 65535u);
    dispatch[1] = (groups + 65534u) / 65535u;
    dispatch[2] = 1u;
}

@compute @workgroup_size(64)
fn cast_listed(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x + id.y * 65535u * 64u;
    if (k >= atomicLoad(&counters[3])) { return; }
    let entry = cast_list[k];
    let i = entry & 0x7fffffffu;
    let p = vec2<f32>(f32(i % params.width) + 0.5, f32(i / params.width) + 0.5);
    var layer = 3u;
    if ((entry & 0x80000000u) != 0u) { layer = 1u; }
    put(i, p, trace(p), layer);
}
