// Depth of field (Lee 2009 ch. 4), the GPU twin of
// `effects::depth_of_field` (the reference): level 0 decoded with its depth
// and degree of blur, the anisotropic Gaussian pyramid (eq. 4.1, 4.9), and
// the blend of the 9-point circular filter over two levels (eq. 4.8). The
// CPU gives what needs f64 (see `gpu::dof`): the CoC constant, the exact
// depth interval of sharp pixels, the f32 threshold of "behind the focus".
// Every sum is in the CPU's order.

struct Params {
    width: u32,
    height: u32,
    // Levels built (level 0 included).
    n_levels: u32,
    // The level this dispatch builds from (pyramid passes).
    src: u32,
    // C(d) = k·|d − d_f|/d (finite focus) or k/d (focus at infinity).
    k: f32,
    // d_f split in two f32 (hi + lo) for |d − d_f|.
    focus_hi: f32,
    focus_lo: f32,
    focus_finite: u32,
    // The CoC of the background (nothing hit: infinite depth).
    coc_background: f32,
    // Hit depths in [sharp_lo, sharp_hi] have level 0 (exactly the CPU's
    // set); sharp_background: the background has level 0.
    sharp_lo: f32,
    sharp_hi: f32,
    sharp_background: u32,
    // The smallest f32 above d_f (f64): z >= it is "behind the focus".
    z_behind: f32,
    k_sigma: f32,
    top: f32,
    anisotropic: u32,
    taps: vec4<f32>,
    // Circular filter: neighbour weight, normalisation, 1/sqrt(2).
    g: f32,
    norm: f32,
    diag: f32,
    delta: f32,
    nearest: f32,
    sigma_cap: f32,
    // The focal depth as the CPU's foreground smoothing compares depths
    // with it (f32, unclamped; +∞ for a focus at infinity).
    fg_focus: f32,
    pad1: u32,
    levels: array<LevelDesc, 9>,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(4) var<storage, read> depth: array<f32>;
// Binding 5: the colour pyramid `px` (pyramid.wgsl).
// The depth mip (Z); background (infinite depth) anywhere in a texel's
// footprint is stored as -1.
@group(0) @binding(6) var<storage, read_write> zmip: array<f32>;
// The degree-of-blur mip (B, σ in px).
@group(0) @binding(7) var<storage, read_write> smip: array<f32>;

fn coc(i: u32, hit: bool) -> f32 {
    if (!hit) {
        return p.coc_background;
    }
    let d = max(depth[i], p.nearest);
    if (p.focus_finite == 1u) {
        return p.k * abs((d - p.focus_hi) - p.focus_lo) / d;
    }
    return p.k / d;
}

fn is_sharp(i: u32, hit: bool) -> bool {
    if (!hit) {
        return p.sharp_background == 1u;
    }
    let d = depth[i];
    return d >= p.sharp_lo && d <= p.sharp_hi;
}

// Level 0: colour, depth (background -1) and σ.
@compute @workgroup_size(8, 8)
fn dof_base(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let i = id.y * p.width + id.x;
    let word = pixels[i];
    let hit = ((word >> 24u) & 1u) == 1u;
    px[i] = vec4<f32>(decode(word), 0.0);
    note_level(i, hit);
    if (hit) {
        zmip[i] = depth[i];
    } else {
        zmip[i] = -1.0;
    }
    smip[i] = min(coc(i, hit) * 0.5, p.sigma_cap);
}

// Level src + 1 from level src.
@compute @workgroup_size(8, 8)
fn dof_reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = p.levels[p.src];
    let t = p.levels[p.src + 1u];
    if (id.x >= t.w || id.y >= t.h) {
        return;
    }
    var z = 0.0;
    var sg = 0.0;
    var behind_any = false;
    // The 4 taps of `p.taps`: between source texels 2x and 2x + 1.
    for (var ty = 0u; ty < 4u; ty++) {
        let row = s.off + reduce_source(id.y, ty, 4u, s.h) * s.w;
        for (var tx = 0u; tx < 4u; tx++) {
            let q = row + reduce_source(id.x, tx, 4u, s.w);
            let wgt = p.taps[ty] * p.taps[tx];
            let zq = zmip[q];
            if (zq < 0.0) {
                behind_any = true;
            } else {
                z += wgt * zq;
            }
            sg += wgt * smip[q];
        }
    }
    let background = p.focus_finite == 1u && (behind_any || z >= p.z_behind);
    var acc = vec3<f32>(0.0);
    var total = 0.0;
    for (var ty = 0u; ty < 4u; ty++) {
        let row = s.off + reduce_source(id.y, ty, 4u, s.h) * s.w;
        for (var tx = 0u; tx < 4u; tx++) {
            let q = row + reduce_source(id.x, tx, 4u, s.w);
            let wgt = p.taps[ty] * p.taps[tx];
            if (p.anisotropic == 1u && background && sg > smip[q] + p.delta) {
                continue;
            }
            acc += wgt * px[q].xyz;
            total += wgt;
        }
    }
    let i = t.off + id.y * t.w + id.x;
    if (behind_any) {
        zmip[i] = -1.0;
    } else {
        zmip[i] = z;
    }
    smip[i] = sg;
    if (total > 0.0) {
        px[i] = vec4<f32>(acc / total, 0.0);
    } else {
        px[i] = px[s.off + reduce_source(id.y, 1u, 4u, s.h) * s.w + reduce_source(id.x, 1u, 4u, s.w)];
    }
}

// A_k(p): the 9-point circular Gaussian over level k at pixel (x, y).
fn circular(k: u32, x: u32, y: u32) -> vec3<f32> {
    let l = p.levels[k];
    let c = level_coords(k, x, y);
    let u = c.x;
    let v = c.y;
    let dg = p.diag;
    var acc = level_bilinear(l, u, v);
    acc += p.g * level_bilinear(l, u + 1.0, v);
    acc += p.g * level_bilinear(l, u - 1.0, v);
    acc += p.g * level_bilinear(l, u, v + 1.0);
    acc += p.g * level_bilinear(l, u, v - 1.0);
    acc += p.g * level_bilinear(l, u + dg, v + dg);
    acc += p.g * level_bilinear(l, u + dg, v - dg);
    acc += p.g * level_bilinear(l, u - dg, v + dg);
    acc += p.g * level_bilinear(l, u - dg, v - dg);
    return acc * p.norm;
}

// Eq. 4.8, linear blend, for every pixel whose level is above 0.
@compute @workgroup_size(8, 8)
fn dof_blend(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let i = id.y * p.width + id.x;
    let word = pixels[i];
    let hit = ((word >> 24u) & 1u) == 1u;
    // Foreground smoothing's level, where it gave one (sharp pixels too).
    var m = override_level(i);
    if (m < 0.0) {
        if (is_sharp(i, hit)) {
            return;
        }
        let s = p.k_sigma * (coc(i, hit) * 0.5);
        m = clamp(1.0 + log2(s), 0.0, p.top);
    }
    if (!(m > 0.0)) {
        return;
    }
    let lf = floor(m);
    let l = u32(lf);
    let beta = m - lf;
    var a: vec3<f32>;
    if (l == 0u) {
        a = px[i].xyz;
    } else {
        a = circular(l - 1u, id.x, id.y);
    }
    var c = a;
    if (!(beta <= 0.0) && l < p.n_levels) {
        let b = circular(l, id.x, id.y);
        c = a + (b - a) * beta;
    }
    pixels[i] = encode_into(word, c);
}
