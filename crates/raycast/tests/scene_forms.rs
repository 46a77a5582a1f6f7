//! The scene file's two forms: the new one (`sampling: Foveated(refine:
//! […])`, `passes: […]`) that the shipped scenes use, and the old one
//! (`effects: [FoveatedSampling, …]` with `crease_deg` and `depth_jump` at
//! the top level) that labs' files still use. Both load to the same scene;
//! a file may not mix them; errors name the file, line and field.

use std::path::{Path, PathBuf};

use raycast::scene::{PostPass, Refinement, Sampling};
use raycast::{Scene, SceneError, SceneFile};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/scenes")
}

fn shipped(name: &str) -> String {
    let path = scenes_dir().join(format!("{name}.ron"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn build(text: &str) -> Result<Scene, SceneError> {
    let file: SceneFile = ron::from_str(text).unwrap_or_else(|e| panic!("parses: {e}"));
    Scene::build(&file, &scenes_dir())
}

/// The error `gazecast` prints for `text`: the field located at its line.
fn located(text: &str) -> ron_config::ConfigError {
    match build(text) {
        Err(SceneError::Field { field, message }) => {
            ron_config::invalid_field(Path::new("s.ron"), text, &field, message)
        }
        other => panic!("expected a field error, got {:?}", other.map(|s| s.name)),
    }
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no line with {needle}"))
        + 1
}

/// Every field of two scenes that the file decides.
fn assert_same(a: &Scene, b: &Scene) {
    assert_eq!(a.name, b.name);
    assert_eq!(a.background, b.background);
    assert_eq!(a.background_rgb8, b.background_rgb8);
    assert_eq!(a.object_materials, b.object_materials);
    assert_eq!(a.object_importance, b.object_importance);
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.sampling, b.sampling);
    assert_eq!(a.passes, b.passes);
    assert_eq!(a.accel, b.accel);
    assert_eq!(a.is_moving(), b.is_moving());
    assert_eq!(
        format!("{:?}", a.triangles),
        format!("{:?}", b.triangles),
        "triangles"
    );
}

#[test]
fn every_shipped_scene_loads_in_the_new_form() {
    let mut names: Vec<String> = std::fs::read_dir(scenes_dir())
        .expect("config/scenes")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .map(|p| p.file_stem().expect("stem").to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(names.len() >= 6, "{names:?}");
    for name in &names {
        let text = shipped(name);
        let file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!file.is_old_form(), "{name} is in the old form");
        Scene::build(&file, &scenes_dir()).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn old_and_new_form_copies_give_the_same_scene() {
    let new = shipped("stress-dof");
    let sampling = "sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),\n    passes: [DepthOfField(pupil_mm: 6.0, focus: Gaze)],";
    assert!(new.contains(sampling), "stress-dof's sampling line changed");
    let old = new.replace(
        sampling,
        "effects: [FoveatedSampling, SilhouetteRefinement, CreaseRefinement, DepthRefinement,\n        DepthOfField(pupil_mm: 6.0, focus: Gaze)],",
    );
    let (a, b) = (build(&new).expect("new"), build(&old).expect("old"));
    assert_same(&a, &b);
    assert_eq!(a.sampling, Sampling::default());
    assert!(matches!(
        a.passes(),
        [PostPass::DepthOfField { pupil_mm, .. }] if *pupil_mm == 6.0
    ));

    // Refinement parameters: inside the sampling, or at the old top level.
    let faces = shipped("faces");
    let line = "sampling: Foveated(refine: [Silhouette]),\n    passes: [],";
    assert!(faces.contains(line), "faces' sampling line changed");
    let new = faces.replace(
        line,
        "sampling: Foveated(refine: [Depth(jump: 0.2), Crease(angle_deg: 12.5), Silhouette]),\n    passes: [PorOverlay(half_px: 20)],",
    );
    let old = faces.replace(
        line,
        "effects: [PorOverlay(half_px: 20), DepthRefinement, FoveatedSampling, CreaseRefinement, SilhouetteRefinement],\n    crease_deg: 12.5,\n    depth_jump: 0.2,",
    );
    let (a, b) = (build(&new).expect("new"), build(&old).expect("old"));
    assert_eq!(a.passes, b.passes);
    assert_eq!(a.name, b.name);
    for s in [&a.sampling, &b.sampling] {
        assert!(s.is_foveated() && s.silhouette());
        assert_eq!(s.crease_deg(), Some(12.5));
        assert_eq!(s.depth_jump(), Some(0.2));
    }

    // No sampling given in either form: the seed's, as before.
    let none = faces.replace(line, "");
    assert_eq!(build(&none).expect("builds").sampling, Sampling::default());
    // Without FoveatedSampling the old form renders every pixel.
    let full = faces.replace(line, "effects: [SilhouetteRefinement],");
    assert_eq!(build(&full).expect("builds").sampling, Sampling::Full);
    let full = faces.replace(line, "sampling: Full,");
    assert_eq!(build(&full).expect("builds").sampling, Sampling::Full);
    assert_eq!(
        build(&faces.replace(line, "sampling: Foveated(),"))
            .expect("builds")
            .sampling,
        Sampling::Foveated { refine: vec![] }
    );
    assert_eq!(
        build(&faces.replace(line, "sampling: Foveated(refine: [Crease()]),"))
            .expect("builds")
            .sampling
            .refinements(),
        [Refinement::Crease { angle_deg: 30.0 }]
    );
}

#[test]
fn a_file_that_mixes_the_forms_is_refused_naming_file_line_and_field() {
    let faces = shipped("faces");
    let line = "sampling: Foveated(refine: [Silhouette]),";
    for (old, field) in [
        ("effects: [FoveatedSampling],", "effects"),
        ("crease_deg: 20.0,", "crease_deg"),
        ("depth_jump: 0.1,", "depth_jump"),
    ] {
        let text = faces.replace(line, &format!("{line}\n    {old}"));
        let e = located(&text);
        assert_eq!(e.field(), Some(field), "{e}");
        assert_eq!(e.line(), line_of(&text, old), "{e}");
        let msg = e.to_string();
        assert!(
            msg.contains("s.ron:") && msg.contains("old form") && msg.contains("sampling"),
            "{msg}"
        );
    }
}

#[test]
fn bad_new_form_entries_name_file_line_and_field() {
    let faces = shipped("faces");
    let line = "sampling: Foveated(refine: [Silhouette]),\n    passes: [],";
    for (replacement, field, needle) in [
        (
            "sampling: Foveated(refine: [\n        Silhouette,\n        Crease(angle_deg: -1.0),\n    ]),",
            "sampling.refine[1].angle_deg",
            "angle_deg",
        ),
        (
            "sampling: Foveated(refine: [Silhouette,\n        Depth(jump: NaN)]),",
            "sampling.refine[1].jump",
            "jump",
        ),
        (
            "sampling: Foveated(refine: [Silhouette,\n        Silhouette]),",
            "sampling.refine[1]",
            "        Silhouette]",
        ),
        (
            "passes: [PorOverlay(),\n        PorOverlay(half_px: 3)],",
            "passes[1]",
            "half_px: 3",
        ),
        (
            "passes: [\n        DepthOfField(pupil_mm: -2.0)],",
            "passes[0].pupil_mm",
            "pupil_mm",
        ),
    ] {
        let text = faces.replace(line, replacement);
        let e = located(&text);
        assert_eq!(e.field(), Some(field), "{e}");
        assert_eq!(e.line(), line_of(&text, needle), "{field}: {e}");
    }
    // Unknown triggers, passes and fields are serde's errors, with their line.
    for bad in [
        "sampling: Foveated(refine: [Edges]),",
        "sampling: Foveated(refine: [Crease(angle: 3.0)]),",
        "passes: [FoveatedSampling],",
        "sampling: Partial,",
    ] {
        let text = faces.replace(line, bad);
        let e = ron_config::parse::<SceneFile>(Path::new("s.ron"), &text).expect_err(bad);
        assert_eq!(e.line(), line_of(&text, bad), "{bad}: {e}");
    }
}

/// The room (issue 34) fills the screen: on every shipped display, every
/// primary ray hits something (every 7th pixel of every 7th row, and the
/// frame's border in full).
#[test]
fn the_room_fills_every_displays_screen() {
    let file: SceneFile = ron::from_str(&shipped("room")).expect("room.ron parses");
    let scene = Scene::build(&file, &scenes_dir()).expect("room builds");
    assert!(
        scene.triangles.len() > 200_000,
        "{} triangles",
        scene.triangles.len()
    );
    let displays = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/displays");
    let mut seen = 0;
    for entry in std::fs::read_dir(&displays).expect("config/displays") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|x| x != "ron") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("display file");
        let display: foveation::Display =
            ron::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let g = display.geometry().expect("geometry");
        let cam = raycast::Camera::new(&g);
        let (w, h) = (g.width_px, g.height_px);
        let border = (0..w)
            .flat_map(|x| [(x, 0), (x, h - 1)])
            .chain((0..h).flat_map(|y| [(0, y), (w - 1, y)]));
        let inside = (0..h)
            .step_by(7)
            .flat_map(|y| (0..w).step_by(7).map(move |x| (x, y)));
        for (x, y) in border.chain(inside) {
            let ray = cam.pixel_ray(x, y);
            assert!(
                scene
                    .intersect(&ray, 0.0, raycast::ray::TriangleTest::Watertight)
                    .is_some(),
                "{}: pixel ({x}, {y}) misses",
                path.display()
            );
        }
        seen += 1;
    }
    assert!(seen >= 5, "{seen} display files");
}
