//! Triangle meshes: loaded from OBJ (through `tobj`) or generated.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use crate::error::SceneError;

/// An indexed triangle mesh with smooth (area-weighted) vertex normals.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions, mesh units.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub indices: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Builds a mesh, checking indices and coordinates, and computes normals.
    /// `origin` names the data in errors.
    pub fn new(
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        origin: &str,
    ) -> Result<Self, SceneError> {
        if positions.is_empty() || indices.is_empty() {
            return Err(SceneError::mesh(
                origin,
                None,
                "the mesh is empty (no vertices or no triangles)",
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::mesh(
                origin,
                Some(i),
                format!("vertex {i} is not finite: {:?}", positions[i]),
            ));
        }
        let n = positions.len() as u32;
        if let Some((t, tri)) = indices
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i >= n))
        {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("triangle {t} uses vertex {tri:?}, but the mesh has {n} vertices"),
            ));
        }
        Ok(Self::with_normals(positions, indices))
    }

    /// A mesh from finite positions and in-range indices (checked by the
    /// callers), with its vertex normals.
    ///
    /// The normals are computed on the positions scaled by a power of two
    /// that brings the largest coordinate into [1, 2): exact, so ordinary
    /// meshes get bit-for-bit the normals of the unscaled sums, while meshes
    /// with coordinates near `f32::MAX` (whose cross products would
    /// overflow) or near zero (which would underflow) still get their true
    /// normals. A vertex whose normal is still zero (degenerate triangles
    /// only) gets +z; every normal is finite and unit length.
    fn with_normals(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Self {
        let largest = positions
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0f32, f32::max);
        let scale = if largest > 0.0 && largest.is_finite() {
            pow2(-(largest.log2().floor() as i32))
        } else {
            1.0
        };
        let mut normals = vec![Vec3::ZERO; positions.len()];
        for t in &indices {
            let [a, b, c] = t.map(|i| positions[i as usize] * scale);
            let n = (b - a).cross(c - a); // length = 2·area: area weighting
            for &i in t {
                normals[i as usize] += n;
            }
        }
        for n in &mut normals {
            *n = n.try_normalize().unwrap_or(Vec3::Z);
        }
        Self {
            positions,
            normals,
            indices,
        }
    }

    /// The corners of triangle `i`.
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    /// Loads every model of an OBJ file as one mesh (faces of more than
    /// three vertices are fanned into triangles).
    ///
    /// The file must be a regular file (a directory, FIFO or device is
    /// refused with what it is) of UTF-8 text: a leading UTF-8 byte-order
    /// mark is skipped; a NUL byte or a byte sequence that is not UTF-8 is
    /// refused as binary, naming the line. Every face (`f`) needs at least
    /// three vertices, each index naming an existing vertex: *decision*, a
    /// face of one or two vertices is an error naming its line (OBJ draws
    /// points and lines with `p` and `l`; those statements are valid and
    /// draw nothing here).
    pub fn load_obj(path: &Path) -> Result<Self, SceneError> {
        let origin = path.display().to_string();
        let bytes = read_obj(path, &origin)?;
        let text = obj_text(&bytes, &origin)?;
        check_obj_faces(text, &origin)?;
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            // `p` and `l` statements are not surfaces: never triangles.
            ignore_points: true,
            ignore_lines: true,
        };
        let mut reader = std::io::Cursor::new(text.as_bytes());
        let (models, _) = tobj::load_obj_buf(&mut reader, &opts, |_| {
            Err(tobj::LoadError::MaterialParseError)
        })
        .map_err(|e| SceneError::mesh(&origin, None, format!("cannot load: {e}")))?;
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for m in models {
            let base = positions.len() as u32;
            for p in m.mesh.positions.chunks_exact(3) {
                positions.push(Vec3::new(p[0], p[1], p[2]));
            }
            for t in m.mesh.indices.chunks_exact(3) {
                indices.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
        Self::new(positions, indices, &origin).map_err(|e| e.with_obj_line(text))
    }

    /// An icosphere of radius 1: an icosahedron subdivided `subdivisions` times
    /// (20·4^s triangles).
    pub fn icosphere(subdivisions: u32) -> Self {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut positions: Vec<Vec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
        .collect();
        let mut indices: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions.min(9) {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
            let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    positions
                        .push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                    positions.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(indices.len() * 4);
            for [a, b, c] in indices {
                let ab = midpoint(a, b, &mut positions);
                let bc = midpoint(b, c, &mut positions);
                let ca = midpoint(c, a, &mut positions);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            indices = next;
        }
        // Unit vectors and their normalised midpoints: finite, indices in
        // range by construction.
        Self::with_normals(positions, indices)
    }

    /// A torus around the y axis: ring radius `major`, tube radius `minor`,
    /// at least 3 segments and 3 sides. Refused (naming `origin`) when the
    /// radii are not positive and finite, when `major + minor` overflows
    /// f32 (the outermost vertices would not be finite), or when
    /// `segments × sides` vertices cannot be indexed by u32.
    pub fn torus(
        major: f32,
        minor: f32,
        segments: u32,
        sides: u32,
        origin: &str,
    ) -> Result<Self, SceneError> {
        if !(major.is_finite() && minor.is_finite() && major > 0.0 && minor > 0.0) {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("torus radii must be positive and finite (major {major}, minor {minor})"),
            ));
        }
        if !(major + minor).is_finite() {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("torus radii {major} + {minor} overflow f32"),
            ));
        }
        let (segments, sides) = (segments.max(3), sides.max(3));
        if u64::from(segments) * u64::from(sides) > u64::from(u32::MAX) {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("{segments} × {sides} torus vertices cannot be indexed"),
            ));
        }
        let mut positions = Vec::with_capacity(segments as usize * sides as usize);
        for i in 0..segments {
            let u = i as f32 / segments as f32 * std::f32::consts::TAU;
            for j in 0..sides {
                let v = j as f32 / sides as f32 * std::f32::consts::TAU;
                let r = major + minor * v.cos();
                positions.push(Vec3::new(r * u.cos(), minor * v.sin(), r * u.sin()));
            }
        }
        let idx = |i: u32, j: u32| (i % segments) * sides + (j % sides);
        let mut indices = Vec::with_capacity(2 * segments as usize * sides as usize);
        for i in 0..segments {
            for j in 0..sides {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                indices.push([a, c, b]);
                indices.push([a, d, c]);
            }
        }
        // |coordinates| ≤ major + minor, which is finite.
        Self::new(positions, indices, origin)
    }

    /// An icosphere with at least `triangles` triangles whose radius is
    /// displaced by a smooth seeded pattern of relative `amplitude`,
    /// which must be finite and below 1 in magnitude (the surface would
    /// fold through the centre otherwise); refused naming `origin`.
    pub fn bumpy(
        triangles: u32,
        amplitude: f32,
        seed: u64,
        origin: &str,
    ) -> Result<Self, SceneError> {
        if !(amplitude.is_finite() && amplitude.abs() < 1.0) {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("bump amplitude {amplitude} must be finite and below 1 in magnitude"),
            ));
        }
        let mut s = 0;
        while 20u64 * 4u64.pow(s) < u64::from(triangles) && s < 9 {
            s += 1;
        }
        let mut m = Self::icosphere(s);
        // A few seeded plane waves: smooth bumps, deterministic.
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32
        };
        let waves: Vec<(Vec3, f32, f32)> = (0..6)
            .map(|_| {
                let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5)
                    .try_normalize()
                    .unwrap_or(Vec3::X);
                (d, 3.0 + 9.0 * rnd(), std::f32::consts::TAU * rnd())
            })
            .collect();
        for p in &mut m.positions {
            let bump: f32 = waves
                .iter()
                .map(|(d, f, ph)| (d.dot(*p) * f + ph).sin())
                .sum::<f32>()
                / waves.len() as f32;
            *p *= 1.0 + amplitude * bump;
        }
        // Radii within (0, 2): finite.
        Self::new(m.positions, m.indices, origin)
    }
}

