//! Building a scene from its file: every check (meshes loaded or
//! generated, the triangle budget, every field, every placed vertex
//! finite), the objects placed in the display frame and the hierarchy
//! built over them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{EulerRot, Mat3, Vec3};

use super::file::{
    check_colour, Light, Material, MeshSource, SceneFile, FACE_EXPRESSIONS, MAX_COLOUR,
};
use super::motion::{moving_scene, SceneMotion};
use super::pass::PostPass;
use super::sampling::Sampling;
use super::{next_revision, Accel, Scene, WorldTriangle};
use crate::accel::{Bvh, Bvh4};
use crate::error::SceneError;
use crate::mesh::TriangleMesh;
use crate::ray::Aabb;

/// Most triangles a scene may have, all objects together (each object
/// counts its mesh's triangles).
pub const MAX_TRIANGLES: u64 = 20_000_000;

/// Peak memory per triangle while a scene is built: the triangles in file
/// order and again in BVH order (2 × 76 B), their boxes (24 B), the BVH
/// build's centres and order (12 + 4 B), at most two 32-byte BVH nodes and
/// a third of a 128-byte 4-wide node (64 + 43 B): 299 B. At
/// [`MAX_TRIANGLES`], about 6 GB.
pub const BYTES_PER_TRIANGLE: u64 = 300;

/// Triangles in BVH leaf order and the BVH over them.
pub(super) fn hierarchy(triangles: Vec<WorldTriangle>) -> (Vec<WorldTriangle>, Bvh) {
    let bounds: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let mut b = Aabb::EMPTY;
            t.p.iter().for_each(|p| b.grow(*p));
            b
        })
        .collect();
    let bvh = Bvh::build(&bounds);
    let triangles = bvh.order.iter().map(|&i| triangles[i as usize]).collect();
    (triangles, bvh)
}

/// A scene file checked and placed, before its hierarchy is built.
struct Checked {
    sampling: Sampling,
    passes: Vec<PostPass>,
    triangles: Vec<WorldTriangle>,
    materials: Vec<Material>,
    object_material: Vec<u32>,
    object_importance: Vec<f32>,
    motion: Option<SceneMotion>,
}

impl Scene {
    /// The files a scene reads besides its own: each OBJ mesh's field
    /// (`meshes.NAME`) and path, resolved as [`Scene::build`] resolves it.
    /// A command lists them among its inputs so that no output replaces one.
    pub fn mesh_files(file: &SceneFile, base_dir: &Path) -> Vec<(String, PathBuf)> {
        file.meshes
            .iter()
            .filter_map(|(name, src)| match src {
                MeshSource::Obj { path } => {
                    Some((format!("meshes.{name}"), obj_path(path, base_dir)))
                }
                _ => None,
            })
            .collect()
    }

    /// Builds the world. Relative OBJ paths are resolved against `base_dir`.
    /// Errors name the field (`objects[3].mesh`) or the mesh file and line.
    pub fn build(file: &SceneFile, base_dir: &Path) -> Result<Self, SceneError> {
        let Checked {
            sampling,
            passes,
            triangles,
            materials,
            object_material,
            object_importance,
            motion,
        } = Self::checked(file, base_dir)?;
        let (triangles, lights, pose) = match &motion {
            Some(m) => {
                let (t, l, p) = m.place(0.0);
                (t, l, Some(p))
            }
            None => (triangles, file.lights.clone(), None),
        };
        let (triangles, bvh) = hierarchy(triangles);
        let object_materials = object_material
            .iter()
            .map(|&m| materials[m as usize])
            .collect();
        let c = file.background;
        Ok(Self {
            name: file.name.clone(),
            background: Vec3::new(c.0, c.1, c.2),
            background_rgb8: crate::shade::to_rgb8(Vec3::new(c.0, c.1, c.2)),
            object_materials,
            object_importance,
            lights,
            sampling,
            passes,
            triangles,
            bvh4: Bvh4::collapse(&bvh),
            bvh,
            grid: None,
            accel: Accel::Bvh,
            revision: next_revision(),
            motion: motion.map(std::sync::Arc::new),
            pose,
        })
    }

