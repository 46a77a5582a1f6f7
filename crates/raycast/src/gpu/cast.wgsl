// gazecast GPU core: one primary ray per pixel through the flattened binary
// BVH, the watertight ray/triangle test (Woop, Benthin & Wald 2013) and
// Blinn-Phong shading, written as 8-bit RGB with a hit flag and the layer,
// plus the G-buffer: eye distance (mm), object id and shading normal. The same
// arithmetic as the CPU reference (crates/raycast/src/{ray,bvh,shade}.rs),
// in f32, without the CPU's f64 re-test of exactly-zero edge functions.

struct Params {
    width: u32,
    height: u32,
    n_lights: u32,
    n_triangles: u32,
    eye: vec4<f32>,          // xyz; w: the camera's step (display px per px)
    pitch: vec4<f32>,        // x, y: the display's pitch; z, w: the shift (Camera::grid)
    background: vec4<f32>,   // linear rgb
    background_rgb8: vec4<u32>,
};

struct Node {
    min_x: f32, min_y: f32, min_z: f32,
    left_or_first: u32,
    max_x: f32, max_y: f32, max_z: f32,
    count: u32,
};

struct Triangle {
    p0: vec4<f32>,  // w: object id (bitcast)
    p1: vec4<f32>,
    p2: vec4<f32>,
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
};

struct Material {
    diffuse: vec4<f32>,   // w: shininess
    specular: vec4<f32>,
};

struct Light {
    kind: vec4<u32>,      // x: 0 headlight, 1 point, 2 directional
    data: vec4<f32>,      // xyz: position or direction, w: intensity
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> object_materials: array<Material>;  // by object id
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(5) var<storage, read> gamma: array<u32>;
// Per pixel: colour, hit flag and layer (`pack`).
@group(0) @binding(6) var<storage, read_write> pixels: array<u32>;
// Per pixel: eye distance in mm (f32 max for the background; the CPU reads
// misses as infinity from the hit flag).
@group(0) @binding(7) var<storage, read_write> depth: array<f32>;
// Per pixel: object id, 0xffffffff (`NO_OBJECT`) for the background.
@group(0) @binding(8) var<storage, read_write> object_ids: array<u32>;
// Per pixel: shading normal x, y, z (zero for the background).
@group(0) @binding(9) var<storage, read_write> normals: array<f32>;

const EPS: f32 = 1.1920929e-7;
const INF: f32 = 3.4028235e38;
const AMBIENT: f32 = 0.08;
const GAMMA_STEPS: f32 = 4096.0;

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
    inv_dir: vec3<f32>,
    parallel: bool,
};

fn box_hit(n: Node, r: Ray, t_max: f32) -> f32 {
    let lo = vec3<f32>(n.min_x, n.min_y, n.min_z);
    let hi = vec3<f32>(n.max_x, n.max_y, n.max_z);
    if (!r.parallel) {
        let t1 = (lo - r.origin) * r.inv_dir;
        let t2 = (hi - r.origin) * r.inv_dir;
        let mn = min(t1, t2);
        let mx = max(t1, t2);
        let near = max(max(max(mn.x, mn.y), mn.z), 0.0);
        let far = min(min(min(mx.x, mx.y), mx.z) * (1.0 + 2.0 * EPS), t_max);
        if (near <= far) { return near; }
        return -1.0;
    }
    var t0 = 0.0;
    var t1 = t_max;
    for (var a = 0; a < 3; a++) {
        let o = r.origin[a];
        let d = r.dir[a];
        if (d == 0.0) {
            if (o < lo[a] || o > hi[a]) { return -1.0; }
            continue;
        }
        var near = (lo[a] - o) * r.inv_dir[a];
        var far = (hi[a] - o) * r.inv_dir[a];
        if (near > far) { let s = near; near = far; far = s; }
        t0 = max(t0, near);
        t1 = min(t1, far * (1.0 + 2.0 * EPS));
        if (t0 > t1) { return -1.0; }
    }
    return t0;
}