/// Angle from +z (degrees, measured on the unit-sphere direction of each
/// vertex) of the front cap of [`TriangleMesh::face`]: every vertex outside
/// it, its normal and the index buffer are the same for all expressions.
pub const FACE_CAP_DEG: f32 = 55.0;

/// The face's features are exactly zero beyond this angle from +z (inside
/// [`FACE_CAP_DEG`], so the cap's rim and the normals of the vertices just
/// outside it are untouched as well).
pub const FACE_FEATURE_DEG: f32 = 50.0;

/// Full strength of the features within this angle from +z; between it and
/// [`FACE_FEATURE_DEG`] they taper smoothly to zero.
const FACE_TAPER_START_DEG: f32 = 44.0;

/// Most subdivisions of the face's icosphere (7: 327 680 triangles).
pub const FACE_MAX_SUBDIVISIONS: u32 = 7;

/// Semi-axes of the head's ellipsoid (x: width, y: height, z: depth), in
/// the unit sphere with room for the features; the largest coordinate stays
/// in [0.5, 1) for every expression, so the normals' exact power-of-two
/// prescale (and with it the normals outside the cap) does not depend on it.
pub const FACE_SEMI_AXES: [f32; 3] = [0.80, 0.96, 0.82];

/// The bytes of an OBJ file, refusing what is not a regular file with
/// what it is (a directory reads as "Is a directory" at best, a FIFO or a
/// device blocks or never ends) and files over [`input_file::MESH`].
fn read_obj(path: &Path, origin: &str) -> Result<Vec<u8>, SceneError> {
    input_file::read(path, input_file::MESH).map_err(|e| {
        let what = if e.kind() == std::io::ErrorKind::NotFound {
            format!("cannot open the OBJ file: {e}")
        } else {
            e.to_string()
        };
        SceneError::mesh(origin, None, what)
    })
}