    /// Every check [`Scene::build`] makes — meshes loaded or generated,
    /// the triangle limit, every field, every placed vertex finite — without
    /// building the hierarchy (the costly part): a scene that passes
    /// builds. For checking a scene before committing to it (the
    /// experiment checks its stimulus scenes before the window opens).
    pub fn check(file: &SceneFile, base_dir: &Path) -> Result<(), SceneError> {
        Self::checked(file, base_dir).map(|_| ())
    }

    fn checked(file: &SceneFile, base_dir: &Path) -> Result<Checked, SceneError> {
        let (sampling, passes) = file.sampling_and_passes()?;
        check_colour("background", file.background)?;
        let meshes = load_meshes(file, base_dir)?;
        let (materials, material_index) = check_materials(file)?;
        check_triangle_budget(file, &meshes)?;
        let Placed {
            triangles,
            object_material,
            object_importance,
        } = place_objects(file, &meshes, &material_index)?;
        check_lights(file)?;
        check_refinement(file, &sampling)?;
        let motion = moving_scene(file, &meshes)?;
        Ok(Checked {
            sampling,
            passes,
            triangles,
            materials,
            object_material,
            object_importance,
            motion,
        })
    }
}

/// Whether every component of `v` is finite.
fn finite3(v: (f32, f32, f32)) -> bool {
    v.0.is_finite() && v.1.is_finite() && v.2.is_finite()
}

/// Every mesh loaded (OBJ) or generated, by name; errors name
/// `meshes.NAME` (and the field) or the mesh file and line.
fn load_meshes(
    file: &SceneFile,
    base_dir: &Path,
) -> Result<BTreeMap<String, TriangleMesh>, SceneError> {
    let mut meshes = BTreeMap::new();
    for (name, src) in &file.meshes {
        let field = format!("meshes.{name}");
        let mesh = match src {
            MeshSource::Obj { path } => TriangleMesh::load_obj(&obj_path(path, base_dir))?,
            MeshSource::Icosphere { subdivisions } => {
                if *subdivisions > 8 {
                    return Err(SceneError::field(
                        format!("{field}.subdivisions"),
                        "subdivisions above 8 (1.3 M triangles) are not supported",
                    ));
                }
                TriangleMesh::icosphere(*subdivisions)
            }
            MeshSource::Torus {
                major_radius,
                minor_radius,
                segments,
                sides,
            } => {
                for (f, r) in [
                    ("major_radius", major_radius),
                    ("minor_radius", minor_radius),
                ] {
                    if !(r.is_finite() && *r > 0.0) {
                        return Err(SceneError::field(
                            format!("{field}.{f}"),
                            "must be a positive number",
                        ));
                    }
                }
                // The outermost ring lies at major + minor.
                if !(major_radius + minor_radius).is_finite() {
                    return Err(SceneError::field(
                        format!("{field}.major_radius"),
                        format!(
                            "major_radius + minor_radius ({major_radius} + {minor_radius}) overflows f32"
                        ),
                    ));
                }
                if u64::from(*segments) * u64::from(*sides) > 20_000_000 {
                    return Err(SceneError::field(
                        format!("{field}.segments"),
                        "segments × sides is too large (more than 20 M)",
                    ));
                }
                TriangleMesh::torus(*major_radius, *minor_radius, *segments, *sides, &field)?
            }
            MeshSource::Bumpy {
                triangles,
                amplitude,
                seed,
            } => {
                if *triangles > 20_000_000 {
                    return Err(SceneError::field(
                        format!("{field}.triangles"),
                        "more than 20 M triangles are not supported",
                    ));
                }
                if !(amplitude.is_finite() && amplitude.abs() < 1.0) {
                    return Err(SceneError::field(
                        format!("{field}.amplitude"),
                        "must be finite with |amplitude| < 1",
                    ));
                }
                TriangleMesh::bumpy(*triangles, *amplitude, *seed, &field)?
            }
            MeshSource::Face {
                expression,
                subdivisions,
            } => {
                if *expression as usize >= FACE_EXPRESSIONS.len() {
                    let names: Vec<String> = FACE_EXPRESSIONS
                        .iter()
                        .enumerate()
                        .map(|(i, n)| format!("{i} {n}"))
                        .collect();
                    return Err(SceneError::field(
                        format!("{field}.expression"),
                        format!(
                            "must be 0 to {}, found {expression}: {}",
                            FACE_EXPRESSIONS.len() - 1,
                            names.join(", ")
                        ),
                    ));
                }
                let max = crate::mesh::FACE_MAX_SUBDIVISIONS;
                if *subdivisions > max {
                    return Err(SceneError::field(
                        format!("{field}.subdivisions"),
                        format!(
                            "subdivisions above {max} ({} triangles) are not supported, found {subdivisions}",
                            20u64 << (2 * max)
                        ),
                    ));
                }
                TriangleMesh::face(*expression, *subdivisions, &field)?
            }
            MeshSource::Triangle { a, b, c } => {
                for (f, p) in [("a", a), ("b", b), ("c", c)] {
                    if !finite3(*p) {
                        return Err(SceneError::field(
                            format!("{field}.{f}"),
                            "corners must be finite",
                        ));
                    }
                }
                let v = |t: (f32, f32, f32)| Vec3::new(t.0, t.1, t.2);
                TriangleMesh::new(vec![v(*a), v(*b), v(*c)], vec![[0, 1, 2]], &field)?
            }
        };
        meshes.insert(name.clone(), mesh);
    }
    Ok(meshes)
}

