// gazecast GPU raster path (appended to cast.wgsl, whose `Params`, `shade`,
// `to_rgb8`, `try_normalize`, `pack` and frame buffers it uses): a render
// pipeline draws a list of triangles through the display's off-axis frustum
// into four colour targets and a reversed-Z depth buffer, then a compute
// pass resolves the targets into the frame's buffers (`put`'s layout), so
// the read-back is the ray caster's.

struct RasterParams {
    // Off-axis projection of eye-relative world positions (mm) to clip space.
    clip: mat4x4<f32>,
};

// One corner of a triangle: position (w: object id, bitcast), corner
// normal and the triangle's unit face normal (zero when degenerate).
struct RasterVertex {
    p: vec4<f32>,
    n: vec4<f32>,
    face: vec4<f32>,
};

@group(0) @binding(10) var<uniform> raster: RasterParams;
@group(0) @binding(11) var<storage, read> raster_vertices: array<RasterVertex>;

struct RasterVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) face: vec3<f32>,
    @location(3) @interpolate(flat) object: u32,
};

@vertex
fn raster_vertex(@builtin(vertex_index) i: u32) -> RasterVarying {
    let v = raster_vertices[i];
    var out: RasterVarying;
    out.clip = raster.clip * vec4<f32>(v.p.xyz - params.eye.xyz, 1.0);
    out.world = v.p.xyz;
    out.normal = v.n.xyz;
    out.face = v.face.xyz;
    out.object = bitcast<u32>(v.p.w);
    return out;
}

struct RasterTargets {
    // `pack`: colour, hit flag (always set here), layer 0 (full).
    @location(0) word: u32,
    // Eye distance (mm) of the interpolated world position.
    @location(1) depth: f32,
    @location(2) object: u32,
    @location(3) normal: vec4<f32>,
};

// Shades a fragment as the caster shades a hit (`trace` then `colour`):
// the normalised blend of the corner normals (the face normal when it
// vanishes), Blinn-Phong at the interpolated position, the gamma table.
@fragment
fn raster_fragment(in: RasterVarying) -> RasterTargets {
    let eye = params.eye.xyz;
    var n = try_normalize(in.normal);
    if (all(n == vec3<f32>(0.0))) {
        n = try_normalize(in.face);
        if (all(n == vec3<f32>(0.0))) { n = vec3<f32>(0.0, 0.0, 1.0); }
    }
    let c = shade(in.object, in.world, n, eye);
    var rgb = params.background_rgb8.xyz;
    if (!all(c == params.background.xyz)) { rgb = to_rgb8(c); }
    var out: RasterTargets;
    out.word = pack(rgb, 1u, 0u);
    out.depth = length(in.world - eye);
    out.object = in.object;
    out.normal = vec4<f32>(n, 0.0);
    return out;
}

@group(1) @binding(0) var raster_word: texture_2d<u32>;
@group(1) @binding(1) var raster_depth: texture_2d<f32>;
@group(1) @binding(2) var raster_object: texture_2d<u32>;
@group(1) @binding(3) var raster_normal: texture_2d<f32>;

// The targets into the frame's buffers; a pixel no fragment reached (its
// word still cleared to 0: no hit flag) gets the background, as `put` writes
// a miss.
@compute @workgroup_size(8, 8)
fn raster_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) { return; }
    let i = id.y * params.width + id.x;
    let at = vec2<i32>(id.xy);
    let word = textureLoad(raster_word, at, 0).x;
    if (((word >> 24u) & 1u) == 1u) {
        let n = textureLoad(raster_normal, at, 0).xyz;
        pixels[i] = word;
        depth[i] = textureLoad(raster_depth, at, 0).x;
        object_ids[i] = textureLoad(raster_object, at, 0).x;
        normals[3u * i] = n.x;
        normals[3u * i + 1u] = n.y;
        normals[3u * i + 2u] = n.z;
    } else {
        pixels[i] = pack(params.background_rgb8.xyz, 0u, 0u);
        depth[i] = INF;
        object_ids[i] = 0xffffffffu;
        normals[3u * i] = 0.0;
        normals[3u * i + 1u] = 0.0;
        normals[3u * i + 2u] = 0.0;
    }
}