/// An OBJ file's bytes as text: a leading UTF-8 byte-order mark skipped;
/// a NUL byte or bytes that are not UTF-8 refused, naming the line.
fn obj_text<'a>(bytes: &'a [u8], origin: &str) -> Result<&'a str, SceneError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let line_at = |offset: usize| 1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count();
    let binary = |offset: usize, what: String| {
        SceneError::mesh_at(
            origin,
            line_at(offset),
            format!(
                "{what} at byte {offset}: this is not a text file (a binary mesh?); \
                 an OBJ mesh is UTF-8 text"
            ),
        )
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        binary(at, format!("byte 0x{:02X} is not UTF-8", bytes[at]))
    })?;
    if let Some(at) = text.bytes().position(|b| b == 0) {
        return Err(binary(at, "a NUL byte".into()));
    }
    Ok(text)
}

/// Every `f` statement has at least three vertex references, each naming
/// a vertex of the file, and its texture coordinate and normal (`v/vt/vn`)
/// where given naming existing ones (OBJ indices count from 1; a negative
/// index counts back from the last one read so far). Errors name the line.
fn check_obj_faces(text: &str, origin: &str) -> Result<(), SceneError> {
    const KINDS: [(&str, &str); 3] = [
        ("v", "vertex"),
        ("vt", "texture coordinate"),
        ("vn", "normal"),
    ];
    let mut total = [0i64; 3];
    for line in text.lines() {
        if let Some(k) = KINDS
            .iter()
            .position(|(w, _)| line.split_whitespace().next() == Some(*w))
        {
            total[k] += 1;
        }
    }
    let mut seen = [0i64; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(word) = words.next() else { continue };
        if let Some(k) = KINDS.iter().position(|(w, _)| *w == word) {
            seen[k] += 1;
            continue;
        }
        if word != "f" {
            continue;
        }
        let at = |message: String| SceneError::mesh_at(origin, i + 1, message);
        let refs: Vec<&str> = words.collect();
        if refs.len() < 3 {
            return Err(at(format!(
                "a face of {} vertices: a face needs at least 3 (OBJ writes lines as `l`)",
                refs.len()
            )));
        }
        for r in refs {
            let parts: Vec<&str> = r.split('/').collect();
            if parts.len() > 3 {
                return Err(at(format!("face vertex `{r}`: more than v/vt/vn")));
            }
            for (k, part) in parts.iter().enumerate() {
                // `v//vn` leaves the texture coordinate out.
                if k > 0 && part.is_empty() {
                    continue;
                }
                let what = KINDS[k].1;
                let index: i64 = part.parse().map_err(|_| {
                    at(format!("face vertex `{r}`: `{part}` is not a {what} index"))
                })?;
                let ok = if index > 0 {
                    index <= total[k]
                } else {
                    index < 0 && -index <= seen[k]
                };
                if !ok {
                    return Err(at(format!(
                        "face vertex `{r}`: no {what} {index} (the file has {}, {} before this line; indices count from 1, negative ones back from the last)",
                        total[k], seen[k]
                    )));
                }
            }
        }
    }
    Ok(())
}