/// The materials checked: index 0 the default, then the file's in name
/// order, with each name's index.
fn check_materials(file: &SceneFile) -> Result<(Vec<Material>, BTreeMap<String, u32>), SceneError> {
    let mut material_index = BTreeMap::new();
    let mut materials = vec![Material::default()];
    for (name, m) in &file.materials {
        for (f, c) in [("diffuse", m.diffuse), ("specular", m.specular)] {
            check_colour(&format!("materials.{name}.{f}"), c)?;
        }
        if !(m.shininess.is_finite() && m.shininess >= 0.0) {
            return Err(SceneError::field(
                format!("materials.{name}.shininess"),
                format!("{} must be finite and zero or positive", m.shininess),
            ));
        }
        material_index.insert(name.clone(), materials.len() as u32);
        materials.push(*m);
    }
    Ok((materials, material_index))
}

/// The scene stays within [`MAX_TRIANGLES`], counted before any object is
/// placed.
fn check_triangle_budget(
    file: &SceneFile,
    meshes: &BTreeMap<String, TriangleMesh>,
) -> Result<(), SceneError> {
    // Size before generating anything: 2000 instances of a 1.3 M-triangle
    // mesh would otherwise abort on allocation.
    let mut total = 0u64;
    let mut first_over = None;
    for (k, o) in file.objects.iter().enumerate() {
        total += meshes.get(&o.mesh).map_or(0, |m| m.indices.len() as u64);
        if total > MAX_TRIANGLES && first_over.is_none() {
            first_over = Some(k);
        }
    }
    if let Some(k) = first_over {
        return Err(SceneError::field(
            format!("objects[{k}]"),
            format!(
                "the objects up to here take the scene past {MAX_TRIANGLES} triangles; \
                 its {} objects have {total} triangles in all, about {:.1} GB to build \
                 ({BYTES_PER_TRIANGLE} bytes per triangle)",
                file.objects.len(),
                total as f64 * BYTES_PER_TRIANGLE as f64 / 1e9
            ),
        ));
    }
    Ok(())
}

