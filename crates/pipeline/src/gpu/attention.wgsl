// Lee's attention model (2009 ch. 3), the per-pixel and per-map part, on a
// frame's buffers: the GPU twin of `attention::AttentionTracker`'s passes
// (crates/attention/src/tracker.rs, pyramid.rs, contrast.rs, hls.rs,
// fast_math.rs), in the same order and with the same arithmetic in f32.
// Appended to colour.wgsl, of which only `pixels` (binding 3) is read and
// bound (`lut` and `thresholds` are left out of the layout). The
// per-object results go to `stats` (u32 words, atomics) and are read back;
// the finishing steps run on the CPU (`AttentionTracker::update_measured`).
//
// Entry points, in dispatch order:
//   att_stats      per (map column, frame row): object pixel counts, index
//                  sums, depth sums (fixed point), the fastest visible object
//   att_objects    per object: B_s (eq. 3.2) and B_m (eq. 3.3)
//   att_cells      per map cell: area average of the frame -> level 0 of the
//                  six channel pyramids (L, hue vector x, y, depth, size, motion)
//   att_rows       per level: binomial [1,3,3,1]/8 along x, decimate
//   att_cols       per level: the same along y -> the next level
//   att_contrast   per map cell: eq. 3.4 for each feature, their maxima
//   att_combine    per map cell: eq. 3.5 with w_f of eq. 3.6, its maximum
//   att_normalise  per map cell: S_p = S / max S (or 1 everywhere)
//   att_saliency   per (map column, frame row): sum of S_p per object (fixed
//                  point) and its highest S_p
//   att_peak       the same: the lowest cell holding that highest S_p
//   att_centroid   per object: its pixels in that cell, their index sums

@group(0) @binding(0) var<uniform> params: AttParams;
// Eye distance per pixel as f32 bits (read as bits: WGSL may assume floats
// are finite, and non-finite depths must be recognised).
@group(0) @binding(4) var<storage, read> depth_bits: array<u32>;
// Object id per pixel; 0xffffffff is background.
@group(0) @binding(5) var<storage, read> ids: array<u32>;
// Sorted ids, the optional direct id table, speeds, cell tables.
@group(0) @binding(6) var<storage, read> tables: array<u32>;
// Globals then one record per object (see `obj`).
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>>;
// Pyramids, scratch, contrast maps, S_p, per-object B_s and B_m.
@group(0) @binding(8) var<storage, read_write> maps: array<f32>;

struct AttParams {
    width: u32,
    height: u32,
    map: u32,
    n_objects: u32,
    // Bits 0-4: luminance, hue, depth, size, motion.
    flags: u32,
    // 1: `tables[t_direct + id]` is the dense index of id < direct_len.
    direct: u32,
    direct_len: u32,
    // The pyramid level a rows/cols dispatch reads.
    level: u32,
    near_mm: f32,
    inv_range: f32,
    total_px: f32,
    // Eye distances above this count as this (2^29 mm; see `depth_fixed`).
    depth_cap_mm: f32,
    t_sorted: u32,
    t_direct: u32,
    t_speed: u32,
    t_fx0: u32,
    t_fx1: u32,
    t_fy0: u32,
    t_fy1: u32,
    t_ox0: u32,
    t_ox1: u32,
    t_oy0: u32,
    t_oy1: u32,
    t_celly: u32,
    t_taps: u32,
    m_plane: u32,
    m_scratch: u32,
    m_scratch_plane: u32,
    m_contrast: u32,
    m_sal: u32,
    m_objfeat: u32,
    // Steps of the fixed-point S_p sums per unit (2^23).
    sal_scale: f32,
    levels: array<LevelDesc, 7>,
}

const BG: u32 = 0xffffffffu;
const NONE: u32 = 0xffffffffu;
const PI: f32 = 3.14159265358979;
const FRAC_PI_2: f32 = 1.57079632679490;