/// A compact smooth bump: (1 − q)³ for q = (du/ru)² + (dv/rv)² < 1, else
/// exactly 0; C² everywhere (value and slope vanish at its rim).
fn bump(du: f32, dv: f32, ru: f32, rv: f32) -> f32 {
    let q = (du / ru).powi(2) + (dv / rv).powi(2);
    if q < 1.0 {
        (1.0 - q).powi(3)
    } else {
        0.0
    }
}

/// A smooth ridge (positive `amplitude`) or groove (negative) along the
/// curve v = `centre(u)` for |u − u0| < `half_length`, of half-width
/// `half_width` across (measured in v); C¹ and exactly 0 outside.
fn ridge(
    u: f32,
    v: f32,
    u0: f32,
    half_length: f32,
    half_width: f32,
    amplitude: f32,
    centre: impl Fn(f32) -> f32,
) -> f32 {
    let x = (u - u0) / half_length;
    let s = (v - centre(x)) / half_width;
    if x.abs() >= 1.0 || s.abs() >= 1.0 {
        return 0.0;
    }
    amplitude * (1.0 - x.powi(4)).powi(2) * (1.0 - s * s).powi(3)
}

/// Relative radial displacement of the face at the front direction (u, v) =
/// (x, y) of a unit vector with z > 0, before the cap taper: eye sockets,
/// brows, nose and the expression's mouth (see [`TriangleMesh::face`]).
fn face_relief(expression: u32, u: f32, v: f32) -> f32 {
    let surprise = expression == 3;
    let mut h = 0.0;
    for side in [-1.0f32, 1.0] {
        let eye_u = side * 0.33;
        // Eye socket with the eyeball in it.
        h -= 0.15 * bump(u - eye_u, v - 0.16, 0.19, 0.14);
        h += 0.06 * bump(u - eye_u, v - 0.16, 0.08, 0.075);
        // Brow: a ridge over the socket; raised and arched in surprise.
        let (rest, arch) = if surprise {
            (0.45, 0.05)
        } else {
            (0.34, 0.015)
        };
        h += ridge(u, v, eye_u, 0.19, 0.065, 0.08, |x| {
            rest + arch * (1.0 - x * x)
        });
    }
    // Nose: a bridge down the middle and a rounder tip above the mouth.
    h += 0.07 * bump(u, v - 0.03, 0.06, 0.15);
    h += 0.11 * bump(u, v + 0.08, 0.085, 0.075);
    // Mouth.
    let mouth_v = -0.33;
    match expression {
        // Surprise: an open round mouth with a lip rim.
        3 => {
            h -= 0.20 * bump(u, v - (mouth_v - 0.03), 0.135, 0.13);
            h += 0.04 * bump(u, v - (mouth_v - 0.03), 0.22, 0.20);
        }
        // A groove along a straight line or an arc whose corners turn up
        // (smile) or down (frown).
        _ => {
            let bend = match expression {
                1 => 0.16,
                2 => -0.16,
                _ => 0.0,
            };
            let centre = |x: f32| mouth_v - bend * 0.35 + bend * x * x;
            h += ridge(u, v, 0.0, 0.28, 0.085, -0.12, centre);
            // The lower lip.
            h += ridge(u, v, 0.0, 0.2, 0.06, 0.03, |x| centre(x) - 0.09);
        }
    }
    h
}

