//! The search display of one trial as a scene file: the design's grid of
//! face meshes (`raycast`'s procedural `Face`, four expressions with one
//! topology and one silhouette) placed on the [`Layout`], the target
//! preview (the target alone at the centre), and the full-resolution
//! reference (the target alone at the reference cell, which the runner
//! draws over every search frame when the design's reference is
//! `ReferenceDetail::Full`).

use std::collections::BTreeMap;

use raycast::scene::{Effect, Light, Material, MeshSource, Object};
use raycast::SceneFile;

use super::layout::{cell_mm, Layout, DEPTH_MM};
use crate::design::{Condition, Design, ReferenceDetail};
use crate::Trial;

/// Icosphere subdivisions of each face mesh (20·4⁵ = 20 480 triangles).
pub const FACE_SUBDIVISIONS: u32 = 5;

/// The effects a condition's scene lists: the full-resolution control
/// none (the pipeline then renders every pixel), the hybrid method the
/// CSF mask, with silhouette refinement when edges are kept, and every
/// other method the CSF mask too: the pipeline renders a scene without it
/// at full resolution whatever the method that follows the gaze (image,
/// layers, simplify, lod: `pipeline::Method::for_scene`), so without it
/// such a condition would be rendered as the control. (`ulod` follows
/// attention and runs whatever the scene lists.)
pub fn effects_for(condition: &Condition) -> Vec<Effect> {
    match condition.method.as_str() {
        "full" => Vec::new(),
        "hybrid" => {
            let mut e = vec![Effect::FoveatedSampling];
            if condition.silhouette_edges {
                e.push(Effect::SilhouetteRefinement);
            }
            e
        }
        _ => vec![Effect::FoveatedSampling],
    }
}

fn base_scene(name: String, design: &Design, effects: Vec<Effect>) -> SceneFile {
    let meshes: BTreeMap<String, MeshSource> = (0..design.stimulus.meshes)
        .map(|k| {
            (
                mesh_name(k),
                MeshSource::Face {
                    expression: k % 4,
                    subdivisions: FACE_SUBDIVISIONS,
                },
            )
        })
        .collect();
    let mut materials = BTreeMap::new();
    materials.insert(
        "skin".to_string(),
        Material {
            diffuse: (0.78, 0.64, 0.52),
            ..Material::default()
        },
    );
    SceneFile {
        name,
        background: (0.06, 0.06, 0.08),
        meshes,
        materials,
        objects: Vec::new(),
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(effects),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    }
}

pub(crate) fn mesh_name(k: u32) -> String {
    format!("face{k}")
}

fn object(mesh: u32, (x, y): (f64, f64), scale_mm: f64) -> Object {
    Object {
        mesh: mesh_name(mesh),
        material: Some("skin".into()),
        translate_mm: (x as f32, y as f32, -DEPTH_MM as f32),
        rotate_deg: (0.0, 0.0, 0.0),
        scale_mm: scale_mm as f32,
        importance: 1.0,
        motion: None,
    }
}

/// The trial's search display: every cell's mesh from the plan.
pub fn search_scene(design: &Design, trial: &Trial, layout: &Layout) -> SceneFile {
    let condition = &design.conditions[trial.condition];
    let mut f = base_scene(
        format!(
            "{} trial {} ({})",
            design.name,
            trial.index + 1,
            condition.name
        ),
        design,
        effects_for(condition),
    );
    for r in 0..layout.rows {
        for c in 0..layout.cols {
            let mesh = trial
                .cells
                .get((r * layout.cols + c) as usize)
                .copied()
                .unwrap_or(0);
            let at = cell_mm(r, c, layout.rows, layout.cols, layout.spacing_mm);
            f.objects.push(object(mesh, at, layout.scale_mm));
        }
    }
    f
}

/// The target preview: the target mesh alone at the screen's centre, at
/// full resolution.
pub fn preview_scene(design: &Design, trial: &Trial, layout: &Layout) -> SceneFile {
    let mut f = base_scene(
        format!("{} trial {} target", design.name, trial.index + 1),
        design,
        Vec::new(),
    );
    f.objects
        .push(object(trial.target_mesh, (0.0, 0.0), layout.scale_mm));
    f
}

