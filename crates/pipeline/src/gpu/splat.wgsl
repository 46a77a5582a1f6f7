// Depth of field by splatting on per-pixel layers (Lee 2009 ch. 5), the
// GPU twin of `effects::dof_splat` (the reference): the visible image V
// with its signed CoC, the seed's tests for a hidden sample (a, b; c is
// the hidden cast of raycast's hidden.wgsl), the scatter of every V and H
// sprite into three layers with fixed-point atomics, and eq. 5.4's
// composition and normalisation. The CPU gives what needs f64 (the CoC
// constant, the focus split in two f32, the exact f32 thresholds of "in
// front of / behind the focus", the background's CoC) and the tables
// (k_n, the eq. 5.1 spiral).
//
// Fixed point: every term (a·r, a·g, a·b, a) is rounded to a multiple of
// 2^-24 and added into a 64-bit accumulator (two u32 words, low word by
// atomicAdd, a carry into the high word when it wraps), so the sums are
// exact and independent of the order the sprites land in.

struct Params {
    width: u32,
    height: u32,
    hidden: u32,
    highlights: u32,
    // C(d) = k·|d − d_f|/d (finite focus) or k/d (focus at infinity).
    k: f32,
    focus_hi: f32,
    focus_lo: f32,
    focus_finite: u32,
    // The background's signed CoC (also the hidden background's).
    b_background: f32,
    // d < z_in_front ⟺ d (f64) < d_f; d ≥ z_behind ⟺ d > d_f (clamped focus).
    z_in_front: f32,
    z_behind: f32,
    // Test (a): z_v < z_front ⟺ z_v ≤ focus (f64, unclamped; 0 for NaN).
    z_front: f32,
    nearest: f32,
    delta: f32,
    lap_threshold: f32,
    max_coc: f32,
    hl_threshold: f32,
    hl_exponent: f32,
    hl_gain: f32,
    steps_per_px: f32,
    // The scene's linear background clamped to [0, 1] (a hidden background).
    background: vec4<f32>,
    spiral: array<vec4<f32>, 6>,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(4) var<storage, read> depth: array<f32>;
// k_n(C) by quantised diameter.
@group(0) @binding(5) var<storage, read> kn: array<f32>;
// V samples (linear rgb, signed CoC) at 0..n, H samples at n..2n.
@group(0) @binding(6) var<storage, read_write> work: array<vec4<f32>>;
// Per pixel: 1 where the hidden surface is wanted (tests a and b).
@group(0) @binding(7) var<storage, read_write> want: array<u32>;
// The hidden cast's output (`GpuFrame::cast_hidden`).
@group(0) @binding(8) var<storage, read_write> hidden_out: array<vec4<f32>>;
// Per pixel 25 words: 3 layers × 4 channels × (lo, hi), then "touched";
// word 25·n: whether any sprite is wider than 1 px.
@group(0) @binding(9) var<storage, read_write> acc: array<atomic<u32>>;

const WORDS: u32 = 25u;
const F_INF: f32 = 3.4028235e38;

fn is_hit(i: u32) -> bool {
    return ((pixels[i] >> 24u) & 1u) == 1u;
}

// The frame's depth, the background infinitely far.
fn depth_of(i: u32) -> f32 {
    if (is_hit(i)) { return depth[i]; }
    return F_INF;
}

// `signed_coc_px` of a hit depth.
fn signed_coc(z: f32) -> f32 {
    let d = max(z, p.nearest);
    var c: f32;
    if (p.focus_finite == 1u) {
        c = p.k * abs((d - p.focus_hi) - p.focus_lo) / d;
    } else {
        c = p.k / d;
    }
    c = min(c, p.max_coc);
    if (!(c == c)) { c = 0.0; }
    if (d < p.z_in_front) { return -c; }
    if (d >= p.z_behind) { return c; }
    return 0.0;
}

// Rust's `f32::round` (half away from zero) for |v| < 2^23.
fn round_away(v: f32) -> f32 {
    let f = floor(v);
    let d = v - f;
    if (d > 0.5 || (d == 0.5 && v > 0.0)) { return f + 1.0; }
    return f;
}

// The quantised diameter of a signed CoC (index into k_n).
fn quantise(b: f32) -> u32 {
    return u32(round_away(min(abs(b), p.max_coc) * p.steps_per_px));
}

// `Highlights::apply` with the CoC ramp.
fn boost(rgb: vec3<f32>, c: f32) -> vec3<f32> {
    if (p.highlights == 0u) { return rgb; }
    let weight = clamp(c - 1.0, 0.0, 1.0);
    let lambda = 0.3 * rgb.x + 0.59 * rgb.y + 0.11 * rgb.z;
    let l0 = p.hl_threshold;
    if (!(lambda > l0 && l0 < 1.0 && weight > 0.0)) { return rgb; }
    let ln = min((lambda - l0) / (1.0 - l0), 1.0);
    let lb = pow(ln, p.hl_exponent);
    var scale = (1.0 - lb) + lb * p.hl_gain;
    scale = 1.0 + (scale - 1.0) * min(weight, 1.0);
    if (abs(scale) < F_INF) { return rgb * scale; }
    return rgb;
}

// Eq. 5.1 at pixel (x, y) of CoC c.
fn laplacian(x: u32, y: u32, c: f32) -> f32 {
    let zp = depth_of(y * p.width + x);
    let radius = 0.5 * c;
    var sum = 0.0;
    for (var k = 0u; k < 12u; k++) {
        let s = p.spiral[k / 2u];
        var uv = s.xy;
        if (k % 2u == 1u) { uv = s.zw; }
        let nx = u32(clamp(round_away(f32(x) + uv.x * radius), 0.0, f32(p.width - 1u)));
        let ny = u32(clamp(round_away(f32(y) + uv.y * radius), 0.0, f32(p.height - 1u)));
        let zn = depth_of(ny * p.width + nx);
        var term = 0.0;
        if (zn == zp) {
            term = 0.0;
        } else if (zn >= F_INF) {
            term = 1.0;
        } else {
            term = clamp((zn - zp) / zp, -1.0, 1.0);
        }
        if (term == term) { sum += term; }
    }
    return sum / 12.0;
}

// V: colour and signed CoC; the hidden tests (a) and (b).
@compute @workgroup_size(8, 8)
fn splat_visible(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) { return; }
    let i = id.y * p.width + id.x;
    let hit = is_hit(i);
    var b = p.b_background;
    if (hit) { b = signed_coc(depth[i]); }
    let c = abs(b);
    work[i] = vec4<f32>(boost(decode(pixels[i]), c), b);
    var wanted = 0u;
    if (p.hidden == 1u && hit && depth[i] < p.z_front) {
        let l = laplacian(id.x, id.y, c);
        if (!(l < p.lap_threshold || l <= 0.0)) { wanted = 1u; }
    }
    want[i] = wanted;
}

