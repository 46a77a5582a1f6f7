// Pixel ownership on the GPU: the CPU's `render::ownership`, bit for bit.
// Every pixel starts unowned; the fovea's spans claim theirs; then each
// intermediate-mesh cell claims the pixels whose centres it contains by the
// exact integer top-left rule (coordinates snapped to 1/65536 px, edge
// functions evaluated exactly in 64-bit integers, emulated here with pairs
// of u32 since WGSL has no 64-bit integers). Cells share edges but never a
// pixel under that rule, so a cell's "claim while unowned" needs no atomics
// (as on the CPU). Only the mask goes up: its vertices (f32, the same
// buffer the vertex rays read), its cells and its fovea spans.

struct Own {
    width: u32,
    height: u32,
    n_spans: u32,
    n_cells: u32,
};

const NO_VERTEX: u32 = 0xffffffffu;
const FOVEA: u32 = 0xffffffffu;
const UNOWNED: u32 = 0xfffffffeu;
// 1/65536 px: the CPU's SUB.
const SUB: i32 = 65536;
const HALF: i32 = 32768;

@group(0) @binding(0) var<uniform> own: Own;
@group(0) @binding(1) var<storage, read> vertices: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read> cells: array<vec4<u32>>;
// Fovea spans: (y, x_start, x_end), x_end exclusive, clipped to the screen.
@group(0) @binding(3) var<storage, read> spans: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> owner: array<u32>;

@compute @workgroup_size(8, 8)
fn own_clear(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= own.width || id.y >= own.height) { return; }
    owner[id.y * own.width + id.x] = UNOWNED;
}

@compute @workgroup_size(64)
fn own_fovea(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if (i >= own.n_spans) { return; }
    let s = spans[i];
    let row = s.x * own.width;
    for (var x = s.y; x < s.z; x++) {
        owner[row + x] = FOVEA;
    }
}

// A 64-bit two's-complement integer: (low word, high word).
fn mul_wide_u(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = p01 + p10;
    let mid_carry = select(0u, 1u, mid < p01);
    let lo = p00 + (mid << 16u);
    let lo_carry = select(0u, 1u, lo < p00);
    let hi = p11 + (mid >> 16u) + (mid_carry << 16u) + lo_carry;
    return vec2<u32>(lo, hi);
}

fn neg64(x: vec2<u32>) -> vec2<u32> {
    let lo = ~x.x + 1u;
    let hi = ~x.y + select(0u, 1u, lo == 0u);
    return vec2<u32>(lo, hi);
}

// a · b exactly, for |a|, |b| < 2^31.
fn mul_wide(a: i32, b: i32) -> vec2<u32> {
    let m = mul_wide_u(u32(abs(a)), u32(abs(b)));
    if ((a < 0) != (b < 0)) { return neg64(m); }
    return m;
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    let carry = select(0u, 1u, lo < a.x);
    return vec2<u32>(lo, a.y + b.y + carry);
}

fn sub64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x - b.x;
    let borrow = select(0u, 1u, a.x < b.x);
    return vec2<u32>(lo, a.y - b.y - borrow);
}

// -1, 0 or 1: the sign of a 64-bit integer.
fn sign64(x: vec2<u32>) -> i32 {
    if (i32(x.y) < 0) { return -1; }
    if (x.x == 0u && x.y == 0u) { return 0; }
    return 1;
}

// The CPU's `(f64::from(v) * SUB).round() as i64` (half away from zero):
// v · 65536 is exact in f32, and so are its truncation and fraction. The
// caller keeps |v| below 8192 px (the CPU checks before choosing this path).
fn snap(v: f32) -> i32 {
    let x = v * 65536.0;
    let t = trunc(x);
    var r = i32(t);
    if (abs(x - t) >= 0.5) {
        r += select(1, -1, x < 0.0);
    }
    return r;
}

// ceil(n / 65536) and floor(n / 65536) for any i32 (arithmetic shifts).
fn ceil_sub(n: i32) -> i32 { return -((-n) >> 16u); }
fn floor_sub(n: i32) -> i32 { return n >> 16u; }

// One thread per cell (most cells cover a few pixels): it walks its
// bounding box row by row.
@compute @workgroup_size(64)
fn own_cells(@builtin(global_invocation_id) id: vec3<u32>) {
    let ci = id.x + id.y * 65535u * 64u;
    if (ci >= own.n_cells) { return; }
    let c = cells[ci];
    var n = 4u;
    if (c.w == NO_VERTEX) { n = 3u; }
    var p: array<vec2<i32>, 4>;
    for (var k = 0u; k < n; k++) {
        let v = vertices[c[k]];
        p[k] = vec2<i32>(snap(v.x), snap(v.y));
    }
    // Twice the signed area: 0 claims nothing; negative runs the edges
    // the other way round (the CPU reverses the corners).
    var area = vec2<u32>(0u, 0u);
    for (var k = 0u; k < n; k++) {
        let a = p[k];
        let b = p[(k + 1u) % n];
        area = add64(area, sub64(mul_wide(a.x, b.y), mul_wide(b.x, a.y)));
    }
    let s = sign64(area);
    if (s == 0) { return; }
    let reversed = s < 0;
    var lo = p[0];
    var hi = p[0];
    for (var k = 1u; k < n; k++) {
        lo = min(lo, p[k]);
        hi = max(hi, p[k]);
    }
    let px0 = max(ceil_sub(lo.x - HALF), 0);
    let py0 = max(ceil_sub(lo.y - HALF), 0);
    let px1 = min(floor_sub(hi.x - HALF), i32(own.width) - 1);
    let py1 = min(floor_sub(hi.y - HALF), i32(own.height) - 1);
    if (px0 > px1 || py0 > py1) { return; }
    // Each edge: start, direction, and whether a centre on it is inside.
    var start: array<vec2<i32>, 4>;
    var dir: array<vec2<i32>, 4>;
    var on: array<bool, 4>;
    for (var k = 0u; k < n; k++) {
        var a = p[k];
        var b = p[(k + 1u) % n];
        if (reversed) {
            let t = a;
            a = b;
            b = t;
        }
        let d = b - a;
        start[k] = a;
        dir[k] = d;
        on[k] = d.y > 0 || (d.y == 0 && d.x < 0);
    }
    // Each edge function exactly at a row's first centre, then stepped by
    // the exact −dy · SUB per pixel (as the CPU does), so a pixel costs
    // 64-bit additions, not multiplications.
    var step: array<vec2<u32>, 4>;
    for (var k = 0u; k < n; k++) {
        step[k] = mul_wide(-dir[k].y, SUB);
    }
    let cx0 = px0 * SUB + HALF;
    let rows = u32(py1 - py0 + 1);
    for (var r = 0u; r < rows; r++) {
        let py = py0 + i32(r);
        let cy = py * SUB + HALF;
        var e: array<vec2<u32>, 4>;
        for (var k = 0u; k < n; k++) {
            // e = dx · (cy − ay) − dy · (cx0 − ax), exactly.
            e[k] = sub64(
                mul_wide(dir[k].x, cy - start[k].y),
                mul_wide(dir[k].y, cx0 - start[k].x),
            );
        }
        let row = u32(py) * own.width;
        for (var px = px0; px <= px1; px++) {
            var inside = true;
            for (var k = 0u; k < n; k++) {
                let sg = sign64(e[k]);
                if (!(sg > 0 || (sg == 0 && on[k]))) {
                    inside = false;
                }
                e[k] = add64(e[k], step[k]);
            }
            if (inside) {
                let at = row + u32(px);
                if (owner[at] == UNOWNED) {
                    owner[at] = ci;
                }
            }
        }
    }
}