/// The full-resolution reference of the trial, when the design's
/// reference is [`ReferenceDetail::Full`]: the target mesh alone at the
/// reference cell's place, without effects (rendered at full resolution,
/// then drawn over each search frame where it hit the mesh). For a
/// reference at the centre cell of the grid its objects are the preview's
/// (same mesh, same place), so its frame is the preview's. `None` without
/// a reference or with [`ReferenceDetail::AsCondition`] (the reference is
/// then one more object of the search display, rendered by the method).
pub fn reference_scene(design: &Design, trial: &Trial, layout: &Layout) -> Option<SceneFile> {
    let reference = design.stimulus.reference?;
    if reference.detail != ReferenceDetail::Full {
        return None;
    }
    let (r, c) = trial.reference_cell?;
    let mut f = base_scene(
        format!("{} trial {} reference", design.name, trial.index + 1),
        design,
        Vec::new(),
    );
    let at = cell_mm(r, c, layout.rows, layout.cols, layout.spacing_mm);
    f.objects
        .push(object(trial.target_mesh, at, layout.scale_mm));
    Some(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::run::test_support::{murphy, seed_display};

    #[test]
    fn scenes_place_the_plan_and_list_only_the_condition_effects() {
        let d = murphy();
        let l = Layout::new(&d, &seed_display());
        let trials = crate::plan(&d, 0).expect("plan");
        for t in &trials[..11] {
            let s = search_scene(&d, t, &l);
            assert_eq!(s.objects.len(), 25);
            let at = (t.target_cell.0 * 5 + t.target_cell.1) as usize;
            assert_eq!(s.objects[at].mesh, mesh_name(t.target_mesh));
            let c = &d.conditions[t.condition];
            let e = effects_for(c);
            assert_eq!(s.effects.as_ref(), Some(&e));
            assert_eq!(e.contains(&Effect::FoveatedSampling), c.method != "full");
            assert_eq!(
                e.contains(&Effect::SilhouetteRefinement),
                c.silhouette_edges
            );
            let p = preview_scene(&d, t, &l);
            assert_eq!(p.objects.len(), 1);
            assert!(p.effects.as_ref().is_some_and(|e| e.is_empty()));
            assert_eq!(p.objects[0].mesh, mesh_name(t.target_mesh));
            // The reference at the centre: the target mesh there in the
            // search display, and its full-resolution scene is the
            // preview's objects (so the runner reuses the preview frame).
            assert_eq!(t.reference_cell, Some((2, 2)));
            assert_eq!(s.objects[12].mesh, mesh_name(t.target_mesh));
            let r = reference_scene(&d, t, &l).expect("a Full reference");
            assert_eq!(r.objects, p.objects);
            assert!(r.effects.as_ref().is_some_and(|e| e.is_empty()));
        }
    }

    /// A reference at another cell stands at that cell's place; with
    /// `AsCondition` or without a reference there is no separate scene.
    #[test]
    fn the_reference_scene_follows_the_design() {
        use crate::design::{Reference, ReferenceCell};
        let mut d = murphy();
        d.stimulus.reference = Some(Reference {
            at: ReferenceCell::Cell(0, 4),
            detail: ReferenceDetail::Full,
        });
        let l = Layout::new(&d, &seed_display());
        let t = &crate::plan(&d, 0).expect("plan")[0];
        assert_eq!(t.reference_cell, Some((0, 4)));
        let r = reference_scene(&d, t, &l).expect("a Full reference");
        let s = search_scene(&d, t, &l);
        assert_eq!(r.objects.len(), 1);
        assert_eq!(
            r.objects[0], s.objects[4],
            "the search display's cell (0, 4)"
        );
        assert_ne!(r.objects, preview_scene(&d, t, &l).objects);
        d.stimulus.reference = Some(Reference {
            at: ReferenceCell::Centre,
            detail: ReferenceDetail::AsCondition,
        });
        let t = &crate::plan(&d, 0).expect("plan")[0];
        assert_eq!(t.reference_cell, Some((2, 2)));
        assert!(reference_scene(&d, t, &l).is_none());
        d.stimulus.reference = None;
        let t = &crate::plan(&d, 0).expect("plan")[0];
        assert_eq!(t.reference_cell, None);
        assert!(reference_scene(&d, t, &l).is_none());
    }
}