// Globals in `stats`.
const G_BACKGROUND: u32 = 0u;
const G_UNLISTED: u32 = 1u;
const G_MAX_SPEED: u32 = 2u;
// Five contrast maxima (f32 bits), Feature order.
const G_CMAX: u32 = 3u;
// The maximum of S before normalisation (f32 bits).
const G_SMAX: u32 = 8u;
const GLOBALS: u32 = 16u;
// One object's record.
const REC: u32 = 16u;
const O_COUNT: u32 = 0u;
const O_DEPTH_COUNT: u32 = 1u;
const O_SUM_X: u32 = 2u; // 64-bit: lo, hi
const O_SUM_Y: u32 = 4u; // 64-bit
const O_DEPTH: u32 = 6u; // 64-bit, 1/256 mm
const O_SAL: u32 = 8u; // 64-bit, 2^-23
const O_BEST: u32 = 10u; // f32 bits of the highest S_p
const O_NOT_CELL: u32 = 11u; // !cell of the peak (atomicMax = lowest cell)
const O_PEAK_COUNT: u32 = 12u;
const O_PEAK_X: u32 = 13u;
const O_PEAK_Y: u32 = 14u;

// S_p is summed in fixed point, `params.sal_scale` (2^23) steps per unit.
// Every per-row pass adds runs inside one map column: at most
// ceil(MAX_FRAME_SIDE / MIN_MAP_SIZE) = 256 pixels (`MAX_RUN_PX`, checked at
// compile time in attention.rs), so one run's S_p sum is at most 2^31, its
// column index sum below 2^22.

fn obj(d: u32, field: u32) -> u32 {
    return GLOBALS + d * REC + field;
}

fn feature_on(f: u32) -> bool {
    return ((params.flags >> f) & 1u) == 1u;
}

// A 64-bit add into two words (lo, hi) with the carry.
fn add64(i: u32, lo: u32, hi: u32) {
    if (lo != 0u) {
        let old = atomicAdd(&stats[i], lo);
        if (old + lo < old) {
            atomicAdd(&stats[i + 1u], 1u);
        }
    }
    if (hi != 0u) {
        atomicAdd(&stats[i + 1u], hi);
    }
}

