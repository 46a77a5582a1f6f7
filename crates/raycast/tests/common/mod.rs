//! Shared by the raycast integration tests: the repository, the test display
//! and the shipped scenes (the last two from the dev-only `fixtures` crate).
#![allow(dead_code)]

use std::path::Path;

/// The dissertation's 17" display at a reduced pixel count (same size and
/// distance), so the tests stay fast; ppd drops, the maths is the same.
#[allow(unused_imports)]
pub use fixtures::display_17in as display;
/// A shipped scene from `config/scenes`.
#[allow(unused_imports)]
pub use fixtures::scene as load;

pub fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}
