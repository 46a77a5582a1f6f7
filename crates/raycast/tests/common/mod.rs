//! Shared by the raycast integration tests: the repository, the test display
//! and the shipped scenes.
#![allow(dead_code)]

use std::path::Path;

use foveation::Display;
use raycast::{Scene, SceneFile};

pub fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// The dissertation's 17" display at a reduced pixel count (same size and
/// distance), so the tests stay fast; ppd drops, the maths is the same.
pub fn display(w: u32, h: u32) -> Display {
    Display::seed_17in(w, h)
}

/// A shipped scene from `config/scenes`.
pub fn load(name: &str) -> Scene {
    let path = repo().join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}
