// The image pyramid's WGSL, the GPU side of `crate::pyramid`, shared by
// the two shaders that build and read one (`dof.wgsl`,
// `image_foveation.wgsl`; each is compiled as colour.wgsl + this file +
// itself): the pyramid buffer, REDUCE's footprint and the bilinear lookup
// of a level, each in the CPU's arithmetic. The filters (depth of field's
// anisotropic 4×4 Gaussian, foveation's separable binomial) and the blends
// stay in each shader, as on the CPU.

// The pyramid (linear RGB in xyz), every level at its `LevelDesc`'s
// offset: binding 5 of the shaders that include this file.
@group(0) @binding(5) var<storage, read_write> px: array<vec4<f32>>;

// The source texel of tap `t` of an `n_taps`-tap REDUCE kernel for
// destination texel `x`, in a source of `n` texels (`Kernel::source`):
// `(2x + t).saturating_sub((n_taps − 1) / 2).min(n − 1)`.
fn reduce_source(x: u32, t: u32, n_taps: u32, n: u32) -> u32 {
    let c = (n_taps - 1u) / 2u;
    return min(max(2u * x + t, c) - c, n - 1u);
}

// Level `l` bilinearly at texel position (x, y), texel centres at
// integers, clamped to the edge (`pyramid::bilinear`).
fn level_bilinear(l: LevelDesc, xin: f32, yin: f32) -> vec3<f32> {
    let x = clamp(xin, 0.0, f32(l.w - 1u));
    let y = clamp(yin, 0.0, f32(l.h - 1u));
    let x0f = floor(x);
    let y0f = floor(y);
    let fx = x - x0f;
    let fy = y - y0f;
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

// The centre of level-0 pixel (x, y) in level-`k` texel coordinates
// (`pyramid::level_coords`).
fn level_coords(k: u32, x: u32, y: u32) -> vec2<f32> {
    let scale = f32(1u << k);
    return vec2<f32>((f32(x) + 0.5) / scale - 0.5, (f32(y) + 0.5) / scale - 0.5);
}

// Level `l` (level `k`) at the centre of level-0 pixel (x, y)
// (`Level::at_pixel`).
fn level_at_pixel(l: LevelDesc, k: u32, x: u32, y: u32) -> vec3<f32> {
    let c = level_coords(k, x, y);
    return level_bilinear(l, c.x, c.y);
}
