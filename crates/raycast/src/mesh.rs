//! Triangle meshes: loaded from OBJ (through `tobj`) or generated.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use crate::error::SceneError;

/// An indexed triangle mesh with smooth (area-weighted) vertex normals.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
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

    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    /// Loads the first… all models of an OBJ file as one mesh (triangulated).
    pub fn load_obj(path: &Path) -> Result<Self, SceneError> {
        let origin = path.display().to_string();
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        // tobj reports "open file failed" and drops the system's reason:
        // open the file here for the error, and parse from the buffer.
        let file = std::fs::File::open(path).map_err(|e| {
            SceneError::mesh(&origin, None, format!("cannot open the OBJ file: {e}"))
        })?;
        let mut reader = std::io::BufReader::new(file);
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
        Self::new(positions, indices, &origin).map_err(|e| e.with_obj_line(path))
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