struct Watertight {
    kx: i32, ky: i32, kz: i32,
    s: vec3<f32>,
};

fn watertight_setup(r: Ray) -> Watertight {
    let a = abs(r.dir);
    var kz = 2;
    if (a.x > a.y) {
        if (a.x > a.z) { kz = 0; }
    } else if (a.y > a.z) {
        kz = 1;
    }
    var kx = (kz + 1) % 3;
    var ky = (kx + 1) % 3;
    if (r.dir[kz] < 0.0) { let s = kx; kx = ky; ky = s; }
    let dz = r.dir[kz];
    return Watertight(kx, ky, kz, vec3<f32>(r.dir[kx] / dz, r.dir[ky] / dz, 1.0 / dz));
}

// Returns (t, u, v) with t < 0 for a miss.
fn watertight(w: Watertight, origin: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, t_max: f32) -> vec3<f32> {
    let a = p0 - origin;
    let b = p1 - origin;
    let c = p2 - origin;
    let ax = a[w.kx] - w.s.x * a[w.kz];
    let ay = a[w.ky] - w.s.y * a[w.kz];
    let bx = b[w.kx] - w.s.x * b[w.kz];
    let by = b[w.ky] - w.s.y * b[w.kz];
    let cx = c[w.kx] - w.s.x * c[w.kz];
    let cy = c[w.ky] - w.s.y * c[w.kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let ww = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || ww < 0.0) && (u > 0.0 || v > 0.0 || ww > 0.0)) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let det = u + v + ww;
    if (det == 0.0) { return vec3<f32>(-1.0, 0.0, 0.0); }
    let az = w.s.z * a[w.kz];
    let bz = w.s.z * b[w.kz];
    let cz = w.s.z * c[w.kz];
    let t_scaled = u * az + v * bz + ww * cz;
    var lo = 0.0;
    var hi = t_max * det;
    if (det < 0.0) { lo = t_max * det; hi = 0.0; }
    if (!(t_scaled > lo && t_scaled < hi)) { return vec3<f32>(-1.0, 0.0, 0.0); }
    let inv = 1.0 / det;
    return vec3<f32>(t_scaled * inv, v * inv, ww * inv);
}

struct Hit {
    t: f32,
    tri: u32,
    u: f32,
    v: f32,
};

// A walk of the BVH for one ray, front to back, as the CPU's
// `Bvh::traverse`: at an inner node the nearer child first, the farther
// one on the stack with its entry distance; a pop skips nodes that start
// beyond the closest hit. Both traversals use it, the cast's closest hit
// (`intersect`) and the hidden image's K nearest (hidden.wgsl): each asks
// `bvh_next_leaf` for the next leaf with its current `t_max`, tests the
// leaf's triangles (`first`, `count`) and lowers its `t_max`, as the
// CPU's `visit` closure does.
struct BvhWalk {
    stack_node: array<u32, 64>,
    stack_t: array<f32, 64>,
    sp: i32,
    node: u32,
    // Pop before looking at `node` again: after a leaf, after an inner
    // node whose children are both missed, or for a ray that misses the
    // root (an empty stack: no leaf at all).
    pop: bool,
    // The leaf `bvh_next_leaf` stopped at: its triangles.
    first: u32,
    count: u32,
};

fn bvh_walk(r: Ray) -> BvhWalk {
    var walk: BvhWalk;
    walk.sp = 0;
    walk.node = 0u;
    walk.pop = params.n_triangles == 0u || box_hit(nodes[0], r, INF) < 0.0;
    return walk;
}