/// Every object checked and placed in the display frame: its triangles
/// (object ids in file order), material index and importance.
fn place_objects(
    file: &SceneFile,
    meshes: &BTreeMap<String, TriangleMesh>,
    material_index: &BTreeMap<String, u32>,
) -> Result<Placed, SceneError> {
    let mut object_material = Vec::new();
    let mut object_importance = Vec::new();
    let mut triangles = Vec::new();
    for (k, o) in file.objects.iter().enumerate() {
        let field = |f: &str| format!("objects[{k}].{f}");
        let mesh = meshes.get(&o.mesh).ok_or_else(|| {
            SceneError::field(
                field("mesh"),
                format!("no mesh named `{}` in `meshes`", o.mesh),
            )
        })?;
        let material = match &o.material {
            None => 0,
            Some(m) => *material_index.get(m).ok_or_else(|| {
                SceneError::field(field("material"), format!("no material named `{m}`"))
            })?,
        };
        if !finite3(o.translate_mm) {
            return Err(SceneError::field(field("translate_mm"), "must be finite"));
        }
        if !finite3(o.rotate_deg) {
            return Err(SceneError::field(field("rotate_deg"), "must be finite"));
        }
        if !(o.scale_mm.is_finite() && o.scale_mm > 0.0) {
            return Err(SceneError::field(
                field("scale_mm"),
                "must be a positive number",
            ));
        }
        if !(o.importance.is_finite() && (0.0..=1.0).contains(&o.importance)) {
            return Err(SceneError::field(
                field("importance"),
                format!("{} must be from 0 to 1", o.importance),
            ));
        }
        object_material.push(material);
        object_importance.push(o.importance);
        let r = o.rotate_deg;
        let rot = Mat3::from_euler(
            EulerRot::ZYX,
            r.2.to_radians(),
            r.1.to_radians(),
            r.0.to_radians(),
        );
        let t = Vec3::new(o.translate_mm.0, o.translate_mm.1, o.translate_mm.2);
        // Every placed vertex must be finite: scaling (and rotating)
        // may overflow f32, and so may translating.
        let mut placed = Vec::with_capacity(mesh.positions.len());
        for p in &mesh.positions {
            let turned = rot * (*p * o.scale_mm);
            if !turned.is_finite() {
                return Err(SceneError::field(
                    field("scale_mm"),
                    "the scaled mesh overflows f32",
                ));
            }
            let moved = turned + t;
            if !moved.is_finite() {
                return Err(SceneError::field(
                    field("translate_mm"),
                    "the translated mesh overflows f32",
                ));
            }
            placed.push(moved);
        }
        for tri in &mesh.indices {
            let p = tri.map(|i| placed[i as usize]);
            let n = tri.map(|i| rot * mesh.normals[i as usize]);
            if n.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::field(
                    field("rotate_deg"),
                    "the rotated normals are not finite",
                ));
            }
            triangles.push(WorldTriangle {
                p,
                n,
                object: k as u32,
            });
        }
    }
    Ok(Placed {
        triangles,
        object_material,
        object_importance,
    })
}

/// The objects placed: their triangles (object ids in file order) and,
/// per object, its material index and importance.
struct Placed {
    triangles: Vec<WorldTriangle>,
    object_material: Vec<u32>,
    object_importance: Vec<f32>,
}

/// Every light's position or direction finite and intensity in range.
fn check_lights(file: &SceneFile) -> Result<(), SceneError> {
    for (i, l) in file.lights.iter().enumerate() {
        let (intensity, (f, ok)) = match l {
            Light::Headlight { intensity } => (intensity, ("intensity", true)),
            Light::Point {
                position_mm,
                intensity,
            } => (intensity, ("position_mm", finite3(*position_mm))),
            Light::Directional {
                direction,
                intensity,
            } => {
                let d = Vec3::new(direction.0, direction.1, direction.2);
                let usable = d.try_normalize().is_some();
                (intensity, ("direction", finite3(*direction) && usable))
            }
        };
        if !ok {
            return Err(SceneError::field(
                format!("lights[{i}].{f}"),
                "must be finite (a direction also non-zero)",
            ));
        }
        if !(intensity.is_finite() && (0.0..=MAX_COLOUR).contains(intensity)) {
            return Err(SceneError::field(
                format!("lights[{i}].intensity"),
                format!("{intensity} must be from 0 to {MAX_COLOUR}"),
            ));
        }
    }
    Ok(())
}

/// The refinement parameters zero or positive, in either form.
fn check_refinement(file: &SceneFile, sampling: &Sampling) -> Result<(), SceneError> {
    for (name, v) in [
        ("crease_deg", file.crease_deg),
        ("depth_jump", file.depth_jump),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::field(name, "must be zero or positive"));
            }
        }
    }
    if file.is_old_form() {
        return Ok(());
    }
    sampling.check_parameters("sampling")
}

/// An OBJ path from a scene file: absolute as it is, relative to the
/// scene file's folder otherwise.
fn obj_path(path: &str, base_dir: &Path) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base_dir.join(p)
    }
}
