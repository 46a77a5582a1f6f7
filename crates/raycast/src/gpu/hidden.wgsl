// The hidden image of Lee 2009 §5.1.2 on the GPU, the twin of
// `raycast::layers` (`pixel_layers` + the ch. 5 pass's rule): per pixel
// asked for, the first `HIDDEN_HITS` distinct surfaces along the primary
// ray (one BVH traversal whose t_max is the K-th nearest distance once K
// are kept; hits within SAME_SURFACE_REL are one surface, the nearer then
// the lower triangle kept), and of them the first whose object differs
// from the visible one (`object_ids`) and lies deeper than it, shaded
// like a primary hit (`shade` of cast.wgsl). Appended to cast.wgsl.

// Per pixel: non-zero where the hidden surface is wanted.
@group(1) @binding(0) var<storage, read> hidden_want: array<u32>;
// Per pixel: linear colour clamped to [0, 1] in xyz; w the eye distance
// (mm) of the hidden surface, -2 for the background (the ray left the
// scene before another object), -1 for none (not wanted, or K surfaces
// of the visible object).
@group(1) @binding(1) var<storage, read_write> hidden_out: array<vec4<f32>>;

const HIDDEN_HITS: u32 = 4u;
const SAME_SURFACE_REL: f32 = 1e-5;

struct Nearest {
    len: u32,
    t: array<f32, 4>,
    tri: array<u32, 4>,
    u: array<f32, 4>,
    v: array<f32, 4>,
};

fn nearest_t_max(s: Nearest) -> f32 {
    if (s.len == HIDDEN_HITS) { return s.t[HIDDEN_HITS - 1u]; }
    return INF;
}

fn better(ta: f32, ia: u32, tb: f32, ib: u32) -> bool {
    return ta < tb || (ta == tb && ia < ib);
}

fn same_surface(a: f32, b: f32) -> bool {
    return abs(a - b) <= SAME_SURFACE_REL * max(abs(a), abs(b));
}

// `Nearest::offer` of layers.rs.
fn offer(s: ptr<function, Nearest>, tri: u32, t: f32, u: f32, v: f32) {
    var len = (*s).len;
    for (var j = 0u; j < len; j++) {
        if (same_surface((*s).t[j], t)) {
            if (better(t, tri, (*s).t[j], (*s).tri[j])) {
                (*s).t[j] = t; (*s).tri[j] = tri; (*s).u[j] = u; (*s).v[j] = v;
                // Re-sort (insertion sort by (t, triangle)).
                for (var a = 1u; a < len; a++) {
                    var b = a;
                    loop {
                        if (b == 0u) { break; }
                        if (!better((*s).t[b], (*s).tri[b], (*s).t[b - 1u], (*s).tri[b - 1u])) { break; }
                        let t0 = (*s).t[b]; let i0 = (*s).tri[b]; let u0 = (*s).u[b]; let v0 = (*s).v[b];
                        (*s).t[b] = (*s).t[b - 1u]; (*s).tri[b] = (*s).tri[b - 1u];
                        (*s).u[b] = (*s).u[b - 1u]; (*s).v[b] = (*s).v[b - 1u];
                        (*s).t[b - 1u] = t0; (*s).tri[b - 1u] = i0; (*s).u[b - 1u] = u0; (*s).v[b - 1u] = v0;
                        b--;
                    }
                }
            }
            return;
        }
    }
    if (len == HIDDEN_HITS) {
        if (!better(t, tri, (*s).t[HIDDEN_HITS - 1u], (*s).tri[HIDDEN_HITS - 1u])) { return; }
        len--;
    }
    var j = len;
    loop {
        if (j == 0u) { break; }
        if (!better(t, tri, (*s).t[j - 1u], (*s).tri[j - 1u])) { break; }
        (*s).t[j] = (*s).t[j - 1u]; (*s).tri[j] = (*s).tri[j - 1u];
        (*s).u[j] = (*s).u[j - 1u]; (*s).v[j] = (*s).v[j - 1u];
        j--;
    }
    (*s).t[j] = t; (*s).tri[j] = tri; (*s).u[j] = u; (*s).v[j] = v;
    (*s).len = len + 1u;
}

// `nearest_hits` over the BVH: cast.wgsl's walk (`bvh_next_leaf`, the
// traversal of `intersect`) with the K-th nearest distance as t_max.
fn nearest_hits(r: Ray) -> Nearest {
    var s: Nearest;
    s.len = 0u;
    for (var k = 0u; k < HIDDEN_HITS; k++) { s.t[k] = INF; s.tri[k] = 0xffffffffu; }
    let w = watertight_setup(r);
    var walk = bvh_walk(r);
    loop {
        if (!bvh_next_leaf(&walk, r, nearest_t_max(s))) { break; }
        for (var i = walk.first; i < walk.first + walk.count; i++) {
            let tr = triangles[i];
            let h = watertight(w, r.origin, tr.p0.xyz, tr.p1.xyz, tr.p2.xyz, nearest_t_max(s));
            if (h.x >= 0.0) {
                offer(&s, i, h.x, h.y, h.z);
            }
        }
    }
    return s;
}

@compute @workgroup_size(8, 8)
fn hidden(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) { return; }
    let i = id.y * params.width + id.x;
    hidden_out[i] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    if (hidden_want[i] == 0u) { return; }
    let p = vec2<f32>(f32(id.x) + 0.5, f32(id.y) + 0.5);
    let r = primary_ray(p);
    let s = nearest_hits(r);
    let length_dir = length(r.dir);
    let visible = object_ids[i];
    let zv = depth[i];
    for (var k = 1u; k < s.len; k++) {
        let tr = triangles[s.tri[k]];
        let object = bitcast<u32>(tr.p0.w);
        let d = s.t[k] * length_dir;
        if (object == visible || object == 0xffffffffu || !(d > zv)) { continue; }
        let n = shading_normal(tr, s.u[k], s.v[k]);
        let c = shade(object, r.origin + r.dir * s.t[k], n, r.origin);
        hidden_out[i] = vec4<f32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), d);
        return;
    }
    if (s.len < HIDDEN_HITS) {
        hidden_out[i] = vec4<f32>(0.0, 0.0, 0.0, -2.0);
    }
}
