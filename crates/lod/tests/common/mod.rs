//! Procedural meshes for the tests and the bench.
#![allow(dead_code)]

use foveation::perceptibility::ThresholdTable;
use foveation::GeislerPerry;
use glam::Vec3;
use lod::{LodError, VertexTree};

/// A mesh in flat arrays, as `VertexTree::build` takes it.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub luminance: Vec<f32>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn tree(&self) -> Result<VertexTree, LodError> {
        VertexTree::build(
            &self.positions,
            &self.normals,
            &self.luminance,
            &self.triangles,
        )
    }

    pub fn push_vertex(&mut self, p: Vec3, n: Vec3, lum: f32) -> u32 {
        self.positions.push(p);
        self.normals.push(n);
        self.luminance.push(lum);
        (self.positions.len() - 1) as u32
    }
}

/// A luminance pattern (cd/m²) with smooth bands and a little texture, so
/// nodes have a spread of fold contrasts.
pub fn pattern(u: f32, v: f32) -> f32 {
    40.0 + 25.0 * (3.0 * u).sin() * (2.0 * v).cos() + 4.0 * (17.0 * u + 11.0 * v).sin()
}

/// A closed torus in the xy plane around `centre`: `nu` segments around the
/// big circle, `nv` around the tube, 2·nu·nv triangles, outward normals.
pub fn torus(nu: u32, nv: u32, major_mm: f32, minor_mm: f32, centre: Vec3) -> Mesh {
    let mut m = Mesh::default();
    for i in 0..nu {
        let u = i as f32 / nu as f32 * std::f32::consts::TAU;
        for j in 0..nv {
            let v = j as f32 / nv as f32 * std::f32::consts::TAU;
            let ring = Vec3::new(u.cos(), u.sin(), 0.0);
            let n = ring * v.cos() + Vec3::Z * v.sin();
            let p = centre + ring * major_mm + n * minor_mm;
            m.push_vertex(p, n, pattern(u, v));
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + (j % nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            m.triangles.push([a, b, c]);
            m.triangles.push([a, c, d]);
        }
    }
    m
}

/// An open, gently bumpy square grid in the xy plane: (nx+1)(ny+1)
/// vertices, 2·nx·ny triangles, normals +z.
pub fn grid(nx: u32, ny: u32, size_mm: f32) -> Mesh {
    let mut m = Mesh::default();
    for j in 0..=ny {
        for i in 0..=nx {
            let (u, v) = (i as f32 / nx as f32, j as f32 / ny as f32);
            let z = 0.05 * size_mm * (6.0 * u).sin() * (5.0 * v).cos();
            m.push_vertex(
                Vec3::new((u - 0.5) * size_mm, (v - 0.5) * size_mm, z),
                Vec3::Z,
                pattern(u * 6.0, v * 6.0),
            );
        }
    }
    let id = |i: u32, j: u32| j * (nx + 1) + i;
    for j in 0..ny {
        for i in 0..nx {
            m.triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            m.triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    m
}

/// The same triangles with every corner its own vertex (an unwelded
/// "triangle soup", as STL files store meshes).
pub fn soup(mesh: &Mesh) -> Mesh {
    let mut m = Mesh::default();
    for tri in &mesh.triangles {
        let t = tri.map(|v| {
            let v = v as usize;
            m.push_vertex(mesh.positions[v], mesh.normals[v], mesh.luminance[v])
        });
        m.triangles.push(t);
    }
    m
}

/// Two meshes side by side as one (disconnected) mesh.
pub fn concat(a: &Mesh, b: &Mesh) -> Mesh {
    let mut m = a.clone();
    let off = m.positions.len() as u32;
    m.positions.extend_from_slice(&b.positions);
    m.normals.extend_from_slice(&b.normals);
    m.luminance.extend_from_slice(&b.luminance);
    m.triangles
        .extend(b.triangles.iter().map(|t| t.map(|v| v + off)));
    m
}

/// The Geisler–Perry table (Luebke & Hallen's model, built from the CSF).
pub fn table() -> ThresholdTable {
    ThresholdTable::from_model(&GeislerPerry::default())
}