// H: the hidden cast's surface as a sample; w = 0 marks none.
@compute @workgroup_size(8, 8)
fn splat_hidden(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) { return; }
    let i = id.y * p.width + id.x;
    let n = p.width * p.height;
    let h = hidden_out[i];
    if (want[i] == 0u || h.w == -1.0) {
        want[i] = 0u;
        return;
    }
    var b = p.b_background;
    var rgb = vec3<f32>(0.0);
    if (h.w == -2.0) {
        // The scene's linear background, as the CPU pass takes it.
        rgb = p.background.xyz;
    } else {
        rgb = h.xyz;
        b = signed_coc(h.w);
    }
    work[n + i] = vec4<f32>(boost(rgb, abs(b)), b);
    want[i] = 2u;
}

// Adds `v` (≥ 0) in 2^-24 units to the 64-bit accumulator at word `j`.
fn add_fixed(j: u32, v: f32) {
    let x = clamp(v, 0.0, 255.0) * 16777216.0;
    var t: u32;
    if (x >= 8388608.0) { t = u32(x); } else { t = u32(floor(x + 0.5)); }
    if (t == 0u) { return; }
    let old = atomicAdd(&acc[j], t);
    if (old > 0xffffffffu - t) {
        atomicAdd(&acc[j + 1u], 1u);
    }
}

fn dest_layer(b: f32, q: u32) -> u32 {
    let bq = work[q].w;
    let tol = p.delta * max(abs(bq), 1.0);
    let d = b - bq;
    if (d < -tol) { return 0u; }
    if (d > tol) { return 2u; }
    return 1u;
}