// Advances `walk` to the next leaf whose box the ray enters within
// `t_max`: true with the leaf in `first`, `count`; false when the walk is
// done.
fn bvh_next_leaf(walk: ptr<function, BvhWalk>, r: Ray, t_max: f32) -> bool {
    loop {
        if ((*walk).pop) {
            // Pop, skipping nodes that start beyond the closest hit.
            var found = false;
            loop {
                if ((*walk).sp == 0) { break; }
                (*walk).sp = (*walk).sp - 1;
                if ((*walk).stack_t[(*walk).sp] <= t_max) {
                    (*walk).node = (*walk).stack_node[(*walk).sp];
                    found = true;
                    break;
                }
            }
            if (!found) { return false; }
            (*walk).pop = false;
        }
        let n = nodes[(*walk).node];
        if (n.count > 0u) {
            (*walk).first = n.left_or_first;
            (*walk).count = n.count;
            (*walk).pop = true;
            return true;
        }
        let a = n.left_or_first;
        let b = a + 1u;
        let ta = box_hit(nodes[a], r, t_max);
        let tb = box_hit(nodes[b], r, t_max);
        if (ta >= 0.0 && tb >= 0.0) {
            let sp = (*walk).sp;
            if (ta <= tb) {
                (*walk).stack_node[sp] = b; (*walk).stack_t[sp] = tb; (*walk).node = a;
            } else {
                (*walk).stack_node[sp] = a; (*walk).stack_t[sp] = ta; (*walk).node = b;
            }
            (*walk).sp = sp + 1;
        } else if (ta >= 0.0) {
            (*walk).node = a;
        } else if (tb >= 0.0) {
            (*walk).node = b;
        } else {
            (*walk).pop = true;
        }
    }
    return false;
}

// The closest hit along the ray (the CPU's `intersect`).
fn intersect(r: Ray) -> Hit {
    var best = Hit(-1.0, 0u, 0.0, 0.0);
    var t_max = INF;
    let w = watertight_setup(r);
    var walk = bvh_walk(r);
    loop {
        if (!bvh_next_leaf(&walk, r, t_max)) { break; }
        for (var i = walk.first; i < walk.first + walk.count; i++) {
            let tr = triangles[i];
            let h = watertight(w, r.origin, tr.p0.xyz, tr.p1.xyz, tr.p2.xyz, t_max);
            if (h.x >= 0.0) {
                t_max = h.x;
                best = Hit(h.x, i, h.y, h.z);
            }
        }
    }
    return best;
}

fn try_normalize(v: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if (l > 0.0 && l < INF) { return v * (1.0 / l); }
    return vec3<f32>(0.0);
}

fn shade(object: u32, position: vec3<f32>, normal: vec3<f32>, eye: vec3<f32>) -> vec3<f32> {
    let m = object_materials[object];
    let diffuse = m.diffuse.xyz;
    var v = try_normalize(eye - position);
    if (all(v == vec3<f32>(0.0))) { v = vec3<f32>(0.0, 0.0, 1.0); }
    var n = normal;
    if (dot(n, v) < 0.0) { n = -n; }
    var c = diffuse * AMBIENT;
    for (var i = 0u; i < params.n_lights; i++) {
        let light = lights[i];
        var l = v;
        if (light.kind.x == 1u) {
            let d = try_normalize(light.data.xyz - position);
            if (any(d != vec3<f32>(0.0))) { l = d; }
        } else if (light.kind.x == 2u) {
            let d = try_normalize(-light.data.xyz);
            if (any(d != vec3<f32>(0.0))) { l = d; }
        }
        let ndl = max(dot(n, l), 0.0);
        if (ndl > 0.0) {
            var h = try_normalize(l + v);
            if (all(h == vec3<f32>(0.0))) { h = n; }
            c += light.data.w * (diffuse * ndl + m.specular.xyz * pow(max(dot(n, h), 0.0), m.diffuse.w));
        }
    }
    return c;
}

fn to_rgb8(c: vec3<f32>) -> vec3<u32> {
    let i = vec3<u32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * GAMMA_STEPS + 0.5);
    return vec3<u32>(gamma[i.x], gamma[i.y], gamma[i.z]);
}

