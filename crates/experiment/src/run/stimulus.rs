//! The search display of one trial as a scene file: the design's grid of
//! face meshes (`raycast`'s procedural `Face`, four expressions with one
//! topology and one silhouette) placed on the [`Layout`], and the target
//! preview (the target alone at the centre).

use std::collections::BTreeMap;

use raycast::scene::{Effect, Light, Material, MeshSource, Object};
use raycast::SceneFile;

use super::layout::{cell_mm, Layout, DEPTH_MM};
use crate::design::{Condition, Design};
use crate::Trial;

/// Icosphere subdivisions of each face mesh (20·4⁵ = 20 480 triangles).
pub const FACE_SUBDIVISIONS: u32 = 5;

/// The effects a condition's scene lists: the full-resolution control
/// none (the pipeline then renders every pixel), the hybrid method the
/// CSF mask, with silhouette refinement when edges are kept, and the
/// image method the CSF mask too (it blurs each pixel to the mask's level
/// there; without it the pipeline renders the full-resolution frame, and
/// an image condition was rendered as the control).
pub fn effects_for(condition: &Condition) -> Vec<Effect> {
    match condition.method.as_str() {
        "hybrid" => {
            let mut e = vec![Effect::FoveatedSampling];
            if condition.silhouette_edges {
                e.push(Effect::SilhouetteRefinement);
            }
            e
        }
        "image" => vec![Effect::FoveatedSampling],
        _ => Vec::new(),
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
            assert_eq!(
                e.contains(&Effect::FoveatedSampling),
                c.method == "hybrid" || c.method == "image"
            );
            assert_eq!(
                e.contains(&Effect::SilhouetteRefinement),
                c.silhouette_edges
            );
            let p = preview_scene(&d, t, &l);
            assert_eq!(p.objects.len(), 1);
            assert!(p.effects.as_ref().is_some_and(|e| e.is_empty()));
            assert_eq!(p.objects[0].mesh, mesh_name(t.target_mesh));
        }
    }
}