/// Hermite smoothstep of t clamped to [0, 1].
fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl TriangleMesh {
    /// A head facing +z, of unit scale (inside the unit sphere): an
    /// icosphere of `subdivisions` (20·4^s triangles, at most
    /// [`FACE_MAX_SUBDIVISIONS`]) stretched to the ellipsoid
    /// [`FACE_SEMI_AXES`], whose vertices within [`FACE_FEATURE_DEG`] of +z
    /// are moved radially by a smooth relief: two eye sockets with
    /// eyeballs, brows, a nose, and a mouth that is the expression
    /// ([`crate::scene::FACE_EXPRESSIONS`]): 0 neutral (a straight groove),
    /// 1 smile (an arc with the corners up), 2 frown (corners down),
    /// 3 surprise (raised brows and an open round mouth).
    ///
    /// The four expressions share one topology: the index buffer, every
    /// vertex outside the front cap of [`FACE_CAP_DEG`] and its normal are
    /// bit-identical, so their outlines seen from within ±15° of +z are the
    /// same. The displacement is radial with 1 + h > 0, so the surface stays
    /// star-shaped about the origin and cannot fold. Refused (naming
    /// `origin`) for an expression above 3 or too many subdivisions.
    pub fn face(expression: u32, subdivisions: u32, origin: &str) -> Result<Self, SceneError> {
        if expression > 3 {
            return Err(SceneError::mesh(
                origin,
                None,
                format!(
                    "face expression {expression} does not exist: 0 to 3 ({})",
                    crate::scene::FACE_EXPRESSIONS.join(", ")
                ),
            ));
        }
        if subdivisions > FACE_MAX_SUBDIVISIONS {
            return Err(SceneError::mesh(
                origin,
                None,
                format!("face subdivisions {subdivisions} above {FACE_MAX_SUBDIVISIONS}"),
            ));
        }
        let sphere = Self::icosphere(subdivisions);
        let [ax, ay, az] = FACE_SEMI_AXES;
        let feature_cos = FACE_FEATURE_DEG.to_radians().cos();
        let full_cos = FACE_TAPER_START_DEG.to_radians().cos();
        let positions = sphere
            .positions
            .iter()
            .map(|d| {
                let base = Vec3::new(ax * d.x, ay * d.y, az * d.z);
                if d.z <= feature_cos {
                    // The same for every expression: bit-identical.
                    return base;
                }
                let taper = smoothstep((d.z - feature_cos) / (full_cos - feature_cos));
                let h = taper * face_relief(expression, d.x, d.y);
                base * (1.0 + h)
            })
            .collect();
        // Unit directions scaled by at most 0.96 and by 1 + h, |h| ≤ 0.2:
        // finite, and the indices are the icosphere's.
        Ok(Self::with_normals(positions, sphere.indices))
    }
}