// A cast sample: did the ray through screen point p hit, where, what.
struct Sample {
    hit: u32,
    object: u32,
    t: f32,
    normal: vec3<f32>,
};

fn screen_point(p: vec2<f32>) -> vec3<f32> {
    // `Camera::screen_point`: the step in eye.w, the shift in pitch.zw.
    return vec3<f32>(
        (p.x * params.eye.w + params.pitch.z) * params.pitch.x,
        (params.pitch.w - p.y * params.eye.w) * params.pitch.y,
        0.0);
}

// The primary ray from the eye through screen point p (direction not
// normalised: t in units of |screen point − eye|). Also the hidden cast's.
fn primary_ray(p: vec2<f32>) -> Ray {
    let eye = params.eye.xyz;
    let dir = screen_point(p) - eye;
    return Ray(eye, dir, 1.0 / dir, dir.x == 0.0 || dir.y == 0.0 || dir.z == 0.0);
}

// The shading normal of triangle `tr` at barycentrics (u, v): its vertex
// normals interpolated, else its face normal, else +z. Also the hidden
// cast's.
fn shading_normal(tr: Triangle, u: f32, v: f32) -> vec3<f32> {
    var n = try_normalize(tr.n0.xyz * (1.0 - u - v) + tr.n1.xyz * u + tr.n2.xyz * v);
    if (all(n == vec3<f32>(0.0))) {
        n = try_normalize(cross(tr.p1.xyz - tr.p0.xyz, tr.p2.xyz - tr.p0.xyz));
        if (all(n == vec3<f32>(0.0))) { n = vec3<f32>(0.0, 0.0, 1.0); }
    }
    return n;
}

fn trace(p: vec2<f32>) -> Sample {
    let h = intersect(primary_ray(p));
    if (h.t < 0.0) { return MISS; }
    let tr = triangles[h.tri];
    return Sample(1u, bitcast<u32>(tr.p0.w), h.t, shading_normal(tr, h.u, h.v));
}

// 8-bit colour of a sample seen through screen point p (the CPU's
// `colour_of` followed by `rgb8`).
fn colour(p: vec2<f32>, s: Sample) -> vec3<u32> {
    if (s.hit == 0u) { return params.background_rgb8.xyz; }
    let eye = params.eye.xyz;
    let position = eye + (screen_point(p) - eye) * s.t;
    let c = shade(s.object, position, s.normal, eye);
    if (all(c == params.background.xyz)) { return params.background_rgb8.xyz; }
    return to_rgb8(c);
}

fn pack(rgb: vec3<u32>, hit: u32, layer: u32) -> u32 {
    return rgb.x | (rgb.y << 8u) | (rgb.z << 16u) | (hit << 24u) | (layer << 25u);
}

const MISS: Sample = Sample(0u, 0u, 0.0, vec3<f32>(0.0));

// Writes pixel i of the frame: the colour word, and the G-buffer of sample s
// seen through screen point p — the CPU's `texel`: eye distance
// t·|screen point − eye|, object and normal; background values for a miss.
fn put(i: u32, p: vec2<f32>, s: Sample, layer: u32) {
    pixels[i] = pack(colour(p, s), s.hit, layer);
    if (s.hit == 1u) {
        depth[i] = s.t * length(screen_point(p) - params.eye.xyz);
        object_ids[i] = s.object;
        normals[3u * i] = s.normal.x;
        normals[3u * i + 1u] = s.normal.y;
        normals[3u * i + 2u] = s.normal.z;
    } else {
        depth[i] = INF;
        object_ids[i] = 0xffffffffu;
        normals[3u * i] = 0.0;
        normals[3u * i + 1u] = 0.0;
        normals[3u * i + 2u] = 0.0;
    }
}

@compute @workgroup_size(8, 8)
fn full(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) { return; }
    let p = vec2<f32>(f32(id.x) + 0.5, f32(id.y) + 0.5);
    put(id.y * params.width + id.x, p, trace(p), 0u);
}