fn add_local(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

fn is_finite_bits(bits: u32) -> bool {
    return (bits & 0x7f800000u) != 0x7f800000u;
}

// The pixel's id: background where the cast hit nothing (bit 24 of the
// colour word).
fn pixel_id(i: u32) -> u32 {
    if (((pixels[i] >> 24u) & 1u) == 0u) {
        return BG;
    }
    return ids[i];
}

// Dense index (rank in id order) of a listed id, NONE otherwise.
fn dense_of(id: u32) -> u32 {
    if (id == BG) {
        return NONE;
    }
    if (params.direct == 1u) {
        if (id < params.direct_len) {
            return tables[params.t_direct + id];
        }
        return NONE;
    }
    var lo = 0u;
    var hi = params.n_objects;
    loop {
        if (lo >= hi) {
            break;
        }
        let mid = (lo + hi) / 2u;
        if (tables[params.t_sorted + mid] < id) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    if (lo < params.n_objects && tables[params.t_sorted + lo] == id) {
        return lo;
    }
    return NONE;
}

// A finite eye distance (negative as 0) in 1/256 mm, rounded, as (lo, hi);
// distances above `params.depth_cap_mm` (2^29 mm) count as 2^29 mm, so a
// value is at most 2^37 (an exact f32) and 2^26 pixels sum to at most 2^63:
// the 64-bit sum cannot wrap (checked at compile time in attention.rs).
fn depth_fixed(bits: u32) -> vec2<u32> {
    let z = min(max(bitcast<f32>(bits), 0.0), params.depth_cap_mm);
    let v = floor(z * 256.0 + 0.5);
    let hi = floor(v * 2.3283064365386963e-10);
    let lo = v - hi * 4294967296.0;
    return vec2<u32>(u32(lo), u32(hi));
}

fn flush_stats(d: u32, y: u32, count: u32, sum_x: u32, depth_count: u32, depth: vec2<u32>) {
    if (d == NONE || count == 0u) {
        return;
    }
    atomicAdd(&stats[obj(d, O_COUNT)], count);
    atomicAdd(&stats[obj(d, O_DEPTH_COUNT)], depth_count);
    add64(obj(d, O_SUM_X), sum_x, 0u);
    add64(obj(d, O_SUM_Y), y * count, 0u);
    add64(obj(d, O_DEPTH), depth.x, depth.y);
    // Speeds are finite and >= 0: their bits order as the values.
    atomicMax(&stats[G_MAX_SPEED], tables[params.t_speed + d]);
}

// Pass A (tracker.rs `object_statistics`): the pixels of map column `cx`
// in frame row `y`, by runs of one id.
@compute @workgroup_size(8, 8)
fn att_stats(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let y = gid.y;
    if (cx >= params.map || y >= params.height) {
        return;
    }
    let x0 = tables[params.t_ox0 + cx];
    let x1 = tables[params.t_ox1 + cx];
    let row = y * params.width;
    var run_id = BG;
    var d = NONE;
    var count = 0u;
    var sum_x = 0u;
    var depth_count = 0u;
    var depth = vec2<u32>(0u, 0u);
    var background = 0u;
    var unlisted = 0u;
    for (var x = x0; x < x1; x++) {
        let i = row + x;
        let id = pixel_id(i);
        if (id != run_id) {
            flush_stats(d, y, count, sum_x, depth_count, depth);
            run_id = id;
            d = dense_of(id);
            count = 0u;
            sum_x = 0u;
            depth_count = 0u;
            depth = vec2<u32>(0u, 0u);
        }
        if (id == BG) {
            background++;
        } else if (d == NONE) {
            unlisted++;
        } else {
            count++;
            sum_x += x;
            let bits = depth_bits[i];
            if (is_finite_bits(bits)) {
                depth_count++;
                depth = add_local(depth, depth_fixed(bits));
            }
        }
    }
    flush_stats(d, y, count, sum_x, depth_count, depth);
    if (background > 0u) {
        atomicAdd(&stats[G_BACKGROUND], background);
    }
    if (unlisted > 0u) {
        atomicAdd(&stats[G_UNLISTED], unlisted);
    }
}

// B_s (eq. 3.2) and B_m (eq. 3.3, over the fastest visible object).
@compute @workgroup_size(64)
fn att_objects(@builtin(global_invocation_id) gid: vec3<u32>) {
    let d = gid.x;
    if (d >= params.n_objects) {
        return;
    }
    let count = atomicLoad(&stats[obj(d, O_COUNT)]);
    let max_speed = bitcast<f32>(atomicLoad(&stats[G_MAX_SPEED]));
    let speed = bitcast<f32>(tables[params.t_speed + d]);
    var motion = 0.0;
    if (count > 0u && max_speed > 0.0) {
        motion = min(speed / max_speed, 1.0);
    }
    maps[params.m_objfeat + 2u * d] = f32(count) / params.total_px;
    maps[params.m_objfeat + 2u * d + 1u] = motion;
}

// sin and cos of x in [0, 2pi] to about 1e-7: WGSL's own are allowed an
// absolute error of 2^-11, which would show in the hue vector.
fn sin_cos(x: f32) -> vec2<f32> {
    let q = round(x * 0.636619772);
    let r = (x - q * 1.5707963705062866) + q * 4.371139000186241e-08;
    let r2 = r * r;
    let s = r * (1.0 + r2 * (-0.16666666666 + r2 * (0.0083333333333 + r2 * (-0.000198412698 + r2 * 2.75573192e-06))));
    let c = 1.0 + r2 * (-0.5 + r2 * (0.041666666666 + r2 * (-0.00138888888 + r2 * (2.48015873e-05 + r2 * -2.75573192e-07))));
    let k = u32(q) & 3u;
    if (k == 0u) {
        return vec2<f32>(s, c);
    } else if (k == 1u) {
        return vec2<f32>(c, -s);
    } else if (k == 2u) {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}

// hls.rs `lightness_and_hue_vector`: HLS lightness and the
// chroma-weighted hexcone hue vector of an RGB colour in [0, 1].
fn lightness_hue(rgb: vec3<f32>) -> vec3<f32> {
    let r = clamp(rgb.x, 0.0, 1.0);
    let g = clamp(rgb.y, 0.0, 1.0);
    let b = clamp(rgb.z, 0.0, 1.0);
    let mx = max(max(r, g), b);
    let mn = min(min(r, g), b);
    let chroma = mx - mn;
    var h = 0.0;
    if (chroma > 0.0) {
        if (mx == r) {
            h = (g - b) / chroma;
        } else if (mx == g) {
            h = (b - r) / chroma + 2.0;
        } else {
            h = (r - g) / chroma + 4.0;
        }
        if (h < 0.0) {
            h = h + 6.0;
        }
        if (h >= 6.0) {
            h = 0.0;
        }
    }
    let sc = sin_cos(h * 60.0 * 0.017453292);
    return vec3<f32>(0.5 * (mx + mn), chroma * sc.y, chroma * sc.x);
}

fn plane_at(ch: u32, level: u32, x: u32, y: u32) -> u32 {
    let l = params.levels[level];
    return ch * params.m_plane + l.off + y * l.w + x;
}

// Step 1 (tracker.rs `area_average_cells`): each map cell's footprint
// averaged, converted to the six channels at level 0.
@compute @workgroup_size(8, 8)
fn att_cells(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let cy = gid.y;
    let m = params.map;
    if (cx >= m || cy >= m) {
        return;
    }
    let x0 = tables[params.t_fx0 + cx];
    let x1 = tables[params.t_fx1 + cx];
    let y0 = tables[params.t_fy0 + cy];
    let y1 = tables[params.t_fy1 + cy];
    let colour = feature_on(0u) || feature_on(1u);
    let depth = feature_on(2u);
    let object = feature_on(3u) || feature_on(4u);
    var red = 0u;
    var green = 0u;
    var blue = 0u;
    var depth_sum = 0.0;
    var size_sum = 0.0;
    var motion_sum = 0.0;
    var run_id = BG;
    var d = NONE;
    for (var y = y0; y < y1; y++) {
        var depth_row = 0.0;
        var size_row = 0.0;
        var motion_row = 0.0;
        for (var x = x0; x < x1; x++) {
            let i = y * params.width + x;
            let word = pixels[i];
            let hit = ((word >> 24u) & 1u) == 1u;
            if (colour) {
                red += word & 255u;
                green += (word >> 8u) & 255u;
                blue += (word >> 16u) & 255u;
            }
            if (depth) {
                // Eq. 3.1; background (non-finite) is the far plane.
                let bits = depth_bits[i];
                if (hit && is_finite_bits(bits)) {
                    depth_row += clamp((bitcast<f32>(bits) - params.near_mm) * params.inv_range, 0.0, 1.0);
                } else {
                    depth_row += 1.0;
                }
            }
            if (object) {
                let id = pixel_id(i);
                if (id != run_id) {
                    run_id = id;
                    d = dense_of(id);
                }
                if (d != NONE) {
                    size_row += maps[params.m_objfeat + 2u * d];
                    motion_row += maps[params.m_objfeat + 2u * d + 1u];
                }
            }
        }
        depth_sum += depth_row;
        size_sum += size_row;
        motion_sum += motion_row;
    }
    let inv = 1.0 / f32((x1 - x0) * (y1 - y0));
    var lh = vec3<f32>(0.0, 0.0, 0.0);
    if (colour) {
        let k = inv / 255.0;
        lh = lightness_hue(vec3<f32>(f32(red) * k, f32(green) * k, f32(blue) * k));
    }
    var values = array<f32, 6>(
        select(0.0, lh.x, feature_on(0u)),
        select(0.0, lh.y, feature_on(1u)),
        select(0.0, lh.z, feature_on(1u)),
        select(0.0, depth_sum * inv, depth),
        select(0.0, size_sum * inv, feature_on(3u)),
        select(0.0, clamp(motion_sum * inv, 0.0, 1.0), feature_on(4u)),
    );
    for (var ch = 0u; ch < 6u; ch++) {
        maps[plane_at(ch, 0u, cx, cy)] = values[ch];
    }
}

// The feature of a channel: 0 L, 1-2 hue, 3 depth, 4 size, 5 motion.
fn channel_feature(ch: u32) -> u32 {
    if (ch <= 1u) {
        return ch;
    }
    return ch - 1u;
}

// pyramid.rs `downsample`, horizontal half: level `params.level` (w x h)
// into the scratch (ceil(w/2) x h).
@compute @workgroup_size(8, 8)
fn att_rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    let src = params.levels[params.level];
    let w2 = params.levels[params.level + 1u].w;
    let x2 = gid.x;
    let y = gid.y;
    let ch = gid.z;
    if (x2 >= w2 || y >= src.h || ch >= 6u || !feature_on(channel_feature(ch))) {
        return;
    }
    let row = ch * params.m_plane + src.off + y * src.w;
    let c = i32(2u * x2);
    let last = i32(src.w) - 1;
    let a = maps[row + u32(clamp(c - 1, 0, last))];
    let b = maps[row + u32(clamp(c, 0, last))];
    let e = maps[row + u32(clamp(c + 1, 0, last))];
    let f = maps[row + u32(clamp(c + 2, 0, last))];
    maps[params.m_scratch + ch * params.m_scratch_plane + y * w2 + x2] =
        0.125 * a + 0.375 * b + 0.375 * e + 0.125 * f;
}

// pyramid.rs `downsample`, vertical half: the scratch into level + 1.
@compute @workgroup_size(8, 8)
fn att_cols(@builtin(global_invocation_id) gid: vec3<u32>) {
    let src = params.levels[params.level];
    let dst = params.levels[params.level + 1u];
    let x2 = gid.x;
    let y2 = gid.y;
    let ch = gid.z;
    if (x2 >= dst.w || y2 >= dst.h || ch >= 6u || !feature_on(channel_feature(ch))) {
        return;
    }
    let base = params.m_scratch + ch * params.m_scratch_plane + x2;
    let c = i32(2u * y2);
    let last = i32(src.h) - 1;
    let a = maps[base + u32(clamp(c - 1, 0, last)) * dst.w];
    let b = maps[base + u32(clamp(c, 0, last)) * dst.w];
    let e = maps[base + u32(clamp(c + 1, 0, last)) * dst.w];
    let f = maps[base + u32(clamp(c + 2, 0, last)) * dst.w];
    maps[ch * params.m_plane + dst.off + y2 * dst.w + x2] =
        0.125 * a + 0.375 * b + 0.375 * e + 0.125 * f;
}

// pyramid.rs `AxisTaps` of level l (1-6) at level-0 index i, made by the
// CPU's own code and uploaded (the map is square: one table for both
// axes): the lower texel, the upper texel and the upper one's weight.
fn taps(l: u32, i: u32) -> vec3<f32> {
    let t = params.t_taps + 3u * ((l - 1u) * params.map + i);
    return vec3<f32>(f32(tables[t]), f32(tables[t + 1u]), bitcast<f32>(tables[t + 2u]));
}

// Level `l` of channel `ch` at level-0 cell (x, y), magnified bilinearly
// as contrast.rs does: along x on both rows, then along y.
fn sample(ch: u32, l: u32, x: u32, y: u32) -> f32 {
    if (l == 0u) {
        return maps[plane_at(ch, 0u, x, y)];
    }
    let lv = params.levels[l];
    let tx = taps(l, x);
    let ty = taps(l, y);
    let base = ch * params.m_plane + lv.off;
    let r0 = base + u32(ty.x) * lv.w;
    let r1 = base + u32(ty.y) * lv.w;
    let a0 = maps[r0 + u32(tx.x)];
    let b0 = maps[r0 + u32(tx.y)];
    let a1 = maps[r1 + u32(tx.x)];
    let b1 = maps[r1 + u32(tx.y)];
    let top = a0 + tx.z * (b0 - a0);
    let bottom = a1 + tx.z * (b1 - a1);
    return top + ty.z * (bottom - top);
}

// fast_math.rs `angle_from_cross_dot`.
fn angle_from_cross_dot(cross_abs: f32, dot_ab: f32) -> f32 {
    let ax = abs(dot_ab);
    let ay = cross_abs;
    let mx = max(ax, ay);
    let mn = min(ax, ay);
    var a = 0.0;
    if (mx > 0.0) {
        a = mn / mx;
    }
    let s = a * a;
    var r = a * (0.99997726 + s * (-0.33262347 + s * (0.19354346 + s * (-0.11643287 + s * (0.05265332 + s * -0.0117212)))));
    if (ay > ax) {
        r = FRAC_PI_2 - r;
    }
    if (dot_ab < 0.0) {
        r = PI - r;
    }
    return r;
}

// hls.rs `hue_vector_contrast_with_lengths`.
fn hue_contrast(a: vec2<f32>, la: f32, b: vec2<f32>, lb: f32) -> f32 {
    let weight = min(la, lb);
    let cross_abs = abs(a.x * b.y - a.y * b.x);
    let dot_ab = a.x * b.x + a.y * b.y;
    let value = weight * angle_from_cross_dot(cross_abs, dot_ab) * 0.31830987;
    if (weight > 1e-12 && value < 1.0) {
        return max(value, 0.0);
    } else if (weight > 1e-12) {
        return 1.0;
    }
    return 0.0;
}

var<workgroup> wg_max: array<atomic<u32>, 6>;

// Eq. 3.4 (contrast.rs `CentreSurround`): pairs (0,3) (0,4) (1,4) (1,5)
// (2,5) (2,6), every level sampled at the level-0 cell; and each map's
// maximum (eq. 3.6), reduced in the workgroup first.
@compute @workgroup_size(8, 8)
fn att_contrast(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    if (li < 6u) {
        atomicStore(&wg_max[li], 0u);
    }
    workgroupBarrier();
    let m = params.map;
    let x = gid.x;
    let y = gid.y;
    if (x < m && y < m) {
        let cell = y * m + x;
        // Scalar features: channel per feature.
        var scalar_ch = array<u32, 5>(0u, 0u, 3u, 4u, 5u);
        for (var f = 0u; f < 5u; f++) {
            var c = 0.0;
            if (feature_on(f) && f != 1u) {
                let ch = scalar_ch[f];
                var v: array<f32, 7>;
                for (var l = 0u; l < 7u; l++) {
                    v[l] = sample(ch, l, x, y);
                }
                let sum = abs(v[0] - v[3]) + abs(v[0] - v[4]) + abs(v[1] - v[4]) + abs(v[1] - v[5])
                    + abs(v[2] - v[5]) + abs(v[2] - v[6]);
                c = sum * (1.0 / 6.0);
            } else if (feature_on(f)) {
                var hv: array<vec2<f32>, 7>;
                var hl: array<f32, 7>;
                for (var l = 0u; l < 7u; l++) {
                    hv[l] = vec2<f32>(sample(1u, l, x, y), sample(2u, l, x, y));
                    hl[l] = sqrt(hv[l].x * hv[l].x + hv[l].y * hv[l].y);
                }
                var o = 0.0;
                o += hue_contrast(hv[0], hl[0], hv[3], hl[3]);
                o += hue_contrast(hv[0], hl[0], hv[4], hl[4]);
                o += hue_contrast(hv[1], hl[1], hv[4], hl[4]);
                o += hue_contrast(hv[1], hl[1], hv[5], hl[5]);
                o += hue_contrast(hv[2], hl[2], hv[5], hl[5]);
                o += hue_contrast(hv[2], hl[2], hv[6], hl[6]);
                c = o * (1.0 / 6.0);
            }
            maps[params.m_contrast + f * m * m + cell] = c;
            // Non-negative floats order as their bits; NaN is skipped as
            // contrast.rs's fold skips it.
            if (c > 0.0) {
                atomicMax(&wg_max[f], bitcast<u32>(c));
            }
        }
    }
    workgroupBarrier();
    if (li < 5u) {
        let v = atomicLoad(&wg_max[li]);
        if (v > 0u) {
            atomicMax(&stats[G_CMAX + li], v);
        }
    }
}

// contrast.rs `contrast_weight`: 1 / max, or 0 at or below MIN_CONTRAST.
fn weight(f: u32) -> f32 {
    let mx = bitcast<f32>(atomicLoad(&stats[G_CMAX + f]));
    if (mx > 1e-5 && is_finite_bits(bitcast<u32>(mx))) {
        return 1.0 / mx;
    }
    return 0.0;
}

// Eq. 3.5: S = sum of w_f C_f over the features with weight > 0; and the
// maximum of S.
@compute @workgroup_size(8, 8)
fn att_combine(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    if (li == 0u) {
        atomicStore(&wg_max[0], 0u);
    }
    workgroupBarrier();
    let m = params.map;
    let x = gid.x;
    let y = gid.y;
    if (x < m && y < m) {
        let cell = y * m + x;
        var s = 0.0;
        for (var f = 0u; f < 5u; f++) {
            let w = weight(f);
            if (w > 0.0) {
                s += w * maps[params.m_contrast + f * m * m + cell];
            }
        }
        maps[params.m_sal + cell] = s;
        if (s > 0.0) {
            atomicMax(&wg_max[0], bitcast<u32>(s));
        }
    }
    workgroupBarrier();
    if (li == 0u) {
        let v = atomicLoad(&wg_max[0]);
        if (v > 0u) {
            atomicMax(&stats[G_SMAX], v);
        }
    }
}

// contrast.rs `combine`'s normalisation: S_p = clamp(S / max S, 0, 1), or 1
// everywhere when no feature has contrast.
@compute @workgroup_size(8, 8)
fn att_normalise(@builtin(global_invocation_id) gid: vec3<u32>) {
    let m = params.map;
    let x = gid.x;
    let y = gid.y;
    if (x >= m || y >= m) {
        return;
    }
    var any_weight = false;
    for (var f = 0u; f < 5u; f++) {
        any_weight = any_weight || weight(f) > 0.0;
    }
    let bits = atomicLoad(&stats[G_SMAX]);
    let mx = bitcast<f32>(bits);
    let cell = y * m + x;
    if (!any_weight || !(mx > 0.0) || !is_finite_bits(bits)) {
        maps[params.m_sal + cell] = 1.0;
    } else {
        let inv = 1.0 / mx;
        maps[params.m_sal + cell] = clamp(maps[params.m_sal + cell] * inv, 0.0, 1.0);
    }
}

// S_p as read for the object reductions: -0 (or anything not > 0) as 0, so
// that its bits order as its value.
fn cell_saliency(cell: u32) -> f32 {
    let v = maps[params.m_sal + cell];
    return select(0.0, min(v, 1.0), v > 0.0);
}

fn flush_saliency(d: u32, count: u32, value: f32) {
    if (d == NONE || count == 0u) {
        return;
    }
    let q = u32(round(value * params.sal_scale));
    add64(obj(d, O_SAL), q * count, 0u);
    atomicMax(&stats[obj(d, O_BEST)], bitcast<u32>(value));
}

// Pass C (tracker.rs `object_saliency`): every pixel of a listed object
// adds its cell's S_p; each object's highest S_p.
@compute @workgroup_size(8, 8)
fn att_saliency(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let y = gid.y;
    if (cx >= params.map || y >= params.height) {
        return;
    }
    let x0 = tables[params.t_ox0 + cx];
    let x1 = tables[params.t_ox1 + cx];
    let cell = tables[params.t_celly + y] * params.map + cx;
    let value = cell_saliency(cell);
    let row = y * params.width;
    var run_id = BG;
    var d = NONE;
    var count = 0u;
    for (var x = x0; x < x1; x++) {
        let id = pixel_id(row + x);
        if (id != run_id) {
            flush_saliency(d, count, value);
            run_id = id;
            d = dense_of(id);
            count = 0u;
        }
        count++;
    }
    flush_saliency(d, count, value);
}

// The lowest cell whose S_p is the object's highest (ties: lowest cell).
@compute @workgroup_size(8, 8)
fn att_peak(@builtin(global_invocation_id) gid: vec3<u32>) {
    let cx = gid.x;
    let y = gid.y;
    if (cx >= params.map || y >= params.height) {
        return;
    }
    let x0 = tables[params.t_ox0 + cx];
    let x1 = tables[params.t_ox1 + cx];
    let cell = tables[params.t_celly + y] * params.map + cx;
    let bits = bitcast<u32>(cell_saliency(cell));
    let row = y * params.width;
    var run_id = BG;
    for (var x = x0; x < x1; x++) {
        let id = pixel_id(row + x);
        if (id != run_id) {
            run_id = id;
            let d = dense_of(id);
            if (d != NONE && atomicLoad(&stats[obj(d, O_BEST)]) == bits) {
                atomicMax(&stats[obj(d, O_NOT_CELL)], ~cell);
            }
        }
    }
}

// The object's pixels inside its peak cell: count and index sums (one
// thread per object; a cell holds at most 256 x 256 frame pixels, whose
// index sums stay below 2^30).
@compute @workgroup_size(64)
fn att_centroid(@builtin(global_invocation_id) gid: vec3<u32>) {
    let d = gid.x;
    if (d >= params.n_objects) {
        return;
    }
    let not_cell = atomicLoad(&stats[obj(d, O_NOT_CELL)]);
    if (not_cell == 0u || atomicLoad(&stats[obj(d, O_COUNT)]) == 0u) {
        return;
    }
    let cell = ~not_cell;
    let m = params.map;
    let cx = cell % m;
    let cy = cell / m;
    let id = tables[params.t_sorted + d];
    let x0 = tables[params.t_ox0 + cx];
    let x1 = tables[params.t_ox1 + cx];
    let y0 = tables[params.t_oy0 + cy];
    let y1 = tables[params.t_oy1 + cy];
    var count = 0u;
    var sum_x = 0u;
    var sum_y = 0u;
    for (var y = y0; y < y1; y++) {
        for (var x = x0; x < x1; x++) {
            if (pixel_id(y * params.width + x) == id) {
                count++;
                sum_x += x;
                sum_y += y;
            }
        }
    }
    atomicStore(&stats[obj(d, O_PEAK_COUNT)], count);
    atomicStore(&stats[obj(d, O_PEAK_X)], sum_x);
    atomicStore(&stats[obj(d, O_PEAK_Y)], sum_y);
}