/// 2^k as f32, for k clamped to the normal range [-126, 127].
fn pow2(k: i32) -> f32 {
    f32::from_bits(((k.clamp(-126, 127) + 127) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_meshes_are_closed_two_manifolds() {
        for m in [
            TriangleMesh::icosphere(2),
            TriangleMesh::torus(1.0, 0.3, 24, 12, "torus").expect("torus"),
            TriangleMesh::bumpy(3000, 0.1, 5, "bumpy").expect("bumpy"),
            TriangleMesh::face(1, 3, "face").expect("face"),
        ] {
            let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
            for t in &m.indices {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            assert!(
                edges.values().all(|&c| c == 2),
                "every edge is shared by exactly two triangles"
            );
        }
        assert_eq!(TriangleMesh::icosphere(3).indices.len(), 20 * 64);
        let bumpy = TriangleMesh::bumpy(20_000, 0.1, 1, "bumpy").expect("bumpy");
        assert!(bumpy.indices.len() >= 20_000);
    }

    /// The four faces at `subdivisions`, with the icosphere they displace.
    fn faces(subdivisions: u32) -> (TriangleMesh, Vec<TriangleMesh>) {
        let faces = (0..4)
            .map(|e| TriangleMesh::face(e, subdivisions, "face").expect("face"))
            .collect();
        (TriangleMesh::icosphere(subdivisions), faces)
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    #[test]
    fn the_four_faces_share_topology_and_everything_outside_the_front_cap() {
        let cap_cos = FACE_CAP_DEG.to_radians().cos();
        let feature_cos = FACE_FEATURE_DEG.to_radians().cos();
        for s in [2, 5] {
            let (sphere, faces) = faces(s);
            let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
            for t in &faces[0].indices {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            assert!(edges.values().all(|&c| c == 2), "s {s}: closed 2-manifold");
            for (e, f) in faces.iter().enumerate() {
                assert_eq!(f.indices, faces[0].indices, "s {s}: indices of {e}");
                assert_eq!(f.positions.len(), sphere.positions.len());
                for (p, n) in f.positions.iter().zip(&f.normals) {
                    assert!(p.is_finite() && p.length() < 1.0, "s {s} {e}: {p}");
                    assert!((n.length() - 1.0).abs() < 1e-5, "s {s} {e}: normal {n}");
                }
                // Outside the feature zone the vertices are the ellipsoid's;
                // outside the cap their normals are also the same for all.
                for (i, d) in sphere.positions.iter().enumerate() {
                    if d.z <= feature_cos {
                        assert_eq!(bits(f.positions[i]), bits(faces[0].positions[i]));
                        let [ax, ay, az] = FACE_SEMI_AXES;
                        assert_eq!(
                            bits(f.positions[i]),
                            bits(Vec3::new(ax * d.x, ay * d.y, az * d.z))
                        );
                    }
                    if d.z < cap_cos {
                        assert_eq!(
                            bits(f.normals[i]),
                            bits(faces[0].normals[i]),
                            "s {s} {e}: normal {i}"
                        );
                    }
                }
                // Radial displacement keeps every triangle facing away from
                // the centre: no fold.
                for t in 0..f.indices.len() {
                    let [a, b, c] = f.triangle(t);
                    let n = (b - a).cross(c - a);
                    assert!(n.dot(a + b + c) > 0.0, "s {s} {e}: triangle {t} folds");
                }
            }
            let cap = sphere.positions.iter().filter(|d| d.z >= cap_cos).count();
            for a in 0..4 {
                for b in a + 1..4 {
                    let moved = (0..sphere.positions.len())
                        .filter(|&i| faces[a].positions[i] != faces[b].positions[i])
                        .count();
                    assert!(
                        moved * 50 > cap,
                        "s {s}: expressions {a} and {b} differ at {moved} of {cap} cap vertices"
                    );
                }
            }
        }
    }

    #[test]
    fn the_face_relief_is_smooth_and_tapers_to_zero() {
        // No spikes: the relief h (relative radial displacement) has a
        // bounded slope along every edge, the same at two resolutions (a
        // spike's would grow with the resolution), and stays small.
        // Measured: slopes 2.5–2.8, relief 0.12 (0.16 for surprise).
        let [ax, ay, az] = FACE_SEMI_AXES;
        for s in [6, 7] {
            let (sphere, faces) = faces(s);
            for (e, f) in faces.iter().enumerate() {
                let h: Vec<f32> = sphere
                    .positions
                    .iter()
                    .zip(&f.positions)
                    .map(|(d, p)| {
                        p.length() / Vec3::new(ax * d.x, ay * d.y, az * d.z).length() - 1.0
                    })
                    .collect();
                let relief = h.iter().fold(0.0f32, |m, h| m.max(h.abs()));
                let mut slope = 0.0f32;
                for t in &f.indices {
                    for k in 0..3 {
                        let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                        let arc = sphere.positions[a].distance(sphere.positions[b]);
                        slope = slope.max((h[a] - h[b]).abs() / arc);
                    }
                }
                assert!(
                    relief < 0.25,
                    "s {s} expression {e}: relative relief {relief}"
                );
                assert!(slope < 3.0, "s {s} expression {e}: relief slope {slope}");
            }
        }
        assert_eq!(smoothstep(0.0), 0.0);
        assert_eq!(smoothstep(1.0), 1.0);
        for (du, dv) in [(1.0, 0.0), (0.0, 1.0), (2.0, 2.0)] {
            assert_eq!(bump(du, dv, 1.0, 1.0), 0.0);
        }
    }

    #[test]
    fn faces_refuse_unknown_expressions_and_too_many_subdivisions() {
        for (e, s) in [
            (4, 2),
            (u32::MAX, 2),
            (0, FACE_MAX_SUBDIVISIONS + 1),
            (1, u32::MAX),
        ] {
            let err = TriangleMesh::face(e, s, "meshes.f").expect_err("refused");
            assert!(err.to_string().starts_with("meshes.f:"), "{err}");
        }
        let err = TriangleMesh::face(7, 1, "f").expect_err("refused");
        assert!(err.to_string().contains("surprise"), "{err}");
    }

    #[test]
    fn generators_refuse_what_they_cannot_represent() {
        for (major, minor) in [
            (f32::MAX, f32::MAX),
            (3e38, 1e38),
            (f32::NAN, 1.0),
            (1.0, f32::INFINITY),
            (0.0, 1.0),
            (1.0, -1.0),
        ] {
            let e = TriangleMesh::torus(major, minor, 8, 6, "t").expect_err("refused");
            assert!(e.to_string().starts_with("t:"), "{e}");
        }
        assert!(TriangleMesh::torus(1.0, 0.5, u32::MAX, 2, "t").is_err());
        for a in [1.0, -1.5, f32::NAN, f32::INFINITY] {
            assert!(TriangleMesh::bumpy(100, a, 1, "b").is_err(), "{a}");
        }
        // Just representable: finite positions and unit normals.
        let m = TriangleMesh::torus(2e38, 1e38, 8, 6, "t").expect("fits");
        assert!(m.positions.iter().all(|p| p.is_finite()));
        assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    }

    #[test]
    fn normals_do_not_depend_on_the_scale() {
        let unit = TriangleMesh::torus(1.0, 0.3, 16, 8, "t").expect("torus");
        for s in [1e-38f32, 1e-20, 4.0, 1e30, 1e38] {
            let scaled = TriangleMesh::new(
                unit.positions.iter().map(|p| *p * s).collect(),
                unit.indices.clone(),
                "t",
            )
            .expect("finite");
            for (a, b) in unit.normals.iter().zip(&scaled.normals) {
                assert!((*a - *b).length() < 1e-5, "scale {s}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn bad_meshes_are_errors() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(TriangleMesh::new(p.clone(), vec![[0, 1, 3]], "t")
            .unwrap_err()
            .to_string()
            .contains("triangle 0"));
        assert!(
            TriangleMesh::new(vec![Vec3::ZERO, Vec3::NAN, Vec3::Y], vec![[0, 1, 2]], "t").is_err()
        );
        assert!(TriangleMesh::new(p, vec![], "t").is_err());
    }
}
