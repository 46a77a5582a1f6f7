// Lee §4.3's foreground smoothing (eqs. 4.10–4.11) on the GPU, the twin of
// `effects::depth_of_field::foreground` (the reference), compiled into
// `dof.wgsl` only for a pass that asks for it (`smooth_foreground`):
// without it the stubs in `dof_sharp_foreground.wgsl` take its place and
// no buffer is bound.
//
// One buffer of words: [0] the frame's highest level m as f32 bits
// (atomicMax: m ≥ 0, so the bits order as the values), then ρ of the
// level M = min(⌈max m⌉, top) the CPU builds its pyramid to (sized for
// level 1, the largest it can be), then each pixel's smoothed level
// (−1: none).
@group(0) @binding(8) var<storage, read_write> fg: array<atomic<u32>>;

fn fg_rho_at(i: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&fg[1u + i]));
}

// Where the per-pixel levels start (after ρ at level 1's size).
fn fg_level_base() -> u32 {
    let l1 = p.levels[1];
    return 1u + l1.w * l1.h;
}

// The level M the CPU builds its pyramid to (0: nothing to blur).
fn fg_top() -> u32 {
    let max_m = bitcast<f32>(atomicLoad(&fg[0]));
    return min(u32(ceil(max_m)), u32(p.top));
}

// dof_base: every pixel's level (`level_for_coc`) raises the maximum.
fn note_level(i: u32, hit: bool) {
    let s = p.k_sigma * (coc(i, hit) * 0.5);
    let m = clamp(1.0 + log2(s), 0.0, p.top);
    if (m > 0.0) {
        atomicMax(&fg[0], bitcast<u32>(m));
    }
}

// dof_blend: the pixel's smoothed level, or a negative number.
fn override_level(i: u32) -> f32 {
    return bitcast<f32>(atomicLoad(&fg[fg_level_base() + i]));
}

// Eq. 4.6: 0 below half a pixel of blur, else 1 + log2(k_σ·σ).
fn mip_of_sigma(sigma: f32) -> f32 {
    let s = p.k_sigma * sigma;
    if (s < 0.5) {
        return 0.0;
    }
    return 1.0 + log2(s);
}

// Depth of a depth-mip texel, background (−1) as +∞ (the CPU's mips
// average the background's infinite depth).
fn fg_depth(q: u32) -> f32 {
    let z = zmip[q];
    if (z < 0.0) {
        return bitcast<f32>(0x7f800000u);
    }
    return z;
}

// Eq. 4.10: ρ at level M, the largest σ among the 4×4 taps of level M − 1
// in front of the focus and of the texel.
@compute @workgroup_size(8, 8)
fn dof_fg_rho(@builtin(global_invocation_id) id: vec3<u32>) {
    let top = fg_top();
    if (top < 1u) {
        return;
    }
    let s = p.levels[top - 1u];
    let t = p.levels[top];
    if (id.x >= t.w || id.y >= t.h) {
        return;
    }
    let zp = fg_depth(t.off + id.y * t.w + id.x);
    var best = 0.0;
    for (var ty = 0u; ty < 4u; ty++) {
        let row = s.off + reduce_source(id.y, ty, 4u, s.h) * s.w;
        for (var tx = 0u; tx < 4u; tx++) {
            let q = row + reduce_source(id.x, tx, 4u, s.w);
            let zq = fg_depth(q);
            if (zq < p.fg_focus && zq < zp) {
                best = max(best, smip[q]);
            }
        }
    }
    atomicStore(&fg[1u + id.y * t.w + id.x], bitcast<u32>(best));
}

// A scalar of w × h texels bilinearly at (x, y), clamped to the edge
// (`pyramid::bilinear`); `rho`: ρ, else σ of the level at `off`.
fn fg_bilinear(rho: bool, off: u32, w: u32, h: u32, xin: f32, yin: f32) -> f32 {
    let x = clamp(xin, 0.0, f32(w - 1u));
    let y = clamp(yin, 0.0, f32(h - 1u));
    let x0f = floor(x);
    let y0f = floor(y);
    let fx = x - x0f;
    let fy = y - y0f;
    let x0 = u32(x0f);
    let y0 = u32(y0f);
    let x1 = min(x0 + 1u, w - 1u);
    let y1 = min(y0 + 1u, h - 1u);
    var v: array<f32, 4>;
    let at = array<u32, 4>(y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1);
    for (var k = 0u; k < 4u; k++) {
        if (rho) {
            v[k] = fg_rho_at(at[k]);
        } else {
            v[k] = smip[off + at[k]];
        }
    }
    let top = v[0] + (v[1] - v[0]) * fx;
    let bot = v[2] + (v[3] - v[2]) * fx;
    return top + (bot - top) * fy;
}

// Eq. 4.11 and the smoothed σ(n): each pixel's level where ρ(M) gives one.
@compute @workgroup_size(8, 8)
fn dof_fg_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.width || id.y >= p.height) {
        return;
    }
    let i = id.y * p.width + id.x;
    let out = fg_level_base() + i;
    let top = fg_top();
    if (top < 1u) {
        atomicStore(&fg[out], bitcast<u32>(-1.0));
        return;
    }
    // ρ(M): the 9-point circular filter over ρ at level M.
    let t = p.levels[top];
    let c = level_coords(top, id.x, id.y);
    let dg = p.diag;
    var acc = fg_bilinear(true, 0u, t.w, t.h, c.x, c.y);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x + 1.0, c.y);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x - 1.0, c.y);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x, c.y + 1.0);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x, c.y - 1.0);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x + dg, c.y + dg);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x + dg, c.y - dg);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x - dg, c.y + dg);
    acc += p.g * fg_bilinear(true, 0u, t.w, t.h, c.x - dg, c.y - dg);
    let rho_m = acc * p.norm;
    var n = mip_of_sigma(rho_m);
    if (!(n > 0.0)) {
        atomicStore(&fg[out], bitcast<u32>(-1.0));
        return;
    }
    n = min(n, f32(top));
    // σ(n): linear between levels, bilinear within one; level 0 is the
    // pixel's own σ.
    let l = min(u32(floor(n)), top);
    let f = n - f32(l);
    let ll = p.levels[l];
    let cl = level_coords(l, id.x, id.y);
    var sigma = fg_bilinear(false, ll.off, ll.w, ll.h, cl.x, cl.y);
    if (f > 0.0 && l + 1u <= top) {
        let lh = p.levels[l + 1u];
        let ch = level_coords(l + 1u, id.x, id.y);
        let b = fg_bilinear(false, lh.off, lh.w, lh.h, ch.x, ch.y);
        sigma = sigma + (b - sigma) * f;
    }
    let smoothed = clamp(mip_of_sigma(sigma), 0.0, f32(top));
    atomicStore(&fg[out], bitcast<u32>(smoothed));
}