fn land(q: u32, l: u32, a: f32, rgb: vec3<f32>, touch: bool) {
    let base = q * WORDS + l * 8u;
    add_fixed(base, a * rgb.x);
    add_fixed(base + 2u, a * rgb.y);
    add_fixed(base + 4u, a * rgb.z);
    add_fixed(base + 6u, a);
    if (touch) { atomicStore(&acc[q * WORDS + 24u], 1u); }
}

// `Band::splat` of one sample at (xs, ys).
fn splat_one(xs: u32, ys: u32, s: vec4<f32>, own: bool) {
    let b = s.w;
    let ci = quantise(b);
    let r = f32(ci) / p.steps_per_px * 0.5;
    if (r <= 0.5) {
        let q = ys * p.width + xs;
        var l = dest_layer(b, q);
        if (!own && l == 0u) { l = 1u; }
        land(q, l, 1.0, s.xyz, l < 2u && !own);
        return;
    }
    atomicStore(&acc[p.width * p.height * WORDS], 1u);
    let rr = r + 0.5;
    let ext = u32(floor(rr));
    let k = kn[min(ci, arrayLength(&kn) - 1u)];
    let lo = max(i32(ys) - i32(ext), 0);
    let hi = min(i32(ys + ext + 1u), i32(p.height));
    let inner = r - 0.5;
    for (var yd = lo; yd < hi; yd++) {
        let dy = f32(yd) - f32(ys);
        let span2 = rr * rr - dy * dy;
        if (span2 < 0.0) { continue; }
        let half = i32(floor(sqrt(span2)));
        let x_lo = max(i32(xs) - half, 0);
        let x_hi = min(i32(xs) + half + 1, i32(p.width));
        for (var xd = x_lo; xd < x_hi; xd++) {
            let dx = f32(xd) - f32(xs);
            let d2 = dx * dx + dy * dy;
            var cov: f32;
            if (inner > 0.0 && d2 <= inner * inner) {
                cov = 1.0;
            } else {
                cov = clamp(r + 0.5 - sqrt(d2), 0.0, 1.0);
            }
            if (cov <= 0.0) { continue; }
            let a = cov * k;
            let q = u32(yd) * p.width + u32(xd);
            var l = dest_layer(b, q);
            if (!own && l == 0u) { l = 1u; }
            land(q, l, a, s.xyz, l < 2u);
        }
    }
}

@compute @workgroup_size(8, 8)
fn splat_scatter(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) { return; }
    let i = id.y * p.width + id.x;
    splat_one(id.x, id.y, work[i], true);
    if (want[i] == 2u) {
        if (quantise(work[p.width * p.height + i].w) > u32(p.steps_per_px)) {
            atomicStore(&acc[p.width * p.height * WORDS], 1u);
        }
        splat_one(id.x, id.y, work[p.width * p.height + i], false);
    }
}

fn fixed(j: u32) -> f32 {
    return f32(atomicLoad(&acc[j + 1u])) * 256.0 + f32(atomicLoad(&acc[j])) * 5.9604645e-8;
}

// Eq. 5.4 (`compose`) and the encode, for every touched pixel.
@compute @workgroup_size(8, 8)
fn splat_compose(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) { return; }
    let i = id.y * p.width + id.x;
    if (atomicLoad(&acc[p.width * p.height * WORDS]) == 0u) { return; }
    if (atomicLoad(&acc[i * WORDS + 24u]) == 0u) { return; }
    var d = vec3<f32>(0.0);
    var da = 0.0;
    for (var step = 0u; step < 3u; step++) {
        let l = 2u - step;
        let base = i * WORDS + l * 8u;
        var c = vec3<f32>(fixed(base), fixed(base + 2u), fixed(base + 4u));
        var a = fixed(base + 6u);
        if (l == 2u) {
            if (a > 0.0) {
                d = c / a;
                da = 1.0;
            }
            continue;
        }
        if (a > 1.0) {
            c = c / a;
            a = 1.0;
        }
        let t = 1.0 - a;
        d = c + t * d;
        da = a + t * da;
        if (da > 0.0) {
            d = d / da;
            da = 1.0;
        }
    }
    d = select(vec3<f32>(0.0), d, abs(d) < vec3<f32>(F_INF));
    pixels[i] = encode_into(pixels[i], d);
}
